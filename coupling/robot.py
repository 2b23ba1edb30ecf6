"""The project's own Unitree A1 model, built with ``mujoco.MjSpec`` from the published figures
(Unitree's A1 masses, inertias and link dimensions) and the paper's modifications (joint limits,
frictionloss, start height, torque motors). Collision geometry is primitive (boxes, cylinders,
foot spheres), as in the A1's published collision model; there are no meshes.

The A1's public interface, which any user-supplied MJCF must share: joints
``{leg}_{joint}_joint`` and motors ``{leg}_{joint}`` for legs FR, FL, RR, RL and joints hip,
thigh, calf, and a free joint on the trunk.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from ..errors import EnvironmentFault, InputError, setting
from ..support.reading import check_regular

def quiet_mujoco_log() -> None:
    """MuJoCo's default warning handler appends every warning to ``MUJOCO_LOG.TXT`` in the
    working folder and prints it on stdout. Route its warnings to the ``astrocpg.mujoco``
    logger instead (debug level; instability is read from ``MjData.warning``, see the bridge).
    Idempotent; called wherever a robot is built or loaded."""
    global _QUIET
    if not _QUIET:
        log = logging.getLogger("astrocpg.mujoco")
        mujoco.set_mju_user_warning(lambda msg: log.debug("MuJoCo warning: %s", msg))
        _QUIET = True


_QUIET = False

LEGS = ("FR", "FL", "RR", "RL")
JOINTS = ("hip", "thigh", "calf")
JOINT_NAMES = tuple(f"{leg}_{j}_joint" for leg in LEGS for j in JOINTS)
ACTUATOR_NAMES = tuple(f"{leg}_{j}" for leg in LEGS for j in JOINTS)


@dataclass(kw_only=True, frozen=True)
class A1Parameters:
    """The robot and simulation settings of the paper (supplementary, Table II)
    and docs/model.md, "The robot".

    start_height: torso height at reset, m (paper: 0.35, modified from Unitree's 0.3).
    thigh_range_front, thigh_range_rear, calf_range: joint limits, rad (paper, modified from the
        manufacturer's for better gait formation); hip_range: Unitree's hip limits, rad.
    frictionloss_thigh, frictionloss_calf, frictionloss_hip: joint dry friction, N m (paper).
    frictionloss_free_joint: dry friction on the torso's six free degrees of freedom (docs/model.md: the
        authors' model gave the free joint the default joint frictionloss of 10; the published
        results were obtained with it).
    joint_damping, joint_armature: for every joint, free joint included (authors' model).
    motor_range: torque limit of the 12 motors, N m (Unitree A1: 33.5).
    timestep: physics step, s (paper: 1000 Hz, the CPG's step too).
    solver_iterations: Newton solver iterations (authors' model: 50).
    gravity: m/s^2 (authors' model: 9.806).
    friction: sliding, torsional, rolling friction of every geom (authors' model).
    geom_margin: contact margin of every geom, m (authors' model).
    reset_lower_weight: reset angle of thigh and calf = w*lower + (1-w)*upper limit (paper 0.7).
    """

    start_height: float = 0.35
    thigh_range_front: tuple[float, float] = (0.6, 1.4)
    thigh_range_rear: tuple[float, float] = (0.7, 1.5)
    calf_range: tuple[float, float] = (-1.6, -1.0)
    hip_range: tuple[float, float] = (-0.802851, 0.802851)
    frictionloss_thigh: float = 25.0
    frictionloss_calf: float = 10.0
    frictionloss_hip: float = 10.0
    frictionloss_free_joint: float = 10.0
    joint_damping: float = 0.01
    joint_armature: float = 0.01
    motor_range: float = 33.5
    timestep: float = 0.001
    solver_iterations: int = 50
    gravity: float = 9.806
    friction: tuple[float, float, float] = (0.6, 0.3, 0.3)
    geom_margin: float = 0.001
    reset_lower_weight: float = 0.7

    def __post_init__(self) -> None:
        for name in ("start_height", "motor_range", "timestep", "solver_iterations"):
            if not getattr(self, name) > 0:
                raise InputError(f"A1Parameters.{name} must be positive, got {getattr(self, name)}")
        for name in ("thigh_range_front", "thigh_range_rear", "calf_range", "hip_range"):
            lo, hi = getattr(self, name)
            if not lo < hi:
                raise InputError(f"A1Parameters.{name} must have lower < upper, got {(lo, hi)}")
        if not 0.0 <= self.reset_lower_weight <= 1.0:
            raise InputError("A1Parameters.reset_lower_weight must lie in [0, 1]")


# ---- Unitree A1 published physical figures (SI units). Mirrored legs: side = +1 left, -1 right;
# end = +1 front, -1 rear.
_TRUNK = dict(mass=4.714, ipos=(0.0127283, 0.00218554, 0.000514891),
              iquat=(0.00186575, 0.711506, 0.000389649, 0.702677),
              inertia=(0.0648213, 0.0565803, 0.0169323), box=(0.1335, 0.066, 0.057))
_HIP_OFFSET = (0.183, 0.047)  # hip joint from trunk origin: (end*x, side*y)
_HIP_MASS, _HIP_INERTIA = 0.696, (0.000807752, 0.00055293, 0.000468983)
_HIP_IQUAT = {  # principal axes of each hip (the mirrored parts have mirrored frames)
    "FR": (0.507528, 0.506268, 0.491507, 0.494499), "FL": (0.494499, 0.491507, 0.506268, 0.507528),
    "RR": (0.491507, 0.494499, 0.507528, 0.506268), "RL": (0.506268, 0.507528, 0.494499, 0.491507),
}
_HIP_COM = (0.003311, 0.000635, 3.1e-05)  # (-end*x, side*y, z)
_HIP_CYLINDER = (0.04, 0.04, 0.055)  # radius, half-length, lateral offset (side*y)
_THIGH_OFFSET = 0.08505  # thigh joint from hip joint, side*y
_THIGH_MASS, _THIGH_INERTIA = 1.013, (0.00555739, 0.00513936, 0.00133944)
_THIGH_COM = (-0.003237, 0.022327, -0.027326)  # (x, -side*y, z)
_THIGH_IQUAT = (0.999125, 0.00256393, -0.0409531, 0.00806091)  # (w, side*x, y, side*z)
_THIGH_BOX = (0.1, 0.01225, 0.017)  # along the link, centred 0.1 m below the joint
_LINK_LENGTH = 0.2  # thigh and calf
_CALF_MASS, _CALF_INERTIA = 0.226, (0.00340344, 0.00339393, 3.54834e-05)
_CALF_COM = (0.00472659, 0.0, -0.131975)
_CALF_IQUAT = (0.706886, 0.017653, 0.017653, 0.706886)
_CALF_BOX = (0.1, 0.008, 0.008)
_FOOT_RADIUS = 0.02
_ALONG_LINK = (0.7071068, 0.0, 0.7071068, 0.0)  # box x axis along the link (-z)


def _side(leg: str) -> int:
    return 1 if leg[1] == "L" else -1


def _end(leg: str) -> int:
    return 1 if leg[0] == "F" else -1


def build_spec(params: A1Parameters = A1Parameters()) -> mujoco.MjSpec:
    """The A1 as an ``MjSpec``: floor, trunk with free joint, 4 legs, 12 torque motors, sensors."""
    quiet_mujoco_log()
    spec = mujoco.MjSpec()
    spec.modelname = "astrocpg_a1"
    spec.compiler.degree = False
    spec.option.timestep = params.timestep
    spec.option.gravity = [0.0, 0.0, -params.gravity]
    spec.option.iterations = params.solver_iterations
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON

    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.85, 0.9, 0.85],
                     rgb2=[0.7, 0.8, 0.7], width=512, height=512)
    spec.add_material(name="floor", textures=["", "grid"], texrepeat=[8, 8], texuniform=True)
    world = spec.worldbody
    world.add_light(name="sun", pos=[0, 0, 10], dir=[0, 0, -1],
                    type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, castshadow=0,
                    diffuse=[0.8, 0.8, 0.8])
    world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1],
                   material="floor", friction=list(params.friction), margin=params.geom_margin,
                   condim=3)

    def geom(body, **kw):
        return body.add_geom(friction=list(params.friction), margin=params.geom_margin,
                             contype=1, conaffinity=1, **kw)

    def joint(body, name, axis, rng, frictionloss):
        return body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis,
                              range=list(rng), limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                              frictionloss=frictionloss, damping=params.joint_damping,
                              armature=params.joint_armature)

    trunk = world.add_body(name="trunk", pos=[0, 0, params.start_height])
    trunk.explicitinertial = True
    trunk.mass, trunk.ipos, trunk.iquat = _TRUNK["mass"], list(_TRUNK["ipos"]), list(_TRUNK["iquat"])
    trunk.inertia = list(_TRUNK["inertia"])
    trunk.add_joint(name="trunk_free", type=mujoco.mjtJoint.mjJNT_FREE,
                    frictionloss=params.frictionloss_free_joint, damping=params.joint_damping,
                    armature=params.joint_armature)
    geom(trunk, name="trunk", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(_TRUNK["box"]),
         rgba=[0.9, 0.9, 0.85, 1])
    trunk.add_site(name="imu", pos=[0, 0, 0])
    trunk.add_camera(name="track", mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM,
                     pos=[-1.0, -0.2, 0.7], xyaxes=[0.2, -1, 0, 0.6, 0.1, 1])

    for leg in LEGS:
        s, e = _side(leg), _end(leg)
        thigh_range = params.thigh_range_front if e > 0 else params.thigh_range_rear
        hip = trunk.add_body(name=f"{leg}_hip", pos=[e * _HIP_OFFSET[0], s * _HIP_OFFSET[1], 0])
        hip.explicitinertial = True
        hip.mass, hip.inertia = _HIP_MASS, list(_HIP_INERTIA)
        hip.ipos = [-e * _HIP_COM[0], s * _HIP_COM[1], _HIP_COM[2]]
        hip.iquat = list(_HIP_IQUAT[leg])
        joint(hip, f"{leg}_hip_joint", [1, 0, 0], params.hip_range, params.frictionloss_hip)
        r, half, off = _HIP_CYLINDER
        geom(hip, name=f"{leg}_hip", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[r, half, 0],
             pos=[0, s * off, 0], quat=[0.7071068, 0.7071068, 0, 0], rgba=[0.9, 0.9, 0.85, 1])

        thigh = hip.add_body(name=f"{leg}_thigh", pos=[0, s * _THIGH_OFFSET, 0])
        thigh.explicitinertial = True
        thigh.mass, thigh.inertia = _THIGH_MASS, list(_THIGH_INERTIA)
        thigh.ipos = [_THIGH_COM[0], -s * _THIGH_COM[1], _THIGH_COM[2]]
        w, x, y, z = _THIGH_IQUAT
        thigh.iquat = [w, s * x, y, s * z]
        joint(thigh, f"{leg}_thigh_joint", [0, 1, 0], thigh_range, params.frictionloss_thigh)
        geom(thigh, name=f"{leg}_thigh", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(_THIGH_BOX),
             pos=[0, 0, -_LINK_LENGTH / 2], quat=list(_ALONG_LINK), rgba=[0.9, 0.9, 0.85, 1])

        calf = thigh.add_body(name=f"{leg}_calf", pos=[0, 0, -_LINK_LENGTH])
        calf.explicitinertial = True
        calf.mass, calf.inertia = _CALF_MASS, list(_CALF_INERTIA)
        calf.ipos, calf.iquat = list(_CALF_COM), list(_CALF_IQUAT)
        joint(calf, f"{leg}_calf_joint", [0, 1, 0], params.calf_range, params.frictionloss_calf)
        geom(calf, name=f"{leg}_calf", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(_CALF_BOX),
             pos=[0, 0, -_LINK_LENGTH / 2], quat=list(_ALONG_LINK), rgba=[0.2, 0.2, 0.2, 1])
        geom(calf, name=f"{leg}_foot", type=mujoco.mjtGeom.mjGEOM_SPHERE,
             size=[_FOOT_RADIUS, 0, 0], pos=[0, 0, -_LINK_LENGTH], rgba=[0.1, 0.1, 0.1, 1])
        calf.add_site(name=f"{leg}_foot", pos=[0, 0, -_LINK_LENGTH], size=[_FOOT_RADIUS * 1.05, 0, 0])

    for leg in LEGS:
        for j in JOINTS:
            spec.add_actuator(name=f"{leg}_{j}", target=f"{leg}_{j}_joint",
                              trntype=mujoco.mjtTrn.mjTRN_JOINT, gear=[1, 0, 0, 0, 0, 0],
                              ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
                              ctrlrange=[-params.motor_range, params.motor_range])

    S, O = mujoco.mjtSensor, mujoco.mjtObj
    for leg in LEGS:
        for j in JOINTS:
            spec.add_sensor(name=f"{leg}_{j}_angle", type=S.mjSENS_JOINTPOS,
                            objtype=O.mjOBJ_JOINT, objname=f"{leg}_{j}_joint")
    for leg in LEGS:
        for j in JOINTS:
            spec.add_sensor(name=f"{leg}_{j}_angular_velocity", type=S.mjSENS_JOINTVEL,
                            objtype=O.mjOBJ_JOINT, objname=f"{leg}_{j}_joint")
    spec.add_sensor(name="torso_gyro", type=S.mjSENS_GYRO, objtype=O.mjOBJ_SITE, objname="imu")
    for name, kind in (("torso_position", S.mjSENS_FRAMEPOS),
                       ("torso_orientation", S.mjSENS_FRAMEQUAT),
                       ("torso_velocity", S.mjSENS_FRAMELINVEL),
                       ("torso_z_axis", S.mjSENS_FRAMEZAXIS)):
        spec.add_sensor(name=name, type=kind, objtype=O.mjOBJ_SITE, objname="imu")
    for leg in LEGS:
        spec.add_sensor(name=f"{leg}_foot_touch", type=S.mjSENS_TOUCH, objtype=O.mjOBJ_SITE,
                        objname=f"{leg}_foot")
    return spec


def build_model(params: A1Parameters = A1Parameters()) -> mujoco.MjModel:
    return build_spec(params).compile()


def a1_xml(params: A1Parameters = A1Parameters()) -> str:
    """The A1 as MJCF text (what :func:`export_xml` writes)."""
    spec = build_spec(params)
    spec.compile()
    return spec.to_xml()


def export_xml(path: str | os.PathLike, params: A1Parameters = A1Parameters()) -> None:
    """Write the A1 as MJCF (opens in MuJoCo's viewer; loads as a run's ``robot``)."""
    Path(path).write_text(a1_xml(params))


def load_robot(path: str | os.PathLike) -> mujoco.MjModel:
    """Load a user MJCF that has the A1's joints, motors and a free trunk; one-line errors."""
    quiet_mujoco_log()
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"expected the path of an MJCF file, got {type(path).__name__}",
                         culprit="robot")
    p = Path(path)
    check_regular(p, setting("robot", p))  # a FIFO is refused, never waited on
    if not os.path.lexists(p):  # a missing input: the environment's (exit 1)
        raise EnvironmentFault("no such file", culprit=setting("robot", p))
    if not p.is_file():
        raise InputError("is not a file", culprit=setting("robot", p))
    try:
        model = mujoco.MjModel.from_xml_path(str(p))
    except Exception as e:  # MuJoCo raises ValueError with a multi-line message
        first = " ".join(str(e).strip().splitlines()[:2]) or type(e).__name__
        raise InputError(f"not a valid MJCF model ({first})",
                         culprit=setting("robot", p.name)) from None
    names = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, k) for k in range(model.njnt)}
    missing = [n for n in JOINT_NAMES if n not in names]
    if missing:
        raise InputError(f"lacks the A1 joint(s) {', '.join(missing[:3])}"
                         f"{' ...' if len(missing) > 3 else ''}", culprit=setting("robot", p.name))
    acts = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, k) for k in range(model.nu)}
    missing = [n for n in ACTUATOR_NAMES if n not in acts]
    if missing:
        raise InputError(f"lacks the A1 motor(s) {', '.join(missing[:3])}"
                         f"{' ...' if len(missing) > 3 else ''}", culprit=setting("robot", p.name))
    if _free_joint(model) is None:
        raise InputError("has no free joint on the trunk", culprit=setting("robot", p.name))
    return model


def _free_joint(model: mujoco.MjModel) -> int | None:
    for k in range(model.njnt):
        if model.jnt_type[k] == mujoco.mjtJoint.mjJNT_FREE:
            return k
    return None


@dataclass
class RobotLayout:
    """Addresses of the A1's joints and motors in a model, as index arrays for the hot loop."""

    qpos_adr: np.ndarray  # (4, 3) [leg, joint]
    dof_adr: np.ndarray  # (4, 3)
    actuator: np.ndarray  # (4, 3)
    joint_range: np.ndarray  # (4, 3, 2) rad, from the model
    free_qpos_adr: int
    free_dof_adr: int
    trunk_body: int
    reset_qpos: np.ndarray = field(repr=False)
    touch_adr: np.ndarray | None = None  # (4,) sensordata addresses of foot touch sensors

    @classmethod
    def from_model(cls, model: mujoco.MjModel,
                   params: A1Parameters = A1Parameters()) -> "RobotLayout":
        J = mujoco.mjtObj.mjOBJ_JOINT
        jid = np.array([[mujoco.mj_name2id(model, J, f"{leg}_{j}_joint") for j in JOINTS]
                        for leg in LEGS])
        act = np.array([[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{leg}_{j}")
                         for j in JOINTS] for leg in LEGS])
        if (jid < 0).any() or (act < 0).any():
            raise InputError("robot model lacks A1 joint or motor names")
        free = _free_joint(model)
        if free is None:
            raise InputError("robot model has no free joint on the trunk")
        ranges = model.jnt_range[jid]  # (4, 3, 2)
        qpos0 = model.qpos0.copy()
        fq = int(model.jnt_qposadr[free])
        qpos0[fq:fq + 3] = [0.0, 0.0, params.start_height]
        qpos0[fq + 3:fq + 7] = [1.0, 0.0, 0.0, 0.0]
        w = params.reset_lower_weight
        qadr = model.jnt_qposadr[jid]
        for leg in range(4):
            qpos0[qadr[leg, 0]] = 0.0
            for j in (1, 2):  # thigh and calf: weighted sum of their limits (paper)
                lo, hi = ranges[leg, j]
                qpos0[qadr[leg, j]] = w * lo + (1 - w) * hi
        touch = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, f"{leg}_foot_touch")
                 for leg in LEGS]
        touch_adr = (np.array([model.sensor_adr[k] for k in touch], dtype=np.intp)
                     if min(touch) >= 0 else None)
        return cls(qpos_adr=qadr.astype(np.intp), dof_adr=model.jnt_dofadr[jid].astype(np.intp),
                   actuator=act.astype(np.intp), joint_range=ranges.copy(), free_qpos_adr=fq,
                   free_dof_adr=int(model.jnt_dofadr[free]),
                   trunk_body=int(model.jnt_bodyid[free]), reset_qpos=qpos0, touch_adr=touch_adr)


def reset(model: mujoco.MjModel, data: mujoco.MjData, layout: RobotLayout) -> None:
    """Start pose of a session: trunk at the start height, legs at the paper's reset angles."""
    mujoco.mj_resetData(model, data)
    data.qpos[:] = layout.reset_qpos
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
