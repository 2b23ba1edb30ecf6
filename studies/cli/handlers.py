"""The command line's handlers, one per command: the parsed arguments as the Python API's
settings, the API function called (the same checks, the same manifest as ``ac.NAME(...)``),
its result printed; the return value is the exit code. The API is imported inside each
handler, so ``astrocpg --help`` does not load Brian2."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Callable

from ...errors import InputError, one_line


def model_args(args: argparse.Namespace) -> dict[str, Any]:
    """``--set``, ``--equations`` and ``--model`` as the API's ``overrides``, ``equations``
    and ``models`` (each file read once, here)."""
    from ...models.compose import read_equation_files, read_model_files
    return {"overrides": list(args.overrides), "equations": read_equation_files(args.equations),
            "models": read_model_files(getattr(args, "model_files", []))}


def population_args(args: argparse.Namespace) -> dict[str, Any]:
    """``--population FILE`` as the API's ``populations`` ({file: text}, each read once)."""
    from ...support.reading import read_text

    return {"populations": {f: read_text(f, culprit=f"--population {f}")
                            for f in getattr(args, "population_files", [])}}


def input_files(args: argparse.Namespace) -> list[str]:
    """The files --model and --equations MODEL=FILE and --population name: --out may not be or
    hold them."""
    items = [*getattr(args, "model_files", []), *getattr(args, "equations", [])]
    return ([item.partition("=")[2] for item in items if "=" in item]
            + list(getattr(args, "population_files", [])))


def _recording(args: argparse.Namespace) -> dict[str, Any]:
    """``--spikes`` and ``--traces``: what a simulation records."""
    return {"spikes": args.spikes, "traces": args.traces}


def unit_command(args: argparse.Namespace) -> int:
    from ...network.recording import overflow_words
    from ..commands.unit import format_rhythm, unit

    seed = 1 if args.seed is None else args.seed
    result = unit(seconds=args.seconds, seed=seed, trials=args.trials,
                  trace_dt=args.trace_dt, trace_dtype=args.trace_dtype, out=args.out,
                  overwrite=args.overwrite, progress=not args.no_progress,
                  inputs=input_files(args), workers=args.workers, **_recording(args),
                  **model_args(args), **population_args(args))
    for b, s in enumerate(result.summary["rhythm"]):
        print(format_rhythm(b, seed + b, s))
    if result.summary.get("trace_overflow"):
        print("warning: " + overflow_words(result.summary["trace_overflow"]))
    print(f"wrote {args.out}/")
    return 0


def run_command(args: argparse.Namespace) -> int:
    """``astrocpg run``; with ``--session``, the replay of a training's session (``ac.run``
    with ``session``, which takes the rest from the training)."""
    from ..commands.replay import format_replay
    from ..commands.run import format_run, run

    result = run(seconds=args.seconds, seed=args.seed, trials=args.trials, weights=args.weights,
                 trial=args.trial, robot=args.robot, trace_dt=args.trace_dt,
                 trace_dtype=args.trace_dtype, robot_stride=args.robot_stride, out=args.out,
                 overwrite=args.overwrite, progress=not args.no_progress, figure=args.figure,
                 session=args.session, inputs=input_files(args), workers=args.workers,
                 **_recording(args), **model_args(args), **population_args(args))
    if args.session is not None:
        print("\n".join(format_replay(result)))
        print(f"wrote {args.out}/ (the session: {args.out}/recordings/trial00_session0001/)")
        return 0
    print("\n".join(format_run(result, result.seed)))
    print(f"wrote {args.out}/" + ("" if args.figure else f" (figures: astrocpg plot {args.out})"))
    return 0


def train_command(args: argparse.Namespace) -> int:
    """``astrocpg train`` (``ac.train``) or ``train --resume DIR`` (``ac.resume``, which
    refuses an option given again that differs from the training's own). Only the options
    given are passed: the defaults are the API's."""
    from ..commands.resume import resume
    from ..commands.train import train
    from ..commands.train_summary import format_train
    from ..commands.trainer import TrainingStopped

    given = {key: value for key, value in (
        ("sessions", args.sessions), ("seed", args.seed), ("trials", args.trials),
        ("astrocytes", None if args.no_astrocytes is None else not args.no_astrocytes))
        if value is not None}
    common = dict(record_every=args.record_every, record_stride=args.record_stride,
                  trace_dtype=args.trace_dtype, progress=not args.no_progress,
                  workers=args.workers, **_recording(args), **given)
    try:
        if args.resume:
            result = resume(args.resume, out=args.out or None, overwrite=args.overwrite,
                            **common, **model_args(args), **population_args(args))
        else:
            result = train(out=args.out, overwrite=args.overwrite, inputs=input_files(args),
                           **common, **model_args(args), **population_args(args))
    except TrainingStopped as e:
        where = args.resume or args.out
        sys.stderr.write(f"astrocpg: training {e}; continue with astrocpg train --resume "
                         f"{where}\n")
        return 130
    for line in format_train(result):
        print(line)
    print(f"wrote {args.resume or args.out}/ (sessions.csv, weights.npz, checkpoint.npz, "
          f"manifest.json)")
    return 0


def evaluate_command(args: argparse.Namespace) -> int:
    from ..commands.api import evaluate
    from ..commands.evaluate import format_summary

    from ..commands.evaluate import format_baseline

    res = evaluate(args.dir, worlds=args.worlds, seconds=args.seconds, repeats=args.repeats,
                   seed=args.seed, conditions=args.condition, out=args.out,
                   overwrite=args.overwrite, progress=not args.no_progress,
                   workers=args.workers, scheduler=args.scheduler, session=args.session,
                   point=args.point, baseline=args.baseline,
                   **model_args(args), **population_args(args))
    for line in format_summary(res["summary"]):
        print(line)
    for line in format_baseline(res.get("baseline") or []):
        print(line)
    print(f"wrote {res['out']}/ (evaluation.csv, summary.csv, manifest.json)")
    return 0


def gait_command(args: argparse.Namespace) -> int:
    from ..commands.api import gait

    for line in gait(args.dir, seconds=args.seconds, repeats=args.repeats, seed=args.seed,
                     world=args.world, progress=not args.no_progress,
                     workers=args.workers, **model_args(args), **population_args(args)):
        print(line)
    return 0


def _overflow_warning(folder: str) -> None:
    """The warning a folder whose traces overflowed their type carries, printed."""
    from ...network.recording import overflow_words
    from ..outputs.writing import read_manifest

    over = (read_manifest(Path(folder)) or {}).get("results", {}).get("trace_overflow")
    if over:
        print("warning: " + overflow_words(over))


def plot_command(args: argparse.Namespace) -> int:
    from ..commands.view import plot

    written = plot(args.dir, trial=args.trial, window=args.window, fmt=args.format,
                   seconds=args.seconds, out=args.out, overwrite=args.overwrite,
                   progress=not args.no_progress)
    print(f"wrote {len(written)} figure(s): {', '.join(str(p) for p in written)}")
    _overflow_warning(args.dir)  # the figures draw what was recorded: infinities are gaps
    return 0


def video_command(args: argparse.Namespace) -> int:
    from ..commands.view import video

    res = video(args.dir, trial=args.trial, fps=args.fps, speed=args.speed, size=args.size,
                out=args.out, overwrite=args.overwrite, progress=not args.no_progress,
                panel=args.panel, start=args.start, stop=args.stop)
    print(f"wrote {res['path']} ({res['frames']} frames at {res['fps']:g} fps, "
          f"{res['seconds']:.1f} s; {seconds_text(res['start'])} to "
          f"{seconds_text(res['stop'])} s of the recording)")
    return 0


def _study_status(args: argparse.Namespace) -> int:
    from ..parameter_studies.api import study_status

    if args.file is not None:
        raise InputError("takes a study folder alone (astrocpg study --status DIR)",
                         culprit=f"--status {args.status} {args.file}")
    # --status reads a folder and runs nothing: an option that would act on a run is refused,
    # never ignored (--workers is the estimate's number of processes)
    given = [option for option, value in (
        ("--out", args.out), ("--seeds", args.seeds), ("--sessions", args.sessions),
        ("--set", args.overrides), ("--scheduler", args.scheduler), ("--codegen", args.codegen),
        ("--plan-from", args.plan_from),
        ("--overwrite", args.overwrite), ("--no-progress", args.no_progress)) if value]
    if given:
        raise InputError(f"reads a study folder and runs nothing: {given[0]} does not apply "
                         f"(only --workers, for the estimate)", culprit=f"--status {args.status}")
    print(study_status(args.status, workers=args.workers).text())
    return 0


def study_command(args: argparse.Namespace) -> int:
    """``astrocpg study`` (``ac.study``, its plan printed before the runs start), or
    ``study --status DIR`` (``ac.study_status``)."""
    from ..parameter_studies.api import study

    if args.status is not None:
        return _study_status(args)
    if args.file is None:
        raise InputError("a study file or a built-in study's name is needed (or --status DIR)",
                         culprit="astrocpg study")
    try:
        res = study(args.file, out=args.out or None, seeds=args.seeds, sessions=args.sessions,
                    overrides=args.overrides, workers=args.workers, scheduler=args.scheduler,
                    plan_from=args.plan_from, overwrite=args.overwrite,
                    progress=not args.no_progress, announce=print)
    except KeyboardInterrupt:
        sys.stderr.write("astrocpg: study interrupted; run the same command again to "
                         "continue (finished runs are kept)\n")
        return 130
    return _study_outcome(res)


def _study_outcome(res: dict[str, Any]) -> int:
    """What a study's result says on stdout and stderr, and its exit code: 0 every run
    finished, 3 every run left diverged (a rerun diverges again), 1 runs left to retry."""
    from ..parameter_studies.layout import RESULTS

    counts = ", ".join(f"{v} {k}" for k, v in res["counts"].items())
    print(f"runs: {counts}; {res['rows']} rows in {res['out'] / RESULTS}")
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
            f"astrocpg: study {res['name']}: {len(diverged)} of {res['runs']} run(s) "
            f"diverged ({', '.join(diverged[:5])}{', ...' if len(diverged) > 5 else ''}); "
            f"{diverged[0]}: {one_line(first, 200)}; errors in {res['failures']}; change the "
            f"settings of its condition (a new --out), a rerun diverges again", 900) + "\n")
        return 3
    if res["failed"]:
        # every failed run refused its input (a value whose arithmetic overflows): bad input
        return 2 if _study_not_finished(res, diverged) else 1
    return 0


def _study_not_finished(res: dict[str, Any], diverged: list[str]) -> bool:
    """One line on stderr, like every failure: which runs, the first error, where the rest
    is (only a file that exists), and whether a rerun can help. Whether every run that failed
    (diverged aside) refused its input."""
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
        f"astrocpg: study {res['name']}: {len(res['failed'])} of {res['runs']} run(s) "
        f"not finished ({', '.join(res['failed'][:5])}"
        f"{', ...' if len(res['failed']) > 5 else ''})"
        + (f"; {first[0]}: {one_line(first[1], 200)}" if first else "")
        + f"{where}; {retry}", 900) + "\n")
    return bad_input


def report_command(args: argparse.Namespace) -> int:
    from ..parameter_studies.api import report

    written = report(args.dir, last=args.last, smooth=args.smooth, out=args.out,
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


def power_command(args: argparse.Namespace) -> int:
    from ..commands.api import power
    from ..commands.power import format_power

    path, res = power(args.dir, trial=args.trial, sessions=args.sessions,
                      overrides=args.overrides, progress=not args.no_progress)
    print(format_power(res))
    print(f"wrote {path}")
    return 0


def response_command(args: argparse.Namespace) -> int:
    """``astrocpg response MODEL``: the model's response curve, printed and written."""
    from ..commands.response import format_response, response

    result = response(args.model, rates=args.rates, seconds=args.seconds, warmup=args.warmup,
                      replicates=args.replicates, seed=args.seed, marks=args.marks,
                      out=args.out, overwrite=args.overwrite, progress=not args.no_progress,
                      inputs=input_files(args), **model_args(args))
    print("\n".join(format_response(result)))
    print(f"wrote {args.out}/ (response.csv, response.png, manifest.json)")
    return 0


def export_command(args: argparse.Namespace) -> int:
    from ..commands.api import export

    path = export(args.dir, args.format, args.out or None, overwrite=args.overwrite,
                  experimenter=args.experimenter, institution=args.institution)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    _overflow_warning(args.dir)  # the file's notes and the series' descriptions say it too
    return 0


def describe_command(args: argparse.Namespace) -> int:
    if not (args.overrides or args.equations or getattr(args, "model_files", [])
            or args.population_files):
        # the built-in models: from the cache, without importing Brian2 when it is warm
        from ..runtime.describe_cache import cached_text

        def render() -> str:
            from ..commands.api import describe
            return describe(args.model, args.format)

        name_ok = args.model is None or args.model.isidentifier()
        if name_ok and args.format in ("text", "markdown", "latex"):
            sys.stdout.write(cached_text(args.model, args.format, render))
            return 0
    from ..commands.api import describe

    sys.stdout.write(describe(args.model, args.format, **model_args(args),
                              **population_args(args)))
    return 0


def models_command(args: argparse.Namespace) -> int:
    """``models list`` (``ac.list_models()``) and ``models dump MODEL`` (``ac.dump_model``:
    the same text; the model named as typed when unknown)."""
    from ...errors import did_you_mean
    from ...models import INTERFACES
    from ...models.files import model_to_toml
    from ..commands.api import list_models

    if args.models_command == "list":
        for name, model in list_models().items():
            print(f"{name:20s} {model.kind:10s} {len(model.parameters):3d} parameters  "
                  f"{INTERFACES.get(name) or '-'}")
        from ...support.shipped import ROOT, shipped
        for kind, use in (("model", "--model MODEL=NAME"), ("study", "astrocpg study NAME"),
                          ("worlds", "evaluate --worlds NAME")):
            print(f"\nshipped {kind} files ({use}):")
            for name, path in shipped(kind).items():
                print(f"  {name:28s} {path.relative_to(ROOT).as_posix()}")
        return 0
    known = dict(list_models(**model_args(args)).items())
    if args.name not in known:
        raise InputError(f"unknown model{did_you_mean(args.name, known)} (models: "
                         f"{', '.join(known)})", culprit=args.name)
    sys.stdout.write(model_to_toml(known[args.name]))
    return 0


def robot_command(args: argparse.Namespace) -> int:
    from ..commands.api import robot

    print(f"wrote {robot(args.path, overwrite=args.overwrite)}")
    return 0


def seconds_text(seconds: float) -> str:
    """A time in s for a person: to the microsecond at most, no float noise (``1.1e-16`` is
    ``0``, ``3.9999999999`` is ``4``)."""
    return f"{round(float(seconds), 6):g}"


def docs_command(args: argparse.Namespace) -> int:
    """``astrocpg docs`` (``ac.docs``): where the manual is; ``--path``: the folder of its pages
    and of the files its recipes read; ``--open``: open it in a web browser."""
    from ..commands.api import docs

    where = docs(path=args.path, open=args.open)
    if args.path:
        print(where)
        return 0
    print(f"the manual: {where}")
    if where.suffix == ".md":
        print(f"(its pages as Markdown, in {where.parent}; the files its recipes read are there "
              f"too, and astrocpg finds them by the manual's spelling, e.g. "
              f"docs/examples/interlimb_table.csv, from any folder)")
    return 0


#: the handler of each command (``args.command``)
COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "unit": unit_command, "run": run_command, "train": train_command, "gait": gait_command,
    "evaluate": evaluate_command,
    "plot": plot_command, "video": video_command, "robot": robot_command,
    "study": study_command, "report": report_command, "power": power_command,
    "response": response_command,
    "export": export_command, "describe": describe_command, "models": models_command,
    "docs": docs_command}
