"""Exception types shared by all rooms."""

__all__ = ["PointAtlasError"]


class PointAtlasError(ValueError):
    """A user-facing error about input data or parameters (a ``ValueError``).

    The CLI prints its message as one line and exits with status 1.
    """
