"""Fixtures shared by the tiled-processing tests."""

from __future__ import annotations

import dask
import distributed
import pytest

from pointatlas.batch._runner import NO_PROFILER


@pytest.fixture(scope="module")
def client():
    """An in-process dask client with one single-threaded worker (one per test module),
    without dask's statistical profiler (as `scheduler`)."""
    with (
        dask.config.set(NO_PROFILER),
        distributed.Client(
            processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
        ) as c,
    ):
        yield c


@pytest.fixture(scope="module")
def scheduler():
    """An in-process cluster the commands reach by its address (no worker processes),
    without dask's statistical profiler (`pointatlas.batch._runner.NO_PROFILER`: its
    ``sys._current_frames()`` deadlocked a tiled segment's worker thread twice)."""
    with (
        dask.config.set(NO_PROFILER),
        distributed.LocalCluster(
            processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
        ) as cluster,
    ):
        yield cluster.scheduler_address
