"""MuJoCo's side of the race: the scene as MJCF (the same links, inertias and initial
state; contacts off), integrated by `Euler` (semi-implicit), `implicitfast` or `RK4` at a
fixed step, timed over `mujoco.rollout` (the steps run in C, in chunks, into a reused
buffer: no Python per step).
"""

import time

import mujoco
import numpy as np
from mujoco import rollout

INTEGRATORS = ["Euler", "implicitfast", "RK4"]


def _quat(rot):
    """(w, x, y, z) of a rotation matrix."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, rot.reshape(9))
    return q


def mjcf(scene, h, integrator):
    """The scene's MJCF text."""
    g = " ".join(f"{x:.17g}" for x in scene.gravity)
    children = {k: [] for k in range(-1, len(scene.links))}
    for k, link in enumerate(scene.links):
        children[link.parent].append(k)

    def body(k):
        link = scene.links[k]
        pos = " ".join(f"{x:.17g}" for x in link.joint_pos)
        quat = " ".join(f"{x:.17g}" for x in _quat(link.rot))
        joint = {
            "hinge_y": '<joint type="hinge" axis="0 1 0"/>',
            "ball": '<joint type="ball"/>',
            "free": "<freejoint/>",
        }[link.joint]
        com = " ".join(f"{x:.17g}" for x in link.com)
        inertia = " ".join(f"{x:.17g}" for x in link.inertia)
        inner = "".join(body(c) for c in children[k])
        return (f'<body name="{link.name}" pos="{pos}" quat="{quat}">{joint}'
                f'<inertial pos="{com}" mass="{link.mass:.17g}" diaginertia="{inertia}"/>'
                f"{inner}</body>")

    world = "".join(body(c) for c in children[-1])
    return (f'<mujoco><option timestep="{h:.17g}" integrator="{integrator}" gravity="{g}">'
            f'<flag contact="disable"/></option><worldbody>{world}</worldbody></mujoco>')


def run(scene, h, integrator, chunk=20000):
    """(CPU seconds, final poses) of one run at step h."""
    model = mujoco.MjModel.from_xml_string(mjcf(scene, h, integrator))
    data = mujoco.MjData(model)
    data.qvel[:] = np.concatenate([link.qd0 for link in scene.links])
    steps = int(round(scene.duration / h))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstate = mujoco.mj_stateSize(model, spec)
    state = np.zeros(nstate)
    mujoco.mj_getState(model, data, state, spec)
    buf = np.zeros((1, min(chunk, steps), nstate))
    t0 = time.process_time()
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        out = buf if n == buf.shape[1] else np.zeros((1, n, nstate))
        rollout.rollout(model, data, state[None, :], nstep=n, state=out)
        state = out[0, -1].copy()
        done += n
    cpu = time.process_time() - t0
    mujoco.mj_setState(model, data, state, spec)
    mujoco.mj_kinematics(model, data)
    poses = []
    for link in scene.links:
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link.name)
        poses.append((data.xipos[b].copy(), data.xmat[b].reshape(3, 3).copy()))
    return cpu, poses
