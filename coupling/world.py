"""The world of ``models.world`` made physical: the ground (slope, heightfield, friction), the
payload on the torso, and the disturbances of every step (lateral push, torque noise).

Build-time parts change the MuJoCo model (:func:`world_model`); step-time parts are a bridge hook
(:func:`add_disturbances`), installed only when a push or torque noise is set, so the default
world costs nothing per step and leaves the robot's trajectory exactly as without it.
"""

from __future__ import annotations

import math
import dataclasses
from dataclasses import dataclass, field, fields

import mujoco
import numpy as np

from ..errors import InputError, setting
from ..models import ModelSet
from ..models.units import whole_steps
from ..models.world import (TERRAIN_FLAT_RADIUS, TERRAIN_RESOLUTION, TERRAIN_THICKNESS,
                            TERRAIN_X, TERRAIN_Y)
from ..network.cpg import trial_seeds
from ..network.noise import TrialNormals
from .robot import A1Parameters, build_spec

ORDER_WORLD = 5  # before_physics: the push and the torque noise act on this step's torques

_NON_NEGATIVE = {"non_negative": True}  # a World field that must not be negative


@dataclass(frozen=True, kw_only=True)
class World:
    """The world parameters as plain SI floats (see ``astrocpg.models.world``)."""

    slope: float
    terrain_height: float = field(metadata=_NON_NEGATIVE)
    terrain_length: float
    terrain_seed: int
    friction: float
    payload: float = field(metadata=_NON_NEGATIVE)
    push_force: float
    push_time: float = field(metadata=_NON_NEGATIVE)
    push_duration: float
    torque_noise: float = field(metadata=_NON_NEGATIVE)

    @classmethod
    def from_models(cls, models: ModelSet) -> "World":
        p = models.world.parameters
        for f in fields(cls):
            if f.name not in p:  # a world model file must declare every world parameter
                raise InputError("is missing from the world model (astrocpg models dump world "
                                 "shows them all)", culprit=f"world.{f.name}")
        # every world parameter through the door (the world's interface lists them all)
        raw = cls(**{f.name: models.value(f.name) for f in fields(cls)})
        seed = raw.terrain_seed
        if seed != int(seed) or seed < 0:
            raise InputError(f"must be a non-negative integer, got {seed:g}",
                             culprit="world.terrain_seed")
        world = dataclasses.replace(raw, terrain_seed=int(seed))
        for f in fields(cls):
            if f.metadata.get("non_negative") and getattr(world, f.name) < 0:
                raise InputError(f"must not be negative, got {getattr(world, f.name):g}",
                                 culprit=f"world.{f.name}")
        if not abs(world.slope) < math.pi / 2:
            raise InputError(f"must lie within (-pi/2, pi/2) rad, got {world.slope:g}",
                             culprit="world.slope")
        if world.terrain_height > 0:  # the heightfield's grid, refused before it is made
            res, nx, ny = terrain_grid(world.terrain_length)
            if res < MIN_TERRAIN_RESOLUTION:
                raise InputError(
                    f"a correlation length of {world.terrain_length:g} m needs a "
                    f"heightfield grid of {res:.3g} m ({nx} x {ny} = {nx * ny:.3g} cells); the "
                    f"finest grid is {MIN_TERRAIN_RESOLUTION * 100:g} cm, so terrain_length "
                    f"must be at least {4 * MIN_TERRAIN_RESOLUTION:g} m",
                    culprit="world.terrain_length")
        return world

    @property
    def disturbed(self) -> bool:
        """A push or torque noise acts during steps."""
        return self.push_force != 0.0 or self.torque_noise != 0.0


#: The finest heightfield grid (m): 4001 x 1001 cells over the terrain's 40 m x 10 m, a
#: terrain_length of 4 cm. A shorter correlation length would need a finer grid (the cells grow
#: as 1/length^2: 1 mm, a thousand times more) and is refused before anything is built.
MIN_TERRAIN_RESOLUTION = 0.01


def terrain_grid(length: float) -> tuple[float, int, int]:
    """(resolution m, columns along x, rows along y) of the heightfield for a correlation
    length ``length`` (m): 5 cm, finer for short lengths (4 cells per length)."""
    res = min(TERRAIN_RESOLUTION, length / 4)
    nx = int(round((TERRAIN_X[1] - TERRAIN_X[0]) / res)) + 1 if res > 0 else 0
    ny = int(round((TERRAIN_Y[1] - TERRAIN_Y[0]) / res)) + 1 if res > 0 else 0
    return res, nx, ny


def heightfield(world: World) -> np.ndarray:
    """Ground heights (rows along y, columns along x; m) of the rough terrain: white noise from
    ``terrain_seed`` filtered by a Gaussian kernel so that the heights' correlation falls to 1/e
    at ``terrain_length``, zero mean, RMS ``terrain_height``, flattened smoothly to 0 within
    ``TERRAIN_FLAT_RADIUS`` of the start so that the robot is not dropped onto a bump."""
    res, nx, ny = terrain_grid(world.terrain_length)
    white = np.random.default_rng(world.terrain_seed).standard_normal((ny, nx))
    # kernel exp(-2 r^2 / l^2) in space -> correlation exp(-r^2 / l^2)
    s = world.terrain_length / 2.0
    ky = 2 * np.pi * np.fft.fftfreq(ny, d=res)
    kx = 2 * np.pi * np.fft.rfftfreq(nx, d=res)
    gain = np.exp(-0.5 * s * s * (ky[:, None] ** 2 + kx[None, :] ** 2))
    h = np.fft.irfft2(np.fft.rfft2(white) * gain, s=(ny, nx))
    h -= h.mean()
    h *= world.terrain_height / h.std()
    x = np.linspace(TERRAIN_X[0], TERRAIN_X[1], nx)
    y = np.linspace(TERRAIN_Y[0], TERRAIN_Y[1], ny)
    r = np.hypot(x[None, :], y[:, None])
    window = np.clip((r - TERRAIN_FLAT_RADIUS) / TERRAIN_FLAT_RADIUS, 0.0, 1.0)
    return h * window * window * (3 - 2 * window)  # smoothstep: 0 at the start, 1 beyond 2 R


def _add_terrain(spec: mujoco.MjSpec, world: World) -> None:
    """Turn the floor plane of the project's A1 spec into the heightfield."""
    floor = spec.geom("floor")
    h = heightfield(world)
    lo, hi = float(h.min()), float(h.max())
    ny, nx = h.shape
    spec.add_hfield(name="terrain",
                    size=[(TERRAIN_X[1] - TERRAIN_X[0]) / 2, (TERRAIN_Y[1] - TERRAIN_Y[0]) / 2,
                          max(hi - lo, 1e-9), TERRAIN_THICKNESS],
                    nrow=ny, ncol=nx, userdata=((h - lo) / max(hi - lo, 1e-9)).ravel().tolist())
    # the floor plane becomes the heightfield (same name, friction, margin)
    floor.type = mujoco.mjtGeom.mjGEOM_HFIELD
    floor.hfieldname = "terrain"
    floor.pos = [(TERRAIN_X[0] + TERRAIN_X[1]) / 2, (TERRAIN_Y[0] + TERRAIN_Y[1]) / 2, lo]


def world_model(models: ModelSet, params: A1Parameters | None = None,
                robot: mujoco.MjModel | None = None) -> mujoco.MjModel:
    """The robot model in the world of ``models.world``: the project's A1 (``params``) or a
    given ``robot`` (modified in place; rough terrain needs the project's A1)."""
    world = World.from_models(models)
    if robot is None:
        spec = build_spec(params if params is not None else A1Parameters())
        if world.terrain_height > 0:
            _add_terrain(spec, world)
        model = spec.compile()
    else:
        if world.terrain_height > 0:
            raise InputError("rough terrain is built into the project's A1 model only; "
                             f"run without {setting('robot')} or with terrain_height=0",
                             culprit="world.terrain_height")
        model = robot
    apply_world(model, world)
    return model


def _ground_geoms(model: mujoco.MjModel) -> np.ndarray:
    return np.flatnonzero(model.geom_bodyid == 0)  # geoms of the world body


def apply_world(model: mujoco.MjModel, world: World) -> None:
    """Gravity tilted by the slope, the ground's friction, the payload (in place; a value at its
    default leaves the model untouched)."""
    if world.slope != 0.0:
        g = float(np.linalg.norm(model.opt.gravity))
        # uphill along +x: gravity pulls the robot back along -x
        model.opt.gravity[:] = (-g * math.sin(world.slope), 0.0, -g * math.cos(world.slope))
    ground = _ground_geoms(model)
    if len(ground) and np.any(model.geom_friction[ground, 0] != world.friction):
        model.geom_friction[ground, 0] = world.friction
        # MuJoCo takes the larger coefficient of two touching geoms unless one has priority:
        # the ground's coefficient is the contact's
        model.geom_priority[ground] = model.geom_priority.max() + 1
    if world.payload != 0.0:
        trunk = _trunk(model)
        model.body_mass[trunk] += world.payload  # a point mass at the torso's centre of mass
        mujoco.mj_setConst(model, mujoco.MjData(model))  # derived masses and inertias


def _trunk(model: mujoco.MjModel) -> int:
    free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    if not len(free):
        raise InputError("robot model has no free joint on the trunk")
    return int(model.jnt_bodyid[free[0]])


def add_disturbances(bridge, models: ModelSet) -> None:
    """Install the push and the torque noise of ``models.world`` as the bridge hook ``world``
    (before physics, :data:`ORDER_WORLD`); nothing when neither is set. The push acts from
    ``push_time`` after each trial's last reset (its session's start) for ``push_duration``."""
    world = World.from_models(models)
    if not world.disturbed:
        return
    trunk = _trunk(bridge.model)
    B, dt = bridge.n_trials, bridge.dt
    forces = [d.xfrc_applied[trunk] for d in bridge.data]  # views into each MjData
    on_step = whole_steps(world.push_time, dt, culprit="world.push_time", minimum=0)
    off_step = on_step + whole_steps(world.push_duration, dt, culprit="world.push_duration")
    # one stream per trial and actuator (network/noise.py): a trial's torque noise does not
    # depend on its batch, and a replayed session gets its own (the network's step offset)
    cpg = bridge.cpg
    act = bridge.actuators.ravel()
    noise = (TrialNormals("torque_disturbance", trial_seeds(cpg.seed, B), len(act), cpg.noise_offset)
             if world.torque_noise else None)
    push, sigma, ctrl = world.push_force, world.torque_noise, bridge.ctrl

    def disturb() -> None:
        if push:
            k = bridge.step_count - bridge.session_start  # steps since each trial's reset
            on = (k >= on_step) & (k < off_step)
            for b in range(B):
                forces[b][1] = push if on[b] else 0.0
        if noise is not None:
            # the step being taken: bridge.step_count counts the steps done before it
            ctrl[:, act] *= 1.0 + sigma * noise.draw(bridge.step_count)

    bridge.add_hook("before_physics", "world", disturb, order=ORDER_WORLD)


__all__ = ["World", "ORDER_WORLD", "MIN_TERRAIN_RESOLUTION", "terrain_grid", "heightfield",
           "world_model", "apply_world",
           "add_disturbances"]
