"""`check_neighbors`: the one validation of a neighbour table (``neighbors=``)."""

import numpy as np
import pytest

from pointatlas._core import PointAtlasError, check_neighbors


def test_returns_contiguous_int64_first_k_columns():
    table = np.array([[0, 1, 2], [1, 0, 2], [2, 1, 0]], dtype=np.int32)
    out = check_neighbors(table, 3, k=2)
    assert out.dtype == np.int64 and out.flags.c_contiguous
    np.testing.assert_array_equal(out, table[:, :2])
    np.testing.assert_array_equal(check_neighbors(table, 3), table)


def test_accepts_the_query_knn_tuple():
    table = np.array([[0, 1], [1, 0]])
    out = check_neighbors((table, np.zeros((2, 2))), 2)
    np.testing.assert_array_equal(out, table)


def test_view_when_no_conversion_is_needed():
    table = np.array([[0, 1], [1, 0]], dtype=np.int64)
    assert check_neighbors(table, 2) is table


@pytest.mark.parametrize(
    ("table", "kwargs", "error", "match"),
    [
        (np.zeros((3, 2)), {}, TypeError, "neighbors must be an integer index array; got dtype"),
        (
            np.zeros((3, 1), dtype=int),
            {"k": 2},
            ValueError,
            r"N = 3 points and m >= 2; got \(3, 1\)",
        ),
        (np.zeros((4, 2), dtype=int), {}, ValueError, r"m >= 1; got \(4, 2\)"),
        (np.zeros(3, dtype=int), {}, ValueError, r"got \(3,\)"),
        (np.full((3, 2), 3), {}, PointAtlasError, r"index points 0\.\.2; got range 3\.\.3"),
        (-np.ones((3, 2), dtype=int), {}, PointAtlasError, r"got range -1\.\.-1"),
        (np.full((3, 2), 5), {"allow_negative": True}, PointAtlasError, "index points < 3"),
    ],
)
def test_errors(table, kwargs, error, match):
    with pytest.raises(error, match=match):
        check_neighbors(table, 3, **kwargs)


def test_negative_entries_allowed_when_asked():
    table = np.array([[0, -1], [1, 0], [2, -1]])
    np.testing.assert_array_equal(check_neighbors(table, 3, allow_negative=True), table)


def test_range_check_can_be_left_to_a_kernel():
    table = np.full((2, 2), 9)
    np.testing.assert_array_equal(check_neighbors(table, 2, check_range=False), table)


def test_range_over_many_blocks_matches_numpy():
    rng = np.random.default_rng(0)
    table = rng.integers(0, 5000, size=(5000, 7))
    table[4321, 3] = 5000
    with pytest.raises(PointAtlasError, match=r"got range 0\.\.5000"):
        check_neighbors(table, 5000)
    table[4321, 3] = 0
    check_neighbors(table, 5000)
