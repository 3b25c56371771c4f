"""Labelled test shapes in plain numpy: flat faces sampled on grids, exact normals."""

from __future__ import annotations

import numpy as np


def rect(origin, e1, e2, n1, n2, label, *, jitter=0.0, rng=None):
    """Cell-centred samples of the rectangle origin + s e1 + t e2, normal e1 x e2."""
    origin, e1, e2 = (np.asarray(v, dtype=float) for v in (origin, e1, e2))
    s, t = np.meshgrid((np.arange(n1) + 0.5) / n1, (np.arange(n2) + 0.5) / n2, indexing="ij")
    s, t = s.ravel(), t.ravel()
    if jitter:
        rng = np.random.default_rng(rng)
        s = s + rng.uniform(-jitter, jitter, s.size) / n1
        t = t + rng.uniform(-jitter, jitter, t.size) / n2
    pts = origin + s[:, None] * e1 + t[:, None] * e2
    nrm = np.cross(e1, e2)
    nrm = nrm / np.linalg.norm(nrm)
    return pts, np.tile(nrm, (pts.shape[0], 1)), np.full(pts.shape[0], label, dtype=np.int64)


def _stack(parts):
    pts, nrm, lab = zip(*parts, strict=True)
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(lab)


def box(a=1.0, b=1.0, c=1.0, n=10, *, jitter=0.0, rng=None):
    """An axis-aligned box [-a,a]x[-b,b]x[-c,c], 6 faces labelled 0..5, n samples per unit."""
    rng = np.random.default_rng(rng)
    ex, ey, ez = np.eye(3)
    na, nb, nc = (max(2, int(round(2 * v * n))) for v in (a, b, c))
    kw = {"jitter": jitter, "rng": rng}
    return _stack(
        [
            rect([-a, -b, -c], 2 * c * ez, 2 * b * ey, nc, nb, 0, **kw),  # -x
            rect([a, -b, -c], 2 * b * ey, 2 * c * ez, nb, nc, 1, **kw),  # +x
            rect([-a, -b, -c], 2 * a * ex, 2 * c * ez, na, nc, 2, **kw),  # -y
            rect([-a, b, -c], 2 * c * ez, 2 * a * ex, nc, na, 3, **kw),  # +y
            rect([-a, -b, -c], 2 * b * ey, 2 * a * ex, nb, na, 4, **kw),  # -z
            rect([-a, -b, c], 2 * a * ex, 2 * b * ey, na, nb, 5, **kw),  # +z
        ]
    )


def plate_with_hole(outer=1.0, inner=0.4, thickness=0.3, h=0.05):
    """A square plate with a square hole: 0 top, 1 bottom, 2-5 outer sides, 6-9 hole sides."""
    ex, ey, ez = np.eye(3)
    parts = []
    # top (normal +z) and bottom (normal -z): the annulus as 4 rectangles
    strips = [
        ([-outer, -outer], [2 * outer, 0], [0, outer - inner]),
        ([-outer, inner], [2 * outer, 0], [0, outer - inner]),
        ([-outer, -inner], [outer - inner, 0], [0, 2 * inner]),
        ([inner, -inner], [outer - inner, 0], [0, 2 * inner]),
    ]
    for (x0, y0), (dx, _), (_, dy) in strips:
        n1, n2 = max(1, int(round(dx / h))), max(1, int(round(dy / h)))
        parts.append(rect([x0, y0, thickness], [dx, 0, 0], [0, dy, 0], n1, n2, 0))
        parts.append(rect([x0, y0, 0], [0, dy, 0], [dx, 0, 0], n2, n1, 1))
    m_out, m_in, m_t = (
        int(round(2 * outer / h)),
        int(round(2 * inner / h)),
        int(round(thickness / h)),
    )
    t = thickness * ez
    L, l_ = 2 * outer, 2 * inner
    parts += [
        rect([-outer, -outer, 0], L * ex, t, m_out, m_t, 2),  # -y side, normal -y
        rect([outer, -outer, 0], L * ey, t, m_out, m_t, 3),  # +x
        rect([outer, outer, 0], -L * ex, t, m_out, m_t, 4),  # +y
        rect([-outer, outer, 0], -L * ey, t, m_out, m_t, 5),  # -x
        rect([-inner, -inner, 0], t, l_ * ex, m_t, m_in, 6),  # hole wall y=-inner, normal +y
        rect([inner, -inner, 0], t, l_ * ey, m_t, m_in, 7),  # x=+inner, normal -x
        rect([inner, inner, 0], t, -l_ * ex, m_t, m_in, 8),  # y=+inner, normal -y
        rect([-inner, inner, 0], t, -l_ * ey, m_t, m_in, 9),  # x=-inner, normal +x
    ]
    return _stack(parts)
