"""Option checks of the commands that name the flag as typed, run before any work.

The VSA flags of ``segment`` and ``simplify`` become one `VSAOptions` here
(`vsa_options`: ``--seeds`` parsed, degrees to radians), and angle flags in degrees
are checked (`angle_deg_option`), so the jobs below the commands can build them too.
Two kinds of checks: an error of a library function called with the flags' values
(`VSAOptions`' ``k must ...``) is re-worded with the flag (``--k must ...``); and
bounds that depend on the number of points (``--k`` at most N, ``--seeds`` a count
at most N or indices below N) are checked once the input is read, before normals
are estimated (`pointatlas.cli._app.read_with_normals` calls the check).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from .._core import PointAtlasError, as_float, as_int
from .._core.tolerances import MAX_ITERATIONS, MAX_LISTED_INDICES

__all__ = [
    "VSA_FLAGS",
    "angle_deg_option",
    "check_iterations",
    "feature_counts",
    "flatness_counts",
    "named_as_typed",
    "normal_k_check",
    "normal_k_counts",
    "parse_seeds",
    "vsa_counts",
    "vsa_options",
]

#: `VSAOptions` fields and the flags of ``segment`` and ``simplify`` that set them.
VSA_FLAGS = {
    "k": "--k",
    "eta": "--eta",
    "seeds": "--seeds",
    "weights": "--weights",
    "max_iter": "--max-iter",
    "min_region_size": "--min-region-size",
}


def named_as_typed(exc: Exception, flags: Mapping[str, str]) -> Exception:
    """``exc`` with a leading parameter name replaced by its flag (``k must`` ->
    ``--k must``); ``exc`` itself when its message names none of ``flags``."""
    text = str(exc)
    for name, flag in flags.items():
        if text.startswith(f"{name} "):
            return type(exc)(flag + text[len(name) :])
    return exc


def check_iterations(value: int | None, flag: str) -> None:
    """An iteration count flag: an integer in [0, `MAX_ITERATIONS`] (None: the
    command's default). A larger count would run for days (each iteration is a pass
    over every point) or size arrays by it, so it is refused here, with the reason."""
    if value is not None:
        as_int(
            value,
            flag,
            lo=0,
            hi=MAX_ITERATIONS,
            note="each iteration is a pass over every point",
        )


def normal_k_check(normal_k: int, n_points: int) -> None:
    """``--normal-k`` (the PCA neighbours of estimated normals) in [3, N]."""
    as_int(normal_k, "--normal-k", lo=3, hi=n_points, note="the number of points")


def normal_k_counts(normal_k: int) -> Callable[[int], None]:
    """`normal_k_check` as a check of the number of points (a tiled run's ``checks``)."""
    return lambda n_points: normal_k_check(normal_k, n_points)


def vsa_counts(options) -> Callable[[int], None]:
    """The check of ``--k`` and ``--seeds`` against the number of points N (the bounds
    `pointatlas.segment.vsa_segment` applies, named by their flags)."""

    def check(n_points: int) -> None:
        as_int(options.k, "--k", lo=1, hi=n_points, note="the number of points")
        seeds = options.seeds
        if isinstance(seeds, str):
            return
        if np.ndim(seeds) == 0:
            as_int(int(seeds), "--seeds", lo=1, hi=n_points, note="the number of points")
            return
        out = np.asarray(seeds) >= n_points
        if out.any():
            shown = ", ".join(str(int(i)) for i in np.asarray(seeds)[out][:MAX_LISTED_INDICES])
            raise PointAtlasError(
                f"--seeds must be point indices in [0, {n_points}) (the number of points); "
                f"got {shown}"
            )

    return check


def flatness_counts(k: int, k_start: int | None) -> Callable[[int], None]:
    """The check of flatness' ``--k`` and ``--k-start`` against the number of points
    (the bounds of `pointatlas.denoise.flatness_denoise`, named by their flags)."""

    def check(n_points: int) -> None:
        as_int(k, "--k", lo=3, hi=n_points - 1, note="the number of points - 1")
        if k_start is not None:
            as_int(k_start, "--k-start", lo=k, hi=n_points - 1, note="--k .. number of points - 1")

    return check


def angle_deg_option(value, flag: str, *, lo: float = 0.0, hi: float = 180.0):
    """Validate an angle flag in degrees (finite, in [lo, hi]); None passes through."""
    if value is None:
        return None
    return as_float(value, flag, lo=lo, hi=hi, what="angle", unit="degrees")


def parse_seeds(text: str):
    """``--seeds``: ``"all"``, a count (``"12"``) or comma-separated indices (``"0,5,9"``)."""
    text = text.strip()
    if text.lower() == "all":
        return "all"
    try:
        if "," in text:
            return np.array([int(t) for t in text.split(",") if t.strip()], dtype=np.int64)
        value = int(text)
    except ValueError:
        raise PointAtlasError(
            f"--seeds must be 'all', a count or comma-separated indices; got {text!r}"
        ) from None
    if value < 1:
        raise PointAtlasError(f"--seeds must be 'all', a count >= 1 or indices; got {text!r}")
    return value


def vsa_options(
    *,
    k: int,
    eta: float | None,
    max_angle_deg: float | None,
    seeds: str,
    split: bool,
    merge: bool,
    switch: str,
    classic: bool,
    weights: str,
    max_iter: int,
    local: bool = False,
):
    """The VSA flags (``cli/_app.py``'s `VSAKOption`, `EtaOption`, ...) as a
    `pointatlas.segment.VSAOptions`: ``--seeds`` parsed, degrees to radians; a
    bad ``--switch``, ``--max-angle-deg`` or ``--seeds`` is named by its flag."""
    import math

    from ..segment import VSAOptions

    if switch not in ("batch", "single", "none"):
        raise PointAtlasError(f"--switch must be batch, single or none; got {switch!r}")
    max_angle = angle_deg_option(max_angle_deg, "--max-angle-deg")
    seeds = parse_seeds(seeds)
    try:
        return VSAOptions(
            k=k,
            eta=eta,
            max_angle=None if max_angle is None else math.radians(max_angle),
            seeds=seeds,
            split=split,
            merge=merge,
            switch=switch,
            classic=classic,
            weights=weights,
            max_iter=max_iter,
            local=local,
        )
    except (TypeError, ValueError) as exc:  # VSAOptions names its fields: name the flags
        raise named_as_typed(exc, VSA_FLAGS) from None


def feature_counts(k: int | None, k_range) -> Callable[[int], None]:
    """The check of ``features --k`` and ``--k-range`` against the number of points
    (the bounds of `pointatlas.features`, named by their flags)."""

    def check(n_points: int) -> None:
        if k is not None:
            as_int(k, "--k", lo=1, hi=n_points, note="the number of points")
        if k_range is not None:
            for end in k_range:
                as_int(end, "--k-range", lo=1, hi=n_points, note="the number of points")

    return check
