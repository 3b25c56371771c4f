"""One vocabulary (docs/decisions/cli.md): a renamed flag's old spelling still works
for one release, hidden from ``--help``, and says so in one line on stderr."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from pointatlas.cli import app

runner = CliRunner()

#: (command line before the flag, old spelling and value, new spelling)
RENAMED = [
    (["features", "hand", "{tmp}/f.ply", "--k", "8"], ["--weights", "equal"], "--weighting"),
    (["features", "hand", "{tmp}/f.ply", "--k", "8"], ["--normals"], "--estimate-normals"),
    (
        ["denoise", "hand", "{tmp}/d.ply", "--method", "flatness", "--n-iter", "1", "--k", "8"],
        ["--eta", "0.5"],
        "--plane-weight",
    ),
    (
        ["simplify", "synth:cube", "{tmp}/c.obj", "--vertices", "optimize"],
        ["--weight", "2"],
        "--vertex-weight",
    ),
    (["render", "{tmp}/cube.obj", "{tmp}/r.png"], ["--size", "200", "160"], "--render-size"),
    (
        ["cloudsurface", "{tmp}/cs", "--from-mesh", "cube", "--no-render"],
        ["--model", "eta3"],
        "--density",
    ),
    (
        ["cloudsurface", "{tmp}/cs", "--from-mesh", "cube", "--no-render"],
        ["--c", "0.5"],
        "--density-c",
    ),
    (
        ["cloudsurface", "{tmp}/cs", "--from-mesh", "cube", "--no-render", "--density", "eta3"],
        ["--c-v", "0.4"],
        "--density-c-v",
    ),
    (
        ["cloudsurface", "{tmp}/cs", "--from-mesh", "cube", "--no-render", "--density", "eta3"],
        ["--c-h", "0.4"],
        "--density-c-h",
    ),
    (
        ["cloudsurface", "{tmp}/cs", "--from-mesh", "cube", "--no-render"],
        ["--t", "0.3"],
        "--radius-position",
    ),
    (
        ["deform", "{tmp}/cs0", "{tmp}/cs0/complex.ply", "{tmp}/m.ply"],
        ["--points", "{tmp}/cs0/clouds.ply"],
        "--move",
    ),
]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("renamed")
    assert runner.invoke(app, ["data", "export", "cube", str(tmp / "cube.obj")]).exit_code == 0
    args = ["cloudsurface", str(tmp / "cs0"), "--from-mesh", "cube", "--no-render"]
    assert runner.invoke(app, args).exit_code == 0
    return tmp


def _words(words, tmp):
    return [w.format(tmp=tmp) for w in words]


@pytest.mark.parametrize(("before", "old", "new"), RENAMED, ids=[r[1][0] for r in RENAMED])
def test_old_spelling_works_with_a_one_line_notice_and_is_hidden(inputs, before, old, new):
    result = runner.invoke(app, _words(before + old, inputs))
    assert result.exit_code == 0, result.output
    notice = f"warning: {old[0]} is deprecated; use {new} (the old name goes in the next release)"
    assert notice in result.stderr.splitlines()
    help_text = runner.invoke(app, [before[0], "--help"]).stdout
    assert new in help_text
    assert f"{old[0]} " not in help_text.replace(new, "")


@pytest.mark.parametrize(("before", "old", "new"), RENAMED[:1], ids=["--weighting"])
def test_new_spelling_prints_no_notice(inputs, before, old, new):
    result = runner.invoke(app, _words(before + [new, *old[1:]], inputs))
    assert result.exit_code == 0, result.output
    assert "deprecated" not in result.stderr
