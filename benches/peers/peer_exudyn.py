"""Exudyn's side of the race, where Exudyn has an explicit integrator for the scene:

- planar chains: `ObjectKinematicTree` (minimal coordinates, O(n) articulated-body
  dynamics) with revolute-y joints;
- a free rigid body: a rigid-body node with rotation-vector coordinates, integrated on the
  Lie group (`useLieGroupIntegration`).

Explicit Runge–Kutta `RK44` and `RK67` at a fixed step, one thread, no solution file;
timed over `SolveDynamic` (the step loop runs in C++). Exudyn's kinematic tree has no
spherical joint, and its explicit solvers do not take the spherical joints of a
redundant-coordinate model, so the 3-D double pendulum has no Exudyn entry.
"""

import time

import exudyn as exu
import numpy as np
from exudyn.itemInterface import NodeGenericODE2, ObjectKinematicTree
from exudyn.utilities import RigidBodyInertia

import reference

SOLVERS = ["RK44", "RK67"]


def supports(scene):
    """Whether the scene has an Exudyn model here."""
    kinds = {link.joint for link in scene.links}
    return kinds == {"hinge_y"} or (kinds == {"free"} and len(scene.links) == 1)


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


def run(scene, h, solver):
    """(CPU seconds, final poses) of one run at step h."""
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
        return cpu, reference.poses(scene, model, ids, q)
    pos = np.array(mbs.GetNodeOutput(node, exu.OutputVariableType.Position))
    rot = np.array(mbs.GetNodeOutput(node, exu.OutputVariableType.RotationMatrix)).reshape(3, 3)
    return cpu, [(pos, rot)]
