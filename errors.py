"""The exceptions that user-facing commands turn into one line on stderr and an exit code.

Every layer raises these; only the command line turns them into exit codes:

========  =================  ==============================================================
exit      exception          meaning
========  =================  ==============================================================
0         (none)             done
1         EnvironmentFault   the environment failed us: disk full, unwritable folder, I/O
2         InputError         bad input: a value, an option, an equation, a file's content
3         Diverged           a state NaN, inf or beyond 1e50, or a MuJoCo instability
130       KeyboardInterrupt  interrupted (Ctrl-C, SIGTERM)
========  =================  ==============================================================

Like Nengo's ``ValidationError(msg, attr, obj)``, each error carries the *culprit* (what the
user typed or the object at fault: ``--set tau_motor``, ``motor_neuron.tau_motor``, a path)
apart from the message, and formats the one line in one place: ``<culprit>: <message>``.
"""

from __future__ import annotations

import difflib
import re
from typing import Any

EXIT_CODES = {"done": 0, "environment": 1, "input": 2, "diverged": 3, "interrupted": 130}


def one_line(text: str, limit: int = 600) -> str:
    """Collapse whitespace and newlines: a message is always one line."""
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[:limit - 3] + "..."


def did_you_mean(name: str, choices: Any, cutoff: float = 0.6) -> str:
    """`` (did you mean X?)`` naming the closest of ``choices`` to a misspelt ``name``
    (difflib's similarity ratio, at least ``cutoff``; names as close as the closest are named
    too, up to three), else ``""``: the one way every "unknown ..." message of the project
    suggests a name (a parameter, a model, a command, an option). A difference of case alone
    is the closest."""
    name = str(name)
    choices = [c for c in dict.fromkeys(str(c) for c in choices) if c != name]
    same_case = [c for c in choices if c.lower() == name.lower()]
    if same_case:
        hints = same_case[:3]
    else:
        scored = sorted(((difflib.SequenceMatcher(None, name, c).ratio(), c) for c in choices),
                        key=lambda sc: -sc[0])
        best = scored[0][0] if scored else 0.0
        hints = [c for r, c in scored if r >= cutoff and r >= best - 0.02][:3]
    return f" (did you mean {' or '.join(hints)}?)" if hints else ""


class AstrocpgError(Exception):
    """Base of the errors a command reports in one line. ``culprit`` names what is at fault."""

    exit_code = 1

    def __init__(self, message: str, culprit: Any = None) -> None:
        self.message = one_line(message)
        self.culprit = None if culprit is None else one_line(str(culprit), 200)
        super().__init__(self.line)

    @property
    def line(self) -> str:
        """``<culprit>: <message>``, or the message alone when there is no culprit."""
        return f"{self.culprit}: {self.message}" if self.culprit else self.message

    def __reduce__(self):  # picklable across Dask workers with its culprit
        return (self.__class__, (self.message, self.culprit))


# A command-line option as the Python API's keyword (the API's keywords are named like the
# options: ``--trace-dtype`` is ``trace_dtype``; these are the exceptions and the flags).
_KEYWORDS = {"set": "overrides", "model": "models", "condition": "conditions",
             "no-progress": "progress=False", "overwrite": "overwrite=True",
             "no-astrocytes": "astrocytes=False"}
_OPTION = re.compile(r"(?<![\w-])--([a-z][a-z0-9-]*)(=?)")


def in_keywords(text: str, renames: dict[str, str] | None = None) -> str:
    """``text`` with every command-line option named as the API's keyword: ``--out x`` is
    ``out=x``, ``--set tau_motr`` is ``overrides tau_motr``, ``--overwrite`` is
    ``overwrite=True``. ``renames``: options whose keyword differs in one function
    (``ac.resume``'s ``--resume`` is its ``folder``)."""
    names = _KEYWORDS | dict(renames or {})

    def keyword(m: "re.Match[str]") -> str:
        name = names.get(m.group(1), m.group(1).replace("-", "_"))
        return name if "=" in name else name + "="
    out = _OPTION.sub(keyword, str(text))
    # "out= x" (an option and its value) reads "out=x"; "overrides= tau_motr" reads "overrides tau_motr"
    out = re.sub(r"\b(overrides|models|conditions|equations)= ", r"\1 ", out)
    out = re.sub(r"(\w)=(?=[:;,)]|$)", r"\1", out)  # "seconds=: must be" reads "seconds: must be"
    out = re.sub(r"(\w)= (?=[^\s;,:])", r"\1=", out)
    return re.sub(r"(?<!=)= ", " ", out)  # a comparison (`__name__ == "__main__"`) stays


def speak_keywords(err: AstrocpgError, renames: dict[str, str] | None = None) -> AstrocpgError:
    """The same error (changed in place, traceback kept) naming the API's keywords instead of
    the command line's options: what a script calling ``ac.run(...)`` is told."""
    err.message = in_keywords(err.message, renames)
    if err.culprit is not None:
        err.culprit = in_keywords(err.culprit, renames)
    err.args = (err.line,)
    return err


class InputError(AstrocpgError, ValueError):
    """Bad user input (a parameter, an equation, a file, a command-line value): exit 2.

    e.g. ``InputError("must be positive, got -9. ms", culprit="motor_neuron.tau_motor")``.
    """

    exit_code = 2


class EnvironmentFault(AstrocpgError):
    """The environment failed: a file or folder could not be read or written (disk full,
    permission, read-only file system): exit 1. The culprit is the path."""

    exit_code = 1

    @classmethod
    def from_os_error(cls, err: OSError, path: Any = None, doing: str = "") -> "EnvironmentFault":
        where = path if path is not None else (err.filename or "")
        reason = err.strerror or type(err).__name__
        return cls(f"{doing + ': ' if doing else ''}{reason}", culprit=where or None)


class Diverged(AstrocpgError):
    """The simulation left the numbers: a state variable NaN, inf or beyond 1e50 in SI units
    (Brian2's bound of a valid state: :data:`astrocpg.network.divergence.LIMIT`), or a MuJoCo
    instability warning. ``what`` names the population and variable (or the warning), ``t`` the time in s,
    ``trial`` the trial (None when unknown)."""

    exit_code = 3

    def __init__(self, message: str, culprit: Any = None, *, t: float | None = None,
                 trial: int | None = None) -> None:
        self.t, self.trial = t, trial
        super().__init__(message, culprit)

    def __reduce__(self):
        return (_rebuild_diverged, (self.message, self.culprit, self.t, self.trial))


def _rebuild_diverged(message: str, culprit: Any, t: float | None, trial: int | None) -> Diverged:
    return Diverged(message, culprit, t=t, trial=trial)


__all__ = ["AstrocpgError", "InputError", "EnvironmentFault", "Diverged", "EXIT_CODES",
           "one_line", "did_you_mean", "in_keywords", "speak_keywords"]
