"""The closed loop put together once: robot model, CPG, bridge, and the bridge's operation in the
network. ``run``, ``train``, ``power``, the gait and plot commands and the speed benchmark all
start from :func:`build_closed_loop`.

    loop = build_closed_loop(models, n_trials=4, seed=1)
    Training(loop.cpg, loop.bridge, models, n_sessions=10)   # optional: hooks itself in
    loop.run(5.0)                                            # Diverged comes out as itself
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import mujoco
import numpy as np
from brian2 import second

from ..errors import InputError
from ..models import ModelSet
from ..network import CPG, LEGS, build_cpg, check_runs, limb_stages, run_network
from ..network.populations import Population
from .bridge import Bridge
from .robot import A1Parameters, RobotLayout
from .world import World, add_disturbances, world_model


@dataclass
class ClosedLoop:
    """A CPG of ``n_trials`` copies driving as many robots through ``bridge``."""

    cpg: CPG
    robot: mujoco.MjModel
    robot_layout: RobotLayout
    bridge: Bridge
    models: ModelSet

    @property
    def n_trials(self) -> int:
        return self.cpg.n_trials

    def run(self, seconds: float, **kwargs: Any) -> None:
        """Run the network for ``seconds`` (one ``Network.run``); a divergence raises
        :class:`~astrocpg.errors.Diverged` itself (:func:`~astrocpg.network.run_network`)."""
        kwargs.setdefault("namespace", {})
        run_network(self.cpg.net, seconds * second, **kwargs)


def check_models(models: ModelSet, robot_params: A1Parameters | None = None) -> None:
    """What building the closed loop of ``models`` would refuse, found without building it
    (milliseconds): the world's values and its terrain's grid, and the inter-limb delays (they
    must order the limbs in stages, :func:`~astrocpg.network.limb_stages`). A study checks
    every point with it before any run starts. InputError naming the parameter."""
    params = robot_params if robot_params is not None else A1Parameters()
    World.from_models(models)
    limb_stages(models, LEGS, params.timestep * second)


def build_closed_loop(models: ModelSet, *, n_trials: int = 1, seed: int = 0,
                      weights: np.ndarray | None = None,
                      robot: mujoco.MjModel | None = None,
                      robot_layout: RobotLayout | None = None,
                      robot_params: A1Parameters | None = None,
                      on_step: Callable[[int], None] | None = None,
                      check_every: int = 10, check: bool = True,
                      codegen: str | None = None,
                      populations: Sequence[Population] | None = None) -> ClosedLoop:
    """Robot + CPG + bridge from settings, the bridge's operation added to the network.

    robot: None = the project's A1 in the world of ``models.world`` (slope, terrain, friction,
        payload: :func:`~astrocpg.coupling.world.world_model`), or an MjModel with the A1's
        joints and motors whose timestep is the CPG's step, used as it is (put a model of your
        own in the world with ``world_model(models, robot=...)`` first). The world's push and
        torque noise act every step either way (a bridge hook named ``world``).
    robot_layout: the robot's addresses (default: read from ``robot`` with ``robot_params``).
    robot_params: reset pose and, for the project's A1, the model itself (default A1Parameters()).
    weights: inter-limb tables, (8, 8) or (n_trials, 8, 8) volt (default zero).
    on_step, check_every: see :class:`Bridge`.
    check: prepare every Brian2 object first (:func:`check_runs`: one-line errors naming the
        model; nothing to do for the built-in models).
    codegen: Brian2's target, numpy or cython (default $ASTROCPG_CODEGEN, else numpy).
    populations: rows added to the built-in population table (the CPG is built from both:
        :func:`~astrocpg.network.build_cpg`).
    """
    params = robot_params if robot_params is not None else A1Parameters()
    model = world_model(models, params) if robot is None else robot
    if not model.opt.timestep > 0:
        raise InputError(f"robot timestep must be positive, got {model.opt.timestep}")
    layout = robot_layout if robot_layout is not None else RobotLayout.from_model(model, params)
    cpg = build_cpg(models, n_trials=n_trials, seed=seed, legs=LEGS,
                    dt=model.opt.timestep * second, interlimb_weights=weights, codegen=codegen,
                    populations=populations)
    if check:
        check_runs(cpg)
    bridge = Bridge(cpg, model, layout, models, on_step=on_step, check_every=check_every)
    add_disturbances(bridge, models)
    cpg.net.add(bridge.operation())
    return ClosedLoop(cpg=cpg, robot=model, robot_layout=layout, bridge=bridge, models=models)


__all__ = ["ClosedLoop", "build_closed_loop", "check_models"]
