"""The panel under a video's frames (``astrocpg video`` with ``panel``), drawn with matplotlib's Agg
canvas: the time and forward speed, a scrolling gait diagram and, when the replayed result
recorded them, the activity of each leg's thigh pools and the Ca2+ of their astrocytes, all in
one time window that scrolls with the frame's time (a vertical line marks "now").

Every artist is made once; a frame only moves data and limits (``set_data``, ``set_xlim``),
and the pool activity is binned once for the whole recording, so a frame costs one canvas draw.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ...network.layout import LEGS, THIGH_POOLS
from ...network.populations import trace_sources
from ..analysis.fall import first_fall
from ..analysis.rhythm import convolve_same, pool_activity
from .plots import POOL_COLOURS
from .traces import DT, recorded_span

#: pool activity: spikes counted per network step (DT), smoothed over a box longer than the
#: ~18 ms between a bursting pool's volleys (else a burst reads as a comb), drawn every 10 ms
SMOOTH_S = 0.04
GRID_S = 0.01
#: the fraction of the window before "now" (the rest shows what comes next)
PAST = 0.75
#: half a leg's row of the activity diagram that the trial's highest rate fills
ROW = 0.45
LEG_COLOURS = ("tab:green", "tab:purple", "tab:brown", "tab:gray")
CALCIUM = "astrocyte_Ca"

# layout in pixels at scale 1 (a 640 x 240 panel); larger panels scale fonts and margins
_LEFT, _RIGHT, _TOP, _BOTTOM, _GAP = 62, 104, 6, 30, 6
_SHARES = {"gait": 0.28, "activity": 0.36, "calcium": 0.36}
_FONT = 7


def panel_height(frame_height: int, result: Any | None) -> int:
    """Even pixel height (H.264) of the panel under a frame ``frame_height`` pixels tall: a
    third of it for the gait diagram alone (no ``result``), else half of it and at least 240
    pixels, so the activity and Ca2+ rows stay readable under a small frame."""
    if result is None:
        return (frame_height // 3) // 2 * 2
    return max(frame_height // 2, 240) // 2 * 2


class GaitPanel:
    """``draw(k)``: a (height, width, 3) uint8 image for robot sample ``k``: the ``span`` s
    around it (``PAST`` of it before), as a gait diagram (foot contact, black) and, with
    ``result`` (the Result whose robot is replayed; ``trial`` indexes both), rows of each leg's
    thigh extensor and flexor activity (spikes per neuron per s, extensor upwards, flexor
    downwards) and of the Ca2+ of each leg's thigh-pool astrocytes (µM); a row whose data was not
    recorded holds a note. Beside them: the time, the playback speed and the forward speed.
    For inspection: ``axes`` ({"gait", "activity", "calcium"}: Axes), ``now`` (the "now"
    lines) and ``series`` ((line, t, values) of each activity and Ca2+ line, whole
    recording)."""

    def __init__(self, robot: dict[str, Any], trial: int, width: int, height: int, *,
                 speed: float = 1.0, span: float = 2.0, result: Any | None = None) -> None:
        self.t = np.asarray(robot["t"], dtype=float)
        force = np.asarray(robot["foot_force"])[trial] if "foot_force" in robot else None
        self.stance = (force > 0) if force is not None and np.all(np.isfinite(force)) else None
        self.step = float(np.median(np.diff(self.t))) if len(self.t) > 1 else 1e-3
        self.vx = np.asarray(robot["torso_velocity"])[trial][:, 0]
        # the fall, said beside the time from the frame it happens on (a video of a fallen
        # robot says so, as its figures do)
        self.fall = (first_fall(self.t, np.asarray(robot["alive"])[trial]) if "alive" in robot
                     else None)
        self.speed, self.span = speed, span
        self.legs = [str(x) for x in robot.get("legs", LEGS)]
        self.size = (height, width)
        rows = ["gait"] if result is None else ["gait", "activity", "calcium"]

        # fonts are in points: a dpi that grows with the panel scales text and margins alike
        scale = max(1.0, min(width / 640, height / 240))
        dpi = 100 * scale
        self.fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        self.axes = self._layout(rows, width, height, scale)
        self.now = [ax.axvline(0.0, color="tab:orange", lw=1.0, zorder=5)
                    for ax in self.axes.values()]
        self.series: list[tuple[Line2D, np.ndarray, np.ndarray]] = []

        gait = self.axes["gait"]
        gait.set_yticks(range(len(self.legs)), self.legs)
        gait.set_ylim(len(self.legs) - 0.5, -0.5)
        gait.set_ylabel("foot\ncontact")
        self.image = None
        if self.stance is not None:
            self.image = gait.imshow(np.zeros((len(self.legs), 2)), aspect="auto", cmap="Greys",
                                     vmin=0, vmax=1, interpolation="nearest")
        else:
            _note(gait, "no foot contact recorded")
        if result is not None:
            self._activity(self.axes["activity"], result, trial)
            self._calcium(self.axes["calcium"], result, trial)
        bottom = self.axes[rows[-1]]
        bottom.set_xlabel("time (s)", labelpad=1)
        top = gait.get_position()
        self.text = self.fig.text(top.x1 + 6 * scale / width, (top.y0 + top.y1) / 2, "",
                                  fontsize=_FONT, va="center", family="monospace")
        # what changes from frame to frame is drawn over a background drawn once (blitting):
        # labels, y axes and legends cost most of a full draw and never move
        moving = [line for line, _, _ in self.series] + self.now + [self.image]
        self._moving: list[tuple[Any, list[Any]]] = [
            (ax, sorted((a for a in moving if a is not None and a.axes is ax),
                        key=lambda a: a.get_zorder()) + [ax.xaxis])
            for ax in self.axes.values()]
        for _, artists in self._moving:
            for a in artists:
                a.set_animated(True)
        self.text.set_animated(True)
        self._background = None

    # ------------------------------------------------------------ set-up
    def _layout(self, rows: list[str], width: int, height: int,
                scale: float) -> dict[str, Any]:
        """One axes per row, stacked, sharing the time axis, in fixed pixel margins (the left
        one for y labels, the right one for the text and the legends)."""
        left, right = _LEFT * scale, _RIGHT * scale
        if left + right > 0.6 * width:  # a narrow frame: the time axis keeps 40 % of it
            left, right = (m * 0.6 * width / (left + right) for m in (left, right))
        top, bottom, gap = _TOP * scale, _BOTTOM * scale, _GAP * scale
        free = height - top - bottom - gap * (len(rows) - 1)
        total = sum(_SHARES[r] for r in rows)
        axes: dict[str, Any] = {}
        y = height - top
        for r in rows:
            h = free * _SHARES[r] / total
            y -= h
            box = (left / width, y / height, (width - left - right) / width, h / height)
            ax = self.fig.add_axes(box, sharex=axes.get(rows[0]))
            ax.tick_params(labelsize=_FONT - 0.5, length=2, pad=1)
            ax.yaxis.label.set_size(_FONT)
            ax.xaxis.label.set_size(_FONT)
            if r != rows[-1]:
                ax.tick_params(labelbottom=False)
            axes[r] = ax
            y -= gap
        return axes

    def _activity(self, ax: Any, result: Any, trial: int) -> None:
        """Each leg's thigh extensor (upwards) and flexor (downwards) around the leg's row,
        binned once: neurons spiking per step, smoothed, as spikes per neuron per s."""
        ax.set_yticks(range(len(self.legs)), self.legs[::-1])
        ax.set_ylim(-0.5, len(self.legs) - 0.5)
        if "motor" not in result.spikes:
            ax.set_ylabel("pool\nactivity")
            _note(ax, "motor spikes not recorded")
            return
        L = result.layout
        times, indices = (np.asarray(a) for a in result.spikes["motor"])
        t_stop = recorded_span(result)[1]
        width = max(1, int(round(SMOOTH_S / DT)))
        every = max(1, int(round(GRID_S / DT)))
        rates = {}
        for leg_i in range(L.n_legs):
            for pool in THIGH_POOLS:
                counts = pool_activity(times, indices, L.motor_neurons(trial, leg_i, pool),
                                       t_stop, DT).astype(float)
                smooth = convolve_same(counts, np.ones(width) / width)
                rates[leg_i, pool] = smooth[::every] / (L.pool_size * DT)
        n = len(next(iter(rates.values())))
        grid = (np.arange(n) * every + 0.5) * DT  # the centre of each sampled step
        peak = max(float(np.max(r, initial=0.0)) for r in rates.values()) or 1.0
        for base in range(len(self.legs)):  # each leg's zero (static: drawn once)
            ax.axhline(base, color="0.8", lw=0.5, zorder=1)
        for (leg_i, pool), rate in rates.items():
            base = len(self.legs) - 1 - leg_i  # the first leg on top, as in the gait diagram
            sign = 1.0 if pool == "thigh_extensor" else -1.0
            line, = ax.plot([], [], lw=0.8, color=POOL_COLOURS[pool])
            self.series.append((line, grid, base + sign * ROW * rate / peak))
        ax.set_ylabel(f"pool activity\n(0–{peak:.0f} Hz)")
        handles = [Line2D([], [], color=POOL_COLOURS["thigh_extensor"], label="extensor ↑"),
                   Line2D([], [], color=POOL_COLOURS["thigh_flexor"], label="flexor ↓")]
        self._legend(ax, handles, ncol=1, title="thigh pool")

    def _calcium(self, ax: Any, result: Any, trial: int) -> None:
        """One line per thigh-pool astrocyte: colour by leg, solid extensor, dashed flexor."""
        unit = trace_sources(result.layout.rows)[CALCIUM][3].replace("uM", "µM")
        ax.set_ylabel(f"astrocyte\nCa²⁺ ({unit})")
        if CALCIUM not in result.traces:
            ax.set_yticks([])
            _note(ax, "astrocyte Ca²⁺ not recorded")
            return
        L = result.layout
        t, values = (np.asarray(a, dtype=float) for a in result.traces[CALCIUM])
        values = values[:, None] if values.ndim == 1 else values
        cols = []
        for leg_i in range(L.n_legs):
            for pool in THIGH_POOLS:
                col = L.thigh_pool(trial, leg_i, pool)
                cols.append(values[:, col])
                line, = ax.plot([], [], lw=0.8, color=LEG_COLOURS[leg_i % len(LEG_COLOURS)],
                                ls="-" if pool == "thigh_extensor" else "--")
                self.series.append((line, t, values[:, col]))
        # fixed limits over the whole recording: a level reads the same in every frame
        lo, hi = (float(f(np.stack(cols))) for f in (np.nanmin, np.nanmax)) if len(t) \
            else (0.0, 1.0)
        pad = 0.08 * (hi - lo) if hi > lo else max(abs(hi), 1e-3) * 0.1
        ax.set_ylim(lo - pad, hi + pad)
        ax.yaxis.get_major_locator().set_params(nbins=3)
        handles = [Line2D([], [], color=LEG_COLOURS[i % len(LEG_COLOURS)], label=leg)
                   for i, leg in enumerate(L.legs)]
        handles += [Line2D([], [], color="k", ls="-", label="ext"),
                    Line2D([], [], color="k", ls="--", label="flex")]
        self._legend(ax, handles, ncol=2)

    def _legend(self, ax: Any, handles: list[Line2D], *, ncol: int, title: str | None = None):
        ax.legend(handles=handles, loc="center left", bbox_to_anchor=(1.0, 0.5), ncol=ncol,
                  fontsize=_FONT - 1, title=title, title_fontsize=_FONT - 1, frameon=False,
                  handlelength=1.6, columnspacing=0.8, labelspacing=0.2, borderaxespad=0.4,
                  handletextpad=0.4, borderpad=0.2)

    # ------------------------------------------------------------ per frame
    def draw(self, k: int) -> np.ndarray:
        t_now = float(self.t[k])
        t0 = t_now - PAST * self.span
        t1 = t0 + self.span
        if self.image is not None:
            i0, i1 = np.searchsorted(self.t, (t0, t1), side="right")
            if i1 > i0:
                self.image.set_data(self.stance[i0:i1].T.astype(float))
                self.image.set_extent((self.t[i0] - self.step, self.t[i1 - 1],
                                       len(self.legs) - 0.5, -0.5))
        for line, x, y in self.series:
            # one sample beyond each edge, so a line reaches the window's edges
            i0, i1 = np.searchsorted(x, (t0, t1))
            i0, i1 = max(i0 - 1, 0), min(i1 + 1, len(x))
            line.set_data(x[i0:i1], y[i0:i1])
        for line in self.now:
            line.set_xdata([t_now, t_now])
        self.axes["gait"].set_xlim(t0, t1)  # the rows share the time axis
        fell = (f"\nfell at {self.fall.t_s:.2f} s"
                if self.fall is not None and t_now >= self.fall.t_s else "")
        self.text.set_text(f"t = {t_now:6.2f} s\nx{self.speed:g} real time\n"
                           f"vx = {self.vx[k]:+.2f} m/s{fell}")
        if self._background is None:
            self.canvas.draw()
            self._background = self.canvas.copy_from_bbox(self.fig.bbox)
        else:
            self.canvas.restore_region(self._background)
        for ax, artists in self._moving:
            for a in artists:
                ax.draw_artist(a)
        self.fig.draw_artist(self.text)
        rgba = np.asarray(self.canvas.buffer_rgba())
        return np.ascontiguousarray(rgba[: self.size[0], : self.size[1], :3])


def _note(ax: Any, text: str) -> None:
    """What a row would show was not recorded: say so in it."""
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center",
            fontsize=_FONT, color="0.35")


__all__ = ["GaitPanel", "panel_height"]
