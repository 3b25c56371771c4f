"""A CAD-like test scene sampled as a raw point cloud (for bench_vsa.py).

Ground plane with a round hole (wall and floor inside), three boxes (one turned
about z), a house with a gabled roof, a standing cylinder (tank) and a sphere
resting on the ground. Every patch is sampled uniformly by area; Gaussian noise
of ``noise`` (absolute units) is added along the exact normal.

    python benchmarks/scene.py OUT.ply [N]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

__all__ = ["cad_scene"]


def _rect(origin, u, v, n_pts, rng):
    """Points on the parallelogram origin + s u + t v, s, t in [0, 1]."""
    s, t = rng.random(n_pts), rng.random(n_pts)
    pts = origin + s[:, None] * u + t[:, None] * v
    normal = np.cross(u, v)
    normal = normal / np.linalg.norm(normal)
    return pts, np.tile(normal, (n_pts, 1))


def _triangle(a, b, c, n_pts, rng):
    s, t = rng.random(n_pts), rng.random(n_pts)
    flip = s + t > 1
    s[flip], t[flip] = 1 - s[flip], 1 - t[flip]
    pts = a + s[:, None] * (b - a) + t[:, None] * (c - a)
    normal = np.cross(b - a, c - a)
    return pts, np.tile(normal / np.linalg.norm(normal), (n_pts, 1))


def _box_patches(center, size, angle):
    """The five visible faces (no bottom) of a box standing on z = 0."""
    c, s = np.cos(angle), np.sin(angle)
    ex = np.array([c, s, 0.0]) * size[0]
    ey = np.array([-s, c, 0.0]) * size[1]
    ez = np.array([0.0, 0.0, size[2]])
    o = np.array([center[0], center[1], 0.0]) - ex / 2 - ey / 2
    return [
        ("rect", (o + ez, ex, ey)),  # top (+z)
        ("rect", (o, ex, ez)),  # -y side: normal = ex x ez
        ("rect", (o + ey, ez, ex)),  # +y side
        ("rect", (o, ez, ey)),  # -x side
        ("rect", (o + ex, ey, ez)),  # +x side
    ]


def _footprints():
    boxes = [((-5.0, 4.0), (4.0, 3.0, 2.0), 0.0), ((4.0, 5.0), (3.0, 3.0, 3.5), 0.5)]
    boxes.append(((-6.0, -5.0), (2.0, 5.0, 1.0), 0.0))
    house = ((1.0, -1.0), (4.0, 3.0, 2.5), 0.0)  # walls; roof ridge along x, height 1.5
    tank = ((7.0, -1.0), 1.2, 4.0)
    ball = ((-1.0, 6.5), 1.5)
    hole = ((4.0, -6.0), 1.5, 2.0)
    return boxes, house, tank, ball, hole


def cad_scene(n_points: int = 1_000_000, *, noise: float = 0.005, rng=0):
    """Sample the scene.

    Parameters
    ----------
    n_points : int
        Number of points (approximately uniform density over all surfaces).
    noise : float
        Standard deviation of the Gaussian noise along the normal (scene units;
        the scene spans 20 x 20 x 5 units).
    rng : seed or Generator

    Returns
    -------
    points : ndarray of shape (n_points, 3)
    normals : ndarray of shape (n_points, 3)
        Exact outward normals of the sampled patches (for evaluation only).
    part : ndarray of shape (n_points,), int64
        Index of the planar/curved patch every point comes from.
    """
    rng = np.random.default_rng(rng)
    boxes, house, tank, ball, hole = _footprints()
    patches = []  # (kind, params, area)
    for center, size, angle in boxes:
        for kind, par in _box_patches(center, size, angle):
            patches.append((kind, par))
    (hx, hy), (lx, ly, hz), _ = house
    o = np.array([hx - lx / 2, hy - ly / 2, 0.0])
    ex, ey, ez = np.array([lx, 0, 0.0]), np.array([0, ly, 0.0]), np.array([0, 0, hz])
    patches += [
        ("rect", (o, ex, ez)),
        ("rect", (o + ey, ez, ex)),
        ("rect", (o, ez, ey)),
        ("rect", (o + ex, ey, ez)),
    ]
    ridge = np.array([0, ly / 2, hz + 1.5])
    top_front, top_back = o + ez, o + ey + ez
    patches += [
        ("rect", (top_front, ex, ridge - ez)),  # roof slope towards -y
        ("rect", (top_back, ridge - ez - ey, ex)),  # roof slope towards +y
        ("tri", (top_front, o + ridge, top_back)),  # gable -x
        ("tri", (top_front + ex, top_back + ex, o + ridge + ex)),  # gable +x
    ]
    patches.append(("cyl", (tank[0], tank[1], 0.0, tank[2], 1.0)))
    patches.append(("disk", (tank[0], tank[2], tank[1])))
    patches.append(("sphere", (ball[0], ball[1])))
    patches.append(("cyl", (hole[0], hole[1], -hole[2], 0.0, -1.0)))  # hole wall (inward)
    patches.append(("disk", (hole[0], -hole[2], hole[1])))  # hole floor
    patches.append(("ground", ()))

    def area(kind, par):
        if kind == "rect":
            return np.linalg.norm(np.cross(par[1], par[2]))
        if kind == "tri":
            return 0.5 * np.linalg.norm(np.cross(par[1] - par[0], par[2] - par[0]))
        if kind == "cyl":
            return 2 * np.pi * par[1] * (par[3] - par[2])
        if kind == "disk":
            return np.pi * par[2] ** 2
        if kind == "sphere":
            r = ball[1]
            return 4 * np.pi * r * r * 0.5 * (1 + 0.8)  # cap above z = 0 (centre 0.8 r up)
        return 400.0  # ground, approximately (footprints removed by rejection)

    areas = np.array([area(k, p) for k, p in patches])
    counts = rng.multinomial(n_points, areas / areas.sum())
    pts_all, nrm_all, part_all = [], [], []
    for idx, ((kind, par), cnt) in enumerate(zip(patches, counts, strict=True)):
        if cnt == 0:
            continue
        if kind == "rect":
            p, n = _rect(*par, cnt, rng)
        elif kind == "tri":
            p, n = _triangle(*par, cnt, rng)
        elif kind == "cyl":
            (x, y), r, z0, z1, sign = par
            phi, z = rng.random(cnt) * 2 * np.pi, z0 + rng.random(cnt) * (z1 - z0)
            n = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(cnt)])
            p = np.column_stack([x + r * n[:, 0], y + r * n[:, 1], z])
            n = n * sign
        elif kind == "disk":
            (x, y), z, r = par
            rad, phi = r * np.sqrt(rng.random(cnt)), rng.random(cnt) * 2 * np.pi
            p = np.column_stack([x + rad * np.cos(phi), y + rad * np.sin(phi), np.full(cnt, z)])
            n = np.tile([0.0, 0.0, 1.0], (cnt, 1))
        elif kind == "sphere":
            (x, y), r = par[0], ball[1]
            zc = 0.8 * r
            v = rng.normal(size=(cnt * 2, 3))
            v /= np.linalg.norm(v, axis=1, keepdims=True)
            v = v[zc + r * v[:, 2] > 0][:cnt]
            while v.shape[0] < cnt:
                w = rng.normal(size=(cnt, 3))
                w /= np.linalg.norm(w, axis=1, keepdims=True)
                v = np.vstack([v, w[zc + r * w[:, 2] > 0]])[:cnt]
            p = np.array([x, y, zc]) + r * v
            n = v
        else:  # ground with the footprints and the hole removed
            got = []
            need = cnt
            while need > 0:
                q = rng.random((need * 2, 2)) * 20 - 10
                keep = _ground_free(q, boxes, house, tank, ball, hole)
                got.append(q[keep][:need])
                need -= got[-1].shape[0]
            q = np.vstack(got)
            p = np.column_stack([q, np.zeros(cnt)])
            n = np.tile([0.0, 0.0, 1.0], (cnt, 1))
        pts_all.append(p)
        nrm_all.append(n)
        part_all.append(np.full(cnt, idx, dtype=np.int64))
    points = np.vstack(pts_all)
    normals = np.vstack(nrm_all)
    points = points + rng.normal(scale=noise, size=(points.shape[0], 1)) * normals
    return points, normals, np.concatenate(part_all)


def _ground_free(q, boxes, house, tank, ball, hole):
    keep = np.ones(q.shape[0], dtype=bool)
    for (cx, cy), (sx, sy, _), angle in [*boxes, house]:
        c, s = np.cos(angle), np.sin(angle)
        dx, dy = q[:, 0] - cx, q[:, 1] - cy
        u, v = c * dx + s * dy, -s * dx + c * dy
        keep &= ~((np.abs(u) < sx / 2) & (np.abs(v) < sy / 2))
    for (cx, cy), r in [(tank[0], tank[1]), (hole[0], hole[1])]:
        keep &= (q[:, 0] - cx) ** 2 + (q[:, 1] - cy) ** 2 > r * r
    (bx, by), br = ball
    rc = br * np.sqrt(1 - 0.8**2)  # where the sphere meets the ground
    keep &= (q[:, 0] - bx) ** 2 + (q[:, 1] - by) ** 2 > rc * rc
    return keep


def main(argv=None) -> int:
    """Write the scene's points to OUT (``python benchmarks/scene.py OUT.ply [N]``)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="the point file to write (.ply, .xyz, .las, ...)")
    ap.add_argument("n", nargs="?", type=int, default=1_000_000, help="points (default 10^6)")
    args = ap.parse_args(argv)
    pts, _, _ = cad_scene(args.n)
    from pointatlas.io import write_point_set

    write_point_set(args.out, pts)
    print(f"wrote {pts.shape[0]} points to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
