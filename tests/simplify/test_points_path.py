"""The points path of `simplify`: connected regions and the per-region report (issue 14)."""

import json

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from pointatlas.neighbors import query_knn
from pointatlas.simplify import simplify_segmentation
from pointatlas.simplify._repair import split_disconnected
from pointatlas.synth import cube


def _n_pieces(labels, indices):
    """Connected pieces per region in the symmetric k-NN graph."""
    n = labels.size
    rows = np.repeat(np.arange(n), indices.shape[1] - 1)
    cols = indices[:, 1:].ravel()
    same = labels[rows] == labels[cols]
    g = sparse.csr_array((np.ones(int(same.sum())), (rows[same], cols[same])), shape=(n, n))
    comp = csgraph.connected_components(g, directed=False)[1]
    return np.array([np.unique(comp[labels == r]).size for r in range(labels.max() + 1)])


def _cube_with_far_piece(n_piece=3):
    """cube(8) labels where region 0 also owns a few points in the middle of face 5."""
    m = cube(8, size=2.0)
    lab = m.labels.copy()
    f5 = np.flatnonzero(lab == 5)
    c = m.vertices[f5].mean(axis=0)
    near = f5[np.argsort(np.linalg.norm(m.vertices[f5] - c, axis=1), kind="stable")[:n_piece]]
    lab[near] = 0
    return m, lab, near


def test_split_disconnected_keeps_connected_labels_and_splits_pieces():
    m, lab, near = _cube_with_far_piece()
    idx, _ = query_knn(m.vertices, 8)
    assert _n_pieces(lab, idx)[0] == 2
    assert np.array_equal(split_disconnected(m.labels, idx), m.labels)
    out = split_disconnected(lab, idx)
    assert out.dtype == np.int64 and out.shape == lab.shape
    assert (_n_pieces(out, idx) == 1).all()
    # the largest piece keeps id 0, the far piece gets the next free id
    assert set(out[near]) == {6}
    assert np.array_equal(out[lab != 0], lab[lab != 0])


def test_disconnected_region_is_split_and_its_small_piece_absorbed():
    m, lab, near = _cube_with_far_piece()
    idx, _ = query_knn(m.vertices, 8)
    s = simplify_segmentation(m.vertices, m.normals, lab, smooth=0)
    assert s.n_faces == 6 and s.is_closed and s.is_manifold and s.is_oriented
    assert s.face_ok.all()
    # every region fed to the complex is connected; the piece went to face 5
    assert (_n_pieces(s.labels, idx) == 1).all()
    assert len(set(s.labels[near])) == 1
    assert s.labels[near[0]] == s.region_map[5]
    rep = s.regions_report
    assert [r["region"] for r in rep] == list(range(6))
    assert all(r["became_face"] for r in rep)
    assert rep[0]["n_points"] == int((lab == 0).sum())
    assert "input regions [0]" in rep[5]["reason"]


def test_deterministic_under_repeats():
    m, lab, _ = _cube_with_far_piece(5)
    a = simplify_segmentation(m.vertices, m.normals, lab, smooth=0)
    b = simplify_segmentation(m.vertices, m.normals, lab, smooth=0)
    assert np.array_equal(a.labels, b.labels) and a.regions_report == b.regions_report


def test_thin_strip_along_an_edge_is_absorbed_without_losing_faces():
    m = cube(8, size=2.0)
    p = m.vertices
    lab = m.labels.copy()
    strip = np.abs(p[:, 0] - 1) + np.abs(p[:, 1] - 1) < 0.3  # 3 points wide, one edge
    lab[strip] = 6
    s = simplify_segmentation(p, m.normals, lab)
    assert s.n_faces == 6 and s.is_closed and s.is_manifold and s.is_oriented
    assert s.face_ok.all()
    rep = s.regions_report
    assert [r["became_face"] for r in rep] == [True] * 6 + [False]
    assert rep[6]["n_points"] == int(strip.sum())
    assert rep[6]["reason"].startswith("merged into a neighbour")
    assert rep[6]["final_region"] in s.face_region


def test_regions_report_is_in_the_json_summary():
    m = cube(6)
    s = simplify_segmentation(m.vertices, m.normals, m.labels)
    rep = json.loads(json.dumps(s.summary()))["regions_report"]
    assert len(rep) == 6
    assert set(rep[0]) == {"region", "n_points", "became_face", "final_region", "reason"}
    assert all(r["became_face"] and r["reason"] == "face" for r in rep)
    assert sum(r["n_points"] for r in rep) == m.vertices.shape[0]
