import json

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.data import load_mesh
from pointatlas.io import read_mesh, write_mesh
from pointatlas.synth import cube, plane_patch

runner = CliRunner()


@pytest.fixture
def cube_file(tmp_path):
    m = cube(8, size=2.0)
    return write_mesh(tmp_path / "cube.obj", m.vertices, m.faces)


#: the cube's edge and corner vertices carry 45- and 55-degree normals: with the
#: default 10-degree threshold they form 28 small regions whose absorption into the
#: faces is decided by exact ties, i.e. by the order of the points (old and new code
#: alike: 2-3 of 12 shuffled inputs gave 7-12 vertices); 20 degrees lets VSA itself
#: absorb them, and every input order gives the 8-vertex cube (tested in
#: test_pipeline.py)
ROBUST = ["--max-angle-deg", "20", "--vertices-only"]


def test_simplify_cube_writes_closed_polygon_mesh(cube_file, tmp_path):
    out = tmp_path / "cube_simple.obj"
    tri = tmp_path / "cube_tri.ply"
    rep = tmp_path / "report.json"
    res = runner.invoke(
        app,
        [
            "simplify",
            str(cube_file),
            str(out),
            "--triangles",
            str(tri),
            "--report",
            str(rep),
            "--vertices",
            "optimize",
            *ROBUST,
        ],
    )
    assert res.exit_code == 0, res.output
    mesh = read_mesh(out)
    assert mesh.n_vertices == 8 and mesh.n_faces == 6
    assert mesh.face_sizes.tolist() == [4] * 6
    assert read_mesh(tri).n_faces == 12
    report = json.loads(rep.read_text())
    assert report["is_closed"] and report["is_oriented"] and report["n_faces"] == 6
    assert report["complex"]["conjecture4"]["holds"]


def test_simplify_default_gives_planar_faces(cube_file, tmp_path):
    rep = tmp_path / "report.json"
    res = runner.invoke(
        app,
        [
            "simplify",
            str(cube_file),
            str(tmp_path / "c.obj"),
            "--report",
            str(rep),
            "--vertices-only",
        ],
    )
    assert res.exit_code == 0, res.output
    report = json.loads(rep.read_text())
    assert report["vertex_method"] == "fit" and not report["fallback"]
    assert report["is_closed"] and report["is_manifold"] and report["is_oriented"]
    assert report["max_planarity_error"] < 1e-9 and report["faces_not_ok"] == []
    res = runner.invoke(
        app,
        [
            "simplify",
            str(cube_file),
            str(tmp_path / "d.obj"),
            "--anchor-weight",
            "0",
            "--vertices-only",
        ],
    )
    assert res.exit_code == 1 and "--anchor-weight" in res.output


def test_simplify_star_faces(cube_file, tmp_path):
    # (--render is exercised by the demo step test below)
    out = tmp_path / "c.ply"
    res = runner.invoke(
        app, ["simplify", str(cube_file), str(out), "--face-method", "star", *ROBUST]
    )
    assert res.exit_code == 0, res.output
    assert read_mesh(out).n_faces == 6


def test_degenerate_input_gives_one_line_and_no_file(tmp_path):
    m = plane_patch()
    flat = write_mesh(tmp_path / "flat.obj", m.vertices, m.faces)
    out = tmp_path / "flat_simple.obj"
    # the thesis path alone cannot mesh one plane: one line, no file
    res = runner.invoke(
        app, ["simplify", str(flat), str(out), "--vertices-only", "--path", "thesis"]
    )
    assert res.exit_code == 1
    assert "error:" in res.output and "regions" in res.output
    assert not out.exists()


def test_flat_points_take_the_robust_path_and_say_why(tmp_path):
    m = plane_patch()
    flat = write_mesh(tmp_path / "flat.obj", m.vertices, m.faces)
    out = tmp_path / "flat_simple.obj"
    rep = tmp_path / "r.json"
    res = runner.invoke(
        app, ["simplify", str(flat), str(out), "--vertices-only", "--report", str(rep)]
    )
    assert res.exit_code == 0, res.output
    info = json.loads(rep.read_text())
    assert info["path"] == "robust"
    assert info["path_reason"].startswith("thesis path: ") and "regions" in info["path_reason"]
    assert info["n_faces"] == 1 and not info["is_closed"] and info["is_manifold"]
    assert "robust" in res.output
    # one face (region); written as planar polygons, several where the outline is not
    # star-shaped (a reader fans each polygon)
    written = read_mesh(out)
    assert written.n_faces == info["n_polygons"]
    centred = written.vertices - written.vertices.mean(axis=0)
    off_plane = np.linalg.svd(centred, compute_uv=False)[-1]  # RMS distance x sqrt(n)
    assert off_plane < 1e-9 * np.ptp(written.vertices[:, 0])


def test_simplify_uses_the_labels_written_by_segment(tmp_path):
    m = cube(8, size=2.0)
    pts = write_mesh(tmp_path / "cube.obj", m.vertices, m.faces)
    seg = tmp_path / "cube_seg.ply"
    res = runner.invoke(app, ["segment", str(pts), str(seg), "--max-angle-deg", "20"])
    assert res.exit_code == 0, res.output
    out = tmp_path / "cube_simple.obj"
    rep = tmp_path / "r.json"
    res = runner.invoke(app, ["simplify", str(seg), str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    assert "the input's 'label' field" in res.output
    info = json.loads(rep.read_text())
    # the six faces of segment's regions, closed; VSA is not run again
    assert info["path"] == "thesis" and info["n_faces"] == 6 and info["is_closed"]
    assert read_mesh(out).n_faces == 6
    # --no-labels runs VSA (here with a threshold that gives the same six faces)
    res = runner.invoke(
        app, ["simplify", str(seg), str(out), "--no-labels", "--max-angle-deg", "20"]
    )
    assert res.exit_code == 0, res.output
    assert "label' field" not in res.output
    assert read_mesh(out).n_faces == 6


def test_open_sheet_keeps_its_boundary_on_the_mesh_path(tmp_path):
    m = plane_patch()
    flat = write_mesh(tmp_path / "flat.obj", m.vertices, m.faces)
    out = tmp_path / "flat_simple.obj"
    rep = tmp_path / "r.json"
    res = runner.invoke(app, ["simplify", str(flat), str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    report = json.loads(rep.read_text())
    assert report["n_faces"] == 1 and not report["is_closed"] and report["is_manifold"]
    assert report["euler_characteristic"] == 1  # a disk
    got = read_mesh(out)
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    np.testing.assert_allclose(got.vertices.min(axis=0), lo, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.vertices.max(axis=0), hi, rtol=0, atol=1e-12)


def test_bad_output_extension(cube_file, tmp_path):
    res = runner.invoke(app, ["simplify", str(cube_file), str(tmp_path / "x.png")])
    assert res.exit_code == 1 and "OUT must end in" in res.output
    res = runner.invoke(
        app,
        [
            "simplify",
            str(cube_file),
            str(tmp_path / "x.obj"),
            "--eta",
            "5",
            "--max-angle-deg",
            "10",
        ],
    )
    assert res.exit_code == 1 and "give one of" in res.output


@pytest.mark.slow
def test_demo_step_segments_and_simplifies_fandisk(tmp_path):
    from pointatlas.cli._cmd_core import run_demo
    from pointatlas.cli._cmd_simplify import demo_simplify

    written = run_demo(tmp_path, steps=[demo_simplify])
    names = {p.name for p in written}
    assert {"fandisk_simplified.obj", "fandisk_simplified.png"} <= names
    assert (tmp_path / "fandisk_simplified.png").stat().st_size > 10_000
    summary = json.loads((tmp_path / "fandisk_simplified.json").read_text())
    assert summary["is_closed"] and summary["n_faces"] >= 15
    assert summary["is_manifold"] and summary["is_oriented"] and summary["faces_not_ok"] == []
    assert summary["vertex_method"] == "fit" and summary["max_planarity_error"] < 1e-9


def test_usage_names_the_arguments_in_and_out():
    # the same IN OUT pattern as the other commands (pointatlas segment --help)
    for command in ("simplify", "segment"):
        res = runner.invoke(app, [command, "--help"], terminal_width=200)
        assert res.exit_code == 0, res.output
        assert f"pointatlas {command} [OPTIONS] {{IN}} {{OUT}}" in " ".join(res.output.split())


def test_triangles_file_opens_in_trimesh_with_the_faces_colours(tmp_path):
    """trimesh (like Open3D and CloudCompare) reads triangle meshes only: the
    ``--triangles`` file is the one to give it; it is closed like the polygon mesh,
    has n - 2 triangles per n-gon, and each triangle carries its face's colour."""
    import numpy as np
    import trimesh

    from pointatlas.viz import label_colors

    out, tri, rep = tmp_path / "f.ply", tmp_path / "f_tri.ply", tmp_path / "r.json"
    args = ["simplify", "fandisk", str(out), "--triangles", str(tri), "--report", str(rep)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    poly = read_mesh(out)
    tm = trimesh.load(tri, process=False)
    assert json.loads(rep.read_text())["is_closed"] and tm.is_watertight
    assert len(tm.faces) == int((poly.face_sizes - 2).sum())
    ours = read_mesh(tri)
    assert np.array_equal(tm.faces, ours.triangles)
    assert np.array_equal(tm.vertices, ours.vertices) and np.array_equal(
        ours.vertices, poly.vertices
    )
    # each triangle has its face's (region's) colour; a face is one or more polygons
    colors = tm.visual.face_colors[:, :3]
    n_regions = json.loads(rep.read_text())["n_faces"]
    assert len(np.unique(colors, axis=0)) == n_regions <= poly.n_faces
    from pointatlas import data
    from pointatlas.simplify import decimate_mesh

    fandisk = data.load_mesh("fandisk")
    face_of = decimate_mesh(fandisk.vertices, fandisk.triangles).triangle_face
    expect = np.round(label_colors(face_of) * 255).astype(np.uint8)
    assert np.array_equal(colors, expect)


@pytest.mark.parametrize("model", ["fandisk", "points"])
def test_stl_output_is_the_earcut_triangles(tmp_path, model):
    """STL holds triangles only: OUT.stl is the ``--triangles`` mesh (earcut, not a
    fan across a non-convex face), closed and consistently oriented, on both paths."""
    import numpy as np
    import trimesh

    from pointatlas.io import write_point_set
    from pointatlas.simplify import mesh_checks
    from pointatlas.synth import sample_mesh

    src = "fandisk"
    if model == "points":
        m = cube(4)
        s = sample_mesh(m.vertices, m.faces, 3000, rng=0)
        src = tmp_path / "pts.ply"
        write_point_set(src, s.points, normals=s.normals)
    stl, tri = tmp_path / "f.stl", tmp_path / "f_tri.ply"
    res = runner.invoke(app, ["simplify", str(src), str(stl), "--triangles", str(tri)])
    assert res.exit_code == 0, res.output
    a, b = read_mesh(stl), read_mesh(tri)
    assert mesh_checks(a.n_vertices, a.triangles) == (True, True, True)
    assert a.n_faces == b.n_faces
    # the same triangles in the same order (STL stores float32 corners)
    corners_a = a.vertices[a.triangles].astype(np.float32)
    assert np.array_equal(corners_a, b.vertices[b.triangles].astype(np.float32))
    assert trimesh.load(stl).is_watertight


def test_max_triangles_decimates_and_regions_is_the_other_method(tmp_path):
    reports = {}
    for how in ([], ["--regions"]):
        out, rep = tmp_path / f"e{len(how)}.obj", tmp_path / f"r{len(how)}.json"
        args = ["simplify", "eight", str(out), "--max-triangles", "320", "--report", str(rep)]
        res = runner.invoke(app, args + how)
        assert res.exit_code == 0, res.output
        reports[len(how)] = info = json.loads(rep.read_text())
        assert info["is_closed"] and info["n_triangles"] <= 330
        assert read_mesh(out).n_faces == info["n_polygons"]
    assert reports[0]["method"] == "decimate" and reports[1]["method"] == "regions"
    # placed vertices: the decimation is much closer at the same budget, both ways
    assert reports[0]["hausdorff"] < 0.5 * reports[1]["hausdorff"]
    # --faces counts regions: the region method
    rep = tmp_path / "f.json"
    args = ["simplify", "eight", str(tmp_path / "x.obj"), "--faces", "5", "--report", str(rep)]
    assert runner.invoke(app, args).exit_code == 0
    assert json.loads(rep.read_text())["method"] == "regions"


def test_default_is_within_half_a_percent_both_ways_and_simplifies(tmp_path):
    """The default level: the fewest triangles within 0.5 % of the diagonal both ways
    (the report's Hausdorff distance), a real simplification of a dense mesh."""
    out, rep = tmp_path / "f.obj", tmp_path / "r.json"
    res = runner.invoke(app, ["simplify", "fandisk", str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    info = json.loads(rep.read_text())
    m = load_mesh("fandisk")
    diag = float(np.linalg.norm(np.ptp(m.vertices, axis=0)))
    assert info["hausdorff"] <= 0.005 * diag
    # the report and the table put the distance on the scale --max-error reads
    assert info["diagonal"] == pytest.approx(diag, rel=1e-12)
    assert info["hausdorff_pct"] == pytest.approx(100.0 * info["hausdorff"] / diag, rel=1e-12)
    assert f"({info['hausdorff_pct']:.2f} % of the diagonal)" in " ".join(res.output.split())
    assert info["n_triangles"] <= 0.05 * len(m.triangles)
    assert info["is_closed"] and info["is_manifold"] and info["is_oriented"]
    rep2 = tmp_path / "r2.json"
    args = ["simplify", "fandisk", str(out.with_suffix(".ply")), "--max-error", "0.1%"]
    assert runner.invoke(app, [*args, "--report", str(rep2)]).exit_code == 0
    finer = json.loads(rep2.read_text())
    assert finer["hausdorff"] <= 0.001 * diag and finer["n_triangles"] > info["n_triangles"]


def test_an_unreachable_target_is_said_and_the_report_describes_the_file(tmp_path):
    part, out, rep = tmp_path / "part.stl", tmp_path / "p.obj", tmp_path / "r.json"
    assert runner.invoke(app, ["data", "export", "cube", str(part)]).exit_code == 0
    res = runner.invoke(
        app, ["simplify", str(part), str(out), "--faces", "1", "--report", str(rep)]
    )
    assert res.exit_code == 0, res.output
    assert "not reachable: --faces 1: the closest level has" in res.stderr
    info, written = json.loads(rep.read_text()), read_mesh(out)
    assert written.n_faces == info["n_polygons"] == 6
    # what was written is the cube's six sides, planar (each side an octagon round its
    # centre vertex, which the two regions kept as input), and the report says so:
    # the polygons are planar, the two faces (three sides each) are not
    assert info["max_polygon_planarity_error"] < 1e-12 and set(written.face_sizes.tolist()) == {8}
    assert info["n_faces"] == 2 and min(info["planarity_error"]) > 0.5


@pytest.mark.parametrize(
    ("flag", "value", "low"),
    [("--faces", "0", 1), ("--max-triangles", "0", 1), ("--smooth", "-1", 0)],
)
def test_a_level_below_one_names_the_flag_as_typed(tmp_path, flag, value, low):
    res = runner.invoke(app, ["simplify", "eight", str(tmp_path / "x.obj"), flag, value])
    assert res.exit_code == 1 and f"{flag} must be at least {low}; got {value}" in res.output
    assert "n_faces" not in res.output and not (tmp_path / "x.obj").exists()


def test_points_report_the_hausdorff_distance_in_percent_of_their_diagonal(tmp_path):
    """Raw points: the JSON report's ``diagonal`` is the points' bounding-box
    diagonal, ``hausdorff_pct`` the report's two-sided distance over it, and the
    table says the same share (the unit of ``--max-error 0.5%``)."""
    from pointatlas.io import read_point_set, write_point_set
    from pointatlas.synth import sample_mesh

    m = cube(4)
    s = sample_mesh(m.vertices, m.faces, 3000, rng=0)
    src, out, rep = tmp_path / "pts.ply", tmp_path / "o.obj", tmp_path / "r.json"
    write_point_set(src, s.points, normals=s.normals)
    res = runner.invoke(app, ["simplify", str(src), str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    info = json.loads(rep.read_text())
    points = read_point_set(src).points
    diag = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    assert info["diagonal"] == pytest.approx(diag, rel=1e-12)
    assert info["hausdorff_pct"] == pytest.approx(100.0 * info["hausdorff"] / diag, rel=1e-12)
    assert info["hausdorff_pct"] > 0.0
    assert f"({info['hausdorff_pct']:.2f} % of the diagonal)" in " ".join(res.output.split())


def test_raw_points_far_from_their_output_get_their_normals_estimated_again(tmp_path, monkeypatch):
    """Where the output of estimated normals misses the points (forced here: a retry
    factor of 0), the command estimates them again at each of `RETRY_K`, says so,
    keeps the output nearest to the points, and reports every estimate."""
    import pointatlas.simplify._estimated as estimated
    from pointatlas.io import write_point_set
    from pointatlas.synth import sample_mesh

    from .cad_shapes import extrude

    monkeypatch.setattr(estimated, "RETRY_FACTOR", 0.0)
    v, t = extrude(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]), height=1.0)
    src = write_point_set(tmp_path / "raw.xyz", np.asarray(sample_mesh(v, t, 3000, rng=0).points))
    out, rep = tmp_path / "out.obj", tmp_path / "r.json"
    res = runner.invoke(app, ["simplify", str(src), str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    assert "normals estimated again at k = 30, 40 in turn" in res.output
    info = json.loads(rep.read_text())
    tried = info["normals_estimated"]["tried"]
    assert [r["k"] for r in tried] == [20, 30, 40]
    nearest = min(tried, key=lambda r: r["hausdorff"])
    assert info["normals_estimated"]["k"] == nearest["k"]
    assert f"kept the normals of k = {nearest['k']}" in res.output
    assert info["hausdorff"] == pytest.approx(nearest["hausdorff"])
    # the polygon file is the kept output, read back by another reader
    import trimesh

    assert trimesh.load(out, process=False, force="mesh").is_watertight
    assert len(read_mesh(out).vertices) == info["n_vertices"]
