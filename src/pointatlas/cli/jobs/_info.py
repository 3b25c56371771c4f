"""The job of ``pointatlas info``: size, bounding box, spacing, k-NN components and
attributes of IN (`pointatlas.neighbors.point_set_info`), the table that shows them
and the HTML report."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rich.markup import escape
from rich.table import Table

from ..._core import PointAtlasError, PointSet
from ...io import MESH_EXTENSIONS, read_mesh, read_point_set
from ...neighbors import knn_components, point_set_info, query_knn
from .._outputs import check_outputs
from .._reports import REPORT_EXTENSIONS, report_layer, report_summary, report_up
from ._console import progress_bar
from ._inputs import read_input

__all__ = ["InfoOptions", "InfoResult", "info_fields", "info_table", "run_info"]


@dataclass(frozen=True, slots=True)
class InfoOptions:
    """The settings of ``pointatlas info``: ``k`` of the k-NN graph whose components
    are counted (``--k``)."""

    k: int = 8


@dataclass(frozen=True)
class InfoResult:
    """What `run_info` did: `point_set_info`'s dict with IN's name first (``file``),
    and the files written (the report, when asked)."""

    info: dict
    written: list


def run_info(in_path, out_path, options: InfoOptions, tiles=None) -> InfoResult:
    """``pointatlas info``: IN read whole (a bundled model's mesh counted), its summary
    computed and, when ``out_path`` is given, the HTML report written there (info's
    only output file, ``--report``). There is no tiled run: ``tiles`` must be None."""
    if tiles is not None:
        raise PointAtlasError("info has no tiled run (--tile-size)")
    file = Path(in_path)
    check_outputs([file], [("--report", out_path, REPORT_EXTENSIONS)])
    with progress_bar(f"reading {file.name}") as advance:
        ps, n_faces, face_sizes = _read_for_info(file)
        advance()
    with progress_bar("neighbourhoods") as advance:
        info = point_set_info(ps, k=options.k, n_faces=n_faces, face_sizes=face_sizes)
        advance()
    info = {"file": str(in_path), **info}
    written = []
    if out_path is not None:
        _write_info_report(out_path, file, ps, info)
        written.append(out_path)
    return InfoResult(info, written)


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _vec(v) -> str:
    return "(" + ", ".join(_fmt(float(c)) for c in v) + ")"


def info_table(info: dict, *, title: str | None = None) -> Table:
    """A rich table of :func:`point_set_info`'s dict."""
    table = Table(title=title, show_header=False, title_justify="left")
    table.add_column("property", style="bold")
    table.add_column("value")
    table.add_row("points", f"{info['points']:,}")
    if info["faces"] is not None:
        kind = f" ({info['face_kind']})" if info.get("face_kind") else ""
        table.add_row("faces", f"{info['faces']:,}{kind}")
    table.add_row("normals", "yes" if info["normals"] else "no")
    if info["bbox_min"] is not None:
        table.add_row("bounding box min", _vec(info["bbox_min"]))
        table.add_row("bounding box max", _vec(info["bbox_max"]))
        table.add_row("bounding box size", _vec(info["bbox_size"]))
    if info["mean_spacing"] is not None:
        table.add_row(f"mean spacing l ({info['mean_spacing_k']}-NN)", _fmt(info["mean_spacing"]))
    comp = f"{info['knn_components']:,}"
    if info["knn_components"] > 1:
        comp += f" (largest {info['largest_component']:,} points)"
    table.add_row(f"{info['knn_k']}-NN components", comp)
    table.add_row("duplicate points", f"{info['duplicates']:,}")
    attrs = info["attributes"]
    listed = ", ".join(
        f"{name} ({a['dtype']}{'x' + 'x'.join(map(str, a['shape'])) if a['shape'] else ''})"
        for name, a in attrs.items()
    )
    table.add_row("attributes", escape(listed) or "none")
    return table


def _read_for_info(path: Path):
    """Read a file (or a bundled model) for ``info``: all points, normals if usable,
    faces if a mesh."""
    n_faces = face_sizes = None
    if not path.exists() and not path.suffix:  # a bundled model name, or one clear error
        from ... import data

        ps = read_input(path)
        mesh = data.load_mesh(str(path))
        return ps, mesh.n_faces, mesh.face_sizes
    if path.suffix.lower() in MESH_EXTENSIONS:
        mesh = read_mesh(path)
        if mesh.n_faces or path.suffix.lower() != ".ply":
            n_faces, face_sizes = mesh.n_faces, mesh.face_sizes
    ps = read_point_set(path, zero_normals="drop")
    if "source_index" in ps.attributes:  # some points lack a normal: keep them all
        ps = read_point_set(path, with_normals=False)
    return ps, n_faces, face_sizes


def info_fields(points, info: dict) -> dict:
    """Per-point fields of ``info --report``: k-NN component and local spacing.

    ``knn_component`` numbers the components of the symmetric k-NN graph (k =
    ``info["knn_k"]``, as counted by `point_set_info`) by size, 0 the largest (ties:
    the one holding the smaller point index); ``spacing`` is a point's mean distance
    to its ``info["mean_spacing_k"]`` nearest other points, whose mean over all
    points is the mean spacing l. Empty below two points.
    """
    n = points.shape[0]
    if n < 2:
        return {}
    k_graph, k_l = info["knn_k"], info["mean_spacing_k"]
    indices, distances = query_knn(points, max(k_graph, k_l + 1))
    _, labels = knn_components(points, k_graph, neighbors=indices)
    sizes = np.bincount(labels)
    order = np.lexsort((np.arange(sizes.size), -sizes))  # largest first, then by label
    rank = np.empty(sizes.size, dtype=np.int64)
    rank[order] = np.arange(sizes.size)
    return {
        "knn_component": rank[labels],
        "spacing": distances[:, 1 : k_l + 1].mean(axis=1),
    }


def _write_info_report(path: Path, file: Path, ps: PointSet, info: dict) -> Path:
    """``info --report``: the summary numbers, the attributes and the points in 3-D."""
    from ...viz import write_report

    result = {key: value for key, value in info.items() if key not in ("file", "attributes")}
    tables = {"result": result}
    if info["attributes"]:
        tables["attributes"] = [
            {"attribute": name, "dtype": a["dtype"], "shape": a["shape"] or "per point"}
            for name, a in info["attributes"].items()
        ]
    layers = []
    if ps.n_points:
        fields = info_fields(ps.points, info)
        layers.append(report_layer(ps, fields, color_by="knn_component"))
    return write_report(
        path,
        title=f"pointatlas info: {Path(file).name}",
        summary=report_summary(file, ps),
        parameters={"k": info["knn_k"]},
        tables=tables,
        layers=layers,
        up=report_up(file),
    )
