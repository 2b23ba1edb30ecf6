"""astrocpg plot (figures of any output folder) and astrocpg video (the recorded robot replayed
in MuJoCo's offscreen renderer)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from astrocpg.studies.cli import main
from astrocpg.studies.figures.traces import trace_figures
from astrocpg.studies.outputs.folder import MANIFEST, inventory
from astrocpg.studies.outputs.result import load

RUN_FIGURES = {"rasters", "pool_activity", "motor_calcium", "joints", "torso_path",
               "gait_diagram"} | {f"astrocyte_{leg}_thigh_{p}" for leg in ("FR", "FL", "RR", "RL")
                                  for p in ("flexor", "extensor")}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A 2 s closed-loop run, one trial, everything recorded."""
    out = tmp_path_factory.mktemp("see") / "run"
    assert main(["run", "--seconds", "2", "--seed", "1", "--out", str(out),
                 "--no-progress"]) == 0
    return out


def _labelled(fig) -> None:
    """Every panel has a y label, the bottom ones an x label with a unit, the figure a title."""
    axes = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert any(ax.get_title() for ax in axes)
    for ax in axes:
        assert ax.get_ylabel(), ax
    bottom = [ax for ax in axes if ax.get_xlabel()]
    assert bottom and all("(" in ax.get_xlabel() for ax in bottom)


def test_run_recording_has_torso_quaternion(run_dir):
    rob = load(run_dir).robot
    q = rob["torso_quaternion"]
    assert q.shape == rob["torso_position"].shape[:2] + (4,)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-6)
    assert np.ptp(q, axis=1).max() > 1e-3  # the torso turned: a recording, not the default


def test_trace_figures_of_a_run(run_dir):
    result = load(run_dir)
    figs = trace_figures(result, 0)
    assert set(figs) == RUN_FIGURES
    for fig in figs.values():
        _labelled(fig)
    ast = figs["astrocyte_FR_thigh_extensor"]
    ylabels = [ax.get_ylabel() for ax in ast.axes]
    assert ylabels == ["Ca²⁺\n(µM)", "IP3\n(µM)", "2-AG\n(a.u.)", "adenosine\n(a.u.)",
                       "pool activity\n(neurons / ms)"]
    joints = figs["joints"]
    assert "angle (deg)" in joints.axes[0].get_ylabel()
    assert "torque (N m)" in joints.axes[1].get_ylabel()
    # what was not recorded is left out (run --spikes none --traces none: the robot's figures)
    result.spikes, result.traces = {}, {}
    assert set(trace_figures(result, 0)) == {"joints", "torso_path", "gait_diagram"}
    result = load(run_dir)
    # a window limits every time axis
    for fig in trace_figures(result, 0, (0.5, 1.0)).values():
        for ax in fig.axes:
            if ax.get_xlabel() == "time (s)":
                assert ax.get_xlim() == pytest.approx((0.5, 1.0))


@pytest.mark.slow
def test_plot_a_run_writes_every_figure(run_dir, tmp_path, capsys):
    out = tmp_path / "figs"
    assert main(["plot", str(run_dir), "--window", "0.5", "1.5", "--format", "pdf",
                 "--out", str(out)]) == 0
    # the figures and the folder's manifest (its inventory makes the folder verifiable)
    assert {p.name for p in out.iterdir()} == {f"{n}.pdf" for n in RUN_FIGURES} | {"manifest.json"}
    assert all((out / f"{n}.pdf").read_bytes().startswith(b"%PDF") for n in RUN_FIGURES)
    # --out that exists: refused; the default folder is replaced whole each time
    assert main(["plot", str(run_dir), "--out", str(out)]) == 2
    assert str(out) in capsys.readouterr().err
    assert load(run_dir).kind == "run"  # the run folder still verifies


@pytest.mark.parametrize("argv, culprit", [
    (["--format", "bmp"], "--format bmp"),
    (["--window", "1.5", "0.5"], "--window"),
    (["--window", "9", "10"], "--window"),
    (["--trial", "3"], "--trial 3"),
])
def test_plot_refuses_bad_options(run_dir, tmp_path, capsys, argv, culprit):
    out = tmp_path / "figs"
    assert main(["plot", str(run_dir), "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err
    assert culprit in err and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.slow
def test_plot_a_unit(tmp_path):
    unit = tmp_path / "unit"
    assert main(["unit", "--seconds", "0.5", "--out", str(unit), "--no-progress"]) == 0
    import astrocpg as ac

    written = ac.plot(unit, fmt="svg")
    names = {p.name for p in (unit / "figures").iterdir()} - {"manifest.json"}
    assert names == {p.name for p in written}
    assert {"rasters.svg", "pool_activity.svg", "motor_calcium.svg",
            "astrocyte_FR_thigh_flexor.svg", "gait_diagram.svg"} <= names
    assert "joints.svg" not in names  # a unit has no robot
    assert main(["video", str(unit)]) == 2


def _frames(path):
    import imageio.v2 as imageio

    with imageio.get_reader(path) as reader:
        return np.stack([f for f in reader])


@pytest.mark.slow
def test_video_of_a_run(run_dir, tmp_path):
    """2 s at 30 fps: 60 frames (+-1) that change along the run, the robot in the middle
    third. Robot pixels: a segmentation rendering of the same replay (same camera, same
    samples) marks every pixel of a geom not on the world body (the floor is)."""
    from astrocpg.coupling.render import Replay, frame_samples
    from astrocpg.coupling.robot import RobotLayout, build_model

    path = tmp_path / "run.mp4"
    assert main(["video", str(run_dir), "--out", str(path), "--size", "320", "240",
                 "--no-progress"]) == 0
    frames = _frames(path)
    assert abs(len(frames) - 60) <= 1
    assert frames.shape[1:] == (240, 320, 3)
    diffs = np.abs(np.diff(frames.astype(np.int16), axis=0)).mean(axis=(1, 2, 3))
    assert (diffs > 0.5).mean() > 0.9  # nearly every frame differs from the previous one
    assert np.abs(frames[-1].astype(int) - frames[0]).mean() > 2

    rob = load(run_dir).robot
    model = build_model()
    samples = frame_samples(rob["t"], 30.0)
    assert len(samples) == len(frames)
    with Replay(model, RobotLayout.from_model(model), rob["joint_angles"][0],
                rob["torso_position"][0], rob["torso_quaternion"][0], width=320,
                height=240) as replay:
        for k in samples[::5]:
            mask = replay.frame(int(k), segmentation=True)
            ys, xs = np.nonzero(mask)
            assert mask.mean() > 0.01  # the robot is drawn, not a speck
            assert 1 / 3 < xs.mean() / 320 < 2 / 3 and 1 / 3 < ys.mean() / 240 < 2 / 3


def test_video_speed_panel_and_default_path(run_dir):
    assert main(["video", str(run_dir), "--speed", "2", "--fps", "10", "--size", "320", "240",
                 "--panel", "--no-progress"]) == 0
    frames = _frames(run_dir / "video_trial00.mp4")
    assert abs(len(frames) - 10) <= 1  # 2 s at twice real time, 10 fps
    # the panel below: gait, pool activity and astrocyte Ca2+ rows, half the height (>= 240)
    assert frames.shape[1:] == (240 + 240, 320, 3)
    strip = frames[:, 240:].astype(int)
    assert np.abs(strip[-1] - strip[1]).mean() > 1  # the panel scrolls with the frame's time
    assert load(run_dir).kind == "run"  # an extra file leaves the folder verifiable


def _texts(ax) -> str:
    return " ".join(t.get_text() for t in ax.texts)


def test_panel_rows_follow_the_frame(run_dir):
    """The panel's rows are labelled with their units, its "now" line sits at the frame's
    time, and two frames at different times differ."""
    from astrocpg.studies.figures.panel import GaitPanel, panel_height

    result = load(run_dir)
    t = result.robot["t"]
    panel = GaitPanel(result.robot, 0, 320, panel_height(240, result), result=result)
    assert set(panel.axes) == {"gait", "activity", "calcium"}
    labels = {name: ax.get_ylabel() for name, ax in panel.axes.items()}
    assert "activity" in labels["activity"] and "Hz" in labels["activity"]
    assert "Ca" in labels["calcium"] and "µM" in labels["calcium"]
    assert "contact" in labels["gait"]
    assert panel.axes["calcium"].get_xlabel() == "time (s)"
    assert not _texts(panel.axes["activity"]) and not _texts(panel.axes["calcium"])
    # 8 activity lines (4 legs x extensor, flexor), 8 astrocytes, their legends
    assert len(panel.axes["activity"].get_legend().get_texts()) == 2
    assert len(panel.axes["calcium"].get_legend().get_texts()) == 4 + 2
    images = []
    for when in (0.8, 1.6):
        k = int(np.searchsorted(t, when))
        images.append(panel.draw(k).astype(int))
        assert images[-1].shape == (240, 320, 3)
        for line in panel.now:
            assert line.get_xdata()[0] == pytest.approx(t[k])
        lo, hi = panel.axes["calcium"].get_xlim()
        assert lo < t[k] < hi
        assert len(panel.series) == 16
        for line, xs, _ in panel.series:  # each series fills the window where it has data
            x = np.asarray(line.get_xdata())
            assert x[0] <= max(lo, xs[0]) + 0.02 and x[-1] >= min(hi, xs[-1]) - 0.02
    assert np.abs(images[1] - images[0]).mean() > 1


def test_video_panel_of_a_run_without_traces(tmp_path):
    """A run recorded with --traces none still gets its panel: Ca2+ left out, with a note."""
    from astrocpg.studies.figures.panel import GaitPanel

    out = tmp_path / "run"
    assert main(["run", "--seconds", "1", "--seed", "2", "--traces", "none", "--out", str(out),
                 "--no-progress"]) == 0
    assert main(["video", str(out), "--panel", "--size", "320", "240", "--fps", "4",
                 "--no-progress"]) == 0
    frames = _frames(out / "video_trial00.mp4")
    assert frames.shape[1:] == (240 + 240, 320, 3)
    result = load(out)
    panel = GaitPanel(result.robot, 0, 320, 240, result=result)
    assert "astrocyte Ca²⁺ not recorded" in _texts(panel.axes["calcium"])
    assert not _texts(panel.axes["activity"])  # the motor spikes were recorded
    assert panel.draw(len(result.robot["t"]) // 2).shape == (240, 320, 3)


def test_video_refuses_a_run_recorded_without_orientation(run_dir, tmp_path, capsys):
    import shutil

    old = tmp_path / "old"
    shutil.copytree(run_dir, old, ignore=shutil.ignore_patterns("*.mp4", "figures"))
    with np.load(old / "robot.npz") as z:
        arrays = {k: z[k] for k in z.files if k != "torso_quaternion"}
    np.savez(old / "robot.npz", **arrays)
    manifest = json.loads((old / MANIFEST).read_text())
    manifest["inventory"] = inventory(old)
    (old / MANIFEST).write_text(json.dumps(manifest))
    assert main(["video", str(old), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "torso_quaternion" in err and err.count("\n") == 1
    assert not list(old.glob("*.mp4")) and not list(old.glob(".*"))


@pytest.mark.parametrize("argv, culprit", [
    (["--size", "321", "240"], "--size"), (["--fps", "0"], "--fps"),
    (["--speed", "-1"], "--speed"), (["--trial", "1"], "--trial 1"),
    (["--stop", "2.5"], "--stop 2.5: is past the recording's end (2 s recorded)"),
    (["--start", "-1"], "--start -1: is before the recording's start (0 s)"),
    (["--start", "1.5", "--stop", "1"], "--start 1.5: must be before --stop (1 s)"),
    (["--start", "nan"], "--start nan")])
def test_video_refuses_bad_options(run_dir, capsys, argv, culprit):
    assert main(["video", str(run_dir), "--no-progress", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and culprit in err, err


def test_video_of_a_time_window(run_dir, tmp_path, capsys):
    """--start/--stop: only that window of the 2 s run, its frames the whole video's."""
    import astrocpg

    whole = astrocpg.video(run_dir, out=tmp_path / "whole.mp4", fps=10, size=(64, 48),
                           progress=False)
    assert (whole["start"], whole["stop"], whole["frames"]) == (0.0, pytest.approx(2.0), 20)
    assert main(["video", str(run_dir), "--start", "0.5", "--stop", "1.2", "--fps", "10",
                 "--size", "64", "48", "--out", str(tmp_path / "part.mp4"),
                 "--no-progress"]) == 0
    assert "0.5 to 1.2 s of the recording" in capsys.readouterr().out
    a, b = _frames(tmp_path / "whole.mp4").astype(int), _frames(tmp_path / "part.mp4")
    assert len(b) == 7
    # frame j of the window is frame 5 + j of the whole video (up to the codec's losses)
    for j in (0, 6):
        assert np.abs(b[j] - a[5 + j]).mean() < np.abs(b[j] - a[0 if j else 19]).mean()
    part = astrocpg.video(run_dir, out=tmp_path / "part2.mp4", fps=10, size=(64, 48),
                          start=1.5, progress=False)
    assert (part["start"], part["frames"]) == (1.5, 5)


@pytest.mark.slow
def test_plot_and_video_of_a_training(tmp_path):
    train = tmp_path / "train"
    assert main(["train", "--sessions", "2", "--record-every", "1", "--out", str(train),
                 "--no-progress"]) == 0
    assert main(["plot", str(train), "--seconds", "2"]) == 0
    figs = train / "figures"
    assert {"weights.png", "training.png", "thigh_extensor_activity.png",
            "gait.png"} <= {p.name for p in figs.iterdir()}
    sub = sorted(figs.glob("recording_trial00_session*"))[-1]
    assert {f"{n}.png" for n in RUN_FIGURES} == {p.name for p in sub.iterdir()} - {"manifest.json"}
    # a recorded session plots and replays like a run
    session = sorted((train / "recordings").iterdir())[-1]
    assert main(["plot", str(session)]) == 0
    assert main(["video", str(train), "--size", "160", "120", "--fps", "5", "--panel",
                 "--no-progress"]) == 0
    frames = _frames(train / "video_trial00.mp4")
    assert len(frames) > 1 and frames.shape[1:] == (120 + 240, 160, 3)
    # the panel draws the recorded session's spikes and traces
    from astrocpg.studies.figures.panel import GaitPanel

    recording = load(session)
    assert "motor" in recording.spikes and "astrocyte_Ca" in recording.traces
    panel = GaitPanel(recording.robot, 0, 320, 240, result=recording)
    assert not _texts(panel.axes["activity"]) and not _texts(panel.axes["calcium"])


def test_a_recordings_span_and_its_times_read_round() -> None:
    """``video --panel`` said "1.10155e-16 to 4 s": the span of samples at whole 1 ms steps is
    (0, 4) exactly, and a time is printed without float noise."""
    import numpy as np

    from astrocpg.coupling.render import recording_span
    from astrocpg.studies.cli.handlers import seconds_text

    t = np.cumsum(np.full(4000, 0.001))  # 0.001 .. 4.0 s, as a run samples its robot
    assert recording_span(t) == (0.0, 4.0)
    assert seconds_text(1.10155e-16) == "0" and seconds_text(3.9999999999) == "4"
    assert seconds_text(2.5) == "2.5" and seconds_text(0.001) == "0.001"
