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
user gave or the object at fault: ``setting("overrides", "tau_motor")``,
``motor_neuron.tau_motor``, a path) apart from the message, and formats the one line in one
place: ``<culprit>: <message>``.

A user's setting is named by its field (:func:`setting`), never as one door spells it: the
command line renders the line with the failing command's options (the one that sets the field,
read from the command's parser), the Python API with the called function's keywords
(``overrides tau_motor``); :meth:`AstrocpgError.render` takes the door's :class:`Vocabulary`.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import Any

EXIT_CODES = {"done": 0, "environment": 1, "input": 2, "diverged": 3, "interrupted": 130}


def one_line(text: str, limit: int | None = 600) -> str:
    """Collapse whitespace and newlines: a message is always one line (of at most ``limit``
    characters; None: any length, for a message whose field references are not yet named)."""
    line = " ".join(str(text).split())
    return line if limit is None or len(line) <= limit else line[:limit - 3] + "..."


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


# ---------------------------------------------------------------- settings named in a message
# A message names the user's settings by their field names (``out``, ``seconds``, ``overrides``),
# never by how one door spells them: the command line names an option, the Python API ``out=``.
# A reference is embedded in the message as a token (below), which the error records and each
# door renders in its own words (:meth:`AstrocpgError.render`). The token's marks are control
# characters that are not whitespace, so :func:`one_line` leaves them whole.
_OPEN, _SEP, _CLOSE = "\x02", "\x01", "\x03"


@dataclass(frozen=True)
class Field:
    """A reference to one of the user's settings: ``name`` is its field (the API's keyword,
    the settings' attribute: ``out``, ``seconds``, ``overrides``), ``value`` what was given with
    it, shown beside it (a path, a number, a parameter's name for ``overrides``); ``advice``
    marks a door's way of doing something (``resume``: an option of ``astrocpg train`` on the
    command line, ``ac.resume(DIR)`` in Python) rather than a setting.

    Embedded in an f-string (``f"drop {setting('out')}"``) or given as a culprit, it becomes a
    token that :meth:`AstrocpgError.render` names in a door's words."""

    name: str
    value: str = ""
    advice: bool = False

    def given(self, value: Any) -> "Field":
        """The same field shown with ``value`` too (``setting("out").given(path)``)."""
        value = "" if value is None else str(value)
        return Field(self.name, f"{self.value} {value}".strip(), self.advice)

    def __str__(self) -> str:
        return f"{_OPEN}{'a' if self.advice else 'f'}{_SEP}{self.name}{_SEP}{self.value}{_CLOSE}"

    def __format__(self, spec: str) -> str:
        return str(self)


def setting(name: str, value: Any = "") -> Field:
    """The setting ``name`` (its field name), shown with ``value`` if given:
    ``setting("seconds")``, ``setting("out", path)``, ``setting("overrides", "tau_motor")``."""
    return Field(name, "" if value is None else str(value))


def advice(name: str, value: Any = "") -> Field:
    """A door's way of doing ``name`` (``advice("resume", "DIR")``): each door says it in its
    own words (:class:`Vocabulary`)."""
    return Field(name, "" if value is None else str(value), advice=True)


def shown_with(culprit: Any, value: Any) -> Any:
    """``culprit`` shown with ``value``: a field given that value (each door then writes it its
    own way: an option and its value, ``out=DIR``), anything else followed by it."""
    if isinstance(culprit, Field):
        return culprit.given(value)
    return f"{culprit} {value}"


def _pieces(text: str) -> list[str | Field]:
    """``text`` cut into plain text and the fields its tokens reference, in order."""
    out: list[str | Field] = []
    rest = text
    while _OPEN in rest:
        before, _, after = rest.partition(_OPEN)
        body, closed, rest = after.partition(_CLOSE)
        parts = body.split(_SEP)
        if not closed or len(parts) != 3 or parts[0] not in ("a", "f"):  # not one of ours
            out.append(before + _OPEN + body + closed)
            continue
        out += [before, Field(parts[1], parts[2], parts[0] == "a")]
    out.append(rest)
    return [p for p in out if p != ""]


class Vocabulary:
    """How one door names the user's settings. This one is the Python API's, and the default
    of every error: a field is its keyword (``seconds``; with a value ``out=/tmp/x``; a
    collection names its item, ``overrides tau_motor``; a switch is named as the value that
    turns it on, ``overwrite=True``). ``renames``: the keywords one function names otherwise
    (``ac.resume`` takes the training folder as ``folder``)."""

    #: switches, named as the keyword's value that does what the message is about
    SWITCHES: dict[str, str] = {"overwrite": "overwrite=True", "progress": "progress=False",
                                "astrocytes": "astrocytes=False", "figure": "figure=True",
                                "panel": "panel=True"}
    #: keywords that take several items: a value shown with one is the item named
    COLLECTIONS: frozenset[str] = frozenset({"overrides", "models", "equations", "populations",
                                              "conditions", "point", "world", "marks",
                                              "experimenter"})
    #: the API's way of doing what a message advises (``{}``: the value given with it; a pair:
    #: the words with a value and without one)
    ADVICE: dict[str, str | tuple[str, str]] = {
        "resume": "ac.resume({})", "record_every": "ac.train(record_every={})",
        "train": "ac.train(out={})", "retrain": "ac.train(out=DIR, overwrite=True)",
        "codegen": ("ASTROCPG_CODEGEN={}", "ASTROCPG_CODEGEN"),
        "extend_study": "ac.study(FILE, sessions={}, out=NEW_DIR)"}

    def __init__(self, renames: dict[str, str] | None = None) -> None:
        self.renames = dict(renames or {})

    def name(self, f: Field) -> str:
        """The words for one field."""
        if f.advice:  # a template for a value (DIR unless given), or with one without
            said = self.ADVICE.get(f.name, f.name + "({})")
            with_value, without = said if isinstance(said, tuple) else (said, said)
            return with_value.format(f.value) if f.value else without.format("DIR")
        key = self.renames.get(f.name, f.name)
        if not f.value:
            return self.SWITCHES.get(f.name, key)
        return f"{key} {f.value}" if f.name in self.COLLECTIONS else f"{key}={f.value}"

    def __call__(self, text: str) -> str:
        """``text`` with each field named in these words."""
        return "".join(p if isinstance(p, str) else self.name(p) for p in _pieces(text))


#: The Python API's words: the default of every error.
KEYWORDS = Vocabulary()


class AstrocpgError(Exception):
    """Base of the errors a command reports in one line. ``culprit`` names what is at fault.

    The message and the culprit may reference the user's settings (:func:`setting`); they are
    kept as given (``raw_message``, ``raw_culprit``), the fields they name are :attr:`fields`,
    and :meth:`render` writes the one line in a door's words. ``message``, ``culprit``,
    ``line`` and ``str(err)`` are in the words the error speaks (:meth:`speak`): the Python
    API's unless a door chose others."""

    exit_code = 1

    def __init__(self, message: str, culprit: Any = None) -> None:
        self.raw_message = one_line(message, limit=None)
        self.raw_culprit = None if culprit is None else one_line(str(culprit), limit=None)
        self.words: Vocabulary = KEYWORDS
        super().__init__(self.line)

    @property
    def fields(self) -> tuple[Field, ...]:
        """The settings (and advice) the culprit and the message reference, in order."""
        return tuple(p for text in (self.raw_culprit or "", self.raw_message)
                     for p in _pieces(text) if isinstance(p, Field))

    @property
    def message(self) -> str:
        """The message in the words this error speaks."""
        return one_line(self.words(self.raw_message))

    @property
    def culprit(self) -> str | None:
        """What is at fault, in the words this error speaks (None: the message alone)."""
        return None if self.raw_culprit is None else one_line(self.words(self.raw_culprit), 200)

    @property
    def raw_line(self) -> str:
        """The line with its field references kept: what an error that wraps this one quotes."""
        return f"{self.raw_culprit}: {self.raw_message}" if self.raw_culprit else self.raw_message

    def render(self, words: Vocabulary) -> str:
        """``<culprit>: <message>`` (or the message alone) with each field in ``words``."""
        message = one_line(words(self.raw_message))
        if self.raw_culprit is None:
            return message
        culprit = one_line(words(self.raw_culprit), 200)
        return f"{culprit}: {message}" if culprit else message

    @property
    def line(self) -> str:
        """The one line in the words this error speaks."""
        return self.render(self.words)

    def speak(self, words: Vocabulary) -> "AstrocpgError":
        """This error (changed in place, traceback kept) in ``words`` from now on."""
        self.words = words
        self.args = (self.line,)
        return self

    def __reduce__(self):  # picklable across Dask workers with its culprit and fields
        return (self.__class__, (self.raw_message, self.raw_culprit))


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
        return (_rebuild_diverged, (self.raw_message, self.raw_culprit, self.t, self.trial))


def _rebuild_diverged(message: str, culprit: Any, t: float | None, trial: int | None) -> Diverged:
    return Diverged(message, culprit, t=t, trial=trial)


__all__ = ["AstrocpgError", "InputError", "EnvironmentFault", "Diverged", "EXIT_CODES",
           "one_line", "did_you_mean", "Field", "setting", "advice", "shown_with", "Vocabulary",
           "KEYWORDS"]
