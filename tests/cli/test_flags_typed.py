"""Option values are refused before any work, named by the flag as typed (issue 28 item 12).

The input has no normals, so a check left until after normals were estimated shows
as an "estimating normals" line before the error.
"""

from __future__ import annotations

import pytest

from pointatlas.io import write_point_set

from .helpers import assert_user_error, run, sphere_points

N = 300


@pytest.fixture
def bare(tmp_path):
    """300 sphere points without normals."""
    path = tmp_path / "bare.ply"
    write_point_set(path, sphere_points(N))
    return path


def _refused_first(result, out, *fragments):
    assert_user_error(result, *fragments)
    assert "estimating normals" not in result.output, result.output
    assert not out.exists()


@pytest.mark.parametrize(
    ("command", "ext", "flags", "words"),
    [
        ("segment", "ply", ["--seeds", "100000"], "--seeds must be an integer in [1, 300]"),
        ("simplify", "obj", ["--seeds", "100000"], "--seeds must be an integer in [1, 300]"),
        ("segment", "ply", ["--seeds", "5,99999"], "--seeds must be point indices in [0, 300)"),
        ("simplify", "obj", ["--seeds", "2,400"], "--seeds must be point indices in [0, 300)"),
        ("segment", "ply", ["--seeds", "5,-1"], "--seeds must be point indices >= 0"),
        ("segment", "ply", ["--k", "100000000000"], "--k must be an integer in [1, 300]"),
        ("segment", "ply", ["--k", "0"], "--k must be an integer >= 1"),
        ("segment", "ply", ["--max-iter", "-1"], "--max-iter must be an integer >= 0"),
        ("segment", "ply", ["--eta", "-1"], "--eta must be a finite number >= 0"),
    ],
)
def test_vsa_flags_checked_against_the_points_before_normals(
    tmp_path, bare, command, ext, flags, words
):
    out = tmp_path / f"out.{ext}"
    _refused_first(run(command, bare, out, *flags), out, words)


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--k", "0"], "--k must be an integer >= 3"),
        (["--k", "100000"], "--k must be an integer in [3, 299] (the number of points - 1)"),
        (["--k-start", "100000"], "--k-start must be an integer in [28, 299]"),
    ],
)
def test_flatness_k_checked_before_normals(tmp_path, bare, flags, words):
    out = tmp_path / "out.ply"
    _refused_first(run("denoise", bare, out, "--method", "flatness", *flags), out, words)


@pytest.mark.parametrize(
    ("method", "flag"),
    [("flatness", "--n-iter"), ("normal-voting", "--n-iter"), ("normal-voting", "--filter-iter")],
)
def test_huge_iteration_counts_get_a_bound_and_its_reason(tmp_path, bare, method, flag):
    out = tmp_path / "out.ply"
    result = run("denoise", bare, out, "--method", method, flag, str(10**12))
    _refused_first(
        result,
        out,
        f"{flag} must be an integer in [0, 100000] (each iteration is a pass over every point)",
    )
    assert "out of memory" not in result.output


def test_flatness_function_bounds_n_iter_instead_of_running_out_of_memory():
    from pointatlas import PointAtlasError
    from pointatlas.denoise import flatness_denoise

    with pytest.raises(PointAtlasError, match=r"^n_iter must be an integer in \[0, 100000\]"):
        flatness_denoise(sphere_points(50), k=8, n_iter=10**12)


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--faces", "0"], "--faces must be at least 1"),
        (["--vertex-weight", "-5"], "--vertex-weight must be a finite number >= 0"),
        (["--anchor-weight", "0"], "--anchor-weight must be a finite number > 0"),
        (["--min-region-size", "0"], "--min-region-size must be an integer >= 1"),
    ],
)
def test_simplify_flags_named_as_typed(tmp_path, bare, flags, words):
    out = tmp_path / "out.obj"
    _refused_first(run("simplify", bare, out, *flags), out, words)


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--radius", "0.8"], "--radius is for the 2-D cover (--dim 2)"),
        (["--dim", "2", "--radius", "100"], "--radius must be a finite number in [0.707"),
        (["--dim", "2", "--layout", "hex"], "--layout must be one of two-radius, tiling"),
    ],
)
def test_cloudsurface_cover_flags_named_as_typed(tmp_path, bare, flags, words):
    out = tmp_path / "cover"
    _refused_first(run("cloudsurface", bare, out, "--scale", "0.5", *flags), out, words)


@pytest.fixture
def bare_las(tmp_path):
    """300 sphere points without normals, as LAS (a tiled run reads its header)."""
    path = tmp_path / "bare.las"
    write_point_set(path, sphere_points(N))
    return path


@pytest.mark.parametrize(
    ("command", "flags", "words"),
    [
        ("segment", ["--k", "100000000000"], "--k must be an integer in [1, 300]"),
        ("segment", ["--normal-k", "100000"], "--normal-k must be an integer in [3, 300]"),
        (
            "denoise",
            ["--method", "flatness", "--k", "100000000000"],
            "--k must be an integer in [3, 299] (the number of points - 1)",
        ),
        (
            "denoise",
            ["--method", "flatness", "--k-start", "100000"],
            "--k-start must be an integer in [28, 299]",
        ),
        ("features", ["--k", "100000000000"], "--k must be an integer in [1, 300]"),
        ("features", ["--k-range", "5", "100000"], "--k-range must be an integer in [1, 300]"),
    ],
)
def test_tiled_runs_check_counts_against_the_header_before_any_work(
    tmp_path, bare_las, command, flags, words
):
    """A tiled run refuses what the untiled one refuses, before a tile starts (a huge
    --k ran a tile's k-NN kernel for hours, deaf to Ctrl-C): no temporary folder."""
    out = tmp_path / "out.las"
    result = run(command, bare_las, out, "--tile-size", "1", *flags)
    _refused_first(result, out, words)
    assert not list(tmp_path.glob(".pointatlas-tiles*")), list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--k", "100000"], "--k must be an integer in [1, 300]"),
        (["--k-range", "5", "100000"], "--k-range must be an integer in [1, 300]"),
    ],
)
def test_features_counts_named_as_typed(tmp_path, bare, flags, words):
    out = tmp_path / "out.ply"
    _refused_first(run("features", bare, out, "--weighting", "equal", *flags), out, words)
