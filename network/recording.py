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

from typing import Any, Callable, Protocol

import brian2
import numpy as np

from .populations import trace_sources

#: What a trace may be kept as: float32 (default) or float64 (Brian2's own resolution).
TRACE_DTYPES = ("float32", "float64")

#: Samples computed in float64 before they are rounded to float32 together: one cast of a block
#: instead of a cast (and a check of numpy's overflow flag) per sample and trace.
STAGED_SAMPLES = 64


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
        self.inf_values = 0  # values beyond float32's range, stored as inf
        self.inf_samples = 0  # samples (rows) holding one
        self.block = np.zeros((rows, self.columns), dtype=self.dtype)  # one rounded block
        #: each column's largest value so far, NaN ignored (a run's summary reads the peaks
        #: without reading the file back)
        self.column_max = np.full(self.columns, np.nan)
        self._block_max = np.empty(self.columns, dtype=self.dtype)
        self.closed = False

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
                self.inf_values += int(bad.sum())
                self.inf_samples += int(bad.any(axis=1).sum())
        if n:
            np.fmax.reduce(block, axis=0, out=self._block_max)
            np.fmax(self.column_max, self._block_max, out=self.column_max)
        self.sink.write(block)
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
        staged = self.dtype != np.float64
        #: float64 blocks of the samples not yet rounded into values (float32 only)
        self._stage: dict[str, np.ndarray] = {}
        #: the traces written to disk as the run goes (their samples are not in values)
        self.spilled: dict[str, SpilledTrace] = {}
        self._flushed = 0  # samples already in values
        rows = min(STAGED_SAMPLES, max(self.n_samples, 1))
        if spill_bytes is None:
            spill_bytes = SPILL_BYTES
        try:
            for name in traces:
                group, var, scale, _ = trace_sources()[name]
                table = cpg.table(group, var)
                columns = table.values.size
                # the table's values as one flat view, cached (read() refreshes it in place)
                self.sources[name] = (table, table.values.reshape(-1), float(scale))
                if spill is not None and \
                        self.n_samples * columns * self.dtype.itemsize >= spill_bytes:
                    path, sink = spill(name)
                    self.spilled[name] = SpilledTrace(name, path, sink, columns, self.dtype, rows)
                    self._stage[name] = np.zeros((rows, columns))
                    continue
                # written through once here: the memory is taken now, not page by page in the
                # run
                self.values[name] = np.empty((self.n_samples, columns), dtype=self.dtype)
                self.values[name].fill(0)
                if staged:
                    self._stage[name] = np.zeros((rows, columns))
        except BaseException:
            self.abandon()
            raise
        # what sample() does per trace, looked up once: the tables to refresh (a live view of
        # Brian2's array needs none), then (flat view, scale, where the sample goes)
        self._reads = [table.read for table, _, _ in self.sources.values() if not table.live]
        self._rows = rows  # samples per float64 block
        self._plan = [(flat, scale, self._stage.get(name), self.values.get(name))
                      for name, (_, flat, scale) in self.sources.items()]

    def operation(self) -> brian2.NetworkOperation:
        """At the start of every step, on the network's clock (one clock: Brian2's single-clock
        loop)."""
        return brian2.NetworkOperation(self.sample, clock=self.cpg.clock, when="start",
                                       order=0, name="trace_recorder")

    def sample(self) -> None:
        if self._timestep[0] != self._next or self.samples >= self.n_samples:
            return
        k = self.samples
        j = k - self._flushed  # its row in the float64 block (float32 traces)
        for read in self._reads:
            read()
        for flat, scale, stage, values in self._plan:
            # the stored unit computed in float64, rounded to float32 with its block (flush)
            np.multiply(flat, scale, out=values[k] if stage is None else stage[j])
        self.samples = k + 1
        self._next += self.stride
        if self._stage and j + 1 == self._rows:
            self.flush()

    def flush(self) -> None:
        """Round the float64 block of the latest samples into :attr:`values` (float32)."""
        n = self.samples - self._flushed
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
    (``--trace-dtype float64`` is the remedy, named wherever the mark is shown)."""
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
    """One sentence naming what :func:`overflowed` found, with the remedy; "" for nothing."""
    if not overflow:
        return ""
    what = "; ".join(f"{name} in {o['samples']} of {o['of_samples']} samples ({o['values']} "
                     f"values)" for name, o in overflow.items())
    return (f"traces beyond float32's range, recorded as inf: {what}; the simulation used "
            f"the finite values: record again with --trace-dtype float64 to keep them")


__all__ = ["SpikeRecorder", "TraceRecorder", "SpilledTrace", "SPILL_BYTES", "Sink",
            "TRACE_DTYPES", "STAGED_SAMPLES", "overflowed", "overflow_words"]
