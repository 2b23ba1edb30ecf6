"""Seeing a result: ``astrocpg plot DIR`` (figures of any output folder) and ``astrocpg video
DIR`` (the recorded robot replayed in MuJoCo's offscreen renderer, as MP4)."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from ...errors import EnvironmentFault, InputError, advice, one_line, setting
from ..figures.save import save_figures
from ..settings.views import MAX_FRAMES, PlotSettings, VideoSettings, check_window
from ..figures.traces import FIGURE_FUNCTIONS, recorded_span, trace_figures
from ..outputs.folder import (OutputFolder, as_path, check_output_path, check_replaceable,
                            refuse_in_use)
from ..outputs.writing import write_manifest
from ..outputs.result import Result, load
from ..runtime.progress import Bar
from .trained_controller import FIGURES, plot_training


def _check_trial(result: Result, trial: int) -> None:
    if not isinstance(trial, (int, np.integer)) or not 0 <= trial < result.n_trials:
        raise InputError(f"{result.folder} has {result.n_trials} trial(s) (0.."
                         f"{result.n_trials - 1})", culprit=setting("trial", trial))




def plot(folder: str | Path, *, trial: int = 0, window: Any = None, fmt: str = "png",
         seconds: float | None = None, out: str | Path | None = None,
         overwrite: bool = False, progress: bool = True) -> list[Path]:
    """The figures of an output folder: what ``astrocpg plot`` draws.

    A unit, a run or a recorded training session: the trace figures of the recording (rasters,
    pool activity, motor-neuron Ca2+, each astrocyte, joints, torso path, gait diagram; those the
    recording allows), no new simulation. A training (or a study's run): its figures from a run
    of ``seconds`` with its trained weights, and the trace figures of the trial's last recorded
    session.

    Parameters
    ----------
    folder : path
        An output folder of unit, run, train or a study's run, or a recorded session.
    trial : int
        Which trial.
    window : (float, float), optional
        The time window (T0, T1) in s (default: the whole recording; a training: the last 2 s of
        its run).
    fmt : {"png", "pdf", "svg"}
        The figures' format.
    seconds : float, optional
        A training: simulated time of the run with the trained weights (default 10 s).
    out : path, optional
        The figure folder (default ``folder/figures``, replaced whole on every plot).
    overwrite : bool
        Replace an existing ``out`` elsewhere (only a folder astrocpg wrote).
    progress : bool
        A bar on stderr: a step per kind of figure drawn and per figure written (and the run's
        own bar, for a training).

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    value = PlotSettings(folder=as_path(folder, "folder"), trial=trial, window=window,
                         format=fmt, seconds=seconds)
    folder = Path(value.folder)
    result = load(folder)
    if result.kind == "train":
        return plot_training(folder, trial=value.trial,
                             seconds=10.0 if value.seconds is None else value.seconds,
                             out=out, overwrite=overwrite, fmt=value.format,
                             window=value.window, progress=progress, record=value.record())
    if value.seconds is not None:  # a recording is drawn as it is: nothing is simulated
        raise InputError(f"simulates a training's weights; {folder} is a {result.kind} "
                         f"folder, drawn from its recording ({setting('window', 'T0 T1')} picks "
                         f"a part)",
                         culprit=setting("seconds"))
    _check_trial(result, value.trial)
    span = recorded_span(result)
    win = check_window(window, span) or span
    target = Path(out) if out is not None else folder / FIGURES
    OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]).check()
    # two bars, each with the total it ends at: the kinds of figure drawn, then the files
    with Bar(total=len(FIGURE_FUNCTIONS), unit="step", desc="plot",
             disable=not progress) as bar:
        figures = trace_figures(result, value.trial, win, on_part=lambda: bar.update(1))
        bar.finish()
    if not figures:
        raise InputError("recorded nothing to draw (no spikes, traces or robot)",
                         culprit=str(folder))
    # the settings as given (the folder made absolute), and the window drawn
    recorded = {**value.record(), "folder": os.path.abspath(folder),
                "window_drawn": list(win) if win else None}
    with Bar(total=len(figures), unit="file", desc="plot: saving",
             disable=not progress) as bar:
        with OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]) as tmp:
            paths = save_figures(figures, tmp, value.format, on_saved=lambda: bar.update(1))
            write_manifest(tmp, command="plot", seed=int(result.manifest.get("seed", 0) or 0),
                           models_json={}, files={p.name: "figure" for p in paths},
                           settings=recorded)
    return [target / p.name for p in paths]


# ---------------------------------------------------------------- video
def _robot_model(result: Result) -> tuple[Any, Any]:
    """The MjModel the run simulated (its ``robot`` file, else the project's A1) and its layout."""
    from ...coupling.robot import A1Parameters, RobotLayout, load_robot
    from ...coupling.world import world_model
    from ...models import DEFAULT_MODELS

    robot = (result.manifest.get("settings") or {}).get("robot")
    params = A1Parameters()
    if robot and not Path(robot).is_file():
        raise InputError(f"the run's robot model {robot} is gone; the replay needs it",
                         culprit=str(result.folder))
    # the run's world (its terrain is drawn; a folder from before world parameters: flat)
    models = result.models if result.models is not None else DEFAULT_MODELS
    model = world_model(models, params, load_robot(robot) if robot else None)
    return model, RobotLayout.from_model(model, params)


def _replayed(folder: Path, trial: int) -> tuple[Result, int]:
    """The result whose robot.npz is replayed and the trial in it (a training: the trial's last
    recorded session)."""
    result = load(folder)
    _check_trial(result, trial)
    if result.kind == "train":
        recorded = sorted(s for b, s in result.recordings if b == trial)
        if not recorded:
            raise InputError(f"has no recorded session of trial {trial} to replay (train with "
                             f"{advice('record_every', 'N')})", culprit=str(folder))
        return result.recording(trial, recorded[-1]), 0
    if result.robot is None:
        raise InputError(f"holds no robot recording (a {result.kind}); video replays a run or "
                         f"a recorded training session", culprit=str(folder))
    return result, trial


#: Bounds of a video, checked before anything is rendered: H.264 players show at most a few
#: hundred frames per second, and 100,000 frames (55 minutes at 30 fps) render for hours.


def _span(t: Any) -> str:
    t = np.asarray(t, dtype=float)
    return f"{float(t[-1] - t[0]):.3g}" if len(t) else "0"


@contextlib.contextmanager
def _stderr_into(fd: int) -> Iterator[None]:
    """File descriptor 2 points to ``fd`` for the block (a child process started in it keeps
    that stderr); Python's own ``sys.stderr`` is flushed first."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        os.dup2(fd, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _ffmpeg_fault(err: BaseException, log: Any, path: Path) -> BaseException:
    """The failure of ffmpeg (or of the pipe to it) as one line: ffmpeg's last message, e.g.
    "No space left on device" (then an OSError ENOSPC naming ``path``, like any full disk)."""
    try:
        log.seek(0)
        said = log.read().decode("utf-8", "replace")
    except OSError:
        said = ""
    lines = [x.strip() for x in said.splitlines() if x.strip()]
    text = " ".join([*lines[-2:], *([] if lines else [str(err).strip().splitlines()[0]
                                                       if str(err).strip() else ""])])
    if "No space left" in said or getattr(err, "errno", None) == errno.ENOSPC:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(path))
    if getattr(err, "errno", None) == errno.EFBIG or "File too large" in said:
        return OSError(errno.EFBIG, os.strerror(errno.EFBIG), os.fspath(path))
    return EnvironmentFault(f"ffmpeg could not write the video: "
                            f"{one_line(text, 300) or type(err).__name__}", culprit=str(path))


def video(folder: str | Path, *, trial: int = 0, fps: float = 30.0, speed: float = 1.0,
          size: Any = (640, 480), out: str | Path | None = None, overwrite: bool = False,
          progress: bool = True, panel: bool = False, start: float | None = None,
          stop: float | None = None) -> dict[str, Any]:
    """Replay a recorded robot as an MP4: what ``astrocpg video`` writes.

    The robot is posed from the recorded joint angles and torso pose, a camera tracking the
    trunk (MuJoCo's offscreen renderer: EGL or OSMesa).

    Parameters
    ----------
    folder : path
        A run, a recorded training session, or a training (its trial's last recorded session).
    trial : int
        Which trial.
    fps : float
        Frames per second of video.
    speed : float
        Simulated seconds per second of video (1: real time).
    size : (int, int)
        Width and height of a frame in pixels.
    out : path, optional
        The file (default ``folder/video_trialTT.mp4``, replaced on each video).
    overwrite : bool
        Replace an existing ``out`` elsewhere.
    progress : bool
        A progress bar on stderr.
    panel : bool
        A panel under each frame (half its height, at least 240 pixels): the time, forward speed
        and, in a window that scrolls with the frame, a gait diagram, each leg's thigh-pool
        activity and its astrocytes' Ca2+ (see :class:`~astrocpg.studies.figures.panel.GaitPanel`).
    start, stop : float, optional
        Only that window of the recording, in simulated s from its start (0 to its length;
        default: all of it).

    Returns
    -------
    dict
        ``{"path", "frames", "fps", "seconds", "start", "stop"}``.
    """
    from ...coupling.render import Replay
    from ..outputs.writing import atomic_path

    value = VideoSettings(folder=as_path(folder, "folder"), trial=trial, fps=fps, speed=speed,
                          size=size, panel=panel, start=start, stop=stop)
    folder, trial, fps, speed = Path(value.folder), value.trial, value.fps, value.speed
    width, height = value.size
    result, b = _replayed(folder, trial)
    rob = result.robot
    if "torso_quaternion" not in rob:
        raise InputError("robot.npz has no torso_quaternion (recorded before astrocpg kept the "
                         "torso's orientation); run it again to make a video",
                         culprit=str(result.folder))
    path = _video_path(folder, trial, out, overwrite)
    shown, samples = _frames(rob["t"], value)
    model, layout = _robot_model(result)

    strip = None
    if value.panel:
        from ..figures.panel import GaitPanel, panel_height

        # the replayed result (a training: its recorded session) gives the spikes and traces
        strip = GaitPanel(rob, b, width, panel_height(height, result), speed=speed,
                          result=result)
    # the video's own record of what it shows: its settings, in the MP4's comment
    comment = json.dumps(value.record(), sort_keys=True)

    def write(tmp: Path) -> None:
        with Replay(model, layout, rob["joint_angles"][b], rob["torso_position"][b],
                    rob["torso_quaternion"][b], width=width, height=height) as replay:
            _write_frames(tmp, path, samples, replay, strip, fps, progress, comment)

    atomic_path(path, write)
    return {"path": path, "frames": len(samples), "fps": fps,
            "seconds": len(samples) / fps, "start": shown[0], "stop": shown[1],
            "settings": value.record()}


def _frames(t: Any, value: VideoSettings) -> tuple[tuple[float, float], Any]:
    """The window shown (checked against the recording ``t``; a start or stop not given
    keeps the recording's own end) and the recording's sample of each frame."""
    from ...coupling.render import frame_count, frame_samples

    fps, speed = value.fps, value.speed
    shown = _time_window(t, value.start, value.stop)
    start = None if value.start is None else shown[0]
    stop = None if value.stop is None else shown[1]
    n_frames = frame_count(t, fps, speed, start=start, stop=stop)
    if n_frames > MAX_FRAMES:  # before a frame index of that length is built
        raise InputError(f"{n_frames:.3g} frames ({_span(t)} s recorded x fps {fps:g} / "
                         f"speed {speed:g}) is more than {MAX_FRAMES}; lower {setting('fps')} or "
                         f"raise {setting('speed')}", culprit=_rates_given(fps, speed))
    return shown, frame_samples(t, fps, speed, start=start, stop=stop)


def _rates_given(fps: float, speed: float) -> str:
    """``fps`` and ``speed`` as a culprit: the two settings with their values."""
    return f"{setting('fps', f'{fps:g}')} {setting('speed', f'{speed:g}')}"


def _video_path(folder: Path, trial: int, out: str | Path | None, overwrite: bool) -> Path:
    """The MP4 a video writes: ``out`` (a file ending in .mp4 in a folder that exists,
    replaced only with ``overwrite``) or the replayed folder's ``video_trialTT.mp4``; never a
    file the folder lists, nor one another process holds."""
    path = Path(out) if out is not None else folder / f"video_trial{trial:02d}.mp4"
    if path.suffix.lower() != ".mp4":
        raise InputError("the file name must end in .mp4", culprit=setting("out", path))
    if not path.parent.is_dir():
        raise InputError(f"folder '{path.parent}' does not exist", culprit=setting("out", path))
    if path.is_dir():
        raise InputError("is a folder; name the file to write", culprit=setting("out", path))
    # not inside the folder it replays (but as its video_trialTT.mp4), never a listed file
    check_output_path(path, [folder], culprit=setting("out", path), file=True)
    if out is not None and path.exists() and not overwrite:
        raise InputError(f"exists; {setting('overwrite')} replaces it",
                         culprit=setting("out", path))
    check_replaceable(path, culprit=setting("out", path))
    refuse_in_use(path, culprit=setting("out", path) if out is not None else str(folder))
    return path


def _write_frames(tmp: Path, path: Path, samples: Any, replay: Any, strip: Any, fps: float,
                  progress: bool, comment: str = "") -> None:
    """Every frame of ``replay`` at ``samples`` (with the panel ``strip`` below it) encoded
    into ``tmp`` by ffmpeg; an ffmpeg error (a full disk, ...) becomes one line naming
    ``path``."""
    import imageio.v2 as imageio

    bar = Bar(total=len(samples), unit="frame", desc="rendering", disable=not progress)
    # ffmpeg writes its errors to the stderr it inherits: into this file instead, and from
    # there into our one line
    with tempfile.TemporaryFile() as log:
        writer = imageio.get_writer(tmp, format="FFMPEG", fps=fps, codec="libx264",
                                    pixelformat="yuv420p", macro_block_size=2, quality=7,
                                    ffmpeg_log_level="error",
                                    output_params=["-metadata", f"comment={comment}"])
        try:
            try:
                started = False
                # the bar counts frames written, here: a count kept by the frame generator
                # (after its yield) missed the last frame, which zip never resumes it for
                for k, frame in zip(samples, replay.frames(samples)):
                    if strip is not None:
                        frame = np.concatenate([frame, strip.draw(int(k))], axis=0)
                    if not started:  # the first frame starts ffmpeg: its stderr is the log
                        with _stderr_into(log.fileno()):
                            writer.append_data(frame)
                        started = True
                    else:
                        writer.append_data(frame)
                    bar.update(1)
                writer.close()
            except (OSError, RuntimeError) as e:
                try:
                    writer.close()
                except Exception:  # noqa: BLE001 - already failing: the first error counts
                    pass
                raise _ffmpeg_fault(e, log, path) from None
        finally:
            bar.close()


def _time_window(t: Any, start: Any, stop: Any) -> tuple[float, float]:
    """``start``/``stop`` checked against the recording's span (0 to its length, in
    simulated s): each a number within it, ``start`` before ``stop``; the defaults are the
    span's ends."""
    from ...coupling.render import recording_span

    first, end = recording_span(t)
    values = []
    for name, value, default in ((setting("start"), start, first), (setting("stop"), stop, end)):
        if value is None:
            values.append(default)
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) \
                or not np.isfinite(value):
            raise InputError("must be a number of seconds", culprit=name.given(value))
        if value < first - 1e-9:
            raise InputError(f"is before the recording's start ({first:g} s)",
                             culprit=name.given(f"{value:g}"))
        if value > end + 1e-9:
            raise InputError(f"is past the recording's end ({end:g} s recorded)",
                             culprit=name.given(f"{value:g}"))
        values.append(float(value))
    if values[0] >= values[1]:
        raise InputError(f"must be before {setting('stop')} ({values[1]:g} s)",
                         culprit=setting("start", f"{values[0]:g}"))
    return values[0], values[1]


__all__ = ["plot", "video"]
