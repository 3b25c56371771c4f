"""Tables 5.1/5.2 and Figs. 5.4-6.8 (``pointatlas experiment neighbourhoods``)."""

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.experiments._stats import moments, pooled
from pointatlas.experiments.neighborhoods import (
    aggregate_neighborhoods,
    decrease_cases,
    energy_histogram,
    neighborhood_model,
    write_neighborhood_outputs,
)
from pointatlas.features import THESIS_ANGLE_GRID, optimal_neighborhood
from pointatlas.io import write_mesh
from pointatlas.neighbors import query_knn
from pointatlas.synth import cube, torus
from tests.features import reference as ref
from tests.features.test_optimal import _noisy_surface


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    for name, m in (("cube", cube(4)), ("torus", torus(n_major=20, n_minor=8))):
        write_mesh(d / f"{name}.obj", m.vertices, m.faces)
    return d


def test_energy_histogram_bins():
    h = energy_histogram([0.0, 0.05, 0.5, 0.99, 1.0, 2.0, np.nan])
    # normalised by the max (2.0): 0, .025, .25, .495, .5, 1.0
    assert h.tolist() == [2, 0, 1, 0, 1, 1, 0, 0, 0, 0, 1]
    assert energy_histogram([]).sum() == 0


# ~4 s with the numba cache warm; on a fresh checkout it is the first test to call the
# features search and pays its JIT compile (45 s to minutes on a busy 2-core box)
@pytest.mark.slow
def test_model_and_aggregate(models, tmp_path):
    rng = np.random.default_rng(0)
    res = {p.stem: neighborhood_model(str(p), rng) for p in sorted(models.iterdir())}
    json.dumps(res)  # JSON-serialisable, as the batch runner needs
    cube_res = res["cube"]
    assert cube_res["n_points"] == 6 * 16 + 2
    hist = np.asarray(cube_res["pair_k_histogram"])
    assert hist.shape == (28, 15) and hist.sum() == cube_res["n_points"]
    assert sum(cube_res["a_cases"]) == cube_res["n_points"]
    summary = aggregate_neighborhoods(res)
    t1 = summary["table_5_1"]
    assert t1["optimal"]["n"] == summary["n_points"]
    # Table 5.1's direction: the optimal weights lower the mean classification error
    assert t1["optimal"]["mean"] < t1["equal"]["mean"]
    assert t1["optimal"]["min"] >= 0
    t2 = summary["table_5_2"]
    assert t2["a=0"] + t2["a-"] + t2["not a-"] == pytest.approx(100)
    assert t2["b=a"] + t2["b-"] + t2["not b-"] == pytest.approx(100)
    assert sum(summary["k_histogram_percent"]) == pytest.approx(100)
    written = write_neighborhood_outputs(summary, tmp_path, label="test")
    names = {p.name for p in written}
    for n in (
        "table_5_1.csv",
        "table_5_2.csv",
        "fig5_4.png",
        "fig5_5.png",
        "fig5_6.png",
        "fig6_3.png",
        "fig6_6.png",
        "neighbourhoods.json",
    ):
        assert n in names
    rows = (tmp_path / "table_5_1.csv").read_text().splitlines()
    assert rows[0].startswith("collection,weights") and len(rows) == 3


@pytest.mark.slow
def test_command_runs_through_the_batch_runner(models, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(
        app,
        [
            "experiment",
            "neighbourhoods",
            "--models",
            str(models),
            "--out",
            str(out),
            "--workers",
            "1",
            "--no-dodecahedron",
        ],
    )
    assert res.exit_code == 0, res.output
    assert "Table 5.1" in res.output and "Table 5.2" in res.output
    assert (out / "results" / "cube.json").exists() and (out / "fig5_4.png").exists()
    bad = CliRunner().invoke(app, ["experiment", "neighbourhoods", "--models", str(tmp_path / "x")])
    assert bad.exit_code == 1 and "must be a folder" in bad.output


def test_decrease_cases_match_direct_checks():
    pts, nrm = _noisy_surface(3, n=40)
    res = optimal_neighborhood(pts, nrm)
    a_case, b_case = decrease_cases(pts, nrm, res)
    grid = np.array(THESIS_ANGLE_GRID)
    idx = query_knn(pts, 20)[0]
    for i in range(40):
        a, b, k = res.a[i], res.b[i], int(res.k[i])
        ia = int(np.argmin(np.abs(grid - a)))
        if ia == 0:
            assert a_case[i] == 0
        else:
            code = ref.point_features(pts, nrm, idx[i], k, grid[ia - 1], b)[0]
            assert a_case[i] == (1 if code == 0 else 2)
        ib = int(np.argmin(np.abs(grid - b)))
        if b == a:
            assert b_case[i] == 0
        else:
            code = ref.point_features(pts, nrm, idx[i], k, a, grid[ib - 1])[0]
            assert b_case[i] == (1 if code == 0 else 2)


def test_angle_grid_nan_in_decrease_cases():
    rng = np.random.default_rng(5)
    pts = rng.random((40, 3)) * [1.0, 1.0, 0.1]
    nrm = np.tile([0.0, 0.0, 1.0], (40, 1)) + rng.normal(scale=0.2, size=(40, 3))
    res = optimal_neighborhood(pts, nrm, k_range=(6, 8))
    with pytest.raises(ValueError, match=r"^a_grid must hold finite angles .*; got nan$"):
        decrease_cases(pts, nrm, res, a_grid=[0.0, math.nan, math.pi])


def test_pooled_statistics_match_the_concatenated_sample():
    rng = np.random.default_rng(1)
    parts = [rng.random(n) for n in (5, 1, 9)]
    both = np.concatenate(parts)
    s = pooled([moments(p) for p in [*parts, [math.nan]]])
    assert s["n"] == 15 and s["min"] == both.min() and s["max"] == both.max()
    assert s["mean"] == pytest.approx(both.mean(), rel=1e-12)
    assert s["sd"] == pytest.approx(both.std(ddof=1), rel=1e-9)
    assert pooled([moments([])])["mean"] is None
