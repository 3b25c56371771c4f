"""Tiled normals and features from one k-NN table per tile (``pointatlas features
--estimate-normals``): PCA normals, MST-oriented and stitched across tiles as `tiled_normals`
does, or made n_z >= 0 per point (``--orient up``, bit for bit the untiled ones), and
equal-weight features of the owned points bit for bit those of the untiled run.

Private to `pointatlas.batch` (decisions in docs/decisions/batch.md, "Tiles — normals
and features in one pass").
"""

from __future__ import annotations

import os

import numpy as np

from .._core import PointAtlasError
from . import _tiles as T
from ._tiles_normals import _Stitch, check_normal_options
from ._tiles_tasks import (
    _certified_table,
    _owned_table,
    _setup,
    _threads,
    feature_kmax,
    features_dispatch,
    mst_tile_normals,
    orient_per_point,
    owned_fields,
)

__all__ = ["normals_features_over", "normals_features_task"]


def normals_features_task(spec, data):
    """One tile. ``orient`` "mst": its certified k-NN table (``max(k, kf)`` rows
    exact, ``orient_k`` columns for the orientation graph) of every tile point, PCA
    normals oriented by MST as `normals_task` (halo parts for the stitching); "up":
    the owned rows' table only (`_owned_table`, as `features_task`), the owned normals
    made n_z >= 0 (per point: nothing to stitch). Then the features of the owned rows
    from the same table (halo rows get a table of the point itself)."""
    from ..normals import estimate_normals

    os.environ.setdefault("PYTHONHASHSEED", "0")
    _threads(spec)
    p = spec["params"]
    k, orient_k, fp = p["k"], p["orient_k"], p["features"]
    orient = p.get("orient", "mst")
    kf = feature_kmax(fp)
    grid, xyz, owner, owned, bdist = _setup(spec, data)
    out = {"status": "ok", "gidx": data["gidx"][owned]}
    if orient == "mst":
        table, fail = _certified_table(
            spec, xyz, owned, bdist, max(k, kf), min_cols=max(k, kf, orient_k)
        )
        if fail:
            return fail
        normals, parts = mst_tile_normals(xyz, table, k, orient_k, data, owner, owned)
        out.update(normals=normals[owned], **parts)
        ftable = np.ascontiguousarray(table[:, :kf])
        halo = np.flatnonzero(~owned)
        ftable[halo] = halo[:, None]
    else:
        table, fail = _owned_table(spec, xyz, owned, bdist, max(k, kf))
        if fail:
            return fail
        normals = estimate_normals(xyz, k, neighbors=table)
        out["normals"] = orient_per_point(xyz, normals, owned, orient)
        ftable = table if table.shape[1] == kf else np.ascontiguousarray(table[:, :kf])
    res = features_dispatch(xyz, None, fp, neighbors=ftable)
    out["fields"] = owned_fields(res, owned, fp)
    return out


def normals_features_over(
    source,
    options,
    params,
    normal_params,
    *,
    normals_out=None,
    fields_out=None,
    spill_dir=None,
    client_info=None,
    label="normals + features",
):
    """Normals (``normal_params``: ``k``, ``orient_k``, ``orient`` "mst" (default) or
    "up") and equal-weight features (``params``: mode "fixed" or "optimal_k") of every
    point, one k-NN per tile.

    Returns ``(normals, fields, run)``.
    """
    if params["mode"] == "optimal":
        raise PointAtlasError(
            "--estimate-normals computes the normals in the same pass as the features; sigmoid "
            "weights need them first: run `pointatlas normals`, then `features`"
        )
    n = source.n
    k, orient_k = int(normal_params["k"]), int(normal_params.get("orient_k", 10))
    orient = normal_params.get("orient", "mst")
    if orient not in ("mst", "up"):
        raise PointAtlasError(f"--orient with --estimate-normals must be mst or up; got {orient!r}")
    check_normal_options(n, k, orient)
    kf = feature_kmax(params)
    if kf > n:
        raise PointAtlasError(f"k = {kf} exceeds the number of points ({n})")
    grid = T._grid_for(source, options)
    stitch = _Stitch(np.zeros((n, 3)) if normals_out is None else normals_out, orient, spill_dir)
    fields = {} if fields_out is None else fields_out

    def on_result(t, res):
        stitch.on_result(t, res)
        for name, v in res["fields"].items():
            if name not in fields:
                T._allocate(fields, name, n, v)
            fields[name][res["gidx"]] = v
        T.release_pages(*fields.values())

    task_params = {
        "k": k,
        "orient_k": orient_k,
        "orient": orient,
        "features": T.sent_as(params, fields),
    }
    cols = max(k, kf, orient_k) if orient == "mst" else max(k, kf)
    with T._maybe_client(options, client_info) as ci:
        halo0, fixed = T._auto_halo(source, max(k, kf), options, client=ci[0])
        run = T.run_tiles(
            normals_features_task,
            source,
            grid,
            task_params,
            options,
            ci,
            on_result,
            halo0=halo0,
            fixed=fixed,
            label=label,
            spill_dir=spill_dir,
            memory_per_point=8.0 * (3 * (cols + 8) + 60),
        )
    stitch.finish(run)
    return stitch.normals, fields, run
