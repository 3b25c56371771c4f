"""The README's Python tour runs as written (in a temporary folder)."""

import pathlib
import re

README = pathlib.Path(__file__).resolve().parent.parent / "README.md"


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
