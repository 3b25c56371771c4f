"""Atomic file writing: temp file in the target folder, fsync, ``os.replace``."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

__all__ = ["atomic_write"]


def _current_umask() -> int:
    # os.umask can only be read by setting it; do it once at import time.
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


@contextlib.contextmanager
def atomic_write(path, mode: str = "wb", *, encoding: str | None = None, newline=None):
    """Open a temporary file that atomically replaces ``path`` when the block succeeds.

    The data goes to a temporary file in the same folder as ``path``; on a normal
    exit of the ``with`` block it is flushed, ``fsync``-ed and moved over ``path``
    with ``os.replace`` (atomic on POSIX and Windows). If the block raises, the
    temporary file is removed and ``path`` is left exactly as it was, so a reader
    never sees a partial file.

    Parameters
    ----------
    path : str or os.PathLike
        Destination file. Its folder must exist.
    mode : {"wb", "w"}
        Binary or text mode.
    encoding : str, optional
        Text encoding for mode ``"w"`` (default UTF-8).
    newline : str, optional
        Passed to :func:`open` in text mode.

    Yields
    ------
    file : file object
        The open temporary file.

    Raises
    ------
    ValueError
        ``mode`` is not ``"wb"`` or ``"w"``.
    OSError
        The folder does not exist or is not writable.

    Notes
    -----
    The new file gets the permissions of the file it replaces, or ``0o666`` minus
    the process umask for a new file (as :func:`open` would give it).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_write(folder / "a.txt", "w") as fh:
    ...     _ = fh.write("hello")
    >>> (folder / "a.txt").read_text()
    'hello'
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"mode must be 'wb' or 'w'; got {mode!r}")
    target = Path(os.fspath(path))
    folder = target.parent if str(target.parent) else Path(".")
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    try:
        try:
            perm = target.stat().st_mode & 0o7777
        except OSError:
            perm = 0o666 & ~_UMASK
        if mode == "w":
            fh = open(fd, "w", encoding=encoding or "utf-8", newline=newline)  # noqa: SIM115
        else:
            fh = open(fd, "wb")  # noqa: SIM115
        with fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp_name, perm)
        os.replace(tmp_name, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp_name)
        raise
    _fsync_folder(folder)


def _fsync_folder(folder: Path) -> None:
    """Make the rename durable where the platform allows opening folders."""
    if os.name != "posix":
        return
    with contextlib.suppress(OSError):
        dir_fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
