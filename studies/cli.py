"""The ``astrocpg`` command line: parses arguments and calls the Python API; nothing imports it.

    astrocpg unit  --seconds S --seed K --out DIR [--trials N]
    astrocpg run   --seconds S --seed K [--trials N] [--weights FILE|DIR] [--robot XML] --out DIR
    astrocpg train --sessions N --trials N --seed K [--no-astrocytes] --out DIR | --resume DIR
    astrocpg gait DIR [--seconds S] [--seed K]
    astrocpg power DIR [--trial K] [--sessions N]
    astrocpg evaluate DIR [--worlds FILE|robustness] [--seconds S] [--repeats R] [--out DIR]
    astrocpg plot DIR [--trial K] [--window T0 T1] [--format png|pdf|svg] [--out DIR]
    astrocpg video DIR [--trial K] [--start S] [--stop S] [--fps F] [--speed X] [--size W H]
                       [--panel] [--out FILE]
    astrocpg study FILE [--seeds 1-3] [--sessions N] [--set NAME=VALUE] [--out DIR]
                        [--workers N] [--scheduler ADDRESS]
    astrocpg report DIR
    astrocpg export DIR [--format nwb|npz] [--experimenter 'LAST, FIRST'] [--institution TEXT]
    astrocpg describe [MODEL|PARAMETER] [--format markdown|latex]
    astrocpg robot export PATH.xml
    astrocpg models list | models dump MODEL [--set NAME=VALUE] [--model MODEL=FILE]

Common options: ``--set NAME=VALUE`` overrides a model parameter (with units),
``--model MODEL=FILE`` replaces a whole model by a model file (TOML: its equations, new
parameters and state variables; ``astrocpg models dump MODEL`` writes one),
``--equations MODEL=FILE`` (a shorthand) replaces a model's equation string by the text of FILE.
Every failure ends with one line on stderr naming the culprit and an exit code (see EXIT_HELP).
"""

from __future__ import annotations

import argparse
import atexit
import logging
import os
import signal
import sys
import threading
import warnings
from pathlib import Path
from typing import Any, Callable, NoReturn, Sequence

from ..errors import AstrocpgError, EnvironmentFault, InputError, did_you_mean, one_line
from ..environment import check as check_environment, flag

DEFAULT_RUN_OUT = "out/run"
DESCRIPTION = """\
astrocpg simulates a spiking central pattern generator with astrocytes (Brian2) that drives
a simulated Unitree A1 quadruped (MuJoCo), and learns its gait by reward-modulated STDP.

typical use:
  astrocpg run --seconds 10 --out out/run         the CPG drives the robot, weights fixed
  astrocpg train --sessions 400 --out out/train   learn a gait; --resume continues it
  astrocpg gait out/train                         name the gait the training learnt
  astrocpg plot out/run                           figures of any output folder
  astrocpg video out/run                          the robot replayed as MP4
  astrocpg study quick                            a parameter study (TOML), resumable

Every command writes one output folder (whole, or nothing). 'astrocpg COMMAND --help' lists
a command's options with their defaults; '--set NAME=VALUE' overrides a model parameter
(with units, e.g. --set tau_motor=9*ms), and 'astrocpg describe' shows the equations."""
EXIT_HELP = """exit codes:
  0    done
  1    environment: a file or folder could not be read or written (disk full, permissions)
  2    bad input: an option, a value, an equation, a file's content; nothing was written
  3    diverged: a network state NaN, inf or beyond 1e50 (SI units), or an unstable robot;
       the folder says 'diverged'
  130  interrupted (Ctrl-C, SIGTERM); no folder that looks finished is left
"""


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:  # every --help lists the exit codes
        kwargs.setdefault("epilog", EXIT_HELP)
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:  # one line, exit 2 (argparse prints usage too)
        sys.stderr.write(f"astrocpg: error: {one_line(message)}\n")
        raise SystemExit(2)

    def _check_value(self, action: argparse.Action, value: Any) -> None:
        # a misspelt command gets the closest name (argparse's own message lists them all)
        if action.choices is not None and value not in action.choices:
            raise argparse.ArgumentError(
                action, f"invalid choice: {value!r}{did_you_mean(value, action.choices)} "
                        f"(choose from {', '.join(map(str, action.choices))})")

    def parse_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                   namespace: argparse.Namespace | None = None) -> argparse.Namespace:
        """argparse's, with the closest option named for a misspelt one (of the command
        typed: its options, not the top level's)."""
        ns, extras = self.parse_known_args(args, namespace)
        if extras:
            options = [o for a in _chosen_parsers(self, ns)[-1]._actions for o in a.option_strings]
            said = [x + (did_you_mean(x.split("=", 1)[0], options) if x.startswith("-") else "")
                    for x in extras]
            self.error(f"unrecognized arguments: {' '.join(said)}")
        return ns


def _chosen_parsers(parser: argparse.ArgumentParser,
                    ns: argparse.Namespace) -> list[argparse.ArgumentParser]:
    """The parser and the (sub)command parsers chosen in ``ns``, outermost first."""
    chain = [parser]
    while True:
        groups = [a for a in chain[-1]._actions if isinstance(a, argparse._SubParsersAction)]
        chosen = [a.choices[getattr(ns, a.dest)] for a in groups
                  if getattr(ns, a.dest, None) in a.choices]
        if not chosen:
            return chain
        chain.append(chosen[0])


def _command_list(parser: argparse.ArgumentParser, ns: argparse.Namespace) -> str | None:
    """What a command group typed alone (``astrocpg``, ``astrocpg models``...) prints: its
    commands, one line each; None when the command typed is complete."""
    last = _chosen_parsers(parser, ns)[-1]
    groups = [a for a in last._actions if isinstance(a, argparse._SubParsersAction)]
    if not groups or getattr(ns, groups[0].dest, None) is not None:
        return None
    lines = [last.format_usage().rstrip(), ""]
    if last.description:
        lines += [last.description.rstrip(), ""]
    lines.append("commands:")
    for choice in groups[0]._choices_actions:  # one per command, with its help
        lines.append(f"  {choice.dest:10s} {choice.help or ''}")
    lines += ["", f"'{last.prog} COMMAND --help' shows a command's options."]
    return "\n".join(lines) + "\n"


def _csv_list(text: str) -> tuple[str, ...]:
    return () if text.strip() in ("", "none") else tuple(x.strip() for x in text.split(","))


def _add_record_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--spikes", type=_csv_list, default=None, metavar="POPS",
                   help="populations whose spikes are recorded, comma-separated, or none "
                        "(default: motor,interneuron,astrocyte)")
    p.add_argument("--traces", type=_csv_list, default=None, metavar="NAMES",
                   help="traces recorded, comma-separated, or none (default: motor_Ca,"
                        "astrocyte_Ca,astrocyte_IP3,astrocyte_AG,astrocyte_ADO)")


def _add_model_file_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", dest="model_files", action="append", default=[],
                   metavar="MODEL=FILE",
                   help="replace MODEL (e.g. astrocyte) by a model file (TOML, as `astrocpg models "
                        "dump MODEL` writes it); it may declare new parameters and variables")


def _add_model_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                   help="override a model parameter, with units (e.g. --set tau_motor=9*ms)")
    p.add_argument("--equations", action="append", default=[], metavar="MODEL=FILE",
                   help="replace the equation string of MODEL (e.g. motor_neuron) by FILE's text")
    _add_model_file_option(p)
    _add_codegen_option(p)
    _add_no_progress(p)


def _add_no_progress(p: argparse.ArgumentParser) -> None:
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bar on stderr (default: a bar while it works)")


def _add_codegen_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--codegen", default=None, metavar="TARGET",
                   help="Brian2 code generation: numpy (default) or cython (2x faster per trial "
                        "for 1-4 trials, 1.5x at 20; the first build compiles for minutes and is "
                        "cached). Default: $ASTROCPG_CODEGEN, else numpy")


def _add_simulation_options(p: argparse.ArgumentParser, seconds: float) -> None:
    p.add_argument("--seconds", type=float, default=seconds,
                   help=f"simulated time in s, a whole number of 1 ms steps (default "
                        f"{seconds:g} s)")
    p.add_argument("--seed", type=int, default=1, help="seed of trial 0 (default 1)")
    p.add_argument("--trials", type=int, default=1,
                   help="independent trials, seeds K, K+1, ... (default 1)")
    p.add_argument("--trace-dt", type=float, default=1.0, metavar="MS",
                   help="sampling interval of the Ca2+/IP3/2-AG/adenosine traces in ms, a "
                        "whole number of 1 ms steps (default 1 ms)")
    p.add_argument("--trace-dtype", default="float32", choices=("float32", "float64"),
                   help="what the traces are kept as: float32 (default, 7 significant digits, "
                        "half the memory) or float64 (Brian2's full resolution)")


def _add_overwrite(p: argparse.ArgumentParser) -> None:
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing output whole (never merged with the new one)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="astrocpg", description=DESCRIPTION, epilog=EXIT_HELP,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    from .. import __version__  # the package's one version (pyproject reads it too)
    parser.add_argument("--version", action="version", version=f"astrocpg {__version__}",
                        help="print the version and exit")
    sub = parser.add_subparsers(dest="command", required=False, parser_class=_Parser,
                                metavar="COMMAND", help="what to do (alone: lists the commands)")

    unit = sub.add_parser("unit", help="one locomotion unit, open loop (paper Fig. 1c)",
                          epilog=EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_simulation_options(unit, seconds=30.0)
    unit.add_argument("--out", required=True, metavar="DIR",
                      help="output folder (required; new or empty, --overwrite replaces it)")
    _add_overwrite(unit)
    _add_record_options(unit)
    _add_model_options(unit)

    run = sub.add_parser("run", help="the closed loop: CPG drives the A1 (fixed weights)",
                         epilog=EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_simulation_options(run, seconds=10.0)
    run.add_argument("--weights", metavar="FILE|DIR",
                     help="8x8 inter-limb table in mV (.npy, .csv/.txt, .json), or a training "
                          "folder (its final weights); default: all zero, limbs uncoupled")
    run.add_argument("--trial", type=int, default=None,
                     help="with --weights DIR: use that trial's table for every trial "
                          "(default: trial k's table for trial k)")
    run.add_argument("--session", type=int, default=None, metavar="N",
                     help="with --weights DIR (a training) and --trial T: replay session N of "
                          "trial T exactly, learning on, from what the training recorded of "
                          "its start (the same final x as in its sessions.csv)")
    run.add_argument("--robot", metavar="XML",
                     help="an MJCF file with the A1's joint and actuator names (default: the "
                          "project's A1, as 'astrocpg robot export' writes it)")
    run.add_argument("--robot-stride", type=int, default=1, metavar="STEPS",
                     help="record the robot every STEPS physics steps (default 1)")
    run.add_argument("--out", default=DEFAULT_RUN_OUT, metavar="DIR",
                     help=f"output folder, new or empty (default {DEFAULT_RUN_OUT}; --overwrite "
                          f"replaces it)")
    run.add_argument("--figure", action="store_true",
                     help="also draw thigh_extensor_activity.png in --out (about 1 s; "
                     "'astrocpg plot OUT' draws every figure of the folder later)")
    _add_overwrite(run)
    _add_record_options(run)
    _add_model_options(run)

    train = sub.add_parser("train", help="gait learning over sessions (reward-modulated STDP)",
                           epilog=EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    train.add_argument("--sessions", type=int, default=None,
                       help="sessions per trial (default 400; with --resume: the run's own, "
                            "or more to extend it, finished or not, exactly as if asked for "
                            "from the start)")
    train.add_argument("--seed", type=int, default=None,
                       help="seed of trial 0; trial k has seed K+k (default 1)")
    train.add_argument("--trials", type=int, default=None,
                       help="independent trials, trained side by side (default 1)")
    train.add_argument("--no-astrocytes", action="store_true", default=None,
                       help="remove the adenosine term (the paper's ablation)")
    train.add_argument("--out", metavar="DIR",
                       help="output folder, new or empty (required unless --resume)")
    train.add_argument("--resume", metavar="DIR",
                       help="continue the run in DIR with the settings it started with (an "
                            "option given again must agree with them, values compared as "
                            "quantities: else it is refused, naming the option); its figures/, "
                            "evaluation/, videos and power estimates, made from the earlier "
                            "weights, are removed; a checkpoint of astrocpg before format 2 "
                            "(checkpoint.pkl) is refused unread")
    _add_overwrite(train)
    train.add_argument("--record-every", type=int, default=None, metavar="N",
                       help="record sessions 1, 1+N, 1+2N... and the last of each trial "
                            "(spikes, traces, robot) into DIR/recordings/ (default: none)")
    train.add_argument("--record-stride", type=int, default=None, metavar="STEPS",
                       help="with --record-every: physics steps (1 ms) between trace and robot "
                            "samples (default 1)")
    _add_record_options(train)
    _add_model_options(train)

    gait = sub.add_parser("gait", help="run trained weights, name their rhythm and their gait")
    gait.add_argument("dir", help="a training folder")
    gait.add_argument("--seconds", type=float, default=10.0,
                      help="simulated time of each run with the trained weights, in s, a "
                           "whole number of 1 ms steps (default 10 s; rhythm and gait are "
                           "read from its second half)")
    gait.add_argument("--repeats", type=int, default=5,
                      help="runs per trained table, learning off, each with its own noise "
                           "(default 5): the gait is the share of runs that show it, with its "
                           "95%% interval")
    gait.add_argument("--seed", type=int, default=None,
                      help="seed of run 0; run b (table k of n, repeat r: b = r*n + k) has "
                           "seed K+b (default: the training's own, so repeat 0 runs each table "
                           "on the network it trained with)")
    gait.add_argument("--world", action="append", default=[], metavar="NAME=VALUE",
                      help="a world parameter for the runs, over the training's world (e.g. "
                           "slope=0.17; repeatable; 'astrocpg models show world' lists them)")
    _add_no_progress(gait)
    _add_codegen_option(gait)

    ev = sub.add_parser("evaluate", help="trained controllers, learning off, in other worlds "
                                         "(slopes, terrain, friction, pushes)")
    ev.add_argument("dir", help="a training folder or a study folder (its finished runs)")
    ev.add_argument("--worlds", default="robustness",
                    help="a worlds file (TOML: [worlds.NAME] tables of world parameters, "
                         "and/or [grid.AXIS] with values = [...] and, for factors, scale = "
                         "[parameters]) or 'robustness' (flat, slopes +-0.09 and +-0.17 rad, "
                         "rough terrain 1 and 2 cm, friction 0.3, a 60 N push; the default)")
    ev.add_argument("--seconds", type=float, default=10.0,
                    help="simulated time of each evaluation run, in s, a whole number of 1 ms "
                         "steps (default 10 s)")
    ev.add_argument("--repeats", type=int, default=5,
                    help="runs per controller and world, each with its own noise (default 5; "
                         "a gait is the share of runs that show it, with its 95%% interval)")
    ev.add_argument("--seed", type=int, default=1,
                    help="seed of the first run; run b of a training's batch (controller k of "
                         "n, repeat r: b = r*n + k) has seed K+b (default 1)")
    ev.add_argument("--condition", action="append", default=None, metavar="NAME",
                    help="only a study's runs of this condition (repeatable; default all)")
    ev.add_argument("--out", default=None, metavar="OUT",
                    help="output folder (default DIR/evaluation, replaced whole each time)")
    _add_overwrite(ev)
    ev.add_argument("--workers", type=int, default=None,
                    help="run the (training, world) cells on a local Dask cluster of N processes "
                         "(default: one after the other, here)")
    ev.add_argument("--scheduler", metavar="ADDRESS",
                    help="run the cells on a running Dask scheduler, e.g. tcp://127.0.0.1:8786 "
                         "(default: none)")
    _add_no_progress(ev)
    _add_codegen_option(ev)

    plot = sub.add_parser("plot", help="figures of any output folder (unit, run, training, "
                                       "recorded session, study run)")
    plot.add_argument("dir", help="an output folder of unit, run, train or a study's run, or a "
                                  "recorded session (TRAINING/recordings/...)")
    plot.add_argument("--trial", type=int, default=0, help="which trial (default 0)")
    plot.add_argument("--window", type=float, nargs=2, metavar=("T0", "T1"), default=None,
                      help="time window in s (default: the whole recording; a training: the "
                           "last 2 s of its run)")
    plot.add_argument("--format", default="png", help="png, pdf or svg (default png)")
    plot.add_argument("--seconds", type=float, default=None,
                      help="a training: simulated time of the run with the trained weights, "
                           "in s, a whole number of 1 ms steps, for its activity and gait "
                           "figures (default 10 s)")
    plot.add_argument("--out", metavar="OUT",
                      help="figure folder (default DIR/figures, replaced on each plot)")
    _add_overwrite(plot)
    _add_no_progress(plot)

    vid = sub.add_parser("video", help="the recorded robot replayed as MP4 (MuJoCo offscreen; "
                                       "MUJOCO_GL honoured, else EGL then OSMesa)")
    vid.add_argument("dir", help="a run, a recorded training session, or a training (its "
                                 "trial's last recorded session)")
    vid.add_argument("--trial", type=int, default=0, help="which trial (default 0)")
    vid.add_argument("--fps", type=float, default=30.0,
                     help="frames per second of video (default 30)")
    vid.add_argument("--speed", type=float, default=1.0,
                     help="simulated seconds per second of video (default 1: real time)")
    vid.add_argument("--size", type=int, nargs=2, metavar=("W", "H"), default=(640, 480),
                     help="frame size in pixels, even numbers (default 640 480)")
    vid.add_argument("--start", type=float, default=None, metavar="S",
                     help="begin at S seconds of the recording (default: its start)")
    vid.add_argument("--stop", type=float, default=None, metavar="S",
                     help="end at S seconds of the recording (default: its end)")
    vid.add_argument("--out", metavar="FILE",
                     help="MP4 file (default DIR/video_trialTT.mp4, replaced each time)")
    vid.add_argument("--panel", action="store_true",
                     help="a panel under the frames, scrolling with them: time, forward speed, "
                          "gait diagram, thigh-pool activity and astrocyte Ca2+ (those recorded)")
    _add_no_progress(vid)
    _add_overwrite(vid)

    study = sub.add_parser("study", help="a parameter study (TOML) on Dask; resumable")
    study.add_argument("file", nargs="?",
                       help="study file, e.g. studies/sweeps/quick.toml, or a built-in "
                            "study's name (quick, ablation)")
    study.add_argument("--status", metavar="DIR",
                       help="say what the study in DIR has done and what is left, with an "
                            "estimate of the time left (reads only; safe while it runs)")
    study.add_argument("--out", metavar="DIR",
                       help="study folder (default out/<study name>; rerunning continues it)")
    study.add_argument("--seeds", metavar="SEEDS",
                       help="the seeds instead of the file's: FIRST-LAST (1-3), a list A,B,C "
                            "(1,4,9) or a count N (N seeds from the file's first seed); "
                            "recorded in the study folder (a rerun gives the same)")
    study.add_argument("--sessions", metavar="N",
                       help="sessions per trial instead of the file's [study] sessions")
    study.add_argument("--set", dest="overrides", action="append", default=[],
                       metavar="NAME=VALUE",
                       help="a parameter of every run, with units, in place of the file's "
                            "[base] value (repeatable; e.g. --set L_max=2*second)")
    study.add_argument("--workers", type=int, default=None,
                       help="local cluster size (default: one worker per core)")
    study.add_argument("--scheduler", metavar="ADDRESS",
                       help="a running Dask scheduler, e.g. tcp://127.0.0.1:8786 (default: "
                            "a local cluster)")
    _add_no_progress(study)
    _add_codegen_option(study)
    _add_overwrite(study)

    report = sub.add_parser("report", help="Fig. 3c curves and final figures of a study")
    report.add_argument("dir", help="a study folder")
    report.add_argument("--smooth", type=int, default=1, metavar="N",
                        help="plot each seed's trailing mean over N sessions (default 1: raw)")
    report.add_argument("--last", type=int, default=50,
                        help="sessions at the end over which final figures are averaged "
                             "(default 50; fewer where a seed trained fewer, and it says so)")
    report.add_argument("--out", metavar="OUT",
                        help="report folder (default DIR/report, replaced each time)")
    _add_overwrite(report)

    power = sub.add_parser("power", help="SNN vs RL power estimate of a trained controller")
    power.add_argument("dir", help="a training folder (astrocpg train, or a study's run)")
    power.add_argument("--trial", type=int, default=0, help="which trial's weights (default 0)")
    power.add_argument("--sessions", type=int, default=10,
                       help="sessions to measure (default 10)")
    power.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                       dest="overrides",
                       help="a parameter over the training's models for this measurement "
                            "(e.g. limit_margin=0*radian; repeatable); the figures go to "
                            "power_trial<K>_<NAME=VALUE>.json")
    _add_no_progress(power)
    _add_codegen_option(power)

    exp = sub.add_parser("export", help="a run or unit folder as NWB or npz")
    exp.add_argument("dir", help="output of astrocpg run or unit")
    exp.add_argument("--format", default="nwb", help="nwb or npz (default nwb)")
    exp.add_argument("--out", metavar="FILE",
                     help="file to write (default DIR.<format>, beside DIR)")
    exp.add_argument("--experimenter", action="append", default=[], metavar="'LAST, FIRST'",
                     help="who ran the simulation (repeatable), recorded in the file "
                          "(default: none)")
    exp.add_argument("--institution", metavar="TEXT",
                     help="where it was run, recorded in the file (default: none)")
    _add_overwrite(exp)

    desc = sub.add_parser("describe", help="a model's equations (sympy) and parameter table, "
                                           "or one parameter")
    desc.add_argument("model", nargs="?", help="one model (default: all), a parameter's name "
                      "(e.g. tau_motor: its value, model and the equations using it), or "
                      "'senses': the robot senses a neuron model may bind")
    desc.add_argument("--format", default="markdown", help="markdown or latex (default markdown)")
    desc.add_argument("--equations", action="append", default=[], metavar="MODEL=FILE",
                      help="describe MODEL with the equation string of FILE")
    desc.add_argument("--set", dest="overrides", action="append", default=[],
                      metavar="NAME=VALUE", help="describe with a parameter overridden")
    _add_model_file_option(desc)

    mods = sub.add_parser("models", help="list the models, or dump one as a model file (TOML)")
    mods_sub = mods.add_subparsers(dest="models_command", required=False, parser_class=_Parser,
                                   metavar="COMMAND",
                                   help="list or dump (alone: lists these commands)")
    mods_sub.add_parser("list", help="the models, their kinds and interfaces")
    dump = mods_sub.add_parser("dump", help="print MODEL as a model file (TOML)")
    dump.add_argument("name", metavar="MODEL",
                      help="the model to dump (e.g. astrocyte; 'astrocpg models list' names them)")
    dump.add_argument("--set", dest="overrides", action="append", default=[],
                      metavar="NAME=VALUE", help="dump with a parameter overridden")
    dump.add_argument("--equations", action="append", default=[], metavar="MODEL=FILE",
                      help="dump with the equation string of FILE")
    _add_model_file_option(dump)

    robot = sub.add_parser("robot", help="the project's A1 model")
    robot_sub = robot.add_subparsers(dest="robot_command", required=False, parser_class=_Parser,
                                     metavar="COMMAND",
                                     help="export (alone: lists these commands)")
    export = robot_sub.add_parser("export", help="write the A1 model as MJCF")
    export.add_argument("path", metavar="PATH.xml", help="the MJCF file to write")
    _add_overwrite(export)
    return parser


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
    interrupted)."""
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
            except (OSError, ValueError):  # a closed pipe or stream: nothing more to say
                pass
        os._exit(code)


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    listing = _command_list(parser, args)
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
    try:
        return _run_command(args)
    finally:
        logging.disable(logging_was)
        quiet.__exit__(None, None, None)


def _run_command(args: argparse.Namespace) -> int:
    # only the main thread may set handlers (main() called in another thread: none of ours)
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _sigterm) if in_main else None
    env_codegen = os.environ.get("ASTROCPG_CODEGEN")  # --codegen sets it for this command only
    unraisable = sys.unraisablehook
    interrupted = False
    try:
        try:
            check_environment()  # a switch that is not a boolean: refused before anything runs
            if getattr(args, "codegen", None) is not None:
                _choose_codegen(args.codegen)
            code = COMMANDS[args.command](args)
            compiled = sys.modules.get("astrocpg.coupling.compiled")
            if code == 0 and compiled is not None and compiled.PROBLEM:
                print(f"warning: {compiled.PROBLEM}")  # warnings are off: said here once
            return code
        except Exception as e:
            if _interrupted(e):  # cleanup that failed while an interrupt unwound the stack
                raise KeyboardInterrupt from None
            raise
    except AstrocpgError as e:
        sys.stderr.write(f"astrocpg: {_kind(e)}: {e.line}\n")
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
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        sys.stderr.close()
        return 0
    except OSError as e:  # an I/O failure no layer turned into an EnvironmentFault
        sys.stderr.write(f"astrocpg: environment: {EnvironmentFault.from_os_error(e).line}\n")
        return 1
    except MemoryError:
        sys.stderr.write("astrocpg: environment: out of memory\n")
        return 1
    except Exception as e:  # a bug of ours: still one line, the traceback on request
        fault = _environment_fault(e)
        if fault is not None:  # a library refusing the environment it was given
            sys.stderr.write(f"astrocpg: environment: {fault.line}\n")
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
    from ..network.codegen import ENV, choose_target

    try:
        os.environ[ENV] = choose_target(value)
    except InputError as e:
        raise InputError(e.message, culprit="--codegen") from None


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


# ---------------------------------------------------------------- commands
def _models(args: argparse.Namespace) -> dict[str, Any]:
    from ..models.compose import read_equation_files, read_model_files
    return {"overrides": list(args.overrides), "equations": read_equation_files(args.equations),
            "models": read_model_files(getattr(args, "model_files", []))}


def _input_files(args: argparse.Namespace) -> list[str]:
    """The files --model and --equations MODEL=FILE name: --out may not be or hold them."""
    items = [*getattr(args, "model_files", []), *getattr(args, "equations", [])]
    return [item.partition("=")[2] for item in items if "=" in item]


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    return dict(vars(args))


def _cmd_unit(args: argparse.Namespace) -> int:
    from ..network.recording import overflow_words
    from .experiments.unit import format_rhythm, unit

    result = unit(seconds=args.seconds, seed=args.seed, trials=args.trials,
                  trace_dt=args.trace_dt, trace_dtype=args.trace_dtype, spikes=args.spikes,
                  traces=args.traces, out=args.out,
                  overwrite=args.overwrite, progress=not args.no_progress,
                  settings=_settings(args), inputs=_input_files(args), **_models(args))
    for b, s in enumerate(result.summary["rhythm"]):
        print(format_rhythm(b, args.seed + b, s))
    if result.summary.get("trace_overflow"):
        print("warning: " + overflow_words(result.summary["trace_overflow"]))
    print(f"wrote {args.out}/")
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    from .experiments.run import format_run, run

    if args.session is not None:
        return _cmd_replay(args)

    result = run(seconds=args.seconds, seed=args.seed, trials=args.trials, weights=args.weights,
                 trial=args.trial, robot=args.robot, trace_dt=args.trace_dt,
                 trace_dtype=args.trace_dtype, robot_stride=args.robot_stride, spikes=args.spikes, traces=args.traces,
                 out=args.out, overwrite=args.overwrite, progress=not args.no_progress,
                 figure=args.figure, settings=_settings(args), inputs=_input_files(args),
                 **_models(args))
    print("\n".join(format_run(result, args.seed)))
    print(f"wrote {args.out}/" + ("" if args.figure else f" (figures: astrocpg plot {args.out})"))
    return 0


def _cmd_replay(args: argparse.Namespace) -> int:
    from ..models.units import whole_steps
    from .experiments.replay import format_replay, replay_session
    from .experiments.run import REPLAY_FIXED

    if args.weights is None:
        raise InputError("replays a session of a training: give the training folder with "
                         "--weights DIR", culprit="--session")
    for name, default in REPLAY_FIXED.items():
        value = getattr(args, {"models": "model_files"}.get(name, name))
        if value != default and not (default is None and not value):
            option = "--" + {"overrides": "set", "models": "model"}.get(
                name, name).replace("_", "-")
            raise InputError("a replay takes the training's own (the session's length, seed, "
                             "models and robot); drop it", culprit=option)
    stride = whole_steps(args.trace_dt * 1e-3, 1e-3, culprit="--trace-dt")
    result = replay_session(args.weights, trial=0 if args.trial is None else args.trial,
                            session=args.session, out=args.out, record_stride=stride,
                            spikes=args.spikes, traces=args.traces, overwrite=args.overwrite,
                            progress=not args.no_progress, inputs=_input_files(args))
    print("\n".join(format_replay(result)))
    print(f"wrote {args.out}/ (the session: {args.out}/recordings/trial00_session0001/)")
    return 0


def _cmd_train(args: argparse.Namespace) -> int:
    from ..models.compose import model_files_record, read_equation_files, read_model_files
    from .experiments.train import TrainingStopped, format_train, resume, train

    try:
        if args.resume:
            if args.out and Path(args.out).resolve() != Path(args.resume).resolve():
                raise InputError("--resume writes into its own folder; drop --out",
                                 culprit="--out")
            if args.overwrite:  # never ignored: it would replace what --resume continues
                raise InputError("replaces a training, --resume continues one: use one of them",
                                 culprit="--overwrite")
            expect = {"sessions": args.sessions, "seed": args.seed, "trials": args.trials,
                      "astrocytes": None if args.no_astrocytes is None
                      else not args.no_astrocytes,
                      "overrides": sorted(args.overrides) or None,
                      "equations": read_equation_files(args.equations) or None,
                      "models": model_files_record(read_model_files(args.model_files)) or None}
            # every option given must agree with the training's own (resume refuses others)
            result = resume(args.resume, progress=not args.no_progress,
                            record_every=args.record_every, record_stride=args.record_stride,
                            spikes=args.spikes, traces=args.traces, expect=expect)
            out = args.resume
        else:
            if not args.out:
                raise InputError("is required (or --resume DIR)", culprit="--out")
            result = train(out=args.out, sessions=400 if args.sessions is None else args.sessions,
                           seed=1 if args.seed is None else args.seed,
                           trials=1 if args.trials is None else args.trials,
                           astrocytes=not args.no_astrocytes, record_every=args.record_every,
                           record_stride=args.record_stride, spikes=args.spikes,
                           traces=args.traces, overwrite=args.overwrite,
                           progress=not args.no_progress, inputs=_input_files(args),
                           **_models(args))
            out = args.out
    except TrainingStopped as e:
        where = args.resume or args.out
        sys.stderr.write(f"astrocpg: training {e}; continue with astrocpg train --resume "
                         f"{where}\n")
        return 130
    for line in format_train(result):
        print(line)
    print(f"wrote {out}/ (sessions.csv, weights.npz, checkpoint.npz, manifest.json)")
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from .experiments.evaluate import evaluate, format_summary

    res = evaluate(args.dir, worlds=args.worlds, seconds=args.seconds, repeats=args.repeats,
                   seed=args.seed, conditions=args.condition, out=args.out,
                   overwrite=args.overwrite, progress=not args.no_progress,
                   workers=args.workers, scheduler=args.scheduler)
    for line in format_summary(res["summary"]):
        print(line)
    print(f"wrote {res['out']}/ (evaluation.csv, summary.csv, manifest.json)")
    return 0


def _cmd_gait(args: argparse.Namespace) -> int:
    from .experiments.trained_controller import describe_gait

    for line in describe_gait(args.dir, seconds=args.seconds, repeats=args.repeats,
                              seed=args.seed, world=args.world,
                              progress=not args.no_progress):
        print(line)
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    from ..network.recording import overflow_words
    from .experiments.view import plot
    from .outputs.writing import read_manifest

    written = plot(args.dir, trial=args.trial, window=args.window, fmt=args.format,
                   seconds=args.seconds, out=args.out, overwrite=args.overwrite,
                   progress=not args.no_progress)
    print(f"wrote {len(written)} figure(s): {', '.join(str(p) for p in written)}")
    over = (read_manifest(Path(args.dir)) or {}).get("results", {}).get("trace_overflow")
    if over:  # the figures draw what was recorded: infinities are gaps in the curves
        print("warning: " + overflow_words(over))
    return 0


def _cmd_video(args: argparse.Namespace) -> int:
    from .experiments.view import video

    res = video(args.dir, trial=args.trial, fps=args.fps, speed=args.speed, size=args.size,
                out=args.out, overwrite=args.overwrite, progress=not args.no_progress,
                panel=args.panel, start=args.start, stop=args.stop)
    print(f"wrote {res['path']} ({res['frames']} frames at {res['fps']:g} fps, "
          f"{res['seconds']:.1f} s; {res['start']:g} to {res['stop']:g} s of the recording)")
    return 0


def _study_status(args: argparse.Namespace) -> int:
    from .sweeps.status import study_status

    if args.file is not None:
        raise InputError("takes a study folder alone (astrocpg study --status DIR)",
                         culprit=f"--status {args.status} {args.file}")
    # --status reads a folder and runs nothing: an option that would act on a run is refused,
    # never ignored (--workers is the estimate's number of processes)
    given = [option for option, value in (
        ("--out", args.out), ("--seeds", args.seeds), ("--sessions", args.sessions),
        ("--set", args.overrides), ("--scheduler", args.scheduler), ("--codegen", args.codegen),
        ("--overwrite", args.overwrite), ("--no-progress", args.no_progress)) if value]
    if given:
        raise InputError(f"reads a study folder and runs nothing: {given[0]} does not apply "
                         f"(only --workers, for the estimate)", culprit=f"--status {args.status}")
    print(study_status(args.status, workers=args.workers or 1).text())
    return 0


def _cmd_study(args: argparse.Namespace) -> int:
    from .sweeps.study import RESULTS, load_study, prepare_study, run_study, study_overrides

    if args.status is not None:
        return _study_status(args)
    if args.file is None:
        raise InputError("a study file or a built-in study's name is needed (or --status DIR)",
                         culprit="astrocpg study")
    sessions = args.sessions
    if sessions is not None:  # parsed, never eval-ed: an integer or a one-line refusal
        try:
            sessions = int(sessions, 10)
        except ValueError:
            raise InputError(f"expected a whole number, got {args.sessions!r}",
                             culprit="--sessions") from None
    given = study_overrides(args.seeds, sessions, args.overrides)
    study = load_study(args.file, overrides=given)
    out = Path(args.out) if args.out else Path("out") / study.name
    study = prepare_study(study, out, workers=args.workers, scheduler=args.scheduler,
                          overwrite=args.overwrite, progress=not args.no_progress)
    if study.batch_setting == "auto":
        c = study.batch_choice or {}
        projected = c.get("projected_s", 0.0)
        span = f"{projected / 60:.0f} min" if projected >= 120 else f"{projected:.0f} s"
        how = c.get("reason") or (f"{c['runs']} runs on {c['workers']} workers: {span} if "
                                  f"every session lasts L_max, on this machine's measured cost "
                                  f"per trial")
        print(f"batch auto: {study.batch} seeds per run ({how})")
    n_trials = sum(r.n_trials for r in study.runs)
    print(f"study {study.name}: {len(study.runs)} runs ({n_trials} trials x "
          f"{study.n_sessions} sessions) -> {out}/")
    try:
        res = run_study(study, out, workers=args.workers, scheduler=args.scheduler,
                        progress=not args.no_progress, overwrite=args.overwrite)
    except KeyboardInterrupt:
        sys.stderr.write("astrocpg: study interrupted; run the same command again to "
                         "continue (finished runs are kept)\n")
        return 130
    counts = ", ".join(f"{v} {k}" for k, v in res["counts"].items())
    print(f"runs: {counts}; {res['rows']} rows in {out / RESULTS}")
    if res.get("evaluation"):
        print(f"evaluated in other worlds: {res['evaluation']}/ (evaluation.csv, summary.csv)")
    diverged = res.get("diverged") or []
    if res["failed"] and len(diverged) == len(res["failed"]):
        # every run left is diverged: a rerun would diverge again (exit 3, like run/train)
        errors = res.get("errors") or {}
        first = errors.get(diverged[0], "")
        print(f"diverged: {', '.join(diverged)} (in {res['failures']}); not a result: its "
              f"settings make it diverge, a rerun would too")
        sys.stderr.write(one_line(
            f"astrocpg: study {study.name}: {len(diverged)} of {len(study.runs)} run(s) "
            f"diverged ({', '.join(diverged[:5])}{', ...' if len(diverged) > 5 else ''}); "
            f"{diverged[0]}: {one_line(first, 200)}; errors in {res['failures']}; change the "
            f"settings of its condition (a new --out), a rerun diverges again", 900) + "\n")
        return 3
    if res["failed"]:
        # one line on stderr, like every failure: which runs, the first error, where the rest
        # is (only a file that exists), and whether a rerun can help
        errors = res.get("errors") or {}
        first = next(((k, e) for k, e in errors.items() if k not in diverged), None)
        where = f"; errors in {res['failures']}" if res.get("failures") else ""
        retried = [e for k, e in errors.items() if k not in diverged]
        bad_input = bool(retried) and all(e.startswith("InputError") for e in retried)
        retry = ("fix the input and rerun the same command" if bad_input
                 else "rerun the same command to retry them")
        if diverged:  # retried runs may finish; the diverged ones are not run again
            retry += f" ({len(diverged)} diverged, not retried: {', '.join(diverged[:3])})"
        print(f"not finished: {', '.join(res['failed'])}"
              f"{' (errors in ' + res['failures'] + ')' if res.get('failures') else ''}; "
              f"{retry}")
        sys.stderr.write(one_line(
            f"astrocpg: study {study.name}: {len(res['failed'])} of {len(study.runs)} run(s) "
            f"not finished ({', '.join(res['failed'][:5])}"
            f"{', ...' if len(res['failed']) > 5 else ''})"
            + (f"; {first[0]}: {one_line(first[1], 200)}" if first else "")
            + f"{where}; {retry}", 900) + "\n")
        return 1
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from .experiments.settings import number
    from .sweeps.report import report

    last = number(args.last, "--last", integer=True, minimum=1)
    smooth = number(args.smooth, "--smooth", integer=True, minimum=1)
    written = report(Path(args.dir), last=last, smooth=smooth, out=args.out,
                     overwrite=args.overwrite)
    if written.get("no_data"):  # a partial study: the groups left out are named, not dropped
        sys.stderr.write(one_line(f"astrocpg: note: no data yet for {len(written['no_data'])} "
                                  f"group(s) of {args.dir}: {'; '.join(written['no_data'])}",
                                  900) + "\n")
    if written.get("diverged"):  # shown as diverged, never as a result
        sys.stderr.write(one_line(f"astrocpg: note: {len(written['diverged'])} group(s) of "
                                  f"{args.dir} diverged (not a result, no figures or tests): "
                                  f"{'; '.join(written['diverged'])}", 900) + "\n")
    print(written["text"])
    print(f"wrote {', '.join(str(p) for p in written['files'])}")
    return 0


def _cmd_power(args: argparse.Namespace) -> int:
    from .experiments.power import format_power, power

    path, res = power(Path(args.dir), trial=args.trial, sessions=args.sessions,
                      progress=not args.no_progress, argv=sys.argv,
                      overrides=args.overrides)
    print(format_power(res))
    print(f"wrote {path}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from ..network.recording import overflow_words
    from .experiments.api import export
    from .outputs.writing import read_manifest

    path = export(args.dir, args.format, args.out or None, overwrite=args.overwrite,
                  experimenter=args.experimenter, institution=args.institution)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    over = (read_manifest(Path(args.dir)) or {}).get("results", {}).get("trace_overflow")
    if over:  # the file's notes and the series' descriptions say it too
        print("warning: " + overflow_words(over))
    return 0


def _cmd_describe(args: argparse.Namespace) -> int:
    if not (args.overrides or args.equations or getattr(args, "model_files", [])):
        # the built-in models: from the cache, without importing Brian2 when it is warm
        from .figures.describe_cache import cached_text

        def render() -> str:
            from .experiments.api import describe
            return describe(args.model, args.format)

        name_ok = args.model is None or args.model.isidentifier()
        if name_ok and args.format in ("markdown", "latex"):
            sys.stdout.write(cached_text(args.model, args.format, render))
            return 0
    from .experiments.api import describe

    sys.stdout.write(describe(args.model, args.format, **_models(args)))
    return 0


def _cmd_models(args: argparse.Namespace) -> int:
    from ..models import INTERFACES
    from ..models.files import model_to_toml
    from ..models.compose import model_set

    models = model_set(**_models(args)) if args.models_command == "dump" else model_set()
    known = dict(models.items())
    if args.models_command == "list":
        for name, model in known.items():
            print(f"{name:20s} {model.kind:10s} {len(model.parameters):3d} parameters  "
                  f"{INTERFACES.get(name) or '-'}")
        from ..shipped import ROOT, shipped
        for kind, use in (("model", "--model MODEL=NAME"), ("study", "astrocpg study NAME"),
                          ("worlds", "evaluate --worlds NAME")):
            print(f"\nshipped {kind} files ({use}):")
            for name, path in shipped(kind).items():
                print(f"  {name:28s} {path.relative_to(ROOT).as_posix()}")
        return 0
    if args.name not in known:
        raise InputError(f"unknown model{did_you_mean(args.name, known)} (models: "
                         f"{', '.join(known)})", culprit=args.name)
    sys.stdout.write(model_to_toml(known[args.name]))
    return 0


def _cmd_robot(args: argparse.Namespace) -> int:
    from .experiments.api import robot

    print(f"wrote {robot(args.path, overwrite=args.overwrite)}")
    return 0


COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "unit": _cmd_unit, "run": _cmd_run, "train": _cmd_train, "gait": _cmd_gait,
    "evaluate": _cmd_evaluate,
    "plot": _cmd_plot, "video": _cmd_video, "robot": _cmd_robot, "study": _cmd_study,
    "report": _cmd_report, "power": _cmd_power, "export": _cmd_export,
    "describe": _cmd_describe, "models": _cmd_models}


if __name__ == "__main__":  # pragma: no cover
    entry()
