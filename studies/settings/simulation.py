"""The settings of ``unit`` and ``run`` as typed values: frozen, checked when built (the
checks of :mod:`.checks`, each naming its setting), the manifest's ``settings`` record
(:meth:`UnitSettings.record`) and read back from it (:meth:`UnitSettings.from_record`), so that
what a folder says it ran is the value that ran."""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping

from ...errors import InputError, setting
from .populations import population_table
from .checks import (STEP, check_duration, check_selection, check_trace_dt, check_trace_dtype,
                     names_list, number, seed_number)


def _names(value: Any, name: str) -> tuple[str, ...] | None:
    """A recording selection as one value whichever way it was given (None: everything; a
    text of names separated by commas, "none"; a list of names): the names, in order. The
    command line's text ``motor`` and Python's ``spikes="motor"`` or ``["motor"]`` are one
    setting, recorded alike."""
    return None if value is None else names_list(value, setting(name))


def _frozen_mapping(value: Any, name: str) -> dict[str, Any]:
    """A mapping setting (``equations``, ``models``, ``populations``) as a dict; anything else
    (a hand-edited manifest's text, say) refused naming the setting."""
    if not value:
        return {}
    if not isinstance(value, Mapping):
        raise InputError(f"expected a mapping, got {type(value).__name__}", culprit=setting(name))
    return {str(k): v for k, v in value.items()}


@dataclasses.dataclass(frozen=True)
class UnitSettings:
    """What one ``unit`` simulates (``astrocpg unit``, ``ac.unit``): simulated ``seconds``, the
    ``seed`` of trial 0 and the number of ``trials``, the trace sampling (``trace_dt`` in ms,
    ``trace_dtype``), what is recorded (``spikes``, ``traces``; None: everything), and the model
    changes: ``overrides`` ("name=value" texts), ``equations`` ({model: text}), ``models``
    ({model: {"sha256", "content"}} of model files) and ``populations`` (the same, of added
    populations)."""

    seconds: float
    seed: int
    trials: int
    trace_dt: float = 1.0
    trace_dtype: str = "float32"
    overrides: tuple[str, ...] = ()
    equations: dict[str, str] = dataclasses.field(default_factory=dict)
    spikes: tuple[str, ...] | None = None
    traces: tuple[str, ...] | None = None
    models: dict[str, Any] = dataclasses.field(default_factory=dict)
    populations: dict[str, Any] = dataclasses.field(default_factory=dict)

    #: the record's keys in the order the manifest writes them
    RECORD = ("seconds", "seed", "trials", "trace_dt", "trace_dtype", "overrides", "equations",
              "spikes", "traces")

    def __post_init__(self) -> None:
        """Checked when built, however built: a value that exists is one a command runs."""
        set_ = object.__setattr__
        set_(self, "seconds", number(self.seconds, setting("seconds"), positive=True))
        check_duration(self.seconds, STEP)
        set_(self, "trials", number(self.trials, setting("trials"), integer=True, minimum=1))
        set_(self, "seed", seed_number(self.seed, setting("seed"), trials=self.trials))
        set_(self, "trace_dt", number(self.trace_dt, setting("trace_dt"), positive=True))
        check_trace_dt(self.trace_dt)  # samples are taken at steps: a whole number of them
        set_(self, "trace_dtype", check_trace_dtype(self.trace_dtype))
        set_(self, "overrides", tuple(str(o) for o in (self.overrides or ())))
        set_(self, "equations", _frozen_mapping(self.equations, "equations"))
        set_(self, "models", _frozen_mapping(self.models, "models"))
        set_(self, "populations", _frozen_mapping(self.populations, "populations"))
        set_(self, "spikes", _names(self.spikes, "spikes"))
        set_(self, "traces", _names(self.traces, "traces"))
        # the names its network can record: the built-in populations and its added ones
        check_selection(self.spikes, self.traces, population_table(self.populations))

    def record(self) -> dict[str, Any]:
        """The manifest's ``settings``: every field (``models`` and ``populations`` only where
        given), JSON-ready."""
        out = {k: _plain(getattr(self, k)) for k in self.RECORD}
        out.update(self._extra_record())
        if self.models:
            out["models"] = dict(self.models)  # each model file's content and sha256
        if self.populations:
            out["populations"] = dict(self.populations)  # each added population's file
        return out

    def _extra_record(self) -> dict[str, Any]:
        return {}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> "UnitSettings":
        """The value a manifest's ``settings`` record (:meth:`record`), checked again."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(record) - names)
        if unknown:
            raise InputError(f"records settings this version does not know: "
                             f"{', '.join(unknown)}", culprit="manifest settings")
        return cls(**{k: v for k, v in record.items()})


@dataclasses.dataclass(frozen=True)
class RunSettings(UnitSettings):
    """What one ``run`` simulates (``astrocpg run``, ``ac.run``): a unit's settings, and the
    robot (``robot``: an MJCF file, None: the project's A1; ``robot_stride``: physics steps
    between robot samples), the inter-limb tables (``weights``: the file or training folder
    they came from, None: zero or an array; ``trial``: a training's trial; ``tables``: which of
    a training's tables they are) and ``figure`` (the activity figure drawn into the folder)."""

    robot_stride: int = 1
    weights: str | None = None
    trial: int | None = None
    robot: str | None = None
    tables: str | None = None
    figure: bool = False

    RECORD = ("seconds", "seed", "trials", "trace_dt", "trace_dtype", "robot_stride",
              "overrides", "equations", "spikes", "traces", "weights", "trial", "robot")

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "robot_stride",
                           number(self.robot_stride, setting("robot_stride"), integer=True, minimum=1))
        if self.trial is not None:
            object.__setattr__(self, "trial",
                               number(self.trial, setting("trial"), integer=True, minimum=0))
        object.__setattr__(self, "figure", bool(self.figure))

    def _extra_record(self) -> dict[str, Any]:
        return {**({} if self.tables is None else {"tables": self.tables}),
                "figure": self.figure}


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return list(value)
    if isinstance(value, dict):
        return dict(value)
    return value


__all__ = ["RunSettings", "UnitSettings"]
