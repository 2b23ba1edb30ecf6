"""Replay of a recorded run in MuJoCo's offscreen renderer: the robot is posed from the recorded
joint angles and torso position and orientation (``mj_forward``, no physics), and drawn by a
camera that tracks the trunk.

The OpenGL backend: ``MUJOCO_GL`` when set (MuJoCo reads it when first imported); otherwise
:func:`choose_gl` tries EGL (GPU, headless), then OSMesa (software), each in a short child
process, and uses the first that draws.
"""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Any, Callable, Iterator

import numpy as np

from ..errors import EnvironmentFault

BACKENDS = ("egl", "osmesa")
_PROBE = ("import mujoco; m = mujoco.MjModel.from_xml_string('<mujoco/>'); "
          "r = mujoco.Renderer(m, 16, 16); d = mujoco.MjData(m); r.update_scene(d); r.render()")
_chosen: str | None = None


def choose_gl() -> str:
    """The OpenGL backend the renderer uses: ``MUJOCO_GL`` if set, else the first of EGL and
    OSMesa that renders in a child process (set into ``MUJOCO_GL`` and, if MuJoCo was imported
    before, into its context factory). EnvironmentFault when none works."""
    global _chosen
    if os.environ.get("MUJOCO_GL"):
        return os.environ["MUJOCO_GL"]
    if _chosen is not None:
        return _chosen
    tried = []
    for backend in BACKENDS:
        env = dict(os.environ, MUJOCO_GL=backend)
        env.pop("PYOPENGL_PLATFORM", None)
        try:
            ok = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True,
                                timeout=60).returncode == 0
        except (OSError, subprocess.TimeoutExpired):
            ok = False
        if ok:
            _use(backend)
            _chosen = backend
            return backend
        tried.append(backend)
    raise EnvironmentFault(f"no offscreen OpenGL ({', '.join(tried)} tried); install EGL "
                           f"(GPU driver) or OSMesa, or set MUJOCO_GL")


def _use(backend: str) -> None:
    os.environ["MUJOCO_GL"] = backend
    if "OpenGL" not in sys.modules:  # PyOpenGL picks its platform once, on first import
        os.environ["PYOPENGL_PLATFORM"] = backend
    context = sys.modules.get("mujoco.rendering.classic.gl_context")
    if context is not None:  # MuJoCo already chose a (windowed) context class at import
        if backend == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.osmesa import GLContext
        context.GLContext = GLContext


class Replay:
    """Poses ``model`` from recorded samples and renders them.

    joint_angles (samples, 4 legs, 3 joints) rad; torso_position (samples, 3) m;
    torso_quaternion (samples, 4) (w, x, y, z); ``layout``: the model's
    :class:`~astrocpg.coupling.robot.RobotLayout`; width, height in pixels.
    """

    def __init__(self, model: Any, layout: Any, joint_angles: np.ndarray,
                 torso_position: np.ndarray, torso_quaternion: np.ndarray, *, width: int = 640,
                 height: int = 480, distance: float = 1.4, azimuth: float = 135.0,
                 elevation: float = -20.0) -> None:
        import mujoco

        choose_gl()
        self.model, self.layout = model, layout
        self.angles = np.asarray(joint_angles, dtype=float)
        self.position = np.asarray(torso_position, dtype=float)
        self.quaternion = np.asarray(torso_quaternion, dtype=float)
        self.data = mujoco.MjData(model)
        # the offscreen buffer must hold the frame
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        try:
            self.renderer = mujoco.Renderer(model, height=height, width=width)
        except Exception as e:  # noqa: BLE001 - the GL stack's errors have no common type
            raise EnvironmentFault(f"the offscreen renderer failed to start "
                                   f"(MUJOCO_GL={os.environ.get('MUJOCO_GL', '')}): "
                                   f"{type(e).__name__}: {e}") from None
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        cam.trackbodyid = int(layout.trunk_body)
        cam.distance, cam.azimuth, cam.elevation = distance, azimuth, elevation
        self.camera = cam
        self._mujoco = mujoco

    def __len__(self) -> int:
        return len(self.position)

    def pose(self, k: int) -> None:
        """Set the robot to sample ``k`` and compute its kinematics."""
        L, q = self.layout, self.data.qpos
        fq = int(L.free_qpos_adr)
        q[:] = L.reset_qpos
        q[fq:fq + 3] = self.position[k]
        quat = self.quaternion[k]
        q[fq + 3:fq + 7] = quat / max(float(np.linalg.norm(quat)), 1e-12)
        q[L.qpos_adr] = self.angles[k]
        self.data.qvel[:] = 0.0
        self._mujoco.mj_forward(self.model, self.data)

    def frame(self, k: int, *, segmentation: bool = False) -> np.ndarray:
        """Sample ``k`` drawn: (height, width, 3) uint8 RGB; with ``segmentation`` a
        (height, width) bool mask of the robot's pixels (any geom not on the world body)."""
        self.pose(k)
        r = self.renderer
        r.update_scene(self.data, camera=self.camera)
        if not segmentation:
            return r.render().copy()
        r.enable_segmentation_rendering()
        try:
            seg = r.render()
        finally:
            r.disable_segmentation_rendering()
        ids, types = seg[..., 0], seg[..., 1]
        geom = types == int(self._mujoco.mjtObj.mjOBJ_GEOM)
        body = np.full(ids.shape, 0)
        body[geom] = self.model.geom_bodyid[ids[geom]]
        return geom & (body > 0)

    def frames(self, samples: np.ndarray, *, on_frame: Callable[[int], None] | None = None
               ) -> Iterator[np.ndarray]:
        """The frames of ``samples`` (sample indices), in order. ``on_frame(n)`` is called as
        the n-th frame is rendered, before it is handed out (after the ``yield`` it would miss
        the last frame: a consumer such as ``zip`` never resumes the generator for it)."""
        for j, k in enumerate(samples):
            frame = self.frame(int(k))
            if on_frame is not None:
                on_frame(j + 1)
            yield frame

    def close(self) -> None:
        self.renderer.close()

    def __enter__(self) -> "Replay":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def recording_span(t: np.ndarray) -> tuple[float, float]:
    """The simulated time a recording at sample times ``t`` covers, in s: from the start of
    the stride its first sample ends (0 for a run: a sample is the state at the end of its
    step) to its last sample."""
    t = np.asarray(t, dtype=float)
    if len(t) == 0:
        return 0.0, 0.0
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    # sample times are whole steps: rounded to the nanosecond, 0.001 - 0.001 is 0, not 1e-16
    return round(max(0.0, float(t[0]) - step), 9), round(float(t[-1]), 9)


def _window(t: np.ndarray, start: float | None, stop: float | None) -> tuple[float, float]:
    """The frames' first time and the time they end at: the recording's own, or the window."""
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    return (float(t[0]) if start is None else float(start),
            float(t[-1]) + step if stop is None else float(stop))


def frame_count(t: np.ndarray, fps: float, speed: float = 1.0, *, start: float | None = None,
                stop: float | None = None) -> float:
    """How many frames :func:`frame_samples` makes of the samples at times ``t`` (a float: it
    may be far too many to make, e.g. ``fps=1e9``); ``start``/``stop``: a window of simulated
    time in s (default: the whole recording)."""
    t = np.asarray(t, dtype=float)
    if len(t) == 0:
        return 0.0
    first, end = _window(t, start, stop)
    return max(1.0, float(np.round((end - first) * fps / speed)))


def frame_samples(t: np.ndarray, fps: float, speed: float = 1.0, *, start: float | None = None,
                  stop: float | None = None) -> np.ndarray:
    """Sample index of each video frame: frame j shows simulated time t0 + j*speed/fps (the
    nearest sample at or before it; t0: ``start``, default the first sample); as many frames
    as the recording's duration, or the window up to ``stop``, fills."""
    t = np.asarray(t, dtype=float)
    if len(t) == 0:
        return np.zeros(0, dtype=np.intp)
    n = int(frame_count(t, fps, speed, start=start, stop=stop))
    first, _ = _window(t, start, stop)
    times = first + np.arange(n) * speed / fps
    return np.clip(np.searchsorted(t, times + 1e-9, side="right") - 1, 0, len(t) - 1)


__all__ = ["Replay", "choose_gl", "frame_count", "frame_samples", "recording_span",
           "BACKENDS"]
