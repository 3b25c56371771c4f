"""One vocabulary in the public API: American spelling, ``neighbors=`` for a neighbour table.

Each former name (a British spelling, or ``indices=`` for the neighbour table) still
works as a deprecated alias: it gives the same result as the new name and warns once
per call, naming the new name (issue 29 item 2). The walk at the end fails on a
British spelling in a public name or keyword that is not one of these aliases.
"""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.neighbors import query_knn
from pointatlas.synth import cube


def _warns_naming(new: str):
    return pytest.warns(DeprecationWarning, match=rf"is deprecated; use {new}")


# ---------------------------------------------------------------- former keyword names


def test_surface_complex_indices_is_the_former_neighbors():
    from pointatlas.complex import surface_complex

    m = cube(4)
    idx, _ = query_knn(m.vertices, 8)
    new = surface_complex(m.vertices, m.labels, k=8, neighbors=idx)
    with _warns_naming(r"surface_complex\(neighbors=\)"):
        old = surface_complex(m.vertices, m.labels, k=8, indices=idx)
    assert old.q_tuples == new.q_tuples
    np.testing.assert_array_equal(old.edges, new.edges)
    assert old.vertex_regions == new.vertex_regions


def test_simplify_segmentation_indices_is_the_former_neighbors():
    from pointatlas.simplify import simplify_segmentation

    m = cube(6)
    idx, _ = query_knn(m.vertices, 8)
    new = simplify_segmentation(m.vertices, m.normals, m.labels, neighbors=idx)
    with _warns_naming(r"simplify_segmentation\(neighbors=\)"):
        old = simplify_segmentation(m.vertices, m.normals, m.labels, indices=idx)
    np.testing.assert_array_equal(old.vertices, new.vertices)
    assert [p.tolist() for p in old.polygons] == [p.tolist() for p in new.polygons]


def test_a_former_keyword_beside_its_new_name_is_refused():
    from pointatlas.simplify import simplify_segmentation

    m = cube(6)
    idx, _ = query_knn(m.vertices, 8)
    with pytest.raises(TypeError, match="not both"):
        simplify_segmentation(m.vertices, m.normals, m.labels, neighbors=idx, indices=idx)
