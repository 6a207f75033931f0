"""The accuracy race (issue 19): CPU time per simulated second that each code needs to
reach a given error at the end of the run, on the scene kinds of `scenes.py`, measured
side by side in one run.

    benches/peers/setup.sh                      # once: the venv with MuJoCo, Exudyn, Pinocchio
    cargo build --release -p mbdc
    benches/peers/.venv/bin/python benches/peers/race.py [--scenes NAME,...] [--interp]

Writes `target/race/race.md` (the table) and `race.json` (every point). For each code and
method, the cost of an error level is read off its work–precision points by log–log
interpolation between the two runs that bracket it (`—` when no run reached it). Errors:
the peers' against the independent reference of `reference.py`; mbdc's are the sweep's
against its own reference, and one mbdc run is also checked against the independent
reference (the `check` column: both errors of that run, which must agree).
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import mbdc_side  # noqa: E402
import peer_exudyn  # noqa: E402
import peer_mujoco  # noqa: E402
import reference  # noqa: E402
import scenes  # noqa: E402

LEVELS = [1e-3, 1e-6]
# a peer's series stops refining once an error is below this or a run costs more than this
FLOOR, BUDGET_S = 1e-10, 20.0


def cost_at(points, level):
    """CPU s per simulated s to reach `level`, interpolated log–log between the cheapest
    run at or below it and the dearer run above it; None if no run reached it."""
    pts = sorted(points, key=lambda p: p[1])  # by cost
    best = None
    for i, (_h, cost, err) in enumerate(pts):
        if err <= level and err > 0:
            if i == 0:
                return cost
            ch, eh = pts[i - 1][1], pts[i - 1][2]
            if eh > level > 0 and eh > err:
                s = (math.log(level) - math.log(eh)) / (math.log(err) - math.log(eh))
                best = math.exp(math.log(ch) + s * (math.log(cost) - math.log(ch)))
            else:
                best = cost
            return best
    return None


def timed(f, *args):
    """Best of up to 3 repetitions while a repetition takes under 0.2 s."""
    cpu, out = f(*args)
    reps = 1
    while cpu < 0.2 and reps < 3:
        c, _ = f(*args)
        cpu = min(cpu, c)
        reps += 1
    return cpu, out


def peer_series(scene, ref, run, method, h0):
    pts = []
    h = h0
    while True:
        cpu, poses = timed(run, scene, h, method)
        err = reference.error(scene, poses, ref)
        pts.append((h, cpu / scene.duration, err))
        print(f"    {method:>12} h={h:.3e}: {cpu / scene.duration:.3e} s/s, error {err:.3e}",
              flush=True)
        if err < FLOOR or cpu > BUDGET_S or not math.isfinite(err) or h < 1e-6:
            break
        h /= 2.0
    return pts


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="", help="comma-separated scene names (default all)")
    ap.add_argument("--mbdc", default=None, help="the mbdc binary (default target/release/mbdc)")
    ap.add_argument("--out", default=None, help="output folder (default target/race)")
    ap.add_argument("--interp", action="store_true", help="mbdc sweep --interp")
    a = ap.parse_args()
    root = HERE.parent.parent
    mbdc = Path(a.mbdc) if a.mbdc else root / "target" / "release" / "mbdc"
    out = Path(a.out) if a.out else root / "target" / "race"
    out.mkdir(parents=True, exist_ok=True)
    chosen = [s for s in a.scenes.split(",") if s]
    results = []
    for scene in scenes.all_scenes():
        if chosen and scene.name not in chosen:
            continue
        print(f"{scene.name}: reference (Pinocchio ABA + DOP853)", flush=True)
        t0 = time.time()
        ref, ref_err = reference.reference(scene)
        print(f"  reference's own error {ref_err:.1e} ({time.time() - t0:.0f} s)", flush=True)
        entries = {}
        h0 = scene.duration / 500.0
        for integ in peer_mujoco.INTEGRATORS:
            entries[f"MuJoCo {integ}"] = peer_series(scene, ref, peer_mujoco.run, integ, h0)
        if peer_exudyn.supports(scene):
            for solver in peer_exudyn.SOLVERS:
                entries[f"Exudyn {solver}"] = peer_series(scene, ref, peer_exudyn.run, solver, h0)
        print("  mbdc sweep", flush=True)
        sw = mbdc_side.sweep(mbdc, root, scene, out / f"sweep_{scene.name}", a.interp)
        mine = mbdc_side.series(sw, scene)
        for method, pts in mine.items():
            entries[f"mbdc {method}"] = pts
        # the check: the finest run of mbdc's method with the smallest error, against the
        # independent reference
        best_m, best = min(((m, min(p, key=lambda x: x[2])) for m, p in mine.items()),
                           key=lambda x: x[1][2])
        poses = mbdc_side.final_poses(mbdc, root, scene, best_m, best[0],
                                      out / f"check_{scene.name}")
        check = (best_m, best[0], best[2], reference.error(scene, poses, ref))
        print(f"  check: mbdc {best_m} h={best[0]:.3e}: sweep error {best[2]:.3e}, against the "
              f"independent reference {check[3]:.3e}", flush=True)
        row = {"scene": scene.name, "duration_s": scene.duration, "measure": scene.measure,
               "reference_error": ref_err, "check": check, "series": entries, "levels": {}}
        for level in LEVELS:
            costs = {k: cost_at(v, level) for k, v in entries.items()}
            m = {k: c for k, c in costs.items() if c is not None and k.startswith("mbdc")}
            p = {k: c for k, c in costs.items() if c is not None and not k.startswith("mbdc")}
            bm = min(m.items(), key=lambda x: x[1]) if m else None
            bp = min(p.items(), key=lambda x: x[1]) if p else None
            row["levels"][str(level)] = {"costs": costs, "mbdc_best": bm, "peer_best": bp}
        results.append(row)
        (out / "race.json").write_text(json.dumps(results, indent=1))
    lines = ["| scene | measure | level | mbdc best (ms per simulated s) | best peer | mbdc / peer | check (sweep error / independent) |",
             "|---|---|---|---|---|---|---|"]
    for r in results:
        for level in LEVELS:
            lv = r["levels"][str(level)]
            bm, bp = lv["mbdc_best"], lv["peer_best"]
            fm = f"{bm[1] * 1e3:.3g} ({bm[0][5:]})" if bm else "—"
            fp = f"{bp[1] * 1e3:.3g} ({bp[0]})" if bp else "—"
            ratio = f"{bm[1] / bp[1]:.2f}" if bm and bp else "—"
            c = r["check"]
            lines.append(f"| {r['scene']} | {r['measure']} | {level:g} | {fm} | {fp} | {ratio} | "
                         f"{c[2]:.2e} / {c[3]:.2e} |")
    table = "\n".join(lines)
    (out / "race.md").write_text(table + "\n")
    print(table)


if __name__ == "__main__":
    main()
