"""Bundled models and named synthetic shapes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pointatlas import PointAtlasError
from pointatlas.data import DEFAULT_MODEL, info, load, load_mesh, names, path
from pointatlas.io import read_mesh

SHARED = Path(__file__).resolve().parents[2] / ".." / "shared" / "data"
BUNDLED = [row.name for row in info() if row.file]

#: what the shared manifest says about the bundled files (vertex count, licence start)
EXPECTED = {
    "fandisk": ("fandisk_12494.obj", 12494, "MPL-2.0"),
    "torus": ("torus_4350.stl", 4350, "MIT"),
    "eight": ("eight_766.off", 766, "MIT"),
    "hand": ("hand_open_810.obj", 810, "CC BY 4.0"),
    "cube": ("cube_26.obj", 26, "CC BY 4.0"),
    "torus_coarse": ("torus_2304.obj", 2304, "CC BY 4.0"),
}


def test_names_sorted_unique_and_complete():
    got = names()
    assert got == sorted(set(got))
    assert set(EXPECTED) <= set(got)
    assert DEFAULT_MODEL == "fandisk" and DEFAULT_MODEL in got
    assert any(n.startswith("synth:") for n in got)
    assert [row.name for row in info()] == got


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_bundled_models_load_with_unit_normals(name):
    file, count, lic = EXPECTED[name]
    ps = load(name)
    assert ps.name == name and ps.n_points == count
    np.testing.assert_allclose(np.linalg.norm(ps.normals, axis=1), 1.0, atol=1e-12)
    assert path(name).name == file and path(name).is_file()
    row = next(r for r in info() if r.name == name)
    assert (row.n_points, row.license, row.file) == (count, lic, file)
    mesh = load_mesh(name)
    assert mesh.name == name and mesh.n_vertices == count
    np.testing.assert_array_equal(mesh.vertices, ps.points)


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data is absent")
def test_bundled_files_are_the_manifest_files():
    manifest = {Path(e["file"]).name: e for e in json.loads((SHARED / "manifest.json").read_text())}
    for name in BUNDLED:
        entry = manifest[path(name).name]
        assert path(name).read_bytes() == (SHARED / entry["file"]).read_bytes()
        mesh = read_mesh(path(name))
        assert (mesh.n_vertices, mesh.n_faces) == (entry["vertices"], entry["faces"])
        assert entry["license"].startswith(EXPECTED[name][2])


def test_package_data_small_and_licensed():
    folder = path("fandisk").parent
    total = sum(f.stat().st_size for f in folder.iterdir())
    assert total < 5_000_000
    licenses = (folder.parent / "LICENSES.md").read_text()
    for name in BUNDLED:
        assert path(name).name in licenses


@pytest.mark.parametrize("name", [n for n in names() if n.startswith("synth:")])
def test_synthetic_shapes(name):
    ps = load(name)
    row = next(r for r in info() if r.name == name)
    assert ps.name == name and ps.n_points == row.n_points
    np.testing.assert_allclose(np.linalg.norm(ps.normals, axis=1), 1.0, atol=1e-12)
    assert load_mesh(name).n_vertices == row.n_points
    with pytest.raises(PointAtlasError, match="no file"):
        path(name)


def test_unknown_name_lists_available():
    for func in (load, load_mesh, path):
        with pytest.raises(PointAtlasError, match="unknown model 'bunny'; available: cube, eight"):
            func("bunny")
