"""kinegym.agents.parallel: jobs shared among processes come back in the jobs' order, whatever
the number of processes, and each is reported done once."""

from __future__ import annotations

import math

import pytest

from kinegym.agents.parallel import in_order


@pytest.mark.parametrize("start_method", ["spawn", "forkserver"])
def test_results_come_back_in_the_jobs_order_from_several_processes(start_method: str) -> None:
    jobs = [7, 3, 12, 1, 9]
    seen: list[int] = []
    got = in_order(math.factorial, jobs, 2, seen.append, start_method=start_method)
    assert got == [math.factorial(j) for j in jobs] == in_order(math.factorial, jobs, 1)
    assert seen == jobs  # done(job) once each, in order
    assert in_order(math.factorial, jobs, 3, start_method=start_method, chunksize=2) == got


def test_a_worker_count_below_one_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match="workers=0; expected an integer >= 1"):
        in_order(math.factorial, [1], 0)
