"""XYZ columns: normals only when they are unit vectors, integer colours as colours,
header rows naming the columns, the choice printed by the CLI (nothing misread)."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.io import PointAtlasIOError, read_point_set
from tests.cli.helpers import run


def _rows(*blocks) -> str:
    table = np.hstack(blocks)
    cells = [[repr(float(v)) if v != int(v) else str(int(v)) for v in row] for row in table]
    return "".join(" ".join(row) + "\n" for row in cells)


@pytest.fixture
def cloud():
    rng = np.random.default_rng(7)
    p = rng.uniform(-5, 5, (50, 3)).round(4)
    n = rng.normal(size=(50, 3))
    n = (n / np.linalg.norm(n, axis=1, keepdims=True)).round(6)
    rgb = rng.integers(0, 256, (50, 3)).astype(float)
    return p, n, rgb


def test_integer_rgb_columns_are_colours_not_normals(tmp_path, cloud):
    p, _, rgb = cloud
    f = tmp_path / "c.xyz"
    f.write_text(_rows(p, rgb))
    ps = read_point_set(f, with_normals=True)
    assert ps.normals is None
    assert ps.attributes["colors"].dtype == np.uint8
    np.testing.assert_array_equal(ps.attributes["colors"], rgb.astype(np.uint8))
    assert "3-5 colours" in ps.meta["columns"]


def test_sixteen_bit_colours_and_normals_then_colours(tmp_path, cloud):
    p, n, rgb = cloud
    f = tmp_path / "c.xyz"
    f.write_text(_rows(p, n, rgb * 257))
    ps = read_point_set(f)
    np.testing.assert_allclose(ps.normals, n / np.linalg.norm(n, axis=1, keepdims=True))
    assert ps.attributes["colors"].dtype == np.uint16
    np.testing.assert_array_equal(ps.attributes["colors"], rgb * 257)


def test_other_columns_stay_columns(tmp_path, cloud):
    p, n, _ = cloud
    f = tmp_path / "c.xyz"
    f.write_text(_rows(p, n * 2.5))  # not unit, not integers
    ps = read_point_set(f)
    assert ps.normals is None
    assert sorted(ps.attributes) == ["column_3", "column_4", "column_5"]
    np.testing.assert_allclose(ps.attributes["column_4"], n[:, 1] * 2.5)


def test_unit_normals_rounded_to_three_decimals_are_normals(tmp_path, cloud):
    p, n, _ = cloud
    f = tmp_path / "c.xyz"
    f.write_text(_rows(p, n.round(3)))
    assert read_point_set(f).normals is not None


@pytest.mark.parametrize(
    "header, sep",
    [
        ("X\tY\tZ\tR\tG\tB\tNx\tNy\tNz", "\t"),
        ("//X Y Z R G B Nx Ny Nz", " "),
        ("x,y,z,r,g,b,nx,ny,nz", ","),
    ],
)
def test_header_rows_name_the_columns(tmp_path, cloud, header, sep):
    p, n, rgb = cloud
    body = _rows(p, rgb, n).replace(" ", sep)
    f = tmp_path / "h.txt"
    f.write_text(header + "\n" + body)
    ps = read_point_set(f)
    np.testing.assert_array_equal(ps.points, p)
    np.testing.assert_allclose(ps.normals, n / np.linalg.norm(n, axis=1, keepdims=True))
    np.testing.assert_array_equal(ps.attributes["colors"], rgb.astype(np.uint8))
    assert ps.meta["columns"].startswith("header:")


def test_header_scalar_names_kept_and_bad_headers_refused(tmp_path, cloud):
    p, _, _ = cloud
    f = tmp_path / "h.txt"
    f.write_text("X Y Z Intensity\n" + _rows(p, p[:, :1]))
    ps = read_point_set(f)
    np.testing.assert_array_equal(ps.attributes["Intensity"], p[:, 0])
    f.write_text("X Y Intensity\n" + _rows(p, p[:, :1]))
    with pytest.raises(PointAtlasIOError, match="names 3 columns but the rows have 4"):
        read_point_set(f)
    f.write_text("X Y W Intensity\n" + _rows(p, p[:, :1]))
    with pytest.raises(PointAtlasIOError, match="names no 'z' column"):
        read_point_set(f)


def test_cli_keeps_the_colours_and_prints_the_choice(tmp_path, cloud):
    rng = np.random.default_rng(1)
    d = rng.normal(size=(400, 3))
    p = d / np.linalg.norm(d, axis=1, keepdims=True)
    rgb = rng.integers(0, 256, (400, 3)).astype(float)
    f = tmp_path / "s.xyz"
    f.write_text(_rows(p, rgb))
    out = tmp_path / "out.ply"
    result = run("normals", f, out, "--k", "10")
    assert result.exit_code == 0, result.output
    assert "3-5 colours (integers 0..255)" in result.stderr
    back = read_point_set(out)
    np.testing.assert_array_equal(back.attributes["colors"], rgb.astype(np.uint8))
    assert not any(k.startswith("input_normals") for k in back.attributes)


def test_coff_vertex_colours_and_noff_normals_are_read_and_kept(tmp_path):
    from plyfile import PlyData

    from pointatlas.io import read_point_set
    from tests.cli.helpers import run

    coff = tmp_path / "c.off"
    rows = [
        f"{x} {y} {z} {r} {g} {b} 255"
        for x, y, z, r, g, b in [
            (0, 0, 0, 255, 0, 0),
            (1, 0, 0, 0, 255, 0),
            (0, 1, 0, 0, 0, 255),
            (0, 0, 1, 10, 20, 30),
            (1, 1, 1, 40, 50, 60),
        ]
    ]
    coff.write_text("COFF\n5 1 0\n" + "\n".join(rows) + "\n3 0 1 2\n")
    ps = read_point_set(coff, with_normals=False)
    assert ps.attributes["colors"].dtype == np.uint8
    assert ps.attributes["colors"][3].tolist() == [10, 20, 30, 255]
    out = tmp_path / "out.ply"
    assert run("normals", coff, out, "--k", "3").exit_code == 0
    got = PlyData.read(str(out))["vertex"].data
    assert got["red"].tolist() == [255, 0, 0, 10, 40] and got["alpha"].tolist()[-1] == 255
    noff = tmp_path / "n.off"
    noff.write_text("NOFF\n3 0 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n")
    assert read_point_set(noff).normals[:, 2].tolist() == [1.0, 1.0, 1.0]
