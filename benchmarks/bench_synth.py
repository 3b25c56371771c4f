"""Build times of the synth shapes and of sampling / noise at 10**6 points.

Times (best of ``--repeat``): the thesis-size meshes (cube 386/1,538, dodecahedron
962/3,842, octahedron 16,386, icospheres 2,562/10,242), a 10,000-point Fibonacci sphere
with its hull, a 10**6-point Fibonacci sphere without faces, ``sample_mesh`` of ``--n``
points on the 10,242-vertex icosphere and ``add_normal_noise`` on them (k = 12, the
mean-spacing query included).

Run: ``.venv/bin/python benchmarks/bench_synth.py [--n 1000000] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import time

from pointatlas import synth


def best_of(func, repeat: int):
    """Smallest wall time of ``repeat`` calls (seconds) and the last result."""
    times, result = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - t0)
    return min(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    cases = [
        ("cube(8)", lambda: synth.cube(8)),
        ("cube(16)", lambda: synth.cube(16)),
        ("dodecahedron(4)", lambda: synth.dodecahedron(4)),
        ("dodecahedron(8)", lambda: synth.dodecahedron(8)),
        ("octahedron(64)", lambda: synth.octahedron(64)),
        ("icosphere(4)", lambda: synth.icosphere(4)),
        ("icosphere(5)", lambda: synth.icosphere(5)),
        ("fibonacci_sphere(10000)", lambda: synth.fibonacci_sphere(10_000)),
        (
            f"fibonacci_sphere({args.n}, triangulate=False)",
            lambda: synth.fibonacci_sphere(args.n, triangulate=False),
        ),
    ]
    for label, func in cases:
        seconds, mesh = best_of(func, args.repeat)
        print(f"{label:45s} {mesh.n_vertices:>9d} vertices  {seconds * 1e3:9.1f} ms")
    ico = synth.icosphere(5)
    seconds, sample = best_of(
        lambda: synth.sample_mesh(ico.vertices, ico.faces, args.n, rng=0), args.repeat
    )
    print(f"{'sample_mesh(icosphere(5), n)':45s} {args.n:>9d} points    {seconds * 1e3:9.1f} ms")
    seconds, _ = best_of(
        lambda: synth.add_normal_noise(sample.points, sample.normals, 0.25, rng=0), args.repeat
    )
    print(f"{'add_normal_noise(k=12)':45s} {args.n:>9d} points    {seconds * 1e3:9.1f} ms")


if __name__ == "__main__":
    main()
