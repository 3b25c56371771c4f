"""The caller's neighbour table of `normal_voting_denoise`, checked before any work."""

from __future__ import annotations

import numpy as np

from .._core import check_neighbors
from .._core.tolerances import DENOISE_K_MAX, DENOISE_K_WIDTH
from ._threads import threads_for

__all__ = ["check_table"]


def check_table(neighbors, n: int, adaptive: bool) -> np.ndarray:
    """The ``neighbors=`` table of `normal_voting_denoise`: at least min(48 (+10
    adaptive), N) columns, each row starting with its point."""
    need = min(DENOISE_K_MAX + (DENOISE_K_WIDTH if adaptive else 0), n)
    with threads_for(n):  # a parallel check: one thread on a busy machine, as the run
        table = check_neighbors(neighbors, n)
    if table.shape[1] < need:
        raise ValueError(
            f"neighbors must have at least {need} columns (min(48, N), +10 for the "
            f"adaptive k); got {table.shape[1]}"
        )
    if not (table[:, 0] == np.arange(n)).all():
        raise ValueError("neighbors must list every point first in its own row")
    return table
