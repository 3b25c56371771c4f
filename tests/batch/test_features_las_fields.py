"""``pointatlas features`` to LAS/LAZ: the float features as float32 extra bytes, equal
to float32(the float64 results), tiled and untiled alike (docs/decisions/io.md,
"LAS/LAZ: feature fields as float32")."""

from __future__ import annotations

import numpy as np
import pytest

laspy = pytest.importorskip("laspy")
pytest.importorskip("distributed")

from pointatlas.features import classify_dimension, covariance_features  # noqa: E402

from .test_tiles_cli import laz, run  # noqa: E402, F401


def _extra(path):
    las = laspy.read(path)
    names = [d for d in las.point_format.extra_dimension_names if d != "reflectance"]
    return las, {n: np.asarray(las[n]) for n in names}


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_float_features_are_float32_of_the_float64_results(tmp_path, laz, suffix):  # noqa: F811
    out = tmp_path / f"f{suffix}"
    assert run("features", laz, out, "--k", 16, "--weighting", "equal").exit_code == 0
    las, got = _extra(out)
    pts = np.column_stack([np.asarray(las[c], dtype=np.float64) for c in "xyz"])
    res = covariance_features(pts, 16)
    ref = {**res.scalar_fields(), "dimension_class": classify_dimension(res)}
    assert set(got) == set(ref)
    for name, v in ref.items():
        want = v.astype(np.float32) if v.dtype == np.float64 else v
        assert got[name].dtype == want.dtype, name
        assert np.array_equal(got[name], want, equal_nan=True), name
    assert got["linearity"].dtype == np.float32 and got["k"].dtype == np.int64
    assert got["reason"].dtype == np.uint8


def test_tiled_float_features_equal_untiled_and_ply_keeps_float64(tmp_path, laz, scheduler):  # noqa: F811
    tiled, plain, ply = tmp_path / "t.laz", tmp_path / "u.laz", tmp_path / "u.ply"
    args = ("--k", 16, "--weighting", "equal")
    assert (
        run("features", laz, tiled, *args, "--tile-size", 10, "--scheduler", scheduler).exit_code
        == 0
    )
    assert run("features", laz, plain, *args).exit_code == 0
    (_, a), (_, b) = _extra(tiled), _extra(plain)
    assert a.keys() == b.keys()
    for name in a:
        assert a[name].dtype == b[name].dtype, name
        assert np.array_equal(a[name], b[name], equal_nan=True), name
    from pointatlas.io import read_point_set

    assert run("features", laz, ply, *args).exit_code == 0
    assert read_point_set(ply).attributes["linearity"].dtype == np.float64
