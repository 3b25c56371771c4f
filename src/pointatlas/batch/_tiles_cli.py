"""The ``--tile-size`` path of ``normals``, ``features``, ``segment`` and ``denoise``.

LAS/LAZ in and out: streamed by chunks (`las_tiled`). Other formats: read whole
(they cannot be streamed), processed by tiles, written with every input field.
"""

from __future__ import annotations

import csv
import io
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._core import PointAtlasError
from ._tiles import (
    ArraySource,
    TileOptions,
    release_pages,
    tile_client,
)
from ._tiles_denoise import denoise_over
from ._tiles_features import features_over
from ._tiles_las import LAS_EXTENSIONS, las_feature_fields, las_tiled
from ._tiles_normals import normals_over
from ._tiles_segment import segment_over

__all__ = [
    "denoise_params",
    "feature_params",
    "input_has_normals",
    "normal_params_for",
    "refuse",
    "run_tiled_command",
    "segment_params",
    "tile_options",
]

#: What each command refuses with --tile-size (needs every point in one process).
_REFUSED = "needs every point in one process; leave out --tile-size or this option"
#: Why the pictures are refused: a tiled run never holds the whole result in one process.
_WHY = {
    "render": "(the picture draws the result of every point, which a tiled run never holds "
    "in one process); leave out --tile-size, or run untiled on a cropped part for a picture",
}


def tile_options(
    tile_size, halo=None, workers=None, scheduler=None, max_memory=None, *, progress: bool = True
):
    """`TileOptions` from the CLI flags, or None without ``--tile-size``.

    The other flags without ``--tile-size`` are an error (they would do nothing).

    Parameters
    ----------
    tile_size : float or None
        ``--tile-size``: the tiles' side in coordinate units; None runs untiled.
    halo, workers, scheduler, max_memory
        ``--halo``, ``--workers`` (2 when not given), ``--scheduler``, ``--max-memory``.
    progress : bool, default True
        Show a progress bar.

    Returns
    -------
    TileOptions or None

    Raises
    ------
    PointAtlasError
        One of the other flags given without ``--tile-size``.
    """
    if tile_size is None:
        given = [
            flag
            for flag, value in (
                ("--halo", halo),
                ("--workers", workers),
                ("--scheduler", scheduler),
                ("--max-memory", max_memory),
            )
            if value is not None
        ]
        if given:
            raise PointAtlasError(f"{', '.join(given)} only apply with --tile-size")
        return None
    return TileOptions(
        tile_size=tile_size,
        halo=halo,
        workers=2 if workers is None else workers,
        scheduler=scheduler,
        max_memory=max_memory,
        progress=progress,
    )


def refuse(options: TileOptions | None, **flags) -> None:
    """One-line error for options that cannot run by tiles (given = truthy)."""
    if options is None:
        return
    for flag, value in flags.items():
        if value:
            why = _WHY.get(flag)
            if why is not None:
                raise PointAtlasError(f"--{flag} needs every point in one process {why}")
            raise PointAtlasError(f"--{flag.replace('_', '-')} {_REFUSED}")


def _streamable(in_path, out_path) -> bool:
    return (
        Path(in_path).suffix.lower() in LAS_EXTENSIONS
        and Path(out_path).suffix.lower() in LAS_EXTENSIONS
    )


def _region_rows(quality) -> list[dict]:
    rows = []
    for r in range(quality["n_regions"]):
        n = quality["proxy_normals"][r]
        c = quality["centroids"][r]
        rows.append(
            {
                "region": r,
                "n_points": int(quality["region_counts"][r]),
                "l21": float(quality["region_l21"][r]),
                "nx": float(n[0]),
                "ny": float(n[1]),
                "nz": float(n[2]),
                "cx": float(c[0]),
                "cy": float(c[1]),
                "cz": float(c[2]),
            }
        )
    return rows


def _write_text(path: Path, text: str) -> Path:
    from ..io import atomic_write

    with atomic_write(path, "w") as fh:
        fh.write(text)
    return path


def _side_outputs(kind, out_path: Path, summary: dict) -> list[Path]:
    """Segment: OUT_regions.csv and OUT_regions.json; denoise: OUT_denoise.json."""
    from ..io import write_json

    stem = out_path.with_suffix("")
    written = []
    if kind == "segment":
        rows = _region_rows(summary.pop("regions"))
        buf = io.StringIO()
        writer = csv.DictWriter(
            buf, fieldnames=list(rows[0]) if rows else ["region"], lineterminator="\n"
        )
        writer.writeheader()
        writer.writerows(rows)
        written.append(_write_text(Path(f"{stem}_regions.csv"), buf.getvalue()))
        payload = {"summary": summary, "regions": rows}
        written.append(write_json(Path(f"{stem}_regions.json"), payload, indent=2))
    elif kind == "denoise":
        written.append(write_json(Path(f"{stem}_denoise.json"), summary, indent=2))
    return written


def run_tiled_command(
    kind: str,
    in_path,
    out_path,
    params: dict,
    options: TileOptions,
    *,
    normal_params=None,
    label_colors=None,
):
    """Run a command by tiles and write OUT (and its side files).

    Parameters
    ----------
    kind : {"normals", "features", "segment", "denoise"}
    in_path, out_path : path-like
    params : dict
        The command's resolved parameters.
    options : TileOptions
    normal_params : dict, optional
        ``k`` (and ``orient_k``, ``orient``: "mst" when not given, or "up") of normals
        estimated by tiles: first (segment, normal voting on an input without
        normals), or with the equal-weight features from the same k-NN (``features
        --normals``).
    label_colors : callable, optional
        ``labels -> (N, 3) uint8`` colours written with segment labels.

    Returns
    -------
    summary : dict
        Points, tiles, halo, seconds, quality measures (segment).
    written : list of pathlib.Path
    """
    in_path, out_path = Path(in_path), Path(out_path)
    t0 = time.perf_counter()
    if _streamable(in_path, out_path):
        extra = None
        if kind == "segment" and label_colors is not None:

            def extra(labels, tmp):
                n = labels.size
                cols = np.lib.format.open_memmap(tmp / "colors.npy", "w+", np.uint8, (n, 3))
                for s in range(0, n, 1 << 22):
                    cols[s : s + (1 << 22)] = label_colors(np.asarray(labels[s : s + (1 << 22)]))
                    release_pages(cols, labels)
                return {"colors": cols}

        summary = las_tiled(
            kind,
            in_path,
            out_path,
            params,
            options,
            normal_params=normal_params,
            extra_fields=extra,
        )
    else:
        summary = _in_memory(kind, in_path, out_path, params, options, normal_params, label_colors)
    summary["seconds_total"] = round(time.perf_counter() - t0, 3)
    summary["input"] = str(in_path)
    written = [out_path, *_side_outputs(kind, out_path, summary)]
    return summary, written


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


def _in_memory(kind, in_path, out_path, params, options, normal_params, label_colors):
    from ..io import merge_attributes, write_point_set

    need_normals = kind in ("segment", "denoise", "features")
    ps = _read_whole(in_path, with_normals=False)
    given = None
    if kind == "normals" or need_normals:
        try:
            given = _read_whole(in_path).normals
        except PointAtlasError:
            given = None
    summary = {"points": ps.n_points}
    ours = {}
    out_points, out_normals = ps.points, given
    with tile_client(options) as ci:
        summary["scheduler"] = ci[1]
        normals = given
        if normal_params is not None:
            normals, run_n = normals_over(
                ArraySource(ps.points),
                replace(options, halo=None),
                k=normal_params["k"],
                orient=normal_params.get("orient", "mst"),
                orient_k=normal_params.get("orient_k", 10),
                viewpoint=None,
                client_info=ci,
            )
            summary["normals_tiles"] = run_n.summary()
            if given is not None:
                ours["input_normals"] = given
            out_normals = normals
        if kind == "normals":
            out_normals, run = normals_over(
                ArraySource(ps.points), options, client_info=ci, **params
            )
            if given is not None:
                ours["input_normals"] = given
        elif kind == "features":
            src = ArraySource(ps.points, normals if params["mode"] == "optimal" else None)
            fields, run = features_over(src, options, params, client_info=ci)
            las_out = Path(out_path).suffix.lower() in LAS_EXTENSIONS
            ours.update(las_feature_fields(fields) if las_out else fields)
        elif kind == "segment":
            labels, quality, run = segment_over(
                ArraySource(ps.points, normals), options, params, client_info=ci
            )
            summary["quality"] = {k: quality[k] for k in ("n_regions", "energy", "mse")}
            summary["regions"] = quality
            ours["label"] = labels
            if label_colors is not None:
                ours["colors"] = label_colors(labels)
        elif kind == "denoise":
            src = ArraySource(ps.points, normals)
            out, run = denoise_over(src, options, params, client_info=ci)
            summary["spacing"] = out["spacing"]
            out_points, out_normals = out["points"], out["normals"]
            ours.update({k: v for k, v in out.items() if k not in ("points", "normals", "spacing")})
        summary["tiles"] = run.summary()
        summary.update({f"tiles_{k}": v for k, v in run.extra.items() if np.isscalar(v)})
    base = dict(ps.attributes)
    colors = ours.pop("colors", None) if "colors" not in base else None
    merged = merge_attributes(base, ours)
    fields = {k: v for k, v in merged.items() if k not in base}
    if colors is not None:
        fields["colors"] = colors
    write_point_set(out_path, ps.replace(points=out_points, normals=out_normals), attributes=fields)
    return summary


def input_has_normals(path) -> bool:
    """Whether IN stores usable normals (LAS/LAZ: ``nx, ny, nz`` dimensions)."""
    p = Path(path)
    if p.suffix.lower() in LAS_EXTENSIONS:
        from ._tiles_las import LasSource

        return LasSource(p).has_normals
    try:
        return _read_whole(p).normals is not None
    except PointAtlasError:
        return False


def normal_params_for(path, estimate, normal_k: int):
    """``--estimate-normals`` semantics of `read_with_normals` for the tiled path:
    None -> estimate only when IN has no normals; True -> always; False -> never
    (an input without normals is then an error)."""
    if estimate:
        return {"k": int(normal_k), "orient_k": 10}
    if input_has_normals(path):
        return None
    if estimate is False:
        raise PointAtlasError(
            f"{path}: the input has no normals; drop --no-estimate-normals to estimate them"
        )
    return {"k": int(normal_k), "orient_k": 10}


def feature_params(*, weights, k, k_range, a_grid, b_grid, flatness, criterion, has_normals):
    """The feature mode of ``pointatlas features``'s flags (as its untiled dispatch):
    equal weights -> "fixed" (k, default 14) or "optimal_k" (k_range); sigmoid ->
    "optimal" over k_range (default 6..20, or k..k)."""
    if weights not in ("auto", "sigmoid", "equal"):
        raise PointAtlasError(f"--weights must be sigmoid, equal or auto; got {weights!r}")
    if weights == "auto":
        weights = "sigmoid" if has_normals else "equal"
    if weights == "sigmoid" and not has_normals:
        raise PointAtlasError(
            "--weights sigmoid needs normals; the input has none (use --weights equal "
            "or a mesh / a point file with nx, ny, nz)"
        )
    if k is not None and k_range is not None:
        raise PointAtlasError("give --k or --k-range, not both")
    flat = tuple(int(v) for v in flatness)
    if weights == "equal":
        if k_range is None:
            return {"mode": "fixed", "k": 14 if k is None else int(k), "flatness": flat}
        return {
            "mode": "optimal_k",
            "k_range": tuple(k_range),
            "criterion": criterion,
            "flatness": flat,
        }
    kr = tuple(k_range) if k_range is not None else ((k, k) if k is not None else (6, 20))
    return {
        "mode": "optimal",
        "k_range": kr,
        "a_grid": tuple(a_grid),
        "b_grid": tuple(b_grid),
        "flatness": flat,
    }


def segment_params(
    *,
    method,
    options=None,
    seeds="all",
    weights="uniform",
    classic=False,
    k=8,
    eta=None,
    max_angle_deg=None,
    split=True,
    merge=True,
    switch="batch",
):
    """``pointatlas segment``'s settings for the tiled path: one
    `pointatlas.segment.VSAOptions` (``options``, as the untiled command builds it;
    or built here from the flags), checked to be stitchable (VSA from every point,
    uniform weights), or a one-line error."""
    from ..segment import VSAOptions
    from ._tiles_segment import vsa_options

    if method != "vsa":
        raise PointAtlasError(f"--method {method} cannot run by tiles; only vsa is stitched")
    if options is None:
        if classic:
            raise PointAtlasError(f"--classic {_REFUSED}")
        if seeds != "all":
            raise PointAtlasError("--seeds must be 'all' with --tile-size (regions grow per tile)")
        if weights != "uniform":
            raise PointAtlasError("--weights must be uniform with --tile-size")
        angle = None if max_angle_deg is None else math.radians(max_angle_deg)
        options = VSAOptions(
            k=int(k), eta=eta, max_angle=angle, split=bool(split), merge=bool(merge), switch=switch
        )
    return vsa_options(options)


def denoise_params(
    path,
    *,
    method,
    estimate,
    rho,
    tau,
    n_iter,
    filter_iter,
    max_step,
    k,
    eta,
    eps,
    schedule,
    k_start,
):
    """``pointatlas denoise``'s flags for the tiled path ("auto": the method the untiled
    command runs, `pointatlas.denoise.choose_method`: normal voting)."""
    if method == "auto":
        from ..denoise import choose_method

        method = choose_method(np.zeros((1, 3)))
    if method == "flatness":
        return {
            "method": method,
            "k": int(k),
            "eta": eta,
            "eps": eps,
            "n_iter": 60 if n_iter is None else int(n_iter),
            "schedule": schedule,
            "k_start": k_start,
        }
    if n_iter is None:  # untiled: rounds until the points settle; no halo bounds that
        raise PointAtlasError(
            f"--method {method} with --tile-size needs --n-iter (the halo covers a fixed "
            "number of iterations)"
        )
    n_iter = int(n_iter)
    return {
        "method": method,
        "rho": rho,
        "tau": tau,
        "n_iter": n_iter,
        "filter_iter": int(filter_iter),
        "max_step": max_step,
    }
