"""The job of ``pointatlas normals``: IN read, PCA normals estimated and oriented,
OUT written with every input field (by tiles with ``tiles``), the report."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError
from ...normals import angle_error, compare_normals
from ._console import progress_bar
from ._inputs import read_keeping_normals
from ._normals import ORIENT_METHODS, compute_normals

__all__ = ["NormalsOptions", "NormalsResult", "run_normals"]


@dataclass(frozen=True, slots=True)
class NormalsOptions:
    """The settings of ``pointatlas normals`` (the flags of the same names).

    ``k``: PCA neighbourhood (the point itself included); ``orient``: one of
    `ORIENT_METHODS`; ``orient_k``: k of the orientation graph; ``viewpoint``: the
    sensor position of ``orient="viewpoint"``; ``report``: also an HTML report there.
    """

    k: int = 20
    orient: str = "mst"
    orient_k: int = 10
    viewpoint: tuple[float, float, float] | None = None
    report: Path | None = None

    def parameters(self) -> dict:
        """The settings a report lists."""
        return {
            "k": self.k,
            "orient": self.orient,
            "orient_k": self.orient_k,
            "viewpoint": self.viewpoint,
        }


@dataclass(frozen=True)
class NormalsResult:
    """What `run_normals` did: the points, seconds of the computation, the
    comparison with IN's own normals (None without), the files written and, by
    tiles, the tiled run's summary (the rest is then None)."""

    n_points: int
    seconds: float | None
    stats: dict | None
    written: list
    tiled: dict | None = None


def run_normals(in_path, out_path, options: NormalsOptions, tiles=None) -> NormalsResult:
    """``pointatlas normals``: PCA normals of IN, oriented, written to OUT with every
    input field (IN's own normals kept as ``input_normals`` and compared); by tiles
    when ``tiles`` (a `pointatlas.batch.TileOptions`) is given."""
    from ...batch import NormalsTileJob
    from ...io import POINT_WRITE_EXTENSIONS
    from .._outputs import check_outputs, check_point_output, write_point_output
    from .._reports import REPORT_EXTENSIONS
    from ._tiled import run_tiled

    o = options
    check_outputs(
        [in_path],
        [("OUT", out_path, POINT_WRITE_EXTENSIONS), ("--report", o.report, REPORT_EXTENSIONS)],
    )
    if o.orient not in ORIENT_METHODS:
        raise PointAtlasError(
            f"--orient must be one of {', '.join(ORIENT_METHODS)}; got {o.orient!r}"
        )
    if tiles is not None:
        job = NormalsTileJob(k=o.k, orient=o.orient, orient_k=o.orient_k, viewpoint=o.viewpoint)
        summary = run_tiled(
            "normals", job, in_path, out_path, tiles, report=o.report, parameters=o.parameters()
        )
        return NormalsResult(summary["points"], None, None, [], tiled=summary)
    ps, ours = read_keeping_normals(in_path)
    reference = ours.get("input_normals")
    check_point_output(out_path, ps.replace(normals=np.zeros((ps.n_points, 3)) + 1.0), ours)
    t0 = time.perf_counter()
    with progress_bar("normals", total=2) as advance:
        normals = compute_normals(
            ps.points,
            k=o.k,
            orient=o.orient,
            orient_k=o.orient_k,
            viewpoint=o.viewpoint,
            advance=advance,
        )
    seconds = time.perf_counter() - t0
    written = [write_point_output(out_path, ps.replace(normals=normals), ours)]
    stats = None if reference is None else compare_normals(normals, reference)
    if o.report is not None:
        _write_report(o.report, in_path, ps, normals, reference, stats, o.parameters(), seconds)
        written.append(o.report)
    return NormalsResult(ps.n_points, seconds, stats, written)


def _write_report(path, in_path, ps, normals, reference, stats, parameters, seconds):
    """``normals --report``: the comparison numbers and the points coloured by error/normal."""
    from ...viz import write_report
    from .._reports import report_layer, report_summary, report_up

    result = {"points": ps.n_points, "seconds": round(seconds, 3), **(stats or {})}
    ours = {}
    if reference is not None:
        ours["normal_error_deg"] = np.degrees(angle_error(normals, reference))
    ours.update(nx=normals[:, 0], ny=normals[:, 1], nz=normals[:, 2])
    write_report(
        path,
        title=f"pointatlas normals: {Path(in_path).name}",
        summary=report_summary(in_path, ps),
        parameters=parameters,
        tables={"result": result},
        layers=[report_layer(ps, ours)],
        up=report_up(in_path),
    )
