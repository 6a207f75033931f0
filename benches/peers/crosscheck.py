"""Correctness checks of the race's closed-loop scenes, outside the timed race: the
independent reference's own error, its agreement with mbdc's `dop853` at tolerance 1e-12
(an interpreted `mbdc run` of a copy of the model asking for `method dop853 { tolerance
1e-12 }`), and one run of each peer at a fixed step, with every code's loop closure.

    benches/peers/.venv/bin/python benches/peers/crosscheck.py [--scenes NAME,...]
        [--mbdc BIN] [--duration S] [--step H] [--out DIR]

The mbdc binary and the output folder are found as by `race.py` (`--mbdc`, `$MBDC_BIN`,
`<target>/release/mbdc`; `<target>/race/crosscheck`).
"""

import argparse
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

# mbdc's tolerance for the agreement check, and the dense output interval of that run (also
# its largest internal step)
TOLERANCE, OUTPUT_STEP = 1e-12, 0.01


def mbdc_dop853(mbdc, root, scene, out, tolerance=TOLERANCE):
    """Final poses and loop closure of mbdc `dop853` at `tolerance` (interpreted), on a copy
    of the scene's model written into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    model = out / Path(scene.model).name
    model.write_text(mbdc_side.with_method((root / scene.model).read_text(),
                                           f"dop853 {{ tolerance {tolerance:.0e} }}"))
    poses = mbdc_side.final_poses(mbdc, root, scene, "dop853", OUTPUT_STEP, out / "run",
                                  model=model)
    return poses, mbdc_side.final_closure(out / "run")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="four_bar_planar,slider_crank_race",
                    help="comma-separated closed-loop scenes (default both)")
    ap.add_argument("--mbdc", default=os.environ.get("MBDC_BIN"),
                    help="the mbdc binary (default $MBDC_BIN, else <target>/release/mbdc)")
    ap.add_argument("--duration", type=float, default=None,
                    help="simulate this long (s) instead of each scene's duration")
    ap.add_argument("--step", type=float, default=1e-4,
                    help="the peers' fixed step, s (default 1e-4)")
    ap.add_argument("--out", default=None, help="output folder (default <target>/race/crosscheck)")
    a = ap.parse_args()
    root = HERE.parent.parent
    target = Path(os.environ.get("CARGO_TARGET_DIR") or root / "target")
    mbdc = (Path(a.mbdc) if a.mbdc else target / "release" / "mbdc").resolve()
    out = (Path(a.out) if a.out else target / "race" / "crosscheck").resolve()
    chosen = [s for s in a.scenes.split(",") if s]
    for scene in scenes.all_scenes():
        if scene.name not in chosen:
            continue
        if not isinstance(scene, scenes.LoopScene):
            sys.exit(f"{scene.name} is not a closed-loop scene")
        if a.duration:
            scene.duration = a.duration
        print(f"{scene.name} ({scene.duration:g} s)", flush=True)
        t0 = time.time()
        ref, ref_err = reference.reference(scene)
        print(f"  reference (coordinate partitioning + DOP853 at {reference.TIGHT:g}): own error "
              f"{ref_err:.1e} m ({time.time() - t0:.0f} s)", flush=True)
        poses, closure = mbdc_dop853(mbdc, root, scene, out / scene.name)
        print(f"  mbdc dop853, tolerance {TOLERANCE:g}: {reference.error(scene, poses, ref):.2e} m "
              f"from the reference, closure at the end {closure:.1e} m", flush=True)
        for method in peer_mujoco.methods(scene, race=False):
            cpu, poses, closure = peer_mujoco.run(scene, a.step, method)
            print(f"  MuJoCo {method} at h = {a.step:g} s: {reference.error(scene, poses, ref):.2e} m, "
                  f"closure (largest sampled) {closure:.1e} m, {cpu:.2f} s CPU", flush=True)
        for solver in dict.fromkeys(peer_exudyn.LOOP_SOLVERS + ["TrapezoidalIndex2"]):
            cpu, poses, closure = peer_exudyn.run(scene, a.step, solver)
            print(f"  Exudyn {solver} at h = {a.step:g} s: {reference.error(scene, poses, ref):.2e} m, "
                  f"closure at the end {closure:.1e} m, {cpu:.2f} s CPU", flush=True)
        for solver in peer_exudyn.SOLVERS:
            print(f"  Exudyn {solver}: {peer_exudyn.loop_refusal(scene, solver)}", flush=True)


if __name__ == "__main__":
    main()
