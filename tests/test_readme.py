"""The README's tours run as written (in a temporary folder).

- the Python blocks (```python) run as one script;
- every ``pointatlas ...`` line of the shell blocks (```bash / ```console / ```sh)
  runs in order, in process, through typer's CliRunner, and must exit 0. ``make``
  lines are the Makefile's targets (CI runs them itself); any other shell command
  fails the test, so the README cannot show a line this test does not run. A line
  naming ``../shared`` (the shared data beside the repository) runs on that folder
  and is skipped, with the reason, only when the folder is absent.
"""

import pathlib
import re
import shlex

import pytest
from typer.testing import CliRunner

REPO = pathlib.Path(__file__).resolve().parent.parent
README = REPO / "README.md"
SHARED = REPO.parent / "shared"


def test_readme_python_tour_runs(tmp_path, monkeypatch):
    text = README.read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README has no python block"
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile("\n".join(blocks), str(README), "exec"), namespace)  # noqa: S102
    assert (tmp_path / "fandisk.obj").stat().st_size > 0
    assert (tmp_path / "features.ply").stat().st_size > 0
    seg = namespace["seg"]
    assert seg.converged and seg.labels.min() == 0
    # what the tour's comments say of its results
    mesh, dec, part = namespace["mesh"], namespace["dec"], namespace["part"]
    assert mesh.is_closed and mesh.is_oriented and mesh.planarity_error.max() < 1e-12
    assert dec.is_closed and dec.summary()["hausdorff"] <= 0.005 * (1 + 1e-9) * _diagonal(
        namespace["tri"]
    )
    assert (part.is_closed, part.is_manifold, part.euler_characteristic) == (True, True, 2)
    assert abs(part.n_faces - 30) <= 2


def _diagonal(mesh) -> float:
    v = mesh.vertices
    return float(((v.max(axis=0) - v.min(axis=0)) ** 2).sum() ** 0.5)


def readme_shell_lines(text: str) -> list[list[str]]:
    """The words of every command line of the README's shell blocks, in order."""
    lines = []
    for block in re.findall(r"```(?:bash|console|sh)\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            line = line.strip()
            if line.startswith("$ "):
                line = line[2:]
            words = shlex.split(line, comments=True)
            if words:
                lines.append(words)
    return lines


def test_readme_shell_lines_are_parsed():
    words = readme_shell_lines(
        "```bash\n$ pointatlas info a.ply   # c\n\nmake demo\n```\n```text\nno\n```\n"
    )
    assert words == [["pointatlas", "info", "a.ply"], ["make", "demo"]]


def test_readme_cli_tour_runs(tmp_path, monkeypatch):
    from pointatlas.cli import app

    commands = readme_shell_lines(README.read_text())
    assert any(w[0] == "pointatlas" for w in commands), "README has no pointatlas line"
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    skipped = []
    for words in commands:
        if words[0] == "make":
            continue
        assert words[0] == "pointatlas", f"README shell line this test cannot run: {words}"
        args = [
            str(SHARED) + a[len("../shared") :] if a.startswith("../shared") else a
            for a in words[1:]
        ]
        if any(a.startswith("../shared") for a in words[1:]) and not SHARED.is_dir():
            skipped.append(" ".join(words))
            continue
        result = runner.invoke(app, args)
        assert result.exit_code == 0, f"{' '.join(words)}\n{result.output}"
    assert (tmp_path / "seg.png").stat().st_size > 0
    assert (tmp_path / "demo-output" / "report.html").stat().st_size > 0
    if skipped:
        pytest.skip(f"needs the shared data folder {SHARED} (absent): {skipped}")
