"""The command line's grammar: one function per command adds its subparser and options
(:func:`build_parser` puts them together); the options several commands share are in
:mod:`.options`."""

from __future__ import annotations

import argparse
from typing import Any

from .options import (DEFAULT_RUN_OUT, DESCRIPTION, EXIT_HELP, Parser, add_codegen_option,
                      add_variant_options,
                      add_model_file_option, add_model_options, add_no_progress, add_overwrite,
                      add_population_option,
                      add_record_options, add_simulation_options, add_workers_option)

#: what ``add_subparsers`` returns (argparse's ``_SubParsersAction``, a private class)
Subparsers = Any


def version_line() -> str:
    """``astrocpg 0.2.0 (commit 1a2b3c4d5e6f)``: the version and, where known, the commit (from
    git in a checkout, recorded by the build in an installed wheel) and uncommitted changes."""
    from ... import build_info

    info = build_info()
    if info["commit"]:
        where = f"commit {info['commit'][:12]}" + (", uncommitted changes" if info["dirty"] else "")
    else:
        where = "commit unknown"
    return f"astrocpg {info['version']} ({where})"


class _Version(argparse.Action):
    """``--version``, its line made only when asked (git runs in a checkout)."""

    def __call__(self, parser, namespace, values, option_string=None):  # noqa: ANN001, ANN204
        print(version_line())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The ``astrocpg`` parser: the top level and every command's subparser."""
    parser = Parser(prog="astrocpg", description=DESCRIPTION, epilog=EXIT_HELP,
                    formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action=_Version, nargs=0,
                        help="print the version and the commit it was built from, and exit")
    sub = parser.add_subparsers(dest="command", required=False, parser_class=Parser,
                                metavar="COMMAND", help="what to do (alone: lists the commands)")
    for add in COMMAND_GRAMMARS:
        add(sub)
    return parser


def add_unit(sub: Subparsers) -> None:
    """``astrocpg unit``: one locomotion unit, open loop."""
    unit = sub.add_parser("unit", help="one locomotion unit, open loop (paper Fig. 1c)",
                          epilog=EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_simulation_options(unit, seconds=30.0)
    unit.add_argument("--out", required=True, metavar="DIR",
                      help="output folder (required; new or empty, --overwrite replaces it)")
    add_overwrite(unit)
    add_record_options(unit)
    add_model_options(unit)
    add_population_option(unit)
    add_workers_option(unit)


def add_run(sub: Subparsers) -> None:
    """``astrocpg run``: the closed loop (and the replay of a training's session)."""
    run = sub.add_parser("run", help="the closed loop: CPG drives the A1 (fixed weights)",
                         epilog=EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_simulation_options(run, seconds=10.0,
                           seed_help="default 1; with --weights DIR, the seed the table trained "
                                     "with, so it runs on its own network")
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
    add_overwrite(run)
    add_record_options(run)
    add_model_options(run)
    add_population_option(run)
    add_workers_option(run)


def add_train(sub: Subparsers) -> None:
    """``astrocpg train``: gait learning, and --resume."""
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
    add_overwrite(train)
    add_workers_option(train, more="; with --resume, a training split over processes keeps "
                                   "its batches")
    train.add_argument("--record-every", type=int, default=None, metavar="N",
                       help="record sessions 1, 1+N, 1+2N... and the last of each trial "
                            "(spikes, traces, robot) into DIR/recordings/ (default: none)")
    train.add_argument("--record-stride", type=int, default=None, metavar="STEPS",
                       help="with --record-every: physics steps (1 ms) between trace and robot "
                            "samples (default 1)")
    train.add_argument("--trace-dtype", default=None, choices=("float32", "float64"),
                       help="with --record-every: what the recorded traces are kept as, float32 "
                            "(default, 7 significant digits; a value beyond 3.4e38 is kept as inf "
                            "and counted) or float64")
    add_record_options(train)
    add_model_options(train)
    add_population_option(train, "; the training keeps its file: --resume rebuilds it (a "
                                 "different file is refused), and its replays (run --weights, "
                                 "gait, evaluate) build it too")


def add_gait(sub: Subparsers) -> None:
    """``astrocpg gait``: the rhythm and gait of trained weights."""
    gait = sub.add_parser("gait", help="run trained weights, name their rhythm and their gait")
    gait.add_argument("dir", help="a training folder (its final tables) or a run folder "
                                  "(astrocpg run --out: the tables its trials ran with)")
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
                           "slope=0.17; repeatable; 'astrocpg describe world' lists them)")
    add_variant_options(gait)
    add_no_progress(gait)
    add_codegen_option(gait)
    add_workers_option(gait, "the runs")


def add_evaluate(sub: Subparsers) -> None:
    """``astrocpg evaluate``: trained controllers in other worlds."""
    ev = sub.add_parser("evaluate", help="trained controllers, learning off, in other worlds "
                                         "(slopes, terrain, friction, pushes, payloads)")
    ev.add_argument("dir", help="a training folder, a run folder (astrocpg run --out: the "
                    "tables its trials ran with), a study folder (its finished runs) or a "
                    "folder of a study's kept tables (docs/ablation/final_tables.py)")
    ev.add_argument("--worlds", default="robustness",
                    help="a worlds file (TOML: [worlds.NAME] tables of world parameters, "
                         "and/or [grid.AXIS] with values = [...] and, for factors, scale = "
                         "[parameters]) or 'robustness' (flat, slopes +-0.09 and +-0.17 rad, "
                         "rough terrain 1 and 2 cm, friction 0.3, a 60 N push, payloads of 3, "
                         "6 and 12 kg; the default)")
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
    ev.add_argument("--point", action="append", default=None, metavar="NAME=VALUE",
                    help="only a study's runs at this sweep point: the swept parameter's value "
                         "as the study file writes it (repeatable, one per swept parameter; "
                         "default every point)")
    ev.add_argument("--baseline", default=None, metavar="WORLD",
                    help="also each world's effect relative to WORLD (e.g. flat): per table "
                         "its figure in the world minus in WORLD, with 95%% intervals over "
                         "tables, and between two conditions the difference of those "
                         "differences, paired by seed (baseline.csv)")
    ev.add_argument("--session", type=int, default=None, metavar="S",
                    help="the tables after session S of each training (every trial must have "
                         "done it; default: the final tables)")
    ev.add_argument("--out", default=None, metavar="OUT",
                    help="output folder (default DIR/evaluation, replaced whole each time)")
    add_overwrite(ev)
    ev.add_argument("--workers", type=int, default=None,
                    help="run the (training, world) cells on a local Dask cluster of N processes "
                         "(default: the cores this process may use; 1: one after the other, "
                         "here)")
    ev.add_argument("--scheduler", metavar="ADDRESS",
                    help="run the cells on a running Dask scheduler, e.g. tcp://127.0.0.1:8786 "
                         "(default: none)")
    add_variant_options(ev)
    add_no_progress(ev)
    add_codegen_option(ev)


def add_plot(sub: Subparsers) -> None:
    """``astrocpg plot``: figures of an output folder."""
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
    add_overwrite(plot)
    add_no_progress(plot)


def add_video(sub: Subparsers) -> None:
    """``astrocpg video``: the robot replayed as MP4."""
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
    add_no_progress(vid)
    add_overwrite(vid)


def add_study(sub: Subparsers) -> None:
    """``astrocpg study``: a parameter study, and --status."""
    study = sub.add_parser("study", help="a parameter study (TOML) on Dask; resumable")
    study.add_argument("file", nargs="?",
                       help="study file, e.g. studies/parameter_studies/quick.toml, or a built-in "
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
                       help="local cluster size (default: the cores this process may use)")
    study.add_argument("--scheduler", metavar="ADDRESS",
                       help="a running Dask scheduler, e.g. tcp://127.0.0.1:8786 (default: "
                            "a local cluster)")
    study.add_argument("--plan-from", metavar="DIR",
                       help="an earlier study of the same conditions (its folder or results "
                            "table): each seed's training length there costs the runs when "
                            "the seeds are split into runs, so that a condition that trains "
                            "longer is split to keep every worker busy to the end (default: "
                            "every session at L_max); recorded in the folder")
    add_no_progress(study)
    add_codegen_option(study)
    add_overwrite(study)


def add_report(sub: Subparsers) -> None:
    """``astrocpg report``: a study's report."""
    report = sub.add_parser("report", help="Fig. 3c curves and final figures of a study")
    report.add_argument("dir", help="a study folder")
    report.add_argument("--smooth", type=int, default=1, metavar="N",
                        help="plot each seed's trailing mean over N sessions (default 1: raw)")
    report.add_argument("--last", type=int, default=50,
                        help="sessions at the end over which final figures are averaged "
                             "(default 50; fewer where a seed trained fewer, and it says so)")
    report.add_argument("--out", metavar="OUT",
                        help="report folder (default DIR/report, replaced each time)")
    add_overwrite(report)


def add_power(sub: Subparsers) -> None:
    """``astrocpg power``: the SNN vs RL power estimate."""
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
    add_no_progress(power)
    add_codegen_option(power)


def add_export(sub: Subparsers) -> None:
    """``astrocpg export``: a folder as NWB or npz."""
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
    add_overwrite(exp)


def add_response(sub: Subparsers) -> None:
    """``astrocpg response``: a model's own response curve (the astrocyte's to its pool)."""
    resp = sub.add_parser("response", help="an astrocyte's adenosine release and mean [ADO] "
                                           "against its pool's spike rate (Poisson input)")
    resp.add_argument("model", metavar="MODEL", choices=("astrocyte",),
                      help="the model whose response is drawn: astrocyte (the built-in one, "
                           "or the file given with --model astrocyte=FILE)")
    resp.add_argument("--rates", default="0:1000:50", metavar="START:STOP:STEP|A,B,...",
                      help="pool spike rates in spikes/s (default 0:1000:50, STOP included)")
    resp.add_argument("--seconds", type=float, default=100.0,
                      help="measured time per astrocyte after the warm-up, in s (default 100)")
    resp.add_argument("--warmup", type=float, default=200.0, metavar="S",
                      help="time run before measuring, in s (default 200: near the onset of "
                           "its Ca2+ oscillations an astrocyte settles over ~100 s)")
    resp.add_argument("--replicates", type=int, default=4,
                      help="astrocytes per rate, each with its own Poisson input (default 4)")
    resp.add_argument("--seed", type=int, default=1, help="seed of the Poisson inputs "
                                                          "(default 1)")
    resp.add_argument("--mark", dest="marks", action="append", default=[],
                      metavar="LABEL=RATE",
                      help="a pool rate drawn beside the curve and read off it (e.g. a trained "
                           "network's thigh-pool rate: --mark 1.0x=566); repeatable")
    resp.add_argument("--out", required=True, metavar="DIR",
                      help="output folder (response.csv, response.png, manifest.json; new or "
                           "empty, --overwrite replaces it)")
    add_overwrite(resp)
    add_model_options(resp)


def add_describe(sub: Subparsers) -> None:
    """``astrocpg describe``: equations and parameter tables."""
    desc = sub.add_parser("describe", help="a model's equations (sympy) and parameter table, "
                                           "or one parameter")
    desc.add_argument("model", nargs="?", help="one model (default: all), a parameter's name "
                      "(e.g. tau_motor: its value, model and the equations using it), or "
                      "'senses': the robot senses a neuron model may bind")
    desc.add_argument("--format", default="text",
                      help="text (for a terminal), markdown or latex (default text)")
    desc.add_argument("--equations", action="append", default=[], metavar="MODEL=FILE",
                      help="describe MODEL with the equation string of FILE")
    desc.add_argument("--set", dest="overrides", action="append", default=[],
                      metavar="NAME=VALUE", help="describe with a parameter overridden")
    add_model_file_option(desc)
    add_population_option(desc, "; its model is described with the others")


def add_models(sub: Subparsers) -> None:
    """``astrocpg models``: models list and models dump."""
    mods = sub.add_parser("models", help="list the models, or dump one as a model file (TOML)")
    mods_sub = mods.add_subparsers(dest="models_command", required=False, parser_class=Parser,
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
    add_model_file_option(dump)


def add_robot(sub: Subparsers) -> None:
    """``astrocpg robot``: robot export."""
    robot = sub.add_parser("robot", help="the project's A1 model")
    robot_sub = robot.add_subparsers(dest="robot_command", required=False, parser_class=Parser,
                                     metavar="COMMAND",
                                     help="export (alone: lists these commands)")
    export = robot_sub.add_parser("export", help="write the A1 model as MJCF")
    export.add_argument("path", metavar="PATH.xml", help="the MJCF file to write")
    add_overwrite(export)


#: each command's grammar, in the order ``astrocpg --help`` lists them
def add_docs(sub: Subparsers) -> None:
    """``astrocpg docs``: where the manual is."""
    docs = sub.add_parser("docs", help="where the manual is (it comes with the package), or "
                                       "open it")
    docs.add_argument("--path", action="store_true",
                      help="print only the folder of the manual's pages and of the files its "
                           "recipes read (docs/examples/interlimb_table.csv, trained tables)")
    docs.add_argument("--open", action="store_true", help="open it in a web browser")


COMMAND_GRAMMARS = (add_unit, add_run, add_train, add_gait, add_evaluate, add_plot, add_video, add_study, add_report, add_power, add_response, add_export, add_describe, add_models, add_robot, add_docs)
