"""Cut and padded files are named for what they are, in words (issue 28 item 12)."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.io import PointAtlasIOError, read_point_set, write_mesh, write_point_set

from ..cli.helpers import assert_user_error, run


def _cloud(n=500):
    return np.random.default_rng(0).random((n, 3))


def _binary_stl(tmp_path):
    path = tmp_path / "part.stl"
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    write_mesh(path, v, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    data = path.read_bytes()
    assert len(data) == 84 + 50 * 4  # binary, four triangles
    return path, data


def test_binary_stl_longer_than_its_header_declares(tmp_path):
    path, data = _binary_stl(tmp_path)
    path.write_bytes(data + b"\x00" * 50)  # a fifth record the header does not count
    result = run("info", path)
    assert_user_error(
        result, str(path), "binary STL longer than its header declares", "284 bytes", "334"
    )
    assert "truncated" not in result.stderr


def test_binary_stl_cut_short_is_truncated(tmp_path):
    path, data = _binary_stl(tmp_path)
    path.write_bytes(data[:-20])
    result = run("info", path)
    assert_user_error(result, "truncated binary STL", "284 bytes", "264")
    assert "longer" not in result.stderr


def _las_bytes(tmp_path, ext):
    path = tmp_path / f"full.{ext}"
    write_point_set(path, _cloud())
    return path.read_bytes()


@pytest.mark.parametrize(
    ("cut", "words"),
    [
        (-1, "the header declares 500 points of 30 bytes from byte 375, so at least 15,375"),
        (0.5, "the header declares 500 points of 30 bytes"),
        (300, "300 bytes, shorter than its 375-byte header"),
        (100, "100 bytes, shorter than the smallest LAS header (227 bytes)"),
    ],
    ids=["last-byte", "half", "in-header", "tiny"],
)
def test_truncated_las_says_so(tmp_path, cut, words):
    data = _las_bytes(tmp_path, "las")
    n = len(data) + cut if cut < 0 else int(len(data) * cut) if cut < 1 else cut
    path = tmp_path / "cut.las"
    path.write_bytes(data[:n])
    with pytest.raises(PointAtlasIOError, match="truncated LAS"):
        read_point_set(path)  # 300 bytes was read as 0 points, without a word
    result = run("info", path)
    assert_user_error(result, str(path), "truncated LAS", words)
    assert "laspy" not in result.stderr.lower() and "buffer size" not in result.stderr


@pytest.mark.parametrize("cut", [-1, -20, 0.5, 400], ids=["table", "chunk", "half", "vlr"])
def test_truncated_laz_says_so(tmp_path, cut):
    data = _las_bytes(tmp_path, "laz")
    n = len(data) + cut if cut < 0 else int(len(data) * cut) if cut < 1 else cut
    path = tmp_path / "cut.laz"
    path.write_bytes(data[:n])
    result = run("info", path)
    assert_user_error(result, str(path), "truncated LAZ file")
    assert "Lazrs" not in result.stderr and "fill whole buffer" not in result.stderr


def test_truncated_las_refused_before_a_tiled_run(tmp_path):
    data = _las_bytes(tmp_path, "las")
    path = tmp_path / "cut.las"
    path.write_bytes(data[: len(data) // 2])
    out = tmp_path / "out.las"
    result = run("features", path, out, "--k", "8", "--tile-size", "0.5")
    assert_user_error(result, "truncated LAS file", "the header declares 500 points")
    assert not out.exists()


def test_complete_las_and_laz_still_read(tmp_path):
    for ext in ("las", "laz"):
        path = tmp_path / f"ok.{ext}"
        write_point_set(path, _cloud())
        assert read_point_set(path).n_points == 500
