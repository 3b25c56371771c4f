"""``pointatlas simplify``: VSA segmentation -> surface-like complex -> polygon mesh.

Also registers the demo step (segment and simplify the demo model); the
``pointatlas experiment simplify`` reproductions live in `pointatlas.experiments`.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError, PointSet, as_float, as_int
from ..io import write_json, write_mesh
from ..simplify import SimplifyWarning, simplify_points
from ._app import (
    ClassicOption,
    EstimateNormalsOption,
    EtaOption,
    MaxAngleDegOption,
    MaxIterOption,
    MergeOption,
    NormalKOption,
    SeedsOption,
    SplitOption,
    SwitchOption,
    VSAKOption,
    VSASeedOption,
    WeightsOption,
    angle_deg_option,
    app,
    console,
    demo_step,
    deprecated_option,
    err_console,
    guarded,
    read_with_normals,
    renamed_flag,
    say,
    vsa_options,
)
from ._cmd_core import REPORT_EXTENSIONS
from ._flag_checks import vsa_counts
from ._mesh_io import read_mesh_input, write_simplified, write_triangles
from ._outputs import check_outputs, write_summary_json
from ._simplify_report import (
    render_simplification,
    render_surface,
    simplification_table,
    surface_table,
)

__all__ = ["render_simplification", "simplification_table"]

#: OUT and --triangles formats (STL: the earcut triangles, `write_simplified`)
MESH_OUT = (".obj", ".ply", ".off", ".stl")
#: Segmentation of the demo model: VSA from every point, split/merge threshold eta.
DEMO_ETA = 20.0


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
        reached = max(res.distance_max, res.back_distance_max)
        if reached > max_error:
            missed.append(f"--max-error {max_error:.4g}: the finest level is {reached:.4g} away")
    for line in missed:
        err_console.print(f"[bold yellow]warning:[/] not reachable: {line}", highlight=False)


def _length_option(text: str | None, flag: str, diagonal: float) -> float | None:
    """A length, or a percentage of the bounding-box diagonal (``0.5%``)."""
    from .._core import as_float

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


def _simplify_mesh_command(
    infile,
    mesh_in,
    out,
    *,
    max_angle,
    eta,
    n_faces,
    max_error,
    max_triangles,
    regions,
    chord_tolerance,
    planarize,
    seed,
    triangles,
    report,
    render,
):
    from ..simplify import decimate_mesh, simplify_mesh, surface_diagonal

    v = mesh_in.vertices
    diagonal = surface_diagonal(v, mesh_in.triangles)
    bound = _length_option(max_error, "--max-error", diagonal)
    if not regions:
        res = _run(
            v,
            mesh_in.triangles,
            max_triangles,
            max_error=bound,
            max_angle=max_angle,
            rng=seed,
            function=decimate_mesh,
        )
    else:
        res = _run(
            v,
            mesh_in.triangles,
            max_angle=max_angle,
            eta=eta,
            n_faces=n_faces,
            max_error=bound,
            max_triangles=max_triangles,
            chord_tolerance=_length_option(chord_tolerance, "--chord-tolerance", diagonal),
            planarize=planarize,
            rng=seed,
            function=simplify_mesh,
        )
    _say_missed_target(res, n_faces=n_faces, max_triangles=max_triangles, max_error=bound)
    written = [write_simplified(out, res)]
    if triangles is not None:
        written.append(write_triangles(triangles, res))
    if render is not None:
        written.append(render_surface(render, mesh_in, res, title=Path(str(infile)).name))
    if report is not None:
        info = {
            "input": str(infile),
            "input_vertices": int(mesh_in.n_vertices),
            "input_faces": int(mesh_in.n_faces),
            "seed": seed,
            **res.summary(),
            "method": "regions" if regions else "decimate",
        }
        if Path(report).suffix.lower() in REPORT_EXTENSIONS:
            from ..viz import MeshLayer

            layers = [
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
            written.append(_html_report(report, infile, info, written, layers, seed))
        else:
            written.append(write_summary_json(report, info, written))
    how = "regions (one face per VSA region)" if regions else "decimate (structure-aware)"
    console.print(surface_table(res, title=Path(str(infile)).name, path=how))
    for path in written:
        say(f"written: {path}")


def _html_report(path, infile, info: dict, written, layers, seed: int):
    """The HTML report of ``simplify``: the numbers, the pictures written, a 3-D view."""
    from ..viz import write_report

    numbers = {
        k: v for k, v in info.items() if not isinstance(v, dict | list | tuple) and k != "input"
    }
    pictures = [p for p in written if Path(p).suffix.lower() == ".png"]
    return write_report(
        path,
        title=f"pointatlas simplify: {Path(str(infile)).name}",
        summary={"file": str(infile), "files written": ", ".join(str(p) for p in written)},
        parameters={k: info[k] for k in ("seed",) if k in info},
        tables={"result": numbers},
        pictures=pictures,
        layers=layers,
        seed=seed,
    )


def _run(*args, function=simplify_points, **kw):
    """simplify_points (or ``function``), each SimplifyWarning one yellow line."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SimplifyWarning)
        result = function(*args, **kw)
    for w in caught:
        if issubclass(w.category, SimplifyWarning):
            err_console.print(f"[bold yellow]warning:[/] {w.message}", highlight=False)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return result


# ------------------------------------------------------------------ the command's options

InArgument = Annotated[
    Path,
    typer.Argument(
        metavar="IN", help="Point set or mesh (PLY, OBJ, OFF, ...), or a bundled model name."
    ),
]
OutArgument = Annotated[
    Path,
    typer.Argument(
        metavar="OUT", help="Simplified polygon mesh (.obj, .ply, .off; .stl: its triangles)."
    ),
]
VerticesOption = Annotated[
    str,
    typer.Option(
        "--vertices",
        help="fit (planes refitted through common vertices: planar faces), "
        "lsq (plane intersection) or optimize (Eq. 4.12).",
    ),
]
FaceMethodOption = Annotated[
    str,
    typer.Option("--face-method", help="Points path: general (cycles, holes) or star ([SZP20])."),
]
FacesOption = Annotated[
    int | None,
    typer.Option("--faces", help="Target number of faces (mesh input; found by bisection)."),
]
MaxTrianglesOption = Annotated[
    int | None,
    typer.Option(
        "--max-triangles",
        help="Mesh input: triangle budget (the decimation stops at the first level "
        "within it; with --regions the finest segmentation within it).",
    ),
]
RegionsOption = Annotated[
    bool,
    typer.Option(
        "--regions",
        help="Mesh input: one face per VSA region, input vertices kept on chords (the "
        "earlier default) instead of the structure-aware decimation; implied by "
        "--faces, --eta, --chord-tolerance and --planarize.",
    ),
]
MaxErrorOption = Annotated[
    str | None,
    typer.Option(
        "--max-error",
        help="Mesh input: largest distance between input and output, both ways (input "
        "vertices to the output, the output's vertices and samples to the input): a "
        "length, or a percentage of the bounding-box diagonal; default 0.5%.",
    ),
]
ChordToleranceOption = Annotated[
    str | None,
    typer.Option(
        "--chord-tolerance",
        help="Mesh input: largest distance of a boundary arc to its chords (a length or "
        "a percentage of the diagonal; default 0.5%).",
    ),
]
PlanarizeOption = Annotated[
    bool,
    typer.Option(
        "--planarize",
        help="Mesh input: move vertices towards their faces' planes (at most the chord "
        "tolerance): flatter faces, larger distance to the input.",
    ),
]
VerticesOnlyOption = Annotated[
    bool,
    typer.Option(
        "--vertices-only",
        help="Use a mesh input's vertices only, as a point set (the thesis' path).",
    ),
]
CentersOption = Annotated[
    str, typer.Option("--centers", help="Proxy plane point: centroid or seed (C_i).")
]
WeightOption = Annotated[
    float, typer.Option("--vertex-weight", help="w~ of Eq. 4.11 (--vertices optimize).")
]
AnchorWeightOption = Annotated[
    float | None,
    typer.Option(
        "--anchor-weight",
        help="Pull of the vertices to plane intersection (--vertices fit; default: "
        "the loosest of 0.01, 0.1, 1, 10 with valid faces).",
    ),
]
MinRegionSizeOption = Annotated[
    int | None, typer.Option("--min-region-size", help="Merge smaller regions (default k).")
]
RepairOption = Annotated[
    bool, typer.Option("--repair/--no-repair", help="Merge regions that cannot be meshed.")
]
SmoothOption = Annotated[int, typer.Option("--smooth", help="Label majority-filter passes.")]
PathOption = Annotated[
    str,
    typer.Option(
        "--path",
        help="Point input: auto (the thesis' surface-like complex, and the robust path "
        "when that gives no closed manifold mesh), thesis, or robust (the points' "
        "surface from the normals on a voxel grid, then the mesh path).",
    ),
]
LabelsOption = Annotated[
    bool,
    typer.Option(
        "--labels/--no-labels",
        help="Point input with a 'label' field (written by pointatlas segment): use it "
        "as the segmentation instead of running VSA.",
    ),
]
TrianglesOption = Annotated[
    Path | None,
    typer.Option(
        "--triangles",
        help="Also write the triangulated mesh here (each face split by earcut; PLY/OFF "
        "triangles coloured by face). Open3D, trimesh and CloudCompare read triangle "
        "meshes only: give them this file.",
    ),
]
ReportOption = Annotated[
    Path | None,
    typer.Option(
        "--report",
        help="Write the quality report: .json (numbers, written last) or .html (with a "
        "3-D view of the input and the simplified mesh).",
    ),
]
RenderOption = Annotated[
    Path | None, typer.Option("--render", help="PNG: segmentation and mesh side by side.")
]


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


def _simplify_points_command(
    infile, out, *, k, estimate, normal_k, use_labels, settings, level, seed, **outputs
):
    """The points path of ``simplify``: read, simplify_points, write the outputs."""
    triangles, report, render = outputs["triangles"], outputs["report"], outputs["render"]
    ps = read_with_normals(
        infile,
        estimate=estimate,
        normal_k=normal_k,
        min_points=max(4, k),
        what=f"simplify with k = {k} (--k)",
        check=vsa_counts(settings["vsa"]),
    )
    normals = ps.normals
    given = ps.attributes.get("label") if use_labels else None
    if given is not None:
        say("segmentation: the input's 'label' field (--no-labels runs VSA instead)")
    diagonal = float(np.linalg.norm(np.ptp(ps.points, axis=0)))
    bound = _length_option(level["max_error"], "--max-error", diagonal)
    result = _run(
        ps.points,
        normals,
        labels=given,
        rng=seed,
        max_error=bound,
        max_triangles=level["max_triangles"],
        **settings,
    )
    mesh = result.mesh
    if result.path == "robust":
        _say_missed_target(mesh, n_faces=None, max_triangles=None, max_error=bound)
    robust = result.path == "robust"
    written = [write_simplified(out, mesh)]
    if triangles is not None:
        written.append(write_triangles(triangles, mesh))
    used = ps.points[result.point_index] if result.point_index.size else ps.points
    if render is not None:
        picture = render_simplification(
            render, used, normals[result.point_index], mesh, title=ps.name, labels=result.labels
        )
        written.append(picture)
    if report is not None:
        info = {"input": str(infile), "seed": seed, **result.summary()}
        if not robust:
            info["complex"] = mesh.surface_complex.summary()
        if Path(report).suffix.lower() in REPORT_EXTENSIONS:
            from ..viz import MeshLayer, PointsLayer

            layers = [
                PointsLayer(used, {"region": np.asarray(result.labels)}, name="points by region"),
                MeshLayer(
                    mesh.vertices,
                    [p.tolist() for p in mesh.polygons],
                    face_labels=mesh.face_region[mesh.polygon_face],
                    name="simplified mesh",
                ),
            ]
            written.append(_html_report(report, infile, info, written, layers, seed))
        else:
            written.append(write_summary_json(report, info, written))
    if robust:
        console.print(surface_table(mesh, title=ps.name, path=f"robust ({result.reason})"))
    else:
        console.print(simplification_table(mesh, result.segmentation, title=ps.name))
    for name in written:
        say(f"written: {name}")


@app.command("simplify")
@guarded
def simplify_command(
    infile: InArgument,
    out: OutArgument,
    k: VSAKOption = 8,
    eta: EtaOption = None,
    max_angle_deg: MaxAngleDegOption = None,
    seeds: SeedsOption = "all",
    split: SplitOption = True,
    merge: MergeOption = True,
    switch: SwitchOption = "batch",
    classic: ClassicOption = False,
    weights: WeightsOption = "uniform",
    max_iter: MaxIterOption = 1000,
    seed: VSASeedOption = 0,
    vertices: VerticesOption = "fit",
    face_method: FaceMethodOption = "general",
    n_faces: FacesOption = None,
    max_error: MaxErrorOption = None,
    max_triangles: MaxTrianglesOption = None,
    regions: RegionsOption = False,
    chord_tolerance: ChordToleranceOption = None,
    planarize: PlanarizeOption = False,
    vertices_only: VerticesOnlyOption = False,
    centers: CentersOption = "centroid",
    weight: WeightOption = 1.0,
    anchor_weight: AnchorWeightOption = None,
    min_region_size: MinRegionSizeOption = None,
    repair: RepairOption = True,
    smooth: SmoothOption = 2,
    estimate: EstimateNormalsOption = None,
    normal_k: NormalKOption = 20,
    path: PathOption = "auto",
    use_labels: LabelsOption = True,
    triangles: TrianglesOption = None,
    report: ReportOption = None,
    render: RenderOption = None,
    old_weight: Annotated[float | None, deprecated_option("--weight", "--vertex-weight")] = None,
):
    """Simplify a mesh or a point set into a polygon mesh with planar faces.

    A mesh input (a file with faces, or a bundled model) takes the mesh path: its
    triangles are segmented (VSA on faces) and decimated by structure-aware edge
    collapse to the fewest triangles within --max-error of the input both ways
    (default 0.5 % of the diagonal) or to --max-triangles; flat regions come out as
    planar polygons. The output is closed and manifold whenever the input is closed
    (edges in four triangles and pinched vertices are cut apart first). --regions
    makes one face per region instead. A point set, or a mesh
    with ``--vertices-only``, takes the thesis' path (VSA on points, surface-like
    complex, 4.4), and the robust path when that gives no closed, manifold mesh
    (the points' surface from their normals on a voxel grid, then the mesh path;
    ``--path``); the table and the report say which and why. A point set with a
    ``label`` field (written by ``pointatlas segment``) is meshed with those regions.
    With ``--report`` the JSON report is written last and names every file of the
    run with its SHA-256.
    """
    weight = renamed_flag("--vertex-weight", weight, "--weight", old_weight)
    check_outputs(
        [infile],
        [
            ("OUT", out, MESH_OUT),
            ("--triangles", triangles, MESH_OUT),
            ("--render", render, (".png",)),
            ("--report", report, (".json", *REPORT_EXTENSIONS)),
        ],
    )
    max_angle = _level_angle(eta, max_angle_deg, n_faces, max_error, max_triangles)
    for flag, value, low in (
        ("--max-triangles", max_triangles, 1),
        ("--faces", n_faces, 1),
        ("--smooth", smooth, 0),
    ):
        if value is not None and value < low:
            raise PointAtlasError(f"{flag} must be at least {low}; got {value}")
    as_float(weight, "--vertex-weight", lo=0.0)
    if anchor_weight is not None:
        as_float(anchor_weight, "--anchor-weight", lo=0.0, lo_open=True)
    if min_region_size is not None:
        as_int(min_region_size, "--min-region-size", lo=1)
    mesh_in = None if vertices_only else read_mesh_input(infile)
    if mesh_in is not None:
        level = {"n_faces": n_faces, "max_error": max_error, "max_triangles": max_triangles}
        regions = regions or planarize or (eta, n_faces, chord_tolerance) != (None,) * 3
        _simplify_mesh_command(
            infile,
            mesh_in,
            out,
            max_angle=max_angle,
            eta=eta,
            **level,
            regions=regions,
            chord_tolerance=chord_tolerance,
            planarize=planarize,
            seed=seed,
            triangles=triangles,
            report=report,
            render=render,
        )
        return
    _refuse_mesh_flags(
        infile,
        planarize=planarize,
        n_faces=n_faces,
        chord_tolerance=chord_tolerance,
        more=(("--regions", regions or None),),
    )
    options = vsa_options(
        k=k,
        eta=eta,
        max_angle_deg=max_angle_deg,
        seeds=seeds,
        split=split,
        merge=merge,
        switch=switch,
        classic=classic,
        weights=weights,
        max_iter=max_iter,
    )
    settings = {
        "path": path,
        "vsa": options,
        "vertices": vertices,
        "faces": face_method,
        "centers": centers,
        "weight": weight,
        "anchor_weight": anchor_weight,
        "min_region_size": min_region_size,
        "repair": repair,
        "smooth": smooth,
    }
    level = {"max_error": max_error, "max_triangles": max_triangles}
    _simplify_points_command(
        infile,
        out,
        k=k,
        estimate=estimate,
        normal_k=normal_k,
        use_labels=use_labels,
        settings=settings,
        level=level,
        seed=seed,
        triangles=triangles,
        report=report,
        render=render,
    )


@demo_step
def demo_simplify(ps: PointSet, out_dir: Path, console) -> None:
    """Segmentation (VSA) and simplified polygon mesh, side by side."""
    if not ps.has_normals:
        raise PointAtlasError("the demo model has no normals")
    result = _run(ps.points, ps.normals, eta=DEMO_ETA)
    mesh = result.mesh
    obj = write_mesh(
        out_dir / f"{ps.name}_simplified.obj", mesh.vertices, [p.tolist() for p in mesh.polygons]
    )
    png = render_simplification(
        out_dir / f"{ps.name}_simplified.png",
        ps.points,
        ps.normals,
        mesh,
        title=f"{ps.name}: VSA (eta = {DEMO_ETA:g}) and the simplified mesh",
    )
    write_json(out_dir / f"{ps.name}_simplified.json", mesh.summary(), indent=2)
    console.print(simplification_table(mesh, result.segmentation))
    say(f"mesh: {obj}\npicture: {png}")
