"""The biophysics of astrocpg: one model per module, each an equation string and a parameter
table (name, value with unit, the paper's symbol, meaning). :class:`ModelSet` gathers the models
a network is built from; change a model with ``ModelSet.replace(...)`` or override parameter
values by name with ``ModelSet.with_values(...)``. Every model honours one contract,
:class:`~astrocpg.models.base.Model` (``kind``, ``code_field``, ``replace``, ``with_values``,
``with_code``, ``statements``, ``to_json``/``from_json``). Importing this package registers the
integration schemes of :mod:`~astrocpg.models.integration` with Brian2 by name.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

import brian2
import numpy as np

from ..errors import Field, InputError, did_you_mean, setting
from .units import example_value, parse_value, unit_spelling
from .alive import ALIVE
from .astrocyte import ASTROCYTE
from .energy import RL_POWER, SNN_POWER
from .base import (
    BrianModel,
    ExpressionModel,
    Interface,
    Model,
    NeuronModel,
    Parameter,
    ParameterTable,
    SynapseModel,
    WorldModel,
)
from .integration import INPUT_THEN_DECAY, register_method, registered_methods
from .hip_controller import HIP_CONTROLLER
from .interlimb_synapse import INTERLIMB_SYNAPSE
from .interneuron import INTERNEURON
from .interneuron_synapses import INTERNEURON_TO_POOL, POOL_TO_INTERNEURON
from .intra_pool_synapse import INTRA_POOL_SYNAPSE
from .motor_neuron import MOTOR_NEURON
from .pool import POOL, POOL_ACTIVITY
from .reward import REWARD
from .progress import LEARNING_START, PROGRESS
from .torque import TORQUE
from .world import WORLD


@dataclass(frozen=True, kw_only=True)
class ModelSet:
    """Every model the CPG, its astrocytes and its coupling are built from (defaults: the paper
    plus the facts it leaves out, docs/model.md). Parameter names are unique across the set, so
    an override ``NAME=VALUE`` (the ``overrides`` setting) is unambiguous.

    Compose one with :func:`astrocpg.models.compose.model_set` (model files, equation texts,
    ``NAME=VALUE`` overrides), once per command, and hand it down.

    **The one door for reading a parameter by name** is
    :meth:`~astrocpg.models.ModelSet.value`: ``models.value("L_max")`` is the value as a float
    in SI units (seconds here), and only a parameter its model's
    :data:`~astrocpg.models.INTERFACES` entry lists may be read so, so every model file is
    checked at load against everything the framework will read from it. Code outside
    ``models/`` never indexes ``.parameters[...]`` nor converts values itself
    (``tests/test_model_doors.py`` checks it). The framework sets parameters by name only with
    :meth:`~astrocpg.models.ModelSet.with_values` (or
    :meth:`~astrocpg.models.ModelSet.with_zeros`), also with names of the interface. Whole
    tables (a Brian2 group's namespace, the printed and exported tables) are read through the
    models themselves.
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
    world: WorldModel = WORLD

    #: the models of populations added to the network (a population file's neuron model,
    #: ``with_added``), after the slots: their parameters are the set's like any slot's, so
    #: ``overrides`` and the manifest's models reach them; ``items()`` yields them by their names
    added: tuple[NeuronModel, ...] = ()

    def __post_init__(self) -> None:
        owners: dict[str, str] = {}
        for f in _slots(self):
            model, kind = getattr(self, f.name), f.default.kind  # the default's kind
            if not isinstance(model, Model) or model.kind != kind:
                got = model.kind if isinstance(model, Model) else type(model).__name__
                raise InputError(f"must be a {kind} model, got {got}", culprit=f.name)
        taken = {f.name for f in _slots(self)}
        for model in self.added:
            if not isinstance(model, NeuronModel):
                got = model.kind if isinstance(model, Model) else type(model).__name__
                raise InputError(f"an added population's model must be a neuron model, got "
                                 f"{got}", culprit=str(getattr(model, "name", model)))
            if model.name in taken:
                raise InputError("is already a model of the set", culprit=model.name)
            taken.add(model.name)
        for model_name, model in self.items():
            for pname in model.parameters:
                if pname in owners:
                    raise InputError(f"is also declared by {owners[pname]}",
                                     culprit=f"{model_name}.{pname}")
                owners[pname] = model_name

    def items(self) -> Iterator[tuple[str, Model]]:
        """(name, model) of every slot, then of every added model (:attr:`added`)."""
        for f in _slots(self):
            yield f.name, getattr(self, f.name)
        for model in self.added:
            yield model.name, model

    def model(self, name: str) -> Model:
        """The model of slot ``name``, or the added model of that name (KeyError if none)."""
        for model_name, model in self.items():
            if model_name == name:
                return model
        raise KeyError(f"no model {name!r}")

    def with_added(self, *models: NeuronModel) -> "ModelSet":
        """A copy with the models of added populations (:attr:`added`) appended; a model the
        set already holds under that name is kept as it is (it may carry overridden values).
        A parameter named like one of the set's: InputError naming both."""
        have = {m.name for m in self.added}
        new = tuple(m for m in models if getattr(m, "name", None) not in have)
        if not new:
            return self
        return dataclasses.replace(self, added=self.added + new)

    def replace(self, **models: Model) -> "ModelSet":
        """A copy with whole models replaced (e.g. an edited equation string), slots or added
        models by name."""
        names = [f.name for f in _slots(self)]
        added = {m.name: m for m in self.added}
        for name in models:
            if name not in names and name not in added:
                raise InputError(f"unknown model{did_you_mean(name, [*names, *added])} "
                                 f"(models: {', '.join([*names, *added])})", culprit=name)
        slots = {k: v for k, v in models.items() if k in names}
        if any(k in added for k in models):
            slots["added"] = tuple(models.get(k, m) for k, m in added.items())
        return dataclasses.replace(self, **slots)

    def owner_of(self, parameter: str) -> str:
        for model_name, model in self.items():
            if parameter in model.parameters:
                return model_name
        known = [p for _, model in self.items() for p in model.parameters]
        raise InputError(f"unknown model parameter{did_you_mean(parameter, known)}",
                         culprit=parameter)

    def parameter(self, name: str) -> Parameter:
        """The declared parameter ``name`` (value with unit, symbol, meaning), whatever model
        owns it: for names a user gives (``overrides``, a worlds file's ``scale``). The framework
        reads its own names with :meth:`~astrocpg.models.ModelSet.value`."""
        return self.model(self.owner_of(name)).parameters[name]

    def value(self, name: str) -> float:
        """The value of parameter ``name`` as a float in SI units (``value("L_max")`` -> 10.0,
        seconds). Refuses a name its model's interface (:data:`~astrocpg.models.INTERFACES`) does
        not list: the interface is what a model file is checked against, so a read outside it
        could fail late, or read a parameter a file was free to drop."""
        owner = self.owner_of(name)
        declared = INTERFACES.get(owner, Interface()).readable()
        if name not in declared:
            raise InputError(f"is not in the {owner} model's interface (parameters the "
                             f"framework reads: {', '.join(declared) or 'none'}): declare it in "
                             f"the model's INTERFACE before reading it", culprit=f"{owner}.{name}")
        return float(np.asarray(self.parameter(name).value))

    def with_zeros(self, *names: str) -> "ModelSet":
        """A copy with these parameters set to zero, each in its own unit (e.g. the learning
        rates, so that weights stay fixed). Names must be in their model's interface."""
        for name in names:
            self.value(name)  # in the interface
        return self.with_values({name: 0 * self.parameter(name).value for name in names})

    def with_values(self, values: Mapping[str, Any]) -> "ModelSet":
        """A copy with parameter values replaced by name (units must match)."""
        per_model: dict[str, dict[str, Any]] = {}
        for pname, value in values.items():
            per_model.setdefault(self.owner_of(pname), {})[pname] = value
        return self.replace(
            **{m: self.model(m).with_values(**vals) for m, vals in per_model.items()}
        )

    def parse_assignment(self, text: str) -> tuple[str, Any]:
        """Parse ``NAME=VALUE`` (e.g. ``tau_motor=9*ms``, ``A_random=0.3``,
        ``C_K_chan=8 volt/second``). The value is parsed (numbers, Brian2 unit names and
        arithmetic on them: :func:`astrocpg.models.units.parse_value`), never evaluated."""
        name, sep, expr = (s.strip() for s in text.partition("="))
        if not sep or not name:
            raise InputError("expected NAME=VALUE", culprit=setting("overrides", f"'{text}'"))
        try:
            param = self.parameter(name)
        except InputError as e:  # name what the user typed: the option and the name
            raise InputError(e.raw_message, culprit=setting("overrides", name)) from None
        value = parse_value(expr, culprit=setting("overrides", name))
        if brian2.get_dimensions(value) != param.dimensions:
            raise InputError(f"needs units of {unit_spelling(param.value)}, e.g. "
                             f"{example_value(param.value)}; got '{expr}'",
                             culprit=setting("overrides", name))
        if param.positive and not float(np.asarray(value)) > 0:
            raise InputError(f"must be positive ({param.meaning}), got '{expr}'",
                             culprit=setting("overrides", name))
        return name, value

    def to_json(self) -> dict[str, Any]:
        """Each model's :meth:`~astrocpg.models.base.Model.to_json` by name: enough to rebuild
        the set with :meth:`from_json` (statements, method, initial values, parameters)."""
        slots = {f.name for f in _slots(self)}
        return {name: model.to_json() | ({} if name in slots else {"added": True})
                for name, model in self.items()}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "ModelSet":
        """The set :meth:`to_json` wrote (e.g. a manifest's ``"models"``). Models the data does
        not name keep their defaults."""
        if not isinstance(data, Mapping):
            raise InputError(f"expected a table of models, got {type(data).__name__}",
                             culprit="models")
        names = [f.name for f in _slots(cls)]
        models: dict[str, Any] = {}
        added = []
        for name, entry in data.items():
            if isinstance(entry, Mapping) and entry.get("added") is True:  # a population's
                added.append(Model.from_json({k: v for k, v in entry.items() if k != "added"},
                                             name=name))
                continue
            if name not in names:
                raise InputError(f"unknown model{did_you_mean(name, names)} (models: "
                                 f"{', '.join(names)})", culprit=name)
            models[name] = Model.from_json(entry, name=name)
        return cls(**models, added=tuple(added))


def _slots(cls_or_set: Any) -> tuple[dataclasses.Field, ...]:
    """The model slots of :class:`ModelSet` (every field but ``added``)."""
    return tuple(f for f in dataclasses.fields(cls_or_set) if f.name != "added")


DEFAULT_MODELS = ModelSet()


class _BuiltIn:
    """A default as a signature shows it: ``<built-in astrocyte>``, not the model's repr."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return f"<built-in {self.name}>"


def _short_signature(cls: type) -> None:
    """The class's signature with each model default shown by its name (the API reference
    printed every built-in model's repr, 32,000 characters, in ``ModelSet(...)``); what the
    class does is unchanged."""
    import inspect

    sig = inspect.signature(cls)
    cls.__signature__ = sig.replace(parameters=[
        p.replace(default=_BuiltIn(p.name)) if p.default is not inspect.Parameter.empty else p
        for p in sig.parameters.values()])


_short_signature(ModelSet)

from . import astrocyte as _astrocyte, interlimb_synapse as _interlimb  # noqa: E402
from . import motor_neuron as _motor, pool as _pool, torque as _torque  # noqa: E402
from . import world as _world, alive as _alive, reward as _reward  # noqa: E402
from . import hip_controller as _hip, progress as _session, energy as _energy  # noqa: E402

INTERFACES: dict[str, Interface] = {
    "motor_neuron": _motor.INTERFACE, "astrocyte": _astrocyte.INTERFACE, "pool": _pool.INTERFACE,
    "torque": _torque.INTERFACE, "interlimb_synapse": _interlimb.INTERFACE,
    "world": _world.INTERFACE, "alive": _alive.INTERFACE, "reward": _reward.INTERFACE,
    "hip_controller": _hip.INTERFACE, "progress": _session.PROGRESS_INTERFACE,
    "learning_start": _session.LEARNING_START_INTERFACE,
    "snn_power": _energy.SNN_POWER_INTERFACE, "rl_power": _energy.RL_POWER_INTERFACE,
}
"""Each model slot's :class:`~astrocpg.models.base.Interface`, declared in the model's module
as ``INTERFACE``: the variables the network reads or sets on its group, the inputs it gives an
expression model, and the parameters the framework reads
(:meth:`~astrocpg.models.ModelSet.value`) or sets by
name. A model file for the slot must declare all its variables and parameters and may use no
other inputs (``astrocpg.models.files.check_interface``). Slots without an entry (the
synapses the network only builds) offer nothing the framework reads by name."""

__all__ = [
    "ModelSet", "DEFAULT_MODELS", "INTERFACES", "Interface", "Model", "BrianModel", "NeuronModel",
    "SynapseModel", "ExpressionModel", "WorldModel", "Parameter", "ParameterTable",
    "INPUT_THEN_DECAY", "register_method", "registered_methods",
]
