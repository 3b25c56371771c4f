import numpy as np
import pytest

from pointatlas._core import (
    NonFiniteError,
    PointAtlasError,
    PointSet,
    as_k,
    as_labels,
    as_normals,
    as_points,
    as_vectors,
    check_finite,
    readonly_view,
)


def test_as_points_shape_and_dtype():
    pts = as_points([[0, 0, 0], [1, 2, 3]])
    assert pts.dtype == np.float64 and pts.shape == (2, 3)


@pytest.mark.parametrize("bad", [np.zeros((4, 2)), np.zeros(3), np.zeros((2, 3, 1))])
def test_as_points_rejects_bad_shapes(bad):
    with pytest.raises(ValueError, match=r"points must have shape \(N, 3\); got"):
        as_points(bad)


def test_as_points_names_non_finite_indices():
    pts = np.zeros((10, 3))
    pts[[2, 7], 1] = [np.nan, np.inf]
    with pytest.raises(
        NonFiniteError, match=r"^points contains 2 non-finite values \(NaN or Inf\) at rows 2, 7$"
    ):
        as_points(pts)


def test_check_finite_counts_values_and_lists_the_first_rows():
    arr = np.zeros((20, 3))
    arr[3] = np.nan  # three values in one row
    arr[[4, 5, 6, 8, 11], 0] = -np.inf
    expected = r"^xs contains 8 non-finite values \(NaN or Inf\) at rows 3, 4, 5, 6, 8, \.\.\.$"
    with pytest.raises(NonFiniteError, match=expected):
        check_finite(arr, "xs")
    with pytest.raises(
        NonFiniteError, match=r"^v contains 1 non-finite value \(NaN or Inf\) at row 0$"
    ):
        check_finite(np.array([np.nan, 1.0]), "v")
    check_finite(arr[12:], "xs")  # finite: no error


def test_as_points_non_numeric_is_type_error():
    with pytest.raises(TypeError, match="points must be numeric"):
        as_points([["a", "b", "c"]])


def test_as_normals_normalises_and_copies():
    raw = np.array([[0.0, 0.0, 2.0], [3.0, 4.0, 0.0]])
    out = as_normals(raw)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0)
    assert raw[0, 2] == 2.0  # input untouched


def test_as_normals_zero_length_lists_count_and_indices():
    nrm = np.ones((8, 3))
    nrm[[1, 3, 4, 5, 6, 7]] = 0.0
    expected = r"zero-length vectors at 6 \(indices 1, 3, 4, 5, 6, \.\.\.\)"
    with pytest.raises(ValueError, match=expected):
        as_normals(nrm)


def test_as_normals_non_finite_and_count_mismatch():
    with pytest.raises(NonFiniteError, match="^normals contains 1 non-finite value"):
        as_normals([[np.nan, 0, 1]])
    with pytest.raises(ValueError, match="one row per point"):
        as_normals(np.ones((2, 3)), 3)


def test_as_labels():
    assert as_labels([0.0, 2.0]).tolist() == [0, 2]
    with pytest.raises(ValueError, match="must be integers"):
        as_labels([0.5, 1.0])
    with pytest.raises(ValueError, match="one entry per point"):
        as_labels([0, 1], 3)


def test_pointset_is_frozen_and_readonly():
    pts = np.random.default_rng(0).random((5, 3))
    ps = PointSet(pts, normals=np.tile([0, 0, 5.0], (5, 1)), attributes={"f": np.arange(5)})
    assert ps.n_points == 5 and ps.has_normals
    np.testing.assert_allclose(ps.normals[:, 2], 1.0)
    with pytest.raises(ValueError):
        ps.points[0, 0] = 1.0
    with pytest.raises(AttributeError):
        ps.name = "x"
    pts[0, 0] = 42.0  # the PointSet holds its own copy
    assert ps.points[0, 0] != 42.0
    ps2 = ps.with_attributes(g=np.ones(5))
    assert set(ps2.attributes) == {"f", "g"} and set(ps.attributes) == {"f"}


def test_pointset_rejects_bad_attribute_and_bad_normals():
    with pytest.raises(ValueError, match="attribute 'f' must have one entry per point"):
        PointSet(np.zeros((3, 3)), attributes={"f": np.arange(2)})
    with pytest.raises(ValueError, match="zero-length"):
        PointSet(np.zeros((2, 3)), normals=np.zeros((2, 3)))


def test_pointatlas_error_is_value_error():
    assert issubclass(PointAtlasError, ValueError)


def test_as_vectors_keeps_non_finite_rows_and_checks_shape():
    arr = np.array([[0.0, np.nan, 1.0], [np.inf, 2.0, 3.0]])
    out = as_vectors(arr, 2, name="normals")
    assert out.dtype == np.float64 and np.array_equal(out, arr, equal_nan=True)
    with pytest.raises(ValueError, match=r"^normals must have shape \(N, 3\); got \(2, 2\)$"):
        as_vectors(np.zeros((2, 2)), name="normals")
    with pytest.raises(ValueError, match=r"^normals must have one row per point \(3\); got 2$"):
        as_vectors(arr, 3, name="normals")
    with pytest.raises(TypeError, match=r"^points must be an array of shape \(N, 3\); got None$"):
        as_vectors(None, name="points")


@pytest.mark.parametrize(
    ("k", "minimum", "message"),
    [
        (0, 1, r"^k must be an integer in \[1, 5\] \(the number of points\); got 0$"),
        (6, 1, r"^k must be an integer in \[1, 5\] \(the number of points\); got 6$"),
        (2, 3, r"^k must be an integer in \[3, 5\] \(the number of points\); got 2$"),
    ],
)
def test_as_k_counts_the_point_itself(k, minimum, message):
    assert as_k(5, 5, minimum=minimum) == 5
    assert as_k(np.int64(minimum), 5, minimum=minimum) == minimum
    with pytest.raises(PointAtlasError, match=message):
        as_k(k, 5, minimum=minimum)


def test_as_points_is_a_read_only_view_and_leaves_the_input_writeable():
    # no copy of a float64 C-contiguous input, but nothing can be written through
    # it, and the caller's array keeps its flag (kernels see one array type)
    arr = np.random.default_rng(0).random((5, 3))
    pts = as_points(arr)
    assert np.shares_memory(pts, arr) and not pts.flags.writeable
    assert arr.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        pts[0, 0] = 1.0
    arr[0, 0] = 2.0  # the input itself stays the caller's to change
    assert pts[0, 0] == 2.0
    assert not as_points([[0, 0, 0]]).flags.writeable  # a converted copy too


def test_readonly_view_shares_memory_and_keeps_the_original_flag():
    arr = np.arange(6.0).reshape(2, 3)
    view = readonly_view(arr)
    assert np.shares_memory(view, arr) and not view.flags.writeable
    assert arr.flags.writeable and np.array_equal(view, arr)
