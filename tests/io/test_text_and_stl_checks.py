"""STL binary/ASCII detection by size; XYZ rows that are ambiguous are refused with their line."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.io import PointAtlasIOError, read_mesh, read_point_set, write_mesh


def _binary_stl(header: bytes, triangles: np.ndarray) -> bytes:
    rec = np.zeros(
        len(triangles),
        dtype=[("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")],
    )
    rec["corners"] = triangles
    return header.ljust(80, b" ") + np.array([len(triangles)], "<u4").tobytes() + rec.tobytes()


def test_binary_stl_with_solid_header_is_binary(tmp_path):
    tris = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0], [0, 1, 0]]])
    f = tmp_path / "cad.stl"
    f.write_bytes(_binary_stl(b"solid part exported by CAD", tris))
    ps = read_point_set(f)
    assert ps.n_points == 4
    np.testing.assert_array_equal(ps.normals, [[0, 0, 1]] * 4)
    assert read_mesh(f).n_faces == 2


def test_truncated_binary_stl_with_solid_header_is_an_error(tmp_path):
    tris = np.zeros((3, 3, 3))
    tris[:, 1, 0] = 1
    tris[:, 2, 1] = 1
    blob = _binary_stl(b"solid part", tris)
    f = tmp_path / "cut.stl"
    f.write_bytes(blob[:-20])
    match = r"declares 3 triangles, so 234 bytes are expected, but the file has 214 bytes"
    with pytest.raises(PointAtlasIOError, match=match):
        read_point_set(f)


def test_ascii_stl_still_read_and_truncated_refused(tmp_path):
    text = (
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
        "endloop\nendfacet\nendsolid t\n"
    )
    f = tmp_path / "a.stl"
    f.write_text(text)
    assert read_point_set(f).n_points == 3
    f.write_text(text[: text.index("endloop")])
    with pytest.raises(PointAtlasIOError, match="without 'endsolid'"):
        read_point_set(f)


def test_written_stl_reads_back(tmp_path):
    write_mesh(tmp_path / "w.stl", np.eye(3), [[0, 1, 2]])
    assert read_point_set(tmp_path / "w.stl").n_points == 3


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("1,5 2,5 3,5\n", r"line 1: values separated by both ',' and spaces"),
        ("# x y z\n1 2 3\n\n1,5 2,5 3,5\n", r"line 4: ',' in a row of space-separated"),
        ("1;5 2;5 3;5\n", r"line 1: values separated by both ';' and spaces"),
        ("1,5;2,5;3,5\n", r"line 1: both ',' and ';' separate values"),
        ("1 2 3\n4 5 6 7\n", r"line 2: 4 columns, but the first data row \(line 1\) has 3"),
        ("1,2,3\n4,5\n", r"line 2: 2 columns, but the first data row \(line 1\) has 3"),
        ("1,2,3\n4,five,6\n", r"line 2: non-numeric value 'five'"),
    ],
)
def test_xyz_ambiguous_rows_are_refused(tmp_path, text, match):
    f = tmp_path / "a.xyz"
    f.write_text(text)
    with pytest.raises(PointAtlasIOError, match=match) as info:
        read_point_set(f)
    assert str(f) in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    "text",
    [
        "1.5,2.5,3.5\n4,5,6\n",
        "1.5, 2.5, 3.5 # c\n4 ,5 ,6\n",
        "1.5;2.5;3.5\n4;5;6\n",
        "1.5 2.5\t3.5\n4 5 6\n",
    ],
)
def test_xyz_separators_that_work(tmp_path, text):
    f = tmp_path / "a.txt"
    f.write_text(text)
    ps = read_point_set(f)
    assert ps.points.tolist() == [[1.5, 2.5, 3.5], [4, 5, 6]]
    assert ps.normals is None and not ps.attributes
