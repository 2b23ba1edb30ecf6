"""astrocpg: an astrocyte-regulated spiking central pattern generator, declared as Brian2
equation strings, driving a simulated Unitree A1 quadruped in MuJoCo.

The Python API (what the ``astrocpg`` commands call)::

    import astrocpg as ac
    r = ac.run(seconds=1, seed=3)                 # closed loop -> Result
    r.spike_times("motor", leg="FR", pool="thigh_flexor")
    r.trace("astrocyte_Ca").column(leg="FR", pool="thigh_extensor")
    u = ac.unit(seconds=3, seed=1, out="out/unit")
    same = ac.load("out/unit")                    # any output folder -> Result
    ac.plot("out/unit"); ac.video("out/run")      # its figures; the robot replayed as MP4

Every ``astrocpg`` command has its function, its options as keyword arguments: ``unit``,
``run``, ``train`` (and ``resume``, and ``replay_session``: one session of a training run
again alone), ``gait`` (and ``gait_of`` and ``rhythm_of``: the gait and the rhythm of a run
you made), ``evaluate``, ``power``, ``study`` (and ``study_status``), ``report``,
``plot``, ``video``, ``response``, ``export``, ``describe``, ``list_models`` and ``dump_model``
(``astrocpg models list/dump``), ``robot``, ``docs`` (where the manual is); with ``load``, ``Result``
and ``Trace`` they are imported on first use, so ``import astrocpg`` (and ``astrocpg --help``) does not
load Brian2. See docs/tutorial.ipynb.

Sub-packages:
  models    the biophysics: one model per module, its equation string and parameter table
  network   builds populations and synapses (for ``n_trials`` independent copies)
  coupling  the A1 robot model and the 1 ms Brian2 <-> MuJoCo bridge
  studies   runs, outputs, figures, the Python API and the ``astrocpg`` command line
"""

from __future__ import annotations

import importlib

from .support import _streams

# a standard stream closed at start (`astrocpg run ... 2>&-`): /dev/null on its descriptor before
# anything opens a file that would take it
_streams.mend_closed()

from .support import _quiet_brian  # noqa: E402

#: The release this code is or follows: the one version written by hand (the changelog and
#: CITATION.cff name it). ``__version__`` is this copy's version: ``RELEASE`` itself, or a
#: development build with its commit (``0.2.1.dev3+g1a2b3c4d5``), see :mod:`astrocpg._versioning`.
RELEASE = "0.2.0"

# Brian2's import leaves debug files in the temp folder if the process is killed during it.
_quiet_brian.install()

# public name -> module that defines it (imported on first access)
_API = {name: "astrocpg.studies.commands.api"
        for name in ("unit", "run", "train", "resume", "load", "describe", "export", "gait",
                     "gait_of", "rhythm_of", "evaluate", "power", "list_models", "dump_model",
                     "robot", "docs", "Result", "Trace")}
_API.update({name: "astrocpg.studies.parameter_studies.api" for name in ("study", "study_status",
                                                                   "report")})
_API.update({name: "astrocpg.studies.commands.view" for name in ("plot", "video")})
_API["replay_session"] = "astrocpg.studies.commands.replay"
_API["response"] = "astrocpg.studies.commands.response"
_API.update({name: "astrocpg.errors" for name in ("InputError", "EnvironmentFault", "Diverged")})

__all__ = sorted(_API)


# the settings whose keyword in one function is not their field name
_RENAMES = {"resume": {"resume": "folder"}, "study_status": {"status": "folder"},
            "plot": {"format": "fmt"}, "replay_session": {"weights": "training"}}


def _in_keywords(func):  # noqa: ANN001, ANN202
    """``func`` as the API hands it out: an astrocpg error it raises names the user's settings
    by the function's keywords (``seconds``, ``overrides tau_motr``, ``ac.resume``'s
    ``folder``); the command line calls the functions themselves and names its options."""
    import functools

    from .errors import AstrocpgError, Vocabulary

    words = Vocabulary(_RENAMES.get(func.__name__))

    @functools.wraps(func)
    def call(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        try:
            return func(*args, **kwargs)
        except AstrocpgError as e:
            e.speak(words)
            raise

    return call


def build_info() -> dict:
    """This copy's ``version``, git ``commit`` (None where unknown) and ``dirty`` (uncommitted
    changes), and their ``source``: "git" (a checkout), "build" (what the wheel or sdist was
    built from) or "release" (neither: the commit is unknown). Computed once per process."""
    global _BUILD
    if _BUILD is None:
        from ._versioning import build_info as compute
        _BUILD = compute(RELEASE)
    return dict(_BUILD)


_BUILD: dict | None = None


def __getattr__(name: str) -> object:
    """Import the API's functions lazily (PEP 562): Brian2 loads on first use; ``__version__``
    is computed on first use (git, in a checkout)."""
    import inspect

    if name == "__version__":
        return build_info()["version"]
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'astrocpg' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    if inspect.isfunction(value):
        value = _in_keywords(value)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API) | {"__version__"})
