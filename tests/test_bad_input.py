"""Bad input and faults, as a new user meets them: every command, every option.

One table, :data:`CASES`: each case builds its argv from small factories (paths under the test's
``tmp_path``, copies of shared fixture folders), and says what must happen:

* the exit code (0 done, 1 environment, 2 bad input, 3 diverged, 130 interrupted);
* a substring of the one line on stderr (the culprit: the option or the path the user typed);
* the state of the folder the command would write or reads: ``absent`` (nothing there, no hidden
  temporaries beside it), ``unchanged`` (byte-identical: relative path -> sha256 of every file,
  hidden ones included), ``complete`` (``verify(folder)`` passes: every file listed in the
  manifest's inventory, none missing, none extra) or ``diverged`` (written whole, its manifest
  says ``diverged``).

Every failing case must print exactly one non-empty line on stderr, starting with
``astrocpg:``, and no traceback anywhere. Cases run in-process (``main(argv)``, Brian2 imported
once); those that need a fresh process (rlimits, mount namespaces, the temp folder of a
process) run ``python -m astrocpg.studies.cli`` in a subprocess.

The expensive folders (a finished run, one recorded without spikes, a unit, a short training,
a tiny study) are made once per module.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

from astrocpg.studies.cli import main
from astrocpg.studies.outputs.folder import parse_temp_name, verify
from tiny_study import tiny_study

SHORT = ["--set", "L_max=0.2*second", "--set", "L_non_alive=0.1*second"]
ROOT = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------- fixtures (module scope)
def _ok(argv: list[str]) -> None:
    code = main(argv)
    assert code == 0, (argv, code)


@pytest.fixture(scope="module")
def fx(tmp_path_factory) -> dict[str, Path]:
    """Finished folders the cases read (never written: a case that could change one works on
    a copy)."""
    base = tmp_path_factory.mktemp("fixtures")
    out = {"run": base / "run", "run_nospikes": base / "run_nospikes", "unit": base / "unit",
           "train": base / "train", "study": base / "study"}
    _ok(["run", "--seconds", "0.05", "--out", str(out["run"]), "--no-progress"])
    _ok(["run", "--seconds", "0.05", "--spikes", "none", "--traces", "none",
         "--out", str(out["run_nospikes"]), "--no-progress"])
    _ok(["unit", "--seconds", "0.3", "--out", str(out["unit"]), "--no-progress"])
    out["unit_nothing"] = base / "unit_nothing"
    _ok(["unit", "--seconds", "0.01", "--spikes", "none", "--traces", "none", "--out",
         str(out["unit_nothing"]), "--no-progress"])
    _ok(["train", "--sessions", "2", "--seed", "3", *SHORT, "--out", str(out["train"]),
         "--no-progress"])
    study = base / "tiny.toml"
    study.write_text(TINY_STUDY)
    _ok(["study", str(study), "--out", str(out["study"]), "--workers", "1", "--no-progress"])
    return out


TINY_STUDY = tiny_study("tiny", sessions=2)


# ---------------------------------------------------------------- the environment of a case
class Env:
    """Paths for one case: ``tmp`` (the case's own folder), copies of fixture folders, files.
    Each factory makes its path once; calling it again returns the same path."""

    def __init__(self, tmp: Path, fx: dict[str, Path]) -> None:
        self.tmp, self.fx = tmp, fx
        self._made: dict[str, Path] = {}

    def _once(self, key: str, make: Callable[[], Path]) -> Path:
        if key not in self._made:
            self._made[key] = make()
        return self._made[key]

    def new(self, name: str = "out") -> Path:
        """A path that does not exist yet."""
        return self.tmp / name

    def nonempty(self, name: str = "full") -> Path:
        def make() -> Path:
            d = self.tmp / name
            d.mkdir()
            (d / "mine.txt").write_text("the user's own file\n")
            return d
        return self._once("nonempty:" + name, make)

    def empty(self, name: str = "empty") -> Path:
        def make() -> Path:
            d = self.tmp / name
            d.mkdir()
            return d
        return self._once("empty:" + name, make)

    def file(self, name: str, data: bytes | str = b"") -> Path:
        def make() -> Path:
            p = self.tmp / name
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data.encode() if isinstance(data, str) else data)
            return p
        return self._once("file:" + name, make)

    def copy(self, which: str, name: str | None = None) -> Path:
        def make() -> Path:
            dst = self.tmp / (name or which)
            shutil.copytree(self.fx[which], dst, symlinks=True)
            return dst
        return self._once(f"copy:{which}:{name}", make)

    def tampered(self, which: str, file: str, how: str = "flip") -> Path:
        """A copy whose ``file`` no longer matches the manifest (``flip``: one byte changed;
        ``truncate``: cut in half; ``extra``: a stray file added; ``missing``: deleted)."""
        def make() -> Path:
            d = self.copy(which, f"{which}_{how}")
            p = d / file
            if how == "flip":
                raw = bytearray(p.read_bytes())
                raw[len(raw) // 2] ^= 0xFF
                p.write_bytes(bytes(raw))
            elif how == "truncate":
                p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
            elif how == "extra":
                p.write_text("not listed")
            elif how == "missing":
                p.unlink()
            return d
        return self._once(f"tampered:{which}:{file}:{how}", make)

    def geared_robot(self) -> Path:
        """The project's A1 with a huge motor gear: MuJoCo's bad qacc at the first step."""
        def make() -> Path:
            from astrocpg.coupling.robot import export_xml
            p = self.tmp / "a1_geared.xml"
            export_xml(p)
            text = p.read_text()
            p.write_text(text.replace('ctrllimited="true"/>', 'ctrllimited="true" gear="1e12"/>'))
            return p
        return self._once("geared", make)

    def resaved_weights(self) -> Path:
        """A training copy whose weights.npz was saved again with other (valid) tables."""
        def make() -> Path:
            d = self.copy("train", "train_resaved")
            with np.load(d / "weights.npz") as z:
                arrays = {k: z[k] for k in z.files}
            arrays["final_weights_mV"][..., 0, 2] += 0.5  # FR flexor -> FL flexor: allowed
            np.savez_compressed(d / "weights.npz", **arrays)
            return d
        return self._once("resaved", make)

    def derived(self, which: str) -> Path:
        """A copy with what later commands write into it: plot's figures/, a video's mp4."""
        def make() -> Path:
            d = self.copy(which, f"{which}_derived")
            assert main(["plot", str(d)]) == 0
            (d / "video_trial00.mp4").write_bytes(b"\0" * 100)
            return d
        return self._once(f"derived:{which}", make)

    def corrupt_listed(self, which: str, file: str, manifest: str = "manifest.json") -> Path:
        """A copy whose ``file`` is truncated (binary: garbage) and whose ``manifest`` lists it
        as it now is: the folder verifies, but the file cannot be read."""
        def make() -> Path:
            d = self.copy(which, f"{which}_corrupt")
            p = d / file
            if p.suffix in (".npz", ".pkl"):
                p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
            else:
                p.write_bytes(bytes(range(256)) * 4)
            mpath = d / manifest
            key = p.relative_to(mpath.parent).as_posix()
            m = json.loads(mpath.read_text())
            m["inventory"][key] = {"bytes": p.stat().st_size,
                                   "sha256": hashlib.sha256(p.read_bytes()).hexdigest(),
                                   "mtime_ns": p.stat().st_mtime_ns}
            mpath.write_text(json.dumps(m))
            return d
        return self._once(f"corrupt:{which}:{file}", make)

    def equations(self, model: str, edit: Callable[[str], str] | None = None,
                  name: str = "eqs.txt") -> Path:
        from importlib import import_module
        text = import_module(f"astrocpg.models.{model}").EQUATIONS
        return self.file(name, edit(text) if edit else text)

    def study(self, text: str | bytes, name: str = "s.toml") -> Path:
        return self.file(name, text)

    def weights(self, table: Any, name: str = "w.csv") -> Path:
        rows = np.asarray(table, dtype=float)
        return self.file(name, "\n".join(",".join(repr(float(x)) for x in r) for r in rows))


# ---------------------------------------------------------------- the table
@dataclass
class Case:
    id: str
    argv: Callable[[Env], list[str]]
    code: int
    culprit: str | Callable[[Env], str] | None
    state: str  # "absent" | "unchanged" | "complete" | "diverged" | "none"
    target: Callable[[Env], Path] | None = None
    check: Callable[[Env], None] | None = None  # more assertions after the command
    marks: tuple = ()
    subprocess: dict[str, Any] | None = None  # run in a child: {"env": {...}, "rlimit_fsize": n}

    def param(self):
        return pytest.param(self, id=self.id, marks=self.marks)


def out(e: Env) -> Path:
    return e.new("out")


CHEAP = {"unit": ["--seconds", "0.01", "--no-progress"],
         "run": ["--seconds", "0.01", "--no-progress"],
         "train": ["--sessions", "1", *SHORT, "--no-progress"],
         "gait": ["--seconds", "0.05", "--repeats", "1", "--no-progress"],
         "plot": ["--seconds", "0.05", "--no-progress"],
         "video": ["--no-progress", "--size", "64", "48", "--fps", "10"],
         "power": ["--sessions", "1", "--no-progress"]}


def S(*args: Any) -> list[str]:
    """argv of a command; a command that simulates gets cheap settings first (the case's own
    options come later and win), so that a wrongly accepted case finishes quickly."""
    argv = [str(a) for a in args]
    if argv and argv[0] in CHEAP and "--resume" not in argv:
        # after the positional folder of gait/plot/power
        at = 2 if argv[0] in ("gait", "plot", "power", "video") and len(argv) > 1 else 1
        cheap = CHEAP[argv[0]]
        if argv[0] == "plot" and not (len(argv) > 1 and _is_training(argv[1])):
            cheap = ["--no-progress"]  # --seconds simulates a training's weights only
        argv[at:at] = cheap
    return argv


def _is_training(folder: str) -> bool:
    try:
        command = json.loads((Path(folder) / "manifest.json").read_text())["astrocpg_command"]
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return command in ("train", "study-run")


def study_text(**head: Any) -> str:
    """A tiny study file with ``head`` keys replaced (values written as TOML)."""
    lines = ["[study]", 'name = "t"', "sessions = 1", "seeds = { first = 1, count = 1 }"]
    for k, v in head.items():
        lines = [x for x in lines if not x.startswith(f"{k} ")]
        lines.append(f"{k} = {v}")
    return "\n".join(lines) + '\n[base]\nL_max = "0.2*second"\n'


GRID = ("[sweep.axes]\nL_max = [" + ", ".join(f'"{0.1 + k * 1e-4:.5f}*second"' for k in range(1000))
        + "]\ntau_STDP = [" + ", ".join(f'"{5 + k * 1e-3:.4f}*ms"' for k in range(1000)) + "]\n")
EVIL_FLAG = Path(tempfile.gettempdir()) / "astrocpg_evaluated_a_value"
EVIL = f"__import__('os').system('touch {EVIL_FLAG}')"
# the classic escape from eval with empty builtins
EVIL_ESCAPE = ("[c for c in ().__class__.__base__.__subclasses__() if c.__name__ == "
               "'catch_warnings'][0]()._module.__builtins__['__import__']('os')"
               f".system('touch {EVIL_FLAG}')")


NUL_TEXT = "dv/dt = 0 : volt\0"
LATIN1_TEXT = "dv/dt = -v/(9*ms) : volt # caf\xe9".encode("latin-1")


def not_evaluated(e: Env) -> None:
    assert not EVIL_FLAG.exists(), "a value was evaluated as Python"


def _drop_line(text: str, start: str) -> str:
    lines = text.splitlines(keepends=True)
    kept = [x for x in lines if not x.strip().startswith(start)]
    assert len(kept) < len(lines), start
    return "".join(kept)


def said_when(e: Env) -> None:
    """The diverged folder's manifest names the time."""
    error = json.loads((out(e) / "manifest.json").read_text())["results"].get("error", "")
    assert "t = " in json.dumps(error), error


def diverged_row(folder: Path) -> None:
    """A diverged training marks the session (a diverged column) and stops."""
    import csv
    with open(folder / "sessions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and "diverged" in rows[0], rows[:1]
    assert rows[-1]["diverged"] in ("1", "True", "true"), rows[-1]


def export_written(suffix: str) -> Callable[[Env], None]:
    def check(e: Env) -> None:
        written = [p for p in e.tmp.iterdir() if p.name.endswith(suffix)]
        assert written, f"no {suffix} written"
    return check


def no_temporaries_beside(path_of: Callable[[Env], Path]) -> Callable[[Env], None]:
    def check(e: Env) -> None:
        parent = path_of(e).parent
        left = [n for n in os.listdir(parent) if parse_temp_name(n)]
        assert not left, left
    return check


UNIT, RUN = "unit", "run"
CASES: list[Case] = []


def case(*args: Any, **kw: Any) -> None:
    CASES.append(Case(*args, **kw))


# ---- the command line itself
case("no-command", lambda e: [], 0, None, "none")  # lists the commands
case("unknown-command", lambda e: ["fly"], 2, "fly", "none")
case("seconds-not-a-number", lambda e: S("run", "--seconds", "abc", "--out", out(e)), 2,
     "--seconds", "absent", out)
case("seed-not-an-integer", lambda e: S("unit", "--seed", "1.5", "--out", out(e)), 2,
     "--seed", "absent", out)

# ---- unit: durations, counts, sampling, sizes
for cmd in (UNIT, RUN):
    for value, words in (("0", "--seconds"), ("-3", "--seconds"), ("nan", "--seconds"),
                         ("inf", "--seconds"), ("-inf", "--seconds"), ("1e-5", "--seconds"),
                         ("1e309", "--seconds")):
        case(f"{cmd}-seconds-{value}", lambda e, c=cmd, v=value: S(c, "--seconds", v, "--out",
                                                                    out(e)),
             2, words, "absent", out)
    case(f"{cmd}-seconds-1e7", lambda e, c=cmd: S(c, "--seconds", "1e7", "--out", out(e)), 2,
         "memory", "absent", out)
    case(f"{cmd}-trials-100000", lambda e, c=cmd: S(c, "--seconds", "1", "--trials", "100000",
                                                    "--out", out(e)), 2, "memory", "absent", out)
    case(f"{cmd}-trials-0", lambda e, c=cmd: S(c, "--trials", "0", "--out", out(e)), 2,
         "--trials", "absent", out)
    case(f"{cmd}-seed-negative", lambda e, c=cmd: S(c, "--seed", "-1", "--out", out(e)), 2,
         "--seed", "absent", out)
    for value in ("nan", "inf", "0", "-1"):
        case(f"{cmd}-trace-dt-{value}", lambda e, c=cmd, v=value: S(c, "--trace-dt", v,
                                                                    "--out", out(e)),
             2, "--trace-dt", "absent", out)
    case(f"{cmd}-spikes-unknown", lambda e, c=cmd: S(c, "--spikes", "motor,glia", "--out",
                                                     out(e)), 2, "glia", "absent", out)
    case(f"{cmd}-traces-unknown", lambda e, c=cmd: S(c, "--traces", "motor_K", "--out", out(e)),
         2, "motor_K", "absent", out)
    case(f"{cmd}-out-not-empty", lambda e, c=cmd: S(c, "--seconds", "0.01", "--out",
                                                    e.nonempty()), 2,
         lambda e: str(e.nonempty()), "unchanged", lambda e: e.nonempty())
    case(f"{cmd}-out-is-a-file", lambda e, c=cmd: S(c, "--seconds", "0.01", "--out",
                                                    e.file("f.txt", "x")), 2,
         "f.txt", "unchanged", lambda e: e.file("f.txt", "x"))
    case(f"{cmd}-out-parent-is-a-file",
         lambda e, c=cmd: S(c, "--seconds", "0.01", "--out", e.file("f.txt", "x") / "o"),
         1, "f.txt", "unchanged", lambda e: e.file("f.txt", "x"))
    case(f"{cmd}-out-uncreatable", lambda e, c=cmd: S(c, "--seconds", "0.01", "--no-progress",
                                                      "--out", "/sys/astrocpg_out"),
         1, "/sys/astrocpg_out", "absent", lambda e: Path("/sys/astrocpg_out"))

# ---- --set: values are parsed, never evaluated; nan/inf refused; units suggested
for cmd in (UNIT, RUN, "train", "describe"):
    outs = [] if cmd == "describe" else ["--out"]

    def argv(e: Env, *sets: str, c: str = cmd, o: list = outs) -> list[str]:
        return S(c, *(x for s in sets for x in ("--set", s)), *(o and [o[0], out(e)]))

    case(f"{cmd}-set-evaluated", lambda e, a=argv: a(e, f"tau_motor={EVIL}"), 2, "tau_motor",
         "absent" if outs else "none", out, check=not_evaluated)
    case(f"{cmd}-set-1e309", lambda e, a=argv: a(e, "tau_motor=1e309*ms"), 2, "tau_motor",
         "absent" if outs else "none", out)
    case(f"{cmd}-set-nan", lambda e, a=argv: a(e, "tau_motor=nan*ms"), 2, "tau_motor",
         "absent" if outs else "none", out)
# finite, but its arithmetic overflows at the first step (1/(w_max - w_min)**2): refused
# naming the parameter, nothing left (was "internal error", and a training left 'running')
for cmd in ("run", "train"):
    case(f"{cmd}-set-overflows-at-the-first-step",
         lambda e, c=cmd: S(c, "--set", "w_max=1e200*mV", "--out", out(e)), 2,
         "w_max=1e+197*V: makes interlimb_synapse's", "absent", out)
case("study-set-overflows-at-the-first-step",
     lambda e: S("study", e.study(TINY_STUDY), "--set", "w_max=1e200*mV", "--out", out(e),
                 "--workers", "1", "--no-progress"), 2, "w_max=1e+197*V", "none", out)
case("unit-set-escape-from-eval", lambda e: S("unit", "--set", f"tau_motor={EVIL_ESCAPE}",
                                              "--out", out(e)),
     2, "tau_motor", "absent", out, check=not_evaluated)
case("unit-set-unknown-name", lambda e: S("unit", "--set", "tau_motr=9*ms", "--out", out(e)), 2,
     "tau_motr", "absent", out)
case("unit-set-wrong-unit", lambda e: S("unit", "--set", "tau_motor=9*mV", "--out", out(e)), 2,
     "tau_motor", "absent", out)
case("unit-set-no-equals", lambda e: S("unit", "--set", "tau_motor", "--out", out(e)), 2,
     "tau_motor", "absent", out)
for cmd in (UNIT, "train", "gait"):
    case(f"{cmd}-seed-2to32", lambda e, c=cmd: S(c, *([e.copy("train")] if c == "gait" else []),
                                                 "--seed", str(2**32),
                                                 *(["--out", out(e)] if c != "gait" else [])),
         2, "--seed", "absent" if cmd != "gait" else "none", out)
case("gait-repeats-0", lambda e: S("gait", e.copy("train"), "--repeats", "0"), 2, "--repeats",
     "none", out)
case("gait-world-not-a-world-parameter",
     lambda e: S("gait", e.copy("train"), "--world", "tau_motor=9*ms"), 2,
     "--world tau_motor=9*ms", "none", out)
case("gait-world-wrong-unit", lambda e: S("gait", e.copy("train"), "--world", "slope=2*meter"),
     2, "slope", "none", out)
case("run-seeds-of-the-trials-beyond-2to32", lambda e: S("run", "--seed", str(2**32 - 1),
                                                         "--trials", "2", "--out", out(e)),
     2, "--seed", "absent", out)
case("study-seed-2to32", lambda e: S("study", e.study(study_text(seeds=f"[{2**32}]")), "--out",
                                     out(e)), 2, "seeds", "absent", out)
case("unit-trace-dt-tiny", lambda e: S("unit", "--seconds", "10", "--trace-dt", "1e-6", "--out",
                                       out(e)), 2, "--trace-dt", "absent", out)
case("run-robot-a-folder", lambda e: S("run", "--robot", e.empty("a1.xml"), "--out", out(e)), 2,
     "a1.xml", "absent", out)
case("unit-set-empty-name", lambda e: S("unit", "--set", "=9*ms", "--out", out(e)), 2, "--set",
     "absent", out)
case("unit-set-empty-value", lambda e: S("unit", "--set", "tau_motor=", "--out", out(e)), 2,
     "tau_motor", "absent", out)
case("unit-spikes-empty-name", lambda e: S("unit", "--spikes", ",", "--out", out(e)), 2,
     "--spikes", "absent", out)
case("unit-out-root", lambda e: S("unit", "--out", "/"), 2, "--out /", "none")
case("run-weights-trial-negative", lambda e: S("run", "--weights", e.fx["train"], "--trial",
                                               "-1", "--out", out(e)),
     2, "--trial", "absent", out)
case("study-scheduler-refused", lambda e: S("study", e.study(study_text()), "--scheduler",
                                            "tcp://127.0.0.1:1", "--out", out(e)),
     2, "--scheduler", "absent", out)
case("export-non-utf8-folder-name", lambda e: S("export", e.tmp / "no\udcffdir"), 1, "no",
     "absent", lambda e: e.tmp / "no\udcffdir", subprocess={})
case("unit-out-non-utf8-name", lambda e: S("unit", "--out", e.tmp / "u\udcffx"), 0, None,
     "complete", lambda e: e.tmp / "u\udcffx", subprocess={}, marks=(pytest.mark.slow,))
case("unit-set-inf-dimensionless", lambda e: S("unit", "--set", "A_random=inf", "--out",
                                               out(e)), 2, "A_random", "absent", out)
case("run-set-negative-time-constant", lambda e: S("run", "--set", "tau_Ca=-5*ms", "--out",
                                                   out(e)), 2, "tau_Ca", "absent", out)

# ---- --equations: unreadable, binary, not UTF-8, unknown model, a variable missing
for cmd in (UNIT, RUN):
    case(f"{cmd}-equations-missing-file",
         lambda e, c=cmd: S(c, "--equations", f"motor_neuron={e.tmp / 'none.txt'}", "--out",
                            out(e)), 1, "none.txt", "absent", out)
case("unit-equations-binary", lambda e: S("unit", "--equations",
                                          f"motor_neuron={e.file('eq.bin', bytes(range(256)))}",
                                          "--out", out(e)), 2, "eq.bin", "absent", out)
case("unit-equations-nul", lambda e: S("unit", "--equations",
                                       f"motor_neuron={e.file('eq.txt', NUL_TEXT)}",
                                       "--out", out(e)), 2, "eq.txt", "absent", out)
case("unit-equations-latin1", lambda e: S("unit", "--equations",
                                          f"motor_neuron={e.file('eq.txt', LATIN1_TEXT)}",
                                          "--out", out(e)), 2, "eq.txt", "absent", out)
case("unit-equations-unknown-model", lambda e: S("unit", "--equations",
                                                 f"glia={e.equations('motor_neuron')}", "--out",
                                                 out(e)), 2, "glia", "absent", out)
case("unit-equations-no-equals", lambda e: S("unit", "--equations", "motor_neuron", "--out",
                                             out(e)), 2, "--equations", "absent", out)
case("unit-equations-folder", lambda e: S("unit", "--equations", f"motor_neuron={e.tmp}",
                                          "--out", out(e)), 2, "motor_neuron", "absent", out)
# the network sets x_position (anatomy): a file without it names that variable
case("unit-equations-lacks-a-set-variable",
     lambda e: S("unit", "--seconds", "0.01", "--equations",
                 f"motor_neuron={e.equations('motor_neuron', lambda t: _drop_line(t, 'x_position'))}",
                 "--out", out(e)), 2, "x_position", "absent", out)
# the network links torso_speed from the pool model: a file without it names it
case("run-equations-pool-lacks-a-variable-the-robot-sets",
     lambda e: S("run", "--seconds", "0.01", "--equations",
                 f"pool={e.equations('pool', lambda t: _drop_line(t, 'limit_inhibition :'))}",
                 "--equations",
                 f"motor_neuron={e.equations('motor_neuron', lambda t: _drop_line(t, 'limit_inhibition :').replace('C_limit_position*limit_inhibition', '0*volt/second'), name='m.txt')}",
                 "--out", out(e)), 2, "limit_inhibition", "absent", out)
case("train-equations-pool-lacks-a-variable-the-sessions-set",
     lambda e: S("train", "--equations",
                 f"pool={e.equations('pool', lambda t: _drop_line(t, 'reward_mean :'))}",
                 "--out", out(e)), 2, "reward_mean", "absent", out)
case("unit-equations-astrocyte-lacks-variable",
     lambda e: S("unit", "--seconds", "0.01", "--equations",
                 f"astrocyte={e.equations('astrocyte', lambda t: _drop_line(t, 'n_pool'))}",
                 "--out", out(e)), 2, "n_pool", "absent", out)

# ---- run: weights and robot files
case("run-weights-missing", lambda e: S("run", "--weights", e.tmp / "w.csv", "--out", out(e)),
     1, "w.csv", "absent", out)
case("run-weights-wrong-shape", lambda e: S("run", "--weights", e.weights([[1, 2], [3, 4]]),
                                            "--out", out(e)), 2, "w.csv", "absent", out)
case("run-weights-nan", lambda e: S("run", "--weights",
                                    e.weights(np.full((8, 8), np.nan)), "--out", out(e)),
     2, "w.csv", "absent", out)
case("run-weights-binary", lambda e: S("run", "--weights", e.file("w.npy", b"\x93NUMPY\x01\x00garbage"),
                                       "--out", out(e)), 2, "w.npy", "absent", out)
case("run-weights-truncated-npz",
     lambda e: S("run", "--weights", e.tampered("train", "weights.npz", "truncate"), "--out",
                 out(e)), 2, "train_truncate", "absent", out)
case("run-weights-folder-modified", lambda e: S("run", "--weights", e.resaved_weights(), "--out",
                                                 out(e)), 2, "weights.npz", "absent", out)
case("run-weights-folder-without-weights", lambda e: S("run", "--weights", e.copy("unit"),
                                                       "--out", out(e)),
     2, "unit", "absent", out)
case("run-weights-trial-out-of-range", lambda e: S("run", "--weights", e.fx["train"],
                                                   "--trial", "5", "--out", out(e)),
     2, "--trial", "absent", out)
case("run-weights-tables-vs-trials", lambda e: S("run", "--weights", e.fx["train"], "--trials",
                                                 "2", "--seconds", "0.01", "--out", out(e)),
     2, "--weights", "absent", out)
# an option that only acts with another is refused without it, never ignored
case("run-trial-without-weights", lambda e: S("run", "--trial", "0", "--out", out(e)), 2,
     "--trial 0", "absent", out)
case("run-trial-with-a-weights-file", lambda e: S("run", "--weights", e.weights(np.zeros((8, 8))),
                                                  "--trial", "0", "--out", out(e)), 2,
     "--trial 0", "absent", out)
case("run-session-without-weights", lambda e: S("run", "--session", "1", "--out", out(e)), 2,
     "--session", "absent", out)
case("plot-seconds-of-a-run-folder", lambda e: S("plot", e.copy("run"), "--seconds", "2",
                                                 "--out", out(e)), 2, "--seconds", "absent", out)
case("run-robot-missing", lambda e: S("run", "--robot", e.tmp / "a1.xml", "--out", out(e)), 1,
     "a1.xml", "absent", out)
case("run-robot-binary", lambda e: S("run", "--robot", e.file("a1.xml", bytes(range(256)) * 4),
                                     "--out", out(e)), 2, "a1.xml", "absent", out)
case("run-robot-truncated", lambda e: S("run", "--robot", e.file("a1.xml", "<mujoco><worldbody>"),
                                        "--out", out(e)), 2, "a1.xml", "absent", out)
case("run-robot-stride-0", lambda e: S("run", "--robot-stride", "0", "--out", out(e)), 2,
     "--robot-stride", "absent", out)

# ---- train
case("train-without-out", lambda e: ["train", "--sessions", "1"], 2, "--out", "none")
case("train-sessions-0", lambda e: S("train", "--sessions", "0", "--out", out(e)), 2,
     "--sessions", "absent", out)
case("train-trials-100000", lambda e: S("train", "--trials", "100000", "--out", out(e)), 2,
     "memory", "absent", out)
case("train-seed-negative", lambda e: S("train", "--seed", "-2", "--out", out(e)), 2, "--seed",
     "absent", out)
case("train-record-every-0", lambda e: S("train", "--record-every", "0", "--out", out(e)), 2,
     "--record-every", "absent", out)
case("train-record-stride-0", lambda e: S("train", "--record-every", "2", "--record-stride",
                                          "0", "--out", out(e)), 2, "--record-stride",
     "absent", out)
case("train-spikes-without-record", lambda e: S("train", "--spikes", "motor", "--out", out(e)),
     2, "--spikes", "absent", out)
case("train-set-L_max-inf", lambda e: S("train", "--set", "L_max=inf*second", "--out", out(e)),
     2, "L_max", "absent", out)
case("train-out-holds-a-training", lambda e: S("train", "--sessions", "2", "--out",
                                               e.copy("train")), 2, "--resume",
     "unchanged", lambda e: e.copy("train"))
case("train-out-not-empty", lambda e: S("train", "--sessions", "2", "--out", e.nonempty()), 2,
     lambda e: str(e.nonempty()), "unchanged", lambda e: e.nonempty())
case("train-resume-missing", lambda e: S("train", "--resume", e.tmp / "none"), 1, "none",
     "absent", lambda e: e.tmp / "none")
case("train-resume-finished", lambda e: S("train", "--resume", e.copy("train")), 2,
     "already finished", "unchanged", lambda e: e.copy("train"))
case("train-resume-with-other-out", lambda e: S("train", "--resume", e.copy("train"), "--out",
                                                out(e)), 2, "--out", "unchanged",
     lambda e: e.copy("train"))
case("train-resume-other-seed", lambda e: S("train", "--resume", e.copy("train"), "--seed", "9"),
     2, "seed", "unchanged", lambda e: e.copy("train"))
case("train-resume-unit-folder", lambda e: S("train", "--resume", e.copy("unit")), 2, "unit",
     "unchanged", lambda e: e.copy("unit"))
case("train-resume-corrupt-checkpoint",
     lambda e: S("train", "--resume", e.tampered("train", "checkpoint.npz", "flip")), 2,
     "checkpoint", "unchanged", lambda e: e.tampered("train", "checkpoint.npz", "flip"))
case("train-resume-truncated-checkpoint",
     lambda e: S("train", "--resume", e.tampered("train", "checkpoint.npz", "truncate")), 2,
     "checkpoint", "unchanged", lambda e: e.tampered("train", "checkpoint.npz", "truncate"))
case("train-resume-empty-folder", lambda e: S("train", "--resume", e.empty()), 2,
     lambda e: str(e.empty()), "unchanged", lambda e: e.empty())

# ---- gait, plot, power, video: a training folder (plot and video: any output folder)
for cmd in ("gait", "plot", "power", "video"):
    case(f"{cmd}-missing-folder", lambda e, c=cmd: S(c, e.tmp / "nosuch"), 1, "nosuch",
         "absent", lambda e: e.tmp / "nosuch")
for cmd in ("gait", "power"):
    case(f"{cmd}-folder-without-weights", lambda e, c=cmd: S(c, e.copy("unit")), 2,
         lambda e: str(e.copy("unit")), "unchanged", lambda e: e.copy("unit"))
for cmd in ("gait", "plot", "power"):
    case(f"{cmd}-a-file", lambda e, c=cmd: S(c, e.file("w.csv", "1")), 2, "w.csv", "unchanged",
         lambda e: e.file("w.csv", "1"))
    case(f"{cmd}-tampered-weights", lambda e, c=cmd: S(c, e.tampered("train", "weights.npz")), 2,
         "weights.npz", "unchanged", lambda e: e.tampered("train", "weights.npz"))
    case(f"{cmd}-truncated-sessions",
         lambda e, c=cmd: S(c, e.tampered("train", "sessions.csv", "truncate")), 2,
         "sessions.csv", "unchanged", lambda e: e.tampered("train", "sessions.csv", "truncate"))
case("gait-seconds-nan", lambda e: S("gait", e.copy("train"), "--seconds", "nan"), 2,
     "--seconds", "unchanged", lambda e: e.copy("train"))
case("gait-seconds-shorter-than-a-step", lambda e: S("gait", e.copy("train"), "--seconds",
                                                     "1e-5"), 2,
     "--seconds", "unchanged", lambda e: e.copy("train"))
case("gait-seed-negative", lambda e: S("gait", e.copy("train"), "--seed", "-1"), 2, "--seed",
     "unchanged", lambda e: e.copy("train"))
case("gait-seconds-1e7", lambda e: S("gait", e.copy("train"), "--seconds", "1e7"), 2, "memory",
     "unchanged", lambda e: e.copy("train"))
case("plot-seconds-1e7", lambda e: S("plot", e.copy("train"), "--seconds", "1e7", "--out",
                                     out(e)), 2, "memory", "absent", out)
case("train-sessions-1e9", lambda e: S("train", "--sessions", "1000000000", "--out", out(e)), 2,
     "memory", "absent", out)
case("study-billion-sessions", lambda e: S("study", e.study(study_text(sessions="1000000000")),
                                           "--out", out(e)), 2, "memory", "absent", out)
case("gait-corrupt-but-listed-weights", lambda e: S("gait", e.corrupt_listed("train",
                                                                             "weights.npz")),
     2, "weights.npz", "unchanged", lambda e: e.corrupt_listed("train", "weights.npz"))
case("plot-trial-out-of-range", lambda e: S("plot", e.copy("train"), "--trial", "5", "--out",
                                            out(e)), 2, "--trial", "absent", out)
case("plot-seconds-inf", lambda e: S("plot", e.copy("train"), "--seconds", "inf", "--out",
                                     out(e)), 2, "--seconds", "absent", out)
case("plot-out-not-empty", lambda e: S("plot", e.copy("train"), "--out", e.nonempty()), 2,
     lambda e: str(e.nonempty()), "unchanged", lambda e: e.nonempty())
case("plot-seconds-shorter-than-a-figure-needs",
     lambda e: S("plot", e.copy("train"), "--seconds", "0.05", "--out", out(e)), 0, None,
     "complete", out, marks=(pytest.mark.slow,))
case("plot-a-unit-folder", lambda e: S("plot", e.copy("unit"), "--out", out(e)), 0, None,
     "complete", out)
case("plot-unit-trial-out-of-range", lambda e: S("plot", e.copy("unit"), "--trial", "3", "--out",
                                                 out(e)), 2, "--trial", "absent", out)
case("plot-format-unknown", lambda e: S("plot", e.copy("unit"), "--format", "gif", "--out",
                                        out(e)), 2, "--format", "absent", out)
case("plot-window-reversed", lambda e: S("plot", e.copy("unit"), "--window", "0.2", "0.1",
                                         "--out", out(e)), 2, "--window", "absent", out)
case("plot-window-nan", lambda e: S("plot", e.copy("unit"), "--window", "nan", "0.1", "--out",
                                    out(e)), 2, "--window", "absent", out)
case("plot-window-after-the-recording", lambda e: S("plot", e.copy("unit"), "--window", "50",
                                                    "60", "--out", out(e)), 2, "--window",
     "absent", out)
case("plot-tampered-unit", lambda e: S("plot", e.tampered("unit", "spikes.npz"), "--out",
                                       out(e)), 2, "spikes.npz", "absent", out)
case("plot-recorded-nothing-to-draw",
     lambda e: S("plot", e.copy("unit_nothing"), "--out", out(e)), 2,
     lambda e: str(e.copy("unit_nothing")), "absent", out)
case("video-a-unit-folder", lambda e: S("video", e.copy("unit")), 2,
     lambda e: str(e.copy("unit")), "unchanged", lambda e: e.copy("unit"))
case("video-a-training-without-recordings", lambda e: S("video", e.copy("train")), 2,
     lambda e: str(e.copy("train")), "unchanged", lambda e: e.copy("train"))
for opt, value in (("--fps", "0"), ("--fps", "nan"), ("--speed", "inf"), ("--speed", "-1")):
    case(f"video-{opt[2:]}-{value}", lambda e, o=opt, v=value: S("video", e.copy("run"), o, v),
         2, opt, "unchanged", lambda e: e.copy("run"))
case("video-size-odd", lambda e: S("video", e.copy("run"), "--size", "641", "480"), 2, "--size",
     "unchanged", lambda e: e.copy("run"))
case("video-size-zero", lambda e: S("video", e.copy("run"), "--size", "0", "0"), 2, "--size",
     "unchanged", lambda e: e.copy("run"))
case("video-trial-out-of-range", lambda e: S("video", e.copy("run"), "--trial", "4"), 2,
     "--trial", "unchanged", lambda e: e.copy("run"))
case("video-out-not-mp4", lambda e: S("video", e.copy("run"), "--out", e.tmp / "v.avi"), 2,
     "v.avi", "absent", lambda e: e.tmp / "v.avi")
case("video-out-exists", lambda e: S("video", e.copy("run"), "--out", e.file("v.mp4", "mine")),
     2, "v.mp4", "unchanged", lambda e: e.file("v.mp4", "mine"))
case("video-tampered-robot", lambda e: S("video", e.tampered("run", "robot.npz")), 2,
     "robot.npz", "unchanged", lambda e: e.tampered("run", "robot.npz"))
case("export-after-plot-and-video", lambda e: S("export", e.derived("run_nospikes"), "--format",
                                                "npz"),
     0, None, "unchanged", lambda e: e.derived("run_nospikes"), check=export_written(".npz"))
case("power-trial-out-of-range", lambda e: S("power", e.copy("train"), "--trial", "3"), 2,
     "--trial", "unchanged", lambda e: e.copy("train"))
case("power-trial-negative", lambda e: S("power", e.copy("train"), "--trial", "-1"), 2,
     "--trial", "unchanged", lambda e: e.copy("train"))
case("power-sessions-0", lambda e: S("power", e.copy("train"), "--sessions", "0"), 2,
     "--sessions", "unchanged", lambda e: e.copy("train"))
case("power-sessions-1e9", lambda e: S("power", e.copy("train"), "--sessions", "1000000000"),
     2, "memory", "unchanged", lambda e: e.copy("train"))

# ---- study files
case("study-missing-file", lambda e: S("study", e.tmp / "none.toml", "--out", out(e)), 1,
     "none.toml", "absent", out)
case("study-binary-file", lambda e: S("study", e.study(bytes(range(256))), "--out", out(e)), 2,
     "s.toml", "absent", out)
case("study-latin1-file", lambda e: S("study", e.study('[study]\nname = "caf\xe9"\n'
                                                       .encode("latin-1")), "--out", out(e)),
     2, "s.toml", "absent", out)
case("study-not-toml", lambda e: S("study", e.study("[study\nname = 1"), "--out", out(e)), 2,
     "s.toml", "absent", out)
case("study-a-folder", lambda e: S("study", e.empty(), "--out", out(e)), 2, "empty", "absent",
     out)
case("study-name-leaves-the-root", lambda e: S("study", e.study(study_text(name='"../evil"'))),
     2, "name", "absent", lambda e: Path("evil"))
case("study-name-absolute", lambda e: S("study", e.study(study_text(name=f'"{e.tmp}/abs"'))), 2,
     "name", "absent", lambda e: e.tmp / "abs")
case("study-million-seeds", lambda e: S("study", e.study(study_text(
    seeds="{ first = 1, count = 1000000 }")), "--out", out(e)), 2, "seeds", "absent", out)
case("study-million-seeds-in-one-batch", lambda e: S("study", e.study(study_text(
    seeds="{ first = 1, count = 90000 }", batch="90000")), "--out", out(e)), 2, "memory",
     "absent", out)
case("study-million-runs-by-a-sweep", lambda e: S("study", e.study(study_text() + GRID), "--out",
                                                  out(e)), 2, "trainings", "absent", out)
case("study-unknown-key", lambda e: S("study", e.study(study_text(sesions="3")), "--out",
                                      out(e)), 2, "sesions", "absent", out)
case("study-value-evaluated", lambda e: S("study", e.study(
    study_text() + f'[conditions.a]\nset = {{ tau_motor = "{EVIL}" }}\n'), "--out", out(e)), 2,
     "tau_motor", "absent", out, check=not_evaluated)
case("study-value-1e309", lambda e: S("study", e.study(study_text().replace(
    '"0.2*second"', '"1e309*second"')), "--out", out(e)), 2, "L_max", "absent", out)
case("study-value-nan", lambda e: S("study", e.study(study_text().replace(
    '"0.2*second"', '"nan*second"')), "--out", out(e)), 2, "L_max", "absent", out)
case("study-workers-0", lambda e: S("study", e.study(study_text()), "--workers", "0", "--out",
                                    out(e)), 2, "--workers", "absent", out)
case("study-out-is-a-file", lambda e: S("study", e.study(study_text()), "--out",
                                        e.file("f.txt", "x")), 2, "f.txt", "unchanged",
     lambda e: e.file("f.txt", "x"))
case("study-out-not-a-study", lambda e: S("study", e.study(study_text()), "--out",
                                          e.nonempty()), 2, lambda e: str(e.nonempty()),
     "unchanged", lambda e: e.nonempty())
case("study-out-of-another-study", lambda e: S("study", e.study(study_text()), "--out",
                                               e.copy("study")), 2, "tiny", "unchanged",
     lambda e: e.copy("study"))

# ---- report
case("report-missing-folder", lambda e: S("report", e.tmp / "nosuch"), 1, "nosuch", "absent",
     lambda e: e.tmp / "nosuch")
case("report-not-a-study", lambda e: S("report", e.copy("unit")), 2,
     lambda e: str(e.copy("unit")), "unchanged", lambda e: e.copy("unit"))
case("report-last-0", lambda e: S("report", e.copy("study"), "--last", "0", "--out", out(e)), 2,
     "--last", "absent", out)
case("report-smooth-0", lambda e: S("report", e.copy("study"), "--smooth", "0", "--out",
                                    out(e)), 2, "--smooth", "absent", out)
case("report-out-not-empty", lambda e: S("report", e.copy("study"), "--out", e.nonempty()), 2,
     lambda e: str(e.nonempty()), "unchanged", lambda e: e.nonempty())
case("report-corrupt-index", lambda e: S("report", e.tampered("study", "study.json",
                                                              "truncate"), "--out", out(e)),
     2, "study.json", "absent", out)
case("report-binary-sessions",
     lambda e: S("report", e.corrupt_listed("study", "runs/astro__seed1/sessions.csv",
                                            "runs/astro__seed1/manifest.json"),
                 "--out", out(e)), 2, "sessions.csv", "absent", out)
case("report-tampered-weights",
     lambda e: S("report", e.tampered("study", "runs/astro__seed1/weights.npz"), "--out",
                 out(e)), 2, "weights.npz", "absent", out)

# ---- export
case("export-missing-folder", lambda e: S("export", e.tmp / "nosuch"), 1, "nosuch", "absent",
     lambda e: e.tmp / "nosuch")
case("export-missing-folder-with-out", lambda e: S("export", e.tmp / "nosuch", "--out",
                                                   e.tmp / "x.nwb"), 1, "nosuch", "absent",
     lambda e: e.tmp / "x.nwb")
case("export-a-training", lambda e: S("export", e.copy("train")), 2, "train", "unchanged",
     lambda e: e.copy("train"))
case("export-format-unknown", lambda e: S("export", e.copy("run"), "--format", "hdf5"), 2,
     "--format", "unchanged", lambda e: e.copy("run"))
case("export-out-exists", lambda e: S("export", e.copy("run"), "--out", e.file("x.nwb", "old")),
     2, "x.nwb", "unchanged", lambda e: e.file("x.nwb", "old"))
case("export-out-is-a-folder", lambda e: S("export", e.copy("run"), "--out", e.empty()), 2,
     lambda e: str(e.empty()), "unchanged", lambda e: e.empty())
case("export-out-parent-missing", lambda e: S("export", e.copy("run"), "--out",
                                              e.tmp / "no" / "x.nwb"), 2, "x.nwb", "absent",
     lambda e: e.tmp / "no")
case("export-tampered-spikes", lambda e: S("export", e.tampered("run", "spikes.npz"), "--format",
                                           "npz"), 2, "spikes.npz", "unchanged",
     lambda e: e.tampered("run", "spikes.npz"))
case("export-missing-file", lambda e: S("export", e.tampered("run", "traces.npz", "missing")), 2,
     "traces.npz", "unchanged", lambda e: e.tampered("run", "traces.npz", "missing"))
case("export-extra-file", lambda e: S("export", e.tampered("run", "notes.txt", "extra")), 2,
     "notes.txt", "unchanged", lambda e: e.tampered("run", "notes.txt", "extra"))
case("export-corrupt-but-listed-npz", lambda e: S("export", e.corrupt_listed("run", "traces.npz"),
                                                  "--format", "npz"), 2, "traces.npz",
     "unchanged", lambda e: e.corrupt_listed("run", "traces.npz"),
     check=no_temporaries_beside(lambda e: e.corrupt_listed("run", "traces.npz")))
case("export-corrupt-manifest", lambda e: S("export", e.tampered("run", "manifest.json",
                                                                 "truncate")), 2,
     "manifest.json", "unchanged", lambda e: e.tampered("run", "manifest.json", "truncate"))
case("export-run-without-spikes-npz", lambda e: S("export", e.copy("run_nospikes"), "--format",
                                                  "npz"), 0, None, "unchanged",
     lambda e: e.copy("run_nospikes"), check=export_written(".npz"))
case("export-run-without-spikes-nwb", lambda e: S("export", e.copy("run_nospikes")), 0, None,
     "unchanged", lambda e: e.copy("run_nospikes"), check=export_written(".nwb"))

# ---- describe
case("describe-unknown-model", lambda e: ["describe", "glia"], 2, "glia", "none")
case("describe-unknown-format", lambda e: ["describe", "--format", "html"], 2, "--format",
     "none")
case("describe-equations-binary",
     lambda e: S("describe", "motor_neuron", "--equations",
                 f"motor_neuron={e.file('eq.bin', bytes(range(256)))}"), 2, "eq.bin", "none")

# ---- robot export
case("robot-export-not-xml", lambda e: S("robot", "export", e.tmp / "a1.txt"), 2, "a1.txt",
     "absent", lambda e: e.tmp / "a1.txt")
case("robot-export-folder-missing", lambda e: S("robot", "export", e.tmp / "no" / "a1.xml"), 2,
     "a1.xml", "absent", lambda e: e.tmp / "no")
case("robot-export-exists", lambda e: S("robot", "export", e.file("a1.xml", "mine")), 2,
     "a1.xml", "unchanged", lambda e: e.file("a1.xml", "mine"))
case("robot-export-overwrite-a-users-file",
     lambda e: S("robot", "export", e.file("a1.xml", "<mujoco model='mine'/>"), "--overwrite"), 2,
     "not the A1 model astrocpg writes", "unchanged",
     lambda e: e.file("a1.xml", "<mujoco model='mine'/>"))
case("robot-export-is-a-folder", lambda e: S("robot", "export", e.empty("a1.xml"), "--overwrite"),
     2, "a1.xml", "unchanged", lambda e: e.empty("a1.xml"))
case("robot-export-uncreatable", lambda e: ["robot", "export", "/sys/astrocpg_a1.xml"], 1,
     "/sys/astrocpg_a1.xml", "absent", lambda e: Path("/sys/astrocpg_a1.xml"))

# ---- edge values that must work
case("unit-seconds-shorter-than-the-rhythm-analysis",
     lambda e: S("unit", "--seconds", "0.05", "--no-progress", "--out", out(e)), 0, None,
     "complete", out)
case("run-seconds-one-step", lambda e: S("run", "--seconds", "0.001", "--no-progress", "--out",
                                         out(e)), 0, None, "complete", out)
case("gait-seconds-short", lambda e: S("gait", e.copy("train"), "--seconds", "0.05",
                                       "--no-progress"), 0, None, "unchanged",
     lambda e: e.copy("train"))
case("run-overwrite-replaces-whole", lambda e: S("run", "--seconds", "0.01", "--no-progress",
                                                 "--overwrite", "--out", e.derived("run")),
     0, None, "complete", lambda e: e.derived("run"),
     check=lambda e: not (e.derived("run") / "figures").exists() or pytest.fail("merged"))
case("unit-spikes-none", lambda e: S("unit", "--seconds", "0.05", "--spikes", "none", "--traces",
                                     "none", "--no-progress", "--out", out(e)), 0, None,
     "complete", out)

# ---- divergence: exit 3, one line naming population.variable and the time; the folder is
# written whole and says so
BLOW_UP = "r_IP3=1e306*umolar/second"  # IP3 without bound: the astrocytes go NaN within 0.05 s
for cmd in (UNIT, RUN):
    case(f"{cmd}-diverges", lambda e, c=cmd: S(c, "--seconds", "0.1", "--set", BLOW_UP, "--out",
                                               out(e)),
         3, "astrocyte.", "diverged", out, check=lambda e: said_when(e))
case("run-robot-diverges", lambda e: S("run", "--seconds", "0.05", "--robot", e.geared_robot(),
                                       "--out", out(e)),
     3, "MuJoCo", "diverged", out, check=lambda e: said_when(e))
case("train-diverges", lambda e: S("train", "--sessions", "3", "--set", BLOW_UP, "--out", out(e)),
     3, "astrocyte.", "diverged", out, check=lambda e: diverged_row(out(e)))

# ---- write failures (a fresh process: rlimits and mount namespaces)
FSIZE = 20_000
case("run-file-too-large", lambda e: S("run", "--seconds", "0.05", "--no-progress", "--out",
                                       out(e)), 1, "File too large", "absent", out,
     subprocess={"rlimit_fsize": FSIZE}, marks=(pytest.mark.slow,))
case("unit-file-too-large", lambda e: S("unit", "--seconds", "0.05", "--no-progress", "--out",
                                        out(e)), 1, "File too large", "absent", out,
     subprocess={"rlimit_fsize": FSIZE})
case("robot-export-file-too-large", lambda e: S("robot", "export", e.tmp / "a1.xml"), 1,
     "File too large", "absent", lambda e: e.tmp / "a1.xml",
     subprocess={"rlimit_fsize": 1000})
case("unit-disk-full", lambda e: S("unit", "--seconds", "0.05", "--no-progress", "--out",
                                   e.tmp / "small" / "out"), 1, "No space left", "absent",
     lambda e: e.tmp / "small" / "out", subprocess={"tmpfs": "small", "size": "64k"})
case("unit-read-only", lambda e: S("unit", "--seconds", "0.05", "--no-progress", "--out",
                                   e.tmp / "ro" / "out"), 1, "Read-only", "absent",
     lambda e: e.tmp / "ro" / "out", subprocess={"tmpfs": "ro", "size": "64k", "ro": True})
case("export-disk-full", lambda e: S("export", e.copy("run"), "--out",
                                     e.tmp / "small" / "x.nwb"), 1, "No space left", "absent",
     lambda e: e.tmp / "small" / "x.nwb", subprocess={"tmpfs": "small", "size": "16k"},
     check=no_temporaries_beside(lambda e: e.tmp / "small" / "x.nwb"))
# Brian2 keeps debug files in the temp folder for errors it sees; a handled error leaves none
case("unit-bad-equation-leaves-no-debug-files",
     lambda e: S("unit", "--seconds", "0.01", "--equations",
                 f"motor_neuron={e.equations('motor_neuron', lambda t: t.replace('/tau_motor', '/tau_motr'))}",
                 "--out", out(e)), 2, "motor_neuron", "absent", out,
     subprocess={"tmpdir": True})
case("unit-short-leaves-no-debug-files",
     lambda e: S("unit", "--seconds", "0.01", "--no-progress", "--out", out(e)), 0, None,
     "complete", out, subprocess={"tmpdir": True}, marks=(pytest.mark.slow,))
# ---- the command line's own words: a misspelt name gets the closest, in the one line
case("run-misspelt-parameter", lambda e: S("run", "--set", "tau_motr=8*ms", "--out", out(e)), 2,
     "--set tau_motr: unknown model parameter (did you mean tau_motor?)", "absent", out)
case("run-misspelt-option", lambda e: S("run", "--secnds", "1", "--out", out(e)), 2,
     "--secnds (did you mean --seconds?)", "absent", out)
case("misspelt-command", lambda e: ["rn"], 2, "'rn' (did you mean run?)", "none")
case("models-misspelt-subcommand", lambda e: ["models", "lst"], 2, "did you mean list?", "none")
case("models-dump-misspelt-model", lambda e: ["models", "dump", "astrocite"], 2,
     "astrocite: unknown model (did you mean astrocyte?)", "none")
case("run-misspelt-model-file-slot",
     lambda e: S("run", "--model", f"astrocite={e.file('a.toml', 'kind = 1')}", "--out",
                 out(e)), 2, "--model astrocite: unknown model (did you mean astrocyte?)",
     "absent", out)
case("plot-misspelt-format", lambda e: S("plot", e.copy("run"), "--format", "pnj",
                                         "--no-progress"), 2, "did you mean png?", "none")
# a shipped file's name misspelt (a name, not a path): bad input, the closest named
case("study-misspelt-name", lambda e: S("study", "quik", "--out", out(e)), 2,
     "study: unknown study 'quik' (did you mean quick?)", "absent", out)
case("run-misspelt-model-file-name", lambda e: S("run", "--model", "astrocyte=li_rinzel_astrocyt",
                                                 "--out", out(e)), 2,
     "unknown model 'li_rinzel_astrocyt' (did you mean li_rinzel_astrocyte?)", "absent", out)
case("evaluate-misspelt-worlds", lambda e: S("evaluate", e.copy("train"), "--worlds",
                                             "robustnes", "--out", out(e)), 2,
     "unknown worlds 'robustnes' (did you mean robustness?)", "absent", out)
case("study-misspelt-key", lambda e: S("study", e.study('[study]\nname = "x"\nsesions = 2\n'),
                                       "--out", out(e)), 2,
     "unknown key 'sesions' (did you mean sessions?)", "absent", out)
# a missing input file or folder is the environment's (exit 1), whatever reads it
case("run-model-file-missing", lambda e: S("run", "--model", f"astrocyte={e.tmp / 'a.toml'}",
                                           "--out", out(e)), 1, "a.toml", "absent", out)
case("evaluate-worlds-missing", lambda e: S("evaluate", e.copy("train"), "--worlds",
                                            e.tmp / "w.toml", "--out", out(e)), 1, "w.toml",
     "absent", out)
case("study-plan-from-missing", lambda e: S("study", "quick", "--plan-from", e.tmp / "nosuch",
                                            "--out", out(e)), 1, "--plan-from", "absent", out)
case("study-status-missing", lambda e: ["study", "--status", str(e.tmp / "nosuch")], 1,
     "--status", "none")
# a command group alone lists its commands: done, nothing on stderr
case("models-alone", lambda e: ["models"], 0, None, "none")
case("robot-alone", lambda e: ["robot"], 0, None, "none")

# ---- overwrite: what --out may replace (one rule, studies/outputs/folder.py check_output_path
# and check_replaceable): never a folder of the user's own files, the command's input (nor a
# folder holding it, nor a place inside it but figures/, report/, ...), nor the current folder
for cmd in (UNIT, RUN, "train"):
    case(f"{cmd}-overwrite-a-folder-of-user-files",
         lambda e, c=cmd: S(c, "--seconds", "0.01", "--overwrite", "--out", e.nonempty())
         if c != "train" else S(c, "--overwrite", "--out", e.nonempty()), 2,
         lambda e: f"--out {e.nonempty()}: holds files that are not an astrocpg output",
         "unchanged", lambda e: e.nonempty())
case("study-overwrite-a-folder-of-user-files",
     lambda e: S("study", e.study(study_text()), "--overwrite", "--out", e.nonempty()), 2,
     "not an astrocpg output", "unchanged", lambda e: e.nonempty())
case("plot-overwrite-its-own-input", lambda e: S("plot", e.copy("run"), "--out", e.copy("run"),
                                                  "--overwrite"), 2,
     lambda e: f"--out {e.copy('run')}: is {e.copy('run')}, which this command reads",
     "unchanged", lambda e: e.copy("run"))
case("plot-training-overwrite-its-own-input",
     lambda e: S("plot", e.copy("train"), "--out", e.copy("train"), "--overwrite"), 2,
     "which this command reads", "unchanged", lambda e: e.copy("train"))
case("report-overwrite-its-own-study",
     lambda e: S("report", e.copy("study"), "--out", e.copy("study"), "--overwrite"), 2,
     lambda e: f"--out {e.copy('study')}: is", "unchanged", lambda e: e.copy("study"))
case("report-out-inside-the-study-not-its-report",
     lambda e: S("report", e.copy("study"), "--out", e.copy("study") / "runs", "--overwrite"), 2,
     "is inside", "unchanged", lambda e: e.copy("study"))
case("evaluate-overwrite-its-own-training",
     lambda e: S("evaluate", e.copy("train"), "--seconds", "0.05", "--repeats", "1",
                 "--no-progress", "--out", e.copy("train"), "--overwrite"), 2,
     "which this command reads", "unchanged", lambda e: e.copy("train"))
case("run-overwrite-the-training-of-its-weights",
     lambda e: S("run", "--seconds", "0.01", "--weights", e.copy("train"), "--out",
                 e.copy("train"), "--overwrite"), 2,
     "which this command reads", "unchanged", lambda e: e.copy("train"))
case("unit-out-holds-its-model-file",
     lambda e: S("unit", "--seconds", "0.01", "--equations",
                 f"astrocyte={e.equations('astrocyte', name='run/eqs.txt')}",
                 "--out", e.tmp / "run", "--overwrite"), 2,
     "holds", "unchanged", lambda e: e.tmp / "run")
case("study-out-holds-its-study-file",
     lambda e: S("study", (e.copy("study"), e.file("study/tiny.toml", TINY_STUDY))[1],
                 "--out", e.copy("study"), "--overwrite"), 2,
     "holds", "unchanged", lambda e: e.copy("study"))
case("plot-overwrite-the-parent-of-its-input",
     lambda e: S("plot", e.copy("run", "sub/run"), "--out", e.tmp / "sub", "--overwrite"), 2,
     "holds", "unchanged", lambda e: e.tmp / "sub")
case("plot-overwrite-dot", lambda e: S("plot", e.copy("run"), "--out", ".", "--overwrite"), 2,
     "--out .: is the current folder", "unchanged", lambda e: e.tmp)
case("run-overwrite-dot-dot", lambda e: S("run", "--seconds", "0.01", "--out", "..",
                                          "--overwrite"), 2,
     "--out ..: holds the current folder", "unchanged", lambda e: e.tmp)
case("export-overwrite-a-file-of-its-input",
     lambda e: S("export", e.copy("run"), "--format", "npz", "--out",
                 e.copy("run") / "spikes.npz", "--overwrite"), 2,
     "is inside", "unchanged", lambda e: e.copy("run"))
case("export-overwrite-a-file-another-output-lists",
     lambda e: S("export", e.copy("run"), "--format", "npz", "--out",
                 e.copy("train") / "weights.npz", "--overwrite"), 2,
     "listed in its manifest", "unchanged", lambda e: e.copy("train"))
case("video-out-inside-its-input",
     lambda e: S("video", e.copy("run"), "--out", e.copy("run") / "clip.mp4", "--overwrite"), 2,
     "is inside", "unchanged", lambda e: e.copy("run"))
case("plot-overwrite-another-run", lambda e: S("plot", e.copy("run"), "--out",
                                                e.copy("run", "other"), "--overwrite"), 0,
     None, "complete", lambda e: e.copy("run", "other"))


# ---- --overwrite deletes only what astrocpg wrote and recorded: a folder holding anything else
# (a file, a link, an empty folder, a file in figures/, a listed file changed since) is
# refused naming it; a manifest without an inventory claims nothing; a training or a study is
# replaced only by its own command
def _users(e: Env, which: str, what: str) -> Path:
    """A copy of a fixture folder holding one thing of the user's (``what``)."""
    def make() -> Path:
        d = e.copy(which, f"{which}_u")
        if what.startswith("figures/"):  # plot's figures/, with its own manifest
            from astrocpg.studies.outputs.folder import inventory
            (d / "figures").mkdir()
            (d / "figures" / "rasters.png").write_bytes(b"png")
            (d / "figures" / "manifest.json").write_text(json.dumps(
                {"astrocpg_command": "plot", "inventory": inventory(d / "figures")}))
        if what == "lnk":
            (d / "lnk").symlink_to(e.file("elsewhere.txt", "mine\n"))
        elif what.endswith("/"):
            (d / what).mkdir()
        elif what == "spikes.npz":
            (d / what).write_bytes(b"the user's own bytes")
        elif what == "no-inventory":
            m = json.loads((d / "manifest.json").read_text())
            del m["inventory"]
            (d / "manifest.json").write_text(json.dumps(m))
            (d / "compare_rows.py").write_text("print(1)\n")
        else:
            (d / what).write_text("the user's own file\n")
        return d
    return e._once(f"users:{which}:{what}", make)


for what, named in (("analysis.md", "holds analysis.md that astrocpg did not write"),
                    ("lnk", "holds lnk that astrocpg did not write"),
                    ("emptyd/", "holds emptyd/ that astrocpg did not write"),
                    ("figures/notes.md", "holds figures/notes.md that astrocpg did not write"),
                    ("spikes.npz", "holds spikes.npz that astrocpg did not write"),
                    ("no-inventory", "compare_rows.py, and its manifest.json lists no files")):
    case(f"run-overwrite-a-run-holding-{what.strip('/').replace('/', '-')}",
         lambda e, w=what: S("run", "--seconds", "0.01", "--no-progress", "--overwrite",
                             "--out", _users(e, "run", w)), 2,
         named, "unchanged", lambda e, w=what: _users(e, "run", w))
case("train-overwrite-a-training-holding-a-users-file",
     lambda e: S("train", "--sessions", "1", *SHORT, "--no-progress", "--overwrite", "--out",
                 _users(e, "train", "analysis.md")), 2,
     "holds analysis.md that astrocpg did not write", "unchanged",
     lambda e: _users(e, "train", "analysis.md"))
case("plot-overwrite-a-training", lambda e: S("plot", e.copy("run"), "--no-progress", "--out",
                                               e.copy("train"), "--overwrite"), 2,
     "holds an astrocpg train output", "unchanged", lambda e: e.copy("train"))
case("run-overwrite-a-study", lambda e: S("run", "--seconds", "0.01", "--no-progress", "--out",
                                           e.copy("study"), "--overwrite"), 2,
     "holds an astrocpg study output", "unchanged", lambda e: e.copy("study"))


# ---- bounded reading: a user's file is refused by its size, an array file by its header,
# before it is read (sparse files: no disk, no time)
def _sparse(e: Env, name: str, size: int = 1 << 30) -> Path:
    def make() -> Path:
        p = e.tmp / name
        with open(p, "wb") as f:
            f.truncate(size)
        return p
    return e._once("sparse:" + name, make)


def _npy_claiming(shape: tuple[int, ...]) -> bytes:
    import io
    b = io.BytesIO()
    np.lib.format.write_array_header_1_0(b, {"descr": "<f8", "fortran_order": False,
                                             "shape": shape})
    return b.getvalue() + b"\0" * 64


def _huge_checkpoint(e: Env) -> Path:
    """A copy of the training whose checkpoint has an entry claiming a 1 TB shape."""
    def make() -> Path:
        import io
        import zipfile
        d = e.copy("train", "train_huge")
        ck = d / "checkpoint.npz"
        with np.load(ck) as z:
            arrays = {k: z[k] for k in z.files}
        with zipfile.ZipFile(ck, "w") as zf:
            for k, v in arrays.items():
                b = io.BytesIO()
                np.lib.format.write_array(b, v)
                zf.writestr(k + ".npy", _npy_claiming((1 << 40,)) if k == "a0"
                            else b.getvalue())
        return d
    return e._once("huge_checkpoint", make)


def _gz_bomb(e: Env) -> Path:
    """results.csv.gz: a few hundred kB that inflate to more than 256 MiB."""
    def make() -> Path:
        import gzip
        p = e.tmp / "results.csv.gz"
        with gzip.open(p, "wb", compresslevel=1) as f:
            f.write(b"run_id,seed,length_s\n")
            zeros = b"0" * (1 << 20)
            for _ in range(257):
                f.write(zeros)
        return p
    return e._once("gz_bomb", make)


for suffix in ("csv", "json", "npy", "npz", "txt"):
    case(f"run-weights-1GiB-{suffix}",
         lambda e, x=suffix: S("run", "--seconds", "0.01", "--weights", _sparse(e, f"w.{x}"),
                               "--out", out(e)), 2,
         "1,073,741,824 bytes (refused unread), more than the 64 MiB", "absent", out)
case("run-weights-npy-header-claims-a-huge-shape",
     lambda e: S("run", "--seconds", "0.01", "--weights",
                 e.file("h.npy", _npy_claiming((1 << 30, 8, 8))), "--out", out(e)), 2,
     "(1073741824, 8, 8)", "absent", out)
case("study-file-1GiB", lambda e: S("study", _sparse(e, "big.toml"), "--out", out(e)), 2,
     "more than the 16 MiB", "absent", out)
case("run-model-file-1GiB",
     lambda e: S("run", "--seconds", "0.01", "--model",
                 f"motor_neuron={_sparse(e, 'mn.toml')}", "--out", out(e)), 2,
     "more than the 16 MiB", "absent", out)
case("train-resume-checkpoint-entry-claims-a-huge-shape",
     lambda e: S("train", "--resume", _huge_checkpoint(e), "--no-progress"), 2,
     "(1099511627776,)", "unchanged", _huge_checkpoint)
case("study-plan-from-a-gz-bomb",
     lambda e: S("study", e.study(study_text()), "--plan-from", _gz_bomb(e), "--out", out(e)),
     2, "once inflated (or more), more than the 256 MiB", "absent", out)

# ---- leftovers: names of 235-255 bytes (their temporaries' names fit), a killed plot's or
# video's temporary (export still reads the run), the README's delay example (why, and the fix)
LONG = 255


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _killed_plot_and_video(e: Env) -> Path:
    """A run copy with what a SIGKILLed plot and video leave in it (their pid is gone)."""
    d = e.copy("run", "run_killed")
    if not any(n.startswith(".figures.") for n in os.listdir(d)):
        pid = _dead_pid()
        (d / f".figures.partial-{pid}-k2j4h5g6").mkdir()
        (d / f".figures.partial-{pid}-k2j4h5g6" / "rasters.png").write_bytes(b"half")
        (d / f".video_trial00.tmp-{pid}-a1b2c3d4.mp4").write_bytes(b"half")
    return d


for length in (235, LONG):
    case(f"run-out-name-{length}-bytes", lambda e, n=length: S(
        "run", "--seconds", "0.01", "--no-progress", "--out", e.tmp / ("r" * n)), 0, None,
        "complete", lambda e, n=length: e.tmp / ("r" * n))
    case(f"run-overwrite-name-{length}-bytes", lambda e, n=length: S(
        "run", "--seconds", "0.01", "--no-progress", "--overwrite", "--out",
        e.copy("run", "r" * n)), 0, None, "complete", lambda e, n=length: e.copy("run", "r" * n))
case("plot-out-name-255-bytes", lambda e: S("plot", e.copy("run"), "--out", e.tmp / ("f" * LONG)),
     0, None, "complete", lambda e: e.tmp / ("f" * LONG))
case("unit-out-name-255-multibyte", lambda e: S("unit", "--seconds", "0.01", "--no-progress",
                                                "--out", e.tmp / ("\u00e9" * 127)),
     0, None, "complete", lambda e: e.tmp / ("\u00e9" * 127))
case("export-out-name-255-bytes", lambda e: S("export", e.copy("run"), "--format", "npz", "--out",
                                              e.tmp / ("x" * (LONG - 4) + ".npz")), 0, None,
     "unchanged", lambda e: e.copy("run"), check=export_written("x.npz"))
case("export-after-a-killed-plot-and-video", lambda e: S("export", _killed_plot_and_video(e),
                                                         "--format", "npz"), 0, None,
     "unchanged", _killed_plot_and_video, check=export_written("run_killed.npz"))
case("run-readme-delay-example", lambda e: S("run", "--set", "delay_FR_FL=0*ms", "--set",
                                             "delay_FR_RR=0*ms", "--out", out(e)), 2,
     "also set delay_FR_RL=0*ms", "absent", out)
case("run-readme-delay-example-as-the-error-suggests", lambda e: S(
    "run", "--set", "delay_FR_FL=0*ms", "--set", "delay_FR_RR=0*ms", "--set",
    "delay_FR_RL=0*ms", "--out", out(e)), 0, None, "complete", out)

# ---- names that shadow, labels that lie
def _astro_file(e: Env, line: str, name: str = "astro.toml") -> Path:
    """The built-in astrocyte as a model file with ``line`` added to its [parameters]."""
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.models.files import model_to_toml
    text = model_to_toml(DEFAULT_MODELS.astrocyte)
    return e.file(name, text.replace("[parameters]\n", f"[parameters]\n{line}\n"))


for pname, value in (("dt", "0.1*second"), ("t", "1*second"), ("ms", "1*second"),
                     ("exp", "1*second"), ("rand", "1*second"), ("pi", "1*second"),
                     ("lastspike", "1*second"), ("Ca", "1*umolar")):
    case(f"run-model-file-parameter-named-{pname}",
         lambda e, n=pname, v=value: S("run", "--model", "astrocyte=" + str(_astro_file(
             e, n + ' = { value = "' + v + '" }', "shadow.toml")),
             "--set", f"{n}={v}", "--out", out(e)),
         2, f"shadow.toml): astrocyte.{pname}: cannot name a parameter", "absent", out)
case("describe-model-file-parameter-named-dt",
     lambda e: S("describe", "astrocyte", "--model",
                 "astrocyte=" + str(_astro_file(e, 'dt = { value = "1*ms" }', "shadow.toml"))),
     2, "shadow.toml): astrocyte.dt", "none")
case("models-dump-file-parameter-named-exp",
     lambda e: S("models", "dump", "astrocyte", "--model",
                 "astrocyte=" + str(_astro_file(e, 'exp = { value = "1*ms" }', "shadow.toml"))),
     2, "shadow.toml): astrocyte.exp", "none")
case("run-model-file-positive-is-text",
     lambda e: S("run", "--model", "astrocyte=" + str(_astro_file(
         e, 'tau_IP3x = { value = "-1*second", positive = "false" }', "typed.toml")),
                 "--out", out(e)),
     2, "typed.toml): parameters.tau_IP3x: 'positive' must be true or false", "absent", out)
case("run-model-file-symbol-is-a-number",
     lambda e: S("run", "--model", "astrocyte=" + str(_astro_file(
         e, 'tau_IP3x = { value = "1*second", symbol = 3 }', "typed.toml")), "--out", out(e)),
     2, "parameters.tau_IP3x: 'symbol' must be text", "absent", out)
case("run-model-file-parameter-nothing-reads",
     lambda e: S("run", "--model", "astrocyte=" + str(_astro_file(
         e, 'tau_dead = { value = "1*second" }', "dead.toml")),
                 "--set", "tau_dead=2*second", "--out", out(e)),
     2, "dead.toml): parameters.tau_dead: is declared but no code string", "absent", out)


def _interlimb_reading_u(e: Env) -> Path:
    """An inter-limb synapse file declaring ``u``, which its code reads: Brian2 resolves it to
    the target pools' variable, not the parameter (caught when the network is built)."""
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.models.files import model_to_toml
    text = model_to_toml(DEFAULT_MODELS.interlimb_synapse)
    text = text.replace("[parameters]\n", '[parameters]\nu = { value = "1" }\n')
    return e.file("il.toml", text.replace("model = '''\n", "model = '''\nu_seen = u : 1\n", 1))


case("run-model-file-synapse-parameter-shadowed-by-its-target",
     lambda e: S("run", "--model", f"interlimb_synapse={_interlimb_reading_u(e)}", "--out",
                 out(e)), 2, "interlimb_synapse.u: is not the value the network reads",
     "absent", out)
case("train-set-dt", lambda e: S("train", "--set", "dt=0.1*second", "--out", out(e)), 2, "dt",
     "absent", out)
case("study-model-file-parameter-named-dt",
     lambda e: S("study", e.study(study_text() + "[models]\nastrocyte = \"shadow.toml\"\n")
                 if _astro_file(e, 'dt = { value = "1*ms" }', "shadow.toml") else None,
                 "--out", out(e)), 2, "shadow.toml): astrocyte.dt", "absent", out)

# durations are whole steps
for cmd in (UNIT, RUN):
    case(f"{cmd}-seconds-not-whole-steps", lambda e, c=cmd: S(c, "--seconds", "0.0015", "--out",
                                                              out(e)),
         2, "--seconds: 0.0015 s is not a whole number of 1 ms steps", "absent", out)
    case(f"{cmd}-trace-dt-half-a-step", lambda e, c=cmd: S(c, "--trace-dt", "0.5", "--out",
                                                           out(e)),
         2, "--trace-dt: 0.5 ms is not a whole number of 1 ms steps", "absent", out)
    case(f"{cmd}-trace-dt-not-whole-steps", lambda e, c=cmd: S(c, "--trace-dt", "2.5", "--out",
                                                               out(e)),
         2, "nearest valid: 2 or 3 ms", "absent", out)
case("gait-seconds-not-whole-steps", lambda e: S("gait", e.copy("train"), "--seconds",
                                                 "0.0015"), 2, "--seconds", "unchanged",
     lambda e: e.copy("train"))
case("plot-seconds-not-whole-steps", lambda e: S("plot", e.copy("train"), "--seconds", "1.0005",
                                                 "--out", out(e)), 2, "--seconds", "absent", out)
case("evaluate-seconds-not-whole-steps", lambda e: S("evaluate", e.copy("train"), "--seconds",
                                                     "0.0015", "--out", out(e)), 2,
     "--seconds", "absent", out)
case("train-L_max-not-whole-steps", lambda e: S("train", "--set", "L_max=0.2005*second", "--out",
                                                out(e)),
     2, "L_max: 0.2005 s is not a whole number of 1 ms steps", "absent", out)
case("train-session_memory-not-whole", lambda e: S("train", "--set", "session_memory=2.5",
                                                   "--out", out(e)),
     2, "session_memory", "absent", out)
case("study-L_max-not-whole-steps", lambda e: S("study", e.study(study_text().replace(
    '"0.2*second"', '"0.2005*second"')), "--out", out(e)), 2, "L_max", "absent", out)
case("study-evaluate-seconds-not-whole-steps", lambda e: S("study", e.study(
    study_text() + "[evaluate]\nseconds = 0.0015\n"), "--out", out(e)), 2,
     "[evaluate] seconds", "absent", out)

# an evaluation grid: one axis per parameter
TWO_AXES_ONE_PARAMETER = ('[grid.double]\nvalues = [2.0]\nscale = ["I_thigh"]\n'
                          '[grid.triple]\nvalues = [3.0]\nscale = ["I_thigh", "I_calf"]\n')
case("evaluate-two-axes-scale-one-parameter",
     lambda e: S("evaluate", e.copy("train"), "--worlds", e.file("w.toml",
                                                                 TWO_AXES_ONE_PARAMETER),
                 "--out", out(e)), 2, "grid.double and grid.triple", "absent", out)

case("study-condition-sets-a-swept-parameter", lambda e: S("study", e.study(
    study_text() + '[sweep.axes]\ntau_STDP = ["1*second", "2*second"]\n'
    '[conditions.a]\nset = { tau_STDP = "3*second" }\n'), "--out", out(e)), 2,
     "[conditions.a] and [sweep.axes] tau_STDP", "absent", out)


# an export says how the run ended; upright means upright
def _diverged_run(e: Env) -> Path:
    """A run that diverged at its first step (a huge motor gear), its messages kept off the
    case's own stderr."""
    import contextlib
    import io

    def make() -> Path:
        d = e.tmp / "diverged_run"
        with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
            assert main(["run", "--seconds", "0.05", "--robot", str(e.geared_robot()),
                         "--no-progress", "--out", str(d)]) == 3
        return d
    return e._once("diverged_run", make)


def nwb_says_diverged(e: Env) -> None:
    from pynwb import NWBHDF5IO
    with NWBHDF5IO(str(e.tmp / "d.nwb"), "r") as io:
        nwb = io.read()
        notes = json.loads(nwb.notes)
        assert notes["status"] == "diverged" and notes["error"]["line"], notes
        assert notes["simulated_seconds"] < 0.05, notes
        assert "DIVERGED" in nwb.session_description and "of the 0.05 s asked" in \
            nwb.session_description, nwb.session_description


def not_upright(e: Env) -> None:
    low = json.loads((out(e) / "manifest.json").read_text())["results"]["lowest_torso_height_m"]
    assert low[0] < 0.15, low


case("export-diverged-run-says-diverged", lambda e: S("export", _diverged_run(e), "--out",
                                                      e.tmp / "d.nwb"),
     0, None, "unchanged", _diverged_run, check=nwb_says_diverged)
case("run-payload-crushes-the-robot-not-upright",
     lambda e: S("run", "--seconds", "1", "--set", "payload=1e6*kilogram", "--spikes", "none",
                 "--traces", "none", "--out", out(e)), 0, None, "complete", out,
     check=not_upright)

# ---- absurd but finite states: any state variable beyond 1e50 (SI units, Brian2's own bound of
# a valid state) means the run diverged, whatever the population (network/divergence.py): exit
# 3, one line naming population.variable, the folder written whole and marked diverged. In a
# fresh process: Brian2's raw "has NaN, very large values" warning goes to the real stderr.
HUGE = {  # case -> (--set values, the population.variable they drive beyond 1e50)
    "motor-v": (["C_K_chan=1e300*mV/second"], "motor.v"),  # -2e251 V, never inf
    "astrocyte-IP3": (["IP3_star=1e60*nM"], "astrocyte.IP3"),
    "astrocyte-AG": (["r_AG=1e60"], "astrocyte.AG"),
    "intra-pool-weight": (["w_0dist=1e60*mV"], "intra_pool.w"),  # a constant of a synapse
    "torque-trace": (["I_thigh=1e60*newton*meter"], "torque."),
}


def _sets(values: list[str]) -> list[str]:
    return [x for v in values for x in ("--set", v)]


def _huge_interlimb(e: Env) -> Path:
    """Off-diagonal inter-limb weights of 1e60 mV (the same-limb blocks stay zero)."""
    w = np.full((8, 8), 1e60)
    for leg in range(4):
        w[2 * leg:2 * leg + 2, 2 * leg:2 * leg + 2] = 0.0
    return e.weights(w, "huge.csv")


for name, (values, culprit) in HUGE.items():
    case(f"run-huge-{name}", lambda e, v=values: S("run", "--seconds", "0.05", *_sets(v),
                                                   "--out", out(e)),
         3, culprit, "diverged", out, check=said_when, subprocess={})
# a synapse weight: w_max lets 1e57 V through the learning rule's clip
case("run-huge-interlimb-weight",
     lambda e: S("run", "--seconds", "0.05", "--weights", _huge_interlimb(e), "--set",
                 "w_max=1e60*volt", "--out", out(e)),
     3, "interlimb.w", "diverged", out, check=said_when, subprocess={})
# shorter than the 10-step check: found by the check after the run, where Brian2's own check
# printed its warning
for cmd in (UNIT, RUN):
    case(f"{cmd}-huge-in-the-last-steps",
         lambda e, c=cmd: S(c, "--seconds", "0.005", *_sets(HUGE["motor-v"][0]), "--out",
                            out(e)),
         3, "motor.v", "diverged", out, check=said_when, subprocess={})
case("unit-huge-astrocyte", lambda e: S("unit", "--seconds", "0.05", *_sets(["IP3_star=1e60*nM"]),
                                        "--out", out(e)), 3, "astrocyte.IP3", "diverged", out)
case("train-huge-motor-v", lambda e: S("train", "--sessions", "2", *_sets(HUGE["motor-v"][0]),
                                       "--out", out(e)),
     3, "motor.v", "diverged", out, check=lambda e: diverged_row(out(e)))
# the limbs in stages (0 ms delays): each stage's motor group is scanned
case("run-huge-motor-v-staged",
     lambda e: S("run", "--seconds", "0.005", "--model",
                 f"interlimb_synapse={ROOT / 'models' / 'variants' / 'interlimb_authors_delays.toml'}",
                 *_sets(HUGE["motor-v"][0]), "--out", out(e)),
     3, "motor_FR.v", "diverged", out, check=said_when, subprocess={})
# just below the bound: a valid state, the run finishes
case("unit-large-but-valid", lambda e: S("unit", "--seconds", "0.02", "--set",
                                         "IP3_star=1e40*nM", "--out", out(e)),
     0, None, "complete", out)

# ---- checkpoints are data (a planted pickle runs nothing) and resume options
class _Unpickled:
    """Unpickling (or an eval of) what this pickles into touches EVIL_FLAG."""

    def __reduce__(self):
        return (os.system, (f"touch {EVIL_FLAG}",))


def _evil_pickle() -> bytes:
    import pickle
    return pickle.dumps({"fingerprint": "x", "settings": _Unpickled()})


def _old_format() -> bytes:
    """astrocpg's pickled checkpoint.pkl before format 2: MAGIC + sha256(body) + body."""
    body = _evil_pickle()
    return b"ASTROCPG-CHECKPOINT-1\n" + hashlib.sha256(body).hexdigest().encode() + b"\n" + body


def _npz_with_pickled_array(like: Path) -> bytes:
    import io
    with np.load(like) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["a0"] = np.array([_Unpickled(), None], dtype=object)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _planted(e: Env, which: str, how: str) -> Path:
    """A copy of a training (``which="train"``) or of the study with its run made pending,
    holding a malicious checkpoint (``how``: old-format, pickle-named-npz, npz-pickled-array)."""
    def make() -> Path:
        d = e.copy(which, f"{which}_{how}")
        run = d
        if which == "study":
            (run,) = [p for p in (d / "runs").iterdir() if p.is_dir()]
            status = json.loads((run / "status.json").read_text())
            status["state"] = "stopped"  # a rerun resumes it from its checkpoint
            (run / "status.json").write_text(json.dumps(status))
        new, old = run / "checkpoint.npz", run / "checkpoint.pkl"
        if how == "old-format":
            new.unlink()
            old.write_bytes(_old_format())
        elif how == "pickle-named-npz":
            new.write_bytes(_evil_pickle())
        elif how == "npz-pickled-array":
            new.write_bytes(_npz_with_pickled_array(new))
        return d
    return e._once(f"planted:{which}:{how}", make)


def _recorded(e: Env, model: Path | None = None) -> Path:
    """A finished 1-session training that records (every 1, stride 10, motor spikes,
    motor_Ca); with ``model``, trained with that interlimb_synapse model file."""
    def make() -> Path:
        d = e.tmp / ("recorded" if model is None else "with_model")
        extra = [] if model is None else ["--model", f"interlimb_synapse={model}"]
        _ok(["train", "--sessions", "1", "--seed", "3", *SHORT, "--record-every", "1",
             "--record-stride", "10", "--spikes", "motor", "--traces", "motor_Ca", *extra,
             "--out", str(d), "--no-progress"])
        return d
    return e._once(f"recorded:{model}", make)


def _builtin_interlimb_file(e: Env) -> Path:
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.models.files import model_to_toml
    return e.file("builtin.toml", model_to_toml(DEFAULT_MODELS.interlimb_synapse))


def _study_run(e: Env, how: str) -> Path:
    (run,) = [p for p in (_planted(e, "study", how) / "runs").iterdir() if p.is_dir()]
    return run


AUTHORS_DELAYS = ROOT / "models" / "variants" / "interlimb_authors_delays.toml"
for how, named in (("old-format", "checkpoint.pkl"), ("pickle-named-npz", "checkpoint.npz"),
                   ("npz-pickled-array", "checkpoint.npz")):
    case(f"train-resume-malicious-{how}",
         lambda e, h=how: S("train", "--resume", _planted(e, "train", h)), 2,
         lambda e, h=how, n=named: str(_planted(e, "train", h) / n), "unchanged",
         lambda e, h=how: _planted(e, "train", h), check=not_evaluated)
    case(f"study-rerun-malicious-{how}",
         lambda e, h=how: S("study", e.file("tiny.toml", TINY_STUDY), "--out",
                            _planted(e, "study", h), "--workers", "1", "--no-progress"), 2,
         lambda e, h=how, n=named: str(_study_run(e, h) / n), "unchanged",
         lambda e, h=how: _planted(e, "study", h),
         check=not_evaluated)
case("train-resume-old-format-says-so",
     lambda e: S("train", "--resume", _planted(e, "train", "old-format")), 2, "old format",
     "unchanged", lambda e: _planted(e, "train", "old-format"), check=not_evaluated)
case("train-out-on-an-old-format-folder",
     lambda e: S("train", "--out", _planted(e, "train", "old-format")), 2, "old format",
     "unchanged", lambda e: _planted(e, "train", "old-format"), check=not_evaluated)
for option, value, words in (("--record-stride", "5", "--record-stride"),
                             ("--record-every", "2", "--record-every"),
                             ("--spikes", "motor,astrocyte", "--spikes"),
                             ("--traces", "astrocyte_Ca", "--traces"),
                             ("--trace-dtype", "float64", "--trace-dtype")):
    case(f"train-resume-{option[2:]}-differs",
         lambda e, o=option, v=value: S("train", "--resume", _recorded(e), o, v), 2, words,
         "unchanged", lambda e: _recorded(e))
    case(f"train-resume-{option[2:]}-on-a-run-that-records-nothing",
         lambda e, o=option, v=value: S("train", "--resume", e.copy("train"), o, v), 2,
         option, "unchanged", lambda e: e.copy("train"))
case("train-resume-record-stride-same", lambda e: S("train", "--resume", _recorded(e),
                                                    "--record-stride", "10"), 2,
     "already finished", "unchanged", lambda e: _recorded(e))
case("train-trace-dtype-without-record-every",
     lambda e: S("train", "--trace-dtype", "float64", "--out", out(e)), 2, "--trace-dtype",
     "absent", out)
case("train-trace-dtype-float16", lambda e: S("train", "--record-every", "1", "--trace-dtype",
                                              "float16", "--out", out(e)), 2, "--trace-dtype",
     "absent", out)
case("run-session-trace-dtype-float16",
     lambda e: S("run", "--weights", e.copy("train"), "--session", "1", "--trace-dtype",
                 "float16", "--out", out(e)), 2, "--trace-dtype", "absent", out)
case("train-record-stride-without-record-every",
     lambda e: S("train", "--record-stride", "5", "--out", out(e)), 2, "--record-stride",
     "absent", out)
case("train-resume-set-other-value", lambda e: S("train", "--resume", e.copy("train"), "--set",
                                                 "L_max=0.3*second"), 2, "--set L_max",
     "unchanged", lambda e: e.copy("train"))
# recorded as 0.2*second: the same quantity spelled otherwise passes (the next check speaks)
case("train-resume-set-same-value-in-ms", lambda e: S("train", "--resume", e.copy("train"),
                                                      "--set", "L_max=200*ms"), 2,
     "already finished", "unchanged", lambda e: e.copy("train"))
case("train-resume-model-file-given-to-a-built-in-run",
     lambda e: S("train", "--resume", e.copy("train"), "--model",
                 f"interlimb_synapse={AUTHORS_DELAYS}"), 2, "--model interlimb_synapse",
     "unchanged", lambda e: e.copy("train"))
case("train-resume-model-file-respelled",  # a comment added: the same model, accepted
     lambda e: S("train", "--resume", _recorded(e, AUTHORS_DELAYS), "--model",
                 f"interlimb_synapse={e.file('respelled.toml', '# mine' + chr(10) + AUTHORS_DELAYS.read_text())}"),
     2, "already finished", "unchanged", lambda e: _recorded(e, AUTHORS_DELAYS))
case("train-resume-model-file-changed",
     lambda e: S("train", "--resume", _recorded(e, AUTHORS_DELAYS), "--model",
                 f"interlimb_synapse={_builtin_interlimb_file(e)}"),
     2, "--model interlimb_synapse: that run was trained with another interlimb_synapse model",
     "unchanged", lambda e: _recorded(e, AUTHORS_DELAYS))
case("train-resume-equations-changed",
     lambda e: S("train", "--resume", e.copy("train"), "--equations",
                 f"motor_neuron={e.equations('motor_neuron', lambda t: t.replace('/tau_motor', '/(2*tau_motor)'))}"),
     2, "--equations motor_neuron", "unchanged", lambda e: e.copy("train"))
for option, value in (("--sessions", "1"), ("--trials", "2"), ("--no-astrocytes", None),
                      ("--overwrite", None)):
    case(f"train-resume-{option[2:]}-differs",
         lambda e, o=option, v=value: S("train", "--resume", e.copy("train"), o,
                                        *([v] if v else [])), 2, option, "unchanged",
         lambda e: e.copy("train"))

# ---- study integrity, bounds on work, one line always (studyint)
_HOLDERS: list[subprocess.Popen] = []


def _kill_holders() -> None:
    while _HOLDERS:
        p = _HOLDERS.pop()
        p.kill()
        p.wait()


import atexit as _atexit  # noqa: E402

_atexit.register(_kill_holders)


def held_study(e: Env) -> Path:
    """A copy of the tiny study as while it runs: another process holds its folder (the study's
    process) and its run folder (the worker training it)."""
    def make() -> Path:
        d = e.copy("study", "study_held")
        run = d / "runs" / "astro__seed1"
        code = ("import time\nfrom astrocpg.studies.outputs.folder import FolderLock\n"
                f"a = FolderLock({str(d)!r}).acquire()\n"
                f"b = FolderLock({str(run)!r}, inside={str(d)!r}).acquire()\n"
                "print('held', flush=True)\ntime.sleep(300)\n")
        p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
        _HOLDERS.append(p)
        assert p.stdout is not None and p.stdout.readline().strip() == "held"
        return d
    return e._once("held_study", make)


def held_fresh_study(e: Env) -> Path:
    """A study folder as in its first seconds: another process holds it, and it has no
    manifest yet (a study writes it at the end)."""
    def make() -> Path:
        d = e.copy("study", "study_fresh")
        (d / "manifest.json").unlink()
        code = ("import time\nfrom astrocpg.studies.outputs.folder import FolderLock\n"
                f"a = FolderLock({str(d)!r}).acquire()\n"
                "print('held', flush=True)\ntime.sleep(300)\n")
        p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
        _HOLDERS.append(p)
        assert p.stdout is not None and p.stdout.readline().strip() == "held"
        return d
    return e._once("held_fresh_study", make)


def released(e: Env) -> None:
    _kill_holders()


def held_run(e: Env) -> Path:
    return held_study(e) / "runs" / "astro__seed1"


def fake_server(greeting: bytes | None) -> str:
    """tcp://127.0.0.1:PORT of a server that greets each connection with ``greeting`` (None:
    says nothing), e.g. an HTTP server's answer where a Dask scheduler was expected."""
    import socket
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)

    def serve() -> None:
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            if greeting is not None:
                try:
                    conn.sendall(greeting)
                except OSError:
                    pass
            threading.Timer(10.0, conn.close).start()

    threading.Thread(target=serve, daemon=True).start()
    return f"tcp://127.0.0.1:{srv.getsockname()[1]}"


def failures_named(e: Env) -> None:
    """A failed study run: failures.csv exists (the one line points to it)."""
    assert (out(e) / "failures.csv").is_file()


DELAY_STUDY = (study_text(batch=1) + '[sweep.axes]\ndelay_FR_FL = ["1*ms", "0*ms"]\n')
TERRAIN_STUDY = (study_text(batch=1) + 'terrain_height = "0.01*meter"\n'
                 '[sweep.axes]\nterrain_length = ["0.5*meter", "0.001*meter"]\n')
FINE_WORLDS = '[worlds.rough]\nterrain_height = "0.01*meter"\nterrain_length = "0.001*meter"\n'
TOO_MANY_WORKERS = str(4 * (os.cpu_count() or 1) + 1)
EXIT_BASE = 'r_IP3 = "1e306*umolar/second"\n'  # a study run that diverges: exit 3

# a study's run folders are its workers' while they train, the study folder its own
case("study-held-run-train-resume", lambda e: S("train", "--resume", held_run(e)), 2,
     "in use", "unchanged", held_study, check=released)
case("study-held-run-out-overwrite", lambda e: S("run", "--out", held_run(e), "--overwrite"), 2,
     "in use", "unchanged", held_study, check=released)
case("study-held-runs-folder-overwrite",
     lambda e: S("run", "--out", held_study(e) / "runs", "--overwrite"), 2, "lies inside",
     "unchanged", held_study, check=released)
case("study-held-new-subfolder", lambda e: S("unit", "--out", held_study(e) / "runs" / "mine"),
     2, "lies inside", "unchanged", held_study, check=released)
case("study-held-train-into-subfolder",
     lambda e: S("train", "--out", held_study(e) / "runs" / "mine"), 2, "lies inside",
     "unchanged", held_study, check=released)
case("study-held-plot-run", lambda e: S("plot", held_run(e)), 2, "in use", "unchanged",
     held_study, check=released)
case("study-held-power-run", lambda e: S("power", held_run(e)), 2, "in use", "unchanged",
     held_study, check=released)
case("study-held-report", lambda e: S("report", held_study(e)), 2, "in use", "unchanged",
     held_study, check=released)
case("study-held-evaluate", lambda e: S("evaluate", held_study(e), "--seconds", "0.05",
                                        "--no-progress"), 2, "in use", "unchanged",
     held_study, check=released)
case("study-held-rerun", lambda e: S("study", e.study(TINY_STUDY), "--out", held_study(e),
                                     "--workers", "1", "--no-progress"), 2, "in use",
     "unchanged", held_study, check=released)
case("study-held-export-into", lambda e: S("export", e.copy("run"), "--out",
                                           held_study(e) / "x.nwb"), 2, "in use", "unchanged",
     held_study, check=released)
def _status_fifo(e: Env) -> Path:
    """A study copy whose run's sessions.csv is a FIFO (no writer)."""
    def make() -> Path:
        d = e.copy("study", "study_fifo")
        p = next((d / "runs").iterdir()) / "sessions.csv"
        p.unlink()
        os.mkfifo(p)
        return d
    return e._once("status_fifo", make)


def _status_corrupt(e: Env) -> Path:
    """A study copy whose study.json gives a run -10 sessions."""
    def make() -> Path:
        d = e.copy("study", "study_corrupt")
        index = json.loads((d / "study.json").read_text())
        for spec in index["specs"].values():
            spec["n_sessions"] = -10
        (d / "study.json").write_text(json.dumps(index))
        return d
    return e._once("status_corrupt", make)


# --status reads: a FIFO is refused (was: waited on for ever), a corrupt count named (was
# "-1000.0%")
case("study-status-fifo-in-a-run", lambda e: S("study", "--status", _status_fifo(e)), 2,
     "sessions.csv: is not a regular file (a FIFO)", "none")
case("study-status-corrupt-session-count", lambda e: S("study", "--status", _status_corrupt(e)),
     2, "study.json: run astro__seed1: n_sessions is -10", "none")
# a cell that diverges names its world and its controller (was: the MuJoCo warning alone)
SHOVE = ('[worlds.shove]\npush_force = "1e15*newton"\npush_time = "0.02*second"\n'
         'push_duration = "0.05*second"\n')
case("evaluate-cell-diverges",
     lambda e: S("evaluate", e.copy("train"), "--worlds", e.file("shove.toml", SHOVE),
                 "--seconds", "0.1", "--repeats", "1", "--no-progress", "--out", out(e)), 3,
     "world 'shove', controller train (condition ", "absent", out)
# an empty study file (or comments alone) is refused naming it (was: 400 sessions of defaults)
case("study-file-empty", lambda e: S("study", e.study(""), "--out", out(e)), 2,
     "s.toml: is empty", "absent", out)
case("study-file-comments-alone", lambda e: S("study", e.study("# nothing yet\n\n"),
                                              "--out", out(e)), 2, "s.toml: is empty",
     "absent", out)
# a run that fails at its first write: the study's one line names the file (no worker's
# "Compute Failed" block with its traceback)
case("study-run-fails-at-its-first-write",
     lambda e: S("study", e.study(TINY_STUDY), "--out", out(e), "--workers", "1",
                 "--no-progress"), 1, "manifest.json", "none", out,
     subprocess={"rlimit_fsize": 40_960})
# a study that is running is "in use", whatever its folder holds yet (was: "not an astrocpg
# output" for --overwrite before its manifest; "belongs to another study" for a second study)
case("study-held-overwrite-before-its-manifest",
     lambda e: S("study", e.study(TINY_STUDY), "--out", held_fresh_study(e), "--overwrite",
                 "--workers", "1", "--no-progress"), 2, "in use", "unchanged",
     held_fresh_study, check=released)
case("study-held-another-study-into-it",
     lambda e: S("study", e.study(study_text(name='"other"')), "--out", held_study(e),
                 "--workers", "1", "--no-progress"), 2, "in use", "unchanged", held_study,
     check=released)
case("study-held-another-study-into-it-before-its-manifest",
     lambda e: S("study", e.study(study_text(name='"other"')), "--out", held_fresh_study(e),
                 "--workers", "1", "--no-progress"), 2, "in use", "unchanged",
     held_fresh_study, check=released)
# every point's model settings before any run: named with the point and the parameter
case("study-point-invalid-delay-table", lambda e: S("study", e.study(DELAY_STUDY), "--out",
                                                    out(e), "--workers", "1"),
     2, "delay_FR_FL=0*ms", "absent", out)
case("study-point-terrain-grid-too-fine", lambda e: S("study", e.study(TERRAIN_STUDY), "--out",
                                                      out(e), "--workers", "1"),
     2, "terrain_length", "absent", out)
case("study-diverged-run-one-line-exit-3",
     lambda e: S("study", e.study(study_text(batch=1) + EXIT_BASE), "--out", out(e),
                 "--workers", "1", "--no-progress"),
     3, "failures.csv", "none", out, check=failures_named)
# unbounded work refused up front
case("study-evaluate-repeats-beyond-memory",
     lambda e: S("study", e.study(study_text() + "[evaluate]\nrepeats = 1000000000\n"),
                 "--out", out(e)), 2, "[evaluate]", "absent", out)
case("video-fps-1e9", lambda e: S("video", e.copy("run"), "--fps", "1e9"), 2, "--fps",
     "unchanged", lambda e: e.copy("run"))
case("video-speed-tiny", lambda e: S("video", e.copy("run"), "--speed", "1e-9"), 2, "--speed",
     "unchanged", lambda e: e.copy("run"))
case("run-terrain-grid-too-fine", lambda e: S("run", "--set", "terrain_height=0.01*meter",
                                              "--set", "terrain_length=1e-4*meter", "--out",
                                              out(e)), 2, "world.terrain_length", "absent", out)
case("evaluate-world-terrain-grid-too-fine",
     lambda e: S("evaluate", e.copy("train"), "--worlds", e.file("w.toml", FINE_WORLDS),
                 "--seconds", "0.05", "--no-progress", "--out", out(e)),
     2, "terrain_length", "absent", out)
case("study-workers-beyond-the-cores", lambda e: S("study", e.study(study_text()), "--workers",
                                                   TOO_MANY_WORKERS, "--out", out(e)),
     2, "--workers", "absent", out)
case("evaluate-workers-beyond-the-cores",
     lambda e: S("evaluate", e.copy("train"), "--workers", TOO_MANY_WORKERS, "--out", out(e)),
     2, "--workers", "absent", out)
case("study-scheduler-silent", lambda e: S("study", e.study(study_text()), "--scheduler",
                                           fake_server(None), "--out", out(e)),
     2, "--scheduler", "absent", out)
case("study-scheduler-speaks-http",
     lambda e: S("study", e.study(study_text()), "--scheduler",
                 fake_server(b"HTTP/1.1 400 Bad Request\r\n\r\n"), "--out", out(e)),
     2, "not a Dask scheduler", "absent", out)
case("study-scheduler-malformed", lambda e: S("study", e.study(study_text()), "--scheduler",
                                              "nonsense", "--out", out(e)),
     2, "--scheduler nonsense", "absent", out)
# one line, always
case("run-weights-empty-csv", lambda e: S("run", "--weights", e.file("empty.csv", ""), "--out",
                                          out(e)), 2, "empty.csv", "absent", out)
case("unit-model-attribute-in-reset",
     lambda e: S("unit", "--model", "motor_neuron=" + str(e.file(
         "mn.toml", _dumped("motor_neuron").replace(
             'reset = "v = v_motor_rest; Ca += r_Ca"',
             'reset = "v = v_motor_rest; Ca += exp.exp(1)*r_Ca"'))), "--out", out(e)),
     2, "motor_neuron.reset", "absent", out)
case("unit-equations-parse-error-keeps-the-text",
     lambda e: S("unit", "--equations", "motor_neuron=" + str(e.file(
         "eq.txt", "dv/dt = -v/(9*ms) : volt (unknown\n")), "--out", out(e)),
     2, "column 26", "absent", out)
case("video-disk-full", lambda e: S("video", e.copy("run"), "--size", "640", "480", "--fps",
                                    "1000", "--speed", "0.05", "--out",
                                    e.tmp / "small" / "v.mp4"), 1, "No space left", "absent",
     lambda e: e.tmp / "small" / "v.mp4", subprocess={"tmpfs": "small", "size": "4k"},
     check=no_temporaries_beside(lambda e: e.tmp / "small" / "v.mp4"))
# ---- one door into the models: a model file must declare what the framework reads from it
case("run-model-file-renames-a-parameter-the-network-reads",
     lambda e: S("run", "--model", "torque=" + str(e.file(
         "renamed.toml", _dumped("torque").replace("I_thigh = {", "I_hip = {"))),
                 "--out", out(e)),
     2, "renamed.toml): lacks I_thigh, which the framework reads", "absent", out)
# (before: refused only when the network was built, as "torque.I_thigh: unknown parameter")
case("run-model-file-lacks-a-parameter-the-network-reads",
     lambda e: S("run", "--model", "torque=" + str(e.file(
         "dropped.toml", "".join(line for line in _dumped("torque").splitlines(True)
                                 if not line.startswith("I_thigh =")))), "--out", out(e)),
     2, "dropped.toml): lacks I_thigh, which the framework reads", "absent", out)
case("study-model-file-lacks-a-parameter-the-network-reads",
     lambda e: S("study", e.study(study_text() + '[models]\ntorque = "calf.toml"\n')
                 if e.file("calf.toml", "".join(line for line in
                                                _dumped("torque").splitlines(True)
                                                if not line.startswith("I_calf =")))
                 else None, "--out", out(e)),
     2, "calf.toml): lacks I_calf, which the framework reads", "absent", out)


def _dumped(model: str) -> str:
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.models.files import model_to_toml
    return model_to_toml(dict(DEFAULT_MODELS.items())[model])


# ---------------------------------------------------------------- running a case
def sha_tree(root: Path) -> dict[str, str]:
    """relative path -> sha256 of every file below ``root`` (hidden ones too), or of ``root``
    itself if it is a file."""
    if root.is_file():
        return {".": hashlib.sha256(root.read_bytes()).hexdigest()}
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def run_in_process(argv: list[str], capsys) -> tuple[int, str, str]:
    try:
        code = main(argv)
    except SystemExit as e:  # argparse
        code = e.code if isinstance(e.code, int) else 1
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _mount_prefix(e: Env, spec: dict[str, Any]) -> list[str]:
    unshare = shutil.which("unshare")
    where = e.tmp / spec["tmpfs"]
    where.mkdir(exist_ok=True)
    opts = ("ro," if spec.get("ro") else "") + f"size={spec['size']}"
    probe = subprocess.run([unshare or "unshare", "-m", "--propagation", "private", "mount",
                            "-t", "tmpfs", "-o", opts, "tmpfs", str(where)],
                           capture_output=True)
    if unshare is None or probe.returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs a mount namespace)")
    return [unshare, "-m", "--propagation", "private", "sh", "-c",
            f'mount -t tmpfs -o {opts} tmpfs "{where}" && exec "$@"', "sh"]


def run_in_child(argv: list[str], e: Env, spec: dict[str, Any]) -> tuple[int, str, str]:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    prefix: list[str] = []
    if spec.get("tmpdir"):
        tmpdir = e.tmp / "tmpdir"
        tmpdir.mkdir()
        env["TMPDIR"] = str(tmpdir)
    if "tmpfs" in spec:
        prefix = _mount_prefix(e, spec)

    def limits() -> None:
        if "rlimit_fsize" in spec:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (spec["rlimit_fsize"],
                                                       resource.RLIM_INFINITY))

    proc = subprocess.run([*prefix, sys.executable, "-m", "astrocpg.studies.cli", *argv],
                          capture_output=True, text=True, env=env, preexec_fn=limits,
                          cwd=e.tmp, timeout=600)
    if spec.get("tmpdir"):
        left = [n for n in os.listdir(e.tmp / "tmpdir") if n.startswith("brian")]
        assert not left, f"Brian2 left {left} in the temp folder"
    return proc.returncode, proc.stdout, proc.stderr


@pytest.mark.parametrize("c", [c.param() for c in CASES])
def test_case(c: Case, fx, tmp_path, capsys, monkeypatch) -> None:
    e = Env(tmp_path, fx)
    monkeypatch.chdir(tmp_path)  # stray files (MUJOCO_LOG.TXT, out/...) would land here
    EVIL_FLAG.unlink(missing_ok=True)
    argv = c.argv(e)
    target = c.target(e) if c.target else None
    before = sha_tree(target) if c.state == "unchanged" else None
    if c.state == "absent":
        assert not os.path.lexists(target), f"{target} exists before the case"
    if c.subprocess is not None:
        code, stdout, stderr = run_in_child(argv, e, c.subprocess)
    else:
        code, stdout, stderr = run_in_process(argv, capsys)
    lines = [x for x in stderr.splitlines() if x.strip()]
    assert "Traceback" not in stdout + stderr, stderr
    if c.code != 0:
        assert len(lines) == 1, f"expected one line on stderr, got:\n{stderr}"
        assert lines[0].startswith("astrocpg:"), lines[0]
        culprit = c.culprit(e) if callable(c.culprit) else c.culprit
        if culprit:
            assert culprit in lines[0], (culprit, lines[0])
    else:
        assert not any(x.startswith("astrocpg:") for x in lines), stderr
    assert code == c.code, (code, stderr)
    if c.state == "absent":
        assert not os.path.lexists(target), f"{target} was left behind"
        if target.parent.is_dir():
            left = [n for n in os.listdir(target.parent) if parse_temp_name(n)]
            assert not left, f"temporaries left beside {target}: {left}"
    elif c.state == "unchanged":
        assert sha_tree(target) == before, f"{target} changed"
    elif c.state == "complete":
        verify(target)
    elif c.state == "diverged":  # written whole, and it says so: never a finished-looking one
        manifest = verify(target, strict=False)
        assert manifest["results"].get("status") == "diverged", manifest["results"]
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists(), "MuJoCo wrote its log in the cwd"
    if c.check is not None:
        c.check(e)


def test_corpus_size() -> None:
    commands = {c.id.split("-")[0] for c in CASES}
    assert len(CASES) >= 60
    assert {"unit", "run", "train", "gait", "plot", "power", "study", "report", "export",
            "describe", "robot", "video"} <= commands


@pytest.mark.parametrize("command", [[], ["unit"], ["run"], ["train"], ["gait"], ["plot"],
                                     ["video"], ["study"], ["report"], ["power"], ["export"],
                                     ["describe"], ["robot", "export"]],
                         ids=lambda c: " ".join(c) or "astrocpg")
def test_help_lists_exit_codes(command, capsys) -> None:
    with pytest.raises(SystemExit) as e:
        main([*command, "--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    for code, word in (("0", "done"), ("1", "environment"), ("2", "bad input"),
                       ("3", "diverged"), ("130", "interrupted")):
        assert any(line.split()[:1] == [code] and word in line for line in text.splitlines()), \
            (code, text)
    readme = (ROOT / "README.md").read_text()
    for code in ("130", "diverged", "environment"):
        assert code in readme
    assert "exit code" in readme.lower()


@pytest.mark.parametrize("typed", ["9*msec", "9*mv", "9 Ms", "9*milisecond"])
def test_a_unit_message_suggests_a_spelling_the_parser_accepts(typed, capsys) -> None:
    import re
    code, _, err = run_in_process(["describe", "motor_neuron", "--set", f"tau_motor={typed}"],
                                  capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    suggested = re.search(r"did you mean ([A-Za-z_]\w*)", err)
    assert suggested, err
    unit = suggested.group(1)
    code, _, err = run_in_process(["describe", "motor_neuron", "--set",
                                   f"tau_motor=9*{unit}"], capsys)
    # the suggestion parses; the dimension may still be wrong for this parameter (mV), but
    # then the message says so in one line rather than "unknown unit"
    assert code in (0, 2) and "unknown unit" not in err, err


def test_mujoco_warnings_stay_out_of_the_working_folder_and_stdout(tmp_path) -> None:
    e = Env(tmp_path, {})
    argv = S("run", "--seconds", "0.02", "--robot", e.geared_robot(), "--out", tmp_path / "o")
    code, stdout, stderr = run_in_child(argv, e, {})
    assert code == 3, stderr
    assert "MuJoCo" in one_line_of(stderr)
    assert "WARNING" not in stdout, stdout
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def one_line_of(stderr: str) -> str:
    lines = [x for x in stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("astrocpg:"), stderr
    return lines[0]


def _parameters() -> list[tuple[str, str, str]]:
    import brian2
    from astrocpg.models import DEFAULT_MODELS
    out = []
    for model, m in DEFAULT_MODELS.items():
        for name in m.parameters:
            dims = brian2.get_dimensions(m.parameters[name].value)
            out.append((model, name, "" if dims.is_dimensionless
                        else "*" + str(brian2.get_unit(dims))))
    return out


@pytest.mark.parametrize("value", ["inf", "-inf", "nan", "1e309"])
def test_every_parameter_refuses_non_finite_values(value, capsys) -> None:
    """nan, inf and 1e309 (inf once read) are refused for every parameter, with its unit."""
    accepted = []
    for model, name, unit in _parameters():
        code, _, err = run_in_process(["describe", model, "--set", f"{name}={value}{unit}"],
                                      capsys)
        lines = [x for x in err.splitlines() if x.strip()]
        if code != 2 or len(lines) != 1 or name not in lines[0]:
            accepted.append((name, code, err))
    assert not accepted, accepted


# The whole table (and every signal case) is long: CI runs it (CI=true); `pytest -m slow` here.
pytestmark = pytest.mark.slow
