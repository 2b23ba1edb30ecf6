"""What Dask's own machinery costs a study: the CPU of the study's process (scheduler, nannies,
client) and of each worker beyond the task it runs, with Dask's default settings and with the
settings astrocpg gives a local cluster (``astrocpg.studies.runtime.cluster.LEAN_DASK``).

    python benchmarks/dask_overhead.py [--workers 2] [--seconds 4] [--repeats 3] [--codegen cython]

Each repeat starts a local cluster of ``--workers`` processes under each setting in turn, warms
every worker (imports, the compiled model), then has every worker run the closed loop of 20
trials for ``--seconds`` simulated seconds at once. It prints, per setting: the task's own CPU
per simulated second (the thread that runs it), each worker's CPU beyond that thread (Dask's
profiler, event loop, heartbeats) and the study process's CPU, both as a share of the tasks'
wall time. The overheads are CPU counted apart from the task, so they hold on a loaded machine;
the task's own cost moves with the load.
"""

from __future__ import annotations

import argparse
import logging
import os
import statistics
import time
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")


def closed_loop(seconds: float, codegen: str) -> tuple[float, float]:
    """(thread CPU s, wall s) of a 20-trial closed loop run in this worker."""
    os.environ["ASTROCPG_CODEGEN"] = codegen
    import astrocpg as ac

    t0, w0 = time.thread_time(), time.perf_counter()
    ac.run(seconds=seconds, trials=20, seed=1, progress=False, spikes=(), traces=())
    return time.thread_time() - t0, time.perf_counter() - w0


def measure(settings: dict[str, Any], workers: int, seconds: float,
            codegen: str) -> dict[str, float]:
    import dask
    import psutil
    from distributed import Client, LocalCluster

    with dask.config.set(settings):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        names = list(client.scheduler_info()["workers"])
        for w in names:  # warm each worker: imports and the compiled model
            client.submit(closed_loop, 0.05, codegen, pure=False, workers=[w]).result()
        kids = psutil.Process().children(recursive=True)

        def cpu(procs: list) -> float:
            return sum(sum(p.cpu_times()[:2]) for p in procs)

        k0, p0, w0 = cpu(kids), time.process_time(), time.perf_counter()
        futures = [client.submit(closed_loop, seconds, codegen, pure=False, workers=[w])
                   for w in names]
        results = client.gather(futures)
        k1, p1, wall = cpu(kids), time.process_time(), time.perf_counter() - w0
    finally:
        client.close()
        cluster.close()
    task_cpu = sum(r[0] for r in results)
    return {"task_cpu_per_sim_s": task_cpu / (seconds * workers),
            "worker_overhead": (k1 - k0 - task_cpu) / (wall * workers),
            "parent_overhead": (p1 - p0) / wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=4.0, help="simulated s per task")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--codegen", choices=("numpy", "cython"), default="cython")
    args = ap.parse_args()
    import distributed  # noqa: F401  (its settings join dask.config)

    from astrocpg.studies.runtime.cluster import LEAN_DASK

    settings = {"Dask's defaults": {}, "astrocpg's (LEAN_DASK)": LEAN_DASK}
    got: dict[str, list[dict[str, float]]] = {k: [] for k in settings}
    for _ in range(args.repeats):  # the settings in turn, so that drifts in load hit both
        for name, s in settings.items():
            got[name].append(measure(s, args.workers, args.seconds, args.codegen))
    print(f"{args.workers} workers, each a 20-trial closed loop of {args.seconds:g} simulated s "
          f"({args.codegen}), {args.repeats} repeats; load average before the last "
          f"{os.getloadavg()[0]:.1f}")
    print(f"{'settings':<24}{'task CPU s/sim s':>18}{'Dask in a worker':>18}"
          f"{'study process':>16}")
    for name, rows in got.items():
        med = {k: statistics.median(r[k] for r in rows) for k in rows[0]}
        tasks = ", ".join(f"{r['task_cpu_per_sim_s']:.3f}" for r in rows)
        spread = ", ".join(f"{r['worker_overhead']:.1%}" for r in rows)
        print(f"{name:<24}{med['task_cpu_per_sim_s']:>18.3f}{med['worker_overhead']:>18.1%}"
              f"{med['parent_overhead']:>16.1%}   (repeats: task {tasks}; Dask {spread})")
    print("Dask in a worker: its CPU beyond the task's thread, as a share of one core while "
          "the tasks ran; study process: the scheduler, nannies and client, the same way")


if __name__ == "__main__":
    main()
