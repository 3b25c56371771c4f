"""PLY: what is read is written back (colour types, lone alpha, any PLY name), header counts."""

from __future__ import annotations

import numpy as np
import plyfile
import pytest

from pointatlas import PointAtlasError
from pointatlas.io import (
    PointAtlasIOError,
    check_point_set_writable,
    merge_attributes,
    read_point_set,
    write_point_set,
)

N = 30


def _vertex(fields, seed=0):
    rng = np.random.default_rng(seed)
    rec = np.zeros(N, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8"), *fields])
    for name, dt in [("x", "f8"), ("y", "f8"), ("z", "f8"), *fields]:
        dt = np.dtype(dt)
        if dt.kind == "f":
            rec[name] = rng.random(N) * (255 if name.startswith("big") else 1)
        else:
            info = np.iinfo(dt)
            rec[name] = rng.integers(info.min, int(info.max) + 1, N)
    return rec


VARIANTS = {
    "ushort_colours": [("red", "u2"), ("green", "u2"), ("blue", "u2")],
    "ushort_small_colours": [("red", "u2"), ("green", "u2"), ("blue", "u2"), ("alpha", "u2")],
    "float_colours": [("red", "f4"), ("green", "f4"), ("blue", "f4")],
    "double_colours_alpha": [("red", "f8"), ("green", "f8"), ("blue", "f8"), ("alpha", "f8")],
    "lone_alpha": [("alpha", "u1")],
    "cloudcompare_names": [("scalar_Intensity(1)", "f4"), ("scalar_Return[2]", "i4")],
    "mixed_channel_types": [("red", "u1"), ("green", "u1"), ("blue", "u1"), ("alpha", "f4")],
    "channels_of_other_types": [("red", "u1"), ("green", "u2"), ("blue", "f4")],
}


@pytest.mark.parametrize("text", [False, True])
@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_ply_variants_round_trip(tmp_path, variant, text):
    rec = _vertex(VARIANTS[variant])
    if variant == "ushort_small_colours":
        for k in ("red", "green", "blue", "alpha"):
            rec[k] %= 200  # values that fit 8 bits stay 16-bit in the file
    src = tmp_path / "in.ply"
    plyfile.PlyData([plyfile.PlyElement.describe(rec, "vertex")], text=text).write(str(src))
    first = read_point_set(src)
    out = tmp_path / "out.ply"
    write_point_set(out, first, binary=not text)
    second = read_point_set(out)
    assert set(second.attributes) == set(first.attributes)
    np.testing.assert_array_equal(second.points, first.points)
    for name, value in first.attributes.items():
        assert second.attributes[name].dtype == value.dtype, name
        np.testing.assert_array_equal(second.attributes[name], value, name)
    # every property of the input is in the output with its type
    props_in = {p.name: p.val_dtype for p in plyfile.PlyData.read(str(src))["vertex"].properties}
    props_out = {p.name: p.val_dtype for p in plyfile.PlyData.read(str(out))["vertex"].properties}
    assert props_out == props_in


@pytest.mark.parametrize(
    ("fields", "dtype"),
    [(VARIANTS["ushort_colours"], np.uint16), (VARIANTS["float_colours"], np.float32)],
)
def test_ply_colours_keep_their_type(tmp_path, fields, dtype):
    rec = _vertex(fields)
    src = tmp_path / "in.ply"
    plyfile.PlyData([plyfile.PlyElement.describe(rec, "vertex")]).write(str(src))
    colors = read_point_set(src).attributes["colors"]
    assert colors.dtype == dtype
    np.testing.assert_array_equal(colors[:, 0], rec["red"])


BAD_WRITES = [
    ("a.ply", {"attributes": {"my label": [1, 2]}}, "contains whitespace"),
    ("a.ply", {"attributes": {"": [1, 2]}}, "is empty"),
    ("a.ply", {"attributes": {"héllo": [1, 2]}}, "non-ASCII"),
    ("a.ply", {"attributes": {"x": [1, 2]}}, "'x' is reserved for the coordinates"),
    ("a.ply", {"normals": np.eye(3)[:2], "attributes": {"nx": [1, 2]}}, "reserved for the normals"),
    ("a.ply", {"colors": np.zeros((2, 3), np.uint8), "attributes": {"red": [1, 2]}}, "for colors"),
    ("a.ply", {"attributes": {"f": np.zeros((2, 2)), "f_1": [1, 2]}}, "written as PLY property"),
    ("a.ply", {"attributes": {"big": np.array([2**60, 1])}}, "cannot be stored in PLY"),
    ("a.obj", {}, "cannot write point sets as '.obj'"),
    ("a.las", {"attributes": {"x": [1, 2]}}, "reserved for the coordinates"),
    ("a.las", {"attributes": {"n" * 33: [1, 2]}}, "1 to 32 ASCII characters"),
    ("a.las", {"colors": np.full((2, 3), 3.0), "attributes": {}}, r"colors must"),
]


@pytest.mark.parametrize(("name", "kw", "match"), BAD_WRITES)
def test_check_point_set_writable_raises_what_write_raises(tmp_path, name, kw, match):
    p = np.zeros((2, 3))
    path = tmp_path / "missing_folder" / name  # the folder is not checked
    with pytest.raises(PointAtlasError, match=match) as checked:
        check_point_set_writable(path, p, **kw)
    with pytest.raises(PointAtlasError, match=match) as written:
        write_point_set(path, p, **kw)
    assert type(checked.value) is type(written.value)
    assert str(checked.value) == str(written.value)
    assert "\n" not in str(checked.value)
    assert not (tmp_path / "missing_folder").exists()


def test_check_point_set_writable_accepts_what_write_accepts(tmp_path):
    p = np.zeros((2, 3))
    attrs = {"scalar_Intensity(1)": [1.0, 2.0], "alpha": np.array([1, 2], np.uint8)}
    assert check_point_set_writable(tmp_path / "nowhere" / "a.ply", p, attributes=attrs) is None
    write_point_set(tmp_path / "a.ply", p, attributes=attrs)
    assert not list(tmp_path.glob("nowhere"))


def _binary_ply(declared: int, actual: int, *, tail: bytes = b"") -> bytes:
    head = (
        f"ply\nformat binary_little_endian 1.0\nelement vertex {declared}\n"
        "property float x\nproperty float y\nproperty float z\nend_header\n"
    ).encode()
    return head + np.arange(3 * actual, dtype="<f4").tobytes() + tail


def test_binary_ply_with_more_records_than_declared_is_an_error(tmp_path):
    f = tmp_path / "a.ply"
    f.write_bytes(_binary_ply(4, 6))
    with pytest.raises(PointAtlasIOError, match=r"24 bytes after .*vertex: 4 declared"):
        read_point_set(f)
    f.write_bytes(_binary_ply(4, 4, tail=b"\n"))  # one trailing line break is tolerated
    assert read_point_set(f).n_points == 4


def test_binary_ply_elements_after_vertex_are_checked(tmp_path):
    head = (
        b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
        b"property float y\nproperty float z\nelement camera 1\nproperty double fx\nend_header\n"
    )
    body = np.zeros(6, "<f4").tobytes() + np.ones(1, "<f8").tobytes()
    f = tmp_path / "a.ply"
    f.write_bytes(head + body)
    with pytest.warns(UserWarning, match="element 'camera'"):
        assert read_point_set(f).n_points == 2
    f.write_bytes(head + body[:-4])
    with pytest.raises(PointAtlasIOError, match="truncated binary PLY: element 'camera'"):
        read_point_set(f)
    f.write_bytes(head + body + b"\x01" * 8)
    with pytest.raises(PointAtlasIOError, match=r"8 bytes after .*camera: 1 declared"):
        read_point_set(f)


def test_ascii_ply_with_more_records_than_declared_warns(tmp_path):
    f = tmp_path / "a.ply"
    head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
    f.write_text(head + "property float z\nend_header\n0 0 0\n1 1 1\n2 2 2\n3 3 3\n\n")
    with pytest.warns(UserWarning, match=r"2 non-empty lines after .*vertex: 2 declared"):
        ps = read_point_set(f)
    assert ps.n_points == 2


def test_merge_attributes_never_replaces():
    base = {"label": np.arange(3), "red": np.zeros(3), "pa_label": np.ones(3)}
    ours = {"label": np.full(3, 7), "e_dim": np.zeros(3), "nx": np.ones(3), "colors": np.ones(3)}
    merged = merge_attributes(base, ours)
    for key, value in base.items():
        assert merged[key] is value
    assert merged["pa_pa_label"] is ours["label"]
    assert merged["e_dim"] is ours["e_dim"]
    assert merged["pa_nx"] is ours["nx"] and merged["pa_colors"] is ours["colors"]
    assert len(merged) == len(base) + len(ours)
    # a free name of ours is never taken by a renamed entry
    merged = merge_attributes({"a": 1}, {"a": 2, "pa_a": 3})
    assert merged == {"a": 1, "pa_a": 3, "pa_pa_a": 2}
    assert merge_attributes({}, {"x": 1}, prefix="our_") == {"our_x": 1}
    with pytest.raises(PointAtlasError, match="prefix"):
        merge_attributes({}, {}, prefix="")
    with pytest.raises(PointAtlasError, match="mapping"):
        merge_attributes([], {})
