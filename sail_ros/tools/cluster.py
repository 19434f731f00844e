"""The Dask client of a study: a local cluster for the run, or an existing scheduler.

    with dask_client(scheduler=None, workers=None) as client: ...

Default: a `LocalCluster` started for the run, one worker process per core
and one thread each (one BLAS thread too: the model's matrices are small and
several threads per process only compete), fewer where the memory available
would not hold them (`WORKER_BYTES` each); `--workers` may ask for fewer, not
more (`local_workers`). Every port of a local cluster (scheduler, workers,
nannies, Dask's HTTP endpoints and dashboard) listens on 127.0.0.1 only: Dask's
default would serve its dashboard on every interface. `scheduler="tcp://host:8786"`
uses a cluster started with the standard `dask scheduler` and `dask worker`
commands; its workers must have sail_ros installed.

Some of Dask's defaults cost the model's many small steps CPU in a worker, and
local workers go without them (`LOCAL_WORKER_CONFIG`;
`benchmarks/montecarlo_dask.py` measures a worker's time per sample against a
sample called in a plain process):
- MALLOC_TRIM_THRESHOLD_=65536, which the nanny sets before it starts a worker
  (`distributed.nanny.pre-spawn-environ`): glibc then returns freed memory to
  the system at once and, the threshold being set, no longer raises its mmap
  threshold, so the model's short-lived arrays come back as page faults. Local
  workers keep glibc's own settings; a value set in the environment still reaches
  them.
- the statistical profiler (`distributed.worker.profile`), which takes the
  worker's stack every 10 ms: the dashboard's profile page
  of a local cluster stays empty.
- the event loops' periodic work, which wakes a worker's loop thread many times a
  second and takes the interpreter from the thread that computes: the tick that
  watches for a blocked loop (every 20 ms), the system monitor (500 ms) and the
  memory monitor (100 ms). Local workers tick every second, look at the system
  every 5 s and at their memory every second: less of a sample's wall time goes
  beyond its thread's CPU time, and a blocked loop or a worker's memory growth is
  still seen within a second.
An external cluster's workers are started by their owner (`dask worker`), with
that owner's settings: the same holds there.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys

from sail_ros.model.integrals import available_memory_bytes

# what a local worker process may hold [bytes]: the interpreter, numpy, scipy, Dask and the
# model hold about 110 MiB, and a worker peaked at about 190 MiB through the reference
# Monte Carlo study (n_B, n_M = 4, 6)
WORKER_BYTES = 256 << 20
LOCAL_HOST = "127.0.0.1"  # a local cluster's ports, dashboard included: this machine only
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
        check_cluster_options(scheduler, workers)
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
    count = local_workers(workers)
    with (
        dask.config.set(LOCAL_WORKER_CONFIG),
        LocalCluster(
            n_workers=count,
            threads_per_worker=1,
            processes=True,
            host=LOCAL_HOST,
            # a free port (never a clash with another cluster), on loopback only
            dashboard_address=f"{LOCAL_HOST}:0",
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        where = f"; dashboard {client.dashboard_link}" if _has_dashboard() else ""
        print(f"Dask local cluster: {count} worker process(es), 1 thread each{where}",
              file=sys.stderr)  # fmt: skip
        yield client


def check_cluster_options(scheduler: str | None, workers: int | None) -> None:
    """--scheduler and --workers, checked before a study does anything (`local_workers`).

    Raises:
        ValueError: both given, or a number of local workers refused.
    """
    if scheduler:
        if workers is not None:
            raise ValueError("--workers sizes a local cluster; it cannot go with --scheduler")
    else:
        local_workers(workers)


def local_workers(workers: int | None) -> int:
    """How many worker processes a local cluster starts: `workers` (--workers), or by
    default one per core this process may use, as many as the available memory holds (at
    least one).

    Raises:
        ValueError: `workers` is below 1, above the cores (each worker computes with one
            thread: more would only take turns), or more than the memory available holds
            (`WORKER_BYTES` each, within 80 % of it).
    """
    cores = usable_cores()
    memory = available_memory_bytes()
    fit = max(1, int(0.8 * memory) // WORKER_BYTES) if memory is not None else cores
    if workers is None:
        return min(cores, fit)
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    if workers > cores:
        raise ValueError(
            f"--workers {workers}: more than the {cores} core(s) this process may use (a "
            "worker computes with one thread; more workers than cores only take turns)"
        )
    if workers > fit:
        raise ValueError(
            f"--workers {workers}: would need about {workers * WORKER_BYTES / 2**30:.3g} GiB "
            f"({WORKER_BYTES >> 20} MiB a worker), more than 80 % of the "
            f"{memory / 2**30:.3g} GiB available: at most {fit}"
        )
    return workers


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system tells it)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


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
