"""The one engine that runs many *cells*: a study's runs (one training each) and an
evaluation's (controller x world) cells alike.

A cell is a name and the arguments of one call of a function. The engine

- leaves out the cells a store already holds finished (:func:`pending`: the study's runs whose
  ``status.json`` says they ended, the evaluation's cells kept in ``<out>.parts/`` under the
  same fingerprint), so a command started again runs only the rest;
- runs the others in the order given, here one after the other, or on a Dask cluster (a
  running one the caller holds, or one connected for these cells and closed after them), one
  cell per free worker thread (:func:`~astrocpg.studies.runtime.cluster.run_on_cluster`);
- hands each ending cell to the caller (``ended``), which saves it, and keeps the caller's
  progress bar until the last one, closing it whatever happens.

What a cell computes, how it is saved and what the bar counts (a study's sessions, an
evaluation's cells) are the caller's.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, Sequence, TypeVar

from .cluster import connect_cluster, run_on_cluster

T = TypeVar("T")


class Finished:
    """A cell that ran here, as ``ended`` receives it: read like a finished Dask future
    (``status``, ``result()``, ``exception()``)."""

    status = "finished"

    def __init__(self, value: Any) -> None:
        self._value = value

    def result(self) -> Any:
        return self._value

    def exception(self) -> None:
        return None


def pending(cells: Mapping[str, T], finished: Callable[[str], Any]
            ) -> tuple[dict[str, Any], dict[str, T]]:
    """``(done, todo)``: the cells whose ``finished(name)`` is not None ({name: that value},
    what a store kept of them) and the cells still to run ({name: cell}), both in the order of
    ``cells``."""
    done: dict[str, Any] = {}
    todo: dict[str, T] = {}
    for name, cell in cells.items():
        value = finished(name)
        if value is None:
            todo[name] = cell
        else:
            done[name] = value
    return done, todo


def run_cells(fn: Callable[..., Any], todo: Sequence[tuple[str, tuple]],
              ended: Callable[[str, Any], None], *, bar: Any = None, here: bool = False,
              client: Any = None, workers: int | None = None, scheduler: str | None = None,
              tick: Callable[[int], None] | None = None) -> None:
    """``fn(*args)`` for each ``(name, args)`` of ``todo``, in that order, and
    ``ended(name, outcome)`` as each ends.

    ``here``: in this process, one after the other; ``outcome`` is :class:`Finished`, and an
    error a cell raises stops the others and comes out of this call. Otherwise on Dask: on
    ``client`` (a cluster the caller connected and closes), or on a cluster connected now
    (a local one of ``workers`` processes, or the running ``scheduler``) and closed once the
    cells are done; ``outcome`` is the cell's future (its ``result()`` raises the cell's own
    error), ``tick(in_flight)`` is called about every second. ``bar`` (a progress bar, or
    None) is closed at the end, whatever happens."""
    try:
        if here:
            for name, args in todo:
                ended(name, Finished(fn(*args)))
            return
        if client is not None:
            run_on_cluster(client, fn, todo, ended, tick)
            return
        client, cluster = connect_cluster(workers, scheduler)
        try:
            run_on_cluster(client, fn, todo, ended, tick)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    finally:
        if bar is not None:
            bar.close()


__all__ = ["Finished", "pending", "run_cells"]
