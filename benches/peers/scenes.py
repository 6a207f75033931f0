"""The race scenes: one description per scene kind of issue 19, shared by the reference,
the peers and mbdc.

Each scene mirrors an mbdc model file (with `--set` overrides) exactly: the same bodies,
inertias, joints, initial state, gravity and duration. Geometry is given in the mbdc
model's world frame (z up).

A tree scene is a list of links. Link k has a parent (-1: ground), a joint (`hinge_y`,
`ball` or `free`), the joint's position in the parent's link frame (for the ground, in the
world frame), the rotation of the link frame relative to the parent's link frame at the
start (a 3×3 matrix), and its mass, mass centre (in the link frame) and central inertia
(diagonal, in the link frame). The link frame sits at the joint. Initial joint velocities:
a hinge's rate, a ball's angular velocity relative to its parent in the link frame, a free
joint's (linear velocity in world, angular velocity in the link frame).

A closed-loop scene (`LoopScene`) is planar: bodies moving in the world x–y plane, each
with its mass-centre position, the angle of its body x axis from the world x axis about z,
and its velocities; joints between two bodies (or a body and the ground): `revolute` (a
pin about z: two points coincide) and `slide` (body b translates along a world direction
through a ground point without turning). The mbdc models are spatial (revolute joints
about z; the slider-crank's spherical and universal joints and prismatic guide), but their
motion stays in the plane, where they are these planar systems.
"""

from dataclasses import dataclass, field
import math

import numpy as np


def rot_y(angle):
    """Rotation matrix about y by `angle` (rad)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rod_inertia(m, length, radius, axis):
    """mbdc's `rod(length, radius, axis)`: a solid cylinder about its centre."""
    along = 0.5 * m * radius**2
    across = m * (3.0 * radius**2 + length**2) / 12.0
    d = [across, across, across]
    d["xyz".index(axis)] = along
    return np.array(d)


@dataclass
class Link:
    name: str
    parent: int
    joint: str
    joint_pos: np.ndarray
    rot: np.ndarray
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    qd0: np.ndarray = field(default_factory=lambda: np.zeros(0))


@dataclass
class Scene:
    name: str
    links: list
    gravity: np.ndarray
    duration: float
    # `pos-final` or `rot-final`: the error measure of `mbdc sweep --error`
    measure: str
    # the mbdc model and its overrides
    model: str
    overrides: list
    # the planar chain's link length when the scene is one (for Exudyn's kinematic tree)
    planar_link: float = 0.0

    @property
    def names(self):
        """The links' names, as in the mbdc model (the columns of its `bodies.csv`)."""
        return [link.name for link in self.links]


def double_pendulum_3d():
    """models/double_pendulum_3d.mbd: two 1 m, 1 kg rods on spherical joints, bar 1
    tilted 60° in the x–z plane, bar 2 horizontal along +x, all spinning about z at
    1 rad/s; 10 s."""
    L, m, r, tilt = 1.0, 1.0, 0.01, math.radians(60.0)
    r1 = rot_y(-tilt)  # body 1's axes in world: its +z points from its centre to the origin
    omega = np.array([0.0, 0.0, 1.0])
    links = [
        Link("rod1", -1, "ball", np.zeros(3), r1, m, np.array([0.0, 0.0, -L / 2]),
             rod_inertia(m, L, r, "z"), r1.T @ omega),
        # the elbow at bar 1's lower end; bar 2's axes are the world's
        Link("rod2", 0, "ball", np.array([0.0, 0.0, -L]), r1.T, m, np.array([L / 2, 0.0, 0.0]),
             rod_inertia(m, L, r, "x"), np.zeros(3)),
    ]
    return Scene("double_pendulum_3d", links, np.array([0.0, 0.0, -9.81]), 10.0, "pos-final",
                 "models/double_pendulum_3d.mbd", [])


def planar_chain(n, length, mass, duration):
    """models/bench/chain_planar.mbd with N = n: n rods (radius 5 mm) on revolute joints
    about y, released at rest from the horizontal along +x."""
    links = []
    for k in range(n):
        links.append(Link(
            f"link[{k}]", k - 1, "hinge_y",
            np.zeros(3) if k == 0 else np.array([length, 0.0, 0.0]),
            np.eye(3), mass, np.array([length / 2, 0.0, 0.0]),
            rod_inertia(mass, length, 0.005, "x"), np.zeros(1)))
    return Scene(f"chain_planar_{n}", links, np.array([0.0, 0.0, -9.81]), duration, "pos-final",
                 "models/bench/chain_planar.mbd",
                 [f"N={n}", f"L={length} m", f"m={mass} kg"], planar_link=length)


def torque_free():
    """models/torque_free.mbd: a free body with inertia diag(1, 2, 3) kg m², spinning at
    (0.01, 2, 0) rad/s (body axes) near its intermediate axis, no gravity; 100 s."""
    links = [Link("brick", -1, "free", np.zeros(3), np.eye(3), 1.0, np.zeros(3),
                  np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 0.0, 0.01, 2.0, 0.0]))]
    return Scene("torque_free", links, np.zeros(3), 100.0, "rot-final", "models/torque_free.mbd", [])


def rot_z(angle):
    """Rotation matrix about z by `angle` (rad)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def box_inertia(m, a, b, c):
    """mbdc's `box(size: (a, b, c))`: a solid box's central inertia (diagonal)."""
    return m / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


@dataclass
class PlanarBody:
    name: str
    mass: float
    # central inertia, diagonal in the body axes (the planar dynamics uses the z entry)
    inertia: np.ndarray
    # mass centre (x, y) and angle of the body x axis about z, world
    pos: np.ndarray
    angle: float
    # mass-centre velocity (x, y) and angular velocity about z
    vel: np.ndarray = field(default_factory=lambda: np.zeros(2))
    omega: float = 0.0


@dataclass
class PlanarJoint:
    name: str
    # `revolute` (point pa on a and point pb on b coincide) or `slide` (b's point pb stays on
    # the world line through the ground point pa along `axis`, and b does not turn)
    kind: str
    # body indices (-1: ground); points in the body's axes relative to its mass centre, world
    # coordinates for the ground
    a: int
    pa: np.ndarray
    b: int
    pb: np.ndarray
    axis: np.ndarray = None


@dataclass
class LoopScene:
    name: str
    bodies: list
    joints: list
    gravity: np.ndarray
    duration: float
    measure: str
    model: str
    overrides: list
    # the body whose angle is the independent coordinate (a crank pivoted to the ground)
    independent: int = 0

    @property
    def names(self):
        """The bodies' names, as in the mbdc model (the columns of its `bodies.csv`)."""
        return [b.name for b in self.bodies]

    def local(self, body, world_point):
        """A world point (x, y) in the axes of `body` (index) relative to its mass centre,
        as mbdc's `world(P)` gives it."""
        bd = self.bodies[body]
        return rot_z(-bd.angle)[:2, :2] @ (np.asarray(world_point, float) - bd.pos)


def four_bar_planar(theta0=math.radians(60.0)):
    """benches/models/four_bar_planar.mbd: a Grashof crank-rocker (ground 1.0, crank 0.3,
    coupler 0.9, rocker 0.7 m; 1 kg rods of radius 1 cm) in the x–y plane, released at rest
    with the crank at theta0, gravity −y; 10 s. Four pins; the independent coordinate is the
    crank angle."""
    a, b, c = 0.3, 0.9, 0.7
    A, D = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    # the model's construction of the initial pins, step by step
    B = np.array([a * math.cos(theta0), a * math.sin(theta0)])
    e = np.linalg.norm(D - B)
    u = (D - B) / e
    s = (b * b - c * c + e * e) / (2.0 * e)
    C = B + s * u + math.sqrt(b * b - s * s) * np.array([-u[1], u[0]])

    def rod(name, p, q, length):
        return PlanarBody(name, 1.0, rod_inertia(1.0, length, 0.01, "x"), (p + q) / 2.0,
                          math.atan2((q - p)[1], (q - p)[0]))

    scene = LoopScene("four_bar_planar",
                      [rod("crank", A, B, a), rod("coupler", B, C, b), rod("rocker", D, C, c)],
                      [], np.array([0.0, -9.81, 0.0]), 10.0, "pos-final",
                      "benches/models/four_bar_planar.mbd", [], independent=0)
    # the rocker's axis points from D to C, as in the model: its angle is atan2 of C − D
    scene.joints = [
        PlanarJoint("pa", "revolute", -1, A, 0, scene.local(0, A)),
        PlanarJoint("pb", "revolute", 0, scene.local(0, B), 1, scene.local(1, B)),
        PlanarJoint("pc", "revolute", 1, scene.local(1, C), 2, scene.local(2, C)),
        PlanarJoint("pd", "revolute", 2, scene.local(2, D), -1, D),
    ]
    return scene


def slider_crank_race(r=0.15, rod_length=0.5, w0=7.66):
    """benches/models/slider_crank_race.mbd (models/slider_crank.mbd run for 5 s): crank r
    (1 kg rod), connecting rod (1 kg rod), 0.5 kg slider on the world x axis through the
    crank's pivot; crank along +x at w0, the rod turning at −r w0 / l, the slider at rest;
    gravity −y. Planar: the crank–rod spherical and the rod–slider universal joint of the
    model are pins in the plane, its prismatic guide a slide along x."""
    l = rod_length
    phidot = -r * w0 / l
    bodies = [
        PlanarBody("crank", 1.0, rod_inertia(1.0, r, 0.01, "x"), np.array([r / 2, 0.0]), 0.0,
                   np.array([0.0, w0 * r / 2]), w0),
        PlanarBody("rod", 1.0, rod_inertia(1.0, l, 0.01, "x"), np.array([r + l / 2, 0.0]), 0.0,
                   np.array([0.0, w0 * r + phidot * l / 2]), phidot),
        PlanarBody("slider", 0.5, box_inertia(0.5, 0.1, 0.05, 0.05), np.array([r + l, 0.0]),
                   0.0),
    ]
    joints = [
        PlanarJoint("pivot", "revolute", -1, np.zeros(2), 0, np.array([-r / 2, 0.0])),
        PlanarJoint("pin", "revolute", 0, np.array([r / 2, 0.0]), 1, np.array([-l / 2, 0.0])),
        PlanarJoint("wrist", "revolute", 1, np.array([l / 2, 0.0]), 2, np.zeros(2)),
        PlanarJoint("guide", "slide", -1, np.zeros(2), 2, np.zeros(2), axis=np.array([1.0, 0.0])),
    ]
    return LoopScene("slider_crank_race", bodies, joints, np.array([0.0, -9.81, 0.0]), 5.0,
                     "pos-final", "benches/models/slider_crank_race.mbd", [], independent=0)


def all_scenes():
    """The scenes of the race, in table order."""
    return [
        double_pendulum_3d(),
        planar_chain(2, 0.5, 1.0, 5.0),
        planar_chain(8, 0.25, 0.25, 5.0),
        torque_free(),
        four_bar_planar(),
        slider_crank_race(),
    ]
