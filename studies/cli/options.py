"""The command line's shared grammar: the parser class (one-line errors, the closest name for
a misspelt command or option), the top-level texts and the option helpers several commands
share (what to record, model changes, progress, code generation, simulated time)."""

from __future__ import annotations

import argparse
import sys
from typing import Any, NoReturn, Sequence

from ...errors import did_you_mean, one_line

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


class Parser(argparse.ArgumentParser):
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
            options = [o for a in chosen_parsers(self, ns)[-1]._actions for o in a.option_strings]
            said = [x + (did_you_mean(x.split("=", 1)[0], options) if x.startswith("-") else "")
                    for x in extras]
            self.error(f"unrecognized arguments: {' '.join(said)}")
        return ns


def chosen_parsers(parser: argparse.ArgumentParser,
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


def command_list(parser: argparse.ArgumentParser, ns: argparse.Namespace) -> str | None:
    """What a command group typed alone (``astrocpg``, ``astrocpg models``...) prints: its
    commands, one line each; None when the command typed is complete."""
    last = chosen_parsers(parser, ns)[-1]
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


def csv_list(text: str) -> tuple[str, ...]:
    return () if text.strip() in ("", "none") else tuple(x.strip() for x in text.split(","))


def add_record_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--spikes", type=csv_list, default=None, metavar="POPS",
                   help="populations whose spikes are recorded, comma-separated, or none "
                        "(default: motor,interneuron,astrocyte)")
    p.add_argument("--traces", type=csv_list, default=None, metavar="NAMES",
                   help="traces recorded, comma-separated, or none (default: motor_Ca,"
                        "astrocyte_Ca,astrocyte_IP3,astrocyte_AG,astrocyte_ADO)")


def add_model_file_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", dest="model_files", action="append", default=[],
                   metavar="MODEL=FILE",
                   help="replace MODEL (e.g. astrocyte) by a model file (TOML, as `astrocpg models "
                        "dump MODEL` writes it); it may declare new parameters and variables")


def add_population_option(p: argparse.ArgumentParser, more: str = "") -> None:
    p.add_argument("--population", dest="population_files", action="append", default=[],
                   metavar="FILE",
                   help="add a population: a neuron model file (TOML) with a [population] table "
                        "saying its cells, traces, inputs and outputs (docs/model-files.md)" + more)


def _add_set_equations(p: argparse.ArgumentParser, over: str = "") -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                   help="override a model parameter, with units (e.g. --set tau_motor=9*ms)"
                        + over)
    p.add_argument("--equations", action="append", default=[], metavar="MODEL=FILE",
                   help="replace the equation string of MODEL (e.g. motor_neuron) by FILE's text")


def add_model_options(p: argparse.ArgumentParser) -> None:
    _add_set_equations(p)
    add_model_file_option(p)
    add_codegen_option(p)
    add_no_progress(p)


def add_variant_options(p: argparse.ArgumentParser) -> None:
    """A model variant over a trained controller's own models (``gait``, ``evaluate``): the
    options ``run`` and ``train`` take (--set, --equations, --model, --population)."""
    _add_set_equations(p, "; over the controller's own values")
    add_model_file_option(p)
    add_population_option(p, "; added to the controller's network")


def add_no_progress(p: argparse.ArgumentParser) -> None:
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bar on stderr (default: a bar while it works)")


def add_codegen_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--codegen", default=None, metavar="TARGET",
                   help="Brian2 code generation: numpy (default) or cython (2x faster per trial "
                        "for 1-4 trials, 1.5x at 20; the first build compiles for minutes and is "
                        "cached). Default: $ASTROCPG_CODEGEN, else numpy")


def add_simulation_options(p: argparse.ArgumentParser, seconds: float,
                           seed_help: str = "default 1") -> None:
    p.add_argument("--seconds", type=float, default=seconds,
                   help=f"simulated time in s, a whole number of 1 ms steps (default "
                        f"{seconds:g} s)")
    p.add_argument("--seed", type=int, default=None, help=f"seed of trial 0 ({seed_help})")
    p.add_argument("--trials", type=int, default=1,
                   help="independent trials, seeds K, K+1, ... (default 1)")
    p.add_argument("--trace-dt", type=float, default=1.0, metavar="MS",
                   help="sampling interval of the Ca2+/IP3/2-AG/adenosine traces in ms, a "
                        "whole number of 1 ms steps (default 1 ms)")
    p.add_argument("--trace-dtype", default="float32", choices=("float32", "float64"),
                   help="what the traces are kept as: float32 (default, 7 significant digits, "
                        "half the memory) or float64 (Brian2's full resolution)")


def add_overwrite(p: argparse.ArgumentParser) -> None:
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing output whole (never merged with the new one)")



def add_workers_option(p: argparse.ArgumentParser, what: str = "the trials",
                       more: str = "") -> None:
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help=f"processes to split {what} over, N >= 1 (default: the cores this "
                        f"process may use); the results are the same for any N{more}")
