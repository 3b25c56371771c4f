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
def test_old_spelling_says_so_in_one_line_and_is_hidden(inputs, before, old, new):
    # OUT's folder does not exist: the command stops right after reading its flags
    words = [
        w.replace("{tmp}/", "{tmp}/missing/", 1) if w.startswith("{tmp}/") and i == 2 else w
        for i, w in enumerate(before)
    ]
    result = runner.invoke(app, _words(words + old, inputs))
    notice = f"warning: {old[0]} is deprecated; use {new} (the old name goes in the next release)"
    assert result.stderr.splitlines()[0] == notice, result.output
    help_text = runner.invoke(app, [before[0], "--help"]).stdout
    assert new in help_text
    assert f"{old[0]} " not in help_text.replace(new, "")


def test_old_spelling_gives_the_new_ones_value(inputs):
    old = runner.invoke(app, _words(RENAMED[0][0] + ["--weights", "equal"], inputs))
    assert old.exit_code == 0, old.output
    first = (inputs / "f.ply").read_bytes()
    new = runner.invoke(app, _words(RENAMED[0][0] + ["--weighting", "equal"], inputs))
    assert new.exit_code == 0, new.output
    assert "deprecated" not in new.stderr
    assert (inputs / "f.ply").read_bytes() == first
