"""Round trips for every format, reading the shared models, inputs untouched."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import plyfile
import pytest
import trimesh

from pointatlas import PointSet
from pointatlas.io import (
    Mesh,
    as_point_set,
    read_mesh,
    read_point_set,
    vertex_normals,
    write_mesh,
    write_point_set,
)

SHARED = Path(__file__).resolve().parents[2] / ".." / "shared" / "data"
needs_shared = pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data is absent")


@pytest.mark.parametrize("binary", [True, False])
def test_ply_point_round_trip(tmp_path, cloud, binary):
    p, n, rng = cloud
    attrs = {
        "curv": rng.random(200).astype(np.float32),
        "dist": rng.random(200),
        "label": rng.integers(-5, 5, 200).astype(np.int32),
        "count": rng.integers(0, 9, 200).astype(np.uint8),
        "flag": rng.random(200) > 0.5,
        "big": rng.integers(-(2**40), 2**40, 200),
        "feat": rng.random((200, 2)),
    }
    colors = rng.integers(0, 256, (200, 3)).astype(np.uint8)
    f = tmp_path / "c.ply"
    write_point_set(f, p, normals=n, attributes=attrs, colors=colors, binary=binary)
    ps = read_point_set(f)
    np.testing.assert_array_equal(ps.points, p)
    np.testing.assert_allclose(ps.normals, n, atol=1e-15)
    np.testing.assert_array_equal(ps.attributes["colors"], colors)
    assert ps.attributes["curv"].dtype == np.float32
    np.testing.assert_array_equal(ps.attributes["curv"], attrs["curv"])
    np.testing.assert_array_equal(ps.attributes["dist"], attrs["dist"])
    assert ps.attributes["label"].dtype == np.int32
    np.testing.assert_array_equal(ps.attributes["label"], attrs["label"])
    np.testing.assert_array_equal(ps.attributes["count"], attrs["count"])
    np.testing.assert_array_equal(ps.attributes["flag"], attrs["flag"].astype(np.uint8))
    np.testing.assert_array_equal(ps.attributes["big"], attrs["big"])  # stored as double
    np.testing.assert_array_equal(ps.attributes["feat_1"], attrs["feat"][:, 1])
    assert ps.name == "c"
    # a PointSet carries its own normals and attributes
    write_point_set(tmp_path / "d.ply", ps)
    again = read_point_set(tmp_path / "d.ply")
    assert set(again.attributes) == set(ps.attributes)


def test_ply_header_readable_by_plyfile(tmp_path, cloud):
    p, n, rng = cloud
    f = tmp_path / "c.ply"
    write_point_set(
        f,
        p,
        normals=n,
        attributes={"s": rng.random(200).astype(np.float32)},
        colors=rng.random((200, 4)),
    )
    ply = plyfile.PlyData.read(str(f))
    props = {q.name: q.val_dtype for q in ply["vertex"].properties}
    assert props["x"] == "f8" and props["s"] == "f4" and props["red"] == "u1"
    assert "alpha" in props


def test_ply_read_foreign_layouts(tmp_path):
    """Big-endian, float32, PCL normal names, int colours, extra elements, ascii."""
    rec = np.zeros(
        3,
        dtype=[
            ("x", ">f4"),
            ("y", ">f4"),
            ("z", ">f4"),
            ("normal_x", ">f4"),
            ("normal_y", ">f4"),
            ("normal_z", ">f4"),
            ("red", "u1"),
            ("green", "u1"),
            ("blue", "u1"),
            ("quality", ">f8"),
        ],
    )
    rec["x"] = [0, 1, 2]
    rec["normal_z"] = 2.0
    rec["red"] = [1, 2, 3]
    rec["quality"] = [0.5, 1.5, 2.5]
    cam = np.zeros(1, dtype=[("fx", "f4")])
    for text in (False, True):
        el = [
            plyfile.PlyElement.describe(cam, "camera"),
            plyfile.PlyElement.describe(rec, "vertex"),
        ]
        f = tmp_path / f"f{text}.ply"
        plyfile.PlyData(el, text=text, byte_order=">").write(str(f))
        with pytest.warns(UserWarning, match=r"not read .*element 'camera' \(1 records\)"):
            ps = read_point_set(f)
        assert ps.points[:, 0].tolist() == [0, 1, 2]
        np.testing.assert_array_equal(ps.normals, [[0, 0, 1]] * 3)
        assert ps.attributes["colors"][:, 0].tolist() == [1, 2, 3]
        assert ps.attributes["quality"].tolist() == [0.5, 1.5, 2.5]
        assert ps.attributes["quality"].dtype.isnative


@pytest.mark.parametrize("binary", [True, False])
def test_ply_mesh_round_trip_polygons_and_colours(tmp_path, mixed_mesh, binary):
    v, faces = mixed_mesh
    colors = np.arange(15, dtype=np.uint8).reshape(5, 3) * 10
    f = tmp_path / "m.ply"
    write_mesh(f, v, faces, face_colors=colors, binary=binary)
    m = read_mesh(f)
    np.testing.assert_array_equal(m.vertices, v)
    assert [x.tolist() for x in m.face_list()] == faces
    np.testing.assert_array_equal(m.face_colors, colors)
    # plyfile (an independent reader) agrees
    ply = plyfile.PlyData.read(str(f))
    assert [list(x) for x in ply["face"]["vertex_indices"]] == faces
    ps = read_point_set(f)  # a PLY with faces is a mesh: area-weighted normals
    np.testing.assert_allclose(ps.normals, vertex_normals(v, faces), atol=1e-15)


def test_ply_binary_mixed_runs(tmp_path):
    """Many alternating face sizes exercise the run-based list reader."""
    rng = np.random.default_rng(5)
    v = rng.normal(size=(50, 3))
    sizes = rng.integers(3, 7, 400)
    sizes[100:300] = 3  # a long uniform run
    faces = [list(rng.choice(50, s, replace=False)) for s in sizes]
    f = tmp_path / "mixed.ply"
    write_mesh(f, v, faces)
    m = read_mesh(f)
    assert [x.tolist() for x in m.face_list()] == [[int(i) for i in face] for face in faces]


def test_large_polygon_uses_uint_counts(tmp_path):
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    v = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    f = tmp_path / "disk.ply"
    write_mesh(f, v, [list(range(300))])
    m = read_mesh(f)
    assert m.face_sizes.tolist() == [300]
    np.testing.assert_allclose(read_point_set(f).normals, [[0, 0, 1]] * 300, atol=1e-12)


def test_obj_round_trip(tmp_path, mixed_mesh):
    v, faces = mixed_mesh
    f = tmp_path / "m.obj"
    write_mesh(f, Mesh(v, faces))
    m = read_mesh(f)
    np.testing.assert_array_equal(m.vertices, v)
    assert [x.tolist() for x in m.face_list()] == faces
    ps = read_point_set(f)
    np.testing.assert_allclose(ps.normals, vertex_normals(v, faces), atol=1e-15)


def test_obj_features(tmp_path):
    """vt/vn/slashes, negative indices, colours, comments, w coordinate."""
    text = (
        "# comment\nmtllib x.mtl\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\n"
        "vt 0 0\nvn 0 0 1\ng part\nusemtl m\nf 1/1/1 2/1/1 3/1/1\nf -3//1 -2//1 -1//1\nl 1 2\n"
    )
    f = tmp_path / "x.obj"
    f.write_text(text)
    m = read_mesh(f)
    assert m.triangles.tolist() == [[0, 1, 2], [0, 1, 2]]
    ps = read_point_set(f)
    assert ps.attributes["colors"].tolist() == [[255, 0, 0], [0, 255, 0], [0, 0, 255]]
    f.write_text("v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n")
    assert read_point_set(f).n_points == 3
    f.write_text("  v 0 0 0\nv 1 0 0 # c\nv 0 1 0\nf 1 2 3 # trailing comment\n")
    assert read_mesh(f).triangles.tolist() == [[0, 1, 2]]


def test_off_round_trip_with_colours(tmp_path, mixed_mesh):
    v, faces = mixed_mesh
    colors = np.full((5, 3), 200, dtype=np.uint8)
    f = tmp_path / "m.off"
    write_mesh(f, v, faces, face_colors=colors)
    m = read_mesh(f)
    np.testing.assert_array_equal(m.vertices, v)
    assert [x.tolist() for x in m.face_list()] == faces
    np.testing.assert_array_equal(m.face_colors, colors)
    tm = trimesh.load(f, process=False)  # an independent reader agrees
    np.testing.assert_allclose(tm.vertices, v)


def test_off_with_comments_and_counts_on_keyword_line(tmp_path):
    f = tmp_path / "c.off"
    f.write_text("OFF 3 1 0 # counts here\n# a comment\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 0.5 0.5 0.5\n")
    m = read_mesh(f)
    assert m.n_faces == 1 and m.face_colors.tolist() == [[128, 128, 128]]


def test_stl_round_trip_and_merge(tmp_path, cube_quads):
    v, faces = cube_quads
    f = tmp_path / "c.stl"
    write_mesh(f, v, faces)
    m = read_mesh(f)
    assert m.n_vertices == 8 and m.n_faces == 12
    # same vertex set (first-appearance order), triangles map to the same positions
    order = [tuple(x) for x in m.vertices]
    assert sorted(order) == sorted(tuple(x) for x in v)
    written = Mesh(v, faces).triangles
    np.testing.assert_array_equal(m.vertices[m.triangles], v[written])
    ps = read_point_set(f)
    np.testing.assert_allclose(ps.normals, vertex_normals(m.vertices, m.triangles), atol=1e-15)
    tm = trimesh.load(f, process=False)
    np.testing.assert_allclose(np.unique(tm.vertices, axis=0), np.unique(m.vertices, axis=0))


def test_stl_ascii(tmp_path):
    f = tmp_path / "a.stl"
    f.write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
        "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\n"
        "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n"
    )
    m = read_mesh(f)
    assert m.n_vertices == 4 and m.triangles.tolist() == [[0, 1, 2], [1, 3, 2]]


def test_xyz_round_trip(tmp_path, cloud):
    p, n, _ = cloud
    for name in ("a.xyz", "a.txt"):
        write_point_set(tmp_path / name, p, normals=n)
        ps = read_point_set(tmp_path / name)
        np.testing.assert_array_equal(ps.points, p)
        np.testing.assert_allclose(ps.normals, n, atol=1e-15)
    write_point_set(tmp_path / "b.xyz", p)
    assert read_point_set(tmp_path / "b.xyz").normals is None


def test_xyz_comma_comments_and_extra_columns(tmp_path):
    f = tmp_path / "c.xyz"
    f.write_text("# x,y,z,i\n0,0,0,5\n1, 2, 3, 6 # trailing\n\n")
    ps = read_point_set(f)
    assert ps.points.tolist() == [[0, 0, 0], [1, 2, 3]]
    assert ps.attributes["column_3"].tolist() == [5, 6]


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_las_round_trip(tmp_path, cloud, ext):
    p, n, rng = cloud
    p = p * 100 + 5000
    inten = rng.integers(0, 60000, 200).astype(np.uint16)
    cls = rng.integers(0, 20, 200).astype(np.uint8)
    score = rng.random(200)
    colors = rng.integers(0, 256, (200, 3)).astype(np.uint8)
    f = tmp_path / f"c{ext}"
    write_point_set(
        f,
        p,
        normals=n,
        colors=colors,
        attributes={"intensity": inten, "classification": cls, "score": score},
    )
    ps = read_point_set(f)
    extent = np.ptp(p, axis=0)
    assert (np.abs(ps.points - p) <= 2.5e-9 * extent).all()
    np.testing.assert_allclose(ps.normals, n, atol=1e-12)
    np.testing.assert_array_equal(ps.attributes["intensity"], inten)
    np.testing.assert_array_equal(ps.attributes["classification"], cls)
    np.testing.assert_array_equal(ps.attributes["score"], score)
    # LAS colours are 16 bits: uint8 is written x 257 and read back as stored (uint16)
    assert ps.attributes["colors"].dtype == np.uint16
    np.testing.assert_array_equal(ps.attributes["colors"], colors.astype(np.uint16) * 257)


def test_inputs_are_not_modified(tmp_path, cloud):
    p, n, _ = cloud
    p0, n0 = p.copy(), n.copy()
    f = tmp_path / "c.ply"
    write_point_set(f, p, normals=n * 3)
    np.testing.assert_array_equal(p, p0)
    np.testing.assert_array_equal(n, n0)
    before = f.read_bytes()
    ps = read_point_set(f)
    assert f.read_bytes() == before
    assert not ps.points.flags.writeable and not ps.normals.flags.writeable
    with pytest.raises(ValueError):
        ps.points[0, 0] = 1.0


def test_as_point_set_conversions(mixed_mesh, cloud):
    v, faces = mixed_mesh
    p, n, _ = cloud
    ps = as_point_set(np.hstack([p, 2 * n]))
    np.testing.assert_allclose(ps.normals, n, atol=1e-15)
    assert as_point_set(ps) is ps
    mesh_ps = as_point_set(Mesh(v, faces), name="pyr")
    np.testing.assert_allclose(mesh_ps.normals, vertex_normals(v, faces))
    tm = trimesh.Trimesh(vertices=v, faces=Mesh(v, faces).triangles, process=False)
    tm_ps = as_point_set(tm)
    np.testing.assert_allclose(tm_ps.points, v)
    np.testing.assert_allclose(tm_ps.normals, vertex_normals(v, Mesh(v, faces).triangles))
    pc = trimesh.PointCloud(p, colors=np.tile([10, 20, 30, 255], (200, 1)))
    pc_ps = as_point_set(pc)
    np.testing.assert_array_equal(pc_ps.points, p)
    assert pc_ps.attributes["colors"][0].tolist() == [10, 20, 30, 255]


def test_as_point_set_open3d(cloud, mixed_mesh):
    o3d = pytest.importorskip("open3d")
    p, n, _ = cloud
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
    pc.normals = o3d.utility.Vector3dVector(n)
    pc.colors = o3d.utility.Vector3dVector(np.full((200, 3), 0.5))
    ps = as_point_set(pc)
    np.testing.assert_array_equal(ps.points, p)
    np.testing.assert_allclose(ps.normals, n, atol=1e-15)
    assert ps.attributes["colors"][0].tolist() == [128, 128, 128]
    v, faces = mixed_mesh
    tri = Mesh(v, faces).triangles
    om = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(tri))
    np.testing.assert_allclose(as_point_set(om).normals, vertex_normals(v, tri))


def test_zero_normals_policy(tmp_path):
    f = tmp_path / "u.obj"
    f.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 9 9 9\nv 2 0 0\nf 1 2 3\nf 1 2 5\n")
    with pytest.raises(ValueError, match=r"2 \(indices 3, 4\)"):
        read_point_set(f)
    ps = read_point_set(f, zero_normals="drop")
    assert ps.n_points == 3 and ps.attributes["source_index"].tolist() == [0, 1, 2]
    assert read_point_set(f, with_normals=False).n_points == 5
    with pytest.raises(ValueError, match="zero_normals"):
        read_point_set(f, zero_normals="keep")
    g = tmp_path / "z.xyz"
    g.write_text("0 0 0 0 0 1\n1 0 0 0 0 0\n")
    with pytest.raises(ValueError, match=r"1 \(indices 1\)"):
        read_point_set(g)


@needs_shared
def test_shared_fandisk_6475():
    ps = read_point_set(SHARED / "models" / "fandisk_6475.obj")
    assert ps.n_points == 6475 and ps.name == "fandisk_6475"
    np.testing.assert_allclose(np.linalg.norm(ps.normals, axis=1), 1.0, atol=1e-12)
    tm = trimesh.load(SHARED / "models" / "fandisk_6475.obj", process=False)
    np.testing.assert_allclose(ps.points, tm.vertices)
    assert isinstance(ps, PointSet)


@needs_shared
@pytest.mark.parametrize(
    "name", ["torus_4350.stl", "eight_766.off", "hand_open_810.obj", "dragon_50002.ply"]
)
def test_shared_models_match_manifest(name):
    import json

    manifest = {e["file"]: e for e in json.loads((SHARED / "manifest.json").read_text())}
    entry = manifest[f"models/{name}"]
    m = read_mesh(SHARED / "models" / name)
    assert (m.n_vertices, m.n_faces) == (entry["vertices"], entry["faces"])
