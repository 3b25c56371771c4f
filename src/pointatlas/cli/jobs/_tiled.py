"""The ``--tile-size`` branch of ``normals``, ``features``, ``segment`` and ``denoise``.

The flags become a `pointatlas.batch.TileOptions` (`tile_options`) and the command's
settings a batch job object (`NormalsTileJob`, `FeaturesTileJob`, `SegmentTileJob`,
`DenoiseTileJob`); `run_tiled` runs it on the files (`pointatlas.batch.run_tile_job`),
writes the command's side files and report, and prints the summary.
"""

from __future__ import annotations

import csv
import io
import sys
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError
from ...batch import (
    DenoiseTileJob,
    FeaturesTileJob,
    NormalsTileJob,
    SegmentTileJob,
    TileOptions,
    input_has_normals,
    input_point_count,
    run_tile_job,
)
from ._console import say

__all__ = [
    "denoise_job",
    "denoise_side_files",
    "feature_job",
    "feature_weighting",
    "normal_job_for",
    "refuse",
    "run_tiled",
    "segment_job",
    "segment_side_files",
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
    tile_size, halo=None, workers=None, scheduler=None, max_memory=None, **refused
) -> TileOptions | None:
    """`TileOptions` from the tile flags, or None without ``--tile-size``.

    The other tile flags without ``--tile-size`` are an error (they would do
    nothing); ``refused``: flags that cannot run by tiles (``render=path``), any of
    which given with ``--tile-size`` is a one-line error.
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
    options = TileOptions(
        tile_size=tile_size,
        halo=halo,
        workers=2 if workers is None else workers,
        scheduler=scheduler,
        max_memory=max_memory,
        progress=sys.stderr.isatty(),
    )
    refuse(options, **refused)
    return options


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


def normal_job_for(path, estimate, normal_k: int) -> NormalsTileJob | None:
    """``--estimate-normals`` semantics of `read_with_normals` for the tiled path:
    None -> estimate only when IN has no normals; True -> always; False -> never
    (an input without normals is then an error)."""
    if estimate:
        return NormalsTileJob(k=int(normal_k), orient_k=10)
    if input_has_normals(path):
        return None
    if estimate is False:
        raise PointAtlasError(
            f"{path}: the input has no normals; drop --no-estimate-normals to estimate them"
        )
    return NormalsTileJob(k=int(normal_k), orient_k=10)


def feature_weighting(weights: str, *, has_normals: bool, k, k_range) -> str:
    """``features --weighting`` resolved: "sigmoid" or "equal" ("auto": sigmoid when IN
    has normals), checked with ``--k`` / ``--k-range`` (one of them at most)."""
    if weights not in ("auto", "sigmoid", "equal"):
        raise PointAtlasError(f"--weighting must be sigmoid, equal or auto; got {weights!r}")
    if weights == "auto":
        weights = "sigmoid" if has_normals else "equal"
    if weights == "sigmoid" and not has_normals:
        raise PointAtlasError(
            "--weighting sigmoid needs normals; the input has none (use --weighting equal "
            "or a mesh / a point file with nx, ny, nz)"
        )
    if k is not None and k_range is not None:
        raise PointAtlasError("give --k or --k-range, not both")
    return weights


def feature_job(*, weights, k, k_range, a_grid, b_grid, flatness, criterion, has_normals):
    """The `FeaturesTileJob` of ``pointatlas features``'s flags (as its untiled
    dispatch): equal weights -> "fixed" (k, default 14) or "optimal_k" (k_range);
    sigmoid -> "optimal" over k_range (default 6..20, or k..k)."""
    weights = feature_weighting(weights, has_normals=has_normals, k=k, k_range=k_range)
    flat = tuple(int(v) for v in flatness)
    if weights == "equal":
        if k_range is None:
            params = {"mode": "fixed", "k": 14 if k is None else int(k), "flatness": flat}
        else:
            params = {
                "mode": "optimal_k",
                "k_range": tuple(k_range),
                "criterion": criterion,
                "flatness": flat,
            }
        return FeaturesTileJob(params)
    kr = tuple(k_range) if k_range is not None else ((k, k) if k is not None else (6, 20))
    return FeaturesTileJob(
        {
            "mode": "optimal",
            "k_range": kr,
            "a_grid": tuple(a_grid),
            "b_grid": tuple(b_grid),
            "flatness": flat,
        }
    )


def segment_job(*, method, options, label_colors=None) -> SegmentTileJob:
    """``pointatlas segment``'s `VSAOptions` as a `SegmentTileJob`, refused in one line
    when it cannot be stitched (VSA from every point, uniform weights, not classic)."""
    if method != "vsa":
        raise PointAtlasError(f"--method {method} cannot run by tiles; only vsa is stitched")
    return SegmentTileJob(options, label_colors=label_colors)


def denoise_job(
    *, method, rho, tau, n_iter, filter_iter, max_step, k, eta, eps, schedule, k_start
) -> DenoiseTileJob:
    """``pointatlas denoise``'s flags as a `DenoiseTileJob` ("auto": the method the
    untiled command runs, `pointatlas.denoise.choose_method`: normal voting)."""
    if method == "auto":
        from ...denoise import choose_method

        method = choose_method(np.zeros((1, 3)))
    if method == "flatness":
        return DenoiseTileJob(
            {
                "method": method,
                "k": int(k),
                "eta": eta,
                "eps": eps,
                # None: each tile stops once its points moved about the noise, as
                # the untiled default (at most 60 iterations: the halo's rings)
                "n_iter": None if n_iter is None else int(n_iter),
                "schedule": schedule,
                "k_start": k_start,
            }
        )
    if n_iter is None:  # untiled: rounds until the points settle; no halo bounds that
        raise PointAtlasError(
            f"--method {method} with --tile-size needs --n-iter (the halo covers a fixed "
            "number of iterations)"
        )
    return DenoiseTileJob(
        {
            "method": method,
            "rho": rho,
            "tau": tau,
            "n_iter": int(n_iter),
            "filter_iter": int(filter_iter),
            "max_step": max_step,
        }
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


def segment_side_files(out_path: Path, summary: dict) -> list[Path]:
    """OUT_regions.csv and OUT_regions.json of a tiled ``segment`` (the regions leave
    ``summary`` for the tables)."""
    from ...io import write_json, write_text

    stem = Path(out_path).with_suffix("")
    rows = _region_rows(summary.pop("regions"))
    buf = io.StringIO()
    writer = csv.DictWriter(
        buf, fieldnames=list(rows[0]) if rows else ["region"], lineterminator="\n"
    )
    writer.writeheader()
    writer.writerows(rows)
    payload = {"summary": summary, "regions": rows}
    return [
        write_text(Path(f"{stem}_regions.csv"), buf.getvalue()),
        write_json(Path(f"{stem}_regions.json"), payload, indent=2),
    ]


def denoise_side_files(out_path: Path, summary: dict) -> list[Path]:
    """OUT_denoise.json of a tiled ``denoise``."""
    from ...io import write_json

    stem = Path(out_path).with_suffix("")
    return [write_json(Path(f"{stem}_denoise.json"), summary, indent=2)]


def run_tiled(
    name: str,
    job,
    in_path,
    out_path,
    options: TileOptions,
    *,
    normals: NormalsTileJob | None = None,
    side_files=None,
    report=None,
    parameters=None,
    color_by: str | None = None,
    checks=(),
) -> dict:
    """Run a command's ``job`` by tiles, write its side files (``side_files(OUT,
    summary) -> paths``) and ``report`` (an HTML report whose 3-D view reads every
    n-th point back from OUT, coloured by ``color_by``; ``parameters`` in its table),
    print a summary line and the files written; returns the summary.

    ``checks`` (``n_points -> None`` each, raising `PointAtlasError`; None entries
    skipped) refuse options bounded by the input's size before any work, as the
    untiled commands do (`pointatlas.batch.input_point_count`: a LAS header's count)."""
    checks = [c for c in checks if c is not None]
    if checks:
        n_points = input_point_count(in_path)
        for check in checks:
            check(n_points)
    summary = run_tile_job(job, in_path, out_path, options, normals=normals)
    written = [Path(out_path)]
    if side_files is not None:
        written += side_files(Path(out_path), summary)
    if report is not None:
        from .._reports import write_tiled_report

        written.append(
            write_tiled_report(
                report, name, in_path, out_path, parameters, summary, color_by=color_by
            )
        )
    tiles = summary["tiles"]
    line = (
        f"{name}: {summary['points']:,} points in {tiles['tiles']} tiles of "
        f"{tiles['tile_size']:g} (halo {tiles['halo_min']:.4g}"
        + (f"-{tiles['halo_max']:.4g}" if tiles["halo_max"] != tiles["halo_min"] else "")
        + f", {tiles['points_sent_per_point']:.2f} points sent per point) on "
        f"{summary['scheduler']}, {summary['seconds_total']:.1f} s"
    )
    say(line)
    quality = summary.get("quality")
    if quality:
        say(
            f"  {quality['n_regions']} regions, energy {quality['energy']:.6g}, "
            f"MSE {quality['mse']:.3e}"
        )
    for path in written:
        say(f"wrote {path}")
    return summary
