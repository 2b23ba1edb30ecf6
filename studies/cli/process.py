"""The command line's process plumbing: what every command shares around its handler. SIGTERM
stops a command like Ctrl-C; exit codes (0 done, 1 environment, 2 bad input, 3 diverged, 130
interrupted); the one line on stderr of a failure, by the kind of error; standard streams that
survive any bytes, and being closed or a broken pipe (:mod:`astrocpg.support._streams`); library warnings and log records kept off stderr; ``--codegen`` set for the
command alone; and :func:`entry`, which ends the process without the interpreter's teardown."""

from __future__ import annotations

import argparse
import atexit
import logging
import os
import signal
import sys
import threading
import warnings
from typing import Any, NoReturn, Sequence

from ...support._streams import guarded
from ...support.environment import check as check_environment, flag
from ...errors import AstrocpgError, EnvironmentFault, InputError, one_line
from .grammar import build_parser
from .handlers import COMMANDS
from .options import chosen_parsers, command_list
from .words import OptionWords

def _ignore_unraisable(unraisable: Any) -> None:
    """``sys.unraisablehook`` while a command ends by interrupt (see :func:`main`)."""


def _forget_unhandled_interrupt() -> None:
    """Tell CPython the interrupt was handled, so that exit code 130 stands.

    An interrupt that lands while a C extension runs Python source through ``PyRun_String``
    (Cython modules do, as they are imported) sets CPython's "unhandled KeyboardInterrupt"
    flag on its way out of that nested run, although we catch it further up. Under
    ``python -m`` the interpreter then ends by killing itself with SIGINT (exit -2) instead
    of our 130 (CI saw this once in ~850 tests). Every top-level run of source clears the
    flag as it starts, and no public API does, so we run an empty one."""
    import ctypes

    try:
        ctypes.pythonapi.PyRun_SimpleString(b"pass")
    except (AttributeError, OSError):  # not CPython: no such flag
        pass


def _sigterm(signum: int, frame: Any) -> None:
    """SIGTERM ends a command like Ctrl-C does: a Brian2 run in progress stops cleanly at the end
    of its step (the caller then sees it stopped early), anything else is interrupted."""
    brian2 = sys.modules.get("brian2")
    network = getattr(brian2, "Network", None)
    if network is not None and network._globally_running and not network._globally_stopped:
        network._globally_stopped = True
        return
    raise KeyboardInterrupt


def _not_utf8(args: Sequence[str]) -> bool:
    try:
        "\0".join(args).encode("utf-8")
    except UnicodeEncodeError:  # bytes that are not UTF-8, e.g. a file name in Latin-1
        return True
    return False


def _survive_any_bytes() -> None:
    """An argument that is not UTF-8 (a file name with other bytes) is a path like any other:
    our messages print it escaped, and Brian2, which copies the command line into its temp
    folder when imported (and fails on such bytes), is imported without that copy."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            try:
                reconfigure(errors="backslashreplace")
            except (ValueError, OSError):
                pass
    if "brian2" not in sys.modules and _not_utf8(sys.argv):
        argv0, sys.argv[0] = sys.argv[0], ""  # no script to copy
        try:
            import brian2  # noqa: F401
        finally:
            sys.argv[0] = argv0


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; its exit code (0 done, 1 environment, 2 bad input, 3 diverged, 130
    interrupted). Standard streams that are closed, or pipes nobody reads, do not change it
    (:func:`astrocpg.support._streams.guarded`)."""
    with guarded():
        code = _main(argv)
    if code == 130:  # interrupted, whichever layer caught the KeyboardInterrupt
        _forget_unhandled_interrupt()
    return code


def entry() -> NoReturn:
    """The ``astrocpg`` command (and ``python -m astrocpg.studies.cli``): :func:`main`, then
    the process ends without tearing the interpreter down.

    Freeing Brian2's, SymPy's and MuJoCo's objects one by one at interpreter shutdown took
    about 0.6 s after every command. Everything a command writes is closed and renamed before
    :func:`main` returns, so the exit handlers run (Brian2's, Dask's, multiprocessing's), the
    standard streams are flushed and the process ends there. While a non-daemon thread is
    still running, the process exits the usual way, which waits for it."""
    code = main()
    if any(t.is_alive() and not t.daemon for t in threading.enumerate()
           if t is not threading.main_thread()) or not hasattr(atexit, "_run_exitfuncs"):
        raise SystemExit(code)
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):  # a closed pipe or stream
                pass
        os._exit(code)


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    listing = command_list(parser, args)
    if listing is not None:  # a command group alone lists what it can do
        sys.stdout.write(listing)
        return 0
    _survive_any_bytes()
    # One line, always: a command reports through its result or its one error line, so no
    # library's warning (numpy's "input contained no data", Brian2's, Dask's) or log record
    # (Brian2's console log, its "Simulation stop requested" on Ctrl-C) reaches stderr. Both
    # are restored when the command ends (main() runs in-process in tests and notebooks).
    quiet = warnings.catch_warnings()
    quiet.__enter__()
    warnings.simplefilter("ignore")
    logging_was = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    # what the workers of a command before this one (same process: tests, notebooks) reported
    # of their physics is not this command's
    from ..outputs.writing import note_worker_environment

    note_worker_environment({})
    try:
        # an error names the user's settings as this command's options
        return _run_command(args, OptionWords(chosen_parsers(parser, args)))
    finally:
        logging.disable(logging_was)
        quiet.__exit__(None, None, None)


#: numpy's switch for advising the kernel to back large arrays with transparent huge pages
HUGEPAGE_ENV = "NUMPY_MADVISE_HUGEPAGE"


def _small_pages_for_large_arrays() -> None:
    """Large arrays on ordinary 4 KiB pages, unless the user chose otherwise.

    numpy asks the kernel for huge pages (``madvise``) for every array of 4 MiB or more. Where
    the kernel may compact memory to honour that request when a fault first touches the array
    (transparent huge pages with ``defrag`` set to ``madvise``, a common default), a fresh
    array's cost is a gamble: usually less than on 4 KiB pages, now and then a compaction that
    costs many times more (``benchmarks/fresh_memory.py``: 320 MiB, 0.01-0.02 s of system CPU
    most times, 0.5-0.7 s in 2 of 8; 0.09-0.12 s every time on 4 KiB pages). A recorded run's
    cost was unsteady from it. The arrays a run touches every step are small, so the loop does
    not depend on huge pages. Set in the environment too, so a study's worker processes start
    the same way; a value the user set (``NUMPY_MADVISE_HUGEPAGE=1``) is left as numpy read
    it."""
    if os.environ.get(HUGEPAGE_ENV) is not None:
        return
    os.environ[HUGEPAGE_ENV] = "0"
    import numpy as np

    core = getattr(np, "_core", None) or getattr(np, "core", None)
    switch = getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)
    if switch is not None:  # numpy read the variable at its import, before this: told again
        switch(False)


#: the options naming a file or folder a command reads (``run --weights``, ``gait DIR``,
#: ``study --plan-from``, ``train --resume``, ``study --status``): dest -> how a message names it
_INPUT_PATHS = {"dir": "", "weights": "--weights", "plan_from": "--plan-from",
                "resume": "--resume", "status": "--status", "robot": "--robot"}


def _check_inputs(args: argparse.Namespace) -> None:
    """The files and folders a command reads, before it starts: one spelled as the manual
    spells a file or folder the package ships (``docs/examples/interlimb_table.csv``) reads the
    shipped one, so the manual's recipes run from any folder with an installed wheel
    (:func:`astrocpg.support.shipped.resolve_data`); one that does not exist is the environment's
    (exit 1, docs/errors.md), named with its option."""
    from ...errors import EnvironmentFault
    from ...support.shipped import resolve_data

    for name, option in _INPUT_PATHS.items():
        value = getattr(args, name, None)
        if not isinstance(value, str) or not value:
            continue
        value = resolve_data(value)
        setattr(args, name, value)
        if not os.path.lexists(value):
            raise EnvironmentFault("no such file or folder",
                                   culprit=f"{option} {value}".strip())


def _run_command(args: argparse.Namespace, words: OptionWords) -> int:
    # only the main thread may set handlers (main() called in another thread: none of ours)
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _sigterm) if in_main else None
    env_codegen = os.environ.get("ASTROCPG_CODEGEN")  # --codegen sets it for this command only
    unraisable = sys.unraisablehook
    interrupted = False
    try:
        try:
            check_environment()  # a switch that is not a boolean: refused before anything runs
            _small_pages_for_large_arrays()
            if getattr(args, "codegen", None) is not None:
                _choose_codegen(args.codegen)
            _check_inputs(args)
            code = COMMANDS[args.command](args)
            compiled = sys.modules.get("astrocpg.coupling.compiled")
            if code == 0 and compiled is not None and compiled.PROBLEM:
                print(f"warning: {compiled.PROBLEM}")  # warnings are off: said here once
            traces = sys.modules.get("astrocpg.network.recording")
            if code == 0 and traces is not None and traces.KERNEL.problem:
                print(f"warning: {traces.KERNEL.problem}; traces were sampled with numpy "
                      f"(slower, the same values)")
            return code
        except Exception as e:
            if _interrupted(e):  # cleanup that failed while an interrupt unwound the stack
                raise KeyboardInterrupt from None
            raise
    except AstrocpgError as e:
        sys.stderr.write(f"astrocpg: {_kind(e)}: {e.render(words)}\n")
        return e.exit_code
    except KeyboardInterrupt:
        # An interrupt can land inside a constructor (e.g. zipfile.ZipFile's, while numpy
        # writes an .npz): the half-built object's __del__ then fails as the stack unwinds and
        # Python prints "Exception ignored in ..." with a traceback after our line. The
        # interrupt is the whole story: say it once.
        interrupted = True
        sys.unraisablehook = _ignore_unraisable
        sys.stderr.write("astrocpg: interrupted\n")
        return 130
    except OSError as e:  # an I/O failure no layer turned into an EnvironmentFault
        sys.stderr.write(f"astrocpg: environment: {EnvironmentFault.from_os_error(e).line}\n")
        return 1
    except MemoryError:
        sys.stderr.write("astrocpg: environment: out of memory\n")
        return 1
    except Exception as e:  # a bug of ours: still one line, the traceback on request
        fault = _environment_fault(e)
        if fault is not None:  # a library refusing the environment it was given
            sys.stderr.write(f"astrocpg: environment: {fault.render(words)}\n")
            return fault.exit_code
        if _debug():
            raise
        sys.stderr.write(f"astrocpg: internal error: {type(e).__name__}: {one_line(str(e), 300)} "
                         f"(a bug in astrocpg; ASTROCPG_DEBUG=1 shows the traceback)\n")
        return 1
    finally:
        if in_main:
            signal.signal(signal.SIGTERM, previous)
        if interrupted:  # collect what the unwinding left in cycles while the hook is quiet
            import gc

            gc.collect()
            sys.unraisablehook = unraisable
        if env_codegen is None:
            os.environ.pop("ASTROCPG_CODEGEN", None)
        else:
            os.environ["ASTROCPG_CODEGEN"] = env_codegen


def _debug() -> bool:
    """ASTROCPG_DEBUG: a traceback instead of the one line of an internal error (a value
    that is not a boolean counts as on: it is read while reporting a bug, not refused)."""
    try:
        return flag("ASTROCPG_DEBUG")
    except InputError:
        return True


def _choose_codegen(value: str) -> None:
    """--codegen: checked, then set for this process and (through the environment, which they
    inherit) a study's local Dask workers."""
    from ...network.codegen import ENV, choose_target

    try:
        os.environ[ENV] = choose_target(value)
    except InputError as e:
        raise InputError(e.raw_message, culprit="--codegen") from None


def _interrupted(e: BaseException) -> bool:
    """Was ``e`` raised while a Ctrl-C/SIGTERM unwound the stack (e.g. a zip file that cannot
    close its half-written member)? Then the command was interrupted, whatever came next."""
    seen: set[int] = set()
    err: BaseException | None = e
    while err is not None and id(err) not in seen:
        if isinstance(err, KeyboardInterrupt):
            return True
        seen.add(id(err))
        err = err.__context__
    return False


#: Environment variables that libraries read when imported and refuse with an exception of
#: their own (MuJoCo: "invalid value for environment variable MUJOCO_GL: bogus" from
#: ``import mujoco``; "Failed to import OpenGL backend (MUJOCO_GL='egl')"): such an error is
#: the environment's, not a bug of astrocpg.
LIBRARY_ENVIRONMENT = ("MUJOCO_GL", "PYOPENGL_PLATFORM")


def _environment_fault(e: BaseException) -> EnvironmentFault | None:
    """The EnvironmentFault naming the variable when ``e`` (or an error it came from) is a
    library refusing one of :data:`LIBRARY_ENVIRONMENT`; else None."""
    seen: set[int] = set()
    err: BaseException | None = e
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        text = str(err)
        for name in LIBRARY_ENVIRONMENT:
            if name in text:
                value = os.environ.get(name)
                shown = f"{name}={value}" if value is not None else name
                return EnvironmentFault(f"{type(err).__name__}: {one_line(text, 300)} (set it "
                                        f"to a value the library accepts, or unset it)",
                                        culprit=shown)
        # the backend MUJOCO_GL names is missing: PyOpenGL fails inside its own import (e.g.
        # MUJOCO_GL=osmesa without libOSMesa: "'NoneType' object has no attribute 'glGetError'")
        if os.environ.get("MUJOCO_GL") and _raised_in_gl(err):
            return EnvironmentFault(
                f"MuJoCo cannot load this OpenGL backend ({type(err).__name__}: "
                f"{one_line(text, 200)}); install it (OSMesa: the libosmesa6 package; EGL: a GPU "
                f"driver) or unset MUJOCO_GL to let astrocpg choose",
                culprit=f"MUJOCO_GL={os.environ['MUJOCO_GL']}")
        err = err.__cause__ or err.__context__
    return None


def _raised_in_gl(err: BaseException) -> bool:
    """Whether ``err`` was raised inside PyOpenGL or MuJoCo's GL backends (its traceback)."""
    tb = err.__traceback__
    while tb is not None:
        path = tb.tb_frame.f_code.co_filename.replace(os.sep, "/")
        if "/OpenGL/" in path or "/mujoco/osmesa/" in path or "/mujoco/egl/" in path \
                or "/mujoco/glfw/" in path:
            return True
        tb = tb.tb_next
    return False


def _kind(e: AstrocpgError) -> str:
    return {2: "error", 3: "diverged"}.get(e.exit_code, "environment")

