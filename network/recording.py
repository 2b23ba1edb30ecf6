"""Traces of a run, recorded into arrays allocated once for the whole run.

A Brian2 ``StateMonitor`` keeps float64 samples in arrays that grow by doubling as the run
goes, so a run held up to twice its traces' size in float64, most of it the motor neurons'
[Ca2+]: about 7 MiB per trial per simulated second. :class:`TraceRecorder` samples the same
variables at the same point of the step (Brian2's ``start`` slot: the state after the previous
step, labelled with the step's start time, as a ``StateMonitor`` labels it) into arrays of the
run's final size, converted to the stored unit (:mod:`astrocpg.network.populations`) in float64
and then kept as ``dtype``: float32 by default (7 significant digits: 0.0001 of a [Ca2+] of 10),
float64 for full resolution. With float32 a default run keeps about 1.8 MiB per trial per
simulated second (``studies.runtime.resources`` counts it before a run starts).
"""

from __future__ import annotations

import ctypes
import mmap
import warnings
from typing import Any, Callable, Protocol

import brian2
import numpy as np

from ..support.environment import flag
from . import native
from .populations import trace_sources

#: What a trace may be kept as: float32 (default) or float64 (Brian2's own resolution).
TRACE_DTYPES = ("float32", "float64")

#: Samples computed in float64 before they are rounded to float32 together: one cast of a block
#: instead of a cast (and a check of numpy's overflow flag) per sample and trace.
STAGED_SAMPLES = 64


#: One step's samples of every trace in one call (:class:`TraceRecorder`, where a C compiler is
#: found and ``ASTROCPG_COMPILED_RECORDING`` is on): the float64 product of the network's value
#: and the trace's scale rounded to float32 (or kept as float64) as numpy rounds it, so the
#: same bytes as the numpy path, and for a spilled trace the counts of infinities and each
#: column's largest value, taken on the way instead of in a pass over each block.
KERNEL_SOURCE = r"""
#include <string.h>

typedef struct {
    const double* src;      /* the network's values, flat, in the files' column order */
    long n;                 /* values per sample */
    double scale;           /* to the stored unit */
    char* dst;              /* row 0 of where samples go: the held values or a spill block */
    long row_bytes;
    int f32;                /* kept as float32 (else float64) */
    int in_block;           /* its rows are the block's (j), not the run's (k) */
    void* top;              /* NULL, or each column's largest value so far (the trace's own
                               type: float32 compared four at a time), NaN ignored */
    long long* inf;         /* NULL, or (values beyond float32's range, samples holding one) */
} astrocpg_trace;

void astrocpg_sample_traces(const astrocpg_trace* t, int m, long k, long j) {
    for (int i = 0; i < m; i++, t++) {
        const double* s = t->src;
        char* row = t->dst + (t->in_block ? j : k) * t->row_bytes;
        long n = t->n, bad = 0;
        /* each pass is a loop without branches, vectorised (one loop doing both is not) */
        if (t->f32) {
            float* d = (float*)row;
            float* top = (float*)t->top;
            for (long c = 0; c < n; c++)
                d[c] = (float)(s[c] * t->scale);
            if (t->inf) {
                unsigned int b = 0;  /* an infinity's bits, compared as integers */
                for (long c = 0; c < n; c++) {
                    unsigned int u;
                    memcpy(&u, d + c, sizeof u);
                    b += (u & 0x7fffffffu) == 0x7f800000u;
                }
                bad = b;
            }
            if (top)
                for (long c = 0; c < n; c++) {
                    float f = d[c], m = top[c];
                    top[c] = ((f == f) & !(f <= m)) ? f : m;
                }
        } else {
            double* d = (double*)row;
            double* top = (double*)t->top;
            for (long c = 0; c < n; c++)
                d[c] = s[c] * t->scale;
            if (top)
                for (long c = 0; c < n; c++) {
                    double v = d[c], m = top[c];
                    top[c] = ((v == v) & !(v <= m)) ? v : m;
                }
        }
        if (bad && t->inf) {
            t->inf[0] += bad;
            t->inf[1] += 1;
        }
    }
}
"""


class _Trace(ctypes.Structure):
    """``astrocpg_trace`` of :data:`KERNEL_SOURCE`, field for field."""

    _fields_ = [("src", ctypes.c_void_p), ("n", ctypes.c_long), ("scale", ctypes.c_double),
                ("dst", ctypes.c_void_p), ("row_bytes", ctypes.c_long), ("f32", ctypes.c_int),
                ("in_block", ctypes.c_int), ("top", ctypes.c_void_p),
                ("inf", ctypes.c_void_p)]


KERNEL = native.Library("recording", KERNEL_SOURCE, {
    "astrocpg_sample_traces": ([ctypes.c_void_p, ctypes.c_int, ctypes.c_long, ctypes.c_long],
                               None)}, "the compiled trace recorder", flags=("-O3",))


def kernel() -> Any:
    """The compiled trace sampler, or None (off: ``ASTROCPG_COMPILED_RECORDING``; no C
    compiler; a bad cached library that could not be rebuilt: :attr:`KERNEL.problem
    <astrocpg.network.native.Library.problem>`, warned once): the recorder then samples with
    numpy, the same values."""
    if not flag("ASTROCPG_COMPILED_RECORDING"):
        return None
    first = KERNEL.lib is None
    lib = KERNEL.get()
    if lib is None and first and KERNEL.problem:
        warnings.warn(f"{KERNEL.problem}; traces are sampled with numpy (slower, the same "
                      f"values)", RuntimeWarning, stacklevel=2)
    return None if lib is None else lib.astrocpg_sample_traces


def kernel_state() -> str:
    """How this process samples traces, for a manifest: ``compiled``, ``numpy
    (ASTROCPG_COMPILED_RECORDING off)``, ``numpy (<why>)`` or ``not used yet``."""
    if not flag("ASTROCPG_COMPILED_RECORDING"):
        return "numpy (ASTROCPG_COMPILED_RECORDING off)"
    if KERNEL.lib is None:
        return "not used yet"
    if KERNEL.lib is False:
        return f"numpy ({KERNEL.problem or 'the compiled sampler could not be built here'})"
    return "compiled"


class SpikeRecorder(brian2.SpikeMonitor):
    """Brian2's ``SpikeMonitor``, the same spikes in the same arrays, its per-step growth made
    cheaper.

    Every step with a spike, the monitor's compiled code calls :meth:`resize` from C, and
    Brian2's own goes through the monitor's variables and the device to each dynamic array
    (about 28,000 such calls in a 12 s, 20-trial run: a few percent of the recorded run). On
    Brian2's runtime device (numpy and Cython targets) that path ends in the arrays' own
    ``resize``; this one calls those directly, looked up once. Elsewhere (another device), and
    until the arrays exist, it is Brian2's."""

    _dynamic: tuple[Any, ...] | None = None

    def resize(self, new_size: int) -> None:
        arrays = self._dynamic
        if not arrays:
            arrays = _runtime_arrays(self, self.record_variables)
            if not arrays:  # not Brian2's runtime device, or nothing recorded: Brian2's path
                super().resize(new_size)
                return
            self._dynamic = arrays
        for array in arrays:
            array.resize(new_size)


def _runtime_arrays(monitor: Any, names: Any) -> tuple[Any, ...]:
    """The dynamic arrays behind ``names`` of ``monitor`` on Brian2's runtime device, whose
    ``resize`` is all its device's does for them; () where that is not so."""
    from brian2.devices.device import RuntimeDevice, get_device

    device = get_device()
    if type(device).resize is not RuntimeDevice.resize:
        return ()
    out = []
    for name in names:
        var = monitor.variables[name]
        array = device.arrays.get(var)
        if array is None or var.resize_along_first or not hasattr(array, "resize"):
            return ()
        out.append(array)
    return tuple(out)


#: A trace of at least this many bytes goes to disk as the run goes (where the recorder is given
#: somewhere to put it): held in memory, a 12 s, 20-trial run's motor_Ca is 293 MiB of fresh
#: memory kept until the run ends (peak resident memory 670 MB against 375 MB spilled).
SPILL_BYTES = 8 << 20


class Sink(Protocol):
    """Where a spilled trace's bytes go (``write``, then ``close`` or ``abandon``)."""

    def write(self, data: Any) -> int: ...

    def close(self) -> Any: ...

    def abandon(self) -> None: ...


class SpilledTrace:
    """A trace written to a file as the run went, not held in memory: ``samples`` rows of
    ``columns`` values of ``dtype`` (the rows of the ``.npy`` it becomes, nothing else in the
    file), with the counts :func:`overflowed` needs, taken on the way. ``path``: the file."""

    is_spilled_trace = True  # how the writers (which do not import the network) know one
    npz_offset: int | None = None  # where its data starts in the .npz it was copied into

    def __init__(self, name: str, path: Any, sink: Sink, columns: int, dtype: np.dtype,
                 rows: int) -> None:
        self.name, self.path, self.sink = name, path, sink
        self.columns, self.dtype = int(columns), np.dtype(dtype)
        self.samples = 0
        #: values beyond float32's range (stored as inf), samples (rows) holding one
        self.inf_counts = np.zeros(2, dtype=np.int64)
        # one rounded block, page-aligned (anonymous memory): a sink that writes past the page
        # cache takes it as it is (studies/outputs/writing.DirectFile), without a copy
        nbytes = max(rows * self.columns * self.dtype.itemsize, 1)
        self.block = np.frombuffer(mmap.mmap(-1, nbytes), dtype=np.uint8, count=nbytes
                                   ).view(self.dtype).reshape(rows, self.columns)
        #: each column's largest value so far, NaN ignored, in the trace's dtype
        #: (:attr:`column_max`)
        self.top = np.full(self.columns, np.nan, dtype=self.dtype)
        self._block_max = np.empty(self.columns, dtype=self.dtype)
        self.closed = False

    @property
    def column_max(self) -> np.ndarray:
        """Each column's largest value (float64), NaN where all were NaN or none was written:
        a run's summary reads the peaks without reading the file back."""
        return self.top.astype(np.float64)

    @property
    def inf_values(self) -> int:
        return int(self.inf_counts[0])

    @property
    def inf_samples(self) -> int:
        return int(self.inf_counts[1])

    @property
    def shape(self) -> tuple[int, int]:
        return (self.samples, self.columns)

    @property
    def nbytes(self) -> int:
        return self.samples * self.columns * self.dtype.itemsize

    @property
    def size(self) -> int:
        return self.samples * self.columns

    def append(self, stage: np.ndarray) -> None:
        """Round the float64 rows ``stage`` to the trace's dtype and write them."""
        n = len(stage)
        block = self.block[:n]
        with np.errstate(over="ignore"):
            np.copyto(block, stage, casting="same_kind")
        if self.dtype == np.float32:
            # a finite sum means no infinity: the values are counted only where one may be
            with np.errstate(over="ignore", invalid="ignore"):
                maybe = not np.isfinite(block.sum())
            if maybe:
                bad = np.isinf(block)
                self.inf_counts += (int(bad.sum()), int(bad.any(axis=1).sum()))
        if n:
            np.fmax.reduce(block, axis=0, out=self._block_max)
            np.fmax(self.top, self._block_max, out=self.top)
        self.write_block(n)

    def write_block(self, n: int) -> None:
        """Write the first ``n`` rows of :attr:`block`, rounded and counted (by
        :meth:`append`, or by the compiled recorder as it sampled them)."""
        self.sink.write(self.block[:n])
        self.samples += n

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.sink.close()

    def abandon(self) -> None:
        if not self.closed:
            self.closed = True
            self.sink.abandon()


class TraceRecorder:
    """Samples ``traces`` of ``cpg`` every ``stride`` steps for ``n_steps`` steps from the
    network's time at construction; :meth:`operation` is the ``NetworkOperation`` to add.

    values[name]: (samples, columns) in the files' column order (trial-major), in the trace's
    stored unit; :meth:`collected` gives ``{name: (t, values)}`` of the samples taken. Kept as
    float32, the latest samples (up to :data:`STAGED_SAMPLES`) wait in a float64 block until
    it is full or :meth:`collected` (or :meth:`flush`) is called: the same product, rounded
    once to float32, as if each sample had been rounded when taken.

    With ``spill`` (``spill(name) -> (path, sink)``), a trace whose samples would take
    ``spill_bytes`` (default :data:`SPILL_BYTES`) or more is not held: each rounded block is
    written to its sink as it is flushed (:attr:`spilled`, a :class:`SpilledTrace` per such
    trace), the same bytes its ``.npy`` would hold."""

    def __init__(self, cpg: Any, traces: tuple[str, ...], *, stride: int, n_steps: int,
                 dtype: str = "float32",
                 spill: Callable[[str], tuple[Any, Sink]] | None = None,
                 spill_bytes: int | None = None) -> None:
        if dtype not in TRACE_DTYPES:
            raise ValueError(f"trace dtype must be one of {', '.join(TRACE_DTYPES)}, "
                             f"got {dtype!r}")
        self.cpg, self.stride, self.dtype = cpg, int(stride), np.dtype(dtype)
        self.n_samples = (int(n_steps) + self.stride - 1) // self.stride
        self._timestep = cpg.clock.variables["timestep"].get_value()  # live (1,) array
        self.first_step = int(self._timestep[0])
        self._next = self.first_step
        self.samples = 0
        self.dt = float(cpg.dt)
        self.sources: dict[str, tuple[Any, np.ndarray, float]] = {}
        self.values: dict[str, np.ndarray] = {}
        #: float64 blocks of the samples not yet rounded into values (float32 only, numpy path)
        self._stage: dict[str, np.ndarray] = {}
        #: the traces written to disk as the run goes (their samples are not in values)
        self.spilled: dict[str, SpilledTrace] = {}
        self._flushed = 0  # samples already in values
        rows = min(STAGED_SAMPLES, max(self.n_samples, 1))
        if spill_bytes is None:
            spill_bytes = SPILL_BYTES
        try:
            sources = trace_sources(cpg.layout.rows)  # the network's rows, added ones too
            for name in traces:
                group, var, scale, _ = sources[name]
                table = cpg.table(group, var)
                columns = table.values.size
                # the table's values as one flat view, cached (read() refreshes it in place)
                self.sources[name] = (table, table.values.reshape(-1), float(scale))
                if spill is not None and \
                        self.n_samples * columns * self.dtype.itemsize >= spill_bytes:
                    path, sink = spill(name)
                    self.spilled[name] = SpilledTrace(name, path, sink, columns, self.dtype, rows)
                    continue
                # written through once here: the memory is taken now, not page by page in the
                # run
                self.values[name] = np.empty((self.n_samples, columns), dtype=self.dtype)
                self.values[name].fill(0)
            #: every trace's sample of a step in one call of compiled code (None: numpy)
            self._compiled = self._compiled_sampler()
            if self._compiled is None:
                for name, (_, flat, _) in self.sources.items():
                    if name in self.spilled or self.dtype != np.float64:
                        self._stage[name] = np.zeros((rows, flat.size))
        except BaseException:
            self.abandon()
            raise
        # what sample() does per trace, looked up once: the tables to refresh (a live view of
        # Brian2's array needs none), then (flat view, scale, where the sample goes)
        self._reads = [table.read for table, _, _ in self.sources.values() if not table.live]
        self._rows = rows  # samples per float64 block
        self._plan = [(flat, scale, self._stage.get(name), self.values.get(name))
                      for name, (_, flat, scale) in self.sources.items()]

    def _compiled_sampler(self) -> Callable[[int, int], None] | None:
        """``sample(k, j)``: every trace's sample k (row j of a spilled trace's block) by the
        compiled kernel (:func:`kernel`); None where there is none or a source is not one
        float64 array that the table refreshes in place."""
        fn = kernel()
        if fn is None:
            return None
        traces = []
        for name, (table, flat, scale) in self.sources.items():
            if flat.dtype != np.float64 or not flat.flags.c_contiguous \
                    or not np.shares_memory(flat, table.values):
                return None
            spilled = self.spilled.get(name)
            dst = self.values[name] if spilled is None else spilled.block
            f32 = self.dtype == np.float32
            traces.append(_Trace(
                src=flat.ctypes.data, n=flat.size, scale=scale, dst=dst.ctypes.data,
                row_bytes=dst.strides[0], f32=f32, in_block=spilled is not None,
                top=None if spilled is None else spilled.top.ctypes.data,
                inf=spilled.inf_counts.ctypes.data if spilled is not None and f32 else None))
        plan, m = (_Trace * len(traces))(*traces), len(traces)

        def sample(k: int, j: int) -> None:
            fn(plan, m, k, j)
        # the arrays the plan points into are this recorder's and its tables' own, held by it
        sample.keep = plan  # type: ignore[attr-defined]
        return sample

    def operation(self) -> brian2.NetworkOperation:
        """At the start of every step, on the network's clock (one clock: Brian2's single-clock
        loop)."""
        return brian2.NetworkOperation(self.sample, clock=self.cpg.clock, when="start",
                                       order=0, name="trace_recorder")

    def sample(self) -> None:
        if self._timestep[0] != self._next or self.samples >= self.n_samples:
            return
        k = self.samples
        j = k - self._flushed  # its row in the block (float64 stage, or a spilled trace's)
        for read in self._reads:
            read()
        if self._compiled is not None:
            self._compiled(k, j)
        else:
            for flat, scale, stage, values in self._plan:
                # the stored unit computed in float64, rounded to float32 with its block
                # (flush)
                np.multiply(flat, scale, out=values[k] if stage is None else stage[j])
        self.samples = k + 1
        self._next += self.stride
        if j + 1 == self._rows and (self._stage or self.spilled):
            self.flush()

    def flush(self) -> None:
        """Round the float64 block of the latest samples into :attr:`values` (float32), or
        write a spilled trace's block (its samples already rounded by the compiled kernel)."""
        n = self.samples - self._flushed
        if n > 0 and self._compiled is not None:  # rounded and counted as they were sampled
            for spilled in self.spilled.values():
                spilled.write_block(n)
            self._flushed = self.samples
        if n <= 0 or not self._stage:
            return
        # a value beyond float32's range becomes inf: counted after the run (overflowed()),
        # marked in the manifest and the summary, so numpy's warning would only repeat it
        with np.errstate(over="ignore"):
            for name, stage in self._stage.items():
                spilled = self.spilled.get(name)
                if spilled is not None:
                    spilled.append(stage[:n])
                else:
                    self.values[name][self._flushed:self.samples] = stage[:n]
        self._flushed = self.samples

    def times(self) -> np.ndarray:
        """Sampling times (s): the start of each sampled step."""
        return (self.first_step + np.arange(self.samples) * self.stride) * self.dt

    def collected(self) -> dict[str, tuple[np.ndarray, Any]]:
        """``{trace: (t, values)}`` of the samples taken so far (views, not copies), in the
        order the traces were asked for; a spilled trace's values are its
        :class:`SpilledTrace`, its file closed (nothing more is recorded into it)."""
        self.flush()
        t = self.times()
        out: dict[str, tuple[np.ndarray, Any]] = {}
        for name in self.sources:
            spilled = self.spilled.get(name)
            if spilled is not None:
                spilled.close()
                out[name] = (t, spilled)
            else:
                out[name] = (t, self.values[name][:self.samples])
        return out

    def abandon(self) -> None:
        """Throw away what was spilled (the run will not be written)."""
        for spilled in self.spilled.values():
            spilled.abandon()

    def nbytes(self) -> int:
        return sum(v.nbytes for v in self.values.values()) + \
            sum(v.nbytes for v in self._stage.values()) + \
            sum(s.block.nbytes for s in self.spilled.values())


def overflowed(traces: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, dict[str, Any]]:
    """``{trace: {"dtype", "values", "of", "samples"}}`` of the traces kept as float32 that
    hold values beyond float32's range (about 3.4e38), stored as infinities: how many values
    of how many, and in how many samples (time points). A state that is itself infinite (or
    beyond 1e50) stops the run as diverged, so an infinity in a trace of a finished run is
    always this overflow: the simulation went on with the finite value, only its record lost
    it. The run is marked rather than refused or widened: the values are not known before the
    run, and widening every trace to float64 would double the memory the run was sized for
    (``trace_dtype`` float64 is the remedy, named wherever the mark is shown)."""
    out: dict[str, dict[str, Any]] = {}
    for name, (_, v) in traces.items():
        if isinstance(v, SpilledTrace):  # counted as it was written
            if v.dtype == np.float32 and v.inf_values:
                out[name] = {"dtype": "float32", "values": v.inf_values,
                             "of": v.samples * v.columns, "samples": v.inf_samples,
                             "of_samples": v.samples}
            continue
        v = np.asarray(v)
        if v.dtype != np.float32 or not v.size:
            continue
        # a finite sum means no infinity (an inf makes the sum inf or nan): one pass without a
        # temporary; only a trace that may hold one is counted value by value
        with np.errstate(over="ignore", invalid="ignore"):  # large finite values may sum to inf
            maybe = not np.isfinite(v.sum())
        if not maybe:
            continue
        bad = np.isinf(v)
        n = int(bad.sum())
        if n:
            rows = int(bad.reshape(len(v), -1).any(axis=1).sum()) if v.ndim else 1
            out[name] = {"dtype": "float32", "values": n, "of": int(v.size), "samples": rows,
                         "of_samples": int(len(v)) if v.ndim else 1}
    return out


def overflow_words(overflow: dict[str, dict[str, Any]]) -> str:
    """One sentence naming what :func:`overflowed` found, with the remedy (the ``trace_dtype``
    setting, by its field: the sentence is printed, warned and exported alike); "" for
    nothing."""
    if not overflow:
        return ""
    what = "; ".join(f"{name} in {o['samples']} of {o['of_samples']} samples ({o['values']} "
                     f"values)" for name, o in overflow.items())
    return (f"traces beyond float32's range, recorded as inf: {what}; the simulation used "
            f"the finite values: record again with trace_dtype float64 to keep them")


__all__ = ["SpikeRecorder", "TraceRecorder", "SpilledTrace", "SPILL_BYTES", "Sink",
            "TRACE_DTYPES", "STAGED_SAMPLES", "overflowed", "overflow_words"]
