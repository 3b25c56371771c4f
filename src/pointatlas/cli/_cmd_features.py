"""``pointatlas features``: per-point eigen-features, optimal neighbourhoods, pictures.

Thesis 5.2-5.4 and 6.1-6.2 (docs/decisions/features.md). Writes every feature, the chosen
(a, b, k) and the reason codes as PLY scalar fields (CloudCompare shows them as
scalar fields), and with ``--render`` the pictures of Fig. 5.3 and Figs. 6.2/6.5.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError, as_float_array
from ..batch import NormalsTileJob, input_has_normals, las_feature_fields
from ..features import (
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
from ._app import (
    HaloOption,
    InputArgument,
    MaxMemoryOption,
    ReportOption,
    SchedulerOption,
    TileSizeOption,
    WorkersOption,
    app,
    console,
    demo_step,
    deprecated_option,
    fill_unusable_normals,
    guarded,
    read_input,
    renamed_flag,
    run_tiled,
    say,
    tile_options,
)
from ._outputs import check_outputs, check_point_output, write_point_output
from ._reports import REPORT_EXTENSIONS, report_layer, report_summary, report_up
from .jobs import feature_job, feature_weighting, normals_and_table, read_keeping_normals

__all__ = [
    "compute_features_for",
    "demo_features",
    "feature_picture_paths",
    "feature_statistics",
    "features_command",
    "render_feature_pictures",
]


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
    from ..viz import PointsPanel, render_points, render_side_by_side

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


def _print_features(input_path, result, mode: str, elapsed: float, written) -> None:
    """The console lines of ``features``: size, mode, means, degenerate points."""
    n = result.n_points
    say(f"{input_path.name}: {n} points, {mode} ({elapsed:.2f} s)")
    ok = result.is_valid
    if ok.any():
        console.print(
            f"  E_dim mean {np.mean(result.e_dim[ok]):.4f}, flatness mean "
            f"{np.mean(result.flatness[ok]):.4f}"
        )
    for code, count in _reason_counts(result):
        console.print(f"  {count} point(s) degenerate: {REASON_CODES[code]} (NaN)")
    say(f"  wrote {written}")


def _write_features_report(
    report, input_path, ps, result, fields, mode, elapsed, pictures, parameters
) -> None:
    """The HTML report of ``features``: counts, per-field statistics, a 3-D view."""
    from ..viz import write_report

    counts = {"mode": mode, "points": result.n_points, "seconds": round(elapsed, 3)}
    counts.update(
        {f"degenerate: {REASON_CODES[int(c)]}": int(m) for c, m in _reason_counts(result)}
    )
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
    say(f"  wrote {report}")


#: ``--render PATH.png`` (Fig. 5.3; the other pictures beside it, `feature_picture_paths`)
_RenderOption = Annotated[
    Path | None,
    typer.Option(
        "--render",
        help="PNG of Fig. 5.3; Figs. 6.2/6.5 and the flatness go beside it "
        "(<stem>_fig6_5.png, <stem>_flatness.png).",
    ),
]
_RenderSizeOption = Annotated[
    int, typer.Option("--render-size", min=64, help="Pixels per picture panel.")
]
_NormalsOption = Annotated[
    bool,
    typer.Option(
        "--estimate-normals",
        help="Also estimate PCA normals at --k (default 14), oriented by --orient, from the "
        "same k-NN table as the features (equal weights); written as nx, ny, nz.",
    ),
]
#: ``--orient`` of ``--estimate-normals`` (`NORMALS_ORIENT`; docs/decisions/batch.md, "Tiles —
#: normals and features in one pass")
_OrientOption = Annotated[
    str | None,
    typer.Option(
        "--orient",
        help="With --estimate-normals: mst (default; Hoppe's propagation, as `normals`) or up "
        "(nz >= 0 per point, the lidar convention; by tiles no stitching, cheaper).",
    ),
]
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


@app.command("features")
@guarded
def features_command(
    input_path: InputArgument,
    output: Annotated[
        Path, typer.Argument(metavar="OUT", help="Output point file (.ply, .las, .laz).")
    ],
    k: Annotated[
        int | None, typer.Option("--k", help="Fixed neighbourhood size (default 14).", min=3)
    ] = None,
    k_range: Annotated[
        tuple[int, int] | None,
        typer.Option("--k-range", help="Search k in KMIN..KMAX (thesis: 6 20)."),
    ] = None,
    weights: Annotated[
        str,
        typer.Option(
            "--weighting",
            help="sigmoid: search the (a, b) grid on normal angles (Eq. 5.9); equal: "
            "unweighted; auto: sigmoid when the input has normals.",
        ),
    ] = "auto",
    a_grid: Annotated[
        str | None,
        typer.Option("--a-grid-deg", help="a values in degrees, e.g. 0,30,60."),
    ] = None,
    b_grid: Annotated[
        str | None,
        typer.Option("--b-grid-deg", help="b values in degrees (default as a)."),
    ] = None,
    flatness: Annotated[
        tuple[int, int], typer.Option("--flatness", help="Even exponents M1 M2 of Eq. 6.1.")
    ] = (8, 8),
    criterion: Annotated[
        str,
        typer.Option("--criterion", help="Equal-weight k search: e_dim or eigenentropy."),
    ] = "e_dim",
    estimate_normals: _NormalsOption = False,
    orient: _OrientOption = None,
    render: _RenderOption = None,
    render_size: _RenderSizeOption = 800,
    report: ReportOption = None,
    tile_size: TileSizeOption = None,
    halo: HaloOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    max_memory: MaxMemoryOption = None,
    old_weights: Annotated[str | None, deprecated_option("--weights", "--weighting")] = None,
    old_normals: Annotated[bool, deprecated_option("--normals", "--estimate-normals")] = False,
) -> None:
    """Eigen-features per point (linearity ... flatness) with the optimal neighbourhood.

    Writes OUT with every input field kept and the features added (a feature whose
    name the input already uses gets the prefix ``pa_``); with ``--report`` also an
    HTML report with per-field statistics and a 3-D view. ``--estimate-normals`` does the work
    of ``normals --k K --orient O`` then ``features --k K --weighting equal`` in one pass
    (one k-NN query); the input's normals are kept as ``input_normals``.
    """
    from ..io import POINT_WRITE_EXTENSIONS

    weights = renamed_flag("--weighting", weights, "--weights", old_weights)
    estimate_normals = renamed_flag(
        "--estimate-normals", estimate_normals, "--normals", old_normals
    )
    picture_paths = feature_picture_paths(render) if render is not None else (None,) * 3
    check_outputs(
        [input_path],
        [
            ("OUT", output, POINT_WRITE_EXTENSIONS),
            ("--report", report, REPORT_EXTENSIONS),
            *(("--render", p, (".png",)) for p in picture_paths),
        ],
    )
    a_vals = _parse_grid_deg(a_grid, "--a-grid-deg")
    b_vals = _parse_grid_deg(b_grid, "--b-grid-deg") if b_grid is not None else a_vals
    weights = _weights_with_normals(weights, estimate_normals)
    orient = _orient_for(orient, estimate_normals)
    tiles = tile_options(tile_size, halo, workers, scheduler, max_memory, render=render)
    if tiles is not None:
        job = feature_job(
            weights=weights,
            k=k,
            k_range=k_range,
            a_grid=a_vals,
            b_grid=b_vals,
            flatness=flatness,
            criterion=criterion,
            has_normals=not estimate_normals and input_has_normals(input_path),
        )
        normals = (
            NormalsTileJob(k=14 if k is None else k, orient_k=10, orient=orient)
            if estimate_normals
            else None
        )
        run_tiled(
            "features",
            job,
            input_path,
            output,
            tiles,
            normals=normals,
            report=report,
            parameters=job.params,
            color_by="dimension_class",
        )
        return
    ps, ours, table, t0 = _read_for(input_path, output, estimate_normals, k, k_range, orient)
    result, mode = compute_features_for(
        ps.points,
        ps.normals,
        k=k,
        k_range=tuple(k_range) if k_range is not None else None,
        weights=weights,
        a_grid=a_vals,
        b_grid=b_vals,
        flatness=tuple(flatness),
        criterion=criterion,
        neighbors=table,
    )
    elapsed = time.perf_counter() - t0
    fields = result.scalar_fields()
    fields["dimension_class"] = classify_dimension(result)
    written = write_point_output(output, ps, {**ours, **_as_written(output, fields)})
    _print_features(input_path, result, mode, elapsed, written)
    pictures = []
    if render is not None:
        fixed_equal = mode.startswith("fixed")
        energies = result if fixed_equal else None
        pictures = render_feature_pictures(
            render,
            ps.points,
            ps.normals,
            result,
            name=Path(input_path).stem,
            energies=energies,
            size=render_size,
        )
        for p in pictures:
            say(f"  wrote {p}")
    if report is not None:
        parameters = {
            "k": k,
            "k_range": k_range,
            "weights": weights,
            "a_grid_deg": a_grid,
            "b_grid_deg": b_grid,
            "flatness": flatness,
            "criterion": criterion,
            "normals": estimate_normals,
            "orient": orient if estimate_normals else None,
        }
        _write_features_report(
            report, input_path, ps, result, fields, mode, elapsed, pictures, parameters
        )


def _reason_counts(result: FeatureResult) -> list[tuple[int, int]]:
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


@demo_step
def demo_features(ps, out_dir: Path, console) -> None:
    """Features: optimal normal-weighted neighbourhoods and the fandisk classification."""
    from rich.table import Table

    from ..io import write_point_set

    if not ps.has_normals:
        raise PointAtlasError("the demo model has no normals")
    t0 = time.perf_counter()
    from ..experiments.weightings import fig_5_3

    stats, written = fig_5_3(ps.points, ps.normals, out_dir, name=ps.name)
    seconds = time.perf_counter() - t0
    best = optimal_neighborhood(ps.points, ps.normals)
    fields = best.scalar_fields()
    fields["dimension_class"] = classify_dimension(best)
    write_point_set(out_dir / f"{ps.name}_features.ply", ps, attributes=fields)
    table = Table(title=f"Fig. 5.3 on {ps.name} ({seconds:.1f} s)")
    for col in ("weights", "mean E_dim", "degenerate", "linear / planar / scattered"):
        table.add_column(col)
    for title, s in stats.items():
        table.add_row(
            title,
            f"{s['mean_e_dim']:.4f}",
            str(s["n_degenerate"]),
            " / ".join(str(c) for c in s["classes"]),
        )
    console.print(table)
