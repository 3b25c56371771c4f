"""Table 4.1 / Fig. 4.5 (``pointatlas experiment vsa``): per model, aggregate, outputs."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.experiments._stats import describe
from pointatlas.experiments.table_4_1 import COLUMNS, aggregate_vsa, table_markdown, vsa_model

runner = CliRunner()
DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data"
needs_shared = pytest.mark.skipif(
    not (DATA / "models" / "bar_386.obj").is_file(),
    reason="needs ../shared/data/models/bar_386.obj (the shared data folder)",
)


@needs_shared
def test_experiment_model_and_table():
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


def test_describe_matches_numpy():
    v = np.random.default_rng(3).random(17)
    s = describe(v)
    assert s == {
        "min": float(v.min()),
        "max": float(v.max()),
        "avg": float(v.mean()),
        "sd": float(v.std(ddof=1)),
        "n": 17,
    }
    assert describe([2.0])["sd"] == 0.0
    assert describe([])["avg"] is None


def test_experiment_vsa_on_an_obj_without_faces_says_what_is_missing(tmp_path):
    src = tmp_path / "pts.obj"
    src.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n")
    with pytest.raises(Exception, match="needs normals"):
        vsa_model(str(src), np.random.default_rng(0))


@needs_shared
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
