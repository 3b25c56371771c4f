"""``simplify_points(path="auto")``: the robust path at once where the thesis attempt
is not kept (more than `AUTO_THESIS_REGIONS` regions), the thesis' own cases still
on the thesis path."""

from __future__ import annotations

import numpy as np
import pytest

import pointatlas.simplify._pipeline as pipeline
from pointatlas import data
from pointatlas.simplify import simplify_points
from pointatlas.synth import sphere


def _no_thesis(*args, **kwargs):
    raise AssertionError("the thesis path was tried")


def test_many_regions_go_to_the_robust_path_at_once(monkeypatch):
    m = sphere(3000)
    p, n = np.asarray(m.vertices), np.asarray(m.normals)
    # 2 x 100 regions: the two hemispheres cut into 100 longitude wedges each
    wedge = np.floor((np.arctan2(p[:, 1], p[:, 0]) + np.pi) / (2 * np.pi) * 100).astype(int)
    labels = np.minimum(wedge, 99) + 100 * (p[:, 2] > 0)
    n_regions = np.unique(labels).size
    assert n_regions > pipeline.AUTO_THESIS_REGIONS
    monkeypatch.setattr(pipeline, "simplify_segmentation", _no_thesis)
    r = simplify_points(p, n, labels=labels)
    assert r.path == "robust"
    assert r.reason == (
        f"{n_regions} regions: the thesis path is tried up to "
        f"{pipeline.AUTO_THESIS_REGIONS} (path='thesis' forces it)"
    )
    assert r.mesh.is_closed
    # path="thesis" still tries it
    with pytest.raises(AssertionError, match="thesis path was tried"):
        simplify_points(p, n, labels=labels, path="thesis")


@pytest.mark.parametrize(
    ("name", "settings", "n_faces"),
    [("synth:octahedron", {}, 8), ("fandisk", {"eta": 20.0}, None)],
    ids=["octahedron", "fandisk-demo"],
)
def test_the_thesis_cases_keep_the_thesis_mesh(name, settings, n_faces):
    """The bundled octahedron and the demo's fandisk (VSA eta = 20, `DEMO_ETA`) stay
    below both limits and keep the thesis mesh: closed, planar faces."""
    ps = data.load(name)
    r = simplify_points(ps.points, ps.normals, **settings)
    assert r.path == "thesis" and r.reason == ""
    assert int(np.max(r.segmentation.labels)) + 1 <= pipeline.AUTO_THESIS_REGIONS
    m = r.mesh
    assert m.is_closed and m.is_manifold and m.is_oriented
    assert m.planarity_error.max() < 1e-9
    if n_faces is not None:
        assert m.n_faces == n_faces
