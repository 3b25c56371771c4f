"""One numba thread for small inputs on a busy machine (speed only; same output)."""

from __future__ import annotations

from .._core._threads import machine_busy, one_thread_if

__all__ = ["PARALLEL_MIN_POINTS", "machine_busy", "threads_for"]

#: below this many points, on a busy machine (1-minute load average >= the number
#: of CPUs), the denoisers run every numba kernel they call (this room's and those
#: of the neighbours, normals and features rooms) in one thread (`threads_for`): a
#: filter step costs about 1 ms per 6,500 points, less than a parallel region
#: loses when one of its threads waits for a busy core; on an idle machine the
#: second thread pays (measured both ways: docs/decisions/denoise.md, "Speed").
#: Outputs are the same bit for bit (per-point loops; tested)
PARALLEL_MIN_POINTS = 50_000


def threads_for(n_points: int):
    """Run the enclosed numba parallel regions in one thread for small inputs on a busy machine.

    Below `PARALLEL_MIN_POINTS` points, when `machine_busy`, sets numba's thread
    count to 1 for the calling thread (numba's setting is thread-local) and
    restores it on exit; otherwise changes nothing. Results do not depend on it.
    """
    return one_thread_if(n_points < PARALLEL_MIN_POINTS and machine_busy())
