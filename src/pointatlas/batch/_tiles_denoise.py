"""Tiled denoising with a halo that covers every iteration's reach.

Private to `pointatlas.batch` (decisions in docs/decisions/batch.md, "Tiles —
denoising").
"""

from __future__ import annotations

import numpy as np

from .._core import PointAtlasError
from . import _tiles as T
from ._tiles import ArraySource, TileOptions

__all__ = ["denoise_over", "tiled_denoise"]

#: Normal voting's l is the mean 6-NN spacing over at most this many points.
SPACING_SAMPLE = 4_000_000


def tiled_denoise(points, normals, options: TileOptions, params: dict):
    """Denoising by tiles with a halo covering every iteration's reach.

    Parameters
    ----------
    points, normals : ndarray of shape (N, 3)
        Noisy points and (for normal voting) oriented normals.
    options : TileOptions
        Tiling and cluster; an automatic halo is `halo_width` of the parameters
        (a given smaller halo is refused).
    params : dict
        ``method`` "flatness" (``k``, ``eta``, ``eps``, ``n_iter``, ``schedule``,
        ``k_start``) or "normal-voting[-adaptive]" (``rho``, ``tau``, ``n_iter``,
        ``filter_iter``, ``max_step``, optional ``n_update``).

    Returns
    -------
    result : dict
        ``points``, ``normals`` and the per-point fields (``displacement``,
        ``feature_class``, ``denoise_k``, ``flatness``), ``spacing`` (global l).
    run : TiledRun

    Notes
    -----
    The halo comes from the denoise room: `pointatlas.denoise.denoise_halo` gives
    the neighbour rings (hops in the k-NN graph of its ``columns``) an owned point's
    result depends on; `halo_width` turns them into a length. Normal voting runs
    on every tile with the tile's exact k-NN table (``neighbors=``) and the global
    l (``spacing=``): with fixed counts (``n_iter`` and ``n_update`` given) and
    given normals, every owned point equals the untiled run bit for bit; with the
    automatic ``n_update`` the stop is an RMS test per tile instead of over all
    points (the halo then covers the worst case, 12 updates).
    """
    return denoise_over(ArraySource(points, normals), options, params)


def halo_width(source, params, spacing: float):
    """(halo length, `pointatlas.denoise.DenoiseHalo`) of a denoise run's parameters.

    The rings of `denoise_halo` times a high k-NN distance at its ``columns``
    (the 99.99th percentile, as the automatic k-NN halo), x 1.05; flatness
    re-queries moved points, so each of its rings also gets one spacing l.
    """
    from ..denoise import denoise_halo

    method = params["method"]
    if method == "flatness":
        spec = denoise_halo(
            method,
            n_iter=params["n_iter"],
            k=int(params["k"]),
            k_start=params.get("k_start"),
            schedule=params.get("schedule") or "constant",
        )
    else:
        spec = denoise_halo(
            method,
            n_iter=params["n_iter"],
            n_filter_iter=int(params["filter_iter"]),
            n_update=params.get("n_update"),
        )
    _, reach = T._estimate_spacing(source, min(spec.columns, source.n))
    margin = spacing if method == "flatness" else 0.0
    return 1.05 * spec.length(reach + margin), spec


def denoise_over(
    source,
    options,
    params,
    *,
    spill_dir=None,
    client_info=None,
    outs=None,
    normals_array=None,
    label="denoise",
):
    # l of normal voting: the mean 6-NN spacing (exact below SPACING_SAMPLE points)
    spacing, _ = T._estimate_spacing(source, 6, sample=SPACING_SAMPLE)
    p = dict(params)
    p["spacing"] = spacing
    need, spec = halo_width(source, p, spacing)
    p["columns"] = spec.columns
    if options.halo is not None and options.halo < need:
        # flatness' n_iter None: at most FLATNESS_MAX_ITER, the halo's rings
        iterations = spec.rings if p["n_iter"] is None else p["n_iter"]
        raise PointAtlasError(
            f"--halo {options.halo:g} is smaller than the reach of {iterations} denoising "
            f"iterations ({need:.4g}); use --halo {need:.4g} or more, or leave it out"
        )
    halo = float(options.halo) if options.halo is not None else need
    grid = T._grid_for(source, options)
    n = source.n
    out = outs or {"points": np.zeros((n, 3)), "normals": np.zeros((n, 3))}
    n_fallback = [0]

    def on_result(t, res):
        out["points"][res["gidx"]] = res["points"]
        out["normals"][res["gidx"]] = res["normals"]
        for name, v in res["fields"].items():
            if name not in out:
                T._allocate(out, name, n, v)
            out[name][res["gidx"]] = v
        n_fallback[0] += res["n_fallback"]
        T.release_pages(*out.values())

    with T._maybe_client(options, client_info) as ci:
        run = T.run_tiles(
            "denoise",
            source,
            grid,
            p,
            options,
            ci,
            on_result,
            halo0=halo,
            fixed=options.halo is not None,
            label=label,
            spill_dir=spill_dir,
            normals_array=normals_array,
            memory_per_point=8.0 * 200,
        )
    out["spacing"] = spacing
    run.extra["n_fallback"] = n_fallback[0]
    return out, run
