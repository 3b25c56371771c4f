"""``pointatlas cloudsurface``: its flags as `CloudSurfaceOptions` for the job
(`pointatlas.cli.jobs.run_cloudsurface`: the ball cover of a point set, Algorithm 2,
or the clouds of a mesh, Algorithm 1; thesis Chapter A), and what it prints."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .._core import PointAtlasError
from ._app import app, console, deprecated_option, guarded, renamed_flag, say
from .jobs import CloudSurfaceOptions, run_cloudsurface

__all__ = ["cloudsurface_command"]


_PathsArgument = Annotated[
    list[Path],
    typer.Argument(
        metavar="IN OUT_DIR",
        help="Point set or mesh file (or a bundled model name) and the output folder; "
        "with --from-mesh only OUT_DIR.",
    ),
]
_ModelOption = Annotated[
    str, typer.Option("--density", help="--from-mesh: density model eta1, eta2 or eta3.")
]
_COption = Annotated[
    float | None,
    typer.Option(
        "--density-c",
        help="--from-mesh: eta1/eta2 parameter c (default 0 for eta1, 1 for eta2).",
    ),
]


@app.command("cloudsurface")
@guarded
def cloudsurface_command(
    paths: _PathsArgument,
    scale: Annotated[
        float | None, typer.Option("--scale", help="Grid scale s of the ball cover.")
    ] = None,
    search: Annotated[
        tuple[float, float, float] | None,
        typer.Option("--search", help="Try scales SMIN SMAX STEP; keeps the first closed one."),
    ] = None,
    rotations: Annotated[
        int, typer.Option("--rotations", help="Random rotations tried (seeded by --seed).")
    ] = 0,
    offsets: Annotated[
        int,
        typer.Option("--offsets", help="Random lattice offsets tried with each rotation."),
    ] = 0,
    accept: Annotated[
        str | None,
        typer.Option("--accept", help="closed (default in 3-D) or open (boundary allowed)."),
    ] = None,
    dim: Annotated[int, typer.Option("--dim", help="3: Prop. 4; 2: a curve in the xy-plane.")] = 3,
    layout: Annotated[
        str, typer.Option("--layout", help="2-D cover: two-radius (Prop. 5 ii) or tiling (5 i).")
    ] = "two-radius",
    radius: Annotated[
        float | None, typer.Option("--radius", help="2-D cover: big radius in units of s.")
    ] = None,
    cloud_points: Annotated[
        str, typer.Option("--cloud-points", help="Realisation: centroid or center (ball).")
    ] = "centroid",
    from_mesh: Annotated[
        Path | None,
        typer.Option("--from-mesh", help="Generate clouds from this mesh (Algorithm 1)."),
    ] = None,
    model: _ModelOption = "eta1",
    c: _COption = None,
    c_v: Annotated[
        float, typer.Option("--density-c-v", help="--from-mesh: eta3 parameter c_v.")
    ] = 0.5,
    c_h: Annotated[
        float, typer.Option("--density-c-h", help="--from-mesh: eta3 parameter c_h.")
    ] = 0.5,
    t: Annotated[
        float,
        typer.Option("--radius-position", help="--from-mesh: ball radius position t in [0, 1)."),
    ] = 0.5,
    samples: Annotated[
        int, typer.Option("--samples", help="--from-mesh: samples per vertex and triangle.")
    ] = 10,
    curvature: Annotated[
        str, typer.Option("--curvature", help="--from-mesh: none, gaussian or mean scaling.")
    ] = "none",
    render: Annotated[
        bool, typer.Option("--render/--no-render", help="Write cloudsurface.png.")
    ] = True,
    seed: Annotated[int, typer.Option("--seed", help="Seed for rotations and sampling.")] = 0,
    html_report: Annotated[
        Path | None,
        typer.Option(
            "--report",
            help="Also write an HTML report with a 3-D view of the clouds and the complex.",
        ),
    ] = None,
    old_model: Annotated[str | None, deprecated_option("--model", "--density")] = None,
    old_c: Annotated[float | None, deprecated_option("--c", "--density-c")] = None,
    old_c_v: Annotated[float | None, deprecated_option("--c-v", "--density-c-v")] = None,
    old_c_h: Annotated[float | None, deprecated_option("--c-h", "--density-c-h")] = None,
    old_t: Annotated[float | None, deprecated_option("--t", "--radius-position")] = None,
):
    """Cloud surface of a point set (ball cover, Algorithm 2) or of a mesh (Algorithm 1).

    Writes into OUT_DIR the clouds (clouds.ply, Example 2 colours), the complex as a
    mesh, cloudsurface.npz (for ``deform``), report.txt, a picture and, last,
    report.json (topology report and the files of this run with their SHA-256).
    """
    model = renamed_flag("--density", model, "--model", old_model)
    c = renamed_flag("--density-c", c, "--c", old_c)
    c_v = renamed_flag("--density-c-v", c_v, "--c-v", old_c_v)
    c_h = renamed_flag("--density-c-h", c_h, "--c-h", old_c_h)
    t = renamed_flag("--radius-position", t, "--t", old_t)
    in_path, out_dir = _in_and_out(paths, from_mesh)
    options = CloudSurfaceOptions(
        scale=scale,
        search=search,
        rotations=rotations,
        offsets=offsets,
        accept=accept,
        dim=dim,
        layout=layout,
        radius=radius,
        cloud_points=cloud_points,
        from_mesh=from_mesh is not None,
        density=model,
        density_c=c,
        density_c_v=c_v,
        density_c_h=c_h,
        radius_position=t,
        samples=samples,
        curvature=curvature,
        render=render,
        seed=seed,
        report=html_report,
    )
    _print_cloudsurface(run_cloudsurface(in_path, out_dir, options))


def _in_and_out(paths: list[Path], from_mesh: Path | None) -> tuple[Path, Path]:
    """IN and OUT_DIR from the arguments: ``IN OUT_DIR``, or ``OUT_DIR`` with
    ``--from-mesh IN``."""
    if from_mesh is not None:
        if len(paths) != 1:
            raise PointAtlasError("with --from-mesh give only OUT_DIR (the mesh is the input)")
        return from_mesh, paths[0]
    if len(paths) != 2:
        raise PointAtlasError(f"give IN and OUT_DIR; got {len(paths)} path(s)")
    return paths[0], paths[1]


def _print_cloudsurface(result) -> None:
    """The console lines of ``cloudsurface``: Algorithm 1's draw, the search, the
    complex's topology, then the files written."""
    payload, report, chosen, res = result.payload, result.report, result.chosen, result.search
    n_clouds, seconds = result.n_clouds, payload["seconds"]
    if result.from_mesh:
        console.print(
            f"Algorithm 1 ({payload['model']}): {payload['n_points']:,} points in {n_clouds} "
            f"clouds; complex equals the mesh: {payload['complex_equals_mesh']}"
        )
    if res is not None:
        console.print(
            f"search: {res.accepted.size} of {res.scales.size} settings accepted; "
            f"using s = {chosen['scale']:g}, rotation {chosen['rotation']}, "
            f"offset {chosen['offset']}"
        )
    if result.dim == 3:
        console.print(
            f"{n_clouds} clouds: V {report.n_vertices}, E {report.n_edges}, "
            f"F {report.n_faces}, chi {report.euler_characteristic}, "
            f"closed {report.is_closed}, boundary loops {report.n_boundary_loops}, "
            f"orientable {report.is_orientable}, genus {report.genus}, "
            f"cloud surface {report.is_cloud_surface} ({seconds:.1f} s)"
        )
    else:
        console.print(
            f"{n_clouds} clouds: V {report.n_vertices}, E {report.n_edges}, "
            f"1-manifold {report.is_one_manifold}, closed {report.is_closed}, "
            f"components {report.n_components} ({seconds:.1f} s)"
        )
    for path in result.written:
        say(f"wrote {path}")
