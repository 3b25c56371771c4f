"""One vocabulary in the public API: American spelling, ``neighbors=`` for a neighbour table.

Each former name (a British spelling, or ``indices=`` for the neighbour table) still
works as a deprecated alias: it gives the same result as the new name and warns once
per call, naming the new name (issue 29 item 2). The walk at the end fails on a
British spelling in a public name or keyword that is not one of these aliases.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import re

import numpy as np
import pytest

from pointatlas.neighbors import query_knn
from pointatlas.synth import cube

from .test_nonfinite import ROOMS as NONFINITE_ROOMS


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


def test_knn_component_sizes_indices_is_the_former_neighbors():
    from pointatlas.neighbors import knn_component_sizes

    pts = np.array([[0.0, 0, 0], [1, 0, 0], [10, 0, 0], [11, 0, 0], [12, 0, 0]])
    idx, _ = query_knn(pts, 2)
    with _warns_naming(r"knn_component_sizes\(neighbors=\)"):
        old = knn_component_sizes(indices=idx)
    assert old.tolist() == knn_component_sizes(neighbors=idx).tolist() == [3, 2]


# ---------------------------------------------------------------- former (British) names


def test_optimal_neighbourhood_is_optimal_neighborhood():
    from pointatlas import features

    m = cube(4)
    kwargs = {"a_grid": (0.0,), "b_grid": (3.0,), "k_range": (6, 8)}
    new = features.optimal_neighborhood(m.vertices, m.normals, **kwargs)
    with _warns_naming("optimal_neighborhood"):
        old = features.optimal_neighbourhood(m.vertices, m.normals, **kwargs)
    np.testing.assert_array_equal(old.k, new.k)
    np.testing.assert_array_equal(old.e_dim, new.e_dim)


def test_default_neighbourhoods_is_default_neighborhoods():
    from pointatlas import denoise
    from pointatlas.synth import plane_patch

    pts = plane_patch(12, 12).points
    new = denoise.default_neighborhoods(pts)
    with _warns_naming("default_neighborhoods"):
        old = denoise.default_neighbourhoods(pts)
    for a, b in zip(old, new, strict=True):
        np.testing.assert_array_equal(a, b)


def test_realise_complex_is_realize_complex():
    from pointatlas import complex as cx

    m = cube(3)
    K = cx.cloud_complex([list(map(int, f)) for f in m.faces], m.vertices)
    new = cx.realize_complex(K)
    with _warns_naming("realize_complex"):
        old = cx.realise_complex(K)
    for a, b in zip(old, new, strict=True):
        np.testing.assert_array_equal(a, b)


def test_ball_cover_centres_are_its_centers():
    from pointatlas.cover import ball_cover

    pts = cube(4).vertices
    new = ball_cover(pts, 0.6, cloud_points="center")
    with _warns_naming("cloud_points='center'"):
        old = ball_cover(pts, 0.6, cloud_points="centre")
    np.testing.assert_array_equal(old.cloud_complex.cloud_points, new.cloud_complex.cloud_points)
    with _warns_naming("BallCover.centers"):
        np.testing.assert_array_equal(new.centres, new.centers)


def test_tile_grid_neighbours_is_neighbors():
    from pointatlas.batch import make_grid

    grid = make_grid((0.0, 0.0), (4.0, 4.0), 1.0)
    with _warns_naming("TileGrid.neighbors"):
        old = grid.neighbours(5, 1)
    assert old == grid.neighbors(5, 1) == [0, 1, 2, 4, 5, 6, 8, 9, 10]


def test_the_neighbourhoods_study_is_the_neighborhoods_study():
    from pointatlas import experiments

    for old, new in (
        ("aggregate_neighbourhoods", "aggregate_neighborhoods"),
        ("neighbourhood_model", "neighborhood_model"),
        ("run_neighbourhoods", "run_neighborhoods"),
        ("write_neighbourhood_outputs", "write_neighborhood_outputs"),
    ):
        alias = getattr(experiments, old)
        assert alias.__wrapped__ is getattr(experiments, new)
        with _warns_naming(new), pytest.raises(TypeError):
            alias()  # warns before the call (which lacks its arguments)
    module = importlib.import_module("pointatlas.experiments.neighbourhoods")  # the old path
    assert module.energy_histogram is experiments.energy_histogram
    assert module.run_neighbourhoods is experiments.run_neighbourhoods


# ---------------------------------------------------------------- the walk

BRITISH = re.compile(
    r"neighbour|colour|centre|normalis|realis|organis|behaviour|favour|optimis|minimis"
    r"|maximis|summaris|visualis|initialis|serialis|recognis|parametris|discretis"
    r"|regularis|standardis|characteris(?!tic)|licence|grey|metre|fibre|artefact|modell"
    r"|labell|travell|cancell"
)
# the public rooms: those whose non-finite input the non-finite walk checks, but _core
ROOMS = [room for room in NONFINITE_ROOMS if room != "pointatlas._core"]
# The former names, kept as deprecated aliases (each tested above).
DEPRECATED = {
    "pointatlas.features.optimal_neighbourhood",
    "pointatlas.denoise.default_neighbourhoods",
    "pointatlas.complex.realise_complex",
    "pointatlas.experiments.aggregate_neighbourhoods",
    "pointatlas.experiments.neighbourhood_model",
    "pointatlas.experiments.run_neighbourhoods",
    "pointatlas.experiments.write_neighbourhood_outputs",
    "pointatlas.experiments.neighbourhoods",
    "pointatlas.cover.BallCover.centres",
    "pointatlas.batch.TileGrid.neighbours",
}
# ``indices`` names a neighbour table nowhere in the public API; where it stays it
# names something else.
INDICES_ELSEWHERE = {
    "pointatlas.neighbors.RadiusNeighbors": "the CSR column array (indptr, indices)",
}


def _params(obj) -> list[str]:
    try:
        return list(inspect.signature(obj).parameters)
    except (TypeError, ValueError):
        return []


def _public_names():
    """(dotted name, kind) of every public name, keyword, method and field."""
    for room in ROOMS:
        module = importlib.import_module(room)
        names = set(module.__all__) | {
            n
            for n, v in vars(module).items()
            if not n.startswith("_") and getattr(v, "__module__", "").startswith("pointatlas")
        }
        names |= {m.name for m in pkgutil.iter_modules(getattr(module, "__path__", []))}
        for name in sorted(names):
            if name.startswith("_"):
                continue
            where = f"{room}.{name}"
            yield where, "name"
            obj = getattr(module, name, None)
            if obj is None or inspect.ismodule(obj) or where in DEPRECATED:
                continue
            members = [("", obj)]
            if inspect.isclass(obj):
                members += [
                    (f".{a}", getattr(obj, a, None)) for a in dir(obj) if not a.startswith("_")
                ]
            for suffix, member in members:
                if suffix:
                    yield where + suffix, "member"
                if callable(member) and where + suffix not in DEPRECATED:
                    for p in _params(member):
                        yield f"{where}{suffix}({p}=)", "keyword"
            if dataclasses.is_dataclass(obj):
                for f in dataclasses.fields(obj):
                    yield f"{where}.{f.name}", "field"


def test_public_names_and_keywords_are_american():
    british = sorted(
        {
            where
            for where, _ in _public_names()
            if BRITISH.search(where.split(".", 1)[1]) and where not in DEPRECATED
        }
    )
    assert not british, f"British spellings in the public API (rename, alias the old): {british}"


def test_a_neighbor_table_is_neighbors_everywhere():
    odd = sorted(
        where
        for where, kind in _public_names()
        if kind == "keyword"
        and where.endswith("(indices=)")
        and where.split("(")[0].rsplit(".", 1)[0] not in INDICES_ELSEWHERE
        and where.split("(")[0] not in INDICES_ELSEWHERE
    )
    assert not odd, f"a neighbour table is given as neighbors=: {odd}"


def test_the_listed_deprecated_aliases_exist():
    found = {where for where, _ in _public_names()}
    assert DEPRECATED <= found, sorted(DEPRECATED - found)
