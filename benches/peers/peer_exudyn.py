"""Exudyn's side of the race, where Exudyn has an integrator for the scene:

- planar chains: `ObjectKinematicTree` (minimal coordinates, O(n) articulated-body
  dynamics) with revolute-y joints;
- a free rigid body: a rigid-body node with rotation-vector coordinates, integrated on the
  Lie group (`useLieGroupIntegration`);
- closed loops (planar): redundant coordinates, `ObjectRigidBody2D` bodies (x, y, φ at the
  mass centre) with `ObjectJointRevolute2D` pins and an `ObjectJointPrismatic2D` slide.

Trees and the free body: explicit Runge–Kutta `RK44` and `RK67` at a fixed step, one
thread, no solution file; timed over `SolveDynamic` (the step loop runs in C++). Exudyn's
kinematic tree has no spherical joint, and its explicit solvers do not take the spherical
joints of a redundant-coordinate model, so the 3-D double pendulum has no Exudyn entry.

Closed loops: Exudyn's explicit solvers refuse the algebraic constraints of a loop (they
only eliminate constraints that fix single coordinates to the ground; `loop_refusal` shows
the message), and a kinematic tree cannot close a loop. The loops therefore run under an
implicit solver at a fixed step (`LOOP_SOLVERS`): `GeneralizedAlpha` (index 3: the
positions satisfy the joints at every step to Newton's tolerance; Exudyn's default
spectral radius 0.9, second order — at 1.0, the undamped member, Newton fails on the
slider-crank at h = 0.01 s and the errors at finer steps are erratic). `TrapezoidalIndex2`
(the trapezoidal rule on the velocity-level, index-2 constraints: the positions drift off
the joints) runs too, but is not raced (see `LOOP_SOLVERS`). Newton's tolerances are set
tighter than the default (`NEWTON_TOL`; at 1e-13 Newton does not converge on the
slider-crank), where they no longer change the errors.
"""

import re
import time

import exudyn as exu
import numpy as np
from exudyn.itemInterface import (LoadMassProportional, MarkerBodyMass, MarkerBodyPosition,
                                  MarkerBodyRigid, NodeGenericODE2, NodeRigidBody2D, ObjectGround,
                                  ObjectJointPrismatic2D, ObjectJointRevolute2D,
                                  ObjectKinematicTree, ObjectRigidBody2D)
from exudyn.utilities import RigidBodyInertia

import reference
from scenes import LoopScene

SOLVERS = ["RK44", "RK67"]
# the race runs generalized-α only: `TrapezoidalIndex2` is of the same (second) order at
# about the same cost per step, and only adds the drift of its positions off the joints
# (closure 3e-4 m at h = 0.01 s, 2e-11 m at 2.4e-6 s on 0.5 s of the four-bar); `run` takes
# it as well
LOOP_SOLVERS = ["GeneralizedAlpha"]
# Newton's relative and absolute tolerance on the implicit solvers' residuals (Exudyn's
# defaults: 1e-8 and 1e-10)
NEWTON_TOL = 1e-10


def supports(scene):
    """Whether the scene has an Exudyn model here."""
    if isinstance(scene, LoopScene):
        return True
    kinds = {link.joint for link in scene.links}
    return kinds == {"hinge_y"} or (kinds == {"free"} and len(scene.links) == 1)


def solvers(scene):
    """Exudyn's solvers for the scene: the explicit ones on trees and the free body, the
    implicit ones on closed loops (see the module doc)."""
    return LOOP_SOLVERS if isinstance(scene, LoopScene) else SOLVERS


def _settings(scene, h):
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(scene.duration / h))
    ss.timeIntegration.endTime = scene.duration
    ss.timeIntegration.verboseMode = 0
    ss.solutionSettings.writeSolutionToFile = False
    ss.solutionSettings.sensorsWritePeriod = scene.duration
    ss.displayStatistics = False
    ss.displayComputationTime = False
    ss.parallel.numberOfThreads = 1
    ss.timeIntegration.explicitIntegration.useLieGroupIntegration = True
    ss.timeIntegration.explicitIntegration.computeEndOfStepAccelerations = False
    return ss


def _loop_system(scene):
    """A closed-loop scene as an Exudyn system of 2-D rigid bodies and joints; returns the
    system container, the system and each body's node."""
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    nodes, objs = [], []
    for b in scene.bodies:
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[b.pos[0], b.pos[1], b.angle],
                                           initialVelocities=[b.vel[0], b.vel[1], b.omega]))
        obj = mbs.AddObject(ObjectRigidBody2D(physicsMass=b.mass, physicsInertia=b.inertia[2],
                                              nodeNumber=node))
        mass = mbs.AddMarker(MarkerBodyMass(bodyNumber=obj))
        mbs.AddLoad(LoadMassProportional(markerNumber=mass, loadVector=list(scene.gravity)))
        nodes.append(node)
        objs.append(obj)

    def marker(body, p, rigid):
        kind = MarkerBodyRigid if rigid else MarkerBodyPosition
        return mbs.AddMarker(kind(bodyNumber=ground if body < 0 else objs[body],
                                  localPosition=[p[0], p[1], 0.0]))

    for j in scene.joints:
        # a slide needs the orientation of both ends
        ma, mb = (marker(j.a, j.pa, j.kind == "slide"), marker(j.b, j.pb, j.kind == "slide"))
        if j.kind == "revolute":
            mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[ma, mb]))
        else:
            # the slide's axis in the ground's frame, its normal in the body's frame
            u = j.axis / np.linalg.norm(j.axis)
            c, s = np.cos(scene.bodies[j.b].angle), np.sin(scene.bodies[j.b].angle)
            normal = np.array([-u[1], u[0]])
            local = [c * normal[0] + s * normal[1], -s * normal[0] + c * normal[1], 0.0]
            mbs.AddObject(ObjectJointPrismatic2D(markerNumbers=[ma, mb],
                                                 axisMarker0=[u[0], u[1], 0.0],
                                                 normalMarker1=local, constrainRotation=True))
    mbs.Assemble()
    return sc, mbs, nodes


def _loop_state(scene, mbs, nodes):
    """The final poses and loop closure (the largest joint violation, from the scene's
    planar constraints) of an Exudyn loop system."""
    q = np.concatenate([np.array(mbs.GetNodeOutput(n, exu.OutputVariableType.Position))[:2]
                        .tolist() + [mbs.GetNodeOutput(n, exu.OutputVariableType.Rotation)[2]]
                        for n in nodes])
    loop = reference.PlanarLoop(scene)
    return loop.poses(q), loop.closure(q)


def loop_refusal(scene, solver="RK44"):
    """What Exudyn says when an explicit solver is asked to run the loop (its exception's
    text), or None if it runs."""
    sc, mbs, _ = _loop_system(scene)
    ss = _settings(scene, scene.duration / 100)
    try:
        mbs.SolveDynamic(ss, solverType=getattr(exu.DynamicSolverType, solver))
    except Exception as e:  # Exudyn raises a plain RuntimeError / ValueError
        # the message without the Python source location Exudyn appends
        return re.sub(r"\s*\[Python file [^\]]*\]", "", " ".join(str(e).split()))
    return None


def _run_loop(scene, h, solver):
    """(CPU seconds, final poses, loop closure) of one implicit run at step h."""
    sc, mbs, nodes = _loop_system(scene)
    ss = _settings(scene, h)
    ss.timeIntegration.newton.relativeTolerance = NEWTON_TOL
    ss.timeIntegration.newton.absoluteTolerance = NEWTON_TOL
    ss.timeIntegration.adaptiveStep = False
    kind = getattr(exu.DynamicSolverType, solver)
    t0 = time.process_time()
    try:
        ok = mbs.SolveDynamic(ss, solverType=kind)
    except exu.SolverError:  # Newton failed: the run counts as blown up
        ok = False
    cpu = time.process_time() - t0
    poses, closure = _loop_state(scene, mbs, nodes)
    if not ok:
        poses = [(np.full(3, np.nan), np.full((3, 3), np.nan)) for _ in poses]
        closure = float("nan")
    return cpu, poses, closure


def run(scene, h, solver):
    """(CPU seconds, final poses, loop closure: 0 without a loop) of one run at step h."""
    if isinstance(scene, LoopScene):
        return _run_loop(scene, h, solver)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    links = scene.links
    if links[0].joint == "hinge_y":
        n = len(links)
        node = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * n,
                                           initialCoordinates=[0.0] * n,
                                           initialCoordinates_t=[float(l.qd0[0]) for l in links],
                                           numberOfODE2Coordinates=n))
        mbs.AddObject(ObjectKinematicTree(
            nodeNumber=node,
            jointTypes=[exu.JointType.RevoluteY] * n,
            linkParents=[l.parent for l in links],
            jointTransformations=exu.Matrix3DList([l.rot for l in links]),
            jointOffsets=exu.Vector3DList([list(l.joint_pos) for l in links]),
            linkInertiasCOM=exu.Matrix3DList([np.diag(l.inertia) for l in links]),
            linkCOMs=exu.Vector3DList([list(l.com) for l in links]),
            linkMasses=[l.mass for l in links],
            gravity=list(scene.gravity)))
    else:
        link = links[0]
        body = mbs.CreateRigidBody(
            inertia=RigidBodyInertia(mass=link.mass, inertiaTensor=np.diag(link.inertia)),
            referencePosition=[0.0, 0.0, 0.0],
            initialVelocity=list(link.qd0[:3]),
            initialAngularVelocity=list(link.qd0[3:]),
            nodeType=exu.NodeType.RotationRotationVector,
            gravity=list(scene.gravity))
        node = mbs.GetObject(body)["nodeNumber"]
    mbs.Assemble()
    ss = _settings(scene, h)
    kind = getattr(exu.DynamicSolverType, solver)
    t0 = time.process_time()
    mbs.SolveDynamic(ss, solverType=kind)
    cpu = time.process_time() - t0
    if links[0].joint == "hinge_y":
        q = np.array(mbs.systemData.GetODE2Coordinates())
        model, ids = reference.build(scene)
        return cpu, reference.poses(scene, model, ids, q), 0.0
    pos = np.array(mbs.GetNodeOutput(node, exu.OutputVariableType.Position))
    rot = np.array(mbs.GetNodeOutput(node, exu.OutputVariableType.RotationMatrix)).reshape(3, 3)
    return cpu, [(pos, rot)], 0.0
