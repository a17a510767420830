"""Atomic file writing, used by every writer in the project.

A reader (or a crash, or a full disk) must never see a half-written params.json, log
or report: the data go to a temporary file in the target's directory, are flushed to
disk, and the temporary file is then renamed over the target with ``os.replace``,
which is atomic on POSIX and Windows when both names are on the same file system.

A writer killed between creating its temporary file and the rename (``kill -9``, a
power cut) cannot remove it. The next write to the same target does: it removes the
temporary files of this module's naming pattern for that target (``.<name>.<12 hex
digits>.tmp``) that nothing has touched for :data:`STALE_TEMPORARY_AGE_S`.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import stat
import time

__all__ = ["STALE_TEMPORARY_AGE_S", "write_atomic"]

_MAX_NAME_ATTEMPTS = 100
# Hex digits of the random part of a temporary file's name.
_TOKEN_BYTES = 6
# A temporary file unchanged for this long belongs to a writer that died [s]. A live
# writer creates, fills, flushes and renames its file within seconds (an 8 MB params
# or report file: well under one); ten minutes leaves room for a stalled network file
# system and still cleans up after a crash on the next write. The age, not the writer's
# process id, decides: a process id says nothing about a writer on another host sharing
# the directory.
STALE_TEMPORARY_AGE_S = 600.0


def write_atomic(path: str | os.PathLike[str], data: bytes | str) -> None:
    """Write ``data`` to ``path`` so that the file is either fully old or fully new.

    The data are written to a hidden temporary file in the same directory as
    ``path``, flushed and ``fsync``-ed, then renamed over ``path`` with
    ``os.replace``; the directory is ``fsync``-ed afterwards where the platform
    allows it. If anything fails (or the write is interrupted) the temporary file is
    removed, a previous file at ``path`` is left untouched, and the exception
    propagates. Before writing, temporary files of earlier writes to ``path`` that
    were left behind (their writer was killed) and are older than
    :data:`STALE_TEMPORARY_AGE_S` are removed; other files are never touched.

    Parameters
    ----------
    path : str or os.PathLike
        Target file. Missing parent directories are created. An existing file's
        permission bits are kept; a new file gets the usual ``0o666 & ~umask``. If
        ``path`` is a symbolic link, the link itself is replaced by a regular file.
    data : bytes or str
        File content. ``str`` is encoded as UTF-8 without a byte-order mark and
        written as is (no newline translation, so line feeds stay LF on every
        platform).

    Raises
    ------
    TypeError
        If ``data`` is neither ``bytes`` nor ``str``; nothing is written.
    OSError
        If the directory cannot be created or the file cannot be written or renamed.
        The error names ``path`` as given (``filename``), never the temporary file;
        its ``strerror`` is ``"cannot write: <reason>"`` and its ``errno`` (hence its
        subclass, e.g. ``FileNotFoundError``) that of the failure, which is chained
        as ``__cause__``.

    """
    if isinstance(data, str):
        payload = data.encode("utf-8")
    elif isinstance(data, bytes | bytearray | memoryview):
        payload = bytes(data)
    else:
        raise TypeError(f"data must be bytes or str, got {type(data).__name__}")

    shown = os.fspath(path)
    try:
        _write(os.path.abspath(shown), payload)
    except OSError as error:
        raise _naming_target(error, shown) from error


def _write(target: str, payload: bytes) -> None:
    """Write ``payload`` to the absolute path ``target`` by temporary file and rename."""
    directory, name = os.path.split(target)
    try:
        os.makedirs(directory, exist_ok=True)
    except FileExistsError:  # the directory's name is taken by a file
        raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), directory) from None
    mode = _existing_mode(target)
    _remove_stale_temporaries(directory, name)

    temporary = _create_temporary(directory, name)
    try:
        with open(temporary, "wb") as file:
            file.write(payload)
            file.flush()
            os.fsync(file.fileno())
        if mode is not None:
            os.chmod(temporary, mode)
        os.replace(temporary, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
    _fsync_directory(directory)


def _naming_target(error: OSError, path: str) -> OSError:
    """Return the same failure (same errno and subclass) about ``path``, not a temp file.

    The command-line tools print ``<filename>: <strerror>``, so the user reads
    ``<path>: cannot write: <reason>``.
    """
    reason = error.strerror or str(error) or type(error).__name__
    return OSError(error.errno, f"cannot write: {reason}", path)


def _existing_mode(target: str) -> int | None:
    """Return the permission bits of an existing regular file at ``target``, or None."""
    try:
        status = os.stat(target)
    except OSError:
        return None
    return stat.S_IMODE(status.st_mode) if stat.S_ISREG(status.st_mode) else None


def _create_temporary(directory: str, name: str) -> str:
    """Create a new, empty, uniquely named file next to the target and return its path.

    ``os.open`` with ``O_CREAT | O_EXCL`` and mode ``0o666`` lets the operating
    system apply the process umask, as for an ordinary new file (``tempfile.mkstemp``
    would create it with mode ``0o600``).
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    for _ in range(_MAX_NAME_ATTEMPTS):
        candidate = os.path.join(directory, f".{name}.{secrets.token_hex(_TOKEN_BYTES)}.tmp")
        try:
            fd = os.open(candidate, flags, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return candidate
    raise FileExistsError(errno.EEXIST, "no free name for a temporary file", directory)


def _remove_stale_temporaries(directory: str, name: str) -> None:
    """Remove the left-over temporary files of writes to ``name`` in ``directory``.

    Only regular files named as :func:`_create_temporary` names them for this target,
    and unchanged for :data:`STALE_TEMPORARY_AGE_S`, are removed. Nothing here fails a
    write: a file that vanishes or cannot be removed is left to the next write.
    """
    pattern = re.compile(re.escape(f".{name}.") + f"[0-9a-f]{{{2 * _TOKEN_BYTES}}}" + r"\.tmp")
    oldest = time.time() - STALE_TEMPORARY_AGE_S
    try:
        with os.scandir(directory) as listing:
            entries = list(listing)
    except OSError:
        return
    for entry in entries:
        if not pattern.fullmatch(entry.name):
            continue
        with contextlib.suppress(OSError):
            status = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(status.st_mode) and status.st_mtime < oldest:
                os.unlink(entry.path)


def _fsync_directory(directory: str) -> None:
    """Flush the directory entry of the renamed file to disk, where supported."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # e.g. Windows cannot open a directory
        return
    try:
        with contextlib.suppress(OSError):
            os.fsync(fd)
    finally:
        os.close(fd)
