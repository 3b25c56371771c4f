"""Text outputs: a text file and a JSON summary naming the files of a set, atomically."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from pathlib import Path

from ._atomic import atomic_write
from ._json import to_json_safe, write_json

__all__ = ["file_record", "write_summary_json", "write_text"]


def write_text(path, text: str) -> Path:
    """Write a text file atomically (umask permissions, ``\\n`` line ends).

    Parameters
    ----------
    path : str or os.PathLike
        Destination file; its folder must exist.
    text : str
        The whole content.

    Returns
    -------
    path : pathlib.Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write_text(Path(tmp) / "a.txt", "one\\n").read_text()
    'one\\n'
    """
    with atomic_write(path, "w", newline="\n") as fh:
        fh.write(text)
    return Path(path)


def file_record(path, relative_to) -> dict:
    """Name (relative to ``relative_to`` when possible), size and SHA-256 of a file.

    Parameters
    ----------
    path : str or os.PathLike
        An existing file.
    relative_to : str or os.PathLike
        The folder the name is given relative to.

    Returns
    -------
    record : dict
        ``{"path": str, "bytes": int, "sha256": str}``.
    """
    path = Path(path)
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    try:
        name = os.path.relpath(path, relative_to)
    except ValueError:  # another drive (Windows)
        name = str(path)
    return {"path": name, "bytes": path.stat().st_size, "sha256": digest.hexdigest()}


def write_summary_json(path, payload: dict, written: Sequence) -> Path:
    """Write a JSON summary last, naming the files of the set it completes.

    Parameters
    ----------
    path : str or os.PathLike
        The summary file.
    payload : dict
        The summary, converted by `to_json_safe` (non-finite numbers are written as
        null, numpy values as plain numbers and lists).
    written : sequence of path
        The files of the set; each gets a record (path relative to the summary,
        bytes, sha256) in the summary's ``"files"`` list, so a reader that finds the
        summary and matching files knows the set is complete and from one run.

    Returns
    -------
    path : pathlib.Path
        ``path``.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    body = to_json_safe(dict(payload))
    body["files"] = [file_record(p, folder) for p in written]
    return write_json(path, body, indent=1)
