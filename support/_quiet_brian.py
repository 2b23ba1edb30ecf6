"""Brian2 without its debug files, even when the process is killed while importing it.

Brian2 writes ``brian_debug_*.log`` and ``brian_script_*.py`` into the temp folder the moment
it is imported (before any preference of ours can apply) and deletes them at a clean exit
only. A process killed (SIGKILL, OOM) between the import and our clean-up left both behind
in the user's temp folder, one pair per kill.

So Brian2's own import runs with Python's temp folder pointed at a private folder named
after this process (``astrocpg-brian-<pid>-*``). Right after the import the files are closed
and removed, file logging is switched off and the folder goes. A process killed inside that
window leaves only its own folder, and the next astrocpg process removes the folders of
processes that no longer exist. A user who imported Brian2 before astrocpg is covered by the
clean-up in ``network.build`` instead. The same two places mend Brian2's Ctrl-C handler for
processes started with SIGINT ignored (:func:`mend_interrupt_handler`). Imported first from
another thread than the main one (``ac.run`` in a thread), Brian2 could not install that
handler at all and its import failed; it is then installed from the main thread later
(:func:`install_interrupt_handler`).

The same import leaves pylab and pytest out (:class:`_WithoutExtras`), as Brian2 allows where
they are missing, and every command starts about 0.6 s sooner.

:func:`install` is called by ``astrocpg/__init__.py``; it imports nothing heavy.
"""

from __future__ import annotations

import importlib.machinery
import os
import sys
from types import ModuleType

# logging, shutil and tempfile are imported where used: ``astrocpg --help`` imports this module
# and must stay quick.

PREFIX = "astrocpg-brian-"
# Brian2 was imported in another thread than the main one: its Ctrl-C handler is not installed
# yet (install_interrupt_handler does it from the main thread)
_handler_pending = False


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, not ours
        return True
    return True


def remove_stale(folder: str | None = None) -> list[str]:
    """Remove the private import folders of astrocpg processes that no longer exist; return
    what was removed."""
    import shutil
    import tempfile

    folder = folder or tempfile.gettempdir()
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for name in names:
        if not name.startswith(PREFIX):
            continue
        pid = name[len(PREFIX):].split("-", 1)[0]
        if not pid.isdigit() or int(pid) == os.getpid() or _alive(int(pid)):
            continue
        shutil.rmtree(os.path.join(folder, name), ignore_errors=True)
        removed.append(name)
    return removed


def close_debug_files(switch_off: bool = True) -> None:
    """Close and delete the debug log and script copy Brian2 opened at import. ``switch_off``
    (Brian2 imported by astrocpg): its file-logging preferences say so too. Where the user
    imported Brian2 before astrocpg, their preferences are theirs and stay as they are
    (Brian2 reads them at import only)."""
    import logging

    import brian2
    from brian2.utils.logger import BrianLogger

    handler = BrianLogger.file_handler
    if handler is not None:
        logging.getLogger("brian2").removeHandler(handler)
        handler.close()
        BrianLogger.file_handler = None
    for attr in ("tmp_log", "tmp_script"):
        path = getattr(BrianLogger, attr)
        setattr(BrianLogger, attr, None)
        for p in (path, f"{path}.1") if path else ():
            try:
                os.remove(p)
            except OSError:
                pass
    if switch_off:
        brian2.prefs.logging.file_log = False
        brian2.prefs.logging.save_script = False


def mend_interrupt_handler() -> None:
    """Brian2 replaces the SIGINT handler at import with one that stops a running network and
    otherwise calls the handler it replaced. Where that was not a function (a process started
    with SIGINT ignored: a background job of a shell script, ``nohup cmd &``), the call raised a
    TypeError and an interrupt became an internal error (exit 1). An ignored SIGINT stays
    ignored, as in any program started so (SIGTERM still interrupts: exit 130); a default one
    becomes Python's KeyboardInterrupt. A no-op outside the main thread (signals are set
    there only) and when Brian2's handler is no longer installed."""
    import signal
    import threading

    brian2 = sys.modules.get("brian2")
    handler = getattr(brian2, "_int_handler", None)
    previous = getattr(handler, "previous_handler", None)
    if handler is None or callable(previous):
        return
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGINT) is not handler:
        return
    if previous == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    else:  # SIG_DFL, or None: set outside Python
        handler.previous_handler = signal.default_int_handler


def install_interrupt_handler() -> None:
    """Install Brian2's Ctrl-C handler (a clean stop of a running network at the end of a
    step) where Brian2 was imported in another thread than the main one, which could not
    install it. From the main thread only, and only while Python's own handler is in place
    (a handler the user installed stays); a no-op otherwise and once installed."""
    import signal
    import threading

    global _handler_pending
    if not _handler_pending:
        return
    brian2 = sys.modules.get("brian2")
    handler = getattr(brian2, "_int_handler", None)
    if handler is None or threading.current_thread() is not threading.main_thread():
        return
    current = signal.getsignal(signal.SIGINT)
    if current is handler or current is not signal.default_int_handler:
        return
    handler.previous_handler = current
    signal.signal(signal.SIGINT, handler)
    _handler_pending = False


class _Loader:  # an importlib Loader (duck-typed: importlib.abc is slow to import)
    def __init__(self, inner: importlib.abc.Loader) -> None:
        self.inner = inner

    def __getattr__(self, name: str) -> object:  # resource readers, get_source, ...
        return getattr(self.inner, name)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        return self.inner.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        import shutil
        import tempfile

        remove_stale()
        private = tempfile.mkdtemp(prefix=f"{PREFIX}{os.getpid()}-")
        before = tempfile.tempdir
        tempfile.tempdir = private
        without = _WithoutExtras()
        if without.skipped:
            sys.meta_path.insert(0, without)
        hook = sys.excepthook
        try:
            with _signals_from_any_thread():
                self.inner.exec_module(module)
            close_debug_files()
            mend_interrupt_handler()
            _keep_brian_banner_to_brian(hook)
        finally:
            if without in sys.meta_path:
                sys.meta_path.remove(without)
            tempfile.tempdir = before
            shutil.rmtree(private, ignore_errors=True)


def _keep_brian_banner_to_brian(previous) -> None:  # noqa: ANN001
    """Brian2's import sets ``sys.excepthook`` to a hook that prints "Brian 2 encountered an
    unexpected error. If you think this is a bug in Brian 2, please report ..." before any
    uncaught exception. A script calling ``ac.run(...)`` with a bad keyword then saw that banner
    above astrocpg's own error, blaming Brian2. Brian2's hook is kept for what Brian2 raised (the
    innermost frame in Brian2's code); anything else goes to the hook that was in place before
    (Python's own, or the user's)."""
    brian_hook = sys.excepthook
    if brian_hook is previous:
        return
    brian_dir = os.path.dirname(getattr(sys.modules.get("brian2"), "__file__", "") or "")

    def excepthook(exc_type, exc, tb):  # noqa: ANN001, ANN202
        last = tb
        while last is not None and last.tb_next is not None:
            last = last.tb_next
        where = last.tb_frame.f_code.co_filename if last is not None else ""
        if brian_dir and os.path.abspath(where).startswith(brian_dir + os.sep):
            return brian_hook(exc_type, exc, tb)
        return previous(exc_type, exc, tb)

    excepthook.brian_hook = brian_hook  # type: ignore[attr-defined]
    sys.excepthook = excepthook


class _signals_from_any_thread:  # a context manager, only while Brian2's own import runs
    """Brian2's import installs its Ctrl-C handler with ``signal.signal``, which only the main
    thread may call: imported first from another thread (``ac.run`` in a thread, a Dask task),
    the import failed with ``ValueError: signal only works in main thread``. While it runs, a
    call from another thread installs nothing (and returns the handler in place); the handler
    is installed later, from the main thread, by :func:`install_interrupt_handler`. A call
    from the main thread is passed through unchanged."""

    def __enter__(self) -> None:
        import signal
        import threading

        global _handler_pending
        self.signal_module, self.real = signal, signal.signal
        if threading.current_thread() is threading.main_thread():
            return
        _handler_pending = True

        def from_this_thread(signalnum, handler):  # noqa: ANN001, ANN202
            if threading.current_thread() is threading.main_thread():
                return self.real(signalnum, handler)
            return signal.getsignal(signalnum)

        signal.signal = from_this_thread

    def __exit__(self, *exc: object) -> None:
        self.signal_module.signal = self.real


class _WithoutExtras:  # an importlib MetaPathFinder, only while Brian2's own import runs
    """Brian2's ``__init__`` does ``from pylab import *`` and its test package imports pytest;
    where either cannot be imported, Brian2 goes on without it (numpy's names alone; no
    ``brian2.test()``). Together they are about 0.65 s of every command's start-up (pyplot,
    pytest), for names astrocpg never uses: its figures are drawn with ``matplotlib.figure``
    when asked for. So Brian2 is imported as on a machine without them. A process that imported
    pylab or pyplot before (a notebook) keeps pylab's names; one that imported pytest (the test
    suite) keeps ``brian2.test()``."""

    def __init__(self) -> None:
        self.skipped = set()
        if "pylab" not in sys.modules and "matplotlib.pyplot" not in sys.modules:
            self.skipped.add("pylab")
        if "pytest" not in sys.modules:
            self.skipped.add("pytest")

    def find_spec(self, name, path=None, target=None):  # noqa: ANN001, ANN201
        if name in self.skipped:
            raise ImportError(f"{name} is not imported with Brian2 by astrocpg (start-up time)")
        return None


class _Finder:  # an importlib MetaPathFinder
    def find_spec(self, name, path=None, target=None):  # noqa: ANN001, ANN201
        if name != "brian2":
            return None
        sys.meta_path.remove(self)  # once: find the real spec, then wrap its loader
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = _Loader(spec.loader)
        return spec


def install() -> None:
    """Wrap the first import of Brian2 in this process (no-op if it is already imported)."""
    if "brian2" in sys.modules or any(isinstance(f, _Finder) for f in sys.meta_path):
        return
    sys.meta_path.insert(0, _Finder())
