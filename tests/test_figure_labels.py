"""Figures a reader can read: a gait map's cell labels stay inside their cells and its tick
labels apart (a grid of 9 x 9 numbers with units), and a session axis is ticked at whole
sessions (a 3-session training: 1, 2, 3, never 1.25)."""

from __future__ import annotations

import random

import matplotlib

matplotlib.use("Agg")

from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402

from astrocpg.studies.figures.gait_map import gait_map_figures  # noqa: E402


def _grid(nx: int, ny: int) -> tuple[list[dict], list[str], list[str]]:
    random.seed(1)
    xs = [f"{1104 + 69 * k}*mV/second" for k in range(nx)]
    ys = [f"{0.6 + 0.1 * k:.1f}" for k in range(ny)]
    rows = [{"condition": "astrocytes", "gait": random.choice(["none", "trot", "bound"]),
             "mean_speed_m_per_s": random.random(), "fell": random.random() < 0.5,
             "grid_I_background_0": x, "grid_torque_gain": y}
            for x in xs for y in ys for _ in range(3)]
    return rows, xs, ys


def test_gait_map_labels_fit_their_cells_and_ticks_do_not_overlap() -> None:
    for nx, ny in ((5, 5), (9, 9), (12, 4)):
        rows, xs, ys = _grid(nx, ny)
        fig = gait_map_figures(rows, [("torque_gain", ys), ("I_background_0", xs)],
                               {"I_background_0": "I_background_0",
                                "torque_gain": "torque_gain"})["gait_map.png"]
        FigureCanvasAgg(fig).draw()
        renderer = fig.canvas.get_renderer()
        ax = fig.axes[0]
        cells = [t for t in ax.texts if "%" in t.get_text() or t.get_text() in
                 ("trot", "none", "bound")]
        assert len(cells) == nx * ny
        for t in cells:
            x, y = t.get_position()
            (x0, y0), (x1, y1) = ax.transData.transform([(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)])
            box = t.get_window_extent(renderer)
            assert x0 - 1 <= box.x0 and box.x1 <= x1 + 1 and y0 - 1 <= box.y0 and box.y1 <= y1 + 1, \
                (nx, ny, t.get_text(), box, (x0, y0, x1, y1))
            assert t.get_fontsize() >= 4.5, (nx, ny, t.get_fontsize())
        ticks = [t for t in ax.get_xticklabels() if t.get_text()]
        assert [t.get_text() for t in ticks][:2] == ["1104", "1173"]  # the unit on the axis
        assert "mV/second" in ax.get_xlabel()
        boxes = [t.get_window_extent(renderer) for t in ticks]
        for a, b in zip(boxes, boxes[1:]):
            assert a.x1 <= b.x0 + 0.5 or abs(a.y0 - b.y0) > a.height, (nx, ny, a, b)


def test_a_session_axis_is_ticked_at_whole_sessions(tmp_path) -> None:
    from astrocpg.studies.figures.plots import plot_training_curves
    from astrocpg.studies.figures.study_report import fig3c
    import numpy as np

    csv = tmp_path / "sessions.csv"
    csv.write_text("trial,session,mean_reward,final_x_m,length_s\n"
                   + "".join(f"0,{s},{0.1 * s},{0.2 * s},1.0\n" for s in (1, 2, 3)))
    three = (np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.1, 0.1]))
    for fig in (plot_training_curves(csv), fig3c("s", [(0, "a", [three] * 3)], 1)):
        FigureCanvasAgg(fig).draw()
        ticks = [t for t in fig.axes[-1].get_xticks()
                 if fig.axes[-1].get_xlim()[0] <= t <= fig.axes[-1].get_xlim()[1]]
        assert ticks and all(float(t).is_integer() for t in ticks), ticks
