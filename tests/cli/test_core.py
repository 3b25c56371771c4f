"""The core commands: info, normals, render, data list/export, demo."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PIL import Image

from pointatlas.cli._app import DEMO_STEPS
from pointatlas.io import read_mesh, read_point_set, write_point_set

from .helpers import assert_user_error, run, sphere_points, write_unit_cube_obj


@pytest.fixture
def sphere_ply(tmp_path):
    """A small sphere PLY with exact normals and two attributes."""
    pts = sphere_points()
    path = tmp_path / "sphere.ply"
    labels = (pts[:, 2] > 0).astype(np.int64)
    write_point_set(path, pts, normals=pts, attributes={"labels": labels, "height": pts[:, 2]})
    return path


@pytest.fixture
def cube_obj(tmp_path):
    """The unit cube as a quad mesh (polygon faces)."""
    return write_unit_cube_obj(tmp_path / "cube.obj")


# --------------------------------------------------------------------------- info


def test_info_table(sphere_ply):
    result = run("info", sphere_ply)
    assert result.exit_code == 0, result.output
    for text in ("points", "300", "normals", "yes", "bounding box size", "8-NN components"):
        assert text in result.stdout
    assert "labels" in result.stdout and "height" in result.stdout


def test_info_json_values(sphere_ply, tmp_path):
    # two copies of every point: duplicates = N, components merge nothing new
    pts = sphere_points()
    dup = tmp_path / "dup.xyz"
    write_point_set(dup, np.vstack([pts, pts, [[10.0, 10.0, 10.0]]]))
    result = run("info", dup, "--json", "--k", "4")
    assert result.exit_code == 0, result.output
    info = json.loads(result.stdout)
    assert info["points"] == 601
    assert info["duplicates"] == 300
    assert info["knn_k"] == 4
    assert info["knn_components"] >= 2  # the far point is its own component
    assert info["faces"] is None and info["normals"] is False
    assert info["bbox_max"] == [10.0, 10.0, 10.0]
    # l: mean distance to the 12 nearest (independent numpy check)
    from scipy.spatial import cKDTree

    all_pts = np.vstack([pts, pts, [[10.0, 10.0, 10.0]]])
    d, _ = cKDTree(all_pts).query(all_pts, k=13)
    assert info["mean_spacing"] == pytest.approx(d[:, 1:].mean(), rel=1e-12)


def test_info_mesh_counts_faces(cube_obj):
    result = run("info", cube_obj, "--json")
    assert result.exit_code == 0, result.output
    info = json.loads(result.stdout)
    assert info["points"] == 8 and info["faces"] == 6
    assert info["face_kind"] == "polygons (4-4 vertices)"
    assert info["normals"] is True


@pytest.mark.filterwarnings("default::UserWarning")  # as a user's Python shows them
@pytest.mark.parametrize("command", ["info", "simplify"])
def test_an_element_not_read_is_one_warning_line(tmp_path, command):
    # `info` reads the file as a mesh and as points: the warning comes once, without
    # Python's source line
    ply = tmp_path / "odd.ply"
    ply.write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
        "element camera 1\nproperty float fov\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
        "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n45\n"
    )
    args = [tmp_path / "out.obj"] if command == "simplify" else []
    result = run(command, ply, *args)
    assert result.exit_code == 0, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("warning: ") and "element 'camera' (1 records)" in lines[0]
    assert str(ply) in lines[0]


def test_info_truncated_ply_is_one_line_error(sphere_ply, tmp_path):
    data = sphere_ply.read_bytes()
    bad = tmp_path / "truncated.ply"
    bad.write_bytes(data[: len(data) // 2])
    assert_user_error(run("info", bad), "truncated.ply")


def test_info_missing_file(tmp_path):
    assert_user_error(run("info", tmp_path / "nope.ply"), "nope.ply")


def test_bad_option_is_usage_error(sphere_ply):
    result = run("info", sphere_ply, "--no-such-option")
    assert result.exit_code == 2
    result = run("info", sphere_ply, "--k", "many")
    assert result.exit_code == 2


def test_info_bad_k(sphere_ply):
    assert_user_error(run("info", sphere_ply, "--k", "1"), "--k")


# --------------------------------------------------------------------------- normals


def test_normals_writes_oriented_ply(sphere_ply, tmp_path):
    out = tmp_path / "n.ply"
    result = run("normals", sphere_ply, out, "--k", "12", "--orient", "outward")
    assert result.exit_code == 0, result.output
    ps = read_point_set(out)
    assert ps.n_points == 300 and ps.has_normals
    # outward on a sphere: normals point away from the centre, close to exact
    assert np.all(np.einsum("ij,ij->i", ps.normals, ps.points) > 0.9)
    assert "flipped fraction" in result.stdout
    assert set(ps.attributes) >= {"labels", "height"}  # attributes kept


def test_normals_viewpoint_and_errors(sphere_ply, tmp_path):
    out = tmp_path / "v.ply"
    result = run("normals", sphere_ply, out, "--orient", "viewpoint", "--viewpoint", "0", "0", "9")
    assert result.exit_code == 0, result.output
    ps = read_point_set(out)
    to_view = np.array([0, 0, 9.0]) - ps.points
    assert np.all(np.einsum("ij,ij->i", ps.normals, to_view) >= 0)
    assert_user_error(run("normals", sphere_ply, out, "--orient", "viewpoint"), "--viewpoint")
    assert_user_error(run("normals", sphere_ply, out, "--orient", "sideways"), "--orient")
    assert_user_error(run("normals", sphere_ply, tmp_path / "x.obj"), "OUT")
    assert_user_error(run("normals", sphere_ply, out, "--k", "2"), "--k")


# --------------------------------------------------------------------------- render


def png_size(path):
    with Image.open(path) as im:
        return im.size


@pytest.mark.parametrize("color_by", ["normals", "labels", "height", "z"])
def test_render_points(sphere_ply, tmp_path, color_by):
    out = tmp_path / f"{color_by}.png"
    result = run("render", sphere_ply, out, "--color-by", color_by, "--render-size", 300, 200)
    assert result.exit_code == 0, result.output
    assert png_size(out) == (300, 200)


def test_render_mesh_and_bad_field(cube_obj, sphere_ply, tmp_path):
    out = tmp_path / "cube.png"
    result = run("render", cube_obj, out, "--title", "cube", "--render-size", 200, 200)
    assert result.exit_code == 0, result.output
    assert png_size(out) == (200, 200)
    assert_user_error(
        run("render", sphere_ply, tmp_path / "b.png", "--color-by", "nothing"), "height"
    )
    assert_user_error(run("render", sphere_ply, tmp_path / "b.jpg"), "png")
    assert_user_error(run("render", sphere_ply, tmp_path / "b.png", "--up", "w"), "--up")
    assert not (tmp_path / "b.png").exists()


# --------------------------------------------------------------------------- data


def test_data_list():
    result = run("data", "list", "--json")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    names = [r["name"] for r in rows]
    assert "fandisk" in names
    assert all(r["points"] > 0 and r["license"] for r in rows)
    table = run("data", "list")
    assert table.exit_code == 0 and "fandisk" in table.stdout


def test_data_export(tmp_path):
    out = tmp_path / "cube.off"
    result = run("data", "export", "cube", out)
    assert result.exit_code == 0, result.output
    from pointatlas.data import load_mesh

    mesh, ref = read_mesh(out), load_mesh("cube")
    assert mesh.n_faces == ref.n_faces
    assert np.allclose(mesh.vertices, ref.vertices)
    pts = tmp_path / "cube.xyz"
    assert run("data", "export", "cube", pts).exit_code == 0
    assert read_point_set(pts).n_points == ref.n_vertices
    assert_user_error(run("data", "export", "no-such-model", out), "no-such-model")


def test_commands_take_bundled_model_names(tmp_path, monkeypatch):
    """IN may name a bundled model; the result equals running on its exported file."""
    monkeypatch.chdir(tmp_path)  # no file called "synth:cube" here
    exported = tmp_path / "cube.ply"
    assert run("data", "export", "synth:cube", exported, "--points").exit_code == 0
    by_name, by_file = tmp_path / "a.ply", tmp_path / "b.ply"
    assert run("segment", "synth:cube", by_name, "--eta", "25").exit_code == 0
    assert run("segment", exported, by_file, "--eta", "25").exit_code == 0
    a, b = read_point_set(by_name), read_point_set(by_file)
    np.testing.assert_array_equal(a.attributes["label"], b.attributes["label"])
    assert a.attributes["label"].max() == 5  # the six sides
    assert_user_error(run("segment", "no-such-model", by_name), "no-such-model", "bundled")


# --------------------------------------------------------------------------- demo


def test_demo_core_steps(tmp_path):
    out = tmp_path / "demo"
    result = run("demo", "--out", out, "--only", "info,normals,picture")
    assert result.exit_code == 0, result.output
    png = out / "fandisk.png"
    assert png.exists() and png_size(png)[0] >= 900
    assert "mean spacing" in result.stdout and "12,494" in result.stdout
    stats = json.loads((out / "fandisk_normals.json").read_text())
    # PCA normals of a clean CAD model: small mean error, MST orientation consistent
    assert stats["mean_angle_error_deg"] < 10
    assert stats["flipped_fraction"] < 0.01
    assert str(out) in result.stdout


@pytest.mark.slow
def test_demo_all_steps(tmp_path):
    """The whole tour, with the steps other command modules registered."""
    result = run("demo", "--out", tmp_path)
    assert result.exit_code == 0, result.output
    assert (tmp_path / "fandisk.png").exists()
    assert result.stdout.count(f"/{len(DEMO_STEPS)}  ") == len(DEMO_STEPS)
    # the HTML report shows every step's output and every picture written, once
    report = (tmp_path / "report.html").read_text()
    assert report.count("<h2>") == len(DEMO_STEPS)
    pngs = sorted(p.name for p in tmp_path.glob("*.png"))
    assert pngs and sorted(re.findall(r"<img src='([^']+)'", report)) == pngs
    assert "12,494" in report  # the info table's point count


def test_demo_only_unknown_step(tmp_path):
    assert_user_error(run("demo", "--out", tmp_path, "--only", "info,nope"), "nope", "normals")


def test_demo_steps_are_extensible(tmp_path):
    seen = []

    def extra(ps, out_dir, console):
        """Extra step: records what it got."""
        seen.append((ps.name, out_dir, "normal_error_deg" in ps.attributes))

    DEMO_STEPS.append(extra)
    try:
        from pointatlas.cli._cmd_core import run_demo

        run_demo(tmp_path, model="cube", steps=[DEMO_STEPS[1], extra])
    finally:
        DEMO_STEPS.remove(extra)
    assert seen == [("cube", tmp_path, True)]


def test_demo_bad_out(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    assert_user_error(run("demo", "--out", f), "not a folder")


def test_component_sizes_match_neighbors_reference():
    from pointatlas.neighbors import knn_component_sizes, knn_components, query_knn

    rng = np.random.default_rng(5)
    # three separated blobs plus isolated points: several components
    pts = np.vstack(
        [rng.normal(c, 0.1, size=(60, 3)) for c in ([0, 0, 0], [5, 0, 0], [0, 5, 0])]
        + [rng.uniform(20, 40, size=(5, 3))]
    )
    for k in (2, 4, 8):
        idx, _ = query_knn(pts, k)
        n_ref, labels = knn_components(pts, k, neighbors=idx)
        sizes = knn_component_sizes(idx)
        assert sizes.size == n_ref
        assert sorted(sizes.tolist()) == sorted(np.bincount(labels).tolist())


def test_error_messages_keep_brackets(sphere_ply):
    # "[3, 300]" must survive rich's markup parsing
    result = run("normals", sphere_ply, sphere_ply.with_name("o.ply"), "--k", "1000")
    assert_user_error(result, "[3, number of points = 300]")


def test_guarded_interrupt_and_memory():
    import typer

    from pointatlas.cli._app import guarded

    @guarded
    def interrupted():
        raise KeyboardInterrupt

    @guarded
    def hungry():
        raise MemoryError

    with pytest.raises(typer.Exit) as info:
        interrupted()
    assert info.value.exit_code == 130
    with pytest.raises(typer.Exit) as info:
        hungry()
    assert info.value.exit_code == 1


def test_info_mesh_with_unreferenced_vertex(tmp_path):
    path = tmp_path / "extra.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n")
    result = run("info", path, "--json")
    assert result.exit_code == 0, result.output
    info = json.loads(result.stdout)
    assert info["points"] == 4 and info["faces"] == 1
    assert info["normals"] is False  # one vertex has no normal: all points kept
    out = tmp_path / "extra.png"
    assert run("render", path, out, "--render-size", 120, 120).exit_code == 0
    assert run("normals", path, tmp_path / "n.ply", "--k", "3").exit_code == 0


def test_paths_with_brackets_are_printed_verbatim(tmp_path):
    src = tmp_path / "scan[1].xyz"
    write_point_set(src, sphere_points(50))
    result = run("info", src)
    assert result.exit_code == 0 and "scan[1].xyz" in result.stdout
    out = tmp_path / "pic[2].png"
    result = run("render", src, out, "--render-size", 100, 100)
    assert result.exit_code == 0 and "pic[2].png" in result.stdout
    assert_user_error(run("render", src, out, "--as", "mesh"), "no faces")
