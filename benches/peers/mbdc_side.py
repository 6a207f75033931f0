"""mbdc's side of the race: `mbdc sweep` on the scene's model (the compiled program by
default, best-of-k CPU time per run, error against the sweep's own reference), and one
`mbdc run` whose final state is checked against the race's independent reference, so that
the sweep's errors and the peers' errors measure the same thing.
"""

import csv
import json
import math
import subprocess
from pathlib import Path

import numpy as np


def _sets(scene):
    out = []
    for s in scene.overrides:
        out += ["--set", s]
    return out


def sweep(mbdc, root, scene, out, interp=False, levels=7, methods=None):
    """Run `mbdc sweep` into `out`; returns its sweep.json."""
    cmd = [str(mbdc), "sweep", str(root / scene.model), *_sets(scene),
           "--error", scene.measure, "--duration", repr(scene.duration),
           "--levels", str(levels), "-o", str(out), "-q"]
    if interp:
        cmd.append("--interp")
    if methods:
        cmd += ["--methods", ",".join(methods)]
    subprocess.run(cmd, check=True, cwd=root)
    return json.loads((Path(out) / "sweep.json").read_text())


def series(result, scene):
    """Per method, its (step, CPU seconds per simulated second, error) points."""
    key = "pos_err_final_m" if scene.measure == "pos-final" else "rot_err_final_rad"
    out = {}
    for run in result["runs"]:
        if run.get("status") != "finished" or run.get(key) is None:
            continue
        out.setdefault(run["method"], []).append(
            (run["step_s"], run["cpu_time_s"] / scene.duration, run[key]))
    return out


def final_poses(mbdc, root, scene, method, h, out):
    """The final mass-centre positions and orientations of one interpreted `mbdc run`."""
    steps = int(round(scene.duration / h))
    cmd = [str(mbdc), "run", str(root / scene.model), *_sets(scene), "--interp", "-q",
           "--method", method, "--step", repr(h), "--duration", repr(scene.duration),
           "--every", str(steps), "--format", "csv", "-o", str(out)]
    subprocess.run(cmd, check=True, cwd=root)
    with open(Path(out) / "bodies.csv") as f:
        rows = list(csv.reader(f))
    head, last = rows[0], [float(x) for x in rows[-1]]
    col = {name: i for i, name in enumerate(head)}
    poses = []
    for link in scene.links:
        p = np.array([last[col[f"{link.name}.{c}"]] for c in "xyz"])
        w, x, y, z = (last[col[f"{link.name}.{c}"]] for c in ("qw", "qx", "qy", "qz"))
        n = math.sqrt(w * w + x * x + y * y + z * z)
        w, x, y, z = w / n, x / n, y / n, z / n
        rot = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ])
        poses.append((p, rot))
    return poses
