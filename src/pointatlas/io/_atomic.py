"""Atomic file writing: temp file in the target folder, fsync, ``os.replace``."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from pathlib import Path

from .._core._interrupt import interrupt_requested

__all__ = ["atomic_write", "remove_stale_temp_files", "temp_prefix"]


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
    The temporary file is named ``.<name>.pa<pid>.<random>.tmp``; a writer killed
    before the rename (SIGKILL, power loss) leaves it behind, and
    :func:`remove_stale_temp_files` removes such files once their process is gone.
    Once the user asked to stop (``pointatlas._core._interrupt``), the block raises
    ``KeyboardInterrupt`` instead of replacing ``path``.

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
    if interrupt_requested():
        raise KeyboardInterrupt
    fd, tmp_name = tempfile.mkstemp(prefix=temp_prefix(target), suffix=".tmp", dir=folder)
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
        if interrupt_requested():  # the user asked to stop: keep the previous file
            raise KeyboardInterrupt
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


def temp_prefix(path) -> str:
    """Prefix of :func:`atomic_write`'s temporary files for ``path`` (name and pid)."""
    return f".{Path(os.fspath(path)).name}.pa{os.getpid()}."


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def remove_stale_temp_files(path) -> list[Path]:
    """Remove the temporary files that killed writers of ``path`` left behind.

    Parameters
    ----------
    path : str or os.PathLike
        An output file (need not exist). Its folder is searched for
        ``.<name>.pa<pid>.<random>.tmp`` files and folders (a tiled run's temporary
        folder is named so) whose process no longer runs, and for
        ``.<name>.<8 characters>.tmp`` files of versions that did not record the pid.

    Returns
    -------
    removed : list of pathlib.Path
        The files and folders removed (what cannot be removed is left alone).

    Notes
    -----
    A process id names a process of this machine (of this container): a folder
    shared with other machines may hold the temporary files of a writer that runs
    there under an id that is free here.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / ".out.ply.pa999999999.abcd1234.tmp").write_text("partial")
    >>> [p.name for p in remove_stale_temp_files(folder / "out.ply")]
    ['.out.ply.pa999999999.abcd1234.tmp']
    """
    target = Path(os.fspath(path))
    folder = target.parent if str(target.parent) else Path(".")
    pattern = re.compile(
        r"^\." + re.escape(target.name) + r"\.(?:pa(?P<pid>\d+)\.[A-Za-z0-9_]+|[a-z0-9_]{8})\.tmp$"
    )
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = pattern.match(entry.name)
        if match is None:
            continue
        pid = match.group("pid")
        if pid is not None and _process_alive(int(pid)):
            continue
        if entry.is_file(follow_symlinks=False):
            with contextlib.suppress(OSError):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        elif pid is not None and entry.is_dir(follow_symlinks=False):
            shutil.rmtree(entry.path, ignore_errors=True)
            if not os.path.lexists(entry.path):
                removed.append(Path(entry.path))
    return removed
