"""Dask workers for astrocpg studies as SLURM jobs (dask-jobqueue), and their scheduler here.

    python docs/cluster/slurm_cluster.py --partition PARTITION --jobs 40 --memory 4GB \
        --walltime 12:00:00

prints the scheduler's address (``tcp://HOST:PORT``: give it to ``astrocpg study ...
--scheduler``) and keeps the workers running until Ctrl-C (or SIGTERM), which cancels their
jobs. Each job runs ``--cores`` worker processes of one thread each (Brian2 is not
thread-safe) and asks SLURM for that many CPUs, ``--memory`` and ``--walltime``. A job that
ends early (its walltime reached, cancelled, its node lost) is replaced by a new one, and the
run it was training resumes from its checkpoint on another worker. Needs ``pip install
dask-jobqueue`` in astrocpg's environment; the jobs run this environment's Python.
"""

import argparse
import signal
import sys
import time

from dask_jobqueue import SLURMCluster


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--partition", required=True, help="the SLURM partition (queue)")
    p.add_argument("--jobs", type=int, required=True, help="SLURM jobs to keep running")
    p.add_argument("--cores", type=int, default=1,
                   help="CPUs per job: as many single-thread workers (default 1)")
    p.add_argument("--memory", default="4GB", help="memory per job (default 4GB)")
    p.add_argument("--walltime", default="12:00:00", help="per job, HH:MM:SS (default 12:00:00)")
    p.add_argument("--account", help="the SLURM account to charge, if your cluster wants one")
    p.add_argument("--log-directory", help="where the jobs' output files go (default: here)")
    args = p.parse_args()

    cluster = SLURMCluster(queue=args.partition, account=args.account, cores=args.cores,
                           processes=args.cores, memory=args.memory, walltime=args.walltime,
                           log_directory=args.log_directory)
    # adapt, not scale: a job that ends is submitted again, so the study keeps its workers
    cluster.adapt(minimum_jobs=args.jobs, maximum_jobs=args.jobs)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))  # `kill`, `scancel` of this script
    print(cluster.scheduler_address, flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        cluster.close()  # cancels the jobs


if __name__ == "__main__":
    main()
