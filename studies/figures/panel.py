"""The strip under a video's frames (``astrocpg video --panel``): time, forward speed and a
scrolling gait diagram of the last seconds, drawn with matplotlib's Agg canvas."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ...network.layout import LEGS


class GaitPanel:
    """``draw(k)``: a (height, width, 3) uint8 image for robot sample ``k``: a gait diagram of
    the ``span`` s before it (foot contact, black) and the time and forward speed."""

    def __init__(self, robot: dict[str, Any], trial: int, width: int, height: int, *,
                 speed: float = 1.0, span: float = 2.0) -> None:
        self.t = np.asarray(robot["t"], dtype=float)
        force = np.asarray(robot["foot_force"])[trial] if "foot_force" in robot else None
        self.stance = (force > 0) if force is not None and np.all(np.isfinite(force)) else None
        self.step = float(np.median(np.diff(self.t))) if len(self.t) > 1 else 1e-3
        self.vx = np.asarray(robot["torso_velocity"])[trial][:, 0]
        self.speed, self.span = speed, span
        self.legs = [str(x) for x in robot.get("legs", LEGS)]
        dpi = 100
        self.fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.06, 0.28, 0.72, 0.62))
        self.text = self.fig.text(0.80, 0.5, "", fontsize=8, va="center", family="monospace")
        self.ax.set_yticks(range(len(self.legs)), self.legs, fontsize=7)
        self.ax.set_ylim(len(self.legs) - 0.5, -0.5)
        self.ax.tick_params(axis="x", labelsize=7)
        self.ax.set_xlabel("time (s)", fontsize=7, labelpad=1)
        self.image = None
        if self.stance is not None:
            self.image = self.ax.imshow(np.zeros((len(self.legs), 2)), aspect="auto",
                                        cmap="Greys", vmin=0, vmax=1, interpolation="nearest")
        self.size = (height, width)

    def draw(self, k: int) -> np.ndarray:
        t_now = self.t[k]
        t0 = t_now - self.span
        sel = (self.t > t0) & (self.t <= t_now)
        if self.image is not None and sel.any():
            self.image.set_data(self.stance[sel].T.astype(float))
            self.image.set_extent((self.t[sel][0] - self.step, t_now, len(self.legs) - 0.5, -0.5))
        self.ax.set_xlim(t0, t0 + self.span)
        title = "foot contact (black)" if self.stance is not None else "no foot contact recorded"
        self.ax.set_title(title, fontsize=7, pad=2)
        self.text.set_text(f"t = {t_now:6.2f} s\nx{self.speed:g} real time\n"
                           f"vx = {self.vx[k]:+.2f} m/s")
        self.canvas.draw()
        rgba = np.asarray(self.canvas.buffer_rgba())
        return np.ascontiguousarray(rgba[: self.size[0], : self.size[1], :3])


__all__ = ["GaitPanel"]
