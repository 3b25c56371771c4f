"""The shared numeric-option helpers: as_int, as_float, as_float_array (CONTRIBUTING.md, Code)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointatlas._core import PointAtlasError, as_float, as_float_array, as_int, as_normals


@pytest.mark.parametrize("value", [1, 5, 2000, np.int64(7), np.int32(1), np.array(3)])
def test_as_int_accepts_integers_in_range(value):
    out = as_int(value, "k", lo=1, hi=2000)
    assert type(out) is int and out == int(value)


@pytest.mark.parametrize(
    ("value", "match"),
    [
        (True, r"^k must be an integer; got bool True$"),
        (np.bool_(True), r"^k must be an integer; got bool True$"),
        (2.5, r"^k must be an integer; got float 2\.5$"),
        (8.0, r"^k must be an integer; got float 8\.0$"),
        (float("nan"), r"^k must be an integer; got float nan$"),
        (float("inf"), r"^k must be an integer; got float inf$"),
        ("8", r"^k must be an integer; got str '8'$"),
        (None, r"^k must be an integer; got NoneType None$"),
    ],
)
def test_as_int_rejects_non_integers(value, match):
    with pytest.raises(TypeError, match=match):
        as_int(value, "k", lo=1, hi=2000)


@pytest.mark.parametrize(
    ("value", "match"),
    [
        (0, r"^k must be an integer in \[1, 2000\] \(the number of points\); got 0$"),
        (-3, r"^k must be an integer in \[1, 2000\] \(the number of points\); got -3$"),
        (2001, r"^k must be an integer in \[1, 2000\] \(the number of points\); got 2001$"),
        (100000, r"^k must be an integer in \[1, 2000\] \(the number of points\); got 100000$"),
    ],
)
def test_as_int_range_message_house_format(value, match):
    with pytest.raises(PointAtlasError, match=match):
        as_int(value, "k", lo=1, hi=2000, note="the number of points")


def test_as_int_one_sided_and_empty_ranges():
    assert as_int(10**12, "n", lo=0) == 10**12
    with pytest.raises(ValueError, match=r"^max_iter must be an integer >= 0; got -1$"):
        as_int(-1, "max_iter", lo=0)
    with pytest.raises(ValueError, match=r"^m must be an integer <= 3; got 4$"):
        as_int(4, "m", hi=3)
    with pytest.raises(ValueError, match=r"in \[3, 2\] \(the number of points\), which is empty"):
        as_int(3, "k", lo=3, hi=2, note="the number of points")


def test_range_errors_are_value_errors():
    # the CLI prints PointAtlasError, ValueError and TypeError as one line
    assert issubclass(PointAtlasError, ValueError)
    with pytest.raises(ValueError):
        as_float(-1.0, "eta", lo=0.0)


@pytest.mark.parametrize(
    ("kwargs", "value"),
    [
        ({"lo": 0.0}, 0.0),
        ({"lo": 0.0, "lo_open": True}, 1e-300),
        ({"lo": 0.0, "hi": math.pi}, math.pi),
        ({"lo": 0.0, "hi": 1.0}, 1),
        ({}, -1e300),
        ({}, np.float32(0.5)),
        ({}, np.array(2.0)),
    ],
)
def test_as_float_accepts_boundaries(kwargs, value):
    out = as_float(value, "x", **kwargs)
    assert type(out) is float and out == float(value)


@pytest.mark.parametrize(
    ("value", "kwargs", "error", "match"),
    [
        (float("nan"), {"lo": 0.0}, ValueError, r"^eta must be a finite number >= 0; got nan$"),
        (float("inf"), {}, ValueError, r"^eta must be a finite number; got inf$"),
        (-math.inf, {"lo": 0.0}, ValueError, r"^eta must be a finite number >= 0; got -inf$"),
        (10**400, {}, ValueError, r"^eta must be a finite number; got inf$"),
        (0.0, {"lo": 0.0, "lo_open": True}, ValueError, r"^eta must be a finite number > 0"),
        (1.0, {"hi": 1.0, "hi_open": True}, ValueError, r"^eta must be a finite number < 1; got"),
        (True, {}, TypeError, r"^eta must be a real number; got bool True$"),
        ("1.5", {}, TypeError, r"^eta must be a real number; got str '1\.5'$"),
        (None, {}, TypeError, r"^eta must be a real number; got NoneType None$"),
        (1j, {}, TypeError, r"^eta must be a real number; got complex"),
    ],
)
def test_as_float_rejects(value, kwargs, error, match):
    with pytest.raises(error, match=match):
        as_float(value, "eta", **kwargs)


def test_as_float_angle_message_names_unit_and_note():
    with pytest.raises(
        ValueError,
        match=r"^b must be a finite angle in \[0\.5, pi\] radians \(b >= a\); got 0\.25$",
    ):
        as_float(0.25, "b", lo=0.5, hi=math.pi, what="angle", unit="radians", note="b >= a")


def test_as_float_array_accepts_and_copies():
    src = np.array([0.0, 1.0, math.pi])
    out = as_float_array(src, "a_grid", lo=0.0, hi=math.pi)
    assert out.dtype == np.float64 and out.tolist() == src.tolist()
    out[0] = 9.0
    assert src[0] == 0.0
    assert as_float_array(0.5, "a_grid").tolist() == [0.5]
    assert as_float_array([1, 2], "x").dtype == np.float64


@pytest.mark.parametrize(
    ("values", "error", "match"),
    [
        (
            [0.0, float("nan")],
            ValueError,
            r"^a_grid must hold finite angles in \[0, pi\] radians; got nan$",
        ),
        ([float("inf")], ValueError, r"; got inf$"),
        ([-0.1, 4.0, 1.0], ValueError, r"; got -0\.1, 4\.0$"),
        ([], ValueError, r"^a_grid must hold at least 1 value\(s\); got 0$"),
        (
            [[0.0, 1.0]],
            ValueError,
            r"^a_grid must be a flat sequence of numbers; got shape \(1, 2\)$",
        ),
        ([True, False], TypeError, r"^a_grid must hold real numbers"),
        (["a"], TypeError, r"^a_grid must hold real numbers"),
        (None, TypeError, r"^a_grid must be a sequence of numbers; got None$"),
    ],
)
def test_as_float_array_rejects(values, error, match):
    with pytest.raises(error, match=match):
        as_float_array(values, "a_grid", lo=0.0, hi=math.pi, what="angles", unit="radians")


def test_as_float_array_for_cli_degrees():
    # the CLI form: a flag name and degrees (nan must not pass as 180)
    with pytest.raises(
        ValueError, match=r"^--a-grid-deg must hold finite angles in \[0, 180\] degrees; got nan$"
    ):
        as_float_array(
            [0.0, float("nan")], "--a-grid-deg", lo=0, hi=180, what="angles", unit="degrees"
        )


@pytest.mark.parametrize("missing", [None, np.asarray(None)])
def test_as_normals_none_names_parameter(missing):
    # `experiment vsa` on an OBJ without faces passed np.asarray(None) and read
    # "normals must have shape (N, 3); got ()"
    with pytest.raises(TypeError, match=r"^normals must be an array of shape \(N, 3\); got None$"):
        as_normals(missing)
