"""The job of ``pointatlas simplify``: a mesh or a point set as a polygon mesh with
planar faces (docs/decisions/simplify.md).

A mesh input (a file with faces, or a bundled model with a mesh) takes the mesh path
(`pointatlas.simplify.decimate_mesh`, or `simplify_mesh` with ``regions``); a point
set, or a mesh with ``vertices_only``, the points path (`simplify_points`: the
thesis' surface-like complex, 4.4, and the robust path). Writes OUT (the polygons;
STL: the earcut triangles), the triangles, the picture and, last, the report.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError, as_float, as_int
from ...simplify import RETRY_FACTOR, SimplifyWarning, simplify_estimated, simplify_points
from .._flag_checks import angle_deg_option, vsa_counts, vsa_options
from .._outputs import check_outputs, write_summary_json
from .._reports import REPORT_EXTENSIONS
from ._console import counted, say, warn
from ._inputs import estimated_normals, read_estimating_normals
from ._mesh_io import read_mesh_input, write_simplified, write_triangles
from ._simplify_report import (
    distance_shares,
    render_simplification,
    render_surface,
    write_html_report,
)

__all__ = ["MESH_OUT", "SimplifyOptions", "SimplifyResult", "run_simplify", "simplify_quietly"]

#: OUT and --triangles formats (STL: the earcut triangles, `write_simplified`)
MESH_OUT = (".obj", ".ply", ".off", ".stl")


@dataclass(frozen=True)
class SimplifyOptions:
    """The settings of ``pointatlas simplify`` (the flags of the same names;
    ``n_faces`` is ``--faces``, ``face_method`` ``--face-method``, ``use_labels``
    ``--labels``).

    The VSA flags as typed (``k``, ``eta``, ``max_angle_deg``, ``seeds``, ``split``,
    ``merge``, ``switch``, ``classic``, ``weights``, ``max_iter``; ``seed`` of the
    random draws): they become a `VSAOptions` on the points path only, so a mesh
    input never reads them. One level of detail at most: ``eta``,
    ``max_angle_deg``, ``n_faces``, ``max_error`` or ``max_triangles`` (``max_error``
    and ``chord_tolerance`` are lengths or percentages of the diagonal as typed,
    ``"0.5%"``). The mesh path's ``regions``, ``chord_tolerance``, ``planarize``;
    ``vertices_only`` sends a mesh down the points path, whose ``path``,
    ``vertices``, ``face_method``, ``centers``, ``vertex_weight``,
    ``anchor_weight``, ``min_region_size``, ``repair``, ``smooth``, ``use_labels``
    and normals when missing (``estimate_normals``, ``normal_k``) it takes. The
    outputs beside OUT: ``triangles`` (a mesh file), ``render`` (PNG) and ``report``
    (JSON or HTML).
    """

    k: int = 8
    eta: float | None = None
    max_angle_deg: float | None = None
    seeds: str = "all"
    split: bool = True
    merge: bool = True
    switch: str = "batch"
    classic: bool = False
    weights: str = "uniform"
    max_iter: int = 1000
    seed: int = 0
    n_faces: int | None = None
    max_error: str | None = None
    max_triangles: int | None = None
    regions: bool = False
    chord_tolerance: str | None = None
    planarize: bool = False
    vertices_only: bool = False
    path: str = "auto"
    vertices: str = "fit"
    face_method: str = "general"
    centers: str = "centroid"
    vertex_weight: float = 1.0
    anchor_weight: float | None = None
    min_region_size: int | None = None
    repair: bool = True
    smooth: int = 2
    use_labels: bool = True
    estimate_normals: bool | None = None
    normal_k: int = 20
    triangles: Path | None = None
    report: Path | None = None
    render: Path | None = None


@dataclass(frozen=True)
class SimplifyResult:
    """What `run_simplify` did: the simplified ``mesh`` (a `SurfaceResult` on the mesh
    and the robust path, a `SimplifiedMesh` on the thesis' path), the VSA
    ``segmentation`` of the points path (None on the mesh path), the ``title`` of
    its table (IN's name), ``how`` the table names the path taken (None: the thesis'
    path), the files ``written`` (the report last) and the input's bounding-box
    ``diagonal`` (the scale of ``--max-error 0.5%`` and of the table's shares)."""

    mesh: object
    segmentation: object | None
    title: str
    how: str | None
    written: list
    diagonal: float | None = None


def run_simplify(in_path, out_path, options: SimplifyOptions, tiles=None) -> SimplifyResult:
    """``pointatlas simplify``: IN read as a mesh (when it has faces and not
    ``vertices_only``) or as points with normals (estimated when missing), simplified,
    written to OUT with the triangles, the picture and, last, the report. There is
    no tiled run: ``tiles`` must be None."""
    o = options
    if tiles is not None:
        raise PointAtlasError("simplify has no tiled run (--tile-size)")
    check_outputs(
        [in_path],
        [
            ("OUT", out_path, MESH_OUT),
            ("--triangles", o.triangles, MESH_OUT),
            ("--render", o.render, (".png",)),
            ("--report", o.report, (".json", *REPORT_EXTENSIONS)),
        ],
    )
    max_angle = _level_angle(o.eta, o.max_angle_deg, o.n_faces, o.max_error, o.max_triangles)
    _check_counts(o)
    mesh_in = None if o.vertices_only else read_mesh_input(in_path)
    if mesh_in is not None:
        return _simplify_mesh_input(in_path, mesh_in, out_path, o, max_angle)
    _refuse_mesh_flags(
        in_path,
        planarize=o.planarize,
        n_faces=o.n_faces,
        chord_tolerance=o.chord_tolerance,
        more=(("--regions", o.regions or None),),
    )
    return _simplify_point_input(in_path, out_path, o)


def simplify_quietly(*args, function=simplify_points, **kw):
    """`simplify_points` (or ``function``), each `SimplifyWarning` one yellow line on
    stderr; other warnings pass on."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SimplifyWarning)
        result = function(*args, **kw)
    for w in caught:
        if issubclass(w.category, SimplifyWarning):
            warn(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return result


def _check_counts(o: SimplifyOptions) -> None:
    """The bounds of the counts and weights, named by their flags."""
    for flag, value, low in (
        ("--max-triangles", o.max_triangles, 1),
        ("--faces", o.n_faces, 1),
        ("--smooth", o.smooth, 0),
    ):
        if value is not None and value < low:
            raise PointAtlasError(f"{flag} must be at least {low}; got {value}")
    as_float(o.vertex_weight, "--vertex-weight", lo=0.0)
    if o.anchor_weight is not None:
        as_float(o.anchor_weight, "--anchor-weight", lo=0.0, lo_open=True)
    if o.min_region_size is not None:
        as_int(o.min_region_size, "--min-region-size", lo=1)


def _level_angle(eta, max_angle_deg, n_faces, max_error, max_triangles=None) -> float | None:
    """Check that one level of detail is given at most; the angle in radians or None."""
    levels = [
        ("--eta", eta),
        ("--max-angle-deg", max_angle_deg),
        ("--faces", n_faces),
        ("--max-error", max_error),
        ("--max-triangles", max_triangles),
    ]
    given = [flag for flag, value in levels if value is not None]
    if len(given) > 1:
        raise PointAtlasError(
            "give one of --eta, --max-angle-deg, --faces, --max-error, --max-triangles; "
            f"got {', '.join(given)}"
        )
    if max_angle_deg is None:
        return None
    return math.radians(angle_deg_option(max_angle_deg, "--max-angle-deg"))


def _refuse_mesh_flags(infile, *, planarize, n_faces, chord_tolerance, more=()):
    """The mesh path's flags, given with a point input: one clear error."""
    for flag, value in (
        ("--planarize", planarize or None),
        ("--faces", n_faces),
        ("--chord-tolerance", chord_tolerance),
        *more,
    ):
        if value is not None:
            raise PointAtlasError(
                f"{flag} needs a mesh input (a file with faces); {infile} is a point set "
                "or --vertices-only was given: use --max-error, --max-triangles, --eta or "
                "--max-angle-deg"
            )


def _length_option(text: str | None, flag: str, diagonal: float) -> float | None:
    """A length, or a percentage of the bounding-box diagonal (``0.5%``)."""
    if text is None:
        return None
    raw = text.strip()
    try:
        value = float(raw[:-1]) / 100.0 * diagonal if raw.endswith("%") else float(raw)
    except ValueError:
        raise PointAtlasError(
            f"{flag} must be a length or a percentage of the diagonal such as 0.5%; got {text!r}"
        ) from None
    return as_float(value, flag, lo=0.0, lo_open=True, what="length")


def _say_missed_target(res, *, n_faces, max_triangles, max_error) -> None:
    """One warning line when the level asked for was not reached (the output is the
    closest level; the table and report describe it)."""
    missed = []
    if n_faces is not None and res.n_faces != n_faces:
        missed.append(f"--faces {n_faces}: the closest level has {res.n_faces} faces")
    if max_triangles is not None and len(res.triangles) > max_triangles:
        missed.append(
            f"--max-triangles {max_triangles}: the coarsest level has {len(res.triangles)}"
        )
    if max_error is not None:
        reached = res.hausdorff
        if reached > max_error:
            missed.append(f"--max-error {max_error:.4g}: the finest level is {reached:.4g} away")
    for line in missed:
        warn(f"not reachable: {line}")


def _simplify_mesh_input(infile, mesh_in, out, o: SimplifyOptions, max_angle) -> SimplifyResult:
    """The mesh path: structure-aware decimation, or one face per VSA region with
    ``regions`` (implied by ``planarize``, ``eta``, ``n_faces`` and
    ``chord_tolerance``)."""
    from ...simplify import decimate_mesh, simplify_mesh, surface_diagonal

    regions = o.regions or o.planarize or (o.eta, o.n_faces, o.chord_tolerance) != (None,) * 3
    v = mesh_in.vertices
    diagonal = surface_diagonal(v, mesh_in.triangles)
    bound = _length_option(o.max_error, "--max-error", diagonal)
    if not regions:
        res = simplify_quietly(
            v,
            mesh_in.triangles,
            o.max_triangles,
            max_error=bound,
            max_angle=max_angle,
            rng=o.seed,
            function=decimate_mesh,
        )
    else:
        res = simplify_quietly(
            v,
            mesh_in.triangles,
            max_angle=max_angle,
            eta=o.eta,
            n_faces=o.n_faces,
            max_error=bound,
            max_triangles=o.max_triangles,
            chord_tolerance=_length_option(o.chord_tolerance, "--chord-tolerance", diagonal),
            planarize=o.planarize,
            rng=o.seed,
            function=simplify_mesh,
        )
    _say_missed_target(res, n_faces=o.n_faces, max_triangles=o.max_triangles, max_error=bound)
    title = Path(str(infile)).name
    written = [write_simplified(out, res)]
    if o.triangles is not None:
        written.append(write_triangles(o.triangles, res))
    if o.render is not None:
        written.append(render_surface(o.render, mesh_in, res, title=title))
    if o.report is not None:
        info = {
            "input": str(infile),
            "input_vertices": int(mesh_in.n_vertices),
            "input_faces": int(mesh_in.n_faces),
            "seed": o.seed,
            **res.summary(),
            "method": "regions" if regions else "decimate",
        }
        info.update(distance_shares(info, diagonal))
        written.append(_write_report(o.report, infile, info, written, _mesh_layers, mesh_in, res))
    how = "regions (one face per VSA region)" if regions else "decimate (structure-aware)"
    return SimplifyResult(res, None, title, how, written, diagonal)


def _simplify_point_input(infile, out, o: SimplifyOptions) -> SimplifyResult:
    """The points path: read with normals, `simplify_points` (the input's ``label``
    field as the segmentation with ``use_labels``), write the outputs."""
    settings = _point_settings(o)
    ps, estimated = read_estimating_normals(
        infile,
        estimate=o.estimate_normals,
        normal_k=o.normal_k,
        min_points=max(4, o.k),
        what=f"simplify with k = {o.k} (--k)",
        check=vsa_counts(settings["vsa"]),
        surface=True,
    )
    normals = ps.normals
    given = ps.attributes.get("label") if o.use_labels else None
    if given is not None:
        say("segmentation: the input's 'label' field (--no-labels runs VSA instead)")
    diagonal = float(np.linalg.norm(np.ptp(ps.points, axis=0)))
    bound = _length_option(o.max_error, "--max-error", diagonal)
    options = {
        "labels": given,
        "rng": o.seed,
        "max_error": bound,
        "max_triangles": o.max_triangles,
        **settings,
    }
    estimates = None  # with estimated normals: each estimate's k and distance, the kept's
    if estimated:  # estimated again where the output misses the points
        result, normals, estimates = _estimated_run(
            ps.points, normals, o.normal_k, diagonal, options
        )
    else:
        result = simplify_quietly(ps.points, normals, **options)
    mesh = result.mesh
    robust = result.path == "robust"
    if result.n_turned:
        turned = counted(result.n_turned, "normal", "normals")
        say(f"{turned} pointed into the shape: turned to the outside")
    if result.n_repeated:
        repeated = counted(
            result.n_repeated,
            "point repeats the position of a point before it",
            "points repeat the position of a point before them",
        )
        say(f"{repeated}: used once")
    if result.n_off_surface:
        off = counted(result.n_off_surface, "point lies", "points lie")
        warn(
            f"{off} far off the surface the others sample (outliers): left out; the "
            "distances are those of the points used"
        )
    if robust:
        _say_missed_target(mesh, n_faces=None, max_triangles=None, max_error=bound)
    written = [write_simplified(out, mesh)]
    if o.triangles is not None:
        written.append(write_triangles(o.triangles, mesh))
    used = ps.points[result.point_index] if result.point_index.size else ps.points
    if o.render is not None:
        picture = render_simplification(
            o.render, used, normals[result.point_index], mesh, title=ps.name, labels=result.labels
        )
        written.append(picture)
    if o.report is not None:
        info = {"input": str(infile), "seed": o.seed, **result.summary()}
        info.update(distance_shares(info, diagonal))
        if estimates is not None:
            info["normals_estimated"] = estimates
        if not robust:
            info["complex"] = mesh.surface_complex.summary()
        written.append(_write_report(o.report, infile, info, written, _points_layers, used, result))
    how = f"robust ({result.reason})" if robust else None
    return SimplifyResult(mesh, result.segmentation, ps.name, how, written, diagonal)


def _estimated_run(points, normals, normal_k: int, diagonal: float, options: dict):
    """`simplify_estimated` on normals estimated at ``normal_k`` (``normals``), with a
    line when the output misses the points and the normals are estimated again, and
    one with what was kept. Returns the kept result, its normals and the report's
    ``normals_estimated`` (the kept k, and each estimate's k and two-sided distance)."""

    def estimate(k):
        return estimated_normals(points, k, surface=True, label=f"normals, k = {k}")

    def pct(distance: float) -> str:
        return f"{100.0 * distance / diagonal:.2f} %" if diagonal > 0 else f"{distance:.4g}"

    def retrying(distance: float, sizes: tuple) -> None:
        say(
            f"the output lies {pct(distance)} of the diagonal from the points, over "
            f"{RETRY_FACTOR:g} times the bound: normals estimated again at k = "
            + ", ".join(str(k) for k in sizes)
            + " in turn, until one comes within it (the output nearest to the points kept)"
        )

    kept = simplify_quietly(
        points,
        estimate,
        function=simplify_estimated,
        normal_k=normal_k,
        normals=normals,
        on_retry=retrying,
        **options,
    )
    if len(kept.tried) > 1:
        runs = ", ".join(f"k = {k}: {pct(d)}" for k, d in kept.tried)
        say(f"kept the normals of k = {kept.k} ({runs})")
    tried = [{"k": k, "hausdorff": d} for k, d in kept.tried]
    return kept.result, kept.normals, {"k": kept.k, "tried": tried}


def _point_settings(o: SimplifyOptions) -> dict:
    """The keywords of `simplify_points` the flags set (the VSA flags as `VSAOptions`)."""
    options = vsa_options(
        k=o.k,
        eta=o.eta,
        max_angle_deg=o.max_angle_deg,
        seeds=o.seeds,
        split=o.split,
        merge=o.merge,
        switch=o.switch,
        classic=o.classic,
        weights=o.weights,
        max_iter=o.max_iter,
    )
    return {
        "path": o.path,
        "vsa": options,
        "vertices": o.vertices,
        "faces": o.face_method,
        "centers": o.centers,
        "weight": o.vertex_weight,
        "anchor_weight": o.anchor_weight,
        "min_region_size": o.min_region_size,
        "repair": o.repair,
        "smooth": o.smooth,
    }


def _write_report(path, infile, info: dict, written, layers, *shown) -> Path:
    """``--report``: HTML (the 3-D view's ``layers(*shown)``) or JSON (the numbers
    and the files written before it)."""
    if Path(path).suffix.lower() in REPORT_EXTENSIONS:
        return write_html_report(path, infile, info, written, layers(*shown), info["seed"])
    return write_summary_json(path, info, written)


def _mesh_layers(mesh_in, res) -> list:
    """The mesh path's 3-D view: the input's triangles by region, the simplified mesh."""
    from ...viz import MeshLayer

    return [
        MeshLayer(
            mesh_in.vertices,
            mesh_in.triangles,
            face_labels=res.face_labels,
            name="input triangles by region",
        ),
        MeshLayer(
            res.vertices,
            [p.tolist() for p in res.polygons],
            face_labels=res.polygon_face,
            name="simplified mesh",
        ),
    ]


def _points_layers(used, result) -> list:
    """The points path's 3-D view: the points by region, the simplified mesh."""
    from ...viz import MeshLayer, PointsLayer

    mesh = result.mesh
    return [
        PointsLayer(used, {"region": np.asarray(result.labels)}, name="points by region"),
        MeshLayer(
            mesh.vertices,
            [p.tolist() for p in mesh.polygons],
            face_labels=mesh.face_region[mesh.polygon_face],
            name="simplified mesh",
        ),
    ]
