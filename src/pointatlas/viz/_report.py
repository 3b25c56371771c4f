"""Self-contained HTML reports: summary, parameters, tables, pictures and 3-D views.

One file, no network: the viewer (a tree-shaken three.js bundle built by
``tools/viewer/build.sh`` into ``assets/viewer.min.js``) is inlined in a
``<script>`` element, PNG pictures are embedded as base64 data URLs and the
points of a 3-D view as base64 typed arrays. Large clouds are subsampled for the
view only (seeded, stated on the page); the numbers in the tables are whatever
the caller computed, on every point.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..io import to_json_safe
from ._view3d import MeshLayer, PointsLayer, view_data

__all__ = ["ReportSection", "viewer_script", "write_report"]

#: Points drawn in a 3-D view at most; more are subsampled (view only).
MAX_VIEW_POINTS = 100_000
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

_CSS = """
body{font-family:system-ui,sans-serif;max-width:1400px;margin:1.5em auto;padding:0 1em;
 color:#222}
h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ddd;padding-bottom:.2em}
table.pa-table{border-collapse:collapse;margin:.5em 0 1em;font-size:13px}
table.pa-table th,table.pa-table td{border:1px solid #ddd;padding:.2em .5em;text-align:left}
table.pa-table td.num{text-align:right;font-variant-numeric:tabular-nums}
table.pa-table thead th{background:#f3f3f3}
.pa-scroll{max-height:28em;overflow:auto;display:inline-block;max-width:100%}
figure{margin:.5em 0}figure img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:13px;color:#555}
pre.log{background:#f6f6f6;padding:.6em;overflow-x:auto;font-size:12px}
.pa-view{margin:.5em 0 1.5em}
.pa-toolbar{display:flex;gap:1.2em;align-items:center;margin-bottom:.4em;font-size:14px}
.pa-body{display:flex;gap:1em;align-items:flex-start}
.pa-canvas{width:720px;height:540px;border:1px solid #ccc;flex:none}
.pa-side{min-width:14em;font-size:13px}
.pa-legend-title{font-weight:bold;margin-bottom:.3em}
ul.pa-swatches{list-style:none;padding:0;margin:0;columns:2}
.pa-swatch{display:inline-block;width:.9em;height:.9em;border:1px solid #888;
 vertical-align:middle}
.pa-colorbar{height:1em;border:1px solid #888}
.pa-colorbar-ends{display:flex;justify-content:space-between}
.pa-pick{margin-top:1em}.pa-pick th{text-align:left;padding-right:.6em}
.pa-note{font-size:13px;color:#555}
.pa-header{display:flex;gap:2em;flex-wrap:wrap;align-items:flex-start}
table.pa-table caption{text-align:left;font-weight:bold}
"""


@dataclass(frozen=True, slots=True)
class ReportSection:
    """One titled part of a report (a demo step): text, tables, pictures, a 3-D view.

    Parameters
    ----------
    heading : str
        Section title.
    tables : mapping of str to table
        As in :func:`write_report`.
    pictures : sequence
        As in :func:`write_report`.
    layers : sequence of PointsLayer and MeshLayer
        The section's 3-D view (none when empty).
    log_html : str
        Trusted HTML shown first (e.g. a console log exported by ``rich``).
    links : sequence of str
        Files beside the report, linked by relative path.
    """

    heading: str
    tables: Mapping[str, Any] = field(default_factory=dict)
    pictures: Sequence[Any] = ()
    layers: Sequence[Any] = ()
    log_html: str = ""
    links: Sequence[str] = ()


def viewer_script() -> str:
    """The packaged viewer bundle (three.js and the report viewer), as JavaScript text."""
    text = (resources.files("pointatlas.viz") / "assets" / "viewer.min.js").read_text("utf-8")
    return text.replace("</script", "<\\/script")


# --------------------------------------------------------------------------- cells


def _is_number(value) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_
    )


def _cell(value) -> str:
    """A table cell; numbers get their exact value in ``data-value``."""
    if value is None:
        return "<td class='num' data-value='null'>&ndash;</td>"
    if _is_number(value):
        number = value.item() if hasattr(value, "item") else value
        if isinstance(number, float) and not math.isfinite(number):
            return f"<td class='num' data-value='{number}'>{number}</td>"
        text = f"{number:,}" if isinstance(number, int) else f"{number:.6g}"
        return f"<td class='num' data-value='{json.dumps(number)}'>{text}</td>"
    if isinstance(value, list | tuple | np.ndarray):
        items = [_short(v) for v in value]
        return f"<td>{html.escape(', '.join(items))}</td>"
    if isinstance(value, dict):
        return f"<td>{html.escape(json.dumps(to_json_safe(value, default=str)))}</td>"
    return f"<td>{html.escape(str(value))}</td>"


def _short(value) -> str:
    if _is_number(value):
        number = value.item() if hasattr(value, "item") else value
        return f"{number:.6g}" if isinstance(number, float) else str(number)
    return str(value)


def _table_html(name: str, table) -> str:
    """A mapping as a two-column table, a sequence of row mappings as a grid."""
    caption = html.escape(str(name))
    slug = html.escape(str(name), quote=True)
    if isinstance(table, Mapping):
        rows = "".join(
            f"<tr><th>{html.escape(str(k))}</th>{_cell(v)}</tr>" for k, v in table.items()
        )
        return (
            f"<table class='pa-table' data-table='{slug}'>"
            f"<caption>{caption}</caption>{rows}</table>"
        )
    rows = list(table)
    if not all(isinstance(r, Mapping) for r in rows):
        raise TypeError(f"table {name!r} must be a mapping or a sequence of mappings")
    columns: list[str] = []
    for r in rows:
        columns.extend(str(k) for k in r if str(k) not in columns)
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(_cell(dict(r).get(c)) for c in columns) + "</tr>" for r in rows)
    return (
        f"<div class='pa-scroll'><table class='pa-table' data-table='{slug}'>"
        f"<caption>{caption} ({len(rows):,} rows)</caption>"
        f"<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>"
    )


def _picture_html(item, link_from: Path | None = None) -> str:
    """``path`` or ``(caption, path or PNG bytes)`` as a ``<figure>``: embedded, or with
    ``link_from`` a picture given by path is referenced relative to that folder."""
    if isinstance(item, tuple):
        if len(item) != 2:
            raise TypeError("a picture is a path or a (caption, path or bytes) pair")
        caption, source = item
    else:
        caption, source = None, item
    if isinstance(source, bytes | bytearray):
        data = bytes(source)
    else:
        path = Path(os.fspath(source))
        data = path.read_bytes()
        caption = path.name if caption is None else caption
    if not data.startswith(_PNG_SIGNATURE):
        raise ValueError(f"picture {caption!r} is not a PNG")
    if link_from is not None and not isinstance(source, bytes | bytearray):
        ref = html.escape(Path(os.path.relpath(path, link_from)).as_posix(), quote=True)
        return f"<figure><img src='{ref}' alt='{ref}'></figure>"
    alt = html.escape(str(caption or "picture"), quote=True)
    src = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    cap = f"<figcaption>{html.escape(str(caption))}</figcaption>" if caption else ""
    return f"<figure><img src='{src}' alt='{alt}'>{cap}</figure>"


# --------------------------------------------------------------------------- views


def _view_html(view_id: str, layers, *, max_points: int, seed: int, up: str) -> str:
    """A 3-D view: toolbar (field switch, layer switches), canvas, legend, pick box, data."""
    rng = np.random.default_rng(seed)
    data, about = view_data(list(layers), max_points=max_points, rng=rng, up=up)
    tools = []
    if about["fields"]:
        options = "".join(
            f"<option value='{html.escape(f, quote=True)}'"
            f"{' selected' if f == about['initial_field'] else ''}>{html.escape(f)}</option>"
            for f in about["fields"]
        )
        tools.append(f"<label>colour by <select class='pa-field'>{options}</select></label>")
    for layer_id, name in about["layers"]:
        tools.append(
            f"<label><input type='checkbox' class='pa-layer' data-layer='{layer_id}' checked> "
            f"{html.escape(name)}</label>"
        )
    n, shown = about["n_points"], about["n_shown"]
    if n and shown < n:
        note = (
            f"Showing {shown:,} of {n:,} points: a uniform random subsample (seed {seed}) "
            "for this view only; every number on this page was computed on all points."
        )
    elif n:
        note = f"Showing all {n:,} points."
    else:
        note = ""
    note += " Drag to rotate, wheel to zoom, right-drag to pan, click a point to see its values."
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    return (
        f"<div class='pa-view' id='{view_id}'>"
        f"<div class='pa-toolbar'>{''.join(tools)}</div>"
        "<div class='pa-body'><div class='pa-canvas'></div>"
        "<div class='pa-side'><div class='pa-legend'></div>"
        "<div class='pa-pick'>click a point to see its index and values</div></div></div>"
        f"<p class='pa-note'>{html.escape(note.strip())}</p>"
        f"<script type='application/json' class='pa-data'>{payload}</script></div>"
    )


def _section_body(
    tables, pictures, layers, view_id: str, *, max_points: int, seed: int, up: str, link_from
) -> list[str]:
    parts = [_table_html(name, table) for name, table in dict(tables).items()]
    parts.extend(_picture_html(p, link_from) for p in pictures)
    if layers:
        parts.append(_view_html(view_id, layers, max_points=max_points, seed=seed, up=up))
    return parts


def _head_parts(title: str, summary, params, sections) -> list[str]:
    """The page head, the input and parameter tables, the list of sections."""
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1><header class='pa-header'>",
        _table_html("input", summary),
        _table_html("parameters", params),
        "</header>",
    ]
    if sections:
        links = "".join(
            f"<li><a href='#section-{i}'>{html.escape(sec.heading)}</a></li>"
            for i, sec in enumerate(sections, 1)
        )
        parts.append(f"<nav><ol>{links}</ol></nav>")
    return parts


def _extra_section(i: int, sec: ReportSection, **kwargs) -> list[str]:
    """One `ReportSection`: heading, log, tables, pictures, its own view, file links."""
    parts = [f"<section id='section-{i}'><h2>{html.escape(sec.heading)}</h2>", sec.log_html]
    parts.extend(_section_body(sec.tables, sec.pictures, sec.layers, f"view-{i}", **kwargs))
    for name in sec.links:
        ref = html.escape(str(name), quote=True)
        parts.append(f"<p>file: <a href='{ref}'>{html.escape(str(name))}</a></p>")
    parts.append("</section>")
    return parts


def write_report(
    path,
    *,
    title: str,
    summary: Mapping[str, Any],
    parameters: Mapping[str, Any],
    tables: Mapping[str, Any] | None = None,
    pictures: Sequence[Any] = (),
    layers: Sequence[PointsLayer | MeshLayer] = (),
    sections: Sequence[ReportSection] = (),
    seed: int = 0,
    up: str = "y",
    max_view_points: int = MAX_VIEW_POINTS,
    link_pictures: bool = False,
) -> Path:
    """Write a self-contained HTML report with an interactive 3-D view.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.html`` file to write (atomically).
    title : str
        Page title.
    summary : mapping of str to value
        The input: file, number of points, ... (a two-column table).
    parameters : mapping of str to value
        The parameters of the run; ``seed`` is added when missing.
    tables : mapping of str to table, optional
        Named tables of numbers: a mapping (one row per key) or a sequence of row
        mappings with the same keys. Every number keeps its exact value in the
        cell's ``data-value`` attribute; the text shows 6 significant digits.
    pictures : sequence of path or (caption, path or bytes)
        PNG pictures, embedded as base64.
    layers : sequence of PointsLayer and MeshLayer
        The 3-D view: at most one point layer (coloured by a chosen field, with a
        legend or colour bar, a field switch and click-to-pick) and any meshes.
    sections : sequence of ReportSection
        Further parts, each with its own tables, pictures and 3-D view.
    seed : int
        The run's seed, recorded with the parameters; it also draws the view's
        subsample of a large cloud.
    up : {"x", "y", "z"}
        Up axis of the initial camera (``"z"`` for lidar).
    max_view_points : int
        Points shown per view at most; larger clouds are subsampled for the view
        only, and the page says so.
    link_pictures : bool
        Reference pictures given as paths by their path relative to the report's
        folder instead of embedding them (the demo's folder of outputs); the page
        is then self-contained only together with those files.

    Returns
    -------
    path : pathlib.Path
        The file written.

    Raises
    ------
    ValueError, TypeError
        Bad layers (shapes, more than one point layer), a picture that is not a
        PNG, a table that is neither a mapping nor rows, ``max_view_points < 1``.

    Notes
    -----
    No network is used when the page is opened: the three.js viewer bundle is
    inlined, pictures and arrays are embedded. When every view has drawn its
    first frame the page sets ``window.pointatlasReady = true`` (browser tests
    wait for it). Decision record: ``docs/decisions/viz_report.md``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pointatlas.synth import cube
    >>> from pointatlas.viz import MeshLayer, PointsLayer
    >>> m = cube(4)
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "report.html"
    >>> _ = write_report(out, title="cube", summary={"points": m.n_vertices},
    ...                  parameters={"k": 8}, seed=3,
    ...                  tables={"z": {"mean": float(m.vertices[:, 2].mean())}},
    ...                  layers=[PointsLayer(m.vertices, {"z": m.vertices[:, 2]}),
    ...                          MeshLayer(m.vertices, m.faces)])
    >>> text = out.read_text()
    >>> text.count("class='pa-view'"), "data-value='3'" in text  # one view; the seed
    (1, True)
    """
    from ..io import atomic_write

    if int(max_view_points) < 1:
        raise ValueError(f"max_view_points must be at least 1; got {max_view_points!r}")
    params = dict(parameters)
    params.setdefault("seed", seed)
    folder = Path(os.fspath(path)).parent
    kwargs = {
        "max_points": int(max_view_points),
        "seed": int(seed),
        "up": up,
        "link_from": folder if link_pictures else None,
    }
    parts = _head_parts(title, summary, params, sections)
    body = _section_body(tables or {}, pictures, layers, "view-0", **kwargs)
    if body:
        parts.extend(["<section id='results'><h2>Results</h2>", *body, "</section>"])
    for i, sec in enumerate(sections, 1):
        parts.extend(_extra_section(i, sec, **kwargs))
    parts.append(f"<script>{viewer_script()}</script></body></html>")
    out = Path(os.fspath(path))
    with atomic_write(out, "w", newline="\n") as fh:
        fh.write("\n".join(parts))
    return out
