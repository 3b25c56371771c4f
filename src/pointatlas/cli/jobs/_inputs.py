"""Reading IN: a file or a bundled model, with normals when a command needs them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..._core import PointAtlasError
from ...simplify import NORMAL_K_RANGE
from .._flag_checks import normal_k_check
from ._console import err_console, progress_bar, say
from ._normals import compute_normals

__all__ = [
    "estimated_normals",
    "fill_unusable_normals",
    "read_estimating_normals",
    "read_input",
    "read_keeping_normals",
    "read_with_normals",
]


#: The text files whose column layout was printed (a command may read IN twice).
_ANNOUNCED: set[tuple[str, str]] = set()


def read_input(path, *, with_normals: bool = True, zero_normals: str = "raise"):
    """Read IN: a point set or mesh file, or, where no such file exists, a bundled
    model name (``pointatlas data list``: ``fandisk``, ``synth:cube``, ...)."""
    from ...io import read_point_set

    p = Path(path)
    if p.is_dir():
        raise PointAtlasError(f"{path}: is a folder; give a point-set or mesh file")
    if not p.exists():
        from ... import data

        if str(path) in data.names():
            ps = data.load(str(path))
            return ps if with_normals else ps.replace(normals=None)
        if not p.suffix:
            raise PointAtlasError(
                f"{path}: no such file and not a bundled model; bundled: {', '.join(data.names())}"
            )
    ps = read_point_set(p, with_normals=with_normals, zero_normals=zero_normals)
    note = ps.meta.get("columns")  # how a text file's columns were read: said once
    if note and (str(p), note) not in _ANNOUNCED:
        _ANNOUNCED.add((str(p), note))
        say(f"{p}: {note}", out=err_console)
    return ps


def _check_min_points(path, ps, min_points: int, what: str, check=None) -> None:
    if ps.n_points < min_points:
        raise PointAtlasError(
            f"{path}: {what or 'this command'} needs at least {min_points} points; "
            f"got {ps.n_points}"
        )
    if check is not None:
        check(ps.n_points)


def fill_unusable_normals(path, kept, normal_k: int):
    """The whole of IN with a normal for every point, from ``kept`` (IN read with
    ``zero_normals="drop"``: the points whose stored normal is usable, their
    original indices in ``source_index``).

    A point without a usable normal (zero or non-finite in the file; a mesh vertex
    on no face) gets the PCA normal of its ``normal_k`` nearest points (all points
    of IN; at most all of them), signed like the sum of its neighbours' usable
    normals (kept as PCA gives it when none of them has one). A note on stderr
    gives their number. Nothing is left out: every point and attribute of IN is
    there, in the input order (docs/decisions/cli.md).
    """
    from ...neighbors import NeighborIndex

    full = read_input(path, with_normals=False)
    n = full.n_points
    if kept.n_points == 0:  # no usable normal at all: estimated as for an input without
        return full
    good = np.zeros(n, dtype=np.bool_)
    good[kept.attributes["source_index"]] = True
    normals = np.zeros((n, 3))
    normals[good] = kept.normals
    missing = np.flatnonzero(~good)
    k = min(max(int(normal_k), 3), n)
    idx, _ = NeighborIndex(full.points).knn(k, rows=missing)
    nb = full.points[idx]  # (M, k, 3)
    centred = nb - nb.mean(axis=1, keepdims=True)
    cov = np.einsum("mki,mkj->mij", centred, centred)
    pca = np.linalg.eigh(cov)[1][:, :, 0]  # eigenvector of the smallest eigenvalue
    votes = normals[idx].sum(axis=1)  # the neighbours' usable normals (zero rows: none)
    flip = (pca * votes).sum(axis=1) < 0.0
    pca[flip] *= -1.0
    normals[missing] = pca / np.linalg.norm(pca, axis=1, keepdims=True)
    say(
        f"note: {missing.size:,} of {n:,} points had no usable normal (zero or non-finite; "
        f"mesh vertices on no face); they got PCA normals of their {k} nearest points, "
        "signed like their neighbours'",
        out=err_console,
    )
    return full.replace(normals=normals)


def read_with_normals(path, **options):
    """Read IN and make sure it has normals; returns the PointSet
    (`read_estimating_normals`' first output; ``options`` its keywords)."""
    return read_estimating_normals(path, **options)[0]


def read_estimating_normals(
    path,
    *,
    estimate: bool | None = None,
    normal_k: int = 20,
    min_points: int = 1,
    what: str = "",
    check=None,
    surface: bool = False,
):
    """Read IN and make sure it has normals; returns ``(point set, estimated)``:
    whether its normals were estimated here.

    ``estimate`` None (default of the commands): the input's normals are used; an
    input without normals gets PCA normals (``normal_k`` neighbours, MST
    orientation), and a line on stderr says so. True: normals are estimated even
    when the input has some; the input's normals are kept as the attribute
    ``input_normals``. False: an input without normals is an error. Points whose
    stored normal is unusable (zero length, NaN; mesh vertices on no face) get one
    from their neighbours (`fill_unusable_normals`), with a note giving their
    number. An input with fewer than ``min_points``
    points is refused before anything is estimated (``what`` names the job), and so
    is one that ``check`` (called with the number of points) refuses: the options
    bounded by N (`pointatlas.cli._flag_checks`). ``surface``: the estimated normals
    are the points path's (`pointatlas.simplify.surface_normals`: where a
    neighbourhood is not flat, the eigenentropy-optimal one's; oriented, then
    `pointatlas.simplify.sharpen_normals`, then `pointatlas.simplify.outward_normals`).
    """
    from ..._core import as_int

    as_int(normal_k, "--normal-k", lo=3)
    if estimate:
        ps = read_input(path, with_normals=False)
        try:
            given = read_input(path).normals
        except PointAtlasError:  # some points without a normal: nothing to keep
            given = None
        if given is not None:  # kept as input_normals (pa_ prefixed if that name is taken)
            from ...io import merge_attributes

            name = list(merge_attributes(ps.attributes, {"input_normals": given}))[-1]
            ps = ps.with_attributes(**{name: given})
    else:
        ps = read_input(path, zero_normals="drop")
        if "source_index" in ps.attributes:  # rare: some points lack a usable normal
            ps = fill_unusable_normals(path, ps, normal_k)
        if ps.normals is not None:
            _check_min_points(path, ps, min_points, what, check)
            return ps, False
        if estimate is False:
            raise PointAtlasError(
                f"{path}: the input has no normals; drop --no-estimate-normals to estimate them"
            )
    _check_min_points(path, ps, min_points, what, check)
    normal_k_check(normal_k, ps.n_points)
    lo, hi = NORMAL_K_RANGE
    how = f" (k in {lo}..{hi} where bent beyond the noise, least eigenentropy)" if surface else ""
    say(
        f"estimating normals: PCA with k = {normal_k}{how}, MST orientation"
        + (", then sharp beside edges and turned outward" if surface else "")
        + ("" if estimate else " (the input has none)"),
        out=err_console,
    )
    return ps.replace(normals=estimated_normals(ps.points, normal_k, surface=surface)), True


def estimated_normals(points, normal_k: int, *, surface: bool = False, label: str = "normals"):
    """The commands' estimate of the normals of ``points`` (`compute_normals`: PCA at
    ``normal_k``, MST orientation; ``surface``: the points path's), with a progress
    bar named ``label``."""
    with progress_bar(label, total=2) as advance:
        return compute_normals(
            points,
            k=normal_k,
            orient="mst",
            orient_k=10,
            viewpoint=None,
            advance=advance,
            surface=surface,
        )


def read_keeping_normals(path):
    """IN as the normals commands read it: every point, without normals, and the
    input's own normals (when every point has one) as the field ``input_normals``."""
    try:
        ps = read_input(path)
    except PointAtlasError:  # some points without a normal: nothing to keep
        return read_input(path, with_normals=False), {}
    ours = {} if ps.normals is None else {"input_normals": ps.normals}
    return ps.replace(normals=None), ours
