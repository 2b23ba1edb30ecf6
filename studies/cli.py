"""The ``astrocpg`` command line.

    astrocpg unit  --seconds S --seed K --out DIR [--trials N]
    astrocpg run   --seconds S --seed K [--trials N] [--weights FILE|DIR] [--robot XML] --out DIR
    astrocpg train --sessions N --trials N --seed K [--no-astrocytes] --out DIR | --resume DIR
    astrocpg gait DIR | plot DIR | power DIR [--trial K]
    astrocpg study FILE [--out DIR] [--workers N] [--scheduler ADDRESS]
    astrocpg report DIR
    astrocpg export DIR [--format nwb|npz]
    astrocpg describe [MODEL] [--format markdown|latex]
    astrocpg robot export PATH.xml

Common options: ``--set NAME=VALUE`` overrides a model parameter (with units),
``--equations MODEL=FILE`` replaces a model's equation string by the text of FILE.
Bad input ends with one line on stderr naming the culprit, exit code 2, and nothing written.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import InputError

DEFAULT_RUN_OUT = "out/run"


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        sys.stderr.write(f"astrocpg: error: {message}\n")
        raise SystemExit(2)


def _csv_list(text: str) -> tuple[str, ...]:
    return () if text.strip() in ("", "none") else tuple(x.strip() for x in text.split(","))


def _add_record_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--spikes", type=_csv_list, default=None, metavar="POPS",
                   help="populations whose spikes are recorded, comma-separated, or none "
                        "(default: motor,interneuron,astrocyte)")
    p.add_argument("--traces", type=_csv_list, default=None, metavar="NAMES",
                   help="traces recorded, comma-separated, or none (default: motor_Ca,"
                        "astrocyte_Ca,astrocyte_IP3,astrocyte_AG,astrocyte_ADO)")


def _add_model_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                   help="override a model parameter, with units (e.g. --set tau_motor=9*ms)")
    p.add_argument("--equations", action="append", default=[], metavar="MODEL=FILE",
                   help="replace the equation string of MODEL (e.g. motor_neuron) by FILE's text")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="astrocpg", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    unit = sub.add_parser("unit", help="one locomotion unit, open loop (paper Fig. 1c)")
    unit.add_argument("--seconds", type=float, default=30.0)
    unit.add_argument("--seed", type=int, default=1)
    unit.add_argument("--trials", type=int, default=1, help="independent units, seeds K, K+1...")
    unit.add_argument("--trace-dt", type=float, default=1.0, metavar="MS",
                      help="sampling interval of the Ca2+ traces in ms (default 1)")
    unit.add_argument("--out", required=True)
    _add_record_options(unit)
    _add_model_options(unit)

    run = sub.add_parser("run", help="the closed loop: CPG drives the A1 (fixed weights)")
    run.add_argument("--seconds", type=float, default=10.0)
    run.add_argument("--seed", type=int, default=1)
    run.add_argument("--trials", type=int, default=1)
    run.add_argument("--weights", help="8x8 inter-limb table in mV (.npy, .csv/.txt, .json), or "
                     "a training folder (its final weights)")
    run.add_argument("--trial", type=int, default=None,
                     help="with --weights DIR: use that trial's table for every trial")
    run.add_argument("--robot", help="an MJCF file with the A1's joint and actuator names")
    run.add_argument("--trace-dt", type=float, default=1.0, metavar="MS",
                     help="sampling interval of the Ca2+/2-AG/adenosine traces in ms")
    run.add_argument("--robot-stride", type=int, default=1, metavar="STEPS",
                     help="record the robot every STEPS physics steps (default 1)")
    run.add_argument("--out", default=DEFAULT_RUN_OUT)
    _add_record_options(run)
    _add_model_options(run)

    train = sub.add_parser("train", help="gait learning over sessions (reward-modulated STDP)")
    train.add_argument("--sessions", type=int, default=None, help="sessions per trial (400)")
    train.add_argument("--seed", type=int, default=None, help="seed (1)")
    train.add_argument("--trials", type=int, default=None, help="independent trials (1)")
    train.add_argument("--no-astrocytes", action="store_true", default=None,
                       help="remove the adenosine term (the paper's ablation)")
    train.add_argument("--out", help="output folder (new, or empty)")
    train.add_argument("--resume", metavar="DIR", help="continue the run in DIR")
    train.add_argument("--record-every", type=int, default=None, metavar="N",
                       help="record sessions 1, 1+N, 1+2N... and the last of each trial "
                            "(spikes, traces, robot) into DIR/recordings/")
    train.add_argument("--record-stride", type=int, default=1, metavar="STEPS",
                       help="with --record-every: steps between trace and robot samples (1)")
    _add_record_options(train)
    _add_model_options(train)

    gait = sub.add_parser("gait", help="run trained weights and name the gait")
    gait.add_argument("dir", help="a training folder")
    gait.add_argument("--seconds", type=float, default=10.0)
    gait.add_argument("--seed", type=int, default=1)
    gait.add_argument("--no-progress", action="store_true")

    plot = sub.add_parser("plot", help="figures of a training folder (Fig. 3 style)")
    plot.add_argument("dir", help="a training folder")
    plot.add_argument("--trial", type=int, default=0)
    plot.add_argument("--seconds", type=float, default=10.0,
                      help="length of the run with the trained weights (for activity and gait)")

    study = sub.add_parser("study", help="a parameter study (TOML) on Dask; resumable")
    study.add_argument("file", help="study file, e.g. studies/quick.toml")
    study.add_argument("--out", help="study folder (default: out/<study name>)")
    study.add_argument("--workers", type=int, default=None,
                       help="local cluster size (default: one worker per core)")
    study.add_argument("--scheduler", metavar="ADDRESS",
                       help="a running Dask scheduler, e.g. tcp://127.0.0.1:8786")
    study.add_argument("--no-progress", action="store_true")

    report = sub.add_parser("report", help="Fig. 3c curves and final figures of a study")
    report.add_argument("dir", help="a study folder")
    report.add_argument("--smooth", type=int, default=1, metavar="N",
                        help="plot each seed's trailing mean over N sessions (default 1: raw)")
    report.add_argument("--last", type=int, default=50,
                        help="sessions at the end over which final figures are averaged (50)")

    power = sub.add_parser("power", help="SNN vs RL power estimate of a trained controller")
    power.add_argument("dir", help="a training folder (astrocpg train, or a study's run)")
    power.add_argument("--trial", type=int, default=0, help="which trial's weights (0)")
    power.add_argument("--sessions", type=int, default=10, help="sessions to measure (10)")
    power.add_argument("--no-progress", action="store_true")

    exp = sub.add_parser("export", help="a run or unit folder as NWB or npz")
    exp.add_argument("dir", help="output of astrocpg run or unit")
    exp.add_argument("--format", default="nwb", help="nwb (default) or npz")
    exp.add_argument("--out", help="file to write (default DIR/export.<format>)")

    desc = sub.add_parser("describe", help="a model's equations (sympy) and parameter table")
    desc.add_argument("model", nargs="?", help="one model (default: all)")
    desc.add_argument("--format", default="markdown", help="markdown (default) or latex")
    desc.add_argument("--equations", action="append", default=[], metavar="MODEL=FILE",
                      help="describe MODEL with the equation string of FILE")
    desc.add_argument("--set", dest="overrides", action="append", default=[],
                      metavar="NAME=VALUE", help="describe with a parameter overridden")

    robot = sub.add_parser("robot", help="the project's A1 model")
    robot_sub = robot.add_subparsers(dest="robot_command", required=True, parser_class=_Parser)
    export = robot_sub.add_parser("export", help="write the A1 model as MJCF")
    export.add_argument("path")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    warnings.filterwarnings("ignore", module="brian2")
    try:
        return COMMANDS[args.command](args)
    except InputError as e:
        sys.stderr.write(f"astrocpg: error: {e}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("astrocpg: interrupted\n")
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        sys.stderr.close()
        return 0
    return 0


def _cmd_describe(args: argparse.Namespace) -> int:
    from .describe import describe

    sys.stdout.write(describe(args.model, args.format,
                              load_models(args.overrides, args.equations)))
    return 0


# ---------------------------------------------------------------- helpers
def read_equation_files(equations: Sequence[str]) -> dict[str, str]:
    """``MODEL=FILE`` items -> {model: text}."""
    out: dict[str, str] = {}
    for item in equations:
        name, sep, file = item.partition("=")
        if not sep:
            raise InputError(f"--equations '{item}': expected MODEL=FILE")
        try:
            out[name] = Path(file).read_text()
        except OSError as e:
            raise InputError(f"--equations {name}: cannot read '{file}' ({e.strerror})") from None
    return out


def models_from(overrides: Sequence[str], equation_texts: dict[str, str]):
    from ..models import DEFAULT_MODELS

    models = DEFAULT_MODELS
    for name, text in equation_texts.items():
        model = dict(models.items()).get(name)
        if model is None:
            raise InputError(f"--equations: unknown model '{name}' "
                             f"(models: {', '.join(n for n, _ in models.items())})")
        field = {"NeuronModel": "equations", "SynapseModel": "model",
                 "ExpressionModel": "expression"}[type(model).__name__]
        models = models.replace(**{name: model.replace(**{field: text})})
    values = dict(models.parse_assignment(item) for item in overrides)
    return models.with_values(values) if values else models


def load_models(overrides: Sequence[str], equations: Sequence[str]):
    return models_from(overrides, read_equation_files(equations))


def load_weights(path: str, trial: int | None = None) -> np.ndarray:
    """An 8x8 inter-limb table in mV from .npy, .npz ('weights'), .json or text, or a training
    folder (its final tables: all trials, or ``trial``); returns volt."""
    p = Path(path)
    if p.is_dir():
        if not (p / "weights.npz").is_file():
            raise InputError(f"--weights {path}: folder holds no weights.npz (not a training run)")
        with np.load(p / "weights.npz") as z:
            w = np.asarray(z["final_weights_mV"], dtype=float)
        if trial is not None:
            if not 0 <= trial < len(w):
                raise InputError(f"--trial {trial}: {path} has {len(w)} trial(s)")
            w = w[trial]
        return w * 1e-3
    if not p.is_file():
        raise InputError(f"--weights {path}: no such file")
    try:
        if p.suffix == ".npy":
            w = np.load(p)
        elif p.suffix == ".npz":
            with np.load(p) as z:
                w = z["weights_mV"] if "weights_mV" in z else z["weights"]
        elif p.suffix == ".json":
            import json
            obj = json.loads(p.read_text())
            w = np.asarray(obj["weights_mV"] if isinstance(obj, dict) else obj, dtype=float)
        else:
            w = np.loadtxt(p, delimiter="," if p.suffix == ".csv" else None)
    except Exception as e:
        raise InputError(f"--weights {path}: cannot read an 8x8 table ({type(e).__name__})") from None
    w = np.asarray(w, dtype=float)
    if w.shape[-2:] != (8, 8) or w.ndim not in (2, 3):
        raise InputError(f"--weights {path}: expected an 8x8 table, got shape {w.shape}")
    if not np.all(np.isfinite(w)):
        raise InputError(f"--weights {path}: contains non-finite values")
    return w * 1e-3


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    return {k: v for k, v in vars(args).items() if k not in ("func",)}


def _check_common(args: argparse.Namespace) -> None:
    if not np.isfinite(args.seconds) or args.seconds <= 0:
        raise InputError(f"--seconds must be positive, got {args.seconds:g}")
    if args.trials < 1:
        raise InputError(f"--trials must be at least 1, got {args.trials}")
    if args.trace_dt <= 0:
        raise InputError(f"--trace-dt must be positive, got {args.trace_dt:g}")


# ---------------------------------------------------------------- commands
def _cmd_unit(args: argparse.Namespace) -> int:
    from brian2 import ms

    from . import plots
    from .analysis import rhythm_summary
    from .outputs import prepare_output_dir, save_npz, write_manifest
    from .simulate import simulate_unit

    _check_common(args)
    models = load_models(args.overrides, args.equations)
    result = simulate_unit(models, seconds=args.seconds, seed=args.seed, n_trials=args.trials,
                           trace_dt=args.trace_dt * ms, spikes=args.spikes, traces=args.traces,
                           progress=not args.no_progress)
    out = prepare_output_dir(args.out)
    L = result.cpg.layout
    summaries = []
    have = {"motor", "interneuron"} <= set(result.spikes)
    for b in range(L.n_trials if have else 0):  # the rhythm needs both populations' spikes
        pools = {name: L.motor_neurons(b, 0, name) for name in ("thigh_flexor", "thigh_extensor",
                                                                 "calf_flexor", "calf_extensor")}
        t, i = result.spikes["motor"]
        s = rhythm_summary(t, i, pools, t_stop=args.seconds)
        ti, ii = result.spikes["interneuron"]
        mine = (ii // L.interneurons_per_trial == b) & (ti >= 1.0)
        s["interneurons_total_Hz"] = float(mine.sum() / max(args.seconds - 1.0, 1e-9))
        summaries.append(s)
        print(_format_unit_summary(b, args.seed + b, s))
    files = _save_common(out, result, save_npz)
    if have:
        plots.plot_unit(out / "unit.png", result.spikes, L)
        files["unit.png"] = ("raster of the motor neurons and interneurons, and pool activity "
                             "(trial 0)")
    write_manifest(out, command="unit", seed=args.seed, settings=_settings(args),
                   models_json=models.to_json(), files=files,
                   results={"rhythm": summaries, "wall_seconds": result.wall_seconds,
                            "dt_s": float(result.cpg.dt), "layout": _layout_json(L)})
    print(f"wrote {out}/ ({', '.join(files)})")
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    from brian2 import ms

    from ..coupling.robot import A1Parameters, RobotLayout, build_model, load_robot
    from . import plots
    from .outputs import file_sha256, prepare_output_dir, save_npz, write_manifest
    from .simulate import firing_rates, simulate_closed_loop

    _check_common(args)
    if args.robot_stride < 1:
        raise InputError(f"--robot-stride must be at least 1, got {args.robot_stride}")
    models = load_models(args.overrides, args.equations)
    weights = load_weights(args.weights, args.trial) if args.weights else None
    if weights is not None and weights.ndim == 3 and weights.shape[0] != args.trials:
        raise InputError(f"--weights {args.weights}: holds {weights.shape[0]} tables for "
                         f"{args.trials} trials")
    params = A1Parameters()
    robot = load_robot(args.robot) if args.robot else build_model(params)
    if abs(robot.opt.timestep - params.timestep) > 1e-12:
        raise InputError(f"--robot {Path(args.robot).name}: timestep is {robot.opt.timestep:g} s; "
                         f"the CPG steps with the physics at {params.timestep:g} s "
                         f"(set <option timestep=\"{params.timestep:g}\"/>)")
    layout = RobotLayout.from_model(robot, params)
    result = simulate_closed_loop(models, robot, layout, seconds=args.seconds, seed=args.seed,
                                  n_trials=args.trials, weights=weights,
                                  trace_dt=args.trace_dt * ms, robot_stride=args.robot_stride,
                                  spikes=args.spikes, traces=args.traces,
                                  progress=not args.no_progress)
    out = prepare_output_dir(args.out)
    rec = result.robot
    files = _save_common(out, result, save_npz)
    save_npz(out / "robot.npz", {
        "t": rec.t, "joint_angles": rec.joint_angles, "torques": rec.torques,
        "torso_position": rec.torso_position, "torso_velocity": rec.torso_velocity,
        "reward": rec.reward, "alive": rec.alive, "foot_force": rec.foot_force,
        "legs": np.array(["FR", "FL", "RR", "RL"]), "joints": np.array(["hip", "thigh", "calf"]),
        "interlimb_weights_mV": result.cpg.interlimb_weights() * 1e3,
    })
    files["robot.npz"] = ("t (s); joint_angles (trial, t, leg, joint) rad; torques (trial, t, leg, "
                          "joint) N m; torso_position/velocity (trial, t, xyz) m, m/s world; "
                          "reward, alive (trial, t); foot_force (trial, t, leg) N; "
                          "interlimb_weights_mV (trial, 8, 8)")
    if "motor" in result.spikes:
        plots.plot_thigh_extensor_activity(out / "thigh_extensor_activity.png", result.spikes,
                                           result.cpg.layout)
        files["thigh_extensor_activity.png"] = "thigh-extensor activity of the 4 limbs (trial 0)"
    x = rec.torso_position[:, :, 0]
    start_x = layout.reset_qpos[layout.free_qpos_adr]
    distance = x[:, -1] - start_x
    mean_speed = rec.torso_velocity[:, :, 0].mean(axis=1)
    rates = firing_rates(result)
    for b in range(args.trials):
        print(f"trial {b} (seed {args.seed}+{b}): distance {distance[b]:+.3f} m, mean forward "
              f"speed {mean_speed[b]:+.3f} m/s, upright {rec.alive[b].mean() * 100:.0f}% of steps")
        if rates:
            print("  rate per neuron (Hz): "
                  + ", ".join(f"{k} {v[b]:.1f}" for k, v in rates.items()))
    print(f"wall time {result.wall_seconds:.1f} s for {args.seconds:g} simulated s "
          f"x {args.trials} trial(s)")
    robot_info = {"file": os.path.abspath(args.robot), "sha256": file_sha256(args.robot)} \
        if args.robot else {"file": None, "builtin": "astrocpg A1", "parameters": str(params)}
    write_manifest(out, command="run", seed=args.seed, settings=_settings(args),
                   models_json=models.to_json(), files=files,
                   results={"distance_m": distance, "mean_forward_speed_m_per_s": mean_speed,
                            "rate_per_neuron_Hz": rates, "wall_seconds": result.wall_seconds,
                            "dt_s": float(result.cpg.dt),
                            "robot": robot_info, "layout": _layout_json(result.cpg.layout)})
    print(f"wrote {out}/ ({', '.join(files)})")
    return 0


def _cmd_train(args: argparse.Namespace) -> int:
    from .outputs import prepare_output_dir, write_manifest
    from .train import CHECKPOINT, Trainer, TrainingStopped, TrainSettings, read_checkpoint

    given = {"sessions": args.sessions, "seed": args.seed, "trials": args.trials,
             "astrocytes": None if args.no_astrocytes is None else not args.no_astrocytes}
    if args.resume:
        out = Path(args.resume)
        payload = read_checkpoint(out / CHECKPOINT)
        settings = TrainSettings(**payload["settings"])
        stored = {"sessions": settings.n_sessions, "seed": settings.seed,
                  "trials": settings.n_trials, "astrocytes": settings.astrocytes}
        for key, value in given.items():
            if value is not None and value != stored[key]:
                raise InputError(f"--resume {out}: that run has {key}={stored[key]}, "
                                 f"not {value}")
        if (args.overrides and sorted(args.overrides) != sorted(settings.overrides)) or \
                (args.equations and read_equation_files(args.equations) != settings.equations):
            raise InputError(f"--resume {out}: that run has other model settings "
                             f"({', '.join(settings.overrides) or 'defaults'})")
        if args.out and Path(args.out).resolve() != out.resolve():
            raise InputError("--resume writes into its own folder; drop --out")
        if payload["fingerprint"] != settings.fingerprint():
            raise InputError(f"--resume: {out / CHECKPOINT} is not consistent with its settings")
    else:
        if not args.out:
            raise InputError("--out is required (or --resume DIR)")
        settings = TrainSettings(
            n_sessions=400 if args.sessions is None else args.sessions,
            seed=1 if args.seed is None else args.seed,
            n_trials=1 if args.trials is None else args.trials,
            astrocytes=not args.no_astrocytes, overrides=list(args.overrides),
            equations=read_equation_files(args.equations))
        if settings.n_sessions < 1:
            raise InputError(f"--sessions must be at least 1, got {settings.n_sessions}")
        if settings.n_trials < 1:
            raise InputError(f"--trials must be at least 1, got {settings.n_trials}")
        out = Path(args.out)
        if (out / CHECKPOINT).exists() or (out / "sessions.csv").exists():
            raise InputError(f"--out {out}: already holds a training run "
                             f"(continue it with --resume {out})")
        payload = None
    record = _record_plan(args, payload)
    models = models_from(settings.overrides, settings.equations)
    trainer = Trainer(models, settings, out, progress=not args.no_progress,
                      record=record)  # validates models
    prepare_output_dir(out)
    if payload is not None:
        trainer.restore(payload)
    record_json = None if record is None else record.__dict__
    write_manifest(out, command="train", seed=settings.seed,
                   settings=settings.__dict__ | {"record": record_json},
                   models_json=trainer.models.to_json(),
                   files=_train_files(), results={"status": "running"})
    try:
        wall = trainer.run()
    except TrainingStopped as e:
        sys.stderr.write(f"astrocpg: training {e}; continue with astrocpg train --resume "
                         f"{out}\n")
        return 130
    rows = trainer.training.memory.rows
    L_max = float(np.asarray(trainer.models.progress.parameters["L_max"].value))
    summary = _train_summary(rows, settings, L_max)
    for b, line in summary["lines"].items():
        print(line)
    write_manifest(out, command="train", seed=settings.seed,
                   settings=settings.__dict__ | {"record": record_json},
                   models_json=trainer.models.to_json(), files=_train_files(),
                   results={"status": "finished", "wall_seconds_last_invocation": wall,
                            "per_trial": summary["per_trial"]})
    print(f"wrote {out}/ (sessions.csv, weights.npz, checkpoint.pkl, manifest.json)")
    return 0


def _record_plan(args: argparse.Namespace, payload: dict[str, Any] | None):
    """The training's RecordPlan: from the options, or (resuming) from the checkpoint."""
    from ..coupling.recorder import RecordPlan
    from .simulate import check_selection

    stored = (payload or {}).get("record_plan")
    if stored is not None:
        if args.record_every is not None and args.record_every != stored["every"]:
            raise InputError(f"--resume: that run records every {stored['every']} sessions, "
                             f"not {args.record_every}")
        return RecordPlan.from_dict(stored)
    if args.record_every is None:
        if args.spikes is not None or args.traces is not None:
            raise InputError("--spikes/--traces of a training need --record-every N")
        return None
    if args.record_every < 1:
        raise InputError(f"--record-every must be at least 1, got {args.record_every}")
    if args.record_stride < 1:
        raise InputError(f"--record-stride must be at least 1, got {args.record_stride}")
    spikes, traces = check_selection(args.spikes, args.traces)
    return RecordPlan(every=args.record_every, spikes=spikes, traces=traces,
                      stride=args.record_stride)


def _train_files() -> dict[str, str]:
    return {
        "sessions.csv": "one row per trial and session: " + ", ".join(
            __import__("astrocpg.coupling.training", fromlist=["x"]).SESSION_COLUMNS),
        "weights.npz": "weights_mV (trial, session, 8, 8): each trial's inter-limb table after "
                       "each session (NaN after a trial's last); final_weights_mV; labels",
        "checkpoint.pkl": "state to continue exactly (astrocpg train --resume DIR)",
        "recordings/": "with --record-every: trialTT_sessionSSSS/ per recorded session (spikes, "
                       "traces, robot, manifest; astrocpg export reads it)",
    }


def _train_summary(rows: list[dict], settings, L_max: float) -> dict[str, Any]:
    per_trial: dict[int, dict[str, float]] = {}
    lines: dict[int, str] = {}
    for b in range(settings.n_trials):
        mine = [r for r in rows if r["trial"] == b]
        if not mine:
            continue
        last20, last50 = mine[-20:], mine[-50:]
        speed = float(np.mean([r["mean_forward_speed_m_per_s"] for r in last20]))
        full = float(np.mean([r["length_s"] >= L_max - 1e-6 for r in last50]))
        per_trial[b] = {"sessions": len(mine), "mean_speed_last20_m_per_s": speed,
                        "full_length_share_last50": full}
        lines[b] = (f"trial {b}: {len(mine)} sessions; mean forward speed over the last 20: "
                    f"{speed:.3f} m/s; sessions reaching L_max in the last 50: {full:.0%}")
    return {"per_trial": per_trial, "lines": lines}


def _trained_run(folder: str, seconds: float, seed: int, progress: bool):
    """The trained tables of every trial of ``folder``, run for ``seconds`` (one batch)."""
    import json

    from .simulate import simulate_closed_loop

    if not np.isfinite(seconds) or seconds <= 0:
        raise InputError(f"--seconds must be positive, got {seconds:g}")
    weights = load_weights(folder)
    try:
        settings = json.loads((Path(folder) / "manifest.json").read_text())["settings"]
    except (OSError, ValueError, KeyError):
        raise InputError(f"{folder}: no readable manifest.json (not a training run)") from None
    models = models_from(settings.get("overrides", []), settings.get("equations", {}))
    if not settings.get("astrocytes", True):
        models = models.with_values({"astrocyte_regulation": 0.0})
    result = simulate_closed_loop(models, seconds=seconds, seed=seed,
                                  n_trials=len(weights), weights=weights, record_traces=False,
                                  progress=progress)
    return result, weights


def _cmd_gait(args: argparse.Namespace) -> int:
    from .gait import gait_label, leg_phases, weight_structure

    result, weights = _trained_run(args.dir, args.seconds, args.seed, not args.no_progress)
    w_max = float(np.asarray(result.cpg.models.interlimb_synapse.parameters["w_max"].value))
    t, i = result.spikes["motor"]
    rec = result.robot
    for b in range(result.cpg.n_trials):
        g = leg_phases(t, i, result.cpg.layout, b, min(1.0, args.seconds / 5), args.seconds)
        label = gait_label(g["phases"], g["locking"])
        speed = float(rec.torso_velocity[b, :, 0].mean())
        ph = ", ".join(f"{leg} {g['phases'][leg]:.2f} (lock {g['locking'][leg]:.2f})"
                       for leg in ("FR", "FL", "RR", "RL"))
        ws = weight_structure(weights[b], w_max)
        print(f"trial {b}: phases relative to FR: {ph}; gait: {label}; "
              f"mean forward speed {speed:.3f} m/s; upright {rec.alive[b].mean():.0%}; "
              f"weights: {ws['mixed_limb_pairs']} of {ws['limb_pairs']} limb pairs with two "
              f"inhibitory and two excitatory synapses, {ws['share_above_0.9_w_max']:.0%} "
              f"above 0.9 w_max")
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    from . import plots
    from .gait import leg_phases, phase_matrix

    folder = Path(args.dir)
    result, weights = _trained_run(args.dir, args.seconds, 1, False)
    if not 0 <= args.trial < len(weights):
        raise InputError(f"--trial {args.trial}: {folder} has {len(weights)} trial(s)")
    b = args.trial
    plots.plot_weights(folder / "weights.png", weights[b] * 1e3, trial=b)
    plots.plot_training_curves(folder / "training.png", folder / "sessions.csv")
    t_end = args.seconds
    plots.plot_thigh_extensor_activity(folder / "thigh_extensor_activity.png", result.spikes,
                                       result.cpg.layout, trial=b,
                                       window=(max(0.0, t_end - 2.0), t_end))
    t, i = result.spikes["motor"]
    g = leg_phases(t, i, result.cpg.layout, b, min(1.0, t_end / 5), t_end)
    plots.plot_gait(folder / "gait.png", result.robot, b, phase_matrix(g["phases"]), g,
                    window=(max(0.0, t_end - 2.0), t_end))
    print(f"wrote {folder}/weights.png, training.png, thigh_extensor_activity.png, gait.png")
    return 0


def _cmd_study(args: argparse.Namespace) -> int:
    from .study import FAILURES, RESULTS, load_study, run_study

    study = load_study(args.file)
    out = Path(args.out) if args.out else Path("out") / study.name
    n_trials = sum(r.n_trials for r in study.runs)
    print(f"study {study.name}: {len(study.runs)} runs ({n_trials} trials x "
          f"{study.n_sessions} sessions) -> {out}/")
    try:
        res = run_study(study, out, workers=args.workers, scheduler=args.scheduler,
                        progress=not args.no_progress)
    except KeyboardInterrupt:
        sys.stderr.write("astrocpg: study interrupted; run the same command again to "
                         "continue (finished runs are kept)\n")
        return 130
    counts = ", ".join(f"{v} {k}" for k, v in res["counts"].items())
    print(f"runs: {counts}; {res['rows']} rows in {out / RESULTS}")
    if res["failed"]:
        print(f"not finished: {', '.join(res['failed'])} (errors in {out / FAILURES}); "
              f"rerun the same command to retry them")
        return 1
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from .report import report

    if args.last < 1:
        raise InputError(f"--last must be at least 1, got {args.last}")
    if args.smooth < 1:
        raise InputError(f"--smooth must be at least 1, got {args.smooth}")
    written = report(Path(args.dir), last=args.last, smooth=args.smooth)
    print(written["text"])
    print(f"wrote {', '.join(str(p) for p in written['files'])}")
    return 0


def _cmd_power(args: argparse.Namespace) -> int:
    from .outputs import save_json
    from .power import format_power, measure

    folder = Path(args.dir)
    res = measure(folder, trial=args.trial, sessions=args.sessions,
                  progress=not args.no_progress)
    print(format_power(res))
    from .outputs import package_versions
    save_json(folder / f"power_trial{args.trial}.json",
              res | {"package_versions": package_versions(), "argv": sys.argv})
    print(f"wrote {folder / f'power_trial{args.trial}.json'}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from .export import export

    path = export(Path(args.dir), args.format, Path(args.out) if args.out else None)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


def _cmd_robot(args: argparse.Namespace) -> int:
    from ..coupling.robot import A1Parameters, export_xml

    path = Path(args.path)
    if path.suffix.lower() != ".xml":
        raise InputError(f"robot export {path}: the file name must end in .xml")
    if not path.parent.exists():
        raise InputError(f"robot export {path}: folder '{path.parent}' does not exist")
    export_xml(path, A1Parameters())
    print(f"wrote {path}")
    return 0


def _save_common(out: Path, result, save_npz) -> dict[str, str]:
    from .outputs import save_spikes_and_traces
    return save_spikes_and_traces(out, result.spikes, result.traces)


def _layout_json(L) -> dict[str, Any]:
    from ..network import INTERNEURONS, POOLS, THIGH_POOLS
    return {
        "n_trials": L.n_trials, "legs": list(L.legs), "pools": list(POOLS),
        "pool_size": L.pool_size,
        "motor_index": "trial*motor_per_trial + (leg*4 + pool)*pool_size + k",
        "motor_per_trial": L.motor_per_trial,
        "interneurons": [n for n, *_ in INTERNEURONS],
        "interneuron_index": "trial*interneurons_per_trial + leg*6 + interneuron",
        "interneurons_per_trial": L.interneurons_per_trial,
        "astrocyte_index": "trial*thigh_pools_per_trial + leg*2 + (0 flexor, 1 extensor)",
        "thigh_pools": list(THIGH_POOLS),
    }


def _format_unit_summary(b: int, seed: int, s: dict[str, Any]) -> str:
    def f(key: str, fmt: str = ".3f") -> str:
        v = s.get(key)
        return "n/a" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, fmt)
    return (f"unit {b} (seed {seed}): period {f('period')} s; phases vs thigh flexor: "
            f"{_phases(s)}; rate per neuron: {_rates(s)}; interneurons "
            f"{s.get('interneurons_total_Hz', float('nan')):.0f} Hz in total")


def _phases(s: dict[str, Any]) -> str:
    ph = s.get("phases", {})
    return ", ".join(f"{k} {v:.2f}" for k, v in ph.items()) if ph else "n/a"


def _rates(s: dict[str, Any]) -> str:
    r = s.get("rates", {})
    return ", ".join(f"{k} {v:.1f} Hz" for k, v in r.items()) if r else "n/a"


COMMANDS = {"unit": _cmd_unit, "run": _cmd_run, "train": _cmd_train, "gait": _cmd_gait,
            "plot": _cmd_plot, "robot": _cmd_robot, "study": _cmd_study, "report": _cmd_report,
            "power": _cmd_power, "export": _cmd_export, "describe": _cmd_describe}


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
