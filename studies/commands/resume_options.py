"""A resume's settings given again, checked against what the training recorded
(:func:`check_resume_options`): each must agree, or the resume is refused naming the setting
and both values. Parameter values compare as quantities, model files by what they define."""

from __future__ import annotations

import hashlib
from typing import Any, Callable, Mapping, NoReturn, Sequence

import numpy as np

from ...coupling.recorder import RecordPlan
from ...errors import Field, InputError, advice, did_you_mean, setting
from ...models.compose import model_files_record, model_set, override_items
from ..settings import TrainSettings
from ..settings.populations import population_models, population_table, same_populations
from ..settings.checks import check_selection


#: Relative difference below which two values of a parameter are the same value spelled
#: differently (``1000*ms`` and ``1*second``; ``0.1*second`` and ``100*ms`` differ in the last
#: bit of their SI numbers).
SAME_VALUE_RTOL = 1e-12


def check_resume_options(settings: TrainSettings, plan: RecordPlan | None,
                         given: dict[str, Any]) -> None:
    """Refuse every option given to a resume that differs from what the training recorded
    (an InputError naming the option, the recorded value and the given one); an option given
    with the recorded value is accepted (the run continues with it). ``given``: ``sessions``,
    ``seed``, ``trials``, ``astrocytes`` (bool), ``models`` ({model: {"sha256", "content"}}),
    ``equations`` ({model: text}), ``overrides`` (``NAME=VALUE`` items), ``populations``
    ({name: {"sha256", "content"}} of added population files), ``record_every``,
    ``record_stride``, ``spikes``, ``traces``; None: not given.

    Parameter values are compared as quantities in SI (:data:`SAME_VALUE_RTOL`), not as
    spelled; model files by what they define (a file that differs only in comments or
    spelling is the same model); equation files by their text."""
    refuse = _refuse_resume
    for key, option, recorded, noun in (
            ("sessions", setting("sessions"), settings.n_sessions, "sessions per trial"),
            ("seed", setting("seed"), settings.seed, "as its seed"),
            ("trials", setting("trials"), settings.n_trials, "trials")):
        value = given.get(key)
        if value is not None and value != recorded:
            refuse(option, f"that run has {recorded} {noun}, not {value}")
    astro = given.get("astrocytes")
    if astro is not None and bool(astro) != settings.astrocytes:
        refuse(setting("astrocytes"), "that run trained with astrocytes (recorded: astrocytes on, "
                                  "given: off)" if settings.astrocytes else
               "that run trained without astrocytes (recorded: off, given: on)")
    for name, record in model_files_record(given.get("models")).items():  # texts or records
        _check_model_file(name, settings.models.get(name), record, refuse)
    _check_populations(settings.populations, given.get("populations") or {}, refuse)
    _check_equations_given(settings, given.get("equations") or {})
    _check_overrides_given(settings, given.get("overrides") or [])
    _check_recording_given(plan, given, population_table(settings.populations))


def _refuse_resume(option: Field, message: str) -> NoReturn:
    raise InputError(f"{message}; a resumed training keeps the settings it started with "
                     f"(start a new one with {advice('train', 'DIR')})", culprit=option)


def _check_equations_given(settings: TrainSettings, equations: Mapping[str, str]) -> None:
    """Equation files given to a resume: each must be the text the training used (the model's
    built-in equations where it used none)."""
    if not equations:
        return
    known = dict(model_set(models=settings.models).items())
    for name, text in equations.items():
        if name not in known:
            raise InputError(f"unknown model '{name}'{did_you_mean(name, known)} (models: "
                             f"{', '.join(known)})", culprit=setting("equations"))
        recorded_text = settings.equations.get(name)
        if recorded_text is None:  # the model's own equations, as trained
            if text.strip() != known[name].code.strip():
                _refuse_resume(setting("equations", name), f"that run was trained with the "
                                                      f"built-in equations of {name}, not "
                                                      f"these (sha256 {_short_sha(text)})")
        elif text.strip() != recorded_text.strip():
            _refuse_resume(setting("equations", name), f"that run was trained with other equations "
                                                  f"of {name} (recorded sha256 "
                                                  f"{_short_sha(recorded_text)}, given "
                                                  f"{_short_sha(text)})")


def _check_overrides_given(settings: TrainSettings, items: Sequence[str]) -> None:
    """``overrides`` given to a resume: each must equal the training's, as a quantity."""
    from ...models.files import value_text

    if not items:
        return
    recorded_models = model_set(settings.overrides, settings.equations, models=settings.models,
                                added=population_models(settings.populations))
    for item in override_items(items):
        name, value = recorded_models.parse_assignment(item)
        was = recorded_models.parameter(name).value
        if not _same_quantity(was, value):
            _refuse_resume(setting("overrides", name),
                           f"that run has {name}={value_text(was)}, not {value_text(value)}")


def _check_recording_given(plan: RecordPlan | None, given: dict[str, Any],
                           rows: Any = None) -> None:
    """The recording options given to a resume: each must be the training's plan (the names
    those of its population table ``rows``)."""
    refuse = _refuse_resume
    every, stride = given.get("record_every"), given.get("record_stride")
    spikes, traces = given.get("spikes"), given.get("traces")
    dtype = given.get("trace_dtype")
    if plan is None:
        for option, value in ((setting("record_every"), every),
                              (setting("record_stride"), stride), (setting("spikes"), spikes),
                              (setting("traces"), traces), (setting("trace_dtype"), dtype)):
            if value is not None:
                refuse(option, f"that run records no sessions (given "
                               f"{option.given(_option_text(value))})")
        return
    if every is not None and every != plan.every:
        refuse(setting("record_every"),
               f"that run records every {plan.every} sessions, not {every}")
    if dtype is not None and dtype != plan.dtype:
        refuse(setting("trace_dtype"), f"that run keeps its traces as {plan.dtype}, not {dtype}")
    if stride is not None and stride != plan.stride:
        refuse(setting("record_stride"),
               f"that run records every {plan.stride} steps, not {stride}")
    want_spikes, want_traces = check_selection(spikes, traces, rows)
    if spikes is not None and set(want_spikes) != set(plan.spikes):
        refuse(setting("spikes"), f"that run records the spikes of {_option_text(plan.spikes)}, "
                           f"not {_option_text(want_spikes)}")
    if traces is not None and set(want_traces) != set(plan.traces):
        refuse(setting("traces"), f"that run records the traces {_option_text(plan.traces)}, "
                           f"not {_option_text(want_traces)}")


def _check_populations(recorded: dict[str, dict[str, str]], given: Mapping[str, Any],
                       refuse: Callable[[str, str], NoReturn]) -> None:
    """``populations`` given to a resume: each must be a file the training added (the
    same file, or one that defines the same population and model)."""
    name = same_populations(recorded, given)
    if name is None:
        return
    sha = given[name]["sha256"][:12]
    if name not in recorded:
        had = ", ".join(sorted(recorded)) or "none"
        refuse(setting("populations"), f"that run did not add the population {name} (sha256 {sha}; "
                               f"added: {had})")
    refuse(setting("populations"), f"that run added {name} from another file (recorded sha256 "
                           f"{recorded[name]['sha256'][:12]}, given {sha})")


def _option_text(value: Any) -> str:
    if isinstance(value, (tuple, list)):
        return ",".join(map(str, value)) or "none"
    return str(value)


def _short_sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _same_quantity(a: Any, b: Any) -> bool:
    """Same dimensions and the same SI numbers (to :data:`SAME_VALUE_RTOL`)."""
    from brian2 import get_dimensions

    if get_dimensions(a) != get_dimensions(b):
        return False
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return x.shape == y.shape and bool(np.all(
        (x == y) | np.isclose(x, y, rtol=SAME_VALUE_RTOL, atol=0.0)))


def _check_model_file(name: str, recorded: dict[str, str] | None, given: dict[str, str],
                      refuse: Callable[[str, str], NoReturn]) -> None:
    """A model file given for NAME (``models``) against the one the training recorded for
    NAME."""
    option = setting("models", name)
    if recorded is not None and recorded["sha256"] == given["sha256"]:
        return
    # the same model spelled otherwise (comments, order, number spelling) is the same model;
    # a file given for a model the run did not replace must define the built-in one
    given_json = model_set(models={name: given["content"]},
                           option=setting("models")).to_json()[name]
    recorded_json = (model_set() if recorded is None
                     else model_set(models={name: recorded["content"]})).to_json()[name]
    if given_json == recorded_json:
        return
    if recorded is None:
        refuse(option, f"that run was trained with the built-in {name} model, not this model "
                       f"file (sha256 {given['sha256'][:12]})")
    refuse(option, f"that run was trained with another {name} model file (recorded sha256 "
                   f"{recorded['sha256'][:12]}, given {given['sha256'][:12]})")


__all__ = ["SAME_VALUE_RTOL", "check_resume_options"]
