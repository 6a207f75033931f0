"""Independent references for the race, integrated by SciPy's DOP853 at a tight tolerance
(`TIGHT`). Neither the peers nor mbdc share any code with them.

- Trees: Pinocchio's articulated-body algorithm (the forward dynamics of the scene's tree
  in minimal coordinates).
- Closed loops (planar, `scenes.LoopScene`): coordinate partitioning in plain NumPy on the
  planar natural coordinates q = (x, y, φ) of every body, with the constraints Φ(q) = 0 of
  the joints and the crank angle θ as the one independent coordinate. At each right-hand-side
  evaluation the dependent coordinates are solved from Φ = 0 by Newton's method to round-off
  (‖Φ‖ ≤ 1e-15), the velocities from Φ_q q̇ = 0, and the accelerations from the index-1
  system [M Φ_qᵀ; Φ_q 0] [q̈; λ] = [Q; γ]; DOP853 integrates (θ, θ̇) alone. Pinocchio's ABA
  has no loops, so it is not used there.

Quaternions (ball and free joints) are integrated as four coordinates with
q̇ = ½ q ⊗ (ω, 0) and normalized where they are used; at rtol 3e-14 their norm drifts by
less than the tolerance. The reference's own error is estimated by the difference to the
same integration at a tolerance ten times looser, and reported beside it.
"""

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

from scenes import LoopScene, rot_z


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


class PlanarLoop:
    """The planar multibody system of a `scenes.LoopScene` in natural coordinates:
    q = (x_0, y_0, φ_0, x_1, ...), the mass centres and body angles. The ground has no
    coordinates; its points are given in world coordinates."""

    def __init__(self, scene):
        self.scene = scene
        self.n = 3 * len(scene.bodies)
        self.mass = np.concatenate([[b.mass, b.mass, b.inertia[2]] for b in scene.bodies])
        self.force = np.concatenate([[b.mass * scene.gravity[0], b.mass * scene.gravity[1], 0.0]
                                     for b in scene.bodies])
        self.rows = 2 * len(scene.joints)
        if self.rows != self.n - 1:
            raise ValueError(f"{scene.name}: {self.rows} constraint rows on {self.n} "
                             "coordinates: the reference needs exactly one degree of freedom")
        self.indep = 3 * scene.independent + 2
        self.dep = np.array([k for k in range(self.n) if k != self.indep])
        self.q0 = np.concatenate([[b.pos[0], b.pos[1], b.angle] for b in scene.bodies])
        self.qd0 = np.concatenate([[b.vel[0], b.vel[1], b.omega] for b in scene.bodies])
        # the slides' reference angles (a slide keeps its body at its initial angle)
        self.angle0 = [scene.bodies[j.b].angle if j.kind == "slide" else 0.0
                       for j in scene.joints]

    @staticmethod
    def _rot(phi):
        c, s = np.cos(phi), np.sin(phi)
        return np.array([[c, -s], [s, c]])

    def _point(self, q, body, p):
        """World position of point p of `body` (its axes, from its mass centre; world for
        the ground), and its derivative with respect to the body's angle."""
        if body < 0:
            return np.asarray(p, float), np.zeros(2)
        k = 3 * body
        a = self._rot(q[k + 2]) @ p
        return q[k:k + 2] + a, np.array([-a[1], a[0]])

    def phi(self, q):
        """The constraint residuals Φ(q): per revolute, the two points' difference; per
        slide, the point's offset normal to the line and the body's turn."""
        out = np.empty(self.rows)
        for i, (j, ang0) in enumerate(zip(self.scene.joints, self.angle0)):
            pa, _ = self._point(q, j.a, j.pa)
            pb, _ = self._point(q, j.b, j.pb)
            if j.kind == "revolute":
                out[2 * i:2 * i + 2] = pb - pa
            else:
                normal = np.array([-j.axis[1], j.axis[0]]) / np.linalg.norm(j.axis)
                out[2 * i] = normal @ (pb - pa)
                out[2 * i + 1] = q[3 * j.b + 2] - ang0
        return out

    def jacobian(self, q):
        """Φ_q, the constraint Jacobian (rows × coordinates)."""
        jac = np.zeros((self.rows, self.n))
        for i, j in enumerate(self.scene.joints):
            r = slice(2 * i, 2 * i + 2)
            for body, p, sign in ((j.a, j.pa, -1.0), (j.b, j.pb, 1.0)):
                if body < 0:
                    continue
                k = 3 * body
                _, dp = self._point(q, body, p)
                if j.kind == "revolute":
                    jac[r, k:k + 2] += sign * np.eye(2)
                    jac[r, k + 2] += sign * dp
                else:
                    normal = np.array([-j.axis[1], j.axis[0]]) / np.linalg.norm(j.axis)
                    jac[2 * i, k:k + 2] += sign * normal
                    jac[2 * i, k + 2] += sign * normal @ dp
                    if body == j.b:
                        jac[2 * i + 1, k + 2] = 1.0
        return jac

    def gamma(self, q, qd):
        """γ = −(Φ_q q̇)_q q̇, the right-hand side of the acceleration constraints
        Φ_q q̈ = γ: a point's acceleration has the centripetal part −φ̇² A(φ) p."""
        out = np.zeros(self.rows)
        for i, j in enumerate(self.scene.joints):
            acc = np.zeros(2)
            for body, p, sign in ((j.a, j.pa, -1.0), (j.b, j.pb, 1.0)):
                if body < 0:
                    continue
                k = 3 * body
                acc += sign * (-qd[k + 2] ** 2) * (self._rot(q[k + 2]) @ p)
            if j.kind == "revolute":
                out[2 * i:2 * i + 2] = -acc
            else:
                normal = np.array([-j.axis[1], j.axis[0]]) / np.linalg.norm(j.axis)
                out[2 * i] = -normal @ acc
        return out

    def positions(self, theta, guess):
        """The coordinates with the independent one at theta and the dependent ones solved
        from Φ = 0 by Newton's method from `guess`, to ‖Φ‖∞ ≤ 1e-15 (or until a step no
        longer changes them, at round-off)."""
        q = guess.copy()
        q[self.indep] = theta
        for _ in range(50):
            res = self.phi(q)
            if np.max(np.abs(res)) <= 1e-15:
                return q
            step = np.linalg.solve(self.jacobian(q)[:, self.dep], -res)
            q[self.dep] += step
            if np.max(np.abs(step)) <= 1e-16:
                break
        res = np.max(np.abs(self.phi(q)))
        if res > 1e-13:
            raise RuntimeError(f"{self.scene.name}: Newton on the loop stopped at |Φ| = {res:.1e}")
        return q

    def velocities(self, q, thetadot):
        """q̇ with the independent rate thetadot and Φ_q q̇ = 0."""
        jac = self.jacobian(q)
        qd = np.zeros(self.n)
        qd[self.indep] = thetadot
        qd[self.dep] = np.linalg.solve(jac[:, self.dep], -jac[:, self.indep] * thetadot)
        return qd

    def accelerations(self, q, qd):
        """q̈ from the index-1 system [M Φ_qᵀ; Φ_q 0] [q̈; λ] = [Q; γ]."""
        jac = self.jacobian(q)
        n, m = self.n, self.rows
        kkt = np.zeros((n + m, n + m))
        kkt[:n, :n] = np.diag(self.mass)
        kkt[:n, n:] = jac.T
        kkt[n:, :n] = jac
        rhs = np.concatenate([self.force, self.gamma(q, qd)])
        return np.linalg.solve(kkt, rhs)[:n]

    def poses(self, q):
        """Each body's mass-centre position and rotation (body → world)."""
        return [(np.array([q[3 * k], q[3 * k + 1], 0.0]), rot_z(q[3 * k + 2]))
                for k in range(len(self.scene.bodies))]

    def closure(self, q):
        """The largest joint violation |Φ|∞ at q (m, or rad for a slide's turn)."""
        return float(np.max(np.abs(self.phi(q))))


def integrate_loop(scene, rtol):
    """A closed-loop scene's final poses by coordinate partitioning (see the module doc),
    (θ, θ̇) integrated by DOP853 at relative and absolute tolerance rtol."""
    sys_ = PlanarLoop(scene)
    if sys_.closure(sys_.q0) > 1e-12 or np.max(np.abs(sys_.jacobian(sys_.q0) @ sys_.qd0)) > 1e-12:
        raise ValueError(f"{scene.name}: the initial state violates the joints")
    last = [sys_.q0.copy()]

    def rhs(_t, y):
        q = sys_.positions(y[0], last[0])
        last[0] = q
        qd = sys_.velocities(q, y[1])
        return np.array([y[1], sys_.accelerations(q, qd)[sys_.indep]])

    y0 = np.array([sys_.q0[sys_.indep], sys_.qd0[sys_.indep]])
    sol = solve_ivp(rhs, (0.0, scene.duration), y0, method="DOP853", rtol=rtol, atol=rtol)
    if not sol.success:
        raise RuntimeError(f"{scene.name}: reference integration failed: {sol.message}")
    q = sys_.positions(sol.y[0, -1], last[0])
    return sys_.poses(q)


def integrate(scene, rtol):
    """The scene's final poses, integrated by DOP853 at relative tolerance rtol."""
    if isinstance(scene, LoopScene):
        return integrate_loop(scene, rtol)
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
