"""Running many independent cases on Dask (`dask.distributed`), or here.

The studies (`montecarlo`, `stability`) describe their work as a pure
function of one case and a list of cases; `run_cases` submits them to the
Dask `Client` it is given (a local cluster, or a scheduler anywhere) and
returns the results in case order, so where a case ran never shows in the
result. Without a client the cases run in this process, one after another.

A case function reports its own failures as data (a row with an error),
so one bad case never stops a study. Ctrl-C cancels what has not finished
and returns what has (`Outcome.interrupted`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple


class Outcome(NamedTuple):
    """Results in case order (None where a case did not finish), and whether the run
    was interrupted before every case finished."""

    results: list
    interrupted: bool


def run_cases(
    function: Callable,
    cases: Sequence,
    client=None,
    progress: Callable[[int], None] | None = None,
) -> Outcome:
    """`function(case)` for every case.

    Args:
        function: a picklable, module-level function of one case.
        cases: the cases (picklable).
        client: a `dask.distributed.Client`, or None to run here.
        progress: called with 1 after each finished case.
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

    # pure=False: equal cases are still separate runs (no result sharing by hash)
    futures = client.map(function, list(cases), pure=False)
    index_of = {future.key: index for index, future in enumerate(futures)}
    try:
        for future in as_completed(futures):
            results[index_of[future.key]] = future.result()
            if progress is not None:
                progress(1)
    except KeyboardInterrupt:
        client.cancel(futures)
        return Outcome(results, True)
    return Outcome(results, False)
