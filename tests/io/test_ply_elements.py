"""PLY elements: ``tristrips`` read as triangles, and everything not read named in
one warning (an element, a vertex list property, a face property), never silence."""

from __future__ import annotations

import numpy as np
import plyfile
import pytest

from pointatlas import data
from pointatlas.io import read_mesh, read_point_set
from pointatlas.io._ply import strip_triangles


def _strips_of(tri: np.ndarray) -> list[list[int]]:
    """A strip per pair of triangles sharing an edge when possible, else per triangle,
    joined into records with -1 restarts (three records): a plain reference encoding."""
    strips = []
    k = 0
    while k < len(tri):
        a, b, c = tri[k]
        if k + 1 < len(tri):
            d = tri[k + 1]
            # the next triangle as (c, b, x) in strip order: (b, c, x) reversed
            for r in range(3):
                p, q, x = np.roll(d, r)
                if (p, q) == (c, b):
                    strips.append([a, b, c, x])
                    break
            else:
                strips.append([a, b, c])
                k += 1
                continue
            k += 2
        else:
            strips.append([a, b, c])
            k += 1
    records = [[], [], []]
    for i, s in enumerate(strips):
        records[i % 3] += ([-1] if records[i % 3] else []) + [int(v) for v in s]
    return records


def _canonical(tri: np.ndarray) -> np.ndarray:
    """Triangles as sets of oriented rotations: each rotated to start at its smallest id."""
    tri = np.asarray(tri)
    r = np.argmin(tri, axis=1)
    rolled = np.stack([np.roll(t, -k) for t, k in zip(tri, r, strict=True)])
    return rolled[np.lexsort(rolled.T[::-1])]


def _write_strips_ply(path, vertices, records, text: bool, extra=()):
    v = np.zeros(len(vertices), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    for c, k in enumerate("xyz"):
        v[k] = vertices[:, c]
    s = np.empty(len(records), dtype=[("vertex_indices", "O")])
    s["vertex_indices"] = [np.array(r, dtype=np.int32) for r in records]
    elements = [
        plyfile.PlyElement.describe(v, "vertex"),
        plyfile.PlyElement.describe(
            s, "tristrips", val_types={"vertex_indices": "i4"}, len_types={"vertex_indices": "i4"}
        ),
        *extra,
    ]
    plyfile.PlyData(elements, text=text).write(str(path))


@pytest.mark.parametrize("text", [False, True])
def test_tristrips_read_as_the_indexed_twin(tmp_path, text):
    mesh = data.load_mesh("torus")
    tri = np.asarray(mesh.triangles)
    records = _strips_of(tri)
    assert sum(r.count(-1) for r in records) > 0
    f = tmp_path / "strips.ply"
    _write_strips_ply(f, np.asarray(mesh.vertices), records, text)
    back = read_mesh(f)
    assert back.n_faces == len(tri)
    np.testing.assert_array_equal(_canonical(back.triangles), _canonical(tri))
    twin = tmp_path / "twin.ply"
    from pointatlas.io import write_mesh

    write_mesh(twin, mesh)
    np.testing.assert_allclose(read_point_set(f).normals, read_point_set(twin).normals, atol=1e-12)


def test_strip_triangles_against_a_loop():
    rng = np.random.default_rng(3)
    flat = rng.integers(-1, 9, 200)
    sizes = np.array([50, 70, 80])
    expect = []
    start = 0
    for size in sizes:
        run = []
        for v in flat[start : start + size].tolist() + [-1]:
            if v < 0:
                for k in range(len(run) - 2):
                    t = run[k : k + 3]
                    t = [t[1], t[0], t[2]] if k % 2 else t
                    if len(set(t)) == 3:
                        expect.append(t)
                run = []
            else:
                run.append(v)
        start += size
    assert strip_triangles(flat, sizes).tolist() == expect


def test_what_is_not_read_is_named_in_one_warning(tmp_path):
    v = np.zeros(3, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("tags", "O")])
    v["x"] = [0, 1, 0]
    v["y"] = [0, 0, 1]
    v["tags"] = [np.array([1, 2], "i4"), np.array([3, 4], "i4"), np.array([5, 6], "i4")]
    face = np.zeros(1, dtype=[("vertex_indices", "O"), ("flags", "i4")])
    face["vertex_indices"] = [np.array([0, 1, 2], "i4")]
    cam = np.zeros(1, dtype=[("fx", "f4")])
    elements = [
        plyfile.PlyElement.describe(v, "vertex", val_types={"tags": "i4"}),
        plyfile.PlyElement.describe(face, "face"),
        plyfile.PlyElement.describe(cam, "camera"),
    ]
    f = tmp_path / "odd.ply"
    plyfile.PlyData(elements).write(str(f))
    with pytest.warns(UserWarning) as caught:
        mesh = read_mesh(f)
    assert mesh.n_faces == 1
    (message,) = [str(w.message) for w in caught]
    assert len(message.splitlines()) == 1
    for part in ("element 'camera' (1 records)", "face property 'flags'"):
        assert part in message, message
    assert "tags" not in message  # read: lists of one length are kept


@pytest.mark.parametrize("binary", [True, False])
def test_a_vertex_list_property_survives_the_normals_command(tmp_path, binary):
    """``list uchar int tags`` of one length: an (N, 2) attribute, written back as
    tags_0, tags_1 (the values survive); lists of different lengths: refused by name."""
    from tests.cli.helpers import run

    rng = np.random.default_rng(0)
    n = 200
    v = np.zeros(n, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("tags", "O")])
    v["x"], v["y"], v["z"] = rng.random((3, n)).astype("f4")
    v["tags"] = [np.array([i, 2 * i], "i4") for i in range(n)]
    el = plyfile.PlyElement.describe(
        v, "vertex", val_types={"tags": "i4"}, len_types={"tags": "u1"}
    )
    src, out = tmp_path / "tags.ply", tmp_path / "out.ply"
    plyfile.PlyData([el], text=not binary).write(str(src))
    res = run("normals", src, out, "--k", "8")
    assert res.exit_code == 0, res.output
    got = plyfile.PlyData.read(str(out))["vertex"].data
    assert got["tags_0"].tolist() == list(range(n))
    assert got["tags_1"].tolist() == [2 * i for i in range(n)]
    v["tags"][3] = np.array([7], "i4")
    plyfile.PlyData([el], text=not binary).write(str(src))
    bad = run("normals", src, tmp_path / "bad.ply", "--k", "8")
    assert bad.exit_code == 1 and "vertex list property 'tags' has lists of 1 to 2" in bad.output
