"""The accuracy race (issue 19): CPU time per simulated second that each code needs to
reach a given error at the end of the run, on the scene kinds of `scenes.py`, measured
side by side in one run.

    benches/peers/setup.sh                      # once: the venv with MuJoCo, Exudyn, Pinocchio
    cargo build --release -p mbdc
    benches/peers/.venv/bin/python benches/peers/race.py [--scenes NAME,...] [--levels N]
        [--skip-methods NAME,...] [--reference-method NAME] [--tolerances T,...] [--interp]
        [--duration S]

The mbdc binary is `--mbdc`, else `$MBDC_BIN`, else `release/mbdc` of cargo's target folder
(`$CARGO_TARGET_DIR` when set, else the repository's `target/`); the output folder is
`--out`, else `race/` of that same target folder.

Writes `<target>/race/race.md` (the table) and `race.json` (every point). For each code and
method, the cost of an error level is read off its work–precision points by log–log
interpolation between the two runs that bracket it (`—` when no run reached it). Errors:
the peers' against the independent reference of `reference.py`; mbdc's are the sweep's
against its own reference, and one mbdc run is also checked against the independent
reference (the `check` column: both errors of that run, which must agree). The sweep runs
the error-controlled `dopri5` and `dop853` at one tolerance over their steps (`mbdc dopri5
(step series)`); their work–precision series proper vary the tolerance (`--tolerances`,
`mbdc dopri5 (tolerance series)`, `mbdc dop853 (tolerance series)`, errors against the
independent reference; see `mbdc_side.py`).

On the closed loops (`four_bar_planar`, `slider_crank_race`) every run also reports its loop
closure, the largest joint violation (m): MuJoCo's over ~200 states sampled over the run,
Exudyn's at the end, mbdc's sweep runs over their output frames, mbdc's tolerance series and
check run at the end. `race.md` then has a closure table, and the scene notes say where a
peer does not apply (Exudyn's explicit solvers refuse the loop). `crosscheck.py` checks the
loops' models and reference outside the race (the reference against mbdc `dop853` at
tolerance 1e-12, one run of each peer).
"""

import argparse
import json
import math
import os
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
    """Best of up to 3 repetitions while a repetition takes under 0.2 s: (CPU s, and the
    rest of the first run's result: final poses, loop closure)."""
    cpu, *out = f(*args)
    reps = 1
    while cpu < 0.2 and reps < 3:
        c, *_ = f(*args)
        cpu = min(cpu, c)
        reps += 1
    return cpu, out


def peer_series(scene, ref, run, method, h0):
    """(step, CPU s per simulated s, error) of a peer's method, halving the step from h0,
    and each run's loop closure (m). A coarse start may blow up (a non-finite error): the
    series goes on halving until the first finite error, and stops at a non-finite one
    after that. It stops at an error below FLOOR, a run dearer than BUDGET_S or a step
    below 1 µs."""
    pts, closures = [], []
    h = h0
    while True:
        cpu, (poses, closure) = timed(run, scene, h, method)
        err = reference.error(scene, poses, ref)
        pts.append((h, cpu / scene.duration, err))
        closures.append(closure)
        loop = f", closure {closure:.1e}" if isinstance(scene, scenes.LoopScene) else ""
        print(f"    {method:>12} h={h:.3e}: {cpu / scene.duration:.3e} s/s, error {err:.3e}"
              + loop, flush=True)
        blown_up_after_finite = not math.isfinite(err) and any(
            math.isfinite(p[2]) for p in pts)
        if err < FLOOR or cpu > BUDGET_S or blown_up_after_finite or h < 1e-6:
            break
        h /= 2.0
    return pts, closures


def _ms(cost):
    return f"{cost * 1e3:.3g}" if cost is not None else "—"


def bounded(points, level):
    """Whether a series' cheapest run is already at or below `level`: its cost there is only
    an upper bound (a coarser run might have reached it too)."""
    cheapest = min(points, key=lambda p: p[1], default=None)
    return cheapest is not None and 0 < cheapest[2] <= level


def write_tables(results, out):
    """Write `race.md` from the results so far and return its text: the best of mbdc
    against the best peer, mbdc's best against each peer code's best, and every code and
    method's cost at each level (ms of CPU per simulated s) with the smallest error it
    reached. `≤` marks a cost that is an upper bound (see `bounded`); a ratio is then
    marked `≤` or `≥`, or `?` when both costs are bounds."""

    def cost(r, name, level):
        c = r["levels"][str(level)]["costs"][name]
        if c is None:
            return "—"
        return ("≤" if bounded(r["series"][name], level) else "") + _ms(c)

    def ratio(r, mine, theirs, level):
        bm, bp = bounded(r["series"][mine[0]], level), bounded(r["series"][theirs[0]], level)
        mark = "?" if bm and bp else "≤" if bm else "≥" if bp else ""
        return f"{mark}{mine[1] / theirs[1]:.2f}"

    runs = sorted({r.get("run", "") for r in results})
    lines = ["Run: " + ", ".join(f"`race.py {a}`" for a in runs), ""]
    for r in results:
        lines.append(f"- {r['scene']} ({r['duration_s']:g} s): reference "
                     f"{r.get('reference', 'Pinocchio ABA + DOP853')}, its own error "
                     f"{r['reference_error']:.1e}")
        lines += [f"  - {note}" for note in r.get("notes", [])]
    lines += ["", "| scene | measure | level | mbdc best (ms per simulated s) | best peer | mbdc / peer | check (sweep error / independent) |",
             "|---|---|---|---|---|---|---|"]
    for r in results:
        for level in LEVELS:
            lv = r["levels"][str(level)]
            bm, bp = lv["mbdc_best"], lv["peer_best"]
            fm = f"{cost(r, bm[0], level)} ({bm[0][5:]})" if bm else "—"
            fp = f"{cost(r, bp[0], level)} ({bp[0]})" if bp else "—"
            rat = ratio(r, bm, bp, level) if bm and bp else "—"
            c = r["check"]
            lines.append(f"| {r['scene']} | {r['measure']} | {level:g} | {fm} | {fp} | {rat} | "
                         f"{c[2]:.2e} / {c[3]:.2e} |")
    codes = sorted({k.split()[0] for r in results for k in r["series"]} - {"mbdc"})
    lines += ["", "mbdc's best against each peer code's best (CPU time ratio; < 1: mbdc is faster):",
              "", "| scene | level | " + " | ".join(f"mbdc / {c}" for c in codes) + " |",
              "|---|---|" + "---|" * len(codes)]
    for r in results:
        for level in LEVELS:
            costs = r["levels"][str(level)]["costs"]
            bm = r["levels"][str(level)]["mbdc_best"]
            cells = []
            for code in codes:
                cc = [(k, c) for k, c in costs.items() if k.split()[0] == code and c is not None]
                if bm and cc:
                    cells.append(ratio(r, bm, min(cc, key=lambda x: x[1]), level))
                else:
                    cells.append("—" if any(k.split()[0] == code for k in costs) else "n/a")
            lines.append(f"| {r['scene']} | {level:g} | " + " | ".join(cells) + " |")
    lines += ["", "Every code and method (ms of CPU per simulated s; `—`: not reached):", "",
              "| scene | code and method | " + " | ".join(f"to {lv:g}" for lv in LEVELS)
              + " | smallest error reached (its cost, ms/s) |",
              "|---|---|" + "---|" * len(LEVELS) + "---|"]
    for r in results:
        for name, pts in r["series"].items():
            cells = [cost(r, name, lv) for lv in LEVELS]
            ok = [p for p in pts if p[2] > 0 and math.isfinite(p[2])]
            low = min(ok, key=lambda p: p[2]) if ok else None
            least = f"{low[2]:.2e} ({_ms(low[1])})" if low else "—"
            lines.append(f"| {r['scene']} | {name} | " + " | ".join(cells) + f" | {least} |")
    loops = [r for r in results if r.get("closure")]
    if loops:
        lines += ["", "Loop closure, the largest joint violation (m; see the module doc for where "
                  "each code measures it): at each series' most accurate run, and the least and "
                  "largest over the series' runs:", "",
                  "| scene | code and method | at the most accurate run (its error) | least | largest |",
                  "|---|---|---|---|---|"]
        for r in loops:
            for name, cls in r["closure"].items():
                pts = r["series"][name]
                ok = [(p[2], c) for p, c in zip(pts, cls)
                      if c is not None and math.isfinite(p[2]) and math.isfinite(c)]
                if not ok:
                    lines.append(f"| {r['scene']} | {name} | — | — | — |")
                    continue
                err, c = min(ok)
                vals = [c for _, c in ok]
                lines.append(f"| {r['scene']} | {name} | {c:.1e} ({err:.1e}) | {min(vals):.1e} "
                             f"| {max(vals):.1e} |")
            c = r["check"]
            if len(c) > 4 and c[4] is not None:
                lines.append(f"| {r['scene']} | mbdc {c[0]} (check run, h = {c[1]:.2e}, at the end) "
                             f"| {c[4]:.1e} ({c[3]:.1e}) | | |")
    table = "\n".join(lines)
    (out / "race.md").write_text(table + "\n")
    return table


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="", help="comma-separated scene names (default all)")
    ap.add_argument("--mbdc", default=os.environ.get("MBDC_BIN"),
                    help="the mbdc binary (default $MBDC_BIN, else <target>/release/mbdc)")
    ap.add_argument("--out", default=None, help="output folder (default <target>/race)")
    ap.add_argument("--interp", action="store_true", help="mbdc sweep --interp")
    ap.add_argument("--levels", type=int, default=7,
                    help="mbdc sweep --levels: halvings of the step from the sweep's largest (default 7)")
    ap.add_argument("--reference-method", default=None,
                    help="mbdc sweep --reference-method (default: the sweep's choice)")
    ap.add_argument("--skip-methods", default="",
                    help="mbdc methods the sweep leaves out, comma-separated (default none)")
    ap.add_argument("--duration", type=float, default=None,
                    help="simulate this long (s) instead of each scene's duration: quick checks "
                         "of the harness, not race results")
    ap.add_argument("--tables-only", action="store_true",
                    help="only rewrite race.md from the output folder's race.json")
    ap.add_argument("--tolerances", default="1e-3,1e-4,1e-5,1e-6,1e-7,1e-8,1e-9,1e-10,1e-11,1e-12",
                    help="dopri5's and dop853's tolerance series, comma-separated ('' to leave it out)")
    a = ap.parse_args()
    root = HERE.parent.parent
    target = Path(os.environ.get("CARGO_TARGET_DIR") or root / "target")
    mbdc = (Path(a.mbdc) if a.mbdc else target / "release" / "mbdc").resolve()
    out = (Path(a.out) if a.out else target / "race").resolve()
    out.mkdir(parents=True, exist_ok=True)
    if a.tables_only:
        print(write_tables(json.loads((out / "race.json").read_text()), out))
        return
    if not mbdc.is_file():
        sys.exit(f"no mbdc binary at {mbdc}: `cargo build --release -p mbdc`, or --mbdc / MBDC_BIN")
    chosen = [s for s in a.scenes.split(",") if s]
    results = []
    for scene in scenes.all_scenes():
        if chosen and scene.name not in chosen:
            continue
        if a.duration:
            scene.duration = a.duration
        loop = isinstance(scene, scenes.LoopScene)
        ref_kind = ("coordinate partitioning in planar natural coordinates + DOP853" if loop
                    else "Pinocchio ABA + DOP853")
        print(f"{scene.name}: reference ({ref_kind})", flush=True)
        t0 = time.time()
        ref, ref_err = reference.reference(scene)
        print(f"  reference's own error {ref_err:.1e} ({time.time() - t0:.0f} s)", flush=True)
        entries, closures, notes = {}, {}, []
        # coarse enough that each series' cheapest run misses 1e-3 (else its cost there is
        # only a bound, marked ≤)
        h0 = scene.duration / 50.0
        for integ in peer_mujoco.methods(scene):
            name = f"MuJoCo {integ}"
            entries[name], closures[name] = peer_series(scene, ref, peer_mujoco.run, integ, h0)
        if loop:
            for setting in sorted({m.split("(")[1].rstrip(")")
                                   for m in peer_mujoco.methods(scene)}):
                notes.append(f"MuJoCo ({setting}): the loop closed by "
                             f"`<connect {peer_mujoco.EQUALITY[setting]}/>`")
            for solver in peer_exudyn.SOLVERS:
                why = peer_exudyn.loop_refusal(scene, solver)
                notes.append(f"Exudyn {solver}: does not apply (explicit solvers refuse the loop's "
                             f"constraints: \"{why}\")" if why else
                             f"Exudyn {solver}: ran the loop (not raced)")
            notes.append("Exudyn " + ", ".join(peer_exudyn.LOOP_SOLVERS) + ": implicit, on "
                         "ObjectRigidBody2D bodies with 2-D revolute/prismatic joints")
        if peer_exudyn.supports(scene):
            for solver in peer_exudyn.solvers(scene):
                name = f"Exudyn {solver}"
                entries[name], closures[name] = peer_series(scene, ref, peer_exudyn.run,
                                                            solver, h0)
        print("  mbdc sweep", flush=True)
        skip = [m for m in a.skip_methods.split(",") if m]
        sw = mbdc_side.sweep(mbdc, root, scene, out / f"sweep_{scene.name}", a.interp,
                             levels=a.levels, skip=skip,
                             reference_method=a.reference_method)
        mine, mine_closures = mbdc_side.series(sw, scene)
        controlled = [m for m in ("dopri5", "dop853") if m not in skip]
        for method, pts in mine.items():
            # the sweep runs an error-controlled method at one tolerance (the scene's, else
            # 1e-9) over its steps
            name = f"mbdc {method}" + (" (step series)" if method in controlled else "")
            entries[name], closures[name] = pts, mine_closures[method]
        tols = [float(t) for t in a.tolerances.split(",") if t]
        for method in controlled if tols else []:
            print(f"  mbdc {method}, tolerance series", flush=True)
            name = f"mbdc {method} (tolerance series)"
            entries[name], closures[name] = mbdc_side.tolerance_series(
                mbdc, root, scene, out / f"{method}_{scene.name}", ref, reference.error, tols,
                method)
        # the check: the finest run of mbdc's method with the smallest error, against the
        # independent reference
        best_m, best = min(((m, min(p, key=lambda x: x[2])) for m, p in mine.items()),
                           key=lambda x: x[1][2])
        poses = mbdc_side.final_poses(mbdc, root, scene, best_m, best[0],
                                      out / f"check_{scene.name}")
        check = (best_m, best[0], best[2], reference.error(scene, poses, ref),
                 mbdc_side.final_closure(out / f"check_{scene.name}") if loop else None)
        print(f"  check: mbdc {best_m} h={best[0]:.3e}: sweep error {best[2]:.3e}, against the "
              f"independent reference {check[3]:.3e}"
              + (f", closure at the end {check[4]:.1e}" if loop else ""), flush=True)
        row = {"scene": scene.name, "run": " ".join(sys.argv[1:]),
               "duration_s": scene.duration, "measure": scene.measure,
               "reference": ref_kind, "reference_error": ref_err, "notes": notes,
               "check": check, "series": entries, "closure": closures if loop else {},
               "levels": {}}
        for level in LEVELS:
            costs = {k: cost_at(v, level) for k, v in entries.items()}
            m = {k: c for k, c in costs.items() if c is not None and k.startswith("mbdc")}
            p = {k: c for k, c in costs.items() if c is not None and not k.startswith("mbdc")}
            bm = min(m.items(), key=lambda x: x[1]) if m else None
            bp = min(p.items(), key=lambda x: x[1]) if p else None
            row["levels"][str(level)] = {"costs": costs, "mbdc_best": bm, "peer_best": bp}
        results.append(row)
        (out / "race.json").write_text(json.dumps(results, indent=1))
        write_tables(results, out)
    print(write_tables(results, out))

if __name__ == "__main__":
    main()
