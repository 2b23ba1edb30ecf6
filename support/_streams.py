"""Standard streams that cannot stop a command: closed at start (``>&-``, ``2>&-``), or a pipe
whose reader went away (``| head -1``).

Two holes, two mends:

* A standard stream closed when the process started leaves its descriptor (0, 1 or 2) free and
  ``sys.stdout``/``sys.stderr`` ``None``. The next file opened then takes that descriptor, and
  whatever a library (or a worker process, which inherits it) writes to "stderr" lands in that
  file; tqdm's bar and ``print`` fail on ``None``. :func:`mend_closed` puts ``/dev/null`` on
  every closed standard descriptor and a stream on it in ``sys``: it runs first thing when
  ``astrocpg`` is imported, before anything opens a file.
* A write to a pipe nobody reads fails (``BrokenPipeError``), and so does a write to a stream
  closed since. :class:`Guarded` wraps ``sys.stdout``/``sys.stderr`` while a command runs
  (:func:`guarded`): the first such failure points the descriptor at ``/dev/null`` (what was
  in the buffer is dropped, as the reader is gone) and every later write is silently
  discarded, so the command finishes its work and exits with the code it would have had.
"""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Any, Iterator

def _closed(fd: int) -> bool:
    try:
        os.fstat(fd)
    except OSError:
        return True
    return False


def mend_closed() -> None:
    """``/dev/null`` on every standard descriptor (0, 1, 2) that is closed, and a text stream
    on it where ``sys`` has none (Python sets ``sys.stdout`` to ``None`` when descriptor 1 was
    closed at start). Idempotent and cheap: three ``fstat`` calls when nothing is closed."""
    for fd in (0, 1, 2):
        if not _closed(fd):
            continue
        try:
            null = os.open(os.devnull, os.O_RDWR)
        except OSError:  # no /dev/null: nothing to mend with
            return
        if null != fd:
            os.dup2(null, fd)
            os.close(null)
    for name, fd, mode in (("stdin", 0, "r"), ("stdout", 1, "w"), ("stderr", 2, "w")):
        if getattr(sys, name) is None and not _closed(fd):
            setattr(sys, name, open(fd, mode, closefd=False, encoding="utf-8",
                                    errors="backslashreplace", buffering=1 if fd == 2 else -1))


def _to_null(stream: Any) -> None:
    """Point ``stream``'s descriptor at /dev/null (a broken pipe's writes then succeed)."""
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):
        return
    try:
        null = os.open(os.devnull, os.O_WRONLY)
    except OSError:
        return
    try:
        os.dup2(null, fd)
    except OSError:
        pass
    finally:
        os.close(null)


class Guarded:
    """A standard stream whose writes cannot fail: a broken pipe or a closed stream turns it
    into a sink (see the module's docstring). Everything else is the wrapped stream's."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self._dead = stream is None

    @property
    def wrapped(self) -> Any:
        return self._stream

    @property
    def gone(self) -> bool:
        """Whether a write failed and the stream is now a sink."""
        return self._dead

    def _failed(self, err: BaseException) -> None:
        # a broken pipe, a closed stream, or a log file on a full disk (`2> log`): the
        # command's results are in its folder, which reports its own faults
        if not self._dead:
            self._dead = True
            _to_null(self._stream)
            try:  # the buffer's bytes now go to /dev/null, so later flushes succeed
                self._stream.flush()
            except (OSError, ValueError, AttributeError):
                pass

    def write(self, text: str) -> int:
        if not self._dead:
            try:
                return self._stream.write(text)
            except (OSError, ValueError) as e:
                self._failed(e)
        return len(text)

    def writelines(self, lines: Any) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        if not self._dead:
            try:
                self._stream.flush()
            except (OSError, ValueError) as e:
                self._failed(e)

    def isatty(self) -> bool:
        if self._dead:
            return False
        try:
            return bool(self._stream.isatty())
        except (OSError, ValueError, AttributeError):
            return False

    @property
    def closed(self) -> bool:
        return False

    def writable(self) -> bool:
        return True

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


@contextlib.contextmanager
def guarded() -> Iterator[None]:
    """``sys.stdout`` and ``sys.stderr`` wrapped in :class:`Guarded` for the ``with`` block (a
    stream already guarded is left as it is); restored after."""
    mend_closed()
    saved = sys.stdout, sys.stderr
    if not isinstance(sys.stdout, Guarded):
        sys.stdout = Guarded(sys.stdout)  # type: ignore[assignment]
    if not isinstance(sys.stderr, Guarded):
        sys.stderr = Guarded(sys.stderr)  # type: ignore[assignment]
    try:
        yield
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        sys.stdout, sys.stderr = saved
