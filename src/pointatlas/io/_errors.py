"""The I/O error type and small helpers that build its messages."""

from __future__ import annotations

import os

from .._core import PointAtlasError

__all__ = ["PointAtlasIOError"]


class PointAtlasIOError(PointAtlasError):
    """A file could not be read or written (a :class:`PointAtlasError`, so a ``ValueError``).

    The message names the file and what is wrong with it.
    """


def fail(path, what: str) -> PointAtlasIOError:
    """Return (not raise) a PointAtlasIOError ``"<path>: <what>"``."""
    return PointAtlasIOError(f"{os.fspath(path)}: {what}")


def describe_exception(exc: BaseException) -> str:
    """One-line description of a third-party exception for wrapping."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


def first_non_number(tokens):
    """The first token ``float`` cannot parse (for a "non-numeric value" message), or None."""
    for token in tokens:
        try:
            float(token)
        except ValueError:
            return token
    return None
