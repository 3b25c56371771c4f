"""The exact Euclidean distance transform of the robust path's grids
(`simplify/_edt.py`): scipy's `distance_transform_edt`, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from pointatlas.simplify._edt import distance_to


@pytest.mark.parametrize(
    ("shape", "share"),
    [
        ((5, 6, 7), 0.05),
        ((30, 1, 40), 0.01),
        ((1, 1, 40), 0.05),
        ((50, 60, 70), 0.001),
        ((24, 24, 24), 0.3),
    ],
)
def test_distance_to_is_scipys_edt_bit_for_bit(shape, share):
    occupied = np.random.default_rng(sum(shape)).random(shape) < share
    occupied[0, 0, 0] = True  # at least one occupied cell
    got = distance_to(occupied)
    np.testing.assert_array_equal(got, ndimage.distance_transform_edt(~occupied))
    assert got.max() > 1.0  # distances of several cells: the envelope passes ran


def test_one_cell_and_an_empty_grid():
    occupied = np.zeros((4, 5, 6), dtype=bool)
    assert np.isinf(distance_to(occupied)).all()
    occupied[1, 2, 3] = True
    i, j, k = np.indices(occupied.shape)
    want = np.sqrt((i - 1.0) ** 2 + (j - 2.0) ** 2 + (k - 3.0) ** 2)
    np.testing.assert_array_equal(distance_to(occupied), want)
    with pytest.raises(ValueError, match="3-D grid"):
        distance_to(occupied[0])
