"""Every trial's physics step in one call of compiled code.

Stepping ``n`` robots from Python costs, per trial and step, a call into MuJoCo's bindings and
three array copies (the motors' torques in, the joint state out): about 2 us each, 40 us of a
20-trial step. :func:`step_all` makes the same calls of MuJoCo's C library (copy the torques into
``ctrl``, ``mj_step``, copy ``qpos`` and ``qvel`` out) in one C loop over the trials, so the
results are the same, bit for bit. :func:`gather_sensors` copies the feet's touch sensors of
every trial into one array the same way, for the recorders and senses that read them every
step, and :func:`take_robots` writes every trial's sample of a run's robot recording (joints,
applied torques, torso, reward, alive, feet) in one call: the values numpy's copies give.

The loop is compiled once per MuJoCo version with the C compiler Python was built with,
against the headers and the library that ship with the ``mujoco`` package, and kept in
``~/.cache/astrocpg`` (``$ASTROCPG_CACHE``; built and cached by :mod:`astrocpg.network.native`). Without a C compiler, or with
``ASTROCPG_COMPILED_PHYSICS`` off (``0``, ``false``, ``no``, ``off``), the robots are stepped
from Python as before. A cached library that cannot be loaded (damaged, truncated, of another
machine) or lacks the loop is removed and built again, once per process; if that fails too, a
warning says so and the robots are stepped from Python.
"""

from __future__ import annotations

import ctypes
import logging
import subprocess
import warnings
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np

from ..support.environment import flag
from ..network import native

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

/* Where one sample of every trial's robot goes (the run's recording, robot_recording.py): each
   output is sample-major, sample k of trial b at row k * n + b of a `width`-wide table. */
typedef struct {
    int n, row, nq, nv, nj;          /* trials; doubles per state row; joints recorded */
    const long long* qa;             /* the joints' offsets in qpos */
    const long long* act;            /* their motors' offsets in ctrl */
    const double* lo;                /* the motors' ctrlrange: what MuJoCo applies */
    const double* hi;
    int fq, fv;                      /* the free joint's qpos and dof addresses */
    const double* state;             /* the robots' state rows: qpos, qvel, ctrl */
    const double* reward;            /* (n,) this step's reward */
    const unsigned char* alive;      /* (n,) numpy bools */
    mjData** d;                      /* NULL: the touch sensors are not gathered here */
    int touch_adr, touch_k;
    double *angles, *torques, *position, *velocity, *quaternion, *reward_out, *touch;
    unsigned char* alive_out;
} astrocpg_take_plan;

/* Sample k of every trial: joint angles, applied torques (ctrl clamped to ctrlrange as
   np.clip clamps it: NaN stays NaN), torso position, velocity and quaternion, reward, alive and
   the feet's touch sensors: what Recording.take writes with numpy, in one call. */
void astrocpg_take(const astrocpg_take_plan* p, long k) {
    int n = p->n, nj = p->nj;
    size_t s = (size_t)k * n;
    for (int b = 0; b < n; b++) {
        const double* q = p->state + (size_t)b * p->row;
        const double* v = q + p->nq;
        const double* c = v + p->nv;
        double* ang = p->angles + (s + b) * nj;
        double* tor = p->torques + (s + b) * nj;
        for (int j = 0; j < nj; j++) {
            double u = c[p->act[j]];
            u = u < p->lo[j] ? p->lo[j] : u;
            tor[j] = u > p->hi[j] ? p->hi[j] : u;
            ang[j] = q[p->qa[j]];
        }
        memcpy(p->position + (s + b) * 3, q + p->fq, sizeof(double) * 3);
        memcpy(p->quaternion + (s + b) * 4, q + p->fq + 3, sizeof(double) * 4);
        memcpy(p->velocity + (s + b) * 3, v + p->fv, sizeof(double) * 3);
        p->reward_out[s + b] = p->reward[b];
        p->alive_out[s + b] = p->alive[b];
        if (p->d)
            memcpy(p->touch + (s + b) * p->touch_k, p->d[b]->sensordata + p->touch_adr,
                   sizeof(mjtNum) * p->touch_k);
    }
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

#: the library's functions and their signatures (``native.load`` sets them)
FUNCTIONS: dict[str, native.Signature] = {
    "astrocpg_step_all": ([ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p,
                           ctypes.c_int], ctypes.c_int),
    "astrocpg_gather_sensors": ([ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                 ctypes.c_void_p], None),
    "astrocpg_take": ([ctypes.c_void_p, ctypes.c_long], None),
}


def _mujoco_library() -> tuple[Path, Path]:
    """The ``mujoco`` package's C library and its include folder."""
    root = Path(mujoco.__file__).resolve().parent
    libs = sorted(root.glob("libmujoco.so*")) + sorted(root.glob("libmujoco*.dylib"))
    if not libs or not (root / "include" / "mujoco" / "mujoco.h").is_file():
        raise FileNotFoundError(f"no libmujoco and headers in {root}")
    return libs[0], root / "include"


def _target() -> Path:
    library, _ = _mujoco_library()
    return native.target("physics", SOURCE, mujoco.__version__, str(library))


def _load(target: Path) -> ctypes.CDLL:
    return native.load(target, FUNCTIONS)


def _compile(target: Path) -> None:
    library, include = _mujoco_library()
    native.compile_source(target, SOURCE, [f"-I{include}", str(library),
                                           f"-Wl,-rpath,{library.parent}"])


def _build() -> ctypes.CDLL:
    """The compiled loop: the cached library, else built now; a cached one that is bad is
    removed and built again once (BadLibrary if that one is bad too)."""
    return native.build(_target(), lambda target: _compile(target), _load,
                        "the compiled physics")


def library() -> ctypes.CDLL | None:
    """The compiled loop, built at first use; None where it cannot be built or is turned off
    (``ASTROCPG_COMPILED_PHYSICS`` false)."""
    global _LIBRARY, PROBLEM
    if not flag("ASTROCPG_COMPILED_PHYSICS"):  # InputError naming it for a value not a boolean
        return None
    if _LIBRARY is None:
        try:
            _LIBRARY = _build()
        except native.BadLibrary as e:  # a cached library was bad, and so is the one built now
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


class _TakePlan(ctypes.Structure):
    """``astrocpg_take_plan`` of :data:`SOURCE`, field for field."""

    _fields_ = [(name, ctypes.c_int) for name in ("n", "row", "nq", "nv", "nj")] + [
        ("qa", ctypes.c_void_p), ("act", ctypes.c_void_p), ("lo", ctypes.c_void_p),
        ("hi", ctypes.c_void_p), ("fq", ctypes.c_int), ("fv", ctypes.c_int),
        ("state", ctypes.c_void_p), ("reward", ctypes.c_void_p), ("alive", ctypes.c_void_p),
        ("d", ctypes.c_void_p), ("touch_adr", ctypes.c_int), ("touch_k", ctypes.c_int)] + [
        (name, ctypes.c_void_p) for name in ("angles", "torques", "position", "velocity",
                                             "quaternion", "reward_out", "touch", "alive_out")]


def take_robots(data: list[mujoco.MjData], state: np.ndarray, nq: int, nv: int,
                qa: np.ndarray, act: np.ndarray, lo: np.ndarray, hi: np.ndarray, fq: int,
                fv: int, reward: np.ndarray, alive: np.ndarray, touch: tuple[int, int] | None,
                out: dict[str, np.ndarray]) -> Callable[[int], None] | None:
    """A function ``take(k)`` that writes sample ``k`` of every trial's robot into ``out``
    (``angles``, ``torques``: nj values per trial; ``position``, ``velocity``: 3;
    ``quaternion``: 4; ``touch``: the sensors' count; ``reward``; ``alive``, bool: each the
    samples of a run, C-contiguous, sample-major: ``out[name][k, b]`` trial b's sample k) from the robots' ``state`` rows
    (qpos, qvel, ctrl) and the senses' ``reward`` and ``alive``, the torques clamped to
    [``lo``, ``hi``] as MuJoCo applies them; ``touch``: (address, count) of the feet's sensors
    in every MjData's ``sensordata``, or None to leave ``out["touch"]`` alone. The same values
    as the numpy copies of ``Recording.take``, in one call; None where the compiled loop is not
    available or an array is not laid out as this needs."""
    lib = library()
    n = len(data)
    shapes = {"angles": (qa.size,), "torques": (qa.size,), "position": (3,),
              "velocity": (3,), "quaternion": (4,), "reward": (), "alive": (),
              "touch": (4 if touch is None else touch[1],)}
    if lib is None or state.dtype != np.float64 or not state.flags.c_contiguous \
            or reward.dtype != np.float64 or alive.dtype != np.bool_ \
            or reward.shape != (n,) or alive.shape != (n,) or act.size != qa.size:
        return None
    for name, tail in shapes.items():
        a = out[name]
        if a.ndim < 2 or a.shape[1] != n or int(np.prod(a.shape[2:])) != int(np.prod(tail)) \
                or not a.flags.c_contiguous or \
                a.dtype != (np.bool_ if name == "alive" else np.float64):
            return None
    index = [np.ascontiguousarray(x, dtype=np.int64).reshape(-1) for x in (qa, act)]
    bounds = [np.ascontiguousarray(x, dtype=np.float64).reshape(-1) for x in (lo, hi)]
    pointers = np.array([d._address for d in data], dtype=np.uintp)
    plan = _TakePlan(n=n, row=state.shape[1], nq=nq, nv=nv, nj=qa.size,
                     qa=index[0].ctypes.data, act=index[1].ctypes.data,
                     lo=bounds[0].ctypes.data, hi=bounds[1].ctypes.data, fq=fq, fv=fv,
                     state=state.ctypes.data, reward=reward.ctypes.data,
                     alive=alive.ctypes.data,
                     d=None if touch is None else pointers.ctypes.data,
                     touch_adr=0 if touch is None else touch[0],
                     touch_k=0 if touch is None else touch[1],
                     **{("reward_out" if k == "reward" else "alive_out" if k == "alive" else k):
                        out[k].ctypes.data for k in shapes})
    fn, ref = lib.astrocpg_take, ctypes.byref(plan)
    keep = (data, state, reward, alive, index, bounds, pointers, out, plan)

    def take(k: int) -> None:
        fn(ref, k)

    take.keep = keep  # type: ignore[attr-defined]
    return take


__all__ = ["step_all", "gather_sensors", "take_robots", "library", "state", "SOURCE", "PROBLEM"]
