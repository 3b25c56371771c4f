"""The jobs below the commands (``pointatlas.cli.jobs``), called from Python as a
notebook would: the same files as the command, and one error for a tiled run where a
command has none."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pointatlas._core import PointAtlasError
from pointatlas.cli.jobs import (
    CloudSurfaceOptions,
    DeformOptions,
    InfoOptions,
    SimplifyOptions,
    run_cloudsurface,
    run_deform,
    run_info,
    run_simplify,
)
from pointatlas.io import read_point_set, write_point_set

from .helpers import run, sphere_points, write_unit_cube_obj


def test_info_job_gives_the_commands_json(tmp_path):
    path = tmp_path / "s.xyz"
    write_point_set(path, np.vstack([sphere_points(), [[5.0, 5.0, 5.0]]]))
    res = run("info", path, "--json", "--k", "4")
    assert res.exit_code == 0, res.output
    result = run_info(path, None, InfoOptions(k=4))
    assert json.loads(json.dumps(result.info)) == json.loads(res.stdout)
    assert result.info["points"] == 301 and result.info["knn_k"] == 4
    assert result.written == []


def test_simplify_job_writes_the_commands_mesh(tmp_path):
    cube = write_unit_cube_obj(tmp_path / "cube.obj")
    res = run("simplify", cube, tmp_path / "cli.obj")
    assert res.exit_code == 0, res.output
    result = run_simplify(cube, tmp_path / "job.obj", SimplifyOptions())
    assert (tmp_path / "job.obj").read_bytes() == (tmp_path / "cli.obj").read_bytes()
    assert result.written == [tmp_path / "job.obj"]
    assert result.how == "decimate (structure-aware)" and result.segmentation is None
    assert result.mesh.n_faces == 6  # the cube's six planar faces


def test_cloudsurface_and_deform_jobs_write_the_commands_files(tmp_path):
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    pts = np.column_stack([3 * np.cos(t), 1.5 * np.sin(t), np.zeros_like(t)])
    ellipse = write_point_set(tmp_path / "ellipse.ply", pts)
    res = run("cloudsurface", ellipse, tmp_path / "cli", "--dim", "2", "--scale", "0.6")
    assert res.exit_code == 0, res.output
    options = CloudSurfaceOptions(dim=2, scale=0.6)
    result = run_cloudsurface(ellipse, tmp_path / "job", options)
    for name in ("clouds.ply", "complex.obj", "report.txt"):
        assert (tmp_path / "job" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    assert result.written[-1] == tmp_path / "job" / "report.json"
    assert result.accepted and result.dim == 2 and result.n_clouds == 30

    # the complex's vertices moved: the same points from the job as from the command
    cloud_points = read_point_set(tmp_path / "job" / "complex.obj").points
    moved = write_point_set(tmp_path / "moved_cp.ply", cloud_points * 2.0)
    res = run("deform", tmp_path / "cli", moved, tmp_path / "cli_moved.ply")
    assert res.exit_code == 0, res.output
    result = run_deform(tmp_path / "job", tmp_path / "job_moved.ply", DeformOptions(moved))
    assert (tmp_path / "job_moved.ply").read_bytes() == (tmp_path / "cli_moved.ply").read_bytes()
    routes = result.routes
    assert result.n_points == 2000
    assert routes["triangle"] + routes["edge"] + routes["vertex"] + routes["unroutable"] == 2000
    assert result.written[-1] == tmp_path / "job_moved.json"


@pytest.mark.parametrize(
    ("job", "options", "name"),
    [
        (run_info, InfoOptions(), "info"),
        (run_simplify, SimplifyOptions(), "simplify"),
        (run_cloudsurface, CloudSurfaceOptions(scale=1.0), "cloudsurface"),
        (run_deform, DeformOptions("new.ply"), "deform"),
    ],
)
def test_a_job_without_a_tiled_branch_refuses_tiles(tmp_path, job, options, name):
    from pointatlas.batch import TileOptions

    with pytest.raises(PointAtlasError, match=f"{name} has no tiled run"):
        job(tmp_path / "in.ply", tmp_path / "out.ply", options, tiles=TileOptions(tile_size=1.0))
    assert list(tmp_path.iterdir()) == []
