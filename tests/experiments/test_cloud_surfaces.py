"""Chapter A (``pointatlas experiment cloudsurfaces``): every figure and its numbers."""

import json

from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.cli._cmd_experiment import _SIMPLIFY_CASES
from pointatlas.experiments.cloud_surfaces import FIGURES
from pointatlas.experiments.simplify_cases import CASES

runner = CliRunner()


def _run(args):
    return runner.invoke(app, [str(a) for a in args])


def test_experiment_cloudsurfaces_writes_every_figure_and_the_routed_shares(tmp_path):
    res = _run(["experiment", "cloudsurfaces", "--out", tmp_path / "e"])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "e" / "summary.json").read_text())
    names = {f["path"] for f in summary["files"]}
    assert names == {*FIGURES, "cloudsurfaces.csv"}
    assert summary["routed_share"]["2.20"] == 1.0
    assert summary["routed_share"]["2.21"] >= 0.998
    rows = {(r["figure"], r["quantity"]): r["ours"] for r in summary["rows"]}
    assert rows[("2.2", "eta1 delta_h at pi + alpha/2, c = 1")] == 0.5  # c / (c + 1)
    assert rows[("2.2", "eta2 delta_h at pi + alpha/2, c = 2")] == round(1 / 3, 6)
    crossing = rows[("2.14", "vertices of degree != 2 (the crossing at 0) / chi")]
    assert crossing == "1 (degree 4) / -1"
    assert all(
        r["ours"].split(" / ")[1] == "True" for r in summary["rows"] if r["figure"] == "2.9"
    )  # the complex equals the cube mesh
    sph = rows[("2.17", "noisy sphere: chosen s / clouds / closed / chi / genus")]
    assert sph.split(" / ")[2:] == ["True", "2", "0"]


def test_the_cli_lists_every_simplify_case():
    assert _SIMPLIFY_CASES == tuple(CASES)
