"""``pointatlas denoise``: normal voting (thesis 5.4, [YRS+18]) or flatness (6.2) denoising.

Writes the moved points with their filtered normals and every input field, a JSON
summary beside the output (with the measures against ``--clean``) and optionally a
picture of the input beside the result.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError, as_float, as_int
from ..denoise import (
    DENOISE_METHODS,
    FLATNESS_SCHEDULES,
    choose_method,
    default_filter_iter,
    denoise_measures,
    flatness_denoise,
    voting_with_pieces,
)
from ._app import (
    EstimateNormalsOption,
    HaloOption,
    InputArgument,
    MaxMemoryOption,
    NormalKOption,
    SchedulerOption,
    TileSizeOption,
    WorkersOption,
    app,
    console,
    deprecated_option,
    err_console,
    guarded,
    progress_bar,
    read_with_normals,
    renamed_flag,
    run_tiled,
    say,
    tile_options,
)
from ._cmd_core import REPORT_EXTENSIONS, report_layer, report_summary, report_up
from ._flag_checks import check_iterations, flatness_counts
from ._outputs import (
    XYZ_EXTENSIONS,
    check_outputs,
    check_point_output,
    write_point_output,
    write_summary_json,
)
from .jobs import denoise_job, denoise_side_files, normal_job_for

__all__ = ["denoise_command", "read_clean", "summary_path"]

#: what `pointatlas denoise` prints with --clean (attribute, label)
MEASURE_ROWS = (
    ("chamfer", "Chamfer (unit sphere, squared)"),
    ("p2m_mean", "point-to-mesh mean"),
    ("p2m_max", "point-to-mesh max"),
    ("normal_mse", "normal MSE (Eq. 5.10)"),
    ("distance_mean", "distance to clean point, mean"),
    ("distance_max", "distance to clean point, max"),
    ("drift_share", "tangential drift > l, share"),
)


def summary_path(output: Path) -> Path:
    """``OUT_denoise.json`` beside ``OUT``."""
    return Path(f"{output.with_suffix('')}_denoise.json")


def read_clean(path: Path):
    """The clean model of ``--clean``: (points, normals or None, triangles or None).

    A mesh file gives its vertices, area-weighted vertex normals and triangles; a
    point file its points and normals (no point-to-mesh distance then).
    """
    from ..io import MESH_EXTENSIONS, read_mesh, read_point_set

    p = Path(path)
    if not p.is_file():
        raise PointAtlasError(f"--clean: no such file: {str(p)!r}")
    if p.suffix.lower() in MESH_EXTENSIONS:
        mesh = read_mesh(p)
        if mesh.n_faces:
            normals = mesh.vertex_normals()
            if not np.isfinite(normals).all():
                normals = None
            return np.asarray(mesh.vertices), normals, np.asarray(mesh.triangles)
    ps = read_point_set(p, zero_normals="drop")
    return ps.points, ps.normals, None


def _run(
    ps,
    method,
    *,
    rho,
    tau,
    n_iter,
    n_filter_iter,
    max_step,
    k,
    eta,
    eps,
    schedule,
    k_start,
    refit,
    planes,
):
    """Run the method with a progress bar; returns the DenoiseResult (``refit``: the
    normals were estimated, normal voting refits the returned ones to their faces;
    ``planes``: then the planar pieces step, as `pointatlas.denoise.denoise`)."""
    if method == "flatness":
        # n_iter None: at most 60, stopped once the points moved about the noise
        with progress_bar("flatness iterations", total=n_iter) as advance:
            return flatness_denoise(
                ps.points,
                k=k,
                eta=eta,
                eps=eps,
                n_iter=n_iter,
                schedule=schedule,
                k_start=k_start,
                normals=ps.normals,
                progress=advance,
            )
    # n_iter None: rounds until the points settle (normal_voting_denoise); total unknown;
    # the returned normals take n_filter_iter more steps unless refitted
    total = None if n_iter is None else (n_iter + (n_iter > 0 and not refit)) * n_filter_iter
    with progress_bar("normal filter steps", total=total) as advance:
        return voting_with_pieces(
            ps.points,
            ps.normals,
            planes=planes,
            rho=rho,
            tau=tau,
            n_iter=n_iter,
            n_filter_iter=n_filter_iter,
            adaptive=method == "normal-voting-adaptive",
            max_step=max_step,
            refit_normals=refit,
            progress=advance,
        )


def _print_measures(before: dict, after: dict) -> None:
    from rich.table import Table

    table = Table(title="against --clean")
    table.add_column("measure")
    table.add_column("input", justify="right")
    table.add_column("denoised", justify="right")
    for key, label in MEASURE_ROWS:
        a, b = before[key], after[key]
        if isinstance(a, float) and math.isnan(a):
            continue
        table.add_row(label, f"{a:.4g}", f"{b:.4g}")
    console.print(table)


def _html_report(path, input_path, ps, out_ps, ours, summary, written):
    """The HTML report: numbers, measures, the picture, the input beside the result."""
    from ..viz import ReportSection, write_report

    tables = {
        "result": {k: v for k, v in summary.items() if isinstance(v, int | float | str | bool)}
    }
    for key in ("measures_input", "measures_denoised"):
        if key in summary:
            tables[key.replace("_", " ")] = summary[key]
    import dataclasses

    input_layer = dataclasses.replace(report_layer(ps, {}), name="input")
    result_layer = dataclasses.replace(report_layer(out_ps, dict(ours)), name="denoised")
    return write_report(
        path,
        title=f"pointatlas denoise: {Path(str(input_path)).name}",
        summary=report_summary(input_path, ps),
        parameters={"method": summary["method"], **summary["parameters"]},
        tables=tables,
        pictures=[p for p in written if Path(p).suffix.lower() == ".png"],
        layers=[result_layer],
        sections=[ReportSection("the input", layers=[input_layer])],
        up=report_up(input_path),
    )


def _check_options(
    method, schedule, *, rho, tau, max_step, eta, eps, n_filter_iter, n_iter, k, clean
) -> None:
    """One precise error for an option out of range (before any work)."""
    if method not in DENOISE_METHODS:
        raise PointAtlasError(
            f"--method must be one of {', '.join(DENOISE_METHODS)}; got {method!r}"
        )
    if schedule not in FLATNESS_SCHEDULES:
        raise PointAtlasError(
            f"--schedule must be one of {', '.join(FLATNESS_SCHEDULES)}; got {schedule!r}"
        )
    as_float(rho, "--rho", lo=-1.0, hi=1.0)
    as_float(tau, "--tau", lo=0.0, hi=1.0, lo_open=True)
    as_float(max_step, "--max-step", lo=0.0)
    as_float(eta, "--plane-weight", lo=0.0, hi=1.0)
    as_float(eps, "--eps", lo=0.0, lo_open=True)
    check_iterations(n_filter_iter, "--filter-iter")
    check_iterations(n_iter, "--n-iter")
    if method == "flatness":
        as_int(k, "--k", lo=3, note="the point and at least two neighbours")
    if clean is not None and not Path(clean).is_file():
        raise PointAtlasError(f"--clean: no such file: {str(clean)!r}")


def _read_checked(input_path, output, method, estimate, normal_k, *, k, k_start):
    """The method (``auto`` decided on the input as given), the input with normals
    and whether they were estimated, after checking that OUT can hold the input's
    fields and ours; flatness' ``--k`` and ``--k-start`` are checked against the
    points before normals are estimated."""
    estimated = bool(estimate)
    if estimate is None:
        # auto decides on the input as given (choose_method)
        from ._app import read_input

        probe = read_input(input_path, zero_normals="drop")
        estimated = probe.normals is None
        if method == "auto":
            method = choose_method(probe.points, probe.normals)
    elif method == "auto":
        method = choose_method([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    check = flatness_counts(k, k_start) if method == "flatness" else None
    ps = read_with_normals(input_path, estimate=estimate, normal_k=normal_k, check=check)
    n = ps.n_points
    ours = {
        "displacement": np.zeros(n),
        "feature_class": np.zeros(n, np.int8),
        "denoise_k": np.zeros(n, np.int64),
    }
    if method == "flatness":
        ours["flatness"] = np.zeros(n)
    check_point_output(output, ps, _written_fields(output, ours))
    return method, ps, estimated


def _write_out(output, out_ps, ours: dict, json_path) -> Path:
    """OUT with the fields it can hold (`_written_fields`); a note names those left out."""
    fields = _written_fields(output, ours)
    if not fields:
        say(
            f"note: {Path(output).suffix} keeps coordinates and normals only: the fields "
            f"{', '.join(ours)} are not written (their summary is in {json_path.name}; "
            "write .ply, .las or .laz for them)",
            out=err_console,
        )
    return write_point_output(output, out_ps, fields)


def _written_fields(output, ours: dict) -> dict:
    """Our per-point fields as OUT holds them: none in XYZ/TXT, which keeps only
    coordinates and normals. The moved points and their normals are denoise's result;
    the fields are diagnostics (their summary is in OUT's JSON), so they are left out
    with a note rather than the run refused. An input field to keep is still refused
    (`check_point_output`)."""
    return {} if Path(output).suffix.lower() in XYZ_EXTENSIONS else ours


def _our_fields(res, method) -> dict:
    """Our per-point fields of OUT."""
    ours = {
        "displacement": res.displacement,
        "feature_class": res.feature_class,
        "denoise_k": res.k,
    }
    if method == "flatness":
        ours["flatness"] = res.energy
    return ours


def _summary(
    input_path,
    res,
    n,
    method,
    seconds,
    t0,
    *,
    k,
    eta,
    eps,
    schedule,
    k_start,
    rho,
    tau,
    n_filter_iter,
    max_step,
) -> dict:
    """The numbers of OUT_denoise.json (the measures against --clean are added after)."""
    summary = {
        "input": str(input_path),
        "method": res.method,
        "n_points": n,
        "n_iter": res.n_iter,
        "spacing": res.spacing,
        "displacement_mean": float(res.displacement.mean()),
        "displacement_max": float(res.displacement.max()),
        "n_fallback": res.n_fallback,
        "feature_classes": {
            name: int((res.feature_class == c).sum())
            for c, name in ((1, "face"), (2, "edge"), (3, "corner"))
        },
        "parameters": (
            {"k": k, "eta": eta, "eps": eps, "schedule": schedule, "k_start": k_start}
            if method == "flatness"
            else {"rho": rho, "tau": tau, "filter_iter": n_filter_iter, "max_step": max_step}
        ),
        "seconds": round(seconds, 3),
        "seconds_total": round(time.perf_counter() - t0, 3),
    }
    return summary


def _clean_measures(clean, clean_model, ps, res) -> dict:
    """Chamfer, p2m and normal MSE of the input and of the result against --clean."""
    cpts, cnrm, cfaces = clean_model
    before = denoise_measures(
        ps.points, cpts, normals=ps.normals, clean_normals=cnrm, clean_faces=cfaces
    ).as_dict()
    after = denoise_measures(
        res.points, cpts, normals=res.normals, clean_normals=cnrm, clean_faces=cfaces
    ).as_dict()
    return {"clean": str(clean), "measures_input": before, "measures_denoised": after}


def _render_result(render, ps, res, method):
    """The --render PNG: the input beside the result (flatness or feature class)."""
    from ..viz import PointsPanel, render_side_by_side

    scal = res.energy if method == "flatness" else res.feature_class.astype(float)
    name = "flatness" if method == "flatness" else "feature class"
    return render_side_by_side(
        render,
        [
            PointsPanel(ps.points, normals=ps.normals, title="input"),
            PointsPanel(
                res.points,
                normals=res.normals,
                scalars=scal,
                scalar_name=name,
                cmap="Blues",
                title=res.method,
            ),
        ],
        title=f"{ps.name}: denoised ({res.method}, {res.n_iter} iterations)",
    )


_MethodOption = Annotated[
    str,
    typer.Option(
        "--method",
        help="normal-voting, normal-voting-adaptive, flatness or auto (normal-voting; "
        "normals are estimated when IN has none).",
    ),
]
_NIterOption = Annotated[
    int | None,
    typer.Option(
        "--n-iter",
        help="Rounds (voting; default: until the points settle, at most 4) or "
        "iterations (flatness; default: until the points moved about the noise, at most 60).",
    ),
]
_CleanOption = Annotated[
    Path | None,
    typer.Option("--clean", help="Clean mesh (or point set): print and record the measures."),
]
_RenderOption = Annotated[
    Path | None, typer.Option("--render", help="Also write a PNG: input beside result.")
]
_PlanesOption = Annotated[
    bool | None,
    typer.Option(
        "--planes/--no-planes",
        help="Normal voting: points on planar pieces of 150+ points take the piece's "
        "plane (normal and position). Default: on, off with --tile-size (global step).",
    ),
]
_ReportOption = Annotated[
    Path | None,
    typer.Option("--report", help="Also write an HTML report with a 3-D view of input and result."),
]


def _run_tiles(
    input_path,
    output,
    tiles,
    report,
    *,
    method,
    estimate,
    normal_k,
    rho,
    tau,
    n_iter,
    n_filter_iter,
    max_step,
    k,
    eta,
    eps,
    schedule,
    k_start,
):
    """``--tile-size``: the run by tiles on dask (`pointatlas.batch`; no planar pieces)."""
    job = denoise_job(
        method=method,
        rho=rho,
        tau=tau,
        n_iter=n_iter,
        filter_iter=default_filter_iter(refit=False) if n_filter_iter is None else n_filter_iter,
        max_step=max_step,
        k=k,
        eta=eta,
        eps=eps,
        schedule=schedule,
        k_start=k_start,
    )
    run_tiled(
        "denoise",
        job,
        input_path,
        output,
        tiles,
        normals=normal_job_for(input_path, estimate, normal_k),
        side_files=denoise_side_files,
        report=report,
        parameters=job.params,
        color_by="displacement",
    )


@app.command("denoise")
@guarded
def denoise_command(
    input_path: InputArgument,
    output: Annotated[
        Path,
        typer.Argument(
            metavar="OUT", help="Denoised point set (.ply, .las, .laz), every input field kept."
        ),
    ],
    method: _MethodOption = "auto",
    rho: Annotated[float, typer.Option("--rho", help="Normal voting: cut-off on n_i . n_j.")] = 0.9,
    tau: Annotated[
        float,
        typer.Option("--tau", help="Normal voting: eigenvalue threshold (and feature classes)."),
    ] = 0.3,
    n_iter: _NIterOption = None,
    n_filter_iter: Annotated[
        int | None,
        typer.Option(
            "--filter-iter",
            help="Normal voting: filter steps per round (default: 1 when the normals are "
            "estimated, 5 when IN has them).",
        ),
    ] = None,
    max_step: Annotated[
        float, typer.Option("--max-step", help="Normal voting: largest move per iteration, in l.")
    ] = 0.5,
    k: Annotated[
        int, typer.Option("--k", help="Flatness: neighbours, the point itself included.")
    ] = 28,
    eta: Annotated[
        float,
        typer.Option("--plane-weight", help="Flatness: weight of the plane term (eta of Eq. 6.3)."),
    ] = 1.0,
    eps: Annotated[float, typer.Option("--eps", help="Flatness: step scale.")] = 0.1,
    schedule: Annotated[
        str, typer.Option("--schedule", help="Flatness: constant or decreasing (large k first).")
    ] = "constant",
    k_start: Annotated[
        int | None, typer.Option("--k-start", help="Flatness, decreasing: first k (default 4 k).")
    ] = None,
    clean: _CleanOption = None,
    estimate: EstimateNormalsOption = None,
    normal_k: NormalKOption = 20,
    render: _RenderOption = None,
    report: _ReportOption = None,
    planes: _PlanesOption = None,
    tile_size: TileSizeOption = None,
    halo: HaloOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    max_memory: MaxMemoryOption = None,
    old_eta: Annotated[float | None, deprecated_option("--eta", "--plane-weight")] = None,
):
    """Denoise a point set: normal voting with adaptive k (thesis 5.4) or flatness (Eq. 6.3).

    Writes OUT (moved points, filtered normals, every input field, plus
    ``displacement``, ``feature_class``, ``denoise_k`` and, for flatness, ``flatness``)
    and, last, OUT_denoise.json (parameters, timings, measures, files with SHA-256).
    """
    from ..io import POINT_WRITE_EXTENSIONS

    eta = renamed_flag("--plane-weight", eta, "--eta", old_eta)
    json_path = summary_path(output)
    check_outputs(
        [input_path, clean],
        [
            ("OUT", output, POINT_WRITE_EXTENSIONS),
            ("OUT's summary", json_path, None),
            ("--render", render, (".png",)),
            ("--report", report, REPORT_EXTENSIONS),
        ],
    )
    _check_options(
        method,
        schedule,
        rho=rho,
        tau=tau,
        max_step=max_step,
        eta=eta,
        eps=eps,
        n_filter_iter=n_filter_iter,
        n_iter=n_iter,
        k=k,
        clean=clean,
    )
    tiles = tile_options(
        tile_size, halo, workers, scheduler, max_memory, clean=clean, render=render
    )
    if tiles is not None:
        if planes:
            raise PointAtlasError(
                "--planes grows planar pieces over the whole input, which tiles cannot; "
                "drop --planes or --tile-size"
            )
        _run_tiles(
            input_path,
            output,
            tiles,
            report,
            method=method,
            estimate=estimate,
            normal_k=normal_k,
            rho=rho,
            tau=tau,
            n_iter=n_iter,
            n_filter_iter=n_filter_iter,
            max_step=max_step,
            k=k,
            eta=eta,
            eps=eps,
            schedule=schedule,
            k_start=k_start,
        )
        return
    t0 = time.perf_counter()
    method, ps, estimated = _read_checked(
        input_path, output, method, estimate, normal_k, k=k, k_start=k_start
    )
    if n_filter_iter is None:  # estimated normals are refitted: one step per round
        n_filter_iter = default_filter_iter(refit=estimated)
    n = ps.n_points
    clean_model = read_clean(clean) if clean is not None else None
    t1 = time.perf_counter()
    res = _run(
        ps,
        method,
        rho=rho,
        tau=tau,
        n_iter=n_iter,
        n_filter_iter=n_filter_iter,
        max_step=max_step,
        k=k,
        eta=eta,
        eps=eps,
        schedule=schedule,
        k_start=k_start,
        refit=estimated,
        planes=planes is not False,
    )
    seconds = time.perf_counter() - t1
    ours = _our_fields(res, method)
    out_ps = ps.replace(points=res.points, normals=res.normals)
    written = [_write_out(output, out_ps, ours, json_path)]
    summary = _summary(
        input_path,
        res,
        n,
        method,
        seconds,
        t0,
        k=k,
        eta=eta,
        eps=eps,
        schedule=schedule,
        k_start=k_start,
        rho=rho,
        tau=tau,
        n_filter_iter=n_filter_iter,
        max_step=max_step,
    )
    if method != "flatness":
        summary["parameters"]["planes"] = planes is not False
    if clean_model is not None:
        summary.update(_clean_measures(clean, clean_model, ps, res))
    if render is not None:
        written.append(_render_result(render, ps, res, method))
    if report is not None:
        written.append(_html_report(report, input_path, ps, out_ps, ours, summary, written))
    write_summary_json(json_path, summary, written)
    console.print(
        f"{res.method}: {n:,} points, {res.n_iter} iterations, mean move "
        f"{summary['displacement_mean'] / res.spacing if res.spacing else 0:.2f} l "
        f"({seconds:.2f} s)"
    )
    if clean_model is not None:
        _print_measures(summary["measures_input"], summary["measures_denoised"])
    for path in [*written, json_path]:
        say(f"wrote {path}")
