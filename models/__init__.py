"""The biophysics of astrocpg: one model per module, each an equation string and a parameter
table (name, value with unit, the paper's symbol, meaning). :class:`ModelSet` gathers the models
a network is built from; change a model with ``ModelSet.replace(...)`` or override parameter
values by name with ``ModelSet.with_values(...)``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

import brian2
import numpy as np

from ..errors import InputError
from .values import example_value, parse_value, unit_spelling
from .alive import ALIVE
from .astrocyte import ASTROCYTE
from .energy import RL_POWER, SNN_POWER
from .base import ExpressionModel, NeuronModel, Parameter, ParameterTable, SynapseModel
from .hip_controller import HIP_CONTROLLER
from .interlimb_synapse import INTERLIMB_SYNAPSE
from .interneuron import INTERNEURON
from .interneuron_synapses import INTERNEURON_TO_POOL, POOL_TO_INTERNEURON
from .intra_pool_synapse import INTRA_POOL_SYNAPSE
from .motor_neuron import MOTOR_NEURON
from .pool import POOL, POOL_ACTIVITY
from .reward import REWARD
from .session import LEARNING_START, PROGRESS
from .torque import TORQUE

Model = NeuronModel | SynapseModel | ExpressionModel


@dataclass(frozen=True, kw_only=True)
class ModelSet:
    """Every model the CPG, its astrocytes and its coupling are built from (defaults: the paper
    plus SPEC). Parameter names are unique across the set, so ``--set NAME=VALUE`` is unambiguous.
    """

    motor_neuron: NeuronModel = MOTOR_NEURON
    interneuron: NeuronModel = INTERNEURON
    astrocyte: NeuronModel = ASTROCYTE
    torque: NeuronModel = TORQUE
    pool: NeuronModel = POOL
    pool_activity: SynapseModel = POOL_ACTIVITY
    intra_pool_synapse: SynapseModel = INTRA_POOL_SYNAPSE
    pool_to_interneuron: SynapseModel = POOL_TO_INTERNEURON
    interneuron_to_pool: SynapseModel = INTERNEURON_TO_POOL
    interlimb_synapse: SynapseModel = INTERLIMB_SYNAPSE
    hip_controller: ExpressionModel = HIP_CONTROLLER
    reward: ExpressionModel = REWARD
    alive: ExpressionModel = ALIVE
    progress: ExpressionModel = PROGRESS
    learning_start: ExpressionModel = LEARNING_START
    snn_power: ExpressionModel = SNN_POWER
    rl_power: ExpressionModel = RL_POWER

    def __post_init__(self) -> None:
        owners: dict[str, str] = {}
        for model_name, model in self.items():
            for pname in model.parameters:
                if pname in owners:
                    raise InputError(
                        f"{model_name}: parameter '{pname}' is also declared by {owners[pname]}"
                    )
                owners[pname] = model_name

    def items(self) -> Iterator[tuple[str, Model]]:
        for f in dataclasses.fields(self):
            yield f.name, getattr(self, f.name)

    def replace(self, **models: Model) -> "ModelSet":
        """A copy with whole models replaced (e.g. an edited equation string)."""
        for name in models:
            if name not in {f.name for f in dataclasses.fields(self)}:
                raise InputError(f"ModelSet: unknown model '{name}'")
        return dataclasses.replace(self, **models)

    def owner_of(self, parameter: str) -> str:
        for model_name, model in self.items():
            if parameter in model.parameters:
                return model_name
        raise InputError(f"unknown model parameter '{parameter}'")

    def parameter(self, name: str) -> Parameter:
        return getattr(self, self.owner_of(name)).parameters[name]

    def with_values(self, values: Mapping[str, Any]) -> "ModelSet":
        """A copy with parameter values replaced by name (units must match)."""
        per_model: dict[str, dict[str, Any]] = {}
        for pname, value in values.items():
            per_model.setdefault(self.owner_of(pname), {})[pname] = value
        return self.replace(
            **{m: getattr(self, m).with_values(**vals) for m, vals in per_model.items()}
        )

    def parse_assignment(self, text: str) -> tuple[str, Any]:
        """Parse ``NAME=VALUE`` (e.g. ``tau_motor=9*ms``, ``A_random=0.3``,
        ``C_K_chan=8 volt/second``). The value is parsed (numbers, Brian2 unit names and
        arithmetic on them: :func:`astrocpg.models.values.parse_value`), never evaluated."""
        name, sep, expr = (s.strip() for s in text.partition("="))
        if not sep or not name:
            raise InputError("expected NAME=VALUE", culprit=f"--set '{text}'")
        param = self.parameter(name)
        value = parse_value(expr, culprit=f"--set {name}")
        if brian2.get_dimensions(value) != param.dimensions:
            raise InputError(f"needs units of {unit_spelling(param.value)}, e.g. "
                             f"{example_value(param.value)}; got '{expr}'",
                             culprit=f"--set {name}")
        if param.positive and not float(np.asarray(value)) > 0:
            raise InputError(f"must be positive ({param.meaning}), got '{expr}'",
                             culprit=f"--set {name}")
        return name, value

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name, model in self.items():
            entry: dict[str, Any] = {"parameters": model.parameters.to_json()}
            for attr in ("equations", "model", "expression", "threshold", "reset", "on_pre",
                         "weight", "on_step", "refractory"):
                val = getattr(model, attr, None)
                if val:
                    entry[attr] = val
            out[name] = entry
        return out


DEFAULT_MODELS = ModelSet()

__all__ = [
    "ModelSet", "DEFAULT_MODELS", "NeuronModel", "SynapseModel", "ExpressionModel", "Parameter",
    "ParameterTable",
]
