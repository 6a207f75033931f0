"""mbdc's side of the race: `mbdc sweep` on the scene's model (the compiled program by
default, best-of-k CPU time per run, error against the sweep's own reference), and one
`mbdc run` whose final state is checked against the race's independent reference, so that
the sweep's errors and the peers' errors measure the same thing.

`dopri5` and `dop853` are error-controlled: a sweep's step is only their largest internal
step and output interval, and their error follows their tolerance (the scene's, else 1e-9).
Their work–precision series (`tolerance_series`) therefore vary the tolerance instead: per
tolerance, a copy of the model whose `simulate` block asks for `method dopri5 { tolerance
TOL }` (or `dop853`), timed by a
one-run `mbdc sweep` (same CPU accounting as every other mbdc run) at the sweep's largest
default step (20 per shortest period: the largest internal step and the output interval; a
larger one is refused by the explicit methods' stability check), its error measured like
the peers' (an interpreted run against the independent reference).
"""

import csv
import json
import math
import re
import subprocess
from pathlib import Path

import numpy as np

# mbdc's methods, as `MethodSpec::NAMES` (runtime/src/contract/scene.rs) lists them: what a
# sweep asked to leave some out (`skip`) runs instead of its default choice
METHODS = ["staggered", "baumgarte", "penalty", "coordinate_partitioning", "implicit_trapezoid",
           "natural_partitioning", "rk4", "dopri5", "dop853", "state_time"]


def _sets(scene):
    out = []
    for s in scene.overrides:
        out += ["--set", s]
    return out


def sweep(mbdc, root, scene, out, interp=False, levels=7, methods=None, model=None, skip=(),
          reference_method=None):
    """Run `mbdc sweep` into `out` (on `model`, default the scene's) with `methods`, else
    every method that applies, else (when `skip` names some) every method of `METHODS` but
    those; its numerical reference by `reference_method` (default: the sweep's choice);
    returns its sweep.json."""
    if not methods and skip:
        methods = [m for m in METHODS if m not in skip]
    model = model or root / scene.model
    cmd = [str(mbdc), "sweep", str(model), *_sets(scene),
           "--error", scene.measure, "--duration", repr(scene.duration),
           "--levels", str(levels), "-o", str(out), "-q"]
    if interp:
        cmd.append("--interp")
    if reference_method:
        cmd += ["--reference-method", reference_method]
    if methods:
        cmd += ["--methods", ",".join(methods)]
    subprocess.run(cmd, check=True, cwd=root)
    return json.loads((Path(out) / "sweep.json").read_text())


def series(result, scene):
    """Per method, its (step, CPU seconds per simulated second, error) points, and per
    method the runs' loop closures (the largest joint violation over the run, sweep.json's
    `max_violation`, m)."""
    key = "pos_err_final_m" if scene.measure == "pos-final" else "rot_err_final_rad"
    out, closures = {}, {}
    for run in result["runs"]:
        if run.get("status") != "ok" or run.get(key) is None:
            continue
        out.setdefault(run["method"], []).append(
            (run["step_s"], run["cpu_time_s"] / scene.duration, run[key]))
        closures.setdefault(run["method"], []).append(run.get("max_violation"))
    return out, closures


def final_closure(out):
    """The largest joint violation (`JOINT.violation` of `constraints.csv`, m) at the last
    frame of an `mbdc run` written to `out`; None when the run wrote no constraints."""
    path = Path(out) / "constraints.csv"
    if not path.is_file():
        return None
    with open(path) as f:
        rows = list(csv.reader(f))
    if len(rows) < 2:
        return None
    cols = [i for i, name in enumerate(rows[0]) if name.endswith(".violation")]
    return max((abs(float(rows[-1][i])) for i in cols), default=None)


def final_poses(mbdc, root, scene, method, h, out, model=None):
    """The final mass-centre positions and orientations of one interpreted `mbdc run` (of
    `model`, default the scene's); its final loop closure is `final_closure(out)`."""
    model = model or root / scene.model
    steps = int(round(scene.duration / h))
    cmd = [str(mbdc), "run", str(model), *_sets(scene), "--interp", "-q",
           "--method", method, "--step", repr(h), "--duration", repr(scene.duration),
           "--every", str(steps), "--format", "csv", "-o", str(out)]
    subprocess.run(cmd, check=True, cwd=root)
    with open(Path(out) / "bodies.csv") as f:
        rows = list(csv.reader(f))
    head, last = rows[0], [float(x) for x in rows[-1]]
    col = {name: i for i, name in enumerate(head)}
    poses = []
    for name in scene.names:
        p = np.array([last[col[f"{name}.{c}"]] for c in "xyz"])
        w, x, y, z = (last[col[f"{name}.{c}"]] for c in ("qw", "qx", "qy", "qz"))
        n = math.sqrt(w * w + x * x + y * y + z * z)
        w, x, y, z = w / n, x / n, y / n, z / n
        rot = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ])
        poses.append((p, rot))
    return poses


def with_method(text, method):
    """The model text with its `simulate { ... }` block's method replaced by `method` (e.g.
    `dopri5 { tolerance 1e-6 }`); the race's models have the block on one line."""
    m = re.search(r"simulate \{(.*)\}", text)
    if not m:
        raise ValueError("no one-line `simulate { ... }` block in the model")
    body = re.sub(r"(;\s*)?method \w+(\s*\{[^}]*\})?", "", m.group(1))
    return text[:m.start()] + f"simulate {{ method {method};{body}}}" + text[m.end():]


def tolerance_series(mbdc, root, scene, out, ref, error, tolerances, method="dopri5"):
    """An error-controlled `method`'s (`dopri5`, `dop853`) (tolerance, CPU seconds per
    simulated second, error against `ref`) points: see the module doc. `error(scene, poses,
    ref)` is the race's error measure. Returns the points and each point's loop closure
    (the largest joint violation at the end of the interpreted run, m)."""
    text = (root / scene.model).read_text()
    pts, closures = [], []
    for tol in tolerances:
        d = Path(out) / f"tol_{tol:.0e}"
        d.mkdir(parents=True, exist_ok=True)
        model = d / Path(scene.model).name
        model.write_text(with_method(text, f"{method} {{ tolerance {tol:.0e} }}"))
        try:
            sw = sweep(mbdc, root, scene, d / "sweep", levels=1, methods=[method], model=model)
            run = sw["runs"][0]
            if run.get("status") != "ok":
                print(f"    {method} tolerance {tol:.0e}: {run.get('status_text')}", flush=True)
                continue
            poses = final_poses(mbdc, root, scene, method, run["step_s"], d / "run",
                                model=model)
        except subprocess.CalledProcessError as e:
            print(f"    {method} tolerance {tol:.0e}: mbdc failed ({e})", flush=True)
            continue
        err = error(scene, poses, ref)
        closure = final_closure(d / "run")
        pts.append((tol, run["cpu_time_s"] / scene.duration, err))
        closures.append(closure)
        print(f"    {method} tolerance {tol:.0e} (h = {run['step_s']:.3e}): "
              f"{run['cpu_time_s'] / scene.duration:.3e} s/s, error {err:.3e}"
              + (f", closure {closure:.1e}" if closure is not None else ""), flush=True)
    return pts, closures
