"""Normals oriented "up" (n_z >= 0 per point) by tiles: ``normals --orient up`` and
``features --normals --orient up`` equal the untiled runs bit for bit, and their tiles
query the owned rows only (docs/decisions/batch.md, "Tiles — normals and features in
one pass")."""

from __future__ import annotations

import numpy as np
import pytest

laspy = pytest.importorskip("laspy")
pytest.importorskip("distributed")

from pointatlas.batch import (  # noqa: E402
    TileOptions,
    _tiles_tasks,
    tiled_normals,
)
from pointatlas.normals import estimate_normals, orient_normals  # noqa: E402

from .test_tiles import points  # noqa: E402, F401
from .test_tiles_cli import assert_user_error, laz, run  # noqa: E402, F401


def _dims(path):
    las = laspy.read(path)
    return {n: np.asarray(las[n]) for n in las.point_format.dimension_names}


def _normals(dims):
    return np.column_stack([dims[c] for c in ("nx", "ny", "nz")])


@pytest.fixture
def knn_calls(monkeypatch):
    """``rows_only`` of every `exact_tile_knn` call of the tile tasks (in-process
    workers: the patched module is theirs)."""
    calls = []
    real = _tiles_tasks.exact_tile_knn

    def spy(*args, **kwargs):
        calls.append(bool(kwargs.get("rows_only", False)))
        return real(*args, **kwargs)

    monkeypatch.setattr(_tiles_tasks, "exact_tile_knn", spy)
    return calls


def test_tiled_up_normals_equal_untiled_and_query_owned_rows_only(client, points, knn_calls):  # noqa: F811
    ref = orient_normals(points, estimate_normals(points, 20), method="up")
    got, run_ = tiled_normals(
        points, TileOptions(tile_size=9.0, scheduler=client), k=20, orient="up"
    )
    assert run_.n_tiles > 4 and run_.halo_overhead > 1.0
    assert np.array_equal(got, ref) and (got[:, 2] >= 0).all()
    assert "orientation_pieces" not in run_.extra  # nothing stitched
    assert len(knn_calls) >= run_.n_tiles and all(knn_calls)
    knn_calls.clear()
    tiled_normals(points[:6000], TileOptions(tile_size=9.0, scheduler=client), k=20)
    assert knn_calls and not any(knn_calls)  # mst: every tile row (the halo's too)


def test_tiled_normals_up_on_laz_equal_untiled(tmp_path, laz, scheduler):  # noqa: F811
    tiled, plain = tmp_path / "tiled.laz", tmp_path / "plain.laz"
    args = ("--k", 12, "--orient", "up")
    result = run("normals", laz, tiled, *args, "--tile-size", 7.5, "--scheduler", scheduler)
    assert result.exit_code == 0, result.output
    assert run("normals", laz, plain, *args).exit_code == 0
    a, b = _dims(tiled), _dims(plain)
    assert list(a) == list(b)
    for name in b:
        assert np.array_equal(a[name], b[name]), name
    assert (a["nz"] >= 0).all()


def test_one_pass_up_tiled_equals_untiled_and_the_two_commands(tmp_path, laz, scheduler, knn_calls):  # noqa: F811
    tiles = ("--tile-size", 10, "--scheduler", scheduler)
    one_t, one_u = tmp_path / "one_t.laz", tmp_path / "one_u.laz"
    nrm, feat = tmp_path / "n.laz", tmp_path / "f.laz"
    result = run("features", laz, one_t, "--k", 12, "--estimate-normals", "--orient", "up", *tiles)
    assert result.exit_code == 0, result.output
    assert knn_calls and all(knn_calls)  # owned rows only: no MST, no stitching
    assert (
        run("features", laz, one_u, "--k", 12, "--estimate-normals", "--orient", "up").exit_code
        == 0
    )
    a, b = _dims(one_t), _dims(one_u)
    assert list(a) == list(b) and {"nx", "linearity", "dimension_class"} <= set(a)
    for name in b:
        assert a[name].dtype == b[name].dtype, name
        assert np.array_equal(a[name], b[name], equal_nan=True), name
    # the normals of `normals --orient up`, the features of `features --weighting equal`
    assert run("normals", laz, nrm, "--k", 12, "--orient", "up").exit_code == 0
    assert run("features", laz, feat, "--k", 12, "--weighting", "equal").exit_code == 0
    assert np.array_equal(_normals(a), _normals(_dims(nrm)))
    f = _dims(feat)
    for name in f:
        if name not in ("nx", "ny", "nz"):
            assert np.array_equal(a[name], f[name], equal_nan=True), name
    # the same axes as the MST one pass, signs up
    mst = tmp_path / "mst.laz"
    assert run("features", laz, mst, "--k", 12, "--estimate-normals").exit_code == 0
    n_m, n_a = _normals(_dims(mst)), _normals(a)
    assert (n_a[:, 2] >= 0).all()
    assert ((n_a == n_m).all(axis=1) | (n_a == -n_m).all(axis=1)).all()


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (("--orient", "up"), ["--orient only applies with --estimate-normals"]),
        (("--estimate-normals", "--orient", "outward"), ["mst, up", "'outward'"]),
        (("--estimate-normals", "--orient", "viewpoint", "--tile-size", 10), ["mst, up"]),
    ],
)
def test_features_orient_errors_are_one_line(tmp_path, laz, args, fragments):  # noqa: F811
    assert_user_error(run("features", laz, tmp_path / "x.laz", *args), *fragments)
