"""Fixtures shared by the tiled-processing tests."""

from __future__ import annotations

import distributed
import pytest


@pytest.fixture(scope="module")
def client():
    """An in-process dask client with one single-threaded worker (one per test module)."""
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as c:
        yield c


@pytest.fixture(scope="module")
def scheduler():
    """An in-process cluster the commands reach by its address (no worker processes)."""
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as cluster:
        yield cluster.scheduler_address
