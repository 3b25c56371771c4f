"""``pointatlas segment``, its demo step and ``pointatlas experiment vsa``."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.cli._exp_vsa import COLUMNS, aggregate_vsa, table_markdown, vsa_model
from pointatlas.io import read_point_set, write_point_set
from pointatlas.synth import cube

DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data"
runner = CliRunner()


@pytest.fixture
def cube_file(tmp_path):
    mesh = cube(4)
    path = tmp_path / "cube.ply"
    write_point_set(path, mesh.vertices, normals=mesh.normals)
    return path


def test_segment_writes_labels_colours_and_tables(cube_file, tmp_path):
    out = tmp_path / "seg.ply"
    png = tmp_path / "seg.png"
    result = runner.invoke(
        app, ["segment", str(cube_file), str(out), "--eta", "10", "--render", str(png)]
    )
    assert result.exit_code == 0, result.output
    ps = read_point_set(out)
    labels = np.asarray(ps.attributes["label"])
    assert labels.shape == (ps.n_points,) and labels.min() == 0
    assert "colors" in ps.attributes
    with (tmp_path / "seg_regions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == labels.max() + 1
    assert sum(int(r["n_points"]) for r in rows) == ps.n_points
    payload = json.loads((tmp_path / "seg_regions.json").read_text())
    assert payload["summary"]["n_regions"] == len(rows)
    assert payload["summary"]["converged"] is True
    assert png.stat().st_size > 0


def test_segment_region_growing_and_options(cube_file, tmp_path):
    out = tmp_path / "rg.ply"
    result = runner.invoke(
        app,
        ["segment", str(cube_file), str(out), "--method", "region-growing"]
        + ["--smoothness-deg", "10", "--min-cluster-size", "5"],
    )
    assert result.exit_code == 0, result.output
    labels = np.asarray(read_point_set(out).attributes["label"])
    assert labels.max() + 1 == 6 and (labels < 0).any()
    out2 = tmp_path / "fixed.ply"
    result = runner.invoke(
        app,
        ["segment", str(cube_file), str(out2), "--seeds", "6", "--no-split", "--no-merge"]
        + ["--switch", "single", "--max-angle", "20"],
    )
    assert result.exit_code == 0, result.output


def test_segment_estimates_normals_when_the_input_has_none(tmp_path):
    mesh = cube(4)
    raw = tmp_path / "raw.xyz"
    write_point_set(raw, mesh.vertices)
    result = runner.invoke(
        app, ["segment", str(raw), str(tmp_path / "o.ply"), "--no-estimate-normals"]
    )
    assert result.exit_code == 1
    assert "--no-estimate-normals" in result.output
    result = runner.invoke(app, ["segment", str(raw), str(tmp_path / "o.ply"), "--eta", "5"])
    assert result.exit_code == 0, result.output
    assert "estimating normals" in result.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--seeds", "many"], "--seeds"),
        (["--switch", "fast"], "--switch"),
        (["--method", "magic"], "--method"),
        (["--eta", "1", "--max-angle", "5"], "not both"),
    ],
)
def test_segment_bad_options(cube_file, tmp_path, args, message):
    result = runner.invoke(app, ["segment", str(cube_file), str(tmp_path / "o.ply"), *args])
    assert result.exit_code == 1
    assert message in result.output


def test_demo_step_registered():
    from pointatlas.cli._app import DEMO_STEPS
    from pointatlas.cli._cmd_segment import demo_segment

    assert demo_segment in DEMO_STEPS


def test_experiment_model_and_table(tmp_path):
    model = DATA / "models" / "bar_386.obj"
    res = vsa_model(str(model), np.random.default_rng(0))
    for col in COLUMNS:
        assert sum(res[col]["sizes"]) == res["n_points"]
        assert res[col]["m"] == len(res[col]["sizes"]) >= 1
    assert res["no_sm"]["stop_reason"] in ("converged", "cycle", "max_iter")
    summary = aggregate_vsa({"bar": res, "bar2": res})
    assert summary["n_models"] == 2
    assert (
        summary["table_4_1"]["all"]["columns"]["global_eta_sm"]["m"]["avg"]
        == (res["global_eta_sm"]["m"])
    )
    assert "| avg MSE |" in table_markdown(summary)


@pytest.mark.slow
def test_experiment_command(tmp_path):
    models = tmp_path / "models"
    models.mkdir()
    for name in ("bar_386.obj", "cube_26.obj"):
        shutil.copy(DATA / "models" / name, models / name)
    out = tmp_path / "out"
    result = runner.invoke(
        app, ["experiment", "vsa", "--models", str(models), "--out", str(out), "--workers", "1"]
    )
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "table_4_1.json").read_text())
    assert summary["n_failed"] == 0 and summary["n_models"] == 2
    assert (out / "fig_4_5.png").stat().st_size > 0
