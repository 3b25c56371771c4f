"""Does any denoiser, at its defaults, end farther from the true surface than its input?

For every method of `pointatlas.denoise.denoise` at its defaults, the RMS distance to
the true surface before and after, on

- the noisy/clean pairs of ``../shared/data/models/noisy`` and the CAD and organic
  models with 1-3 % isotropic noise of the bounding-sphere radius (the inputs of
  ``bench_denoise.py``; exact point-to-mesh distance to the clean mesh), given no
  normals (they are estimated, as the CLI does for a file without normals);
- sampled thin plates: two 1 x 1 squares, ``--plate-points`` uniform points each,
  ``thickness`` noise sigmas apart, Gaussian noise of sigma = ``noise`` l along
  the normal (l = 1 / sqrt(points per side)); the distance to the nearest of the
  two planes is analytic. Each plate runs with its oriented normals (``N``) and
  without (``-``: estimated).

Columns: ``input`` and ``out`` (RMS distance), ``ratio`` = out / input (must be
< 1), and for plates ``side+`` / ``side-``: the mean signed offset of each side's
points from the mid-plane in noise sigmas (the side's own sign keeps it on its side).

    python benchmarks/bench_denoise_quality.py [--data ../shared/data]
        [--inputs NAME,...] [--methods NAME,...] [--no-plates] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_denoise import inputs  # noqa: E402

from pointatlas.denoise import DENOISE_METHODS, denoise  # noqa: E402
from pointatlas.neighbors import point_mesh_distance  # noqa: E402

METHODS = tuple(m for m in DENOISE_METHODS if m != "auto")
THICKNESSES = (1.0, 1.6, 2.5)
NOISE_L = (0.1, 0.3, 0.6)


def thin_plate(n_side: int, thickness: float, noise: float, rng=0):
    """Two noisy parallel squares; returns (points, normals, side, h, sigma)."""
    gen = np.random.default_rng(rng)
    side = np.repeat([1.0, -1.0], n_side)
    sigma = noise / np.sqrt(n_side)
    h = thickness * sigma
    xy = gen.uniform(0.0, 1.0, (2 * n_side, 2))
    z = side * h / 2 + gen.normal(0.0, sigma, 2 * n_side)
    normals = np.zeros((2 * n_side, 3))
    normals[:, 2] = side
    return np.c_[xy, z], normals, side, h, sigma


def plate_rms(points, h) -> float:
    z = points[:, 2]
    d = np.minimum(np.abs(z - h / 2), np.abs(z + h / 2))
    return float(np.sqrt(np.mean(d**2)))


def mesh_rms(points, cv, cf) -> float:
    return float(np.sqrt(np.mean(point_mesh_distance(points, cv, cf) ** 2)))


def _row(rows, name, method, before, after, extra=""):
    rows.append({"input": name, "method": method, "before": before, "after": after})
    flag = "" if after < before else "  WORSE"
    ratio = after / before
    print(
        f"{name:28s} {method:24s} {before:10.4g} {after:10.4g} {ratio:6.3f}{extra}{flag}",
        flush=True,
    )


def run_meshes(data, methods, keep, rows):
    for name, noisy, cv, cf, _ in inputs(data):
        if keep and not any(name.startswith(w) for w in keep):
            continue
        before = mesh_rms(noisy, cv, cf)
        for method in methods:
            out = denoise(noisy, None, method=method).points
            _row(rows, name, method, before, mesh_rms(out, cv, cf))


def run_plates(methods, n_side, rows):
    for t in THICKNESSES:
        for noise in NOISE_L:
            pts, nrm, side, h, sigma = thin_plate(n_side, t, noise)
            before = plate_rms(pts, h)
            for method in methods:
                for given in (nrm, None):
                    out = denoise(pts, given, method=method).points
                    offs = [float((out[side == s, 2] * s).mean() / sigma) for s in (1, -1)]
                    name = f"plate_{t}sd_{noise}l_{'N' if given is not None else '-'}"
                    _row(
                        rows,
                        name,
                        method,
                        before,
                        plate_rms(out, h),
                        f"  side+ {offs[0]:+.2f} side- {offs[1]:+.2f}",
                    )
                    rows[-1]["side_offsets"] = offs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--inputs", default="", help="keep inputs starting with these words")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--no-plates", action="store_true")
    ap.add_argument("--plate-points", type=int, default=2000)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    keep = [w for w in args.inputs.split(",") if w]
    methods = [m for m in args.methods.split(",") if m]
    rows: list[dict] = []
    print(f"{'input':28s} {'method':24s} {'input RMS':>10s} {'out RMS':>10s} {'ratio':>6s}")
    if not keep or not all(w.startswith("plate") for w in keep):
        run_meshes(args.data, methods, [w for w in keep if not w.startswith("plate")], rows)
    if not args.no_plates and (not keep or any(w.startswith("plate") for w in keep)):
        run_plates(methods, args.plate_points, rows)
    worse = [r for r in rows if r["after"] >= r["before"]]
    print(f"{len(worse)} of {len(rows)} runs end farther from the surface than their input")
    if args.out:
        args.out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
