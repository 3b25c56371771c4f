"""Shared helpers of the CLI tests: invoke the app, check a user error, test data."""

from __future__ import annotations

import numpy as np
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.io import write_mesh

runner = CliRunner()


def run(*args, **kw):
    """Invoke ``pointatlas`` in process with ``args`` (paths become strings)."""
    return runner.invoke(app, [str(a) for a in args], **kw)


def assert_user_error(result, *fragments):
    """Exit 1, one line on stderr, no traceback."""
    assert result.exit_code == 1, result.output
    text = result.stderr.strip()
    assert len(text.splitlines()) == 1, text
    assert "Traceback" not in result.output
    assert text.startswith("error:")
    for fragment in fragments:
        assert fragment in text, text


def sphere_points(n=300, seed=0):
    """``n`` seeded points on the unit sphere (they are their own exact normals)."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def write_unit_cube_obj(path):
    """The unit cube as a quad mesh (polygon faces), written to ``path``."""
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    write_mesh(path, v, faces)
    return path
