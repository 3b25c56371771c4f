"""Clouds from a mesh (Algorithm 1) and the density models of Examples 3-4."""

import math

import numpy as np
import pytest

from pointatlas import data
from pointatlas.complex import cloud_complex, surface_report
from pointatlas.synth import clouds_from_mesh, cube, sphere_density, torus, vertex_curvature


@pytest.mark.parametrize(
    ("name", "model", "kw"),
    [
        ("synth:cube", "eta1", {"c": 0.0}),  # Fig. 2.7: cube, linear model, c = 0
        ("hand", "eta2", {"c": 1.0}),  # Fig. 2.8: hand (open wrist), trigonometric, c = 1
        ("synth:cube", "eta3", {"curvature": "gaussian"}),  # Fig. 2.9 b
        ("synth:cube", "eta3", {"curvature": "mean"}),  # Fig. 2.9 c
    ],
)
def test_complex_of_generated_clouds_equals_the_mesh(name, model, kw):
    m = data.load_mesh(name)
    mc = clouds_from_mesh(m.vertices, m.triangles, model=model, n_samples=5, rng=0, **kw)
    K = cloud_complex(mc.clouds, mc.points, cloud_points=mc.cloud_points)
    tri = np.unique(np.sort(m.triangles, axis=1), axis=0)
    pairs = np.concatenate([tri[:, :2], tri[:, 1:], tri[:, ::2]])
    edges = np.unique(np.sort(pairs, axis=1), axis=0)
    assert np.array_equal(K.triangles, tri) and np.array_equal(K.edges, edges)
    assert K.dimension == 2 and K.empty_clouds.size == 0
    r = surface_report(K)
    assert r.is_cloud_surface
    if name == "hand":
        assert not r.is_closed and r.n_boundary_loops == 1 and r.genus == 0
    else:
        assert r.is_closed and r.euler_characteristic == 2


def test_samples_lie_in_their_ball_and_barycentres_in_three_clouds():
    m = torus(n_major=16, n_minor=8)
    mc = clouds_from_mesh(m.vertices, m.faces, model="eta3", n_samples=8, rng=1)
    F = m.faces.shape[0]
    bary = m.vertices[m.faces].mean(axis=1)
    np.testing.assert_allclose(mc.points[:F], bary)
    smp = np.arange(F, mc.points.shape[0])
    f, v = mc.source_face[smp], mc.source_vertex[smp]
    k = np.argmax(m.faces[f] == v[:, None], axis=1)
    d = np.linalg.norm(mc.points[smp] - m.vertices[v], axis=1)
    assert (d <= mc.radius[f, k] * (1 + 1e-12)).all()
    # Eq. 2.1: |v - b| <= R < min edge at v
    vb = np.linalg.norm(m.vertices[m.faces] - bary[:, None], axis=2)
    assert (mc.radius >= vb - 1e-12).all()
    counts = np.bincount(mc.cloud_members, minlength=mc.points.shape[0])
    assert (counts[:F] == 3).all() and counts.max() <= 3


def test_same_seed_same_clouds():
    m = cube(4)
    a = clouds_from_mesh(m.vertices, m.faces, model="eta2", c=2.0, rng=5)
    b = clouds_from_mesh(m.vertices, m.faces, model="eta2", c=2.0, rng=5)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.cloud_members, b.cloud_members)


def test_density_models_follow_the_guide():
    alpha = math.pi / 3
    R = 1.0
    # inside the sector, in the plane: delta_h = delta_v = 1 (eta1, eta2)
    inside = np.array([[0.5 * math.cos(alpha / 2), 0.5 * math.sin(alpha / 2), 0.0]])
    for model, c in (("eta1", 0.0), ("eta2", 1.0)):
        assert sphere_density(model, inside, alpha, R, c=c)[0] == pytest.approx(1.0)
    # opposite direction alpha/2 + pi in the plane: d = pi - alpha/2
    opp = -inside
    assert sphere_density("eta1", opp, alpha, R, c=0.0)[0] == pytest.approx(0.0, abs=1e-12)
    assert sphere_density("eta1", opp, alpha, R, c=1.0)[0] == pytest.approx(0.5)
    assert sphere_density("eta2", opp, alpha, R, c=1.0)[0] == pytest.approx(0.0, abs=1e-12)
    assert sphere_density("eta2", opp, alpha, R, c=3.0)[0] == pytest.approx(0.5)
    # eta3: 1 inside the cone, c_v at the opposite direction, linear in r to c_h at R
    assert sphere_density("eta3", inside, alpha, R, c_h=0.0)[0] == pytest.approx(0.5)
    far = opp / np.linalg.norm(opp)
    assert sphere_density("eta3", far, alpha, R, c_v=0.25, c_h=1.0)[0] == pytest.approx(0.25)
    up = np.array([[0.0, 0.0, 0.3]])
    assert sphere_density("eta1", up, alpha, R)[0] == pytest.approx(0.0)


def test_curvature_of_a_sphere_and_a_cube():
    from pointatlas.synth import icosphere

    m = icosphere(3)
    k = vertex_curvature(m.vertices, m.faces, "gaussian")
    h = vertex_curvature(m.vertices, m.faces, "mean")
    assert np.allclose(k, 1.0, atol=0.2) and np.allclose(h, 1.0, atol=0.2)
    c = cube(4)
    kc = vertex_curvature(c.vertices, c.faces, "gaussian")
    # angle defect: pi/2 at each of the 8 corners, 0 elsewhere
    defect = kc * np.bincount(c.faces.ravel(), minlength=c.vertices.shape[0])
    assert (np.abs(kc) > 1e-6).sum() == 8 and np.isfinite(defect).all()


def test_bad_input_messages():
    m = cube(2)
    with pytest.raises(ValueError, match="model must be one of"):
        clouds_from_mesh(m.vertices, m.faces, model="eta4")
    with pytest.raises(ValueError, match=r"t must be a finite number in \[0, 1\)"):
        clouds_from_mesh(m.vertices, m.faces, t=1.0)
    with pytest.raises(ValueError, match="eta2 needs c >= 1"):
        clouds_from_mesh(m.vertices, m.faces, model="eta2", c=0.5)
    with pytest.raises(ValueError, match="degenerate triangles"):
        clouds_from_mesh(np.zeros((3, 3)), [[0, 1, 2]])
    with pytest.raises(ValueError, match=r"faces must have shape \(F, 3\)"):
        clouds_from_mesh(m.vertices, [0, 1, 2])
