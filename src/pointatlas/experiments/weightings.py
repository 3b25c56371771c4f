"""Fig. 5.3 of the thesis: equal weights, a cut-off and the optimal (a, b, k) side by side."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..features import classify_dimension, optimal_k_features, optimal_neighborhood

__all__ = ["fig_5_3"]


def fig_5_3(points, normals, out_dir, *, name: str) -> tuple[dict, list[Path]]:
    """Fig. 5.3: equal weights vs cut-off a = b = arccos(0.9) vs optimal (a, b, k).

    Each column minimises E_dim over k = 6..20 for its weights; top picture E_dim,
    bottom picture the largest of linearity / planarity / scattering (grey:
    degenerate for every k, the thesis' red points).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    normals : array_like of shape (N, 3), float64
        Unit normals.
    out_dir : str or os.PathLike
        Existing folder of the two pictures.
    name : str
        Model name: the pictures are ``{name}_fig5_3_edim.png`` and
        ``{name}_fig5_3_classes.png``.

    Returns
    -------
    stats : dict
        Per column: ``mean_e_dim``, ``n_degenerate`` and the three class counts.
    written : list of pathlib.Path
        The two pictures.
    """
    from ..viz import PointsPanel, render_side_by_side

    cut = math.acos(0.9)
    results = {
        "equal weights [WJM14]": optimal_k_features(points, k_range=(6, 20), criterion="e_dim"),
        "cut-off a = b = arccos 0.9": optimal_neighborhood(
            points, normals, a_grid=[cut], b_grid=[cut]
        ),
        "optimal (a, b, k), Eq. 5.9": optimal_neighborhood(points, normals),
    }
    out = Path(out_dir)
    stats = {}
    edim_panels = []
    class_panels = []
    for title, res in results.items():
        ok = res.is_valid
        e = np.where(np.isfinite(res.e_dim), res.e_dim, np.nan)
        stats[title] = {
            "mean_e_dim": float(np.mean(res.e_dim[ok])) if ok.any() else float("nan"),
            "n_degenerate": int((~ok).sum()),
            "classes": [int((classify_dimension(res) == c).sum()) for c in range(3)],
        }
        edim_panels.append(
            PointsPanel(
                points,
                normals=normals,
                scalars=e,
                scalar_name="E_dim",
                clim=(0, 1),
                title=f"{title}\nmean E_dim {stats[title]['mean_e_dim']:.3f}",
            )
        )
        class_panels.append(
            PointsPanel(
                points,
                normals=normals,
                labels=classify_dimension(res),
                title=f"{title}\nlinear / planar / scattered = "
                + " / ".join(str(c) for c in stats[title]["classes"]),
            )
        )
    written = [
        render_side_by_side(
            out / f"{name}_fig5_3_edim.png",
            edim_panels,
            title=f"{name}: E_dim (grey = degenerate for every k)",
        ),
        render_side_by_side(
            out / f"{name}_fig5_3_classes.png",
            class_panels,
            title=f"{name}: largest of linearity / planarity / scattering",
        ),
    ]
    return stats, written
