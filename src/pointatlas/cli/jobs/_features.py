"""The job of ``pointatlas features``: per-point eigen-features, optimal
neighbourhoods, pictures.

Thesis 5.2-5.4 and 6.1-6.2 (docs/decisions/features.md). Writes every feature, the chosen
(a, b, k) and the reason codes as PLY scalar fields (CloudCompare shows them as
scalar fields), and with ``render`` the pictures of Fig. 5.3 and Figs. 6.2/6.5.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError, as_float_array
from ...batch import NormalsTileJob, input_has_normals, las_feature_fields
from ...features import (
    DIMENSION_CLASSES,
    FEATURE_NAMES,
    REASON_CODES,
    THESIS_ANGLE_GRID,
    FeatureResult,
    classify_dimension,
    covariance_features,
    optimal_k_features,
    optimal_neighborhood,
)
from .._flag_checks import feature_counts
from .._outputs import check_outputs, check_point_output, write_point_output
from .._reports import REPORT_EXTENSIONS, report_layer, report_summary, report_up
from ._inputs import fill_unusable_normals, read_input, read_keeping_normals
from ._normals import normals_and_table
from ._tiled import feature_job, feature_weighting, run_tiled

__all__ = [
    "FeaturesOptions",
    "FeaturesResult",
    "compute_features_for",
    "feature_picture_paths",
    "feature_statistics",
    "reason_counts",
    "render_feature_pictures",
    "run_features",
]


@dataclass(frozen=True)
class FeaturesOptions:
    """The settings of ``pointatlas features`` (the flags of the same names).

    ``k`` or ``k_range``; ``weights`` (``--weighting``): sigmoid, equal or auto;
    ``a_grid``, ``b_grid``: the angle grids in degrees as typed (``"0,30,60"``; None:
    the thesis' grid); ``flatness``: (M1, M2); ``criterion`` of the equal-weight k
    search; ``estimate_normals`` (oriented by ``orient``: mst or up) from the
    features' own k-NN; ``render`` (PNG, ``render_size`` pixels per panel) and
    ``report`` (HTML).
    """

    k: int | None = None
    k_range: tuple[int, int] | None = None
    weights: str = "auto"
    a_grid: str | None = None
    b_grid: str | None = None
    flatness: tuple[int, int] = (8, 8)
    criterion: str = "e_dim"
    estimate_normals: bool = False
    orient: str | None = None
    render: Path | None = None
    render_size: int = 800
    report: Path | None = None


@dataclass(frozen=True)
class FeaturesResult:
    """What `run_features` did: the features, the mode in words, the seconds, OUT,
    the pictures and the report (None when not asked); by tiles only ``tiled``, the
    tiled run's summary."""

    result: FeatureResult | None
    mode: str = ""
    seconds: float = 0.0
    written: Path | None = None
    pictures: tuple = ()
    report: Path | None = None
    tiled: dict | None = None


def run_features(in_path, out_path, options: FeaturesOptions, tiles=None) -> FeaturesResult:
    """``pointatlas features``: IN read (normals estimated in the features' pass with
    ``estimate_normals``), features computed, OUT written with every input field and
    ours, then the pictures and the report; by tiles when ``tiles`` (a
    `pointatlas.batch.TileOptions`) is given."""
    from ...io import POINT_WRITE_EXTENSIONS

    o = options
    render, estimate = o.render, o.estimate_normals
    picture_paths = feature_picture_paths(render) if render is not None else (None,) * 3
    check_outputs(
        [in_path],
        [
            ("OUT", out_path, POINT_WRITE_EXTENSIONS),
            ("--report", o.report, REPORT_EXTENSIONS),
            *(("--render", p, (".png",)) for p in picture_paths),
        ],
    )
    a_vals = _parse_grid_deg(o.a_grid, "--a-grid-deg")
    b_vals = _parse_grid_deg(o.b_grid, "--b-grid-deg") if o.b_grid is not None else a_vals
    weights = _weights_with_normals(o.weights, estimate)
    orient = _orient_for(o.orient, estimate)
    if tiles is not None:
        return FeaturesResult(
            None, tiled=_run_tiles(in_path, out_path, o, tiles, weights, orient, a_vals, b_vals)
        )
    ps, ours, table, t0 = _read_for(in_path, out_path, estimate, o.k, o.k_range, orient)
    feature_counts(o.k, o.k_range)(ps.n_points)
    result, mode = compute_features_for(
        ps.points,
        ps.normals,
        k=o.k,
        k_range=tuple(o.k_range) if o.k_range is not None else None,
        weights=weights,
        a_grid=a_vals,
        b_grid=b_vals,
        flatness=tuple(o.flatness),
        criterion=o.criterion,
        neighbors=table,
    )
    elapsed = time.perf_counter() - t0
    fields = result.scalar_fields()
    fields["dimension_class"] = classify_dimension(result)
    written = write_point_output(out_path, ps, {**ours, **_as_written(out_path, fields)})
    pictures = []
    if render is not None:
        energies = result if mode.startswith("fixed") else None
        pictures = render_feature_pictures(
            render,
            ps.points,
            ps.normals,
            result,
            name=Path(in_path).stem,
            energies=energies,
            size=o.render_size,
        )
    if o.report is not None:
        parameters = {
            "k": o.k,
            "k_range": o.k_range,
            "weights": weights,
            "a_grid_deg": o.a_grid,
            "b_grid_deg": o.b_grid,
            "flatness": o.flatness,
            "criterion": o.criterion,
            "normals": estimate,
            "orient": orient if estimate else None,
        }
        _write_features_report(
            o.report, in_path, ps, result, fields, mode, elapsed, pictures, parameters
        )
    return FeaturesResult(result, mode, elapsed, written, tuple(pictures), o.report)


def _run_tiles(in_path, out_path, o: FeaturesOptions, tiles, weights, orient, a_vals, b_vals):
    """``--tile-size``: the features (and normals) by tiles on dask (`pointatlas.batch`)."""
    job = feature_job(
        weights=weights,
        k=o.k,
        k_range=o.k_range,
        a_grid=a_vals,
        b_grid=b_vals,
        flatness=o.flatness,
        criterion=o.criterion,
        has_normals=not o.estimate_normals and input_has_normals(in_path),
    )
    normals = (
        NormalsTileJob(k=14 if o.k is None else o.k, orient_k=10, orient=orient)
        if o.estimate_normals
        else None
    )
    return run_tiled(
        "features",
        job,
        in_path,
        out_path,
        tiles,
        normals=normals,
        report=o.report,
        parameters=job.params,
        color_by="dimension_class",
        checks=(feature_counts(o.k, o.k_range),),
    )


def _parse_grid_deg(text: str | None, name: str) -> tuple[float, ...]:
    if text is None:
        return THESIS_ANGLE_GRID
    try:
        vals = [float(v) for v in text.replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise PointAtlasError(
            f"{name} must be comma-separated angles in degrees, e.g. 0,30,60; got {text!r}"
        ) from None
    arr = as_float_array(vals, name, lo=0.0, hi=180.0, what="angles", unit="degrees")
    return tuple(math.pi if v == 180.0 else math.radians(v) for v in arr.tolist())


def compute_features_for(
    points,
    normals,
    *,
    k: int | None = None,
    k_range: tuple[int, int] | None = None,
    weights: str = "auto",
    a_grid=THESIS_ANGLE_GRID,
    b_grid=THESIS_ANGLE_GRID,
    flatness=(8, 8),
    criterion: str = "e_dim",
    neighbors=None,
) -> tuple[FeatureResult, str]:
    """Dispatch to fixed-k / optimal-k / optimal (a, b, k); returns (result, mode text).
    ``neighbors``: a k-NN table of at least the largest k (equal weights only)."""
    weights = feature_weighting(weights, has_normals=normals is not None, k=k, k_range=k_range)
    if weights == "equal":
        if k_range is None:
            kk = 14 if k is None else k
            nb = None if neighbors is None else np.ascontiguousarray(neighbors[:, :kk])
            res = covariance_features(points, kk, flatness=flatness, neighbors=nb)
            return res, f"fixed k = {kk}"
        nb = None if neighbors is None else np.ascontiguousarray(neighbors[:, : k_range[1]])
        res = optimal_k_features(
            points, k_range=k_range, criterion=criterion, flatness=flatness, neighbors=nb
        )
        return res, f"optimal k in {k_range[0]}..{k_range[1]} by {criterion}, equal weights"
    kr = k_range if k_range is not None else ((k, k) if k is not None else (6, 20))
    res = optimal_neighborhood(
        points, normals, a_grid=a_grid, b_grid=b_grid, k_range=kr, flatness=flatness
    )
    n_pairs = sum(1 for a in a_grid for b in b_grid if a <= b)
    return res, f"optimal (a, b, k): {n_pairs} (a, b) pairs x k in {kr[0]}..{kr[1]}"


def feature_picture_paths(path) -> tuple[Path, Path, Path]:
    """The three PNGs of ``features --render PATH.png``: PATH itself (Fig. 5.3) and,
    beside it, ``<stem>_fig6_5.png`` (Figs. 6.2/6.5) and ``<stem>_flatness.png``."""
    p = Path(path)
    return p, p.with_name(f"{p.stem}_fig6_5.png"), p.with_name(f"{p.stem}_flatness.png")


def render_feature_pictures(
    path, points, normals, result: FeatureResult, *, name: str, energies=None, size: int = 800
):
    """Fig. 5.3 (E_dim, dimension classes) and Figs. 6.2/6.5 (four energies) as PNGs.

    ``path`` is the Fig. 5.3 picture; the others go beside it
    (`feature_picture_paths`). ``name`` titles the pictures. ``energies`` is the
    result drawn in the energy pictures; the thesis (6.2) uses equal weights and
    k = 14, which is computed here when omitted.
    """
    from ...viz import PointsPanel, render_points, render_side_by_side

    if energies is None:
        energies = covariance_features(points, 14, flatness=result.flatness_exponents)
    k_text = f"k = {int(energies.k.max())}" if energies.k.size else ""

    fig5_3, fig6_5, flatness = feature_picture_paths(path)
    e_dim = np.where(np.isfinite(result.e_dim), result.e_dim, np.nan)
    cls = classify_dimension(result)
    counts = [int((cls == c).sum()) for c in range(3)]
    written = [
        render_side_by_side(
            fig5_3,
            [
                PointsPanel(
                    points,
                    normals=normals,
                    scalars=e_dim,
                    scalar_name="E_dim",
                    title="E_dim (Eq. 5.7), grey = degenerate",
                ),
                PointsPanel(
                    points,
                    normals=normals,
                    labels=cls,
                    title="largest of L / P / S: "
                    + ", ".join(f"{c} {n}" for c, n in zip(DIMENSION_CLASSES, counts, strict=True)),
                ),
            ],
            title=f"{name}: classification error and dimension classes",
            size=(2 * size, size),
        )
    ]
    panels = [
        ("flatness", f"flatness m = {energies.flatness_exponents}"),
        ("omnivariance", "omnivariance"),
        ("anisotropy", "anisotropy (reversed)"),
        ("change_of_curvature", "change of curvature"),
    ]
    written.append(
        render_side_by_side(
            fig6_5,
            [
                PointsPanel(
                    points,
                    normals=normals,
                    scalars=getattr(energies, f),
                    scalar_name=f,
                    cmap="Blues",
                    title=t,
                )
                for f, t in panels
            ],
            title=f"{name}: eigenvalue energies (Eqs. 6.1, 6.2), equal weights, {k_text}",
            size=(4 * size, size),
        )
    )
    written.append(
        render_points(
            flatness,
            points,
            normals=normals,
            scalars=energies.flatness,
            scalar_name="flatness",
            cmap="Blues",
            title=f"{name}: flatness (Eq. 6.1, m1, m2 = {energies.flatness_exponents}), {k_text}",
            size=(size, size),
        )
    )
    return written


def _read_checked(input_path, output):
    """Read IN (points without a usable stored normal get one from their neighbours,
    with a note: `fill_unusable_normals`) and check that OUT can hold the input's
    fields and ours, before computing."""
    ps = read_input(input_path, zero_normals="drop")
    if "source_index" in ps.attributes:
        ps = fill_unusable_normals(input_path, ps, 20)
    check_point_output(output, ps, _placeholder(ps.n_points))
    return ps


def _placeholder(n: int) -> dict:
    """Zero arrays named and typed as the fields ``features`` writes (output checks)."""
    names = [*(f"eigenvalue_{i}" for i in (1, 2, 3)), *FEATURE_NAMES, "k", "a", "b", "reason"]
    fields = {name: np.zeros(n) for name in names}
    fields["dimension_class"] = np.zeros(n, np.int64)
    return fields


def _weights_with_normals(weights: str, estimate: bool) -> str:
    """``--estimate-normals`` computes the normals in the features' pass: equal weights only."""
    if not estimate:
        return weights
    if weights == "sigmoid":
        raise PointAtlasError(
            "--estimate-normals computes the normals in the same pass as the features; sigmoid "
            "weights need them first: run `pointatlas normals`, then `features`"
        )
    return "equal" if weights == "auto" else weights


def _read_for_normals(input_path, output):
    """IN for ``--estimate-normals``: every point (as `normals` reads it), the input's normals
    kept as ``input_normals``; OUT checked for them, the normals and the features."""
    ps, ours = read_keeping_normals(input_path)
    n = ps.n_points
    check_point_output(output, ps.replace(normals=np.ones((n, 3))), {**ours, **_placeholder(n)})
    return ps, ours


def _read_for(input_path, output, estimate: bool, k, k_range, orient: str = "mst"):
    """(point set, fields kept, shared k-NN table or None, start time) of an untiled run;
    with ``estimate`` the normals are computed here (oriented by ``orient``, timed with
    the features)."""
    if not estimate:
        ps = _read_checked(input_path, output)
        return ps, {}, None, time.perf_counter()
    ps, ours = _read_for_normals(input_path, output)
    t0 = time.perf_counter()
    kf = (14 if k is None else k) if k_range is None else k_range[1]
    ps, table = _normals_and_table(ps, 14 if k is None else k, kf, orient)
    return ps, ours, table, t0


def _normals_and_table(ps, k: int, kf: int, orient: str = "mst"):
    """PCA normals at ``k`` oriented by ``orient`` ("mst": orientation graph k = 10, as
    `normals`; "up") and the k-NN table they share with the features (``kf`` columns at
    least)."""
    n = ps.n_points
    if k < 3 or k > n or kf > n:
        raise PointAtlasError(f"--k must lie in [3, number of points = {n}]; got {max(k, kf)}")
    normals, (table, _) = normals_and_table(
        ps.points,
        k=k,
        orient=orient,
        orient_k=10,
        viewpoint=None,
        advance=lambda: None,
        min_cols=kf,
    )
    return ps.replace(normals=normals), table


def _as_written(output, fields: dict) -> dict:
    """The fields as OUT stores them: LAS/LAZ keeps the float features as float32
    extra bytes (docs/decisions/io.md, "LAS/LAZ: feature fields as float32")."""
    if Path(output).suffix.lower() not in (".las", ".laz"):
        return fields
    return las_feature_fields(fields)


def _write_features_report(
    report, input_path, ps, result, fields, mode, elapsed, pictures, parameters
) -> None:
    """The HTML report of ``features``: counts, per-field statistics, a 3-D view."""
    from ...viz import write_report

    counts = {"mode": mode, "points": result.n_points, "seconds": round(elapsed, 3)}
    counts.update({f"degenerate: {REASON_CODES[int(c)]}": int(m) for c, m in reason_counts(result)})
    write_report(
        report,
        title=f"pointatlas features: {Path(input_path).name}",
        summary=report_summary(input_path, ps),
        parameters=parameters,
        tables={"result": counts, "fields": feature_statistics(fields)},
        pictures=pictures,
        layers=[report_layer(ps, fields, color_by="dimension_class")],
        up=report_up(input_path),
    )


#: Orientations of ``features --estimate-normals``.
NORMALS_ORIENT = ("mst", "up")


def _orient_for(orient, estimate: bool) -> str:
    """``--orient`` checked: with ``--estimate-normals`` mst (default) or up; else not given."""
    if not estimate:
        if orient is not None:
            raise PointAtlasError("--orient only applies with --estimate-normals")
        return "mst"
    orient = "mst" if orient is None else orient
    if orient not in NORMALS_ORIENT:
        raise PointAtlasError(
            f"--orient with --estimate-normals must be one of {', '.join(NORMALS_ORIENT)}; "
            f"got {orient!r}"
        )
    return orient


def reason_counts(result: FeatureResult) -> list[tuple[int, int]]:
    """(reason code, number of points) of every non-zero reason."""
    codes, counts = np.unique(result.reason, return_counts=True)
    return [(int(c), int(m)) for c, m in zip(codes, counts, strict=True) if c]


def feature_statistics(fields: dict) -> list[dict]:
    """One row per per-point field: mean, min, max over the finite values, NaN count."""
    rows = []
    for name, values in fields.items():
        arr = np.asarray(values, dtype=np.float64)
        ok = np.isfinite(arr)
        row = {"field": name, "mean": None, "min": None, "max": None}
        if ok.any():
            row.update(
                mean=float(arr[ok].mean()), min=float(arr[ok].min()), max=float(arr[ok].max())
            )
        row["non-finite"] = int((~ok).sum())
        rows.append(row)
    return rows
