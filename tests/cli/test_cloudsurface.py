"""``pointatlas cloudsurface`` and ``pointatlas deform``."""

import json

import numpy as np
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.io import read_mesh, read_point_set, write_mesh, write_point_set
from pointatlas.synth import fibonacci_sphere

runner = CliRunner()


def _run(args):
    res = runner.invoke(app, [str(a) for a in args])
    return res


def test_cloudsurface_search_writes_the_set_and_finds_a_closed_sphere(tmp_path):
    src = tmp_path / "sphere.ply"
    write_point_set(
        src,
        fibonacci_sphere(4000).vertices,
        attributes={"intensity": np.arange(4000, dtype=np.uint16)},
    )
    out = tmp_path / "cs"
    res = _run(["cloudsurface", src, out, "--search", "0.8", "1.2", "0.2", "--no-render"])
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "report.json").read_text())
    assert summary["accepted"] and summary["report"]["is_closed"]
    assert summary["report"]["genus"] == 0 and summary["report"]["euler_characteristic"] == 2
    names = {f["path"] for f in summary["files"]}
    assert names == {"clouds.ply", "complex.ply", "cloudsurface.npz", "report.txt", "search.csv"}
    clouds = read_point_set(out / "clouds.ply")
    assert "intensity" in clouds.attributes and "n_clouds" in clouds.attributes
    assert clouds.attributes["n_clouds"].min() >= 1
    mesh = read_mesh(out / "complex.ply")
    assert mesh.n_faces == summary["report"]["n_faces"]
    assert "euler_characteristic" in (out / "report.txt").read_text()


def test_cloudsurface_from_mesh_and_deform_round_trip(tmp_path):
    out = tmp_path / "hand"
    res = _run(
        [
            "cloudsurface",
            "--from-mesh",
            "hand",
            out,
            "--density",
            "eta2",
            "--density-c",
            "1",
            "--samples",
            "3",
            "--no-render",
        ]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "report.json").read_text())
    assert summary["complex_equals_mesh"] and summary["report"]["n_boundary_loops"] == 1
    m = read_mesh(out / "complex.ply")
    write_mesh(tmp_path / "new.ply", m.vertices * 1.5 + 0.1, m.triangles)
    res = _run(["deform", out, tmp_path / "new.ply", tmp_path / "moved.ply"])
    assert res.exit_code == 0, res.output
    res = _run(
        [
            "deform",
            out,
            tmp_path / "new.ply",
            tmp_path / "back.ply",
            "--inverse",
            "--move",
            tmp_path / "moved.ply",
        ]
    )
    assert res.exit_code == 0, res.output
    pts = np.load(out / "cloudsurface.npz")["points"]
    back = read_point_set(tmp_path / "back.ply").points
    assert np.abs(back - pts).max() < 1e-9 * np.abs(pts).max()
    routes = json.loads((tmp_path / "moved.json").read_text())["routes"]
    assert routes["unroutable"] == 0 and routes["triangle"] > 0


def test_cloudsurface_curve_in_the_plane(tmp_path):
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    pts = np.column_stack([3 * np.cos(t), 1.5 * np.sin(t), np.zeros_like(t)])
    write_point_set(tmp_path / "ellipse.ply", pts)
    res = _run(
        ["cloudsurface", tmp_path / "ellipse.ply", tmp_path / "e", "--dim", "2", "--scale", "0.6"]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "e" / "report.json").read_text())
    assert summary["report"]["is_one_manifold"] and summary["report"]["is_closed"]
    assert (tmp_path / "e" / "complex.obj").read_text().count("\nl ") == 30


def test_user_errors_are_one_line(tmp_path):
    res = _run(["cloudsurface", "synth:sphere", tmp_path / "x"])
    assert res.exit_code == 1 and "exactly one of --scale" in res.output
    res = _run(["cloudsurface", "synth:sphere", tmp_path / "x", "--scale", "-1"])
    assert res.exit_code == 1 and "--scale must be a finite number > 0" in res.output
    res = _run(["cloudsurface", "synth:sphere", tmp_path / "x", "--search", "1", "0.5", "0.1"])
    assert res.exit_code == 1 and "--search SMAX" in res.output
    res = _run(["cloudsurface", "--from-mesh", "hand", tmp_path / "y", "--density", "eta9"])
    assert res.exit_code == 1 and "--density must be one of" in res.output
    res = _run(["deform", tmp_path, tmp_path / "n.ply", tmp_path / "o.ply"])
    assert res.exit_code == 1 and "no cloudsurface.npz" in res.output
    res = _run(["cloudsurface", "synth:sphere", tmp_path / "missing" / "deeper", "--scale", "1"])
    assert res.exit_code == 1 and "folder does not exist" in res.output


def test_cloudsurface_offsets_at_one_scale_find_the_planar_patch(tmp_path):
    from pointatlas.synth import plane_patch

    write_point_set(tmp_path / "plane.ply", plane_patch(65, 65, width=4.0, height=4.0).vertices)
    out = tmp_path / "p"
    res = _run(
        [
            "cloudsurface",
            tmp_path / "plane.ply",
            out,
            "--scale",
            "0.25",
            "--offsets",
            "24",
            "--accept",
            "open",
            "--no-render",
        ]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "report.json").read_text())
    assert summary["accepted"] and summary["offset"] > 0 and summary["report"]["genus"] == 0
    assert summary["report"]["n_boundary_loops"] == 1 and (out / "search.csv").exists()
    assert summary["offset_vector"] != [0.0, 0.0, 0.0]
    res = _run(
        [
            "cloudsurface",
            tmp_path / "plane.ply",
            tmp_path / "q",
            "--scale",
            "0.25",
            "--accept",
            "half",
        ]
    )
    assert res.exit_code == 1 and "--accept must be closed or open" in res.output


def test_from_mesh_defaults_are_valid_for_every_model(tmp_path):
    """eta2 needs c >= 1: its default is the thesis' c = 1 (Fig. 2.8), eta1's c = 0."""
    for model in ("eta1", "eta2", "eta3"):
        out = tmp_path / model
        res = runner.invoke(
            app, ["cloudsurface", "--from-mesh", "synth:cube", str(out), "--density", model]
        )
        assert res.exit_code == 0, res.output
        report = json.loads((out / "report.json").read_text())
        assert report["c"] == (1.0 if model == "eta2" else 0.0)
        assert report["complex_equals_mesh"]
