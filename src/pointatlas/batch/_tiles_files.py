"""A tiled run of one job on files: IN read, tiles computed, OUT written.

LAS/LAZ in and out: streamed by chunks (`LasSource`, `write_streamed`), the results
in memory maps of a temporary folder beside OUT. Other formats: read whole (they
cannot be streamed), processed by tiles, written with every input field. The job
object (`NormalsTileJob`, `FeaturesTileJob`, `SegmentTileJob`, `DenoiseTileJob`)
says what the tiles compute; this module does the rest, the same for every job.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._core import PointAtlasError
from ._tiles import ArraySource, tile_client
from ._tiles_jobs import ArrayStore, MappedStore, TileContext
from ._tiles_las import LAS_EXTENSIONS, LasSource, las_feature_fields, write_streamed
from ._tiles_tmp import clean_tmp, make_tmp

__all__ = ["input_has_normals", "input_point_count", "run_tile_job"]


def run_tile_job(job, in_path, out_path, options, *, normals=None) -> dict:
    """Run ``job`` by tiles on IN and write OUT with every input field and ours.

    Parameters
    ----------
    job : NormalsTileJob, FeaturesTileJob, SegmentTileJob or DenoiseTileJob
        What the tiles compute.
    in_path, out_path : str or os.PathLike
        IN (a point file, or a bundled model name where no such file exists) and
        OUT; both LAS/LAZ: streamed by chunks.
    options : TileOptions
        Tiling and cluster.
    normals : NormalsTileJob, optional
        Normals estimated first and used by the job (IN's are kept as
        ``input_normals``); a streamed features job with equal weights computes them
        in its own pass, from the same k-NN.

    Returns
    -------
    summary : dict
        Points, scheduler, tiles (halo, points sent), the job's entries (segment:
        quality and regions; denoise: spacing), ``seconds_total`` and ``input``.
    """
    in_path, out_path = Path(in_path), Path(out_path)
    t0 = time.perf_counter()
    streamed = in_path.suffix.lower() in LAS_EXTENSIONS
    streamed = streamed and out_path.suffix.lower() in LAS_EXTENSIONS
    run = _streamed if streamed else _whole
    summary = run(job, in_path, out_path, options, normals)
    summary["seconds_total"] = round(time.perf_counter() - t0, 3)
    summary["input"] = str(in_path)
    return summary


def _run_summary(summary: dict, out) -> None:
    """The job's entries, then its tiles' (as `TiledRun.summary` and its extras)."""
    summary.update(out.summary)
    summary["tiles"] = out.run.summary()
    summary.update({f"tiles_{k}": v for k, v in out.run.extra.items() if np.isscalar(v)})


def _streamed(job, in_path, out_path, options, normal_job) -> dict:
    """LAS/LAZ to LAS/LAZ by chunks, never the whole file in memory."""
    src = LasSource(in_path)
    t0 = time.perf_counter()
    tmp = make_tmp(options, out_path)
    summary = {"points": src.n}
    try:
        src.keep_records(tmp)  # LAZ: decoded once, by the first pass
        src.bounds()  # the first pass (bounds, subsample): an empty file fails here
        with tile_client(options) as ci:
            summary["scheduler"] = ci[1]
            store = MappedStore(tmp, src.n)
            fused = normal_job is not None and getattr(job, "fuses_normals", lambda: False)()
            normals = None
            if normal_job is not None and not fused:
                src.use_normals = False
                first = normal_job.compute(
                    src, replace(options, halo=None), TileContext(ci, store, tmp)
                )
                normals = first.normals
                summary["normals_tiles"] = first.run.summary()
            src.use_normals = job.uses_normals and normals is None
            ctx = TileContext(ci, store, tmp, normals, normal_job if fused else None)
            out = job.compute(src, options, ctx)
            _run_summary(summary, out)
        t1 = time.perf_counter()
        write_streamed(
            src,
            out_path,
            out.fields,
            normals=out.normals if out.normals is not None else normals,
            points=out.points,
            float_type=job.las_float_type,
        )
        t2 = time.perf_counter()
        summary["seconds"] = {
            "total": round(t2 - t0, 3),
            "tiles (incl. reading)": round(t1 - t0, 3),
            "writing (incl. reading)": round(t2 - t1, 3),
        }
    finally:
        clean_tmp(tmp)
    return summary


def _read_whole(path, *, with_normals: bool = True):
    """IN read whole: a point file, or a bundled model name (``pointatlas data list``)
    where no such file exists (bundled models are small; they run by tiles like a file)."""
    from ..io import read_point_set

    p = Path(path)
    if not p.exists():
        from .. import data

        if str(path) in data.names():
            ps = data.load(str(path))
            return ps if with_normals else ps.replace(normals=None)
    return read_point_set(p, with_normals=with_normals)


def _whole(job, in_path, out_path, options, normal_job) -> dict:
    """IN read whole, tiles on the cluster, OUT written with every input field."""
    from ..io import merge_attributes, write_point_set

    ps = _read_whole(in_path, with_normals=False)
    try:
        given = _read_whole(in_path).normals
    except PointAtlasError:
        given = None
    summary = {"points": ps.n_points}
    with tile_client(options) as ci:
        summary["scheduler"] = ci[1]
        store = ArrayStore(ps.n_points)
        estimated = None
        if normal_job is not None:
            first = normal_job.compute(
                ArraySource(ps.points), replace(options, halo=None), TileContext(ci, store)
            )
            estimated = first.normals
            summary["normals_tiles"] = first.run.summary()
        normals = estimated if estimated is not None else given
        source = ArraySource(ps.points, normals if job.uses_normals else None)
        out = job.compute(source, options, TileContext(ci, store))
        _run_summary(summary, out)
    ours = {}
    if given is not None and (estimated is not None or out.replaces_input_normals):
        ours["input_normals"] = given
    fields = out.fields
    if job.las_float_type is not None and Path(out_path).suffix.lower() in LAS_EXTENSIONS:
        fields = las_feature_fields(fields, job.las_float_type)
    ours.update(fields)
    base = dict(ps.attributes)
    colors = ours.pop("colors", None) if "colors" not in base else None
    merged = merge_attributes(base, ours)
    written = {k: v for k, v in merged.items() if k not in base}
    if colors is not None:
        written["colors"] = colors
    points = out.points if out.points is not None else ps.points
    new_normals = out.normals if out.normals is not None else estimated
    out_normals = new_normals if new_normals is not None else given
    write_point_set(out_path, ps.replace(points=points, normals=out_normals), attributes=written)
    return summary


def input_has_normals(path) -> bool:
    """Whether IN stores usable normals, as a tiled run reads it.

    Parameters
    ----------
    path : str or os.PathLike
        A point file (LAS/LAZ: ``nx, ny, nz`` dimensions), or a bundled model name.

    Returns
    -------
    has_normals : bool
        True when every point has a usable normal.
    """
    p = Path(path)
    if p.suffix.lower() in LAS_EXTENSIONS:
        return LasSource(p).has_normals
    try:
        return _read_whole(p).normals is not None
    except PointAtlasError:
        return False


def input_point_count(path) -> int:
    """The number of points a tiled run of IN reads, before any work.

    Parameters
    ----------
    path : str or os.PathLike
        A point file (LAS/LAZ: its header's count, nothing else read), or a bundled
        model name.

    Returns
    -------
    n_points : int
        Points in IN.

    Notes
    -----
    The commands check their counts against it (``segment --k`` at most N, flatness'
    ``--k`` below N) before a tiled run starts: a k-NN query of a huge k in a
    tile's kernel would run for hours without a signal getting through.
    """
    p = Path(path)
    if p.suffix.lower() in LAS_EXTENSIONS:
        return LasSource(p).n
    return _read_whole(p, with_normals=False).n_points
