"""Jobs in worker processes, results in the jobs' order: the one way kinegym's trainers share
work among cores (the cell classifier's and grid arbiter's photos, the gait warm start's climbs).
The results do not depend on how many processes there are or which ends first."""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable, Sequence
from typing import TypeVar

J, R = TypeVar("J"), TypeVar("R")


def in_order(fn: Callable[[J], R], jobs: Sequence[J], workers: int, done: Callable[[J], None] | None = None,
             start_method: str = "spawn", chunksize: int = 1) -> list[R]:
    """``fn`` of every job, in the jobs' order, in ``workers`` processes started by
    ``start_method`` (``"spawn"``, ``"forkserver"``; 1 worker: here), handed out ``chunksize``
    jobs at a time; ``done(job)`` here as each result arrives. ``fn`` and the jobs must pickle
    when ``workers > 1`` (``fn`` a module-level function or a ``functools.partial`` of one)."""
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers={workers!r}; expected an integer >= 1")
    out: list[R] = []
    if workers > 1:
        with mp.get_context(start_method).Pool(workers) as pool:
            for job, res in zip(jobs, pool.imap(fn, jobs, chunksize=chunksize)):
                out.append(res)
                if done is not None:
                    done(job)
    else:
        for job in jobs:
            out.append(fn(job))
            if done is not None:
                done(job)
    return out
