"""Running many independent cases on Dask (`dask.distributed`), or here.

The studies (`montecarlo`, `stability`) describe their work as a pure
function of one case and a list of cases; `run_cases` submits them to the
Dask `Client` it is given (a local cluster, or a scheduler anywhere) and
returns the results in case order, so where a case ran never shows in the
result. Without a client the cases run in this process, one after another.

On a cluster the cases go in batches, one task each (`batch_sizes`): a task
costs the scheduler, the client and the worker a few milliseconds of Python
each, and its arguments are pickled per task, so a study's shared parts (its
scenario document, the base parameters), which every case holds, travel once
per batch instead of once per case. The batches shrink towards the end of the
study (guided self-scheduling), so that no worker is left with a long batch
while the others have finished: a study ends within about one case of its
last worker's, not within one batch. A batch's results come back together;
the progress callback counts its cases.

A case function reports its own failures as data (a row with an error),
so one bad case never stops a study. Ctrl-C cancels what has not finished
and returns what has (`Outcome.interrupted`).
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

MAX_BATCH = 20  # cases per task at most: the progress bar still moves every few seconds
TASKS_PER_WORKER = 8  # at least this many tasks per worker: the load stays balanced
TAIL_SHARE = 2  # near the end a task takes at most 1 / TAIL_SHARE of a worker's share


class Outcome(NamedTuple):
    """Results in case order (None where a case did not finish), and whether the run
    was interrupted before every case finished."""

    results: list
    interrupted: bool


def batch_size(cases: int, workers: int) -> int:
    """Cases per task: as many as leave `TASKS_PER_WORKER` tasks per worker, at most
    `MAX_BATCH`, at least 1."""
    return max(1, min(MAX_BATCH, math.ceil(cases / (TASKS_PER_WORKER * max(workers, 1)))))


def batch_sizes(cases: int, workers: int) -> list[int]:
    """The cases of each task in order, summing to `cases`: `batch_size`, and once
    fewer cases remain than `TAIL_SHARE` batches per worker hold, a `TAIL_SHARE`-th of
    a worker's share of what remains (at least 1): the last tasks take one case each."""
    workers = max(workers, 1)
    largest, sizes, remaining = batch_size(cases, workers), [], cases
    while remaining > 0:
        size = max(1, min(largest, math.ceil(remaining / (TAIL_SHARE * workers))))
        sizes.append(size)
        remaining -= size
    return sizes


def run_batch(function: Callable, cases: Sequence) -> list:
    """`function(case)` for each of `cases`, in order: one task's work."""
    return [function(case) for case in cases]


def run_cases(
    function: Callable,
    cases: Sequence,
    client=None,
    progress: Callable[[int], None] | None = None,
    batch: int | None = None,
) -> Outcome:
    """`function(case)` for every case.

    Args:
        function: a picklable, module-level function of one case.
        cases: the cases (picklable).
        client: a `dask.distributed.Client`, or None to run here.
        progress: called with the number of cases finished, after each finished batch
            (each case when run here).
        batch: cases per task on a cluster; default `batch_sizes` for its workers.
    """
    results: list = [None] * len(cases)
    if client is None:
        try:
            for index, case in enumerate(cases):
                results[index] = function(case)
                if progress is not None:
                    progress(1)
        except KeyboardInterrupt:
            return Outcome(results, True)
        return Outcome(results, False)

    from dask.distributed import as_completed

    cases = list(cases)
    if batch is None:
        sizes = batch_sizes(len(cases), len(client.scheduler_info()["workers"]))
    else:
        sizes = [min(batch, len(cases) - start) for start in range(0, len(cases), batch)]
    starts = [0, *itertools.accumulate(sizes)][:-1]
    # pure=False: equal batches are still separate runs (no result sharing by hash)
    futures = client.map(
        functools.partial(run_batch, function),
        [cases[start : start + size] for start, size in zip(starts, sizes, strict=True)],
        pure=False,
    )
    start_of = {future.key: start for future, start in zip(futures, starts, strict=True)}
    try:
        for future in as_completed(futures):
            done = future.result()
            start = start_of[future.key]
            results[start : start + len(done)] = done
            if progress is not None:
                progress(len(done))
    except KeyboardInterrupt:
        client.cancel(futures)
        return Outcome(results, True)
    return Outcome(results, False)
