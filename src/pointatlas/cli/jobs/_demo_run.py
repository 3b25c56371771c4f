"""``pointatlas demo`` below the command: the bundled model loaded, the steps run in
order with their console recorded, and ``report.html`` (each step's log, pictures,
files and 3-D view)."""

from __future__ import annotations

import time
from pathlib import Path

from ..._core import PointAtlasError, PointSet
from ...io import POINT_WRITE_EXTENSIONS, read_mesh, read_point_set
from .._outputs import check_outputs
from .._reports import report_layer
from ._console import console

__all__ = ["bundled_data", "run_demo_steps", "write_demo_report"]


def bundled_data():
    """The `pointatlas.data` room (the bundled models), or one error where it is
    missing."""
    try:
        from ... import data
    except ImportError as exc:  # pragma: no cover - the data room ships with the package
        raise PointAtlasError(f"bundled models are not available ({exc})") from None
    return data


def run_demo_steps(out_dir: Path, steps, *, model: str) -> list[Path]:
    """Run the demo ``steps`` (each ``step(ps, out_dir, console)``: the registry is
    `pointatlas.cli._app.DEMO_STEPS`) in order on the bundled ``model`` in
    ``out_dir`` (created), then write ``report.html``; returns the files written."""
    out_dir = Path(out_dir)
    check_outputs([], folders=[("--out", out_dir)])
    out_dir.mkdir(exist_ok=True)
    data = bundled_data()
    if model not in data.names():
        raise PointAtlasError(f"unknown model {model!r}; bundled: {', '.join(data.names())}")
    ps = data.load(model)
    start = time.time() - 1.0
    steps = list(steps)
    sections = []
    seen: set[str] = set()
    was_recording = console.record
    console.record = True
    console.export_text(clear=True)  # drop anything recorded before the demo
    try:
        for i, step in enumerate(steps, 1):
            heading = (step.__doc__ or step.__name__).strip().splitlines()[0]
            step_start = time.time() - 1.0
            console.rule(f"[bold]{i}/{len(steps)}  {heading}", align="left")
            result = step(ps, out_dir, console)
            if isinstance(result, PointSet):
                ps = result
            text = console.export_html(
                clear=True, inline_styles=True, code_format="<pre class='log'>{code}</pre>"
            )
            files = sorted(
                p.name
                for p in out_dir.iterdir()
                if p.is_file() and p.stat().st_mtime >= step_start and p.name not in seen
            )
            seen.update(files)
            layers = _step_layers(out_dir, files, ps)
            sections.append((f"{i}/{len(steps)} {heading}", text, files, layers))
    finally:
        console.record = was_recording
    write_demo_report(out_dir / "report.html", model, sections)
    return sorted(p for p in out_dir.iterdir() if p.is_file() and p.stat().st_mtime >= start)


def _step_layers(out_dir: Path, files, ps: PointSet) -> list:
    """The 3-D view of a demo step: the point set and meshes it wrote.

    The first point file of the step is shown with its fields; without one, the
    demo's current point set (with the fields the steps so far added). Mesh files
    (.obj, .off, .stl) are shown as surfaces.
    """
    from ...viz import MeshLayer

    point_set = None
    meshes = []
    for name in files:
        ext = Path(name).suffix.lower()
        if ext in (".obj", ".off", ".stl"):
            mesh = read_mesh(out_dir / name)
            if mesh.n_faces:
                meshes.append(
                    MeshLayer(mesh.vertices, mesh.faces, face_offsets=mesh.face_offsets, name=name)
                )
        elif ext in POINT_WRITE_EXTENSIONS and point_set is None:
            point_set = read_point_set(out_dir / name, zero_normals="drop")
    return [report_layer(point_set if point_set is not None else ps, {}), *meshes]


def write_demo_report(path: Path, model: str, sections) -> Path:
    """Write the demo's HTML report: each step's console output, pictures, files and 3-D view.

    ``sections`` is a list of ``(heading, html_of_console_output, file_names,
    layers)``; PNGs are shown inline and other files linked (paths relative to the
    report's folder); ``layers`` (`pointatlas.viz.PointsLayer` / ``MeshLayer``)
    make the step's interactive 3-D view.
    """
    from ...viz import ReportSection, write_report

    path = Path(path)
    folder = path.parent
    parts = []
    for heading, text, files, layers in sections:
        parts.append(
            ReportSection(
                heading,
                log_html=text,
                pictures=[folder / name for name in files if name.endswith(".png")],
                layers=layers,
                links=[n for n in files if not n.endswith(".png") and n != path.name],
            )
        )
    return write_report(
        path,
        title=f"pointatlas demo on the bundled model {model}",
        summary={"model": model},
        parameters={"steps": ", ".join(heading for heading, *_ in sections)},
        sections=parts,
        link_pictures=True,
    )
