"""The ``astrocpg`` command line: parses arguments and calls the Python API; nothing imports it.

    astrocpg unit  --seconds S --seed K --out DIR [--trials N] [--workers N]
    astrocpg run   --seconds S --seed K [--trials N] [--weights FILE|DIR] [--robot XML] --out DIR
                   [--workers N]
    astrocpg train --sessions N --trials N --seed K [--no-astrocytes] --out DIR | --resume DIR
                   [--workers N]
    astrocpg gait DIR [--seconds S] [--seed K] [--set NAME=VALUE] [--workers N]
    astrocpg power DIR [--trial K] [--sessions N]
    astrocpg evaluate DIR [--worlds FILE|robustness] [--seconds S] [--repeats R] [--out DIR]
    astrocpg plot DIR [--trial K] [--window T0 T1] [--format png|pdf|svg] [--out DIR]
    astrocpg video DIR [--trial K] [--start S] [--stop S] [--fps F] [--speed X] [--size W H]
                       [--panel] [--out FILE]
    astrocpg study FILE [--seeds 1-3] [--sessions N] [--set NAME=VALUE] [--out DIR]
                        [--workers N] [--scheduler ADDRESS] [--plan-from DIR]
    astrocpg report DIR
    astrocpg export DIR [--format nwb|npz] [--experimenter 'LAST, FIRST'] [--institution TEXT]
    astrocpg response astrocyte [--rates 0:1000:50] [--seconds S] [--model astrocyte=FILE]
                      [--out DIR]
    astrocpg describe [MODEL|PARAMETER] [--format text|markdown|latex]
    astrocpg robot export PATH.xml
    astrocpg models list | models dump MODEL [--set NAME=VALUE] [--model MODEL=FILE]
    astrocpg docs [--path] [--open]

Common options: ``--set NAME=VALUE`` overrides a model parameter (with units),
``--model MODEL=FILE`` replaces a whole model by a model file (TOML: its equations, new
parameters and state variables; ``astrocpg models dump MODEL`` writes one),
``--equations MODEL=FILE`` (a shorthand) replaces a model's equation string by the text of FILE.
Every failure ends with one line on stderr naming the culprit and an exit code (see EXIT_HELP).

Modules: :mod:`.options` (the parser class and the options several commands share),
:mod:`.grammar` (each command's subparser), :mod:`.handlers` (each command: its arguments as
the API's settings, the API function, what it prints), :mod:`.process` (signals, exit codes,
streams, the one line of a failure) and :mod:`.words` (a failure's settings named as the
command's options).
"""

from __future__ import annotations

from .grammar import build_parser
from .handlers import COMMANDS
from .options import DEFAULT_RUN_OUT, DESCRIPTION, EXIT_HELP
from .process import entry, main

__all__ = ["main", "entry", "build_parser", "COMMANDS", "DEFAULT_RUN_OUT", "DESCRIPTION",
           "EXIT_HELP"]
