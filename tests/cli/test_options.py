"""Every numeric option of every command: a bad value is one clear line, never a run.

Item 9 of the hardening issue: NaN, infinities, values out of range and k beyond
the number of points are refused (exit 1, one line naming the option or its
parameter; or typer's usage error, exit 2), the same way as the Python API does.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from pointatlas import data
from pointatlas.cli import app

runner = CliRunner()
MODEL = "synth:cube"

# (command, extra arguments before the bad option, option, bad value, a word the message holds)
CASES = [
    ("segment", [], "--eta", "nan", "eta"),
    ("segment", [], "--eta", "inf", "eta"),
    ("segment", [], "--eta", "-1", "eta"),
    ("segment", [], "--max-angle-deg", "nan", "--max-angle-deg"),
    ("segment", [], "--max-angle-deg", "181", "--max-angle-deg"),
    ("segment", [], "--k", "0", "k"),
    ("segment", [], "--k", "100000", "k"),
    ("segment", [], "--seeds", "0", "--seeds"),
    ("segment", [], "--seeds", "100000", "seeds"),
    ("segment", ["--method", "region-growing"], "--smoothness-deg", "nan", "--smoothness-deg"),
    ("segment", ["--method", "region-growing"], "--curvature-threshold", "nan", "curvature"),
    ("segment", ["--method", "region-growing"], "--min-cluster-size", "0", "min_cluster_size"),
    ("segment", ["--estimate-normals"], "--normal-k", "2", "k"),
    ("segment", ["--estimate-normals"], "--normal-k", "100000", "k"),
    ("simplify", [], "--k", "0", "k"),
    ("simplify", [], "--k", "100000", "k"),
    ("simplify", [], "--eta", "nan", "eta"),
    ("simplify", [], "--max-angle-deg", "nan", "--max-angle-deg"),
    ("simplify", [], "--normal-k", "2", "k"),
    ("features", [], "--k", "100000", "k"),
    ("features", [], "--a-grid-deg", "nan", "--a-grid-deg"),
    ("features", [], "--b-grid-deg", "0,200", "--b-grid-deg"),
    ("features", [], "--flatness", "3 3", "flatness"),
    ("features", [], "--k-range", "9 4", "k_range"),
    ("normals", [], "--k", "2", "k"),
    ("normals", [], "--k", "100000", "k"),
    ("normals", [], "--orient-k", "1", "orient-k"),
    ("render", [], "--azimuth-deg", "nan", "azimuth"),
    ("render", [], "--elevation-deg", "91", "elevation"),
    ("render", [], "--render-size", "0 0", "size"),
    ("info", [], "--k", "1", "k"),
]

OUT = {
    "segment": "s.ply",
    "simplify": "s.obj",
    "features": "f.ply",
    "normals": "n.ply",
    "render": "r.png",
}


def _model_file(tmp_path):
    path = tmp_path / "cube.ply"
    if not path.exists():
        from pointatlas.io import write_point_set

        write_point_set(path, data.load(MODEL))
    return path


@pytest.mark.parametrize(
    ("command", "extra", "option", "value", "word"),
    CASES,
    ids=[f"{c}{''.join(e)}{o}={v}" for c, e, o, v, _ in CASES],
)
def test_bad_numeric_option_is_one_clear_line(tmp_path, command, extra, option, value, word):
    src = _model_file(tmp_path)
    args = [command, str(src)]
    if command in OUT:
        args.append(str(tmp_path / OUT[command]))
    args += [*extra, option, *value.split()]
    result = runner.invoke(app, args)
    assert result.exit_code in (1, 2), result.output
    assert "Traceback" not in result.output
    if result.exit_code == 1:
        text = result.stderr.strip()
        assert len(text.splitlines()) == 1, text
        assert word.lstrip("-") in text, text
    for name in OUT.values():
        assert not (tmp_path / name).exists()
