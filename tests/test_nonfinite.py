"""Every public function that takes a point array refuses NaN and Inf the same way.

The walk covers every room's ``__all__``: each callable with a ``points`` or
``vertices`` parameter must raise `NonFiniteError` naming that argument, with the
count of non-finite values and their rows (issue 28 item 4).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
from functools import cache

import numpy as np
import pytest

from pointatlas._core import NonFiniteError

ROOMS = (
    "pointatlas",
    "pointatlas._core",
    "pointatlas.io",
    "pointatlas.neighbors",
    "pointatlas.normals",
    "pointatlas.features",
    "pointatlas.synth",
    "pointatlas.complex",
    "pointatlas.cover",
    "pointatlas.segment",
    "pointatlas.denoise",
    "pointatlas.simplify",
    "pointatlas.dynamics",
    "pointatlas.viz",
    "pointatlas.batch",
    "pointatlas.experiments",
    "pointatlas.data",
)
ARRAY_ARGS = ("points", "vertices")
BAD_ROWS = (0, 5, 9)

# Records the library returns: their fields are its outputs, never user input, so
# they are built without a check (a check would cost every result a pass over its
# arrays). Everything a user passes in goes through a function or an input record.
# Parameters of these names that hold no point array.
NOT_ARRAYS = {
    ("simplify_points", "vertices"): "vertices= names how vertices are placed ('fit', ...)",
    ("simplify_segmentation", "vertices"): "vertices= names how vertices are placed ('fit', ...)",
}
RESULT_RECORDS = {
    "DeformResult",
    "DenoiseResult",
    "MeshClouds",
    "MeshSample",
    "SimplifiedMesh",
    "SurfaceSimplification",
}


def _walk():
    seen = set()
    for room in ROOMS:
        module = importlib.import_module(room)
        for name in module.__all__:
            obj = getattr(module, name)
            if not callable(obj) or name in RESULT_RECORDS:
                continue
            try:
                params = inspect.signature(obj).parameters
            except (TypeError, ValueError):  # pragma: no cover - builtins only
                continue
            for arg in ARRAY_ARGS:
                if arg in params and (name, arg) not in seen | NOT_ARRAYS.keys():
                    seen.add((name, arg))
                    yield pytest.param(name, arg, id=f"{room}.{name}-{arg}")


@cache
def _mesh():
    from pointatlas.synth import icosphere

    return icosphere(2)  # 162 vertices, 320 triangles


@cache
def _flatness_result():
    from pointatlas.denoise import flatness_denoise

    return flatness_denoise(_mesh().vertices, k=8, n_iter=1)


@cache
def _feature_result():
    from pointatlas.features import optimal_neighborhood

    m = _mesh()
    return optimal_neighborhood(m.vertices, m.normals, a_grid=(0.0,), b_grid=(3.0,), k_range=(6, 7))


def _labels():
    p = _mesh().vertices
    return ((p[:, 0] > 0) + 2 * (p[:, 1] > 0) + 4 * (p[:, 2] > 0)).astype(np.int64)


def _clouds():
    return [list(map(int, f)) for f in _mesh().faces]


@cache
def _cloud_complex():
    from pointatlas.complex import cloud_complex

    return cloud_complex(_clouds(), _mesh().vertices)


def _tile_options():
    from pointatlas.batch import TileOptions

    return TileOptions(tile_size=1.0, workers=1)


def _calls(tmp_path):
    """name -> call(a): ``a`` holds points, normals, vertices (= points) and faces."""
    from pointatlas import (
        _core,
        batch,
        complex,
        cover,
        denoise,
        dynamics,
        experiments,
        features,
        io,
        neighbors,
        normals,
        segment,
        simplify,
        synth,
        viz,
    )

    lab = _labels()

    def _report(layer):
        return viz.write_report(
            tmp_path / "r.html", title="t", summary={}, parameters={}, layers=[layer]
        )

    def _picture(panel):
        return viz.render_side_by_side(tmp_path / "s.png", [panel])

    return {
        "PointSet": lambda a: _core.PointSet(a["points"]),
        "as_points": lambda a: _core.as_points(a["points"]),
        "Mesh": lambda a: io.Mesh(a["vertices"], a["faces"]),
        "vertex_normals": lambda a: io.vertex_normals(a["vertices"], a["faces"]),
        "NeighborIndex": lambda a: neighbors.NeighborIndex(a["points"]),
        "MeshDistanceIndex": lambda a: neighbors.MeshDistanceIndex(a["vertices"], a["faces"]),
        "knn_components": lambda a: neighbors.knn_components(a["points"], 4),
        "knn_graph": lambda a: neighbors.knn_graph(a["points"], 4),
        "mean_spacing": lambda a: neighbors.mean_spacing(a["points"]),
        "point_mesh_distance": lambda a: neighbors.point_mesh_distance(
            a["points"], a["vertices"], a["faces"]
        ),
        "query_knn": lambda a: neighbors.query_knn(a["points"], 4),
        "query_radius": lambda a: neighbors.query_radius(a["points"], 0.3),
        "estimate_normals": lambda a: normals.estimate_normals(a["points"], 8),
        "orient_normals": lambda a: normals.orient_normals(a["points"], a["normals"]),
        "pca_normals": lambda a: normals.pca_normals(a["points"], 8),
        "covariance_features": lambda a: features.covariance_features(a["points"], 8),
        "optimal_k_features": lambda a: features.optimal_k_features(a["points"], k_range=(6, 8)),
        "optimal_neighborhood": lambda a: features.optimal_neighborhood(
            a["points"], a["normals"], a_grid=(0.0,), b_grid=(3.0,), k_range=(6, 7)
        ),
        "weighted_covariances": lambda a: features.weighted_covariances(
            a["points"], np.tile(np.arange(4), (a["points"].shape[0], 1))
        ),
        "SynthMesh": lambda a: synth.SynthMesh(a["vertices"], a["faces"], a["normals"]),
        "add_gaussian_noise": lambda a: synth.add_gaussian_noise(a["points"], 0.01, rng=0),
        "add_normal_noise": lambda a: synth.add_normal_noise(
            a["points"], a["normals"], 0.01, rng=0
        ),
        "clouds_from_mesh": lambda a: synth.clouds_from_mesh(a["vertices"], a["faces"], rng=0),
        "face_areas": lambda a: synth.face_areas(a["vertices"], a["faces"]),
        "sample_mesh": lambda a: synth.sample_mesh(a["vertices"], a["faces"], 10, rng=0),
        "vertex_curvature": lambda a: synth.vertex_curvature(a["vertices"], a["faces"]),
        "cloud_complex": lambda a: complex.cloud_complex(_clouds(), a["points"]),
        "surface_complex": lambda a: complex.surface_complex(a["points"], lab),
        "ball_cover": lambda a: cover.ball_cover(a["points"], 0.5),
        "search_cover_scale": lambda a: cover.search_cover_scale(a["points"], [0.5]),
        "area_weights": lambda a: segment.area_weights(a["points"]),
        "region_adjacency": lambda a: segment.region_adjacency(a["points"], lab),
        "region_growing": lambda a: segment.region_growing(a["points"], a["normals"]),
        "surface_curvature": lambda a: segment.surface_curvature(a["points"]),
        "vsa_segment": lambda a: segment.vsa_segment(a["points"], a["normals"], rng=0),
        "add_impulsive_noise": lambda a: denoise.add_impulsive_noise(
            a["points"], a["normals"], 0.01, rng=0
        ),
        "add_noise": lambda a: denoise.add_noise(a["points"], a["normals"], 0.01, rng=0),
        "chamfer_distance": lambda a: denoise.chamfer_distance(a["points"], _mesh().vertices),
        "choose_method": lambda a: denoise.choose_method(a["points"]),
        "default_neighborhoods": lambda a: denoise.default_neighborhoods(a["points"]),
        "denoise": lambda a: denoise.denoise(a["points"], a["normals"]),
        "denoise_measures": lambda a: denoise.denoise_measures(a["points"], _mesh().vertices),
        "filter_normals": lambda a: denoise.filter_normals(a["points"], a["normals"], n_iter=1),
        "flatness_denoise": lambda a: denoise.flatness_denoise(a["points"], k=8, n_iter=1),
        "flatness_with_sides": lambda a: denoise.flatness_with_sides(a["points"], k=8, n_iter=1),
        "normal_voting_denoise": lambda a: denoise.normal_voting_denoise(
            a["points"], a["normals"], n_iter=1
        ),
        "snap_planar_pieces": lambda a: denoise.snap_planar_pieces(a["points"], _flatness_result()),
        "unit_sphere_transform": lambda a: denoise.unit_sphere_transform(a["points"]),
        "voting_with_pieces": lambda a: denoise.voting_with_pieces(a["points"], a["normals"]),
        "decimate_mesh": lambda a: simplify.decimate_mesh(a["vertices"], a["faces"], 100),
        "region_proxies": lambda a: simplify.region_proxies(a["points"], a["normals"], lab),
        "simplify_mesh": lambda a: simplify.simplify_mesh(a["vertices"], a["faces"]),
        "self_intersections": lambda a: simplify.self_intersections(a["vertices"], a["faces"]),
        "simplify_points": lambda a: simplify.simplify_points(a["points"], a["normals"], rng=0),
        "simplify_estimated": lambda a: simplify.simplify_estimated(
            a["points"], lambda k: a["normals"], rng=0
        ),
        "simplify_segmentation": lambda a: simplify.simplify_segmentation(
            a["points"], a["normals"], lab
        ),
        "surface_diagonal": lambda a: simplify.surface_diagonal(a["vertices"], a["faces"]),
        "surface_normals": lambda a: simplify.surface_normals(a["points"], 8, k_range=(6, 10)),
        "sharpen_normals": lambda a: simplify.sharpen_normals(a["points"], a["normals"], 8),
        "outward_normals": lambda a: simplify.outward_normals(a["points"], a["normals"]),
        "deform_points": lambda a: dynamics.deform_points(
            a["points"], _cloud_complex(), _cloud_complex().cloud_points
        ),
        # the viewer's layers and the pictures' panels are checked where they are drawn
        "MeshLayer": lambda a: _report(viz.MeshLayer(a["vertices"], a["faces"])),
        "MeshPanel": lambda a: _picture(viz.MeshPanel(a["vertices"], a["faces"])),
        "PointsLayer": lambda a: _report(viz.PointsLayer(a["points"])),
        "PointsPanel": lambda a: _picture(viz.PointsPanel(a["points"])),
        "fit_camera": lambda a: viz.fit_camera(a["points"]),
        "render_mesh": lambda a: viz.render_mesh(tmp_path / "m.png", a["vertices"], a["faces"]),
        "render_mesh_array": lambda a: viz.render_mesh_array(a["vertices"], a["faces"]),
        "render_points": lambda a: viz.render_points(tmp_path / "p.png", a["points"]),
        "render_points_array": lambda a: viz.render_points_array(a["points"]),
        "ArraySource": lambda a: batch.ArraySource(a["points"]),
        "tiled_denoise": lambda a: batch.tiled_denoise(
            a["points"], a["normals"], _tile_options(), {}
        ),
        "tiled_features": lambda a: batch.tiled_features(
            a["points"], a["normals"], _tile_options(), {}
        ),
        "tiled_normals": lambda a: batch.tiled_normals(a["points"], _tile_options()),
        "tiled_segment": lambda a: batch.tiled_segment(
            a["points"], a["normals"], _tile_options(), {}
        ),
        "decrease_cases": lambda a: experiments.decrease_cases(
            a["points"], a["normals"], _feature_result()
        ),
        "fig_5_3": lambda a: experiments.fig_5_3(a["points"], a["normals"], tmp_path, name="x"),
    }


def test_every_walked_name_has_a_call():
    names = {p.values[0] for p in _walk()}
    missing = names - set(_calls(None))
    assert not missing, f"add a call for {sorted(missing)}"


@pytest.mark.parametrize("value", [np.nan, np.inf], ids=["nan", "inf"])
@pytest.mark.parametrize(("name", "arg"), list(_walk()))
def test_public_function_refuses_non_finite_points(name, arg, value, tmp_path):
    m = _mesh()
    good = np.array(m.vertices)
    bad = good.copy()
    bad[list(BAD_ROWS), 1] = value
    args = {"points": good, "normals": np.array(m.normals), "vertices": good, "faces": m.faces}
    args[arg] = bad
    expected = f"{arg} contains 3 non-finite values (NaN or Inf) at rows 0, 5, 9"
    with pytest.raises(NonFiniteError, match=f"^{re.escape(expected)}$"):
        _calls(tmp_path)[name](args)


def test_skipped_parameters_take_no_array():
    from pointatlas import simplify

    for name, arg in NOT_ARRAYS:
        default = inspect.signature(getattr(simplify, name)).parameters[arg].default
        assert isinstance(default, str), (name, arg)


def test_result_records_are_what_the_library_returns():
    # the skipped names are frozen dataclasses whose fields are outputs
    for room in ROOMS:
        module = importlib.import_module(room)
        for name in set(module.__all__) & RESULT_RECORDS:
            assert dataclasses.is_dataclass(getattr(module, name)), name
