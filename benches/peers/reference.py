"""Independent references for the race: Pinocchio's articulated-body algorithm (the
forward dynamics of the scene's tree in minimal coordinates) integrated by SciPy's DOP853
at a tight tolerance (`TIGHT`). Neither the peers nor mbdc share any code with it.

Quaternions (ball and free joints) are integrated as four coordinates with
q̇ = ½ q ⊗ (ω, 0) and normalized where they are used; at rtol 3e-14 their norm drifts by
less than the tolerance. The reference's own error is estimated by the difference to the
same integration at a tolerance ten times looser, and reported beside it.
"""

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp


# DOP853's relative (and absolute) tolerance of the reference: SciPy's floor is 100 ε
TIGHT = 3e-14


def build(scene):
    """The Pinocchio model of a scene, and each link's joint id."""
    model = pin.Model()
    model.gravity = pin.Motion(np.concatenate([scene.gravity, np.zeros(3)]))
    ids = []
    for link in scene.links:
        parent = 0 if link.parent < 0 else ids[link.parent]
        placement = pin.SE3(link.rot, link.joint_pos)
        joint = {
            "hinge_y": pin.JointModelRY,
            "ball": pin.JointModelSpherical,
            "free": pin.JointModelFreeFlyer,
        }[link.joint]()
        jid = model.addJoint(parent, joint, placement, link.name)
        model.appendBodyToJoint(jid, pin.Inertia(link.mass, link.com, np.diag(link.inertia)),
                                pin.SE3.Identity())
        ids.append(jid)
    return model, ids


def initial(scene, model):
    """The initial configuration (neutral: every link at its start pose) and velocity."""
    q = pin.neutral(model)
    v = np.concatenate([link.qd0 for link in scene.links])
    return q, v


def _quat_rate(qx, w):
    """d/dt of a unit quaternion (x, y, z, w) turning at the local angular velocity w."""
    vec, s = qx[:3], qx[3]
    return np.concatenate([0.5 * (s * w + np.cross(vec, w)), [-0.5 * vec.dot(w)]])


def _normalized(model, q):
    q = q.copy()
    for j in model.joints[1:]:
        name = j.shortname()
        if name == "JointModelSpherical":
            a = j.idx_q
            q[a:a + 4] /= np.linalg.norm(q[a:a + 4])
        elif name == "JointModelFreeFlyer":
            a = j.idx_q + 3
            q[a:a + 4] /= np.linalg.norm(q[a:a + 4])
    return q


def _qdot(model, q, v):
    out = np.zeros(model.nq)
    for j in model.joints[1:]:
        a, b = j.idx_q, j.idx_v
        name = j.shortname()
        if name == "JointModelRY":
            out[a] = v[b]
        elif name == "JointModelSpherical":
            out[a:a + 4] = _quat_rate(q[a:a + 4], v[b:b + 3])
        elif name == "JointModelFreeFlyer":
            quat = q[a + 3:a + 7]
            rot = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
            out[a:a + 3] = rot @ v[b:b + 3]
            out[a + 3:a + 7] = _quat_rate(quat, v[b + 3:b + 6])
        else:
            raise ValueError(f"joint {name} not handled")
    return out


def poses(scene, model, ids, q):
    """Each link's mass-centre position and rotation (link → world) at configuration q."""
    data = model.createData()
    q = _normalized(model, q)
    pin.forwardKinematics(model, data, q)
    out = []
    for link, jid in zip(scene.links, ids):
        m = data.oMi[jid]
        out.append((m.act(link.com), m.rotation.copy()))
    return out


def integrate(scene, rtol):
    """The scene's final poses, integrated by DOP853 at relative tolerance rtol."""
    model, ids = build(scene)
    data = model.createData()
    q0, v0 = initial(scene, model)
    nq = model.nq
    tau = np.zeros(model.nv)

    def rhs(_t, y):
        q, v = y[:nq], y[nq:]
        qn = _normalized(model, q)
        a = pin.aba(model, data, qn, v, tau)
        return np.concatenate([_qdot(model, qn, v), a])

    sol = solve_ivp(rhs, (0.0, scene.duration), np.concatenate([q0, v0]), method="DOP853",
                    rtol=rtol, atol=rtol, dense_output=False)
    if not sol.success:
        raise RuntimeError(f"{scene.name}: reference integration failed: {sol.message}")
    return poses(scene, model, ids, sol.y[:nq, -1])


def error(scene, got, ref):
    """The scene's error measure (mbdc's `pos-final` or `rot-final`): the RMS over links of
    the mass-centre position error (m) or of the rotation angle between the orientations
    (rad)."""
    if scene.measure == "pos-final":
        e = [np.sum((g[0] - r[0]) ** 2) for g, r in zip(got, ref)]
    else:
        e = []
        for g, r in zip(got, ref):
            c = np.clip((np.trace(r[1].T @ g[1]) - 1.0) / 2.0, -1.0, 1.0)
            # the angle from the rotation's antisymmetric part, accurate at small angles
            w = r[1].T @ g[1]
            s = 0.5 * np.linalg.norm([w[2, 1] - w[1, 2], w[0, 2] - w[2, 0], w[1, 0] - w[0, 1]])
            e.append(np.arctan2(s, c) ** 2)
    return float(np.sqrt(np.mean(e)))


def reference(scene):
    """The reference final poses and an estimate of their own error (the difference to a
    tolerance ten times looser, in the scene's measure)."""
    tight = integrate(scene, TIGHT)
    loose = integrate(scene, 10.0 * TIGHT)
    return tight, error(scene, loose, tight)
