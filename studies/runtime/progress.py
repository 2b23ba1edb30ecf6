"""The progress bars of every command (tqdm), and the one rule about what else may print while
one is on the screen.

A warning printed while a bar is drawn lands in the middle of the bar's line (``...| 2.1/4.0 sim
s/path/file.py:12: SomeWarning: ...``) and the bar goes on below it. :class:`Bar` is tqdm's bar
(:mod:`tqdm.auto`: a terminal or a notebook) that holds the warnings shown while any bar is
open, and the records that console log handlers (the root logger's, Brian2's) would print, and
shows them, in Python's usual way and order, once the last bar has closed: the bar stays whole
and no warning is lost (an ``ignore`` filter still silences one; pytest still records them).

Counting is in whole units (steps, sessions, frames, figures): a bar whose total is a sum of
floats (0.1 s a hundred steps) overshoots it by rounding, which tqdm reports as
``TqdmWarning: clamping frac to range [0, 1]``. A bar of simulated time counts steps and shows
seconds with ``unit_scale`` (:func:`time_bar`).
"""

from __future__ import annotations

import logging
import re
import sys
import warnings
import weakref
from typing import Any

from tqdm.auto import tqdm

_open_bars: "weakref.WeakSet[Bar]" = weakref.WeakSet()
_held: list[warnings.WarningMessage] = []
_shown_before: Any = None  # warnings.showwarning while no bar is open
# loggers whose console handlers a library's messages reach (Brian2 prints its log records, and
# the Python warnings it captures, on stderr with its own handler)
_LOGGERS = ("", "brian2", "py.warnings")


class _HoldRecords(logging.Filter):
    """On a console handler while a bar is open: keep its records for after the bar."""

    def __init__(self, handler: logging.Handler) -> None:
        super().__init__()
        self.handler, self.records = handler, []  # type: list[logging.LogRecord]

    def filter(self, record: logging.LogRecord) -> bool:
        if any(not bar.disable for bar in list(_open_bars)):
            self.records.append(record)
            return False
        return True


_holding: list[_HoldRecords] = []


def _console_handlers() -> list[logging.Handler]:
    found: list[logging.Handler] = []
    for name in _LOGGERS:
        for h in logging.getLogger(name).handlers:
            if (isinstance(h, logging.StreamHandler) and not isinstance(h, logging.FileHandler)
                    and h not in found):
                found.append(h)
    return found


def _hold(message: Any, category: type[Warning], filename: str, lineno: int,
          file: Any = None, line: str | None = None) -> None:
    """``warnings.showwarning`` while a bar is open: keep the warning for after the bar."""
    if any(not bar.disable for bar in list(_open_bars)):
        _held.append(warnings.WarningMessage(message, category, filename, lineno, file, line))
        return
    (_shown_before or warnings._showwarning_orig)(message, category, filename, lineno,
                                                   file, line)


def _opened(bar: "Bar") -> None:
    global _shown_before
    if not _open_bars:
        _shown_before = warnings.showwarning
        warnings.showwarning = _hold
        for handler in _console_handlers():
            hold = _HoldRecords(handler)
            handler.addFilter(hold)
            _holding.append(hold)
    _open_bars.add(bar)


def _closed(bar: "Bar") -> None:
    global _shown_before
    if bar not in _open_bars:
        return
    _open_bars.discard(bar)
    if _open_bars:
        return
    if warnings.showwarning is _hold:  # else someone replaced it since: leave theirs
        warnings.showwarning = _shown_before
    _shown_before = None
    holding, _holding[:] = list(_holding), []
    for hold in holding:
        hold.handler.removeFilter(hold)
    held, _held[:] = list(_held), []
    for msg in held:  # as Python would have shown them (or a recorder would have kept them)
        warnings._showwarnmsg(msg)
    for hold in holding:  # then the log records, on the handler that refused them
        for record in hold.records:
            hold.handler.handle(record)


#: Seconds between two lines of a bar written to a file (a log of a long run), not a terminal.
LOG_INTERVAL = 30.0


def _to_terminal(kwargs: dict[str, Any]) -> bool:
    """Whether the bar is redrawn in place: a terminal, or a notebook's widget (tqdm.auto chose
    the notebook's bar when this module was imported in a notebook)."""
    if tqdm.__module__.startswith("tqdm.notebook"):
        return True
    stream = kwargs.get("file") or sys.stderr
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a real stream
        return False


_ESCAPE = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


class _Lines:
    """A bar's output to a file (a log, a pipe): each redraw a line of its own, never the
    terminal's ``\r`` redraws in place (a log read later would hold every state of the bar on
    one line, or show only the last) nor its cursor moves; a redraw that says what the last
    line said, or nothing (an erased bar), writes nothing."""

    def __init__(self, stream: Any) -> None:
        self.stream, self._last = stream, None

    def write(self, text: str) -> int:
        for part in re.split(r"[\r\n]", _ESCAPE.sub("", text)):
            line = part.rstrip()
            if line and line != self._last:
                self.stream.write(line + "\n")
                self._last = line
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return False

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


class Bar(tqdm):
    """tqdm's bar (terminal or notebook); warnings and console log records shown while it is
    open wait until every bar has closed (see the module's docstring). Close it (``with`` or
    ``close()``); closed by an exception in a ``with``, it erases itself (the error's one line
    stands alone). Written to a file (``command 2> log``), it writes a line at most every
    :data:`LOG_INTERVAL` seconds, its postfix included, each a line of its own (no ``\r``
    redraws): a night's training leaves a log of a few hundred lines, not one per session.
    Its ``total`` is fixed when it is made: a bar never moves its own end."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._terminal = _to_terminal(kwargs)
        if not self._terminal:
            if "mininterval" not in kwargs:
                kwargs["mininterval"] = LOG_INTERVAL
            kwargs["file"] = _Lines(kwargs.get("file") or sys.stderr)
        super().__init__(*args, **kwargs)
        if not self.disable:
            _opened(self)

    def set_postfix(self, ordered_dict: Any = None, refresh: bool = True,
                    **kwargs: Any) -> None:
        # tqdm redraws on every postfix: on a file, the next update's redraw (rate-limited)
        # shows it instead
        super().set_postfix(ordered_dict, refresh=refresh and self._terminal, **kwargs)

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        super().set_postfix_str(s, refresh=refresh and self._terminal)

    def close(self) -> None:
        try:
            super().close()
        finally:
            _closed(self)

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is not None:  # an error or an interrupt: its one line, no bar above it
            self.leave = False
        super().__exit__(exc_type, exc, tb)

    def finish(self) -> None:
        """Move the bar to its total (a whole run ends there, whatever the update stride)."""
        if self.total is not None and self.n < self.total:
            self.update(self.total - self.n)


def held_warnings() -> int:
    """How many warnings are waiting for the open bars to close (for tests)."""
    return len(_held)


def time_bar(steps: int, dt: float, desc: str, enabled: bool) -> Bar:
    """A bar over ``steps`` steps of ``dt`` seconds, shown in simulated seconds
    (``1.2/4.0 sim s``); update it with whole steps."""
    return Bar(total=int(steps), unit="sim s", unit_scale=float(dt), desc=desc,
               disable=not enabled,
               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]")


__all__ = ["Bar", "time_bar", "held_warnings"]
