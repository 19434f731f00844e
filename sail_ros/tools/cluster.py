"""The Dask client of a study: a local cluster for the run, or an existing scheduler.

    with dask_client(scheduler=None, workers=None) as client: ...

Default: a `LocalCluster` started for the run, one worker process per core
and one thread each (one BLAS thread too: the model's matrices are small and
several threads per process only compete). `scheduler="tcp://host:8786"`
uses a cluster started with the standard `dask scheduler` and `dask worker`
commands; its workers must have sail_ros installed.

Some of Dask's defaults cost the model's many small steps CPU in a worker, and
local workers go without them (`LOCAL_WORKER_CONFIG`; measured, a sample took
21-34 % more CPU in a worker with Dask's defaults than called in a plain
process, 7-11 % more without the first two):
- MALLOC_TRIM_THRESHOLD_=65536, which the nanny sets before it starts a worker
  (`distributed.nanny.pre-spawn-environ`): glibc then returns freed memory to
  the system at once and, the threshold being set, no longer raises its mmap
  threshold, so the model's short-lived arrays come back as page faults (12-26
  % more CPU). Local workers keep glibc's own settings; a value set in the
  environment still reaches them.
- the statistical profiler (`distributed.worker.profile`), which takes the
  worker's stack every 10 ms (10-15 % more CPU): the dashboard's profile page
  of a local cluster stays empty.
- the event loops' periodic work, which wakes a worker's loop thread many times a
  second and takes the interpreter from the thread that computes: the tick that
  watches for a blocked loop (every 20 ms), the system monitor (500 ms) and the
  memory monitor (100 ms). Local workers tick every second, look at the system
  every 5 s and at their memory every second: on 2 workers, a sample's wall time
  beyond its thread's CPU time went from 3.4-3.6 to 0.9-1.0 ms, the main process's
  CPU from 0.56-0.77 to 0.16-0.17 s per 400 samples, and 400 samples from 15.1-15.4
  to 14.0-14.2 s. A blocked loop or a worker's memory growth is then seen within a
  second, not a fraction of one.
An external cluster's workers are started by their owner (`dask worker`), with
that owner's settings: the same holds there.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys

# what local workers are started with (the module docstring): glibc's malloc defaults,
# no statistical profiler, the event loops' periodic work seldom
LOCAL_WORKER_CONFIG = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None):
    """A connected `dask.distributed.Client`; the local cluster ends with the block."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # inherited by local workers
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler:
        if workers is not None:
            raise ValueError("--workers sizes a local cluster; it cannot go with --scheduler")
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as error:
            raise ValueError(f"--scheduler {scheduler}: cannot connect ({error})") from None
        print(f"Dask scheduler {scheduler}: {len(client.scheduler_info()['workers'])} worker(s)",
              file=sys.stderr)  # fmt: skip
        try:
            yield client
        finally:
            client.close()
        return
    count = workers if workers is not None else (os.cpu_count() or 1)
    if count < 1:
        raise ValueError(f"--workers must be >= 1, got {count}")
    with (
        dask.config.set(LOCAL_WORKER_CONFIG),
        LocalCluster(
            n_workers=count,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port: never a clash with another cluster
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        where = f"; dashboard {client.dashboard_link}" if _has_dashboard() else ""
        print(f"Dask local cluster: {count} worker process(es), 1 thread each{where}",
              file=sys.stderr)  # fmt: skip
        yield client


def _has_dashboard() -> bool:
    """Dask serves a dashboard only with bokeh installed."""
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return False
    return True


def add_cluster_options(parser) -> None:
    group = parser.add_argument_group("execution (Dask)")
    group.add_argument(
        "--workers", type=int, help="worker processes of the local cluster (default: one per core)"
    )
    group.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="use an existing Dask cluster, e.g. tcp://10.0.0.5:8786 "
        "(started with dask scheduler / dask worker)",
    )
