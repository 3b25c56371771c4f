"""`VSAOptions`: validation, keywords vs options, and the one option set of the CLI."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pointatlas.segment import VSAOptions, vsa_segment
from pointatlas.synth import cube

NAN = float("nan")


@pytest.fixture(scope="module")
def box():
    m = cube(6)
    return np.asarray(m.vertices), np.asarray(m.normals)


def _same_result(a, b):
    for f in ("labels", "proxy_normals", "centroids", "seed_indices", "region_l21", "adjacency"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    np.testing.assert_array_equal(a.energy_history, b.energy_history)
    assert (a.energy, a.mse, a.n_iter, a.stop_reason, a.step_names) == (
        b.energy,
        b.mse,
        b.n_iter,
        b.stop_reason,
        b.step_names,
    )


def test_defaults_are_vsa_segment_defaults():
    opts = VSAOptions()
    assert (opts.k, opts.weights, opts.seeds, opts.eta, opts.max_angle) == (
        8,
        "uniform",
        "all",
        None,
        None,
    )
    assert (opts.split, opts.merge, opts.switch, opts.classic, opts.max_iter) == (
        True,
        True,
        "batch",
        False,
        1000,
    )
    assert opts.min_cos == pytest.approx(math.cos(math.radians(10.0)), abs=1e-15)
    assert VSAOptions(eta=2.0).min_cos is None


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"k": 0}, ValueError, r"^k must be an integer >= 1; got 0$"),
        ({"k": 2.5}, TypeError, r"^k must be an integer; got float 2\.5$"),
        ({"max_iter": -1}, ValueError, r"^max_iter must be an integer >= 0; got -1$"),
        ({"switch": "best"}, ValueError, r"^switch must be one of \('batch', 'single', 'none'\)"),
        ({"eta": 1.0, "max_angle": 0.1}, ValueError, r"^give eta or max_angle, not both$"),
        ({"eta": -1.0}, ValueError, r"^eta must be a finite number >= 0; got -1\.0$"),
        ({"eta": NAN}, ValueError, r"^eta must be a finite number >= 0; got nan$"),
        ({"eta": "1"}, TypeError, r"^eta must be a real number; got str '1'$"),
        ({"max_angle": 4.0}, ValueError, r"^max_angle must be a finite angle in \[0, pi\]"),
        ({"split": 1}, TypeError, r"^split must be True or False; got 1$"),
        ({"merge": "yes"}, TypeError, r"^merge must be True or False; got 'yes'$"),
        ({"classic": None}, TypeError, r"^classic must be True or False; got None$"),
        ({"classic": True, "eta": 1.0}, ValueError, r"^classic=True runs without split/merge"),
        ({"weights": "areal"}, ValueError, r"^weights must be 'uniform', 'area' or an \(N,\)"),
        ({"weights": [[1.0, 2.0]]}, ValueError, r"^weights must have shape \(N,\); got \(1, 2\)$"),
        ({"weights": [1.0, NAN]}, ValueError, r"^weights must be finite and >= 0$"),
        ({"weights": [1.0, -1.0]}, ValueError, r"^weights must be finite and >= 0$"),
        ({"seeds": "some"}, ValueError, r"^seeds must be an int, an index array or 'all'"),
        ({"seeds": 0}, ValueError, r"^seeds must be an integer >= 1; got 0$"),
        ({"seeds": True}, ValueError, r"^seeds must be an int, a non-empty 1-D integer"),
        ({"seeds": []}, ValueError, r"^seeds must be an int, a non-empty 1-D integer"),
        ({"seeds": [0.5, 1.0]}, ValueError, r"^seeds must be an int, a non-empty 1-D integer"),
        ({"seeds": [3, -1]}, ValueError, r"^seeds must be point indices >= 0; got \[3, -1\]$"),
        ({"seeds": [3, 3]}, ValueError, r"^seeds must not repeat a point index$"),
    ],
)
def test_rejects(kwargs, error, match):
    with pytest.raises(error, match=match):
        VSAOptions(**kwargs)
    # the same checks, and messages, through vsa_segment's keywords
    with pytest.raises(error, match=match):
        vsa_segment(np.eye(3), np.eye(3), **{"k": 2, **kwargs})


def test_frozen_read_only_arrays_and_equality():
    w = np.array([1.0, 2.0, 3.0])
    opts = VSAOptions(weights=w, seeds=np.array([2, 0], dtype=np.int32))
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.eta = 1.0
    assert opts.weights is not w and not opts.weights.flags.writeable
    assert opts.seeds.dtype == np.int64 and not opts.seeds.flags.writeable
    w[0] = 9.0  # the options keep their own copy
    assert opts.weights[0] == 1.0
    assert opts == VSAOptions(weights=[1.0, 2.0, 3.0], seeds=[2, 0])
    assert opts != VSAOptions(weights=[1.0, 2.0, 4.0], seeds=[2, 0])
    assert opts != VSAOptions(seeds=[2, 0])
    assert VSAOptions(eta=1) == VSAOptions(eta=1.0) and VSAOptions() != "VSAOptions()"
    assert hash(VSAOptions(eta=1.0)) == hash(VSAOptions(eta=1.0))


def test_replace_validates_and_names_unknown_fields():
    opts = VSAOptions(eta=25.0)
    assert opts.replace() is opts
    assert opts.replace(k=12) == VSAOptions(eta=25.0, k=12)
    with pytest.raises(ValueError, match="^give eta or max_angle, not both$"):
        opts.replace(max_angle=0.2)
    with pytest.raises(TypeError, match=r"^unknown VSA option 'rng'; the options are k, weights"):
        opts.replace(rng=0)


@pytest.mark.parametrize(
    "settings",
    [
        {},
        {"eta": 2.0},
        {"max_angle": 0.3, "k": 10},
        {"eta": 2.0, "split": False, "weights": "area"},
        {"seeds": 12, "split": False, "merge": False, "switch": "single", "max_iter": 50},
        {"seeds": 12, "classic": True},
        {"seeds": [0, 40, 100], "max_angle": 0.2},
        {"max_iter": 2},
    ],
)
def test_options_and_keywords_give_the_same_run(box, settings):
    pts, nrm = box
    by_keywords = vsa_segment(pts, nrm, rng=3, **settings)
    by_options = vsa_segment(pts, nrm, rng=3, options=VSAOptions(**settings))
    _same_result(by_keywords, by_options)


def test_keywords_override_options(box):
    pts, nrm = box
    opts = VSAOptions(eta=2.0, k=12)
    mixed = vsa_segment(pts, nrm, options=opts, k=6, split=False)
    _same_result(mixed, vsa_segment(pts, nrm, eta=2.0, k=6, split=False))
    assert opts.k == 12  # the options value is not changed


def test_vsa_segment_refuses_other_options_and_unknown_keywords(box):
    pts, nrm = box
    with pytest.raises(TypeError, match="^options must be a VSAOptions; got dict$"):
        vsa_segment(pts, nrm, options={"eta": 1.0})
    with pytest.raises(TypeError, match="^unknown VSA option 'threshold'"):
        vsa_segment(pts, nrm, threshold=1.0)


def test_given_weights_and_seeds_are_checked_against_the_points(box):
    pts, nrm = box
    n = pts.shape[0]
    with pytest.raises(ValueError, match=rf"^weights must have shape \({n},\); got \(3,\)$"):
        vsa_segment(pts, nrm, options=VSAOptions(weights=[1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match=rf"^seeds must be point indices in \[0, {n}\)"):
        vsa_segment(pts, nrm, seeds=[0, n])
    with pytest.raises(ValueError, match=rf"^seeds must be an integer in \[1, {n}\]"):
        vsa_segment(pts, nrm, seeds=n + 1)


def test_simplify_points_takes_the_same_options(box):
    from pointatlas.simplify import simplify_points

    pts, nrm = box
    by_keywords = simplify_points(pts, nrm, max_angle=0.3, k=10, seeds=30, rng=2)
    by_options = simplify_points(pts, nrm, vsa=VSAOptions(max_angle=0.3, k=10, seeds=30), rng=2)
    _same_result(by_keywords.segmentation, by_options.segmentation)
    np.testing.assert_array_equal(by_keywords.mesh.vertices, by_options.mesh.vertices)
    with pytest.raises(TypeError, match="^unknown VSA option 'vertex'"):
        simplify_points(pts, nrm, vertex="fit")
