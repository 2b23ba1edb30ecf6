"""What a user pays for ``astrocpg run``'s default recording, end to end, write included.

    python benchmarks/recorded_run_cost.py [--trials 20] [--seconds 2 6] [--codegen cython]
        [--repeats 3] [--runs 2] [--json docs/benchmarks/recorded_run_cost.json]

Each measurement is the command as a user types it, in a fresh process:

    astrocpg run --trials 20 --codegen cython --seconds S --out DIR

once with the default recording (every spike, every trace at 1 ms as float32, the robot every
step; the files written, hashed into the manifest) and once recording nothing
(``--spikes none --traces none --robot-stride`` one sample per run). The figure is the CPU time
of that process (user + system, ``getrusage(RUSAGE_CHILDREN)``: the time other programs take on
the machine is not counted, but sharing a core with them slows a run: each command runs
``--runs`` times, interleaved, and the least CPU counts), at two durations; the slope between
them is the CPU per simulated trial-second, free of the start-up (imports, building the
network). ``ratio`` is the recorded slope over the unrecorded one (goal: at most 1.25).

Beside it, for the recorded run of the longer duration:

- ``write``: the CPU this process takes to write the same arrays again with astrocpg's own
  writers (``spikes.npz``, ``traces.npz``, ``robot.npz``) and to hash them for the manifest's
  inventory, as a share of the recorded run's CPU above the unrecorded one;
- ``MiB``: the folder's size on disk;
- ``load``: the wall time a reader pays for one trace, ``motor_Ca``: ``astrocpg.load(DIR)``
  (which checks every file against the manifest's sha256 and reads them) then
  ``.trace("motor_Ca")`` (a float64 Quantity), imports aside, and
  ``np.load(DIR/traces.npz)["motor_Ca"]`` alone (``np.load``).

A first unmeasured run builds (or finds) the Cython extensions, so that no measured run compiles.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MiB = 2.0 ** 20


def astrocpg_command() -> list[str]:
    """``astrocpg`` as the user runs it: the console script beside this Python, or the module."""
    script = Path(sys.executable).with_name("astrocpg")
    return [str(script)] if script.exists() else [sys.executable, "-m", "astrocpg"]


def command(seconds: float, trials: int, codegen: str, out: Path, record: bool) -> list[str]:
    cmd = astrocpg_command() + ["run", "--trials", str(trials), "--codegen", codegen,
                                "--seconds", f"{seconds:g}", "--out", str(out)]
    if not record:  # nothing recorded but the robot's one sample per run
        cmd += ["--spikes", "none", "--traces", "none",
                "--robot-stride", str(int(round(seconds * 1000)))]
    return cmd


def child_cpu(cmd: list[str]) -> float:
    """CPU seconds (user + system) of ``cmd`` and its children."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"{shlex.join(cmd)} exited {done.returncode}: {done.stderr.strip()[-500:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def write_cpu(folder: Path, scratch: Path) -> float:
    """CPU seconds to write ``folder``'s arrays again with astrocpg's writers and hash them for
    the manifest's inventory (what ``astrocpg run`` does after its loop, the figure aside)."""
    from astrocpg.studies.outputs.folder import inventory
    from astrocpg.studies.outputs.writing import save_npz, save_spikes_and_traces

    with np.load(folder / "spikes.npz") as z:
        s = {k: z[k] for k in z.files}
    with np.load(folder / "traces.npz") as z:
        t = {k: z[k] for k in z.files}
    with np.load(folder / "robot.npz") as z:
        robot = {k: z[k] for k in z.files}
    pops = [k[:-len("_times")] for k in s if k.endswith("_times")]
    spikes = {p: (s[f"{p}_times"], s[f"{p}_indices"]) for p in pops}
    traces = {k: (t[f"{k}_t"], t[k]) for k in t if not k.endswith("_t")}
    scratch.mkdir()
    c0 = time.process_time()
    save_spikes_and_traces(scratch, spikes, traces)
    save_npz(scratch / "robot.npz", robot)
    inventory(scratch)
    return time.process_time() - c0


def load_times(folder: Path) -> dict[str, float]:
    """Wall seconds to get motor_Ca, in a fresh process (nothing cached in Python; the file
    itself is in the page cache, as just written): ``np.load`` of traces.npz alone, and
    ``astrocpg.load`` (checks every file's sha256, reads them) then ``.trace`` (a float64
    Brian2 Quantity), the imports left out."""
    code = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np
t1 = time.perf_counter()
with np.load(sys.argv[1] + "/traces.npz") as z:
    v = z["motor_Ca"]
t2 = time.perf_counter()
import astrocpg, astrocpg.studies.commands.api, brian2  # imports apart: not the reading
t3 = time.perf_counter()
r = astrocpg.load(sys.argv[1])
tr = r.trace("motor_Ca")
t4 = time.perf_counter()
print(json.dumps({"np_load_s": t2 - t1, "astrocpg_load_s": t4 - t3}))
"""
    out = subprocess.run([sys.executable, "-c", code, str(folder)], check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def versions() -> dict[str, str]:
    from importlib import metadata

    out = {"python": platform.python_version()}
    for name in ("astrocpg", "brian2", "numpy", "mujoco", "cython"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def git_commit() -> str | None:
    import astrocpg

    root = Path(astrocpg.__file__).resolve().parent
    try:
        rev = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return (rev + ("+dirty" if dirty else "")) or None
    except (OSError, subprocess.SubprocessError):
        return None


def repeat(args: argparse.Namespace, tmp: Path, k: int) -> dict:
    cpu: dict[str, dict[float, float]] = {"recorded": {}, "unrecorded": {}}
    for j in range(args.runs):  # interleaved: a burst of other work lands on one of each
        for s in args.seconds:
            for label, record in (("recorded", True), ("unrecorded", False)):
                out = tmp / f"r{k}_{label}_{s:g}"
                if j:
                    shutil.rmtree(out)
                c = child_cpu(command(s, args.trials, args.codegen, out, record))
                cpu[label][s] = min(cpu[label].get(s, c), c)
    s1, s2 = min(args.seconds), max(args.seconds)
    trial_seconds = (s2 - s1) * args.trials
    slope = {label: (c[s2] - c[s1]) / trial_seconds for label, c in cpu.items()}
    longest = tmp / f"r{k}_recorded_{s2:g}"
    write = write_cpu(longest, tmp / f"r{k}_rewrite")
    extra = cpu["recorded"][s2] - cpu["unrecorded"][s2]
    row = {"cpu_s": {label: {f"{s:g}": round(v, 3) for s, v in c.items()}
                     for label, c in cpu.items()},
           "slope_s_per_trial_s": {label: round(v, 4) for label, v in slope.items()},
           "ratio": round(slope["recorded"] / slope["unrecorded"], 3),
           "write_cpu_s": round(write, 3),
           "write_share_of_recording": round(write / extra, 3) if extra > 0 else None,
           "write_share_of_run": round(write / cpu["recorded"][s2], 3),
           "folder_MiB": round(folder_bytes(longest) / MiB, 1),
           "traces_MiB": round((longest / "traces.npz").stat().st_size / MiB, 1)}
    row.update({k: round(v, 3) for k, v in load_times(longest).items()})
    for p in tmp.iterdir():  # keep the disk free for the next repeat
        shutil.rmtree(p, ignore_errors=True)
    return row


def pooled_slopes(rows: list[dict], trials: int) -> dict[str, float]:
    """Slopes (CPU s per simulated trial-second) from each command's least CPU over every
    repeat, and their ratio: the runs least slowed by other work on the machine."""
    out = {}
    for label in ("recorded", "unrecorded"):
        best = {float(s): min(r["cpu_s"][label][s] for r in rows) for s in rows[0]["cpu_s"][label]}
        (s1, c1), (s2, c2) = sorted(best.items())
        out[label] = (c2 - c1) / ((s2 - s1) * trials)
    out["ratio"] = out["recorded"] / out["unrecorded"]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seconds", type=float, nargs=2, default=[2.0, 6.0], metavar="S")
    ap.add_argument("--codegen", default="cython", choices=["numpy", "cython"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--runs", type=int, default=2,
                    help="runs of each command per repeat, the least CPU kept (default 2): "
                         "another program on the same core slows a run, never speeds it")
    ap.add_argument("--json", default=str(Path(__file__).resolve().parents[1] / "docs" /
                                          "benchmarks" / "recorded_run_cost.json"),
                    help="where the figures go (none: nowhere)")
    ap.add_argument("--label", default="", help="a word stored with the figures (e.g. before)")
    args = ap.parse_args()
    if args.seconds[0] == args.seconds[1]:
        ap.error("--seconds needs two different durations")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    shown = shlex.join(["astrocpg"] + command(max(args.seconds), args.trials, args.codegen,
                                              Path("DIR"), True)[len(astrocpg_command()):])
    print(f"{shown}  vs  the same with --spikes none --traces none --robot-stride S*1000")
    print(f"CPU of the child (user+sys), slope between {min(args.seconds):g} and "
          f"{max(args.seconds):g} s, per simulated trial-second")
    rows = []
    with tempfile.TemporaryDirectory(prefix="recorded_run_cost_") as name:
        tmp = Path(name)
        child_cpu(command(0.1, 1, args.codegen, tmp / "warm", True))  # build or find extensions
        shutil.rmtree(tmp / "warm")
        print(f"{'repeat':<7}{'rec ms':>8}{'off ms':>8}{'ratio':>7}{'write s':>9}{'write %':>9}"
              f"{'MiB':>7}{'load s':>8}{'np.load':>9}")
        for k in range(args.repeats):
            r = repeat(args, tmp, k)
            rows.append(r)
            sl = r["slope_s_per_trial_s"]
            share = r["write_share_of_recording"]
            print(f"{k:<7}{1e3 * sl['recorded']:>8.1f}{1e3 * sl['unrecorded']:>8.1f}"
                  f"{r['ratio']:>7.3f}{r['write_cpu_s']:>9.2f}"
                  f"{'' if share is None else f'{100 * share:.0f}%':>9}"
                  f"{r['folder_MiB']:>7.0f}{r['astrocpg_load_s']:>8.2f}{r['np_load_s']:>9.3f}",
                  flush=True)
    ratios = [r["ratio"] for r in rows]
    spread = (max(ratios) - min(ratios)) / float(np.median(ratios))
    pooled = pooled_slopes(rows, args.trials)
    print(f"ratio median {np.median(ratios):.3f} (goal 1.25), spread {100 * spread:.0f}% of it; "
          f"'write %': the write's share of what recording adds to the {max(args.seconds):g} s "
          f"run")
    print(f"pooled (each command's least CPU over all {args.repeats * args.runs} runs): "
          f"{1e3 * pooled['recorded']:.1f} against {1e3 * pooled['unrecorded']:.1f} ms per "
          f"simulated trial-second, ratio {pooled['ratio']:.3f}")
    if args.json != "none":
        doc = {"benchmark": "benchmarks/recorded_run_cost.py",
               "argv": sys.argv, "label": args.label,
               "command": shown,
               "unrecorded": "--spikes none --traces none --robot-stride S*1000",
               "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
               "machine": {"platform": platform.platform(),
                           "processor": platform.processor() or platform.machine(),
                           "cpu_count": os.cpu_count()},
               "versions": versions(), "astrocpg_commit": git_commit(),
               "trials": args.trials, "seconds": sorted(args.seconds), "codegen": args.codegen,
               "ratio_median": round(float(np.median(ratios)), 3),
               "pooled": {k: round(v, 4) for k, v in pooled.items()},
               "ratio_spread": round(spread, 3), "repeats": rows}
        path = Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(doc, indent=2) + "\n")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
