"""Tiled covariance features, bit for bit those of the untiled run.

Private to `pointatlas.batch` (decisions in docs/decisions/batch.md, "Tiles —
features").
"""

from __future__ import annotations

from .._core import PointAtlasError
from . import _tiles as T
from ._tiles import ArraySource, TileOptions
from ._tiles_tasks import feature_kmax

__all__ = ["features_over", "tiled_features"]


def tiled_features(points, normals, options: TileOptions, params: dict):
    """Features by tiles, bit for bit those of the untiled run.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    normals : array_like of shape (N, 3) or None
        Oriented normals (needed by ``mode="optimal"``).
    options : TileOptions
        Tiling and cluster.
    params : dict
        ``mode`` "fixed" (``k``), "optimal_k" (``k_range``, ``criterion``) or
        "optimal" (``k_range``, ``a_grid``, ``b_grid``), and ``flatness``.

    Returns
    -------
    fields : dict of str to ndarray
        The ``FeatureResult.scalar_fields()`` and ``dimension_class``.
    run : TiledRun
    """
    return features_over(ArraySource(points, normals), options, params)


def features_over(
    source,
    options,
    params,
    *,
    out=None,
    spill_dir=None,
    client_info=None,
    normals_array=None,
    label="features",
):
    kmax = feature_kmax(params)
    if kmax > source.n:
        raise PointAtlasError(f"k = {kmax} exceeds the number of points ({source.n})")
    if params["mode"] == "optimal" and not source.has_normals and normals_array is None:
        raise PointAtlasError("sigmoid weights need normals; the input has none")
    grid = T._grid_for(source, options)
    fields = {} if out is None else out

    def on_result(t, res):
        for name, v in res["fields"].items():
            if name not in fields:
                T._allocate(fields, name, source.n, v)
            fields[name][res["gidx"]] = v
        T.release_pages(*fields.values())

    with T._maybe_client(options, client_info) as ci:
        halo0, fixed = T._auto_halo(source, kmax, options, client=ci[0])
        run = T.run_tiles(
            "features",
            source,
            grid,
            T.sent_as(params, fields),
            options,
            ci,
            on_result,
            halo0=halo0,
            fixed=fixed,
            label=label,
            spill_dir=spill_dir,
            normals_array=normals_array,
            memory_per_point=8.0 * (kmax + 60),
        )
    return fields, run
