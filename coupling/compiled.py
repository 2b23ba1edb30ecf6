"""Every trial's physics step in one call of compiled code.

Stepping ``n`` robots from Python costs, per trial and step, a call into MuJoCo's bindings and
three array copies (the motors' torques in, the joint state out): about 2 us each, 40 us of a
20-trial step. :func:`step_all` makes the same calls of MuJoCo's C library (copy the torques into
``ctrl``, ``mj_step``, copy ``qpos`` and ``qvel`` out) in one C loop over the trials, so the
results are the same, bit for bit. :func:`gather_sensors` copies the feet's touch sensors of
every trial into one array the same way, for the recorders and senses that read them every
step.

The loop is compiled once per MuJoCo version with the C compiler Python was built with,
against the headers and the library that ship with the ``mujoco`` package, and kept in
``~/.cache/astrocpg`` (``$ASTROCPG_CACHE``). Without a C compiler, or with
``ASTROCPG_COMPILED_PHYSICS`` off (``0``, ``false``, ``no``, ``off``), the robots are stepped
from Python as before. A cached library that cannot be loaded (damaged, truncated, of another
machine) or lacks the loop is removed and built again, once per process; if that fails too, a
warning says so and the robots are stepped from Python.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import subprocess
import sysconfig
import tempfile
import warnings
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np

from ..environment import flag

log = logging.getLogger("astrocpg.compiled")

SOURCE = r"""
#include <string.h>
#include <mujoco/mujoco.h>

/* One physics step of trials 0..n-1. Row b of `state` holds qpos, qvel and ctrl of trial b
   (row doubles apart): its ctrl goes to MuJoCo, mj_step runs, qpos and qvel come back.
   Returns 1 if a trial has an instability warning (bad qacc, qpos, qvel or ctrl), else 0. */
int astrocpg_step_all(const mjModel* m, mjData** d, int n, double* state, int row) {
    int nq = m->nq, nv = m->nv, nu = m->nu, warned = 0;
    for (int b = 0; b < n; b++) {
        double* r = state + (size_t)b * row;
        mjData* x = d[b];
        memcpy(x->ctrl, r + nq + nv, sizeof(mjtNum) * nu);
        mj_step(m, x);
        memcpy(r, x->qpos, sizeof(mjtNum) * nq);
        memcpy(r + nq, x->qvel, sizeof(mjtNum) * nv);
        if (x->warning[mjWARN_BADQACC].number || x->warning[mjWARN_BADQPOS].number
            || x->warning[mjWARN_BADQVEL].number || x->warning[mjWARN_BADCTRL].number)
            warned = 1;
    }
    return warned;
}

/* k values of every trial's sensordata from address adr into row b of `out` (k apart): the
   feet's touch sensors of a batch in one call instead of one copy per trial from Python. */
void astrocpg_gather_sensors(mjData** d, int n, int adr, int k, double* out) {
    for (int b = 0; b < n; b++)
        memcpy(out + (size_t)b * k, d[b]->sensordata + adr, sizeof(mjtNum) * k);
}
"""

_LIBRARY: Any = None  # the loaded library, False once building it failed
#: why a bad cached library could not be replaced (None: no such problem in this process)
PROBLEM: str | None = None


def _cache_dir() -> Path:
    return Path(os.environ.get("ASTROCPG_CACHE", Path.home() / ".cache" / "astrocpg"))


def _mujoco_library() -> tuple[Path, Path]:
    """The ``mujoco`` package's C library and its include folder."""
    root = Path(mujoco.__file__).resolve().parent
    libs = sorted(root.glob("libmujoco.so*")) + sorted(root.glob("libmujoco*.dylib"))
    if not libs or not (root / "include" / "mujoco" / "mujoco.h").is_file():
        raise FileNotFoundError(f"no libmujoco and headers in {root}")
    return libs[0], root / "include"


class BadLibrary(OSError):
    """A cached library that cannot be loaded or lacks ``astrocpg_step_all``."""


def _target() -> Path:
    library, _ = _mujoco_library()
    key = hashlib.sha256(f"{SOURCE}{mujoco.__version__}{library}".encode()).hexdigest()[:16]
    return _cache_dir() / f"physics_{key}{sysconfig.get_config_var('SHLIB_SUFFIX') or '.so'}"


def _load(target: Path) -> ctypes.CDLL:
    """The library at ``target`` with its loop's signature set; BadLibrary when the file is
    not a loadable library or has no loop (the handle is closed again: a later load of a
    rebuilt file at the same path must not get this one back from the loader's cache)."""
    try:
        lib = ctypes.CDLL(str(target))
    except OSError as e:
        raise BadLibrary(f"cannot load {target}: {e}") from None
    try:
        fn, gather = lib.astrocpg_step_all, lib.astrocpg_gather_sensors
    except AttributeError:
        _close(lib)
        raise BadLibrary(f"{target} has no astrocpg_step_all or astrocpg_gather_sensors") \
            from None
    fn.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p,
                   ctypes.c_int]
    fn.restype = ctypes.c_int
    gather.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                       ctypes.c_void_p]
    gather.restype = None
    return lib


def _close(lib: ctypes.CDLL) -> None:
    try:
        import _ctypes

        _ctypes.dlclose(lib._handle)  # POSIX only; elsewhere the rebuilt file is loaded anew
    except (ImportError, AttributeError, OSError):
        pass


def _build() -> ctypes.CDLL:
    """The compiled loop: the cached library, else built now; a cached one that is bad is
    removed and built again once (BadLibrary if that one is bad too)."""
    target = _target()
    if not target.is_file():
        _compile(target)
        return _load(target)
    try:
        return _load(target)
    except BadLibrary as e:
        bad = e
    log.info("rebuilding the compiled physics: %s", bad)
    try:
        target.unlink()
    except FileNotFoundError:
        pass
    try:
        _compile(target)
    except (OSError, subprocess.SubprocessError) as e:
        raise BadLibrary(f"{bad}; building it again failed: {type(e).__name__}") from None
    return _load(target)


def _compile(target: Path) -> None:
    library, include = _mujoco_library()
    if not target.is_file():
        target.parent.mkdir(parents=True, exist_ok=True)
        cc = (sysconfig.get_config_var("CC") or "cc").split()
        with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
            src, out = Path(tmp) / "physics.c", Path(tmp) / target.name
            src.write_text(SOURCE)
            subprocess.run([*cc, "-O2", "-shared", "-fPIC", f"-I{include}", "-o", str(out),
                            str(src), str(library), f"-Wl,-rpath,{library.parent}"],
                           check=True, capture_output=True, timeout=120)
            os.replace(out, target)  # whole or not at all, whoever builds it at the same time


def library() -> ctypes.CDLL | None:
    """The compiled loop, built at first use; None where it cannot be built or is turned off
    (``ASTROCPG_COMPILED_PHYSICS`` false)."""
    global _LIBRARY, PROBLEM
    if not flag("ASTROCPG_COMPILED_PHYSICS"):  # InputError naming it for a value not a boolean
        return None
    if _LIBRARY is None:
        try:
            _LIBRARY = _build()
        except BadLibrary as e:  # a cached library was bad, and so is the one built now
            PROBLEM = (f"the compiled physics cannot be used ({e}); the robots are stepped "
                       f"from Python (slower, the same results)")
            warnings.warn(PROBLEM, RuntimeWarning, stacklevel=2)
            _LIBRARY = False
        except (OSError, subprocess.SubprocessError, FileNotFoundError) as e:
            log.debug("compiled physics unavailable, stepping from Python: %s", e)
            _LIBRARY = False
    return _LIBRARY or None


def state() -> str:
    """How the robots' physics steps in this process, for a manifest: ``compiled``,
    ``python (ASTROCPG_COMPILED_PHYSICS off)``, ``python (no C compiler...)``, or ``not used
    yet``."""
    if not flag("ASTROCPG_COMPILED_PHYSICS"):
        return "python (ASTROCPG_COMPILED_PHYSICS off)"
    if _LIBRARY is None:
        return "not used yet"
    if _LIBRARY is False:
        return f"python ({PROBLEM or 'the compiled loop could not be built here'})"
    return "compiled"


def step_all(model: mujoco.MjModel, data: list[mujoco.MjData],
             state: np.ndarray) -> Callable[[], int] | None:
    """A function that steps every MjData of ``data`` once with its row of ``state`` (qpos,
    qvel, ctrl; C-contiguous float64) and returns 1 if MuJoCo warned of instability; None
    where the compiled loop is not available."""
    lib = library()
    if lib is None or state.dtype != np.float64 or not state.flags.c_contiguous:
        return None
    pointers = np.array([d._address for d in data], dtype=np.uintp)
    fn = lib.astrocpg_step_all
    args = (ctypes.c_void_p(model._address), ctypes.c_void_p(pointers.ctypes.data),
            ctypes.c_int(len(data)), ctypes.c_void_p(state.ctypes.data),
            ctypes.c_int(state.shape[1]))
    # the objects the pointers point into stay alive as long as the function does
    keep = (model, data, state, pointers)

    def step() -> int:
        return fn(*args)

    step.keep = keep  # type: ignore[attr-defined]
    return step


def gather_sensors(data: list[mujoco.MjData], adr: int, k: int,
                   out: np.ndarray) -> Callable[[], None] | None:
    """A function that copies ``k`` values of every MjData's ``sensordata`` from ``adr`` into
    row b of ``out`` ((len(data), k), C-contiguous float64, kept: the same array every call);
    None where the compiled loop is not available."""
    lib = library()
    if lib is None or out.dtype != np.float64 or not out.flags.c_contiguous \
            or out.shape != (len(data), k):
        return None
    pointers = np.array([d._address for d in data], dtype=np.uintp)
    fn = lib.astrocpg_gather_sensors
    args = (ctypes.c_void_p(pointers.ctypes.data), ctypes.c_int(len(data)), ctypes.c_int(adr),
            ctypes.c_int(k), ctypes.c_void_p(out.ctypes.data))
    keep = (data, out, pointers)

    def gather() -> None:
        fn(*args)

    gather.keep = keep  # type: ignore[attr-defined]
    return gather


__all__ = ["step_all", "gather_sensors", "library", "state", "SOURCE", "PROBLEM"]
