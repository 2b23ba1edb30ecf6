"""One way to write a figure: the functions that draw return matplotlib ``Figure`` objects
(made outside pyplot, so drawing leaves a notebook's backend and open figures alone), and
:func:`save_figure` / :func:`save_figures` write them, all at one resolution (:data:`DPI`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

from matplotlib.figure import Figure

DPI = 110  # every figure astrocpg writes (PNG pixels per inch; PDF/SVG images inside)
FORMATS = ("png", "pdf", "svg")


def save_figure(fig: Figure, path: Any, fmt: str | None = None) -> Path:
    """Write ``fig`` to ``path`` at :data:`DPI` (format: ``fmt``, or the path's suffix);
    returns the path."""
    path = Path(path)
    fig.savefig(path, dpi=DPI, format=fmt)
    return path


def save_figures(figures: dict[str, Figure], folder: Any, fmt: str = "png", *,
                 on_saved: Callable[[], None] | None = None) -> list[Any]:
    """Write each figure as ``folder/<name>.<fmt>``; returns the paths. ``on_saved`` is called
    after each figure (a progress bar's step)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fig in figures.items():
        paths.append(save_figure(fig, folder / f"{name}.{fmt}", fmt))
        if on_saved is not None:
            on_saved()
    return paths


__all__ = ["DPI", "FORMATS", "save_figure", "save_figures"]
