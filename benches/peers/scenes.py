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


def all_scenes():
    """The scenes of the race, in table order."""
    return [
        double_pendulum_3d(),
        planar_chain(2, 0.5, 1.0, 5.0),
        planar_chain(8, 0.25, 0.25, 5.0),
        torque_free(),
    ]
