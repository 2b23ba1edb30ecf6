"""An astrocyte's own response: its adenosine release rate and mean [ADO] against its pool's
spike rate, alone, for any astrocyte model (``astrocpg response astrocyte``).

The astrocyte is the one the network builds: the model set's ``astrocyte`` (the built-in one,
or a model file given as ``models`` ``astrocyte=FILE``, with ``overrides``), integrated by
Brian2 from its own equations, threshold, reset, refractory period and parameters. Only its
input is not the network's: in place of a motor-neuron pool, each astrocyte's ``n_pool`` (the
spikes of its pool in a 1 ms step) is drawn each step from a Poisson distribution of mean
``rate * dt``, so its 2-AG rises by ``r_AG`` per spike as in the network (the astrocyte model's
own equation for it). A trained pool fires in bursts at the rhythm's period; over the
astrocyte's slow 2-AG and IP3 (time constants of 1 s and more) the mean rate is what counts.

For every rate, ``replicates`` astrocytes with their own Poisson inputs run for ``warmup``
seconds (not counted: the astrocyte starts from its model's initial state) and then
``seconds`` measured: releases (threshold crossings that pass the refractory period) per second
and the time mean of [ADO], each as the mean over the replicates with their smallest and
largest value. Everything runs in one Brian2 network of ``len(rates) * replicates`` astrocytes.
"""

from __future__ import annotations

import math
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import Diverged, Field, InputError, setting, shown_with
from ...models.compose import Overrides, model_files_record, model_set, override_items
from ...network.wiring import check_parameters_reach
from ...network.runlock import exclusive
from ..outputs.folder import OutputFolder
from ..outputs.writing import atomic_write, write_manifest
from ..runtime.progress import time_bar
from ..settings.checks import STEP, check_duration, number, seed_number

#: the most astrocytes one response runs (rates x replicates)
MAX_CELLS = 100_000
#: the models whose response this command draws
RESPONSE_MODELS = ("astrocyte",)
COLUMNS = ("pool_rate_Hz", "replicates", "releases_per_s", "releases_per_s_min",
           "releases_per_s_max", "mean_ADO", "mean_ADO_min", "mean_ADO_max")

_RANGE = re.compile(r"^\s*([0-9.eE+-]+)\s*:\s*([0-9.eE+-]+)\s*:\s*([0-9.eE+-]+)\s*$")


@dataclass(frozen=True)
class Response:
    """What :func:`~astrocpg.response` measured: ``summary`` (the rows, the release limit, the marks
    read off the curve), the checked ``settings``, the model set used and the folder written
    (None when nothing was)."""

    summary: dict[str, Any]
    settings: dict[str, Any]
    models: Any
    folder: Path | None = None

    @property
    def rows(self) -> list[dict[str, float]]:
        return self.summary["rows"]


def parse_rates(text: Any, culprit: str | Field = setting("rates")) -> tuple[float, ...]:
    """Pool rates in spikes/s: ``START:STOP:STEP`` (STOP included when the steps reach it) or
    a list ``A,B,C`` (a text, or a sequence of numbers); each finite and >= 0."""
    if isinstance(text, str):
        m = _RANGE.match(text)
        if m:
            start, stop, step = (number(float(x), culprit) if _is_float(x) else _bad(text, culprit)
                                 for x in m.groups())
            if step <= 0 or stop < start:
                raise InputError(f"START:STOP:STEP needs STEP > 0 and STOP >= START, got "
                                 f"'{text}'", culprit=culprit)
            n = int(math.floor((stop - start) / step + 1e-9)) + 1
            if n > MAX_CELLS:
                raise InputError(f"'{text}' gives {n} rates, more than {MAX_CELLS}",
                                 culprit=culprit)
            values = [start + k * step for k in range(n)]
        else:
            values = [float(x) if _is_float(x) else _bad(text, culprit)
                      for x in text.split(",") if x.strip()]
    elif isinstance(text, (list, tuple, np.ndarray)):
        values = [number(x, culprit) for x in text]
    else:
        raise InputError(f"expected START:STOP:STEP or a list of rates, got "
                         f"{type(text).__name__}", culprit=culprit)
    if not values:
        raise InputError("names no rate", culprit=culprit)
    for v in values:
        number(v, culprit, minimum=0.0)
    return tuple(float(v) for v in values)


def _is_float(x: str) -> bool:
    try:
        return math.isfinite(float(x))
    except ValueError:
        return False


def _bad(text: str, culprit: str) -> Any:
    raise InputError(f"expected START:STOP:STEP (e.g. 0:1000:50) or rates A,B,C in spikes/s, "
                     f"got '{text}'", culprit=culprit)


def parse_marks(marks: Sequence[str] | Mapping[str, Any] | None,
                culprit: str | Field = setting("marks")) -> dict[str, float]:
    """``LABEL=RATE`` items (or ``{label: rate}``): pool rates drawn beside the curve."""
    if not marks:
        return {}
    items = marks.items() if isinstance(marks, Mapping) else \
        (str(m).partition("=")[::2] for m in marks)
    out: dict[str, float] = {}
    for label, value in items:
        label = str(label).strip()
        if not label or not _is_float(str(value)):
            raise InputError(f"expected LABEL=RATE (e.g. 1.0x=566), got '{label}={value}'",
                             culprit=culprit)
        out[label] = float(number(float(value), shown_with(culprit, label), minimum=0.0))
    return out


def release_limit(model: Any) -> float | None:
    """Releases per second the model's refractory period allows (its ``refractory`` names a
    parameter with a time), None when it does not say."""
    name = str(getattr(model, "refractory", "") or "").strip()
    # the name is the model's own (its refractory statement), looked up in its whole table
    declared = dict(model.parameters.items())
    if name in declared:
        value = float(np.asarray(declared[name].value))
        return 1.0 / value if value > 0 else None
    return None


@exclusive  # one Brian2 build-and-run at a time (network/runlock.py)
def simulate_response(model: Any, rates: Sequence[float], *, seconds: float, warmup: float,
                      replicates: int, seed: int, progress: bool = False
                      ) -> dict[str, np.ndarray]:
    """Releases per second and mean [ADO] of ``replicates`` astrocytes of ``model`` (a
    :class:`~astrocpg.models.NeuronModel` with the astrocyte's interface) per pool rate, each
    fed Poisson spike counts; arrays of shape (len(rates), replicates)."""
    import brian2
    from brian2 import Clock, Hz, Network, NeuronGroup, SpikeMonitor, second

    brian2.seed(seed)
    n = len(rates) * replicates
    clock = Clock(dt=STEP * second)
    source = NeuronGroup(n, """
        rate : Hz (constant)  # the pool's spike rate
        n : 1  # the pool's spikes in this step
        ADO_seen : 1 (linked)  # the astrocyte's [ADO]
        ADO_sum : 1  # [ADO] summed over the measured steps
        """, name="poisson_pool", clock=clock)
    source.rate = np.repeat(np.asarray(rates, dtype=float), replicates) * Hz
    try:
        astro = NeuronGroup(
            n, model.equations, threshold=model.threshold or None, reset=model.reset or None,
            refractory=model.refractory if model.refractory else False, method=model.method,
            namespace=model.parameters.namespace(), name="astrocyte", clock=clock)
        for var, value in model.initial_values.items():
            setattr(astro, var, value)
        astro.n_pool = brian2.linked_var(source, "n")
    except InputError:
        raise
    except Exception as e:  # noqa: BLE001 - Brian2's errors, as one line naming the model
        from ...models.base import brian_error_line
        raise InputError(brian_error_line(e), culprit=model.name) from None
    check_parameters_reach(astro, model)
    source.ADO_seen = brian2.linked_var(astro, "ADO")
    draw = source.run_regularly("n = poisson(rate*dt)", when="start", name="poisson_draw")
    add = source.run_regularly("ADO_sum += ADO_seen", when="end", name="ado_sum")
    add.active = False
    # a model without a threshold never releases: nothing to count
    releases = SpikeMonitor(astro, record=False, name="releases") if model.threshold else None
    net = Network(source, astro, draw, add, *([releases] if releases is not None else []))
    bar = time_bar(check_duration(warmup + seconds), STEP, "response", progress)
    try:
        _run_in_chunks(net, warmup, bar)
        before = _counts(releases, n)
        add.active = True
        _run_in_chunks(net, seconds, bar)
    finally:
        bar.close()
    counts = _counts(releases, n) - before
    steps = check_duration(seconds)
    mean_ado = np.asarray(source.ADO_sum[:], dtype=float) / steps
    for var in ("ADO",):
        if not np.all(np.isfinite(np.asarray(getattr(astro, var)[:], dtype=float))):
            raise Diverged(f"astrocyte {var} left the numbers", culprit=model.name,
                           t=warmup + seconds)
    shape = (len(rates), replicates)
    return {"releases_per_s": (counts / seconds).reshape(shape),
            "mean_ADO": mean_ado.reshape(shape)}


def _counts(releases: Any, n: int) -> np.ndarray:
    """Releases so far per astrocyte (zeros without a monitor: a model without threshold)."""
    return np.zeros(n) if releases is None else np.array(releases.count[:], dtype=float)


def _run_in_chunks(net: Any, seconds: float, bar: Any, chunk: float = 10.0) -> None:
    """``net.run`` over ``seconds`` in whole steps, ``chunk`` seconds at a time (the bar moves
    between them); an interrupted run raises KeyboardInterrupt."""
    from brian2 import second

    steps, per = (int(round(seconds / STEP)), int(round(chunk / STEP)))
    while steps > 0:
        n = min(steps, per)
        t_end = float(net.t / second) + n * STEP
        net.run(n * STEP * second, namespace={})
        if float(net.t / second) < t_end - 0.5 * STEP:  # Brian2 stopped it (Ctrl-C)
            raise KeyboardInterrupt
        bar.update(n)
        steps -= n


def response_table(rates: Sequence[float], raw: Mapping[str, np.ndarray]) -> list[dict[str, float]]:
    """One row per rate: the replicates' mean, smallest and largest value of each measure."""
    rows = []
    for k, rate in enumerate(rates):
        row: dict[str, float] = {"pool_rate_Hz": float(rate),
                                 "replicates": int(raw["releases_per_s"].shape[1])}
        for key in ("releases_per_s", "mean_ADO"):
            v = raw[key][k]
            row |= {key: float(v.mean()), f"{key}_min": float(v.min()),
                    f"{key}_max": float(v.max())}
        rows.append(row)
    return rows


def interpolate(rows: Sequence[Mapping[str, float]], rate: float, key: str) -> float:
    """``key`` at pool rate ``rate``, linearly between the rows' rates (NaN outside them)."""
    x = np.array([r["pool_rate_Hz"] for r in rows])
    y = np.array([r[key] for r in rows])
    if rate < x.min() or rate > x.max():
        return float("nan")
    return float(np.interp(rate, x, y))


def response(model: str = "astrocyte", *, rates: Any = "0:1000:50", seconds: float = 100.0,
             warmup: float = 200.0, replicates: int = 4, seed: int = 1,
             marks: Sequence[str] | Mapping[str, Any] | None = None,
             overrides: Overrides | None = None, equations: Mapping[str, str] | None = None,
             models: Mapping[str, Any] | None = None, out: str | Path | None = None,
             overwrite: bool = False, progress: bool = True,
             inputs: Sequence[str | os.PathLike] = ()) -> Response:
    """The response of one astrocyte model to its pool's spike rate: what ``astrocpg response
    astrocyte`` runs.

    Each astrocyte (the model set's ``astrocyte``: built in, or a model file in ``models``, with
    ``overrides``) is fed Poisson pool spikes at one rate through its 2-AG input; its adenosine
    releases and mean [ADO] are measured after a warm-up.

    Parameters
    ----------
    model : str
        The model whose response is measured ("astrocyte").
    rates : str or sequence of float
        Pool spike rates in spikes/s: ``"0:1000:50"``, ``"100,540"`` or numbers.
    seconds : float
        Measured time per astrocyte, in s, after ``warmup`` seconds.
    warmup : float
        Simulated time before the measurement, in s (the astrocyte settles over ~100 s near the
        onset of its oscillations).
    replicates : int
        Astrocytes per rate, each with its own Poisson input.
    seed : int
        Brian2's seed for the Poisson inputs.
    marks : sequence of str or mapping, optional
        ``LABEL=RATE`` pool rates drawn beside the curve and read off it (e.g. a trained
        network's rate per drive).
    overrides, equations, models : optional
        Parameter values with units, equation texts and whole model files, as for
        :func:`~astrocpg.run`.
    out : path, optional
        Writes ``response.csv``, ``response.png`` and ``manifest.json`` there (whole, or
        nothing).
    overwrite : bool
        Replace a folder that holds files (only one astrocpg wrote; never one of ``inputs``).
    progress : bool
        A progress bar over the simulated time.
    inputs : sequence of path
        Files the caller read: ``out`` may not be or hold one.

    Returns
    -------
    Response
        A :class:`~astrocpg.studies.commands.response.Response` whose ``summary`` holds the
        rows, the release limit the refractory period allows and each mark's values. Bad input
        raises InputError naming the culprit, before anything runs.
    """
    if model not in RESPONSE_MODELS:
        raise InputError(f"no response for '{model}' (models: {', '.join(RESPONSE_MODELS)})",
                         culprit="response MODEL")
    kind = model
    rates, seconds, warmup, replicates, seed, marked = _checked_sizes(
        rates, seconds, warmup, replicates, seed, marks)
    if out is not None:
        OutputFolder(out, overwrite=overwrite, inputs=inputs).check()
    files = model_files_record(models)
    model_set_ = model_set(overrides, equations, models=models)
    chosen = getattr(model_set_, kind)
    settings: dict[str, Any] = {
        "model": kind, "rates_Hz": list(rates), "seconds": seconds, "warmup": warmup,
        "replicates": replicates, "seed": seed, "marks": marked,
        "overrides": override_items(overrides), "equations": dict(equations or {}),
        "input": "Poisson spike counts of mean rate*dt per 1 ms step into n_pool"}
    if files:
        settings["models"] = files
    t0 = time.perf_counter()
    raw = simulate_response(chosen, rates, seconds=seconds, warmup=warmup,
                            replicates=replicates, seed=seed, progress=progress)
    rows = response_table(rates, raw)
    summary = _summary(rows, chosen, marked, time.perf_counter() - t0)
    if out is not None:
        with OutputFolder(out, overwrite=overwrite, inputs=inputs) as folder:
            write_response_folder(folder, rows, summary, settings, model_set_, chosen.name)
    return Response(summary=summary, settings=settings, models=model_set_,
                    folder=Path(out) if out is not None else None)


def _summary(rows: list[dict[str, float]], chosen: Any, marked: Mapping[str, float],
             wall: float) -> dict[str, Any]:
    """A response's summary: its rows, the release limit the refractory period allows and each
    mark's release rate and mean [ADO], interpolated."""
    return {"rows": rows, "release_limit_per_s": release_limit(chosen),
            "marks": {label: {"pool_rate_Hz": rate,
                              "releases_per_s": interpolate(rows, rate, "releases_per_s"),
                              "mean_ADO": interpolate(rows, rate, "mean_ADO")}
                      for label, rate in marked.items()},
            "wall_seconds": wall, "status": "finished"}


def _checked_sizes(rates: Any, seconds: Any, warmup: Any, replicates: Any, seed: Any,
                   marks: Any) -> tuple[tuple[float, ...], float, float, int, int, dict[str, float]]:
    """A response's rates, seconds and warm-up (whole steps), replicates (at most
    :data:`MAX_CELLS` astrocytes in all), seed and marks, checked."""
    rates = parse_rates(rates)
    seconds = number(seconds, setting("seconds"), positive=True)
    check_duration(seconds)
    warmup = number(warmup, setting("warmup"), minimum=0.0)
    if warmup:
        check_duration(warmup, culprit=setting("warmup"))
    replicates = number(replicates, setting("replicates"), integer=True, minimum=1)
    seed = seed_number(seed)
    marked = parse_marks(marks)
    if len(rates) * replicates > MAX_CELLS:
        raise InputError(f"{len(rates)} rates x {replicates} replicates is more than "
                         f"{MAX_CELLS} astrocytes", culprit=setting("replicates"))
    return rates, seconds, warmup, replicates, seed, marked


def write_response_folder(folder: Path, rows: Sequence[Mapping[str, float]],
                          summary: Mapping[str, Any], settings: Mapping[str, Any],
                          models: Any, name: str) -> None:
    """response.csv, response.png and manifest.json."""
    from ..figures.save import save_figure

    def write_csv(f: Any) -> None:
        f.write((",".join(COLUMNS) + "\n").encode())
        for r in rows:
            f.write((",".join(repr(r[c]) if isinstance(r[c], float) else str(r[c])
                              for c in COLUMNS) + "\n").encode())

    atomic_write(folder / "response.csv", write_csv)
    save_figure(response_figure(rows, summary, name), folder / "response.png")
    files = {"response.csv": "per pool rate (spikes/s): releases per second and mean [ADO] of "
                             "the replicates (mean, smallest, largest)",
             "response.png": "release rate and mean [ADO] against the pool's spike rate, the "
                             "marked pool rates drawn beside"}
    write_manifest(folder, command="response", seed=int(settings["seed"]), settings=settings,
                   models_json=models.to_json(), files=files, results=summary)


def response_figure(rows: Sequence[Mapping[str, float]], summary: Mapping[str, Any],
                    name: str) -> Any:
    """Two panels: releases per second and mean [ADO] against the pool's spike rate."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.6))
    x = np.array([r["pool_rate_Hz"] for r in rows])
    for ax, key, label in ((fig.add_subplot(1, 2, 1), "releases_per_s", "releases per second"),
                           (fig.add_subplot(1, 2, 2), "mean_ADO", "mean [ADO]")):
        y = np.array([r[key] for r in rows])
        ax.fill_between(x, [r[f"{key}_min"] for r in rows], [r[f"{key}_max"] for r in rows],
                        color="tab:blue", alpha=0.25, lw=0)
        ax.plot(x, y, "o-", color="tab:blue", ms=3)
        if key == "releases_per_s" and summary.get("release_limit_per_s"):
            ax.axhline(summary["release_limit_per_s"], color="0.5", ls=":", lw=1)
        for k, (mark, m) in enumerate(summary.get("marks", {}).items()):
            ax.axvline(m["pool_rate_Hz"], color=f"C{1 + k % 9}", ls="--", lw=1, label=mark)
        ax.set_xlabel("pool spike rate (spikes/s, Poisson)")
        ax.set_ylabel(label)
        ax.set_ylim(bottom=0)
    if summary.get("marks"):
        fig.axes[1].legend(fontsize=7, title="trained pools", title_fontsize=7)
    fig.suptitle(f"{name}: response to its pool's spike rate", fontsize=10)
    fig.tight_layout()
    return fig


def format_response(result: Response) -> list[str]:
    """Lines printed by ``astrocpg response``: the table, and each mark read off the curve."""
    s = result.summary
    lines = ["pool rate (spikes/s)  releases/s [min, max]   mean [ADO] [min, max]"]
    for r in s["rows"]:
        lines.append(f"{r['pool_rate_Hz']:10.1f}  {r['releases_per_s']:8.3f} "
                     f"[{r['releases_per_s_min']:.3f}, {r['releases_per_s_max']:.3f}]  "
                     f"{r['mean_ADO']:.4g} [{r['mean_ADO_min']:.4g}, {r['mean_ADO_max']:.4g}]")
    if s.get("release_limit_per_s"):
        lines.append(f"release limit of the refractory period: {s['release_limit_per_s']:.3f}/s")
    for label, m in s.get("marks", {}).items():
        lines.append(f"{label} ({m['pool_rate_Hz']:g} spikes/s): {m['releases_per_s']:.3f} "
                     f"releases/s, mean [ADO] {m['mean_ADO']:.4g}")
    return lines
