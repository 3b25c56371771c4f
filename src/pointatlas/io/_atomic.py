"""Atomic file writing: temp file in the target folder, fsync, ``os.replace``."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import stat
import tempfile
from pathlib import Path

from .._core._interrupt import interrupt_requested
from ._errors import fail

__all__ = [
    "atomic_write",
    "name_problem",
    "output_problem",
    "output_target",
    "remove_stale_temp_files",
    "temp_prefix",
]

#: Longest name of one path component (bytes) when ``os.pathconf`` cannot tell: the
#: limit of ext4, XFS, btrfs, APFS and NTFS.
NAME_MAX_DEFAULT = 255


def _current_umask() -> int:
    # os.umask can only be read by setting it; do it once at import time.
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


@contextlib.contextmanager
def atomic_write(path, mode: str = "wb", *, encoding: str | None = None, newline=None):
    """Open a temporary file that atomically replaces ``path`` when the block succeeds.

    The data goes to a temporary file in the same folder as the file ``path``
    names (the target of a symbolic link: the link stays a link); on a normal
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
    PointAtlasIOError
        ``path`` cannot be an output (:func:`output_problem`): it ends in a
        separator, a name is too long, it is a folder or not a regular file, or an
        existing file its owner made read-only (not replaced, as ``cp`` without
        ``-f``).
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
    problem = output_problem(path)
    if problem is not None:
        raise fail(path, problem)
    target = output_target(path)
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


def output_target(path) -> Path:
    """The file that writing ``path`` replaces: ``path``, or where its symlinks lead.

    Parameters
    ----------
    path : str or os.PathLike
        An output path (need not exist).

    Returns
    -------
    target : pathlib.Path
        ``path`` unchanged, or, when its last component is a symbolic link, the
        absolute path the chain of links leads to (which need not exist).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> (folder / "link.ply").symlink_to("real.ply")
    >>> output_target(folder / "link.ply").name
    'real.ply'
    """
    p = Path(os.fspath(path))
    try:
        is_link = stat.S_ISLNK(os.lstat(p).st_mode)
    except OSError:
        return p
    return Path(os.path.realpath(p)) if is_link else p


def _name_max(path: Path) -> int:
    folder = path.parent
    while not folder.is_dir() and folder != folder.parent:
        folder = folder.parent
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return NAME_MAX_DEFAULT


def name_problem(path) -> str | None:
    """Which name of ``path`` is longer than its file system allows, or None.

    Parameters
    ----------
    path : str or os.PathLike
        A file or folder path (need not exist).

    Returns
    -------
    problem : str or None
        A phrase for a one-line message when one component is longer than
        ``NAME_MAX`` (asked of the nearest existing folder; 255 bytes when it
        cannot tell).

    Examples
    --------
    >>> name_problem("short.ply") is None
    True
    """
    p = Path(os.fspath(path))
    limit = _name_max(p)
    for part in p.parts:
        n_bytes = len(os.fsencode(part))
        if n_bytes > limit:
            return (
                f"a name of {n_bytes} bytes is longer than the file system allows ({limit} bytes)"
            )
    return None


def output_problem(path) -> str | None:
    """Why ``path`` cannot be written as an output file, or None when it can.

    Parameters
    ----------
    path : str or os.PathLike
        An output path as given (a trailing separator is seen in a ``str``).

    Returns
    -------
    problem : str or None
        A phrase for a one-line message: the path ends in a separator; one of its
        names is longer than the file system allows (``NAME_MAX``, 255 bytes on
        common file systems); it (or the file its symlinks lead to) is a folder,
        not a regular file, a symlink loop, or an existing file its owner made
        read-only or that this user may not write. A missing file, or a link to
        one, is fine (the target is created).

    Examples
    --------
    >>> output_problem("out.ply/")
    "ends in '/', so it names a folder; give a file name such as 'out.ply'"
    >>> "longer than the file system allows" in output_problem("a" * 1000 + ".ply")
    True
    """
    text = os.fspath(path)
    separators = tuple(s for s in (os.sep, os.altsep) if s)
    if text.endswith(separators) and text.rstrip("".join(separators)):
        name = text.rstrip("".join(separators))
        return f"ends in {text[-1]!r}, so it names a folder; give a file name such as {name!r}"
    p = Path(text)
    too_long = name_problem(p)
    if too_long is not None:
        return too_long
    try:
        st = os.stat(p)
    except FileNotFoundError:
        return None
    except OSError as exc:
        return exc.strerror or str(exc)
    if stat.S_ISDIR(st.st_mode):
        return "is a folder, not a file"
    if not stat.S_ISREG(st.st_mode):
        return "is not a regular file (a device, pipe or socket); write to a file"
    mode = stat.S_IMODE(st.st_mode)
    if not mode & stat.S_IWUSR:
        return (
            f"is read-only (mode {mode:04o}) and is not replaced; make it writable "
            "(chmod u+w) or write to another file"
        )
    if not os.access(p, os.W_OK):
        return f"is not writable by this user (mode {mode:04o}); write to another file"
    return None


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
    """Prefix of :func:`atomic_write`'s temporary files for ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The output file.

    Returns
    -------
    prefix : str
        ``.<name>.pa<pid>.``: the file's name and this process's id, which
        :func:`remove_stale_temp_files` reads to tell a dead writer's files from a
        running one's (a tiled run names its temporary folder so).
    """
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
    target = output_target(path)
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
