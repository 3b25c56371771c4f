"""``pointatlas simplify``: its flags as `SimplifyOptions` for the job
(`pointatlas.cli.jobs.run_simplify`: the mesh path, or the thesis' points path, 4.4,
and the robust path), what it prints, and the demo step (segment and simplify the
demo model); the ``pointatlas experiment simplify`` reproductions live in
`pointatlas.experiments`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .._core import PointSet
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
    app,
    console,
    demo_step,
    deprecated_option,
    guarded,
    renamed_flag,
    say,
)
from .jobs import (
    DEMO_ETA,
    SimplifyOptions,
    run_simplify,
    simplification_table,
    simplify_files,
    surface_table,
)

__all__ = ["DEMO_ETA", "demo_simplify", "simplify_command"]

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
    ``--path``); the table and the report say which and why. A point set without
    normals (or with ``--estimate-normals``) gets them estimated at --normal-k, and
    again at k = 30 and 40 where the output, closed, lies farther than twice the bound
    from the points (the output nearest to them kept). A point set with a
    ``label`` field (written by ``pointatlas segment``) is meshed with those regions.
    With ``--report`` the JSON report is written last and names every file of the
    run with its SHA-256.
    """
    weight = renamed_flag("--vertex-weight", weight, "--weight", old_weight)
    options = SimplifyOptions(
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
        seed=seed,
        n_faces=n_faces,
        max_error=max_error,
        max_triangles=max_triangles,
        regions=regions,
        chord_tolerance=chord_tolerance,
        planarize=planarize,
        vertices_only=vertices_only,
        path=path,
        vertices=vertices,
        face_method=face_method,
        centers=centers,
        vertex_weight=weight,
        anchor_weight=anchor_weight,
        min_region_size=min_region_size,
        repair=repair,
        smooth=smooth,
        use_labels=use_labels,
        estimate_normals=estimate,
        normal_k=normal_k,
        triangles=triangles,
        report=report,
        render=render,
    )
    _print_simplify(run_simplify(infile, out, options))


def _print_simplify(result) -> None:
    """The console lines of ``simplify``: the quality table of the path taken, then
    the files written."""
    shown = {"title": result.title, "diagonal": result.diagonal}
    if result.how is None:
        console.print(simplification_table(result.mesh, result.segmentation, **shown))
    else:
        console.print(surface_table(result.mesh, path=result.how, **shown))
    for path in result.written:
        say(f"written: {path}")


@demo_step
def demo_simplify(ps: PointSet, out_dir: Path, console) -> None:
    """Segmentation (VSA) and simplified polygon mesh, side by side."""
    result, obj, png, diagonal = simplify_files(ps, out_dir)
    console.print(simplification_table(result.mesh, result.segmentation, diagonal=diagonal))
    say(f"mesh: {obj}\npicture: {png}")
