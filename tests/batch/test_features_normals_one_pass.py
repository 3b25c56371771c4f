"""``pointatlas features --normals``: one k-NN for normals and features, the same file as
``normals`` then ``features`` on every point, tiled and untiled (docs/decisions/batch.md,
"Tiles — normals and features in one pass")."""

from __future__ import annotations

import numpy as np
import pytest

laspy = pytest.importorskip("laspy")
pytest.importorskip("distributed")

from .test_tiles_cli import assert_user_error, laz, run  # noqa: E402, F401


def _dims(path):
    las = laspy.read(path)
    return las, {n: np.asarray(las[n]) for n in las.point_format.dimension_names}


def _same_files(a, b, normals_from):
    """Every dimension of ``a`` equals ``b``'s, the normals ``normals_from``'s (the
    `normals` command's file: `features` renormalises the normals it reads, which
    moves a few by one ulp in ``b``)."""
    (la, da), (lb, db) = _dims(a), _dims(b)
    dn = _dims(normals_from)[1]
    assert list(da) == list(db)
    assert np.array_equal(la.header.scales, lb.header.scales)
    for name in da:
        ref = dn[name] if name in ("nx", "ny", "nz") else db[name]
        assert da[name].dtype == ref.dtype, name
        assert np.array_equal(da[name], ref, equal_nan=True), name
        assert np.allclose(da[name], db[name], rtol=0, atol=1e-15, equal_nan=True), name
    return da


def test_one_pass_equals_normals_then_features(tmp_path, laz):  # noqa: F811
    nrm, chain, one = tmp_path / "n.laz", tmp_path / "chain.laz", tmp_path / "one.laz"
    assert run("normals", laz, nrm, "--k", 12).exit_code == 0
    assert run("features", nrm, chain, "--k", 12, "--weighting", "equal").exit_code == 0
    result = run("features", laz, one, "--k", 12, "--estimate-normals")
    assert result.exit_code == 0, result.output
    dims = _same_files(one, chain, nrm)
    assert {"nx", "ny", "nz", "linearity", "dimension_class"} <= set(dims)
    assert dims["linearity"].dtype == np.float32 and dims["nx"].dtype == np.float64


def test_tiled_one_pass_equals_tiled_chain_and_untiled_features(tmp_path, laz, scheduler):  # noqa: F811
    tiles = ("--tile-size", 10, "--scheduler", scheduler)
    nrm, chain, one = tmp_path / "n.laz", tmp_path / "chain.laz", tmp_path / "one.laz"
    plain = tmp_path / "plain.laz"
    assert run("normals", laz, nrm, "--k", 12, *tiles).exit_code == 0
    assert run("features", nrm, chain, "--k", 12, "--weighting", "equal", *tiles).exit_code == 0
    result = run("features", laz, one, "--k", 12, "--estimate-normals", *tiles)
    assert result.exit_code == 0, result.output
    dims = _same_files(one, chain, nrm)  # the same halo (k = 12 both): the same stitching
    assert run("features", laz, plain, "--k", 12, "--estimate-normals").exit_code == 0
    ref = _dims(plain)[1]
    for name in ref:
        if name not in ("nx", "ny", "nz"):
            assert np.array_equal(dims[name], ref[name], equal_nan=True), name
    # the axis is the untiled one bit for bit; MST signs are stitched per tile
    n_t = np.column_stack([dims[c] for c in ("nx", "ny", "nz")])
    n_u = np.column_stack([ref[c] for c in ("nx", "ny", "nz")])
    same = (n_t == n_u).all(axis=1) | (n_t == -n_u).all(axis=1)
    assert same.all()


def test_one_pass_refuses_sigmoid_weights(tmp_path, laz):  # noqa: F811
    out = tmp_path / "x.laz"
    assert_user_error(
        run("features", laz, out, "--estimate-normals", "--weighting", "sigmoid"),
        "--estimate-normals",
        "pointatlas normals",
    )


@pytest.mark.parametrize("orient", ["mst", "up"])
def test_tiled_one_pass_on_ply_equals_untiled_features(tmp_path, laz, scheduler, orient):  # noqa: F811
    """Other formats by tiles: the features equal the untiled ones; MST normals the
    same axes, ``--orient up`` (per point, nothing stitched) the same bits."""
    from pointatlas.io import read_point_set, write_point_set

    ply = tmp_path / "in.ply"
    write_point_set(ply, read_point_set(laz, with_normals=False))
    tiled, plain = tmp_path / "t.ply", tmp_path / "u.ply"
    args = ("--k", 12, "--estimate-normals", "--orient", orient)
    result = run("features", ply, tiled, *args, "--tile-size", 10, "--scheduler", scheduler)
    assert result.exit_code == 0, result.output
    assert run("features", ply, plain, *args).exit_code == 0
    a, b = read_point_set(tiled), read_point_set(plain)
    assert a.attributes.keys() == b.attributes.keys() and "linearity" in a.attributes
    for name, v in b.attributes.items():
        assert np.array_equal(a.attributes[name], v, equal_nan=True), name
    if orient == "up":
        assert np.array_equal(a.normals, b.normals) and (a.normals[:, 2] >= 0).all()
    else:
        assert np.allclose(np.abs(np.einsum("ij,ij->i", a.normals, b.normals)), 1.0)
