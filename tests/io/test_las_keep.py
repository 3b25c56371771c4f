"""LAS/LAZ written from a point set read from LAS keeps the header and every dimension."""

from __future__ import annotations

import laspy
import numpy as np
import plyfile
import pytest
from laspy.vlrs.known import WktCoordinateSystemVlr

from pointatlas import PointSet
from pointatlas.io import (
    PointAtlasIOError,
    check_point_set_writable,
    read_point_set,
    write_point_set,
)

WKT = (
    'PROJCS["ETRS89 / UTM zone 32N",GEOGCS["ETRS89",DATUM["European_Terrestrial_Reference_'
    'System_1989",SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],'
    'UNIT["degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],'
    'UNIT["metre",1],AUTHORITY["EPSG","25832"]]'
)


def _make_las(path, point_format: int, scale: float, n: int = 60, seed: int = 0):
    """A LAS/LAZ file with a CRS VLR, every dimension filled, 16-bit RGB if the format has it."""
    rng = np.random.default_rng(seed)
    version = "1.2" if point_format < 6 else "1.4"
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.array([scale, scale, scale])
    header.offsets = np.array([512000.0, 5403000.0, 100.0])
    header.vlrs.append(WktCoordinateSystemVlr(WKT))
    las = laspy.LasData(header, points=laspy.ScaleAwarePointRecord.zeros(n, header=header))
    las.X = rng.integers(-(10**6), 10**6, n).astype(np.int32)
    las.Y = rng.integers(-(10**6), 10**6, n).astype(np.int32)
    las.Z = rng.integers(-(10**4), 10**4, n).astype(np.int32)
    for dim in las.point_format.dimensions:
        if dim.name in ("X", "Y", "Z"):
            continue
        if dim.kind.name == "BitField":
            las[dim.name] = rng.integers(0, 1 << dim.num_bits, n).astype(np.uint8)
        elif dim.kind.name == "FloatingPoint":
            las[dim.name] = rng.random(n) * 1e5
        else:
            info = np.iinfo(dim.dtype)
            las[dim.name] = rng.integers(info.min, int(info.max) + 1, n).astype(dim.dtype)
    las.write(str(path), do_compress=path.suffix == ".laz")
    return laspy.read(str(path))


def _vlr_bytes(header):
    """VLRs as bytes, without the extra-bytes description (it lists the new fields)."""
    return [
        (v.user_id, v.record_id, v.record_data_bytes())
        for v in header.vlrs
        if (v.user_id, v.record_id) != ("LASF_Spec", 4)
    ]


@pytest.mark.parametrize("ext", [".las", ".laz"])
@pytest.mark.parametrize("scale", [0.01, 0.001])
@pytest.mark.parametrize("point_format", [0, 1, 2, 3, 6, 7, 8])
def test_las_round_trip_keeps_header_and_dimensions(tmp_path, point_format, scale, ext):
    src = tmp_path / f"in{ext}"
    before = _make_las(src, point_format, scale)
    ps = read_point_set(src)
    if "red" in before.point_format.dimension_names:
        colors = ps.attributes["colors"]
        assert colors.dtype == np.uint16 and colors.max() > 255  # 16 bits kept
    n = ps.n_points
    new = {"pa_score": np.linspace(0.0, 1.0, n), "pa_label": np.arange(n, dtype=np.int64)}
    out = tmp_path / f"out{ext}"
    write_point_set(out, ps, attributes=new)
    after = laspy.read(str(out))
    assert str(after.header.version) == str(before.header.version)
    assert after.header.point_format.id == point_format
    np.testing.assert_array_equal(after.header.scales, before.header.scales)
    np.testing.assert_array_equal(after.header.offsets, before.header.offsets)
    assert _vlr_bytes(after.header) == _vlr_bytes(before.header)
    for name in before.point_format.dimension_names:  # X, Y, Z raw integers included
        np.testing.assert_array_equal(np.asarray(after[name]), np.asarray(before[name]), name)
    assert set(after.point_format.extra_dimension_names) == set(new)
    np.testing.assert_array_equal(after["pa_score"], new["pa_score"])
    np.testing.assert_array_equal(after["pa_label"], new["pa_label"])
    # and reading the result gives the same point set plus the new fields
    again = read_point_set(out)
    np.testing.assert_array_equal(again.points, ps.points)
    assert set(again.attributes) == set(ps.attributes) | set(new)


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_las_moved_points_requantised_with_input_scale(tmp_path, ext):
    src = tmp_path / f"in{ext}"
    before = _make_las(src, 3, 0.001)
    ps = read_point_set(src)
    moved = ps.replace(points=ps.points + [1.0, -2.0, 0.5])
    assert moved.meta["las_header"] is ps.meta["las_header"]
    write_point_set(tmp_path / f"m{ext}", moved)
    after = laspy.read(str(tmp_path / f"m{ext}"))
    np.testing.assert_array_equal(after.header.scales, before.header.scales)
    np.testing.assert_array_equal(after.header.offsets, before.header.offsets)
    np.testing.assert_array_equal(after.X, before.X + 1000)
    np.testing.assert_array_equal(after.Y, before.Y - 2000)
    np.testing.assert_array_equal(after.Z, before.Z + 500)
    np.testing.assert_array_equal(after.red, before.red)
    np.testing.assert_array_equal(after.intensity, before.intensity)


def test_las_points_out_of_int32_get_a_new_offset(tmp_path):
    src = tmp_path / "in.las"
    before = _make_las(src, 1, 0.001)
    ps = read_point_set(src)
    far = ps.replace(points=ps.points + [1e7, 0.0, 0.0])  # 1e10 steps of 0.001: beyond int32
    write_point_set(tmp_path / "far.las", far)
    after = laspy.read(str(tmp_path / "far.las"))
    assert after.header.point_format.id == 1 and str(after.header.version) == "1.2"
    assert after.header.scales[0] == before.header.scales[0]
    assert after.header.offsets[0] != before.header.offsets[0]
    np.testing.assert_array_equal(after.header.offsets[1:], before.header.offsets[1:])
    np.testing.assert_allclose(after.x, far.points[:, 0], atol=1e-3)
    np.testing.assert_array_equal(after.Y, before.Y)
    assert _vlr_bytes(after.header) == _vlr_bytes(before.header)


def test_las_values_that_do_not_fit_a_dimension_are_refused(tmp_path):
    src = tmp_path / "in.las"
    _make_las(src, 1, 0.01)
    ps = read_point_set(src)
    bad = ps.with_attributes(classification=np.full(ps.n_points, 40))  # 5-bit field
    out = tmp_path / "bad.las"
    match = r"attribute 'classification' \(int64\) does not fit the LAS dimension"
    with pytest.raises(PointAtlasIOError, match=match):
        check_point_set_writable(out, bad)
    with pytest.raises(PointAtlasIOError, match=match):
        write_point_set(out, bad)
    assert not out.exists()
    # values that fit are written into the dimension, whatever their integer dtype
    ok = ps.with_attributes(classification=np.full(ps.n_points, 7))
    write_point_set(out, ok)
    assert (laspy.read(str(out)).classification == 7).all()


def test_las_to_ply_keeps_every_dimension(tmp_path):
    src = tmp_path / "in.las"
    before = _make_las(src, 3, 0.01)
    ps = read_point_set(src)
    out = tmp_path / "out.ply"
    write_point_set(out, ps)
    props = {p.name: p.val_dtype for p in plyfile.PlyData.read(str(out))["vertex"].properties}
    for name in before.point_format.dimension_names:
        if name not in ("X", "Y", "Z"):
            assert name in props, name
    assert props["red"] == props["green"] == props["blue"] == "u2"
    again = read_point_set(out)
    np.testing.assert_array_equal(
        again.attributes["colors"], np.column_stack([before.red, before.green, before.blue])
    )
    for name, value in ps.attributes.items():
        np.testing.assert_array_equal(again.attributes[name], value, name)


def test_ply_to_las_keeps_attributes(tmp_path):
    rng = np.random.default_rng(3)
    n = 40
    rec = np.zeros(
        n,
        dtype=[
            ("x", "f4"),
            ("y", "f4"),
            ("z", "f4"),
            ("red", "u1"),
            ("green", "u1"),
            ("blue", "u1"),
            ("alpha", "u1"),
            ("scalar_Intensity(1)", "f4"),
            ("flag", "i1"),
        ],
    )
    for k in ("x", "y", "z", "scalar_Intensity(1)"):
        rec[k] = rng.random(n)
    for k in ("red", "green", "blue", "alpha"):
        rec[k] = rng.integers(0, 256, n)
    rec["flag"] = rng.integers(-5, 5, n)
    src = tmp_path / "in.ply"
    plyfile.PlyData([plyfile.PlyElement.describe(rec, "vertex")]).write(str(src))
    ps = read_point_set(src)
    out = tmp_path / "out.laz"
    write_point_set(out, ps)
    las = laspy.read(str(out))
    np.testing.assert_array_equal(las.red, rec["red"].astype(np.uint16) * 257)
    np.testing.assert_array_equal(las["alpha"], rec["alpha"])
    np.testing.assert_array_equal(las["scalar_Intensity(1)"], rec["scalar_Intensity(1)"])
    np.testing.assert_array_equal(las["flag"], rec["flag"])
    back = read_point_set(out)
    assert set(back.attributes) >= {"colors", "alpha", "scalar_Intensity(1)", "flag"}


def test_not_from_las_keeps_todays_header(tmp_path):
    p = np.random.default_rng(1).random((10, 3)) * 100
    write_point_set(tmp_path / "a.las", p, colors=np.full((10, 3), 255, np.uint8))
    las = laspy.read(str(tmp_path / "a.las"))
    assert las.header.point_format.id == 7 and str(las.header.version) == "1.4"
    assert (las.red == 65535).all()
    write_point_set(tmp_path / "b.las", PointSet(p))
    assert laspy.read(str(tmp_path / "b.las")).header.point_format.id == 6


def test_point_set_meta_is_carried():
    ps = PointSet([[0.0, 0, 0], [1, 0, 0]], meta={"las_header": "h"})
    assert ps.replace(points=[[0.0, 0, 1], [1, 0, 1]]).meta == {"las_header": "h"}
    assert ps.with_attributes(label=[1, 2]).meta["las_header"] == "h"
    assert ps.replace(name="b").meta["las_header"] == "h"
    fast = PointSet._from_validated(np.zeros((1, 3)), meta={"k": 1})
    assert fast.meta["k"] == 1 and PointSet(np.zeros((1, 3))).meta == {}
    with pytest.raises(TypeError):
        ps.meta["x"] = 1
    with pytest.raises(TypeError, match="meta must be a mapping"):
        PointSet(np.zeros((1, 3)), meta=[1])
