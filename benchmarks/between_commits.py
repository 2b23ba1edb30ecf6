"""The hot loop's cost at two commits, measured in turns on this machine:

    python benchmarks/between_commits.py BEFORE [AFTER] [--repeats 3] [--seconds 3]
                                         [--codegen cython numpy] [--script own|this]
                                         [--json FILE]

Each commit's own ``benchmarks/speed.py --trials 20`` (``--script this``: this checkout's, for
both) is run in a fresh process against that commit's own package, imported first on ``PYTHONPATH`` (so the installed package is not used):
BEFORE from a temporary ``git worktree``, AFTER from this checkout (or a worktree too, when it
is named). The runs alternate (before, after, before, ...), so a slow spell of the machine lands
on both. Printed: each repeat's trial-step / ``mj_step`` ratio per code generation target, the
medians, their spread (max/min - 1) and the change after/before. The ratio to MuJoCo's own step,
measured in the same process, is steadier than a time on a shared machine; still, read a change
smaller than the spread as no change. speed.py times ``mj_step`` on the loop's own states from
2026-12-05 (before: with held controls, about 6 % cheaper on Cython); two scripts that time it
differently are not compared (exit 2: give ``--script this``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], check=True, capture_output=True,
                          text=True).stdout.strip()


def importable(tree: Path, where: Path, name: str) -> Path:
    """A folder to put first on ``PYTHONPATH`` so that ``import astrocpg`` is ``tree``'s code
    (it holds ``astrocpg``, a link to the tree: the package maps to the repository's root),
    whatever package is installed."""
    path = where / f"path_{name}"
    path.mkdir()
    (path / "astrocpg").symlink_to(tree, target_is_directory=True)
    return path


def checkout(rev: str, where: Path) -> tuple[Path, Path]:
    """A worktree of ``rev`` and its :func:`importable` folder."""
    tree = where / f"tree_{rev[:12]}"
    _git("worktree", "add", "--detach", "-f", str(tree), rev)
    return tree, importable(tree, where, rev[:12])


def denominator(stdout: str) -> str:
    """How the speed.py that printed ``stdout`` timed ``mj_step``: on the loop's states (its
    closing table has an ``x held`` column beside) or with held controls (earlier scripts)."""
    heads = [line for line in stdout.splitlines() if line.startswith("point ")]
    return "the loop's states" if heads and "x held" in heads[-1] else "held controls"


def ratios(stdout: str, codegens: list[str]) -> dict[str, float]:
    """The ``x mj_step`` column of speed.py's last table, per target (20 trials)."""
    out: dict[str, float] = {}
    for line in stdout.splitlines():
        words = line.split()
        if len(words) >= 5 and words[0] in codegens and words[1:3] == ["20", "trials"]:
            try:
                out[words[0]] = float(words[5])
            except (IndexError, ValueError):
                continue
    missing = [c for c in codegens if c not in out]
    if missing:
        sys.exit(f"speed.py printed no 20-trial row for {missing}:\n{stdout[-2000:]}")
    return out


def measure(tree: Path, path: Path, codegens: list[str], seconds: float,
            script: Path | None = None) -> tuple[dict[str, float], str]:
    """The ratios of one run of ``tree``'s speed.py (or ``script``) against ``tree``'s package,
    and how that script timed ``mj_step`` (:func:`denominator`)."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env["PYTHONPATH"] = os.pathsep.join([str(path)] + [p for p in [env.get("PYTHONPATH")] if p])
    script = script or tree / "benchmarks" / "speed.py"
    cmd = [sys.executable, str(script), "--trials", "20",
           "--codegen", *codegens, "--seconds", f"{seconds:g}"]
    done = subprocess.run(cmd, env=env, cwd=tempfile.gettempdir(), capture_output=True,
                          text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} exited {done.returncode}:\n{done.stderr[-2000:]}")
    return ratios(done.stdout, codegens), denominator(done.stdout)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", help="a commit (anything git rev-parse reads)")
    ap.add_argument("after", nargs="?", default=None,
                    help="a commit (default: this checkout as it is, uncommitted changes too)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=3.0, help="simulated s per measurement")
    ap.add_argument("--codegen", nargs="+", default=["cython", "numpy"],
                    choices=["cython", "numpy"])
    ap.add_argument("--script", choices=["own", "this"], default="own",
                    help="each commit's own benchmarks/speed.py (default), or this checkout's "
                         "for both")
    ap.add_argument("--json", default=None, metavar="FILE")
    args = ap.parse_args()
    if args.repeats < 1:
        ap.error("--repeats must be at least 1")
    revs = {"before": _git("rev-parse", args.before)}
    revs["after"] = _git("rev-parse", args.after) if args.after else \
        _git("rev-parse", "HEAD") + ("+dirty" if _git("status", "--porcelain") else "")
    rows: dict[str, list[dict[str, float]]] = {"before": [], "after": []}
    script = Path(__file__).resolve().parent / "speed.py" if args.script == "this" else None
    how: dict[str, str] = {}
    started = time.time()
    with tempfile.TemporaryDirectory(prefix="between_commits_") as name:
        tmp = Path(name)
        trees = {"before": checkout(revs["before"], tmp)}
        trees["after"] = checkout(revs["after"], tmp) if args.after else \
            (ROOT, importable(ROOT, tmp, "checkout"))
        try:
            for k in range(args.repeats):
                for label in ("before", "after"):
                    r, how[label] = measure(*trees[label], args.codegen, args.seconds, script)
                    if len(set(how.values())) > 1:
                        print(f"the two speed.py time mj_step differently (before: "
                              f"{how['before']}, after: {how['after']}): their ratios are "
                              f"not comparable; give --script this", file=sys.stderr)
                        return 2
                    rows[label].append(r)
                    print(f"repeat {k + 1} {label:<6} " + "  ".join(
                        f"{c} {v:.2f} x mj_step" for c, v in r.items()), flush=True)
        finally:
            for label, (tree, _) in trees.items():
                if tree != ROOT:
                    subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                                    str(tree)], capture_output=True)
    summary = {}
    print(f"\ntrial-step / mj_step at 20 trials, {args.repeats} repeats each, "
          f"before {revs['before'][:10]}, after {revs['after'][:10]}")
    for c in args.codegen:
        b = [r[c] for r in rows["before"]]
        a = [r[c] for r in rows["after"]]
        s = {"before": b, "after": a, "median_before": statistics.median(b),
             "median_after": statistics.median(a),
             "spread_before": max(b) / min(b) - 1, "spread_after": max(a) / min(a) - 1}
        s["change"] = s["median_after"] / s["median_before"] - 1
        summary[c] = s
        print(f"{c:<7} before {s['median_before']:.2f} (spread {100 * s['spread_before']:.0f} %)"
              f"  after {s['median_after']:.2f} (spread {100 * s['spread_after']:.0f} %)"
              f"  change {100 * s['change']:+.1f} %")
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"benchmark": "benchmarks/between_commits.py", "argv": sys.argv,
             "date": time.strftime("%Y-%m-%d %H:%M"), "cpu_count": os.cpu_count(),
             "load_average_after": list(os.getloadavg()), "wall_s": round(time.time() - started),
             "commits": revs, "seconds": args.seconds, "script": args.script,
             "mj_step_timed_on": how["after"], "results": summary}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
