"""The settings of the views of a result, ``plot`` and ``video`` (``astrocpg plot``/``video``,
``ac.plot``/``ac.video``), as typed values: frozen, checked when built (what can be checked
before the folder is read; the window against the recording when it is), recorded where the
view is written (the figures' manifest, the video's metadata) and read back from the record."""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

from ...errors import InputError, did_you_mean, setting
from ..figures.save import FORMATS
from .checks import STEP, check_duration, number
from .recorded import Recorded, folder_text

#: The most frames per second of video, and the most frames a video may have.
MAX_FPS = 1000
MAX_FRAMES = 100_000


def _trial(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise InputError("must be a trial number, 0 or more", culprit=setting("trial", value))
    return int(value)


def check_window(window: Any, span: tuple[float, float] | None = None
                 ) -> tuple[float, float] | None:
    """``window`` as (T0, T1) in s, 0 <= T0 < T1 (and T0 before the recording's end where
    its ``span`` is known); None: not given."""
    if window is None:
        return None
    try:
        t0, t1 = (float(x) for x in window)
    except (TypeError, ValueError):
        raise InputError("needs two numbers, T0 T1 in s", culprit=setting("window")) from None
    culprit = setting("window", f"{window[0]} {window[1]}")
    if not (np.isfinite(t0) and np.isfinite(t1)) or t0 < 0 or t1 <= t0:
        raise InputError("needs 0 <= T0 < T1 (s)", culprit=culprit)
    if span is not None and t0 >= span[1]:
        raise InputError(f"starts after the recording ends ({span[1]:g} s)", culprit=culprit)
    return t0, t1


def frame_size(size: Any) -> tuple[int, int]:
    """``size`` as (WIDTH, HEIGHT): even pixels in 16..4096, as H.264 takes them."""
    try:
        w, h = (int(x) for x in size)
    except (TypeError, ValueError):
        raise InputError("needs WIDTH HEIGHT in pixels", culprit=setting("size")) from None
    if not (16 <= w <= 4096 and 16 <= h <= 4096) or w % 2 or h % 2:
        raise InputError("needs even WIDTH and HEIGHT in 16..4096 pixels (H.264)",
                         culprit=setting("size", f"{w} {h}"))
    return w, h


def check_rates(fps: Any, speed: Any) -> None:
    """``fps`` and ``speed`` positive numbers, ``fps`` at most :data:`MAX_FPS`."""
    for name, value in ((setting("fps"), fps), (setting("speed"), speed)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) \
                or not np.isfinite(value) or value <= 0:
            raise InputError("must be a positive number", culprit=name.given(value))
    if fps > MAX_FPS:
        raise InputError(f"must be at most {MAX_FPS} frames per second",
                         culprit=setting("fps", fps))


def _moment(value: Any, name: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) \
            or not np.isfinite(value):
        raise InputError("must be a number of seconds", culprit=setting(name, value))
    return float(value)


@dataclasses.dataclass(frozen=True)
class PlotSettings(Recorded):
    """What ``plot`` draws: the figures of the output ``folder``'s trial ``trial`` in
    ``format`` (png, pdf, svg), over ``window`` (T0, T1 in s; None: the whole recording, a
    training: the last 2 s of its run), and for a training, ``seconds`` of a run with its
    trained weights (None: 10 s)."""

    folder: str
    trial: int = 0
    window: tuple[float, float] | None = None
    format: str = "png"
    seconds: float | None = None

    RECORD: ClassVar[tuple[str, ...]] = ("folder", "trial", "window", "format", "seconds")
    #: the window drawn (the recording's span where none was given), beside the settings
    FOUND: ClassVar[frozenset[str]] = frozenset({"window_drawn"})

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if self.format not in FORMATS:
            raise InputError(f"unknown format{did_you_mean(self.format, FORMATS)} (formats: "
                             f"{', '.join(FORMATS)})", culprit=setting("format", self.format))
        set_(self, "folder", folder_text(self.folder))
        set_(self, "trial", _trial(self.trial))
        set_(self, "window", check_window(self.window))
        if self.seconds is not None:
            set_(self, "seconds", number(self.seconds, setting("seconds"), positive=True))
            check_duration(self.seconds, STEP)


@dataclasses.dataclass(frozen=True)
class VideoSettings(Recorded):
    """What ``video`` renders: the recorded robot of ``folder``'s trial ``trial``, at ``fps``
    frames per second of video and ``speed`` simulated seconds per second of it, frames of
    ``size`` (WIDTH, HEIGHT) pixels, from ``start`` to ``stop`` (s of the recording; None: its
    ends), with the activity ``panel`` under each frame or not."""

    folder: str
    trial: int = 0
    fps: float = 30.0
    speed: float = 1.0
    size: tuple[int, int] = (640, 480)
    panel: bool = False
    start: float | None = None
    stop: float | None = None

    RECORD: ClassVar[tuple[str, ...]] = ("folder", "trial", "fps", "speed", "size", "panel",
                                         "start", "stop")

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "folder", folder_text(self.folder))
        set_(self, "trial", _trial(self.trial))
        check_rates(self.fps, self.speed)
        set_(self, "fps", float(self.fps))
        set_(self, "speed", float(self.speed))
        set_(self, "size", frame_size(self.size))
        set_(self, "panel", bool(self.panel))
        set_(self, "start", _moment(self.start, "start"))
        set_(self, "stop", _moment(self.stop, "stop"))


__all__ = ["MAX_FPS", "MAX_FRAMES", "PlotSettings", "VideoSettings", "check_rates",
           "check_window", "frame_size"]
