"""The robot's senses a neuron model may read: the one list of their names, units and meanings.

A neuron model binds a sense to one of its own variables in its ``senses`` table (a model file's
``[senses]`` table): after every physics step (and after every reset) the coupling writes the
sense into that variable, so an afferent pathway is written in the model's equations like any
other input. The variable is declared in the equations as a plain variable (no ``dv/dt``, no
flag) with the sense's unit::

    equations = '''
    ...
    load_extensor : newton  # the foot's load, seen by extensor motor neurons
    '''

    [senses]
    load_extensor = { sense = "foot_force", only = ["thigh_extensor", "calf_extensor"] }
    # or, for every cell of the population:  load = "foot_force"

A sense "per leg" reaches every cell of that leg (or, with ``only``, the cells whose label is
listed: a pool, an interneuron, a joint; the others read 0); a sense "per trial" reaches every
cell of the trial. ``astrocpg describe senses`` prints this table. The coupling
(``astrocpg.coupling.senses``) computes each of them from MuJoCo's state; a model naming a
sense not listed here is refused when it is loaded, in one line naming it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from brian2 import meter, second
from brian2.units.allunits import newton, radian

from ..errors import InputError, did_you_mean


@dataclass(frozen=True)
class RobotSense:
    """One sense: its ``unit`` (a Brian2 unit: the bound variable's unit; radians are
    dimensionless in Brian2, so ``unit_text`` says what the number is in), whether it is
    measured ``per`` "leg" or "trial", and what it is."""

    unit: Any
    unit_text: str
    per: str
    meaning: str


_PER_SECOND = radian / second
ROBOT_SENSES: dict[str, RobotSense] = {
    "foot_force": RobotSense(newton, "newton", "leg",
                             "normal contact force on the foot (its touch sensor; 0 in swing)"),
    "foot_contact": RobotSense(1, "1", "leg", "1 while the foot touches the ground, else 0"),
    "hip_angle": RobotSense(radian, "radian", "leg", "hip joint angle (abduction)"),
    "thigh_angle": RobotSense(radian, "radian", "leg", "thigh joint angle"),
    "calf_angle": RobotSense(radian, "radian", "leg", "calf joint angle"),
    "hip_velocity": RobotSense(_PER_SECOND, "radian/second", "leg", "hip angular velocity"),
    "thigh_velocity": RobotSense(_PER_SECOND, "radian/second", "leg", "thigh angular velocity"),
    "calf_velocity": RobotSense(_PER_SECOND, "radian/second", "leg", "calf angular velocity"),
    "torso_speed": RobotSense(meter / second, "meter/second", "trial",
                              "speed of the torso (norm of its linear velocity)"),
    "forward_velocity": RobotSense(meter / second, "meter/second", "trial",
                                   "torso velocity along the world x axis (forward at reset)"),
    "torso_height": RobotSense(meter, "meter", "trial",
                               "height of the torso's centre above z = 0"),
    "torso_z_up": RobotSense(1, "1", "trial",
                             "vertical component of the torso's z axis (1: level)"),
}


@dataclass(frozen=True)
class SenseBinding:
    """A model variable bound to a robot sense: the sense's name, and the labels of the cells
    that receive it (empty: every cell)."""

    sense: str
    only: tuple[str, ...] = ()

    def to_json(self) -> Any:
        return self.sense if not self.only else {"sense": self.sense, "only": list(self.only)}


def parse_binding(entry: Any, culprit: str) -> SenseBinding:
    """A binding as a model file or a manifest writes it: ``"foot_force"`` or ``{ sense =
    "foot_force", only = ["thigh_extensor"] }``; an unknown sense name is refused in one line
    naming it."""
    if isinstance(entry, SenseBinding):
        return entry
    if isinstance(entry, str):
        name, only = entry, ()
    elif isinstance(entry, Mapping):
        unknown = set(entry) - {"sense", "only"}
        if unknown:
            raise InputError(f"unknown keys {sorted(unknown)}"
                             f"{did_you_mean(sorted(unknown)[0], ('sense', 'only'))} (sense, only)",
                             culprit=culprit)
        name, only = entry.get("sense"), entry.get("only", ())
        if not isinstance(only, (list, tuple)) or not all(isinstance(x, str) and x
                                                          for x in only):
            raise InputError(f"'only' must be a list of cell labels (pools, interneurons or "
                             f"joints), got {only!r}", culprit=culprit)
    else:
        raise InputError(f'expected a sense name or {{ sense = "...", only = [...] }}, got '
                         f"{entry!r}", culprit=culprit)
    if not isinstance(name, str) or name not in ROBOT_SENSES:
        raise InputError(f"unknown robot sense {name!r}{did_you_mean(str(name), ROBOT_SENSES)} "
                         f"(senses: {', '.join(ROBOT_SENSES)})", culprit=culprit)
    return SenseBinding(name, tuple(only))


def describe_senses() -> str:
    """The senses as a table for people (``astrocpg describe senses``)."""
    rows = [(name, s.unit_text, s.per, s.meaning)
            for name, s in ROBOT_SENSES.items()]
    w = [max(len(r[k]) for r in rows + [("sense", "unit", "per", "")]) for k in range(3)]
    lines = [f"{'sense':<{w[0]}}  {'unit':<{w[1]}}  {'per':<{w[2]}}  meaning"]
    lines += [f"{a:<{w[0]}}  {b:<{w[1]}}  {c:<{w[2]}}  {d}" for a, b, c, d in rows]
    return "\n".join(lines)


__all__ = ["ROBOT_SENSES", "RobotSense", "SenseBinding", "parse_binding", "describe_senses"]
