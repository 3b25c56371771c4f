"""One SHA-256 per output file of every command, run on the bundled models.

A refactoring of the CLI must leave every output as it was, bit for bit. This script
runs each command (``info``, ``normals``, ``features``, ``segment``, ``simplify``,
``denoise``, ``render``, ``cloudsurface``, ``deform``, ``data``, ``demo``) on the
bundled models, plus tiled runs of ``normals``, ``features``, ``segment`` and
``denoise`` (LAS streamed and a PLY read whole) on an in-process dask cluster, in
an empty temporary folder, and prints ``sha256  path`` for every file written,
sorted by path. Save the lines before a change and compare after it::

    .venv/bin/python tools/outputs_digest.py > before.txt
    ... change ...
    .venv/bin/python tools/outputs_digest.py > after.txt && diff before.txt after.txt

What is hashed (only what a run may vary is left out):

- JSON reports: the parsed content, keys sorted, without timings (keys naming
  seconds) and with the temporary folder's path replaced; in the ``files`` records
  of a summary the size and SHA-256 of HTML files (which show timings) are left out;
- HTML reports: the text with timings (``1.23 s``, the numbers of rows naming
  seconds or time) and the temporary folder's path replaced;
- LAS/LAZ: the header's version, point format, scales, offsets, point count and
  VLRs, and the point records (not the file's creation date);
- ``.npz``: every array's name, dtype, shape and bytes (not the zip's time stamps);
- every other file (PLY, OBJ, OFF, STL, XYZ, CSV, TXT, PNG): its bytes.

``--keep DIR`` runs in DIR (created, must be empty) and leaves the files there;
``--only WORD`` runs the command lines containing WORD (a quicker check).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shlex
import sys
import tempfile
from pathlib import Path

#: The command lines, run in order in one folder; later lines read earlier outputs.
#: A tiled run (``--tile-size``) gets ``--scheduler`` of an in-process dask cluster.
COMMANDS: list[str] = [
    # inputs
    "data export fandisk fandisk.ply",
    "data export fandisk fandisk_pts.ply --points",
    "data export hand scan.las",
    "data export hand hand.obj",
    "data export cube part.stl",
    "data export synth:cube cube_labels.ply",
    "data list --json",
    # info
    "info fandisk.ply",
    "info scan.las --report info.html",
    "info fandisk --json --k 12",
    # normals
    "normals scan.las scan.ply --k 20",
    "normals fandisk.ply normals_fandisk.ply --report normals.html",
    "normals fandisk normals_up.ply --orient up --k 12",
    "normals synth:sphere normals_out.ply --orient outward",
    "normals hand normals_vp.ply --orient viewpoint --viewpoint 0 0 3",
    "normals hand normals_none.ply --orient none --orient-k 6",
    # segment
    "segment fandisk.ply seg.ply --eta 25 --render seg.png",
    "segment scan.las scan_seg.ply --max-angle-deg 10 --estimate-normals",
    "segment fandisk.ply seg_report.ply --report seg.html",
    "segment fandisk seg_rg.ply --method region-growing --smoothness-deg 20",
    "segment fandisk seg_classic.ply --seeds 40 --classic --weights area",
    "segment hand seg_local.ply --local --eta 0.5 --min-region-size 0",
    "segment scan.las seg_nk.las --normal-k 12 --k 10 --no-split",
    # simplify
    "simplify fandisk fandisk.obj --render mesh.png",
    "simplify fandisk fandisk_simple.ply --triangles fandisk_tri.ply",
    "simplify part.stl part.obj --faces 6 --report r.json",
    "simplify fandisk fandisk_800.obj --max-triangles 800",
    "simplify eight eight_regions.obj --regions --report eight.html",
    "simplify part.stl part_simple.stl",
    "simplify scan.ply scan.obj --eta 20 --report scan_simplify.json",
    "simplify fandisk fandisk_v.obj --vertices-only --eta 20",
    "simplify seg.ply from_labels.obj --report labels.json",
    "simplify synth:cube cube_opt.off --vertices optimize --vertex-weight 2",
    "simplify fandisk_pts.ply fandisk_robust.obj --path robust",
    # features
    "features fandisk.ply feats.ply --k-range 6 20 --render feats.png",
    "features scan.las scan_feats.las --estimate-normals --k 20",
    "features fandisk feats_eq.ply --weighting equal --k 10 --report f.html",
    "features fandisk feats_ent.ply --weighting equal --k-range 6 12 --criterion eigenentropy",
    "features hand feats_up.ply --estimate-normals --orient up --k 12",
    "features hand feats_grid.ply --a-grid-deg 0,45 --b-grid-deg 45,90 --flatness 4 6 --k 10",
    "features hand feats_small.ply --weighting equal --render feats_s.png --render-size 200",
    # denoise
    "denoise scan.ply clean.ply --method normal-voting-adaptive --clean hand.obj",
    "denoise fandisk dn_flat.ply --method flatness --n-iter 3 --render dn.png --report dn.html "
    "--plane-weight 0.5 --k 20",
    "denoise hand dn.xyz",
    "denoise fandisk_pts.ply dn_vote.ply --n-iter 2 --filter-iter 3 --no-planes --rho 0.8",
    "denoise scan.las dn_est.ply --estimate-normals --normal-k 12",
    "denoise hand dn_dec.ply --method flatness --schedule decreasing --k 10 --k-start 30 "
    "--n-iter 2 --eps 0.05",
    # render
    "render seg.ply seg_render.png --color-by label",
    "render fandisk.ply fandisk_render.png --render-size 300 200 --azimuth-deg 60",
    # cloudsurface and deform
    "cloudsurface synth:sphere cs --search 0.6 1.2 0.1 --rotations 3",
    "cloudsurface torus_coarse cs_t --scale 0.25 --report cs_t.html",
    "cloudsurface cs_m --from-mesh hand --density eta2 --samples 4",
    "cloudsurface cs_m3 --from-mesh cube --density eta3 --density-c-v 0.4 --density-c-h 0.6 "
    "--radius-position 0.3 --no-render",
    "cloudsurface synth:plane_patch cs_2d --dim 2 --scale 0.2",
    "deform cs cs/complex.ply deformed.ply --report deform.html",
    "deform cs cs/complex.ply back.ply --inverse",
    # tiled: LAS streamed, and a PLY (or bundled model) read whole
    "normals scan.las tiled_normals.laz --tile-size 0.3",
    "segment scan.las tiled_seg.las --tile-size 0.4 --local",
    "segment fandisk.ply tiled_seg.ply --tile-size 2 --report tiled_seg.html",
    "features fandisk_pts.ply tiled_feats.ply --estimate-normals --k 14 --tile-size 2",
    "features scan.las tiled_feats.laz --weighting equal --k 10 --tile-size 0.3",
    "features hand tiled_feats_sig.ply --k-range 6 10 --tile-size 0.3",
    "denoise fandisk_pts.ply tiled_dn.ply --method flatness --n-iter 2 --tile-size 2",
    "denoise scan.las tiled_dn.las --method normal-voting --n-iter 1 --tile-size 0.4",
    # the demo
    "demo --out demo-output",
]

#: Numbers that are timings: "1.23 s" in text, and JSON keys naming seconds.
_TIMING = re.compile(r"\d+(?:\.\d+)? ?s\b")
_SECONDS_KEY = re.compile(r"second|elapsed|^time$", re.I)
#: An HTML table row whose heading names a timing: its value cell is dropped.
_TIMING_ROW = re.compile(r"(<th[^>]*>[^<]*(?:second|time)[^<]*</th>\s*)<td[^>]*>[^<]*</td>")


def _replaced(text: str, subs: dict) -> str:
    for old, new in subs.items():
        text = text.replace(old, new)
    return text


def _json_clean(value, subs: dict):
    if isinstance(value, dict):
        out = {}
        for key, val in value.items():
            if _SECONDS_KEY.search(str(key)):
                continue
            out[key] = _json_clean(val, subs)
        if "path" in out and str(out["path"]).endswith((".html", ".htm")):
            out.pop("sha256", None)
            out.pop("bytes", None)
        return out
    if isinstance(value, list):
        return [_json_clean(v, subs) for v in value]
    if isinstance(value, str):
        return _replaced(value, subs)
    return value


def _html_clean(text: str, subs: dict) -> str:
    text = _replaced(text, subs)
    text = _TIMING_ROW.sub(r"\1<td><t></td>", text)
    # the seconds in the embedded JSON of a table, and "1.2 s" in console logs
    text = re.sub(r'("[^"]*(?:second|time)[^"]*"\s*:\s*)[-0-9.eE]+', r"\1<t>", text)
    return _TIMING.sub("<t> s", text)


def _las_digest(path: Path) -> str:
    import laspy

    las = laspy.read(path)
    h = hashlib.sha256()
    head = las.header
    h.update(repr((str(head.version), head.point_format.id, head.point_count)).encode())
    h.update(head.scales.tobytes() + head.offsets.tobytes())
    for vlr in head.vlrs:
        h.update(repr((vlr.user_id, vlr.record_id, vlr.description)).encode())
        h.update(bytes(getattr(vlr, "record_data", b"") or b""))
    h.update(repr(list(las.point_format.dimension_names)).encode())
    h.update(las.points.array.tobytes())
    return h.hexdigest()


def _npz_digest(path: Path) -> str:
    import numpy as np

    h = hashlib.sha256()
    with np.load(path, allow_pickle=False) as z:
        for name in sorted(z.files):
            arr = z[name]
            h.update(repr((name, arr.dtype.str, arr.shape)).encode())
            h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


def digest(path: Path, subs: dict) -> str:
    """The SHA-256 of one output file, as the module docstring describes; ``subs``
    maps what a run may vary (its folder, the scheduler's address) to a fixed text."""
    ext = path.suffix.lower()
    if ext == ".json":
        body = _json_clean(json.loads(path.read_text()), subs)
        data = json.dumps(body, sort_keys=True).encode()
    elif ext in (".html", ".htm"):
        data = _html_clean(path.read_text(), subs).encode()
    elif ext in (".las", ".laz"):
        return _las_digest(path)
    elif ext == ".npz":
        return _npz_digest(path)
    else:
        data = path.read_bytes()
    return hashlib.sha256(data).hexdigest()


def run_all(folder: Path, only: str | None = None) -> list[str]:
    """Run `COMMANDS` in ``folder``; returns the digest lines (stdout of ``--json``
    commands included as ``stdout-N.json``)."""
    import distributed
    from typer.testing import CliRunner

    from pointatlas.cli import app

    runner = CliRunner()
    lines = []
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as cluster:
        address = cluster.scheduler_address
        here = os.getcwd()
        os.chdir(folder)
        try:
            for i, line in enumerate(COMMANDS):
                if only is not None and only not in line:
                    continue
                args = shlex.split(line)
                if "--tile-size" in args:
                    args += ["--scheduler", address]
                result = runner.invoke(app, args)
                if result.exit_code != 0:
                    raise SystemExit(f"pointatlas {line}: exit {result.exit_code}\n{result.output}")
                if "--json" in args:
                    (folder / f"stdout-{i:02d}.json").write_text(result.stdout)
                print(f"ran {line}", file=sys.stderr)
        finally:
            os.chdir(here)
    subs = {str(folder.resolve()): "<tmp>", address: "<scheduler>"}
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        rel = path.relative_to(folder).as_posix()
        lines.append(f"{digest(path, subs)}  {rel}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", type=Path, help="run in this (empty) folder and keep it")
    parser.add_argument("--only", help="run only the command lines with this word")
    args = parser.parse_args()
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
        if any(args.keep.iterdir()):
            raise SystemExit(f"{args.keep}: not empty")
        lines = run_all(args.keep, args.only)
    else:
        with tempfile.TemporaryDirectory(prefix="pointatlas-digest-") as tmp:
            lines = run_all(Path(tmp), args.only)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
