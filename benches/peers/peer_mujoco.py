"""MuJoCo's side of the race: the scene as MJCF (the same links, inertias and initial
state; contacts off), integrated by `Euler` (semi-implicit), `implicitfast` or `RK4` at a
fixed step, timed over `mujoco.rollout` (the steps run in C, in chunks, into a reused
buffer: no Python per step).

A closed loop (`scenes.LoopScene`) becomes a spanning tree of hinges and slides (breadth
first from the ground, in the scene's joint order) and one `<equality><connect>` per joint
left over, which pins the two points together. MuJoCo's equality constraints are soft: the
constraint force is that of a damped spring with time constant and damping ratio `solref`,
mixed with the unconstrained motion by the impedance `solimp`. Each loop series names its
setting (`EQUALITY`). The run also reports the loop's closure: the largest distance between
the connected points at about 200 states sampled over the run (outside the timing).
"""

import time

import mujoco
import numpy as np
from mujoco import rollout

from scenes import LoopScene

INTEGRATORS = ["Euler", "implicitfast", "RK4"]

# The loop closure's softness: MuJoCo's default (time constant 0.02 s, critical damping,
# impedance 0.9–0.95), and a stiff one: the largest impedance MuJoCo allows (0.9999) and a
# time constant of 0.2 ms, which MuJoCo raises to 2 h at steps above 0.1 ms (its `refsafe`
# flag, on by default, which keeps the constraint stable). Tried as well, over 1 s with
# `RK4`: the time constant at its 2 h floor at every step (`solref="1e-9 1"`: the same down to
# h = 1e-4 s, within 10× of this one below, better on one scene and worse on the other), a
# lower impedance (0.99: 10–100× larger errors), and the direct form (`solref="-1e8 -2e4"`,
# stiffness and damping, which `refsafe` does not guard: unstable at h ≥ 1e-3 s on the
# four-bar, not better at fine steps).
EQUALITY = {
    "default": 'solref="0.02 1" solimp="0.9 0.95 0.001 0.5 2"',
    "stiff": 'solref="0.0002 1" solimp="0.9999 0.9999 0.001 0.5 2"',
}


def methods(scene, race=True):
    """The MuJoCo series of a scene: each integrator; on a closed loop each integrator with
    the stiff equality setting (`RK4 (stiff)`), and unless `race`, `RK4 (default)` as well.
    With the default closure the error stalls at the loop's own softness (0.16 m on the
    four-bar, 0.012 m on the slider-crank over the full runs, `crosscheck.py`), so a race
    series would only spend its budget on it."""
    if isinstance(scene, LoopScene):
        return [f"{i} (stiff)" for i in INTEGRATORS] + ([] if race else ["RK4 (default)"])
    return list(INTEGRATORS)


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


def _vec(v):
    return " ".join(f"{x:.17g}" for x in v)


def spanning_tree(scene):
    """A closed loop's spanning tree: per body its (parent body or -1, joint index), found
    breadth first from the ground in the scene's joint order, and the joints left over (the
    cut joints)."""
    tree, cut, frontier = {}, [], [-1]
    used = set()
    while frontier:
        nxt = []
        for parent in frontier:
            for i, j in enumerate(scene.joints):
                if i in used or parent not in (j.a, j.b):
                    continue
                child = j.b if j.a == parent else j.a
                if child in tree or child == -1:
                    continue
                tree[child] = (parent, i)
                used.add(i)
                nxt.append(child)
        frontier = nxt
    cut = [i for i in range(len(scene.joints)) if i not in used]
    return tree, cut


def mjcf_loop(scene, h, integrator, equality):
    """A closed-loop scene's MJCF text: body frames at the mass centres (body x along the
    scene's body axis), hinges about z and slides on the spanning tree, a `connect` per cut
    joint with the `EQUALITY[equality]` setting."""
    tree, cut = spanning_tree(scene)
    children = {}
    for child, (parent, _) in tree.items():
        children.setdefault(parent, []).append(child)

    def frame(parent, child):
        """The child's position and angle in the parent's frame (world for the ground)."""
        c = scene.bodies[child]
        if parent < 0:
            return c.pos, c.angle
        p = scene.bodies[parent]
        return scene.local(parent, c.pos), c.angle - p.angle

    def body(k):
        b = scene.bodies[k]
        parent, ji = tree[k]
        j = scene.joints[ji]
        pos, angle = frame(parent, k)
        point = j.pb if j.b == k else j.pa
        if j.kind == "revolute":
            joint = f'<joint name="{j.name}" type="hinge" axis="0 0 1" pos="{_vec([*point, 0.0])}"/>'
        else:
            local = _rot_z(-b.angle) @ np.array([*(j.axis / np.linalg.norm(j.axis)), 0.0])
            joint = f'<joint name="{j.name}" type="slide" axis="{_vec(local)}"/>'
        inner = "".join(body(c) for c in sorted(children.get(k, [])))
        return (f'<body name="{b.name}" pos="{_vec([*pos, 0.0])}" '
                f'quat="{_vec(_quat(_rot_z(angle)))}">{joint}'
                f'<inertial pos="0 0 0" mass="{b.mass:.17g}" diaginertia="{_vec(b.inertia)}"/>'
                f"{inner}</body>")

    eqs = []
    for i in cut:
        j = scene.joints[i]
        if j.kind != "revolute":
            raise ValueError(f"{scene.name}: the cut joint {j.name} is not a revolute")
        # body1 must be a body; the anchor is in its frame, body2's point follows from the
        # initial (closed) configuration
        b1, p1, b2 = (j.a, j.pa, j.b) if j.a >= 0 else (j.b, j.pb, j.a)
        second = f' body2="{scene.bodies[b2].name}"' if b2 >= 0 else ""
        eqs.append(f'<connect name="{j.name}" body1="{scene.bodies[b1].name}"{second} '
                   f'anchor="{_vec([*p1, 0.0])}" {EQUALITY[equality]}/>')
    world = "".join(body(c) for c in sorted(children[-1]))
    return (f'<mujoco><option timestep="{h:.17g}" integrator="{integrator}" '
            f'gravity="{_vec(scene.gravity)}"><flag contact="disable"/></option>'
            f'<worldbody>{world}</worldbody><equality>{"".join(eqs)}</equality></mujoco>')


def _rot_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _initial_velocity(scene, model):
    """qvel at the start: the tree scenes' joint rates; on a loop, each tree joint's rate
    from the bodies' planar velocities (a hinge: the relative angular velocity; a slide:
    the body's speed along the axis)."""
    if not isinstance(scene, LoopScene):
        return np.concatenate([link.qd0 for link in scene.links])
    tree, _ = spanning_tree(scene)
    qvel = np.zeros(model.nv)
    for child, (parent, ji) in tree.items():
        j = scene.joints[ji]
        adr = model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)]
        c = scene.bodies[child]
        if j.kind == "revolute":
            qvel[adr] = c.omega - (scene.bodies[parent].omega if parent >= 0 else 0.0)
        else:
            qvel[adr] = c.vel @ (j.axis / np.linalg.norm(j.axis))
    return qvel


def closure(scene, model, data):
    """The largest distance between a cut joint's connected points at `data`'s positions
    (after `mj_kinematics`), m; 0 for a tree."""
    if not isinstance(scene, LoopScene):
        return 0.0
    worst = 0.0
    for i in spanning_tree(scene)[1]:
        j = scene.joints[i]
        pts = []
        for body, p in ((j.a, j.pa), (j.b, j.pb)):
            if body < 0:
                pts.append(np.array([*p, 0.0]))
                continue
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, scene.bodies[body].name)
            pts.append(data.xpos[b] + data.xmat[b].reshape(3, 3) @ np.array([*p, 0.0]))
        worst = max(worst, float(np.linalg.norm(pts[0] - pts[1])))
    return worst


def run(scene, h, method, chunk=20000, samples=200):
    """(CPU seconds, final poses, loop closure) of one run at step h; `method` is an
    integrator, on a loop with its equality setting (`RK4 (stiff)`, see `methods`). The
    closure is the largest over about `samples` states spread over the run and the final
    one (0 for a tree)."""
    if isinstance(scene, LoopScene):
        integrator, equality = method.split(" ")
        text = mjcf_loop(scene, h, integrator, equality.strip("()"))
    else:
        text = mjcf(scene, h, method)
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    data.qvel[:] = _initial_velocity(scene, model)
    steps = int(round(scene.duration / h))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstate = mujoco.mj_stateSize(model, spec)
    state = np.zeros(nstate)
    mujoco.mj_getState(model, data, state, spec)
    buf = np.zeros((1, min(chunk, steps), nstate))
    stride = max(1, steps // samples)
    kept = []
    t0 = time.process_time()
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        out = buf if n == buf.shape[1] else np.zeros((1, n, nstate))
        rollout.rollout(model, data, state[None, :], nstep=n, state=out)
        state = out[0, -1].copy()
        if isinstance(scene, LoopScene):
            kept.append(out[0, (-done) % stride::stride].copy())
        done += n
    cpu = time.process_time() - t0
    worst = 0.0
    for block in kept:
        for st in block:
            mujoco.mj_setState(model, data, st, spec)
            mujoco.mj_kinematics(model, data)
            worst = max(worst, closure(scene, model, data))
    mujoco.mj_setState(model, data, state, spec)
    mujoco.mj_kinematics(model, data)
    worst = max(worst, closure(scene, model, data))
    poses = []
    for name in scene.names:
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        poses.append((data.xipos[b].copy(), data.xmat[b].reshape(3, 3).copy()))
    return cpu, poses, worst
