"""The closed loop: the CPG drives ``trials`` robots with fixed inter-limb weights.

``run(...)`` is what ``astrocpg run`` runs; ``replay(folder)`` runs a training's trained tables
(``astrocpg gait`` and ``astrocpg plot``).
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import KEYWORDS, Diverged, InputError, setting
from ...network import recording
from ...network.populations import trace_columns
from ...network.recording import overflow_words, overflowed
from ...support.reading import read_json
from ...models import ModelSet
from ..analysis.fall import fall_words, falls
from ..outputs.folder import OutputFolder, verify
from ..outputs.writing import (file_sha256, read_manifest, remove_files, save_npz,
                               save_spikes_and_traces, spill_files,
                               write_manifest)
from ..outputs.result import Result
from ..outputs.weights import check_table, load_weights, tables_state
from ...models.compose import Overrides, model_files_record, model_set, override_items
from ..settings.checks import (STEP, check_duration, check_selection, check_trace_dt,
                               check_trace_dtype, number, seed_number)
from ..settings.populations import (population_models, population_rows, population_table,
                                    same_populations)
from ..runtime.resources import RECORD_LESS, check_memory, estimate_batched
from ..runtime.workers import resolve_workers, workers_words
from ..settings import RunSettings
from .batched import try_batched
from .simulate import SimulationResult, firing_rates, simulate_closed_loop

ROBOT_FILE = ("t (s); joint_angles (trial, t, leg, joint) rad; torques (trial, t, leg, joint) "
              "N m; torso_position/velocity (trial, t, xyz) m, m/s world; torso_quaternion "
              "(trial, t, wxyz); reward, alive "
              "(trial, t); foot_force (trial, t, leg) N; interlimb_weights_mV (trial, 8, 8)")


def run(*, seconds: float = 10.0, seed: int | None = None, trials: int = 1,
        overrides: Overrides | None = None, equations: Mapping[str, str] | None = None,
        models: Mapping[str, Any] | None = None,
        weights: str | Path | np.ndarray | None = None, trial: int | None = None,
        robot: str | Path | None = None, trace_dt: float = 1.0, trace_dtype: str = "float32",
        robot_stride: int = 1,
        spikes: tuple[str, ...] | None = None, traces: tuple[str, ...] | None = None,
        out: str | Path | None = None, overwrite: bool = False, progress: bool = True,
        figure: bool = False,
        inputs: Sequence[str | os.PathLike] = (), session: int | None = None,
        populations: Any = None, workers: int | None = None) -> Result:
    """Run the CPG driving A1 robots in MuJoCo: the closed loop, what ``astrocpg run`` runs.

    Parameters
    ----------
    seconds, seed, trials : float, int or None, int
        Simulated time in s (whole 1 ms steps); seed of trial 0 (trial k: ``seed + k``; default:
        with ``weights`` a training folder, the seed its tables trained with, plus ``trial``,
        so that each table runs on its own network; else 1); robots.
    overrides, equations, models : optional
        Parameter values with units (``{"tau_motor": "9*ms"}`` or ``["tau_motor=9*ms"]``);
        ``{model: equation text}``; ``{model: model file text}`` replacing whole models.
    weights : path or array, optional
        Inter-limb tables: an 8x8 table in mV as a file (.npy/.npz/.json/.csv) or a training
        folder (its final tables, or its latest with a warning while it runs or after it
        stopped early; ``trial`` picks one), or an array with a unit, ``table * mV``, of shape
        (8, 8) or (trials, 8, 8), range-checked as a file is (a plain array of numbers is
        refused); default zero.
    trial : int, optional
        With ``weights`` a training folder: its trial whose tables drive the robots.
    robot : path, optional
        An MJCF file with the A1's joint and actuator names (default: the project's A1).
    trace_dt, trace_dtype, robot_stride : float, str, int
        Trace sampling in ms; float32 or float64 (full resolution); physics steps between robot
        samples.
    spikes, traces : tuple of str, optional
        Which populations' spikes and which traces to record (None: all).
    out, overwrite, progress : optional
        Write the folder ``astrocpg run`` writes (``overwrite``: replace one astrocpg wrote); a
        progress bar on stderr.
    figure : bool
        Also draw ``thigh_extensor_activity.png`` into ``out`` (``astrocpg plot`` draws it later).
    inputs : sequence of path
        Files the caller read (e.g. model files): ``out`` may not be or hold one, nor ``weights``
        and ``robot`` (:func:`~astrocpg.studies.outputs.folder.check_output_path`).
    session : int, optional
        With ``weights`` a training folder: replay that session (1-based) of trial ``trial``
        exactly, learning on (:func:`~astrocpg.replay_session`; ``out`` required).
    populations : sequence or mapping, optional
        Model files with a ``[population]`` table, added to the network for this call
        (docs/model-files.md); a training folder's own added populations are built too.
    workers : int, optional
        Processes the trials are split over (default: the cores this process may use); the
        results are the same whatever the number.

    Returns
    -------
    Result
        A :class:`~astrocpg.studies.outputs.result.Result` of kind "run" ("train" for a replayed
        ``session``): spikes, traces, the robot's arrays (``result.robot``) and ``summary``
        (distance_m, mean_forward_speed_m_per_s, upright_share, rate_per_neuron_Hz per trial).
    """
    if session is not None:
        if populations:
            raise InputError("a replay runs the training's own network",
                             culprit=setting("populations"))
        return _replay(locals())

    # before any other check; a training's tables run on its network: its populations too
    population_record = with_trained_populations(weights, population_rows(populations)[1])
    rows = population_table(population_record)  # the table this run is built from
    plan = _plan_run(dict(locals()), rows)  # every check and estimate: nothing touched
    return _run_planned(plan, out, overwrite, progress, figure)


@dataclasses.dataclass(frozen=True)
class RunPlan:
    """What :func:`run` simulates, checked: the manifest's ``settings`` (the checked values,
    whichever door called), the model set, the population table, the world with its robot,
    the tables, the processes and what the folder may not replace (``inputs``)."""

    settings: dict[str, Any]
    models: ModelSet
    model: Any
    layout: Any
    table: np.ndarray | None
    procs: int
    inputs: list[Any]
    robot_info: dict[str, Any]
    rows: tuple[Any, ...] = ()


def _plan_run(a: dict[str, Any], rows: Sequence[Any]) -> RunPlan:
    """:func:`run`'s arguments ``a`` checked, its memory estimated and its models, tables and
    world built; refused (InputError) before anything is simulated or written."""
    weights, trial, robot, out = a["weights"], a["trial"], a["robot"], a["out"]
    seconds, trials, seed, trace_dt, robot_stride, trace_dtype = _checked_sizes(
        a["seconds"], a["trials"], a["seed"], weights, trial, a["trace_dt"], a["robot_stride"],
        a["trace_dtype"])
    # what the run reads: out may not replace it (nor hold it)
    inputs = [*a["inputs"], *([weights] if isinstance(weights, (str, os.PathLike)) else []),
              *([robot] if robot is not None else [])]
    if out is not None:  # before the simulation, not after
        OutputFolder(out, overwrite=a["overwrite"], inputs=inputs).check()
    pops, names = check_selection(a["spikes"], a["traces"], rows)
    procs = min(resolve_workers(a["workers"]), trials)
    check_memory(estimate_batched(
        procs, trials=trials, seconds=seconds, dt=STEP, trace_dt=trace_dt * 1e-3,
        traces=trace_columns(names, rows), spikes=bool(pops), robot_stride=robot_stride,
        trace_bytes=np.dtype(trace_dtype).itemsize, spill_bytes=None if out is None
        else recording.SPILL_BYTES),
        culprit=f"{setting('seconds', f'{seconds:g}')} x {setting('trials', trials)}"
        + workers_words(procs), record_less=RECORD_LESS)
    files = model_files_record(a["models"])
    models = model_set(a["overrides"], a["equations"], models=a["models"],
                       added=[r.model for r in rows if not r.built_in])
    table, weights, tables_label = _weights_table(weights, trial, trials, models)
    params, model, layout = _robot_world(models, robot)
    values = RunSettings(
        seconds=seconds, seed=seed, trials=trials, trace_dt=trace_dt, trace_dtype=trace_dtype,
        robot_stride=robot_stride, overrides=override_items(a["overrides"]),
        equations=a["equations"], spikes=a["spikes"], traces=a["traces"],
        weights=None if weights is None or isinstance(weights, np.ndarray) else str(weights),
        trial=trial, robot=None if robot is None else str(robot), tables=tables_label,
        figure=a["figure"], models=files, populations=a["population_record"])
    settings = values.record()
    robot_info = ({"file": os.path.abspath(robot), "sha256": file_sha256(robot)} if robot
                  else {"file": None, "builtin": "astrocpg A1", "parameters": str(params)})
    return RunPlan(settings=settings, models=models, model=model, layout=layout, table=table,
                   procs=procs, inputs=inputs, robot_info=robot_info, rows=tuple(rows))


def _run_planned(plan: RunPlan, out: str | Path | None, overwrite: bool, progress: bool,
                 figure: bool) -> Result:
    """Simulate ``plan`` (over its processes, or here), then write its folder (whole, or
    nothing) where ``out`` is given."""
    p = plan
    start_x = p.layout.reset_qpos[p.layout.free_qpos_adr]

    def simulate(spill: Any) -> Any:  # over the workers, or here
        return _simulate(p.models, p.model, p.layout, dict(p.settings, weights=p.table),
                         p.procs, progress, spill, p.rows)

    def summarise(r: Any, e: Any = None) -> None:
        _summarise(r, p.models, start_x, p.robot_info, p.table, e)

    if out is None:
        result = simulate(None)
        summarise(result)
        summary = run_results(result)
    else:
        result, summary = _simulate_into(OutputFolder(out, overwrite=overwrite, inputs=p.inputs),
                                         simulate, summarise, p.settings, figure)
        result.traces = read_spilled(result.traces, Path(out) / "traces.npz")
    return Result.from_simulation(result, kind="run", seed=p.settings["seed"],
                                  settings=p.settings, summary=summary,
                                  robot=robot_arrays(result), models=p.models, folder=out)


def _checked_sizes(seconds: Any, trials: Any, seed: Any, weights: Any, trial: Any,
                   trace_dt: Any, robot_stride: Any, trace_dtype: Any
                   ) -> tuple[float, int, int, float, int, str]:
    """A run's sizes checked: seconds, trials, seed (a training's own with its tables),
    trace_dt (whole steps), robot_stride and trace_dtype."""
    _check_trial(trial, weights)
    seconds = number(seconds, setting("seconds"), positive=True)
    trials = number(trials, setting("trials"), integer=True, minimum=1)
    seed = seed_number(trained_seed(weights, trial, seed), trials=trials)
    trace_dt = number(trace_dt, setting("trace_dt"), positive=True)
    check_trace_dt(trace_dt)  # samples are taken at steps: a whole number of them
    robot_stride = number(robot_stride, setting("robot_stride"), integer=True, minimum=1)
    trace_dtype = check_trace_dtype(trace_dtype)
    check_duration(seconds, STEP)
    return seconds, trials, seed, trace_dt, robot_stride, trace_dtype


def _robot_world(models: Any, robot: str | Path | None) -> tuple[Any, Any, Any]:
    """(A1Parameters, the MuJoCo model of the world with the robot, its RobotLayout); a robot
    file whose timestep is not the CPG's is refused."""
    from ...coupling.robot import A1Parameters, RobotLayout, load_robot
    from ...coupling.world import world_model

    params = A1Parameters()
    model = world_model(models, params, load_robot(robot) if robot else None)
    if abs(model.opt.timestep - params.timestep) > 1e-12:
        raise InputError(f"timestep is {model.opt.timestep:g} s; the CPG steps with the physics "
                         f"at {params.timestep:g} s (set <option timestep=\"{params.timestep:g}\"/>)",
                         culprit=setting("robot", Path(robot).name))
    return params, model, RobotLayout.from_model(model, params)


def _check_trial(trial: int | None, weights: Any) -> None:
    """A trial picks one table of a training folder: with no weights, a weights file or an
    array there is nothing to pick from, and the option would be ignored."""
    if trial is not None and not (isinstance(weights, (str, os.PathLike))
                                  and Path(weights).is_dir()):
        raise InputError(f"picks a trial's table of a training folder: give one with "
                         f"{setting('weights')} "
                         "DIR" + ("" if weights is None else f" ({_shown(weights)} is not a "
                                                             f"training folder)"),
                         culprit=setting("trial", trial))


def array_table(weights: Any) -> np.ndarray:
    """Tables given as an array (``ac.run(weights=...)``), in volt: a Brian2 quantity of
    voltage (``table * mV``, ``table * volt``). A plain array of numbers is refused: files and
    ``ac.load(...).weights`` are in mV, Brian2's own unit is the volt, and a table read in the
    wrong one is silently clipped by the synapse, so the unit must be said."""
    from brian2 import Quantity, volt
    from brian2.units.fundamentalunits import fail_for_dimension_mismatch, DimensionMismatchError

    if not isinstance(weights, Quantity):
        try:
            np.asarray(weights, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"expected a file, a training folder or 8x8 tables with a unit "
                             f"(table * mV), got {type(weights).__name__}",
                             culprit="weights") from None
        raise InputError("an array of plain numbers has no unit: give it with one, "
                         "weights=table * mV (a training's tables, ac.load(...).weights, and "
                         "every weights file are in mV)", culprit="weights")
    try:
        fail_for_dimension_mismatch(weights, volt)
    except DimensionMismatchError:
        raise InputError(f"expected a voltage (table * mV), got a quantity in "
                         f"{weights.dim}", culprit="weights") from None
    table = np.asarray(weights / volt, dtype=float)
    if table.ndim not in (2, 3) or table.shape[-2:] != (8, 8) or not np.all(np.isfinite(table)):
        raise InputError(f"expected finite 8x8 tables, got shape {table.shape}",
                         culprit="weights")
    return table


def trained_seed(weights: Any, trial: int | None, seed: int | None) -> int:
    """The seed of a run: ``seed`` as given; with ``weights`` a training folder and no seed,
    the seed its table(s) trained with (the training's seed, plus ``trial``), so that a table
    runs on the network and noise it learnt on; otherwise 1. A given seed that differs from the
    training's is run, with a warning."""
    learnt = None
    if isinstance(weights, (str, os.PathLike)) and Path(weights).is_dir() \
            and (Path(weights) / "manifest.json").is_file():
        try:
            learnt = int(training_settings(weights).get("seed", 1)) + (trial or 0)
        except (InputError, TypeError, ValueError):
            learnt = None
    if seed is None:
        return 1 if learnt is None else learnt
    if learnt is not None and isinstance(seed, int) and seed != learnt:
        what = f"trial {trial}'s table" if trial is not None else "its tables"
        warnings.warn(f"{weights}: {what} trained with seed {learnt}; running with seed {seed} "
                      f"(another network and noise; leave the seed out to use {learnt})",
                      UserWarning, stacklevel=3)
    return seed


def _weights_table(weights: Any, trial: int | None, trials: int, models: Any
                   ) -> tuple[np.ndarray | None, Any, str | None]:
    """``run``'s ``weights`` as tables in volt (None: none), as the settings record them (an
    array given: the array), and, for a training folder, which of its tables they are
    ("final", or "after session N" with a warning while it runs or after it stopped early): a
    file's table checked against the synapse's range, a training folder's final tables
    (``trial``: one), an array of 8x8 tables with a unit (:func:`array_table`), range-checked
    too; as many tables as trials."""
    tables_label = None
    if weights is None:
        table = None
    elif isinstance(weights, (str, os.PathLike)):
        table = load_weights(weights, trial)
        if not Path(weights).is_dir():  # a user's table: in the synapse's range, or refused
            check_table(table, models, setting("weights", weights))
        else:  # a training's: its final tables, or said to be otherwise
            state = tables_state(weights)
            tables_label = state["label"]
            if state["warning"]:
                warnings.warn(KEYWORDS(state["warning"]), UserWarning, stacklevel=3)
    else:  # an array with a unit (mV, like every file and ac.load(...).weights)
        table = array_table(weights)
        check_table(table, models, "weights")  # in the synapse's range, as a file's is
        weights = table
    if table is not None and table.ndim == 3 and table.shape[0] != trials:
        raise InputError(f"holds {table.shape[0]} tables for {trials} trials",
                         culprit=setting("weights", "" if isinstance(weights, np.ndarray)
                                         else weights))
    return table, weights, tables_label


def _simulate(models: ModelSet, model: Any, layout: Any, spec: dict[str, Any], procs: int,
              progress: bool, spill: Any, rows: Sequence[Any] = ()) -> SimulationResult:
    """The run of ``spec`` (its checked settings, ``weights`` the tables in volt), with the
    population table ``rows``: over
    ``procs`` processes (:mod:`.batched`), else here (one process, or a batch that diverged:
    what diverged is then written as one process writes it)."""
    from brian2 import ms

    result = try_batched("run", spec, spec["trials"], procs, progress)
    if result is not None:
        result.extra["workers"] = procs
        return result
    return simulate_closed_loop(
        models, model, layout, seconds=spec["seconds"], seed=spec["seed"],
        n_trials=spec["trials"], weights=spec["weights"], trace_dt=spec["trace_dt"] * ms,
        robot_stride=spec["robot_stride"], spikes=spec["spikes"], traces=spec["traces"],
        progress=progress, trace_dtype=spec["trace_dtype"], spill=spill, populations=rows)


def _simulate_into(folder: OutputFolder, simulate: Any, summarise: Any,
                   settings: dict[str, Any], figure: bool) -> tuple[Any, Any]:
    """``simulate(spill)`` and its folder, whole or nothing: (the result, its summary). A run
    that writes a folder puts its large traces on disk as it goes (:func:`read_spilled`):
    hidden in the folder being written, never in the current folder or beside the output.
    Diverged: the folder keeps what ran, and says it diverged; then the error is raised."""
    diverged: Diverged | None = None
    with folder as tmp:
        spill, spilled = spill_files(tmp)
        try:
            try:
                result = simulate(spill)
            except Diverged as e:
                if getattr(e, "result", None) is None:
                    raise
                summarise(e.result, e)
                write_run_folder(tmp, e.result, settings, figure=figure)
                diverged = e
            else:
                summarise(result)
                summary = run_results(result)  # before the spilled traces are read
                write_run_folder(tmp, result, settings, figure=figure, results=summary)
        finally:
            remove_files(spilled)
    if diverged is not None:
        raise diverged
    return result, summary


def read_spilled(traces: dict[str, tuple[np.ndarray, Any]],
                 npz: Path) -> dict[str, tuple[np.ndarray, Any]]:
    """``traces`` with each spilled trace read from the ``.npz`` it was copied into: a
    read-only memory map of its data there (read from disk as it is used, not held). A run
    that writes a folder spills (beside it, hidden) the traces too large to hold in fresh
    memory; the files are removed once copied into ``traces.npz``."""
    out = dict(traces)
    for name, (t, v) in traces.items():
        if isinstance(v, recording.SpilledTrace):
            out[name] = (t, np.memmap(npz, dtype=v.dtype, mode="r", offset=v.npz_offset,
                                      shape=v.shape) if v.size else np.empty(v.shape, v.dtype))
    return out


def with_trained_populations(weights: Any, given: dict[str, Any]) -> dict[str, Any]:
    """``given`` (a record of added population files, ``populations``, :func:`population_rows`)
    with the populations the training folder ``weights`` added (none for a weights file, an
    array or a folder that recorded none); a file given for one of them that is not the
    training's is refused, naming ``populations``."""
    if not (isinstance(weights, (str, os.PathLike)) and Path(weights).is_dir()):
        return given
    settings = (read_manifest(Path(weights)) or {}).get("settings")
    recorded = settings.get("populations") if isinstance(settings, dict) else None
    if not isinstance(recorded, dict) or not recorded:
        return given
    clash = same_populations(recorded, {k: v for k, v in given.items() if k in recorded})
    if clash is not None:
        raise InputError(f"the training in {weights} added {clash} from another file (recorded "
                         f"sha256 {recorded[clash]['sha256'][:12]}, given "
                         f"{given[clash]['sha256'][:12]}); its tables run on its own network",
                         culprit=setting("populations"))
    return dict(recorded) | {k: v for k, v in given.items() if k not in recorded}


def _summarise(result: SimulationResult, models: Any, start_x: float, robot_info: dict,
               initial_weights: np.ndarray | None, diverged: Diverged | None = None) -> None:
    rec = result.robot
    has = rec is not None and len(rec.t) > 0
    n = result.cpg.n_trials
    result.extra.update({
        "models": models,
        "distance_m": rec.torso_position[:, -1, 0] - start_x if has else np.zeros(n),
        "mean_forward_speed_m_per_s": rec.torso_velocity[:, :, 0].mean(axis=1) if has
        else np.zeros(n),
        # the share of steps the alive model counts as upright (the paper's: torso level), and
        # the torso's lowest height, which shows a robot pressed flat with a level torso
        "upright_share": rec.alive.mean(axis=1) if has else np.zeros(n),
        "lowest_torso_height_m": rec.torso_position[:, :, 2].min(axis=1) if has
        else np.zeros(n),
        "rate_per_neuron_Hz": firing_rates(result) if result.seconds > 0 else {},
        "robot_info": robot_info,
        "status": "finished" if diverged is None else "diverged",
    })
    result.extra["mechanisms"] = mechanisms(result, initial_weights)
    if diverged is not None:
        result.extra["error"] = {"line": diverged.line, "t_s": diverged.t,
                                 "trial": diverged.trial}


def _per_trial(values: Any, fmt: str = "d") -> str:
    """One number when every trial has it, else one per trial."""
    v = np.asarray(values)
    if len(v) == 1 or np.all(v == v[0]):
        return format(v[0].item(), fmt)
    return "(" + ", ".join(f"trial {b}: {format(x.item(), fmt)}" for b, x in enumerate(v)) + ")"


def _weight_bounds(models: Any) -> tuple[float, float] | None:
    """(w_min, w_max) in volt of the inter-limb synapse, if its model has them."""
    try:
        return models.value("w_min"), models.value("w_max")
    except (AttributeError, KeyError, TypeError, InputError):
        return None


def mechanisms(result: SimulationResult, initial_weights: np.ndarray | None) -> dict[str, Any]:
    """Which mechanisms acted in a run, from what it recorded: the inter-limb tables at the
    start and the end, the astrocytes' adenosine releases (their "spikes") and peak [ADO] and
    Ca2+ (traces), the limit-position inhibition the bridge applied (onsets and steps), the
    motor neurons' spikes. Returns the numbers (per trial) and ``statements``: one line each,
    only what those numbers show; a mechanism whose data the run did not record is said to be
    unrecorded, not absent."""
    out: dict[str, Any] = {}
    said = _interlimb_said(result, initial_weights, out)
    said.append(_astrocytes_said(result, out))
    said += _limit_and_motor_said(result, out)
    out["statements"] = said
    return out


def _interlimb_said(result: SimulationResult, initial_weights: np.ndarray | None,
                    out: dict[str, Any]) -> list[str]:
    """The inter-limb tables' part of :func:`mechanisms`: coupled or not, learnt or clipped."""
    cpg = result.cpg
    n = cpg.n_trials
    final = cpg.interlimb_weights()
    start = (np.zeros_like(final) if initial_weights is None
             else np.broadcast_to(np.asarray(initial_weights, dtype=float), final.shape))
    pairs = cpg.interlimb_pairs
    mask = np.zeros(final.shape[1:], dtype=bool)
    if len(pairs):
        mask[pairs[:, 0], pairs[:, 1]] = True
    change_mV = np.abs(final - start)[:, mask].max(axis=1) * 1e3 if mask.any() else np.zeros(n)
    nonzero = (np.count_nonzero(final[:, mask], axis=1) if mask.any()
               else np.zeros(n, dtype=int))
    out.update({"interlimb_synapses": int(mask.sum()), "interlimb_nonzero_at_end": nonzero,
                "interlimb_max_change_mV": change_mV})
    said = []
    if not mask.any():
        said.append("no inter-limb synapses: limbs uncoupled")
    elif not nonzero.any():
        said.append("inter-limb weights all zero: limbs uncoupled")
    else:
        said.append(f"limbs coupled: {_per_trial(nonzero)} of {int(mask.sum())} inter-limb "
                    f"weights non-zero")
    bounds = _weight_bounds(result.extra.get("models"))
    if mask.any():
        clipped = (np.clip(start, *bounds) if bounds is not None else start)[:, mask]
        n_clipped = np.count_nonzero(clipped != start[:, mask], axis=1)
        out["interlimb_clipped_to_bounds"] = n_clipped
        if not change_mV.any():
            said.append("learning off: the inter-limb weights did not change (neither STDP "
                        "nor adenosine changed a weight)")
        elif np.allclose(final[:, mask], clipped, rtol=0, atol=1e-12):
            # the synapse's update clips w to [w_min, w_max] every step, learning or not
            lo, hi = (b * 1e3 for b in bounds)
            said.append(f"learning off: the only change to the inter-limb weights is the clip "
                        f"to [w_min, w_max] = [{lo:.3g}, {hi:.3g}] mV of "
                        f"{_per_trial(n_clipped)} given weights (by up to "
                        f"{_per_trial(change_mV, '.3g')} mV)")
        else:
            said.append(f"inter-limb weights changed during the run, by up to "
                        f"{_per_trial(change_mV, '.3g')} mV")
    return said


def _astrocytes_said(result: SimulationResult, out: dict[str, Any]) -> str:
    """The astrocytes' part of :func:`mechanisms`: releases and peak [ADO] and [Ca2+]."""
    L, n = result.cpg.layout, result.cpg.n_trials
    if "astrocyte" in result.spikes:
        _, idx = result.spikes["astrocyte"]
        releases = np.bincount(idx // L.thigh_pools_per_trial, minlength=n)
        out["adenosine_releases"] = releases
        line = (f"astrocytes: {_per_trial(releases)} adenosine release events"
                if releases.any() else "astrocytes: no adenosine release")
    else:
        line = "astrocytes: releases not recorded (astrocyte spikes off)"
    peaks = []
    for name, unit in (("astrocyte_ADO", "a.u."), ("astrocyte_Ca", "uM")):
        if name in result.traces and result.traces[name][1].size:
            v = result.traces[name][1]
            if isinstance(v, recording.SpilledTrace):  # on disk: its columns' peaks kept
                peak = np.nanmax(v.column_max.reshape(n, -1), axis=1)
            else:
                peak = np.nanmax(v.reshape(len(result.traces[name][0]), n, -1), axis=(0, 2))
            out[f"peak_{name}"] = peak
            label = "[ADO]" if name.endswith("ADO") else "[Ca2+]"
            peaks.append(f"peak {label} {_per_trial(peak, '.3g')} {unit}")
    return line + (", " + ", ".join(peaks) if peaks else ", traces of ADO/Ca2+ not recorded")


def _limit_and_motor_said(result: SimulationResult, out: dict[str, Any]) -> list[str]:
    """The limit-position inhibition's and the motor neurons' part of :func:`mechanisms`."""
    L, n = result.cpg.layout, result.cpg.n_trials
    said = []
    limit = result.extra.get("limit_inhibition")
    if limit is not None and limit["of_steps"]:
        out["limit_inhibition_onsets"] = limit["onsets"]
        out["limit_inhibition_steps"] = limit["steps"]
        if limit["onsets"].any():
            said.append(f"limit-position inhibition engaged {_per_trial(limit['onsets'])} times "
                        f"(a pool's inhibition switching on), on "
                        f"{_per_trial(limit['steps'])} of {limit['of_steps']} steps")
        else:
            said.append(f"limit-position inhibition never engaged ({limit['of_steps']} steps)")
    if "motor" in result.spikes:
        _, idx = result.spikes["motor"]
        motor = np.bincount(idx // L.motor_per_trial, minlength=n)
        out["motor_spikes"] = motor
        said.append(f"motor neurons: {_per_trial(motor)} spikes" if motor.any()
                    else "motor neurons: silent (no spike), no torque from the CPG")
    return said


def robot_arrays(result: SimulationResult) -> dict[str, np.ndarray]:
    """The robot's recording as the arrays of ``robot.npz``."""
    rec = result.robot
    return {
        "t": rec.t, "joint_angles": rec.joint_angles, "torques": rec.torques,
        "torso_position": rec.torso_position, "torso_velocity": rec.torso_velocity,
        "torso_quaternion": rec.torso_quaternion,
        "reward": rec.reward, "alive": rec.alive, "foot_force": rec.foot_force,
        "legs": np.array(list(result.cpg.layout.legs)),
        "joints": np.array(["hip", "thigh", "calf"]),
        "interlimb_weights_mV": result.cpg.interlimb_weights() * 1e3,
    }


def write_run_folder(out: Path, result: SimulationResult, settings: Mapping[str, Any], *,
                     figure: bool = False, results: Mapping[str, Any] | None = None) -> None:
    """spikes.npz, traces.npz, robot.npz, manifest.json and, with ``figure``, the thigh-extensor
    figure (matplotlib's import and one figure cost about a second: ten times a 0.1 s run).
    ``results``: the manifest's results (:func:`run_results`, computed here if not given)."""
    files = save_spikes_and_traces(out, result.spikes, result.traces)
    save_npz(out / "robot.npz", robot_arrays(result))
    files["robot.npz"] = ROBOT_FILE
    if figure and "motor" in result.spikes:
        from ..figures import plots
        from ..figures.save import save_figure

        save_figure(plots.plot_thigh_extensor_activity(result.spikes, result.cpg.layout),
                    out / "thigh_extensor_activity.png")
        files["thigh_extensor_activity.png"] = "thigh-extensor activity of the 4 limbs (trial 0)"
    write_manifest(out, command="run", seed=int(settings.get("seed", 1)), settings=settings,
                   models_json=result.extra["models"].to_json(), files=files,
                   results=run_results(result) if results is None else results)


#: run settings a replay takes from the training, with their defaults
REPLAY_FIXED = {"seconds": 10.0, "seed": None, "trials": 1, "overrides": None,
                "equations": None, "models": None, "robot": None, "robot_stride": 1,
                "figure": False}


def _replay(given: dict[str, Any]) -> Result:
    """:func:`run` with ``session``: the replay of a training's session. The errors name the
    command's options (``ac.run`` names its keywords)."""
    from ...models.units import whole_steps
    from .replay import replay_session

    weights = given["weights"]
    if not isinstance(weights, (str, os.PathLike)):
        raise InputError(f"replays a session of a training: give the training folder with "
                         f"{setting('weights', 'DIR')}", culprit=setting("session"))
    for name, default in REPLAY_FIXED.items():
        value = given[name]
        if value != default and not (default is None and not value):
            raise InputError("a replay takes the training's own (the session's length, seed, "
                             "models and robot); drop it", culprit=setting(name))
    if given["out"] is None:
        raise InputError("a replay writes a folder: give one", culprit=setting("out"))
    resolve_workers(given["workers"])  # checked (a replay is one trial: one process)
    stride = whole_steps(float(given["trace_dt"]) * 1e-3, 1e-3, culprit=setting("trace_dt"))
    return replay_session(weights, trial=given["trial"] or 0, session=given["session"],
                          out=given["out"], record_stride=stride, spikes=given["spikes"],
                          traces=given["traces"], trace_dtype=given["trace_dtype"],
                          overwrite=given["overwrite"],
                          progress=given["progress"], inputs=given["inputs"])


def _shown(weights: Any) -> str:
    return "an array" if not isinstance(weights, (str, os.PathLike)) else str(weights)


def run_results(result: SimulationResult) -> dict[str, Any]:
    """What the manifest's ``results`` (and the Result's ``summary``) hold for a run."""
    x = result.extra
    return {"status": x.get("status", "finished"), "error": x.get("error"),
            "distance_m": x["distance_m"],
            "mean_forward_speed_m_per_s": x["mean_forward_speed_m_per_s"],
            "upright_share": x["upright_share"],
            "lowest_torso_height_m": x["lowest_torso_height_m"],
            "rate_per_neuron_Hz": x["rate_per_neuron_Hz"], "mechanisms": x["mechanisms"],
            "wall_seconds": result.wall_seconds, "workers": x.get("workers", 1),
            "seconds": result.seconds, "dt_s": float(result.cpg.dt), "robot": x["robot_info"],
            "layout": result.cpg.layout.to_json(),
            # never silent: which traces lost values to float32 (stored as inf), how many
            "trace_overflow": overflowed(result.traces)}


def _lowest(x: dict, b: int) -> str:
    """``, torso centre at least H m above the ground`` (runs recorded before it: nothing)."""
    low = x.get("lowest_torso_height_m")
    return "" if low is None else f", torso centre at least {low[b]:.2f} m above the ground"


def format_run(result: Result, seed: int) -> list[str]:
    """Distance, speed, upright share, the fall if the robot fell (when, in simulated s) and
    rates per trial, and the wall time."""
    x = result.summary
    rob = result.robot or {}
    fell = (falls(rob["t"], rob["alive"]) if "alive" in rob and "t" in rob
            else [None] * result.layout.n_trials)
    lines = []
    for b in range(result.layout.n_trials):
        fall = fall_words(fell[b]) if b < len(fell) else ""
        lines.append(f"trial {b} (seed {seed}+{b}): distance {x['distance_m'][b]:+.3f} m, mean "
                     f"forward speed {x['mean_forward_speed_m_per_s'][b]:+.3f} m/s, "
                     f"{alive_words(result.models)} {x['upright_share'][b] * 100:.0f}% of "
                     f"steps" + _lowest(x, b) + (f"; {fall}" if fall else ""))
        if x["rate_per_neuron_Hz"]:
            lines.append("  rate per neuron (Hz): " + ", ".join(
                f"{k} {v[b]:.1f}" for k, v in x["rate_per_neuron_Hz"].items()))
        named = _named_gait(result, b)
        if named:
            lines.append(f"  {named}")
    fallen = [(b, f) for b, f in enumerate(fell) if f is not None]
    if fallen:  # the fall in a line of its own: the upright share alone hides it
        lines.append(f"the robot fell in {len(fallen)} of {result.layout.n_trials} trial(s): "
                     + ", ".join(f"trial {b} at {f.t_s:.2f} s" for b, f in fallen))
    mech = x.get("mechanisms") or {}
    if mech.get("statements"):
        lines.append("what acted (from the recorded data):")
        lines += [f"  {s}" for s in mech["statements"]]
    lines.append(f"wall time {x['wall_seconds']:.1f} s for {result.seconds:g} simulated s "
                 f"x {result.layout.n_trials} trial(s)")
    if x.get("trace_overflow"):
        lines.append("warning: " + overflow_words(x["trace_overflow"]))
    return lines


def _named_gait(result: Result, b: int) -> str:
    """``rhythm (thigh bursts) trot; gait (footfalls) none: not periodic (locking 0.58)``:
    trial ``b``'s rhythm and gait over the run's second half (what ``astrocpg gait`` reads),
    or "" where the motor spikes or the robot were not recorded."""
    from types import SimpleNamespace

    from ..analysis.gait import trial_measures

    rob = result.robot or {}
    if "motor" not in result.spikes or not all(k in rob for k in ("t", "alive", "foot_force")) \
            or not result.seconds:
        return ""
    t, i = result.spikes["motor"]
    rec = SimpleNamespace(t=np.asarray(rob["t"], dtype=float), alive=np.asarray(rob["alive"]),
                          foot_force=np.asarray(rob["foot_force"], dtype=float))
    m = trial_measures(np.asarray(t, dtype=float), np.asarray(i), result.layout, rec, b,
                       result.seconds / 2, result.seconds)
    lock = m["gait_locking"]
    return (f"over the second half: rhythm (thigh bursts) {m['rhythm']}; gait (footfalls) "
            f"{m['gait']}{': ' + m['gait_reason'] if m['gait_reason'] else ''}"
            + (f" (locking {lock:.2f}; the label needs 0.7)" if np.isfinite(lock) else ""))


def training_settings(folder: str | Path) -> dict[str, Any]:
    """The settings of the training in ``folder`` (from its manifest)."""
    try:
        return read_json(Path(folder) / "manifest.json")["settings"]
    except InputError:  # not a regular file, nested too deeply: refused, naming it
        raise
    except (OSError, ValueError, KeyError, TypeError):
        raise InputError("no readable manifest.json (not a training run)",
                         culprit=str(folder)) from None


def trained_models(settings: Mapping[str, Any]) -> ModelSet:
    """The model set a training's ``settings`` (:func:`training_settings`) trained with: its
    overrides, equations and model files, the astrocytes' regulation off for the ablation."""
    models = model_set(settings.get("overrides", []), settings.get("equations", {}),
                       models=settings.get("models"),
                       added=population_models(settings.get("populations")))
    if not settings.get("astrocytes", True):
        models = models.with_values({"astrocyte_regulation": 0.0})
    return models


def controller_tables(folder: str | Path, session: int | None = None) -> np.ndarray:
    """The tables (volt, (trials, 8, 8)) of the controller in ``folder``: a training's final
    tables (``weights.npz``; ``session``: after that session), or a run folder's (the ``out``
    of ``astrocpg run``: the inter-limb tables its trials ran with, ``robot.npz``)."""
    p = Path(folder)
    if (p / "weights.npz").is_file() or not (p / "robot.npz").is_file():
        return load_weights(folder, culprit="", session=session)
    if session is not None:
        raise InputError("a run folder has no sessions: give a training folder",
                         culprit=setting("session", session))
    verify(p, strict=False)  # its files are what its manifest lists
    if training_settings(p).get("robot"):
        raise InputError(f"ran a robot model of its own ({setting('robot')}); its tables are "
                         f"replayed on the project's A1 only", culprit=str(folder))
    try:
        with np.load(p / "robot.npz", allow_pickle=False) as z:
            w = np.asarray(z["interlimb_weights_mV"], dtype=float) * 1e-3
    except (OSError, ValueError, KeyError, EOFError) as e:
        raise InputError(f"robot.npz holds no readable inter-limb tables ({type(e).__name__})",
                         culprit=str(folder)) from None
    if w.ndim != 3 or w.shape[-2:] != (8, 8) or not np.all(np.isfinite(w)):
        raise InputError(f"robot.npz holds tables of shape {w.shape}, not (trials, 8, 8)",
                         culprit=str(folder))
    return w


def with_variant(settings: Mapping[str, Any], *, overrides: Overrides | None = None,
                 equations: Mapping[str, str] | None = None,
                 models: Mapping[str, Any] | None = None,
                 populations: Any = None) -> dict[str, Any]:
    """A controller's settings (a training's or a run's, :func:`training_settings`) with a
    model variant over them, as ``run``/``train`` take one: ``overrides`` after the
    controller's own (a name given again takes the new value), ``equations`` and ``models``
    replacing the controller's for the models they name, ``populations`` added to its own.
    Each is checked here (a bad value names its option)."""
    out = dict(settings)
    if overrides:
        out["overrides"] = [*(settings.get("overrides") or []), *override_items(overrides)]
    if equations:
        out["equations"] = {**(settings.get("equations") or {}), **dict(equations)}
    if models:
        out["models"] = {**(settings.get("models") or {}), **model_files_record(models)}
    if populations:
        record = population_rows(populations)[1]
        clash = set(record) & set(settings.get("populations") or {})
        if clash:
            raise InputError(f"the controller already has the population "
                             f"{sorted(clash)[0]}", culprit=setting("populations"))
        out["populations"] = {**(settings.get("populations") or {}), **record}
    if any((overrides, equations, models, populations)):
        population_table(out.get("populations"))  # its rows checked together
        trained_models(out)  # every value of the variant checked now, not mid-run
    return out


def replay(folder: str | Path, *, seconds: float = 10.0, seed: int | None = None,
           progress: bool = True, repeats: int = 1,
           world: Sequence[str] = (), variant: Mapping[str, Any] | None = None,
           workers: int | None = None) -> tuple[SimulationResult, np.ndarray]:
    """The trained tables of every trial of the training in ``folder`` (or the tables of a run
    folder's trials, :func:`controller_tables`), run for ``seconds``
    with the training's models (one batch, learning off), ``repeats`` times: batch trial
    ``b = r * n + k`` is table ``k`` (of ``n``) in repeat ``r``, with seed ``seed + b``
    (independent network noise per run), by default the training's own seed, so that repeat 0
    runs each table on the network and noise it trained with. ``world``: ``NAME=VALUE`` world
    parameters (e.g. ``slope=0.17``) set over the training's own world. ``variant``: a model
    variant over the training's models (``overrides``, ``equations``, ``models``,
    ``populations``: :func:`with_variant`). Returns the result and
    the ``n`` tables (volt). The populations the training added are built too: its network."""
    seconds = number(seconds, setting("seconds"), positive=True)
    check_duration(seconds, STEP)
    repeats = number(repeats, setting("repeats"), integer=True, minimum=1)
    settings = with_variant(training_settings(folder), **dict(variant or {}))
    procs = resolve_workers(workers)
    if seed is None:
        seed = settings.get("seed", 1)
    seed = seed_number(seed)
    verify(folder, strict=False)  # its files are what its manifest lists
    weights = controller_tables(folder)
    if (Path(folder) / "weights.npz").is_file():  # a training's: final, or said otherwise
        state = tables_state(folder)
        if state["warning"]:
            warnings.warn(KEYWORDS(state["warning"]), UserWarning, stacklevel=2)
    populations = settings.get("populations")
    rows = population_table(populations)  # the training's network: its populations too
    models = in_world_settings(trained_models(settings), world)
    runs = len(weights) * repeats
    procs = min(procs, runs)
    check_memory(estimate_batched(procs, trials=runs, seconds=seconds, dt=STEP, robot_stride=1),
                 culprit=f"{setting('seconds', f'{seconds:g}')} x {len(weights)} trained "
                         f"trial(s) x {repeats} repeat(s)"
                         + (f" x {setting('workers', procs)}" if procs > 1 else ""))
    tables = np.concatenate([weights] * repeats)
    result = try_batched("replay", {"modelset": models, "populations": populations,
                                    "seconds": seconds, "seed": seed, "weights": tables},
                         runs, procs, progress)
    if result is None:  # one process (or a batch diverged: it diverges here too)
        result = simulate_closed_loop(models, seconds=seconds, seed=seed,  # the project's A1
                                      n_trials=runs, weights=tables, record_traces=False,
                                      progress=progress, populations=rows)
    else:
        result.cpg.models = models
    return result, weights


def in_world_settings(models: ModelSet, world: Sequence[str]) -> ModelSet:
    """``models`` with the world parameters ``world`` (``NAME=VALUE`` texts)
    set; a name that is not a world parameter is refused, naming it."""
    values = {}
    for text in world:
        name = text.partition("=")[0].strip()
        if name not in models.world.parameters:
            raise InputError(f"is not a world parameter "
                             f"({', '.join(sorted(models.world.parameters))})",
                             culprit=setting("world", text))
        values.update([models.parse_assignment(text)])
    if not values:
        return models
    out = models.with_values(values)
    from ...coupling.assembly import check_models

    check_models(out)  # a world it cannot build (terrain grid, values) is refused here
    return out


def alive_words(models: ModelSet | None) -> str:
    """``alive (the alive model: torso_z_up >= Thres_z_alive)``: the upright share named by
    the alive model the run used (its expression), whatever model file replaced it."""
    if models is None:
        return "alive"
    return f"alive (the alive model: {models.alive.expression})"
