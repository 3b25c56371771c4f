"""Exception types shared by all rooms."""

__all__ = ["NonFiniteError", "PointAtlasError"]


class PointAtlasError(ValueError):
    """A user-facing error about input data or parameters (a ``ValueError``).

    The CLI prints its message as one line and exits with status 1.
    """


class NonFiniteError(PointAtlasError):
    """An input array holds NaN or Inf (raised by `pointatlas._core.check_finite`).

    Every public function refuses non-finite coordinates with this error and the
    same wording: ``points contains 3 non-finite values (NaN or Inf) at rows 0, 5, 9``.
    """
