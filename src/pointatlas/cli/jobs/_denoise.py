"""The job of ``pointatlas denoise``: normal voting (thesis 5.4, [YRS+18]) or flatness
(6.2) denoising.

Writes the moved points with their filtered normals and every input field, a JSON
summary beside the output (with the measures against ``--clean``) and optionally a
picture of the input beside the result and an HTML report.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError, as_float, as_int
from ...denoise import (
    DENOISE_METHODS,
    FLATNESS_SCHEDULES,
    choose_method,
    default_filter_iter,
    denoise_measures,
    flatness_with_sides,
    voting_with_pieces,
)
from .._flag_checks import check_iterations, flatness_counts, normal_k_counts
from .._outputs import (
    XYZ_EXTENSIONS,
    check_outputs,
    check_point_output,
    write_point_output,
    write_summary_json,
)
from .._reports import REPORT_EXTENSIONS, report_layer, report_summary, report_up
from ._console import err_console, progress_bar, say
from ._inputs import read_input, read_with_normals
from ._tiled import denoise_job, denoise_side_files, normal_job_for, run_tiled

__all__ = ["DenoiseOptions", "DenoiseResult", "read_clean", "run_denoise", "summary_path"]


@dataclass(frozen=True)
class DenoiseOptions:
    """The settings of ``pointatlas denoise`` (the flags of the same names; ``eta`` is
    ``--plane-weight``, ``n_filter_iter`` ``--filter-iter``).

    ``method``: one of `pointatlas.denoise.DENOISE_METHODS` or "auto"; normal voting's
    ``rho``, ``tau``, ``n_filter_iter``, ``max_step``, ``planes`` (None: on, off by
    tiles); flatness' ``k``, ``eta``, ``eps``, ``schedule``, ``k_start``; ``n_iter``
    of either; ``clean`` (a clean model to measure against), normals when IN has none
    (``estimate_normals``, ``normal_k``), ``render`` (PNG) and ``report`` (HTML).
    """

    method: str = "auto"
    rho: float = 0.9
    tau: float = 0.3
    n_iter: int | None = None
    n_filter_iter: int | None = None
    max_step: float = 0.5
    k: int = 28
    eta: float = 1.0
    eps: float = 0.1
    schedule: str = "constant"
    k_start: int | None = None
    clean: Path | None = None
    estimate_normals: bool | None = None
    normal_k: int = 20
    render: Path | None = None
    report: Path | None = None
    planes: bool | None = None


@dataclass(frozen=True)
class DenoiseResult:
    """What `run_denoise` did: OUT_denoise.json's summary, the seconds of the
    denoising and the files written (the summary last); by tiles the tiled run's
    summary (``tiled``) and nothing else."""

    summary: dict
    written: list
    seconds: float | None = None
    tiled: bool = False


def run_denoise(in_path, out_path, options: DenoiseOptions, tiles=None) -> DenoiseResult:
    """``pointatlas denoise``: IN read with normals (estimated when missing), denoised,
    written to OUT with every input field and ours, the picture, the report and, last,
    OUT_denoise.json; by tiles when ``tiles`` (a `pointatlas.batch.TileOptions`) is
    given (no planar pieces)."""
    from ...io import POINT_WRITE_EXTENSIONS

    o = options
    json_path = summary_path(out_path)
    check_outputs(
        [in_path, o.clean],
        [
            ("OUT", out_path, POINT_WRITE_EXTENSIONS),
            ("OUT's summary", json_path, None),
            ("--render", o.render, (".png",)),
            ("--report", o.report, REPORT_EXTENSIONS),
        ],
    )
    _check_options(
        o.method,
        o.schedule,
        rho=o.rho,
        tau=o.tau,
        max_step=o.max_step,
        eta=o.eta,
        eps=o.eps,
        n_filter_iter=o.n_filter_iter,
        n_iter=o.n_iter,
        k=o.k,
        clean=o.clean,
    )
    if tiles is not None:
        if o.planes:
            raise PointAtlasError(
                "--planes grows planar pieces over the whole input, which tiles cannot; "
                "drop --planes or --tile-size"
            )
        return DenoiseResult(_run_tiles(in_path, out_path, tiles, o), [], tiled=True)
    t0 = time.perf_counter()
    method, ps, estimated = _read_checked(
        in_path, out_path, o.method, o.estimate_normals, o.normal_k, k=o.k, k_start=o.k_start
    )
    n_filter_iter = o.n_filter_iter
    if n_filter_iter is None:  # estimated normals are refitted: one step per round
        n_filter_iter = default_filter_iter(refit=estimated)
    n = ps.n_points
    clean_model = read_clean(o.clean) if o.clean is not None else None
    t1 = time.perf_counter()
    res = _run(
        ps,
        method,
        rho=o.rho,
        tau=o.tau,
        n_iter=o.n_iter,
        n_filter_iter=n_filter_iter,
        max_step=o.max_step,
        k=o.k,
        eta=o.eta,
        eps=o.eps,
        schedule=o.schedule,
        k_start=o.k_start,
        refit=estimated,
        planes=o.planes is not False,
    )
    seconds = time.perf_counter() - t1
    ours = _our_fields(res, method)
    out_ps = ps.replace(points=res.points, normals=res.normals)
    written = [_write_out(out_path, out_ps, ours, json_path)]
    summary = _summary(
        in_path,
        res,
        n,
        method,
        seconds,
        t0,
        k=o.k,
        eta=o.eta,
        eps=o.eps,
        schedule=o.schedule,
        k_start=o.k_start,
        rho=o.rho,
        tau=o.tau,
        n_filter_iter=n_filter_iter,
        max_step=o.max_step,
    )
    if method != "flatness":
        summary["parameters"]["planes"] = o.planes is not False
    if clean_model is not None:
        summary.update(_clean_measures(o.clean, clean_model, ps, res))
    if o.render is not None:
        written.append(_render_result(o.render, ps, res, method))
    if o.report is not None:
        written.append(_html_report(o.report, in_path, ps, out_ps, ours, summary, written))
    write_summary_json(json_path, summary, written)
    return DenoiseResult(summary, [*written, json_path], seconds)


def _run_tiles(input_path, output, tiles, o: DenoiseOptions) -> dict:
    """``--tile-size``: the run by tiles on dask (`pointatlas.batch`; no planar pieces)."""
    job = denoise_job(
        method=o.method,
        rho=o.rho,
        tau=o.tau,
        n_iter=o.n_iter,
        filter_iter=(
            default_filter_iter(refit=False) if o.n_filter_iter is None else o.n_filter_iter
        ),
        max_step=o.max_step,
        k=o.k,
        eta=o.eta,
        eps=o.eps,
        schedule=o.schedule,
        k_start=o.k_start,
    )
    normals = normal_job_for(input_path, o.estimate_normals, o.normal_k)
    return run_tiled(
        "denoise",
        job,
        input_path,
        output,
        tiles,
        normals=normals,
        side_files=denoise_side_files,
        report=o.report,
        parameters=job.params,
        color_by="displacement",
        # bounded by the input, before any work
        checks=(
            flatness_counts(o.k, o.k_start) if job.params["method"] == "flatness" else None,
            None if normals is None else normal_k_counts(o.normal_k),
        ),
    )


def summary_path(output: Path) -> Path:
    """``OUT_denoise.json`` beside ``OUT``."""
    return Path(f"{output.with_suffix('')}_denoise.json")


def read_clean(path: Path):
    """The clean model of ``--clean``: (points, normals or None, triangles or None).

    A mesh file gives its vertices, area-weighted vertex normals and triangles; a
    point file its points and normals (no point-to-mesh distance then).
    """
    from ...io import MESH_EXTENSIONS, read_mesh, read_point_set

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
            return flatness_with_sides(
                ps.points,
                ps.normals,
                k=k,
                eta=eta,
                eps=eps,
                n_iter=n_iter,
                schedule=schedule,
                k_start=k_start,
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


def _html_report(path, input_path, ps, out_ps, ours, summary, written):
    """The HTML report: numbers, measures, the picture, the input beside the result."""
    from ...viz import ReportSection, write_report

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
    from ...viz import PointsPanel, render_side_by_side

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
