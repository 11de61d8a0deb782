"""Atomic writes: a hidden temporary beside the destination takes its name in one step.

A reader never sees a half-written file and an error leaves nothing behind:
:func:`create_temporary` (a file) and :func:`create_temporary_directory` (a
zarr store) make the temporary, :func:`published` and
:func:`publish_directory` give it the destination's name without clobbering
anything that appeared meanwhile (unless overwriting). On a failure or
Ctrl-C the temporary is removed (by :func:`published`; by the zarr writer for
a directory): each is recorded in ``made`` before it exists. An ``OSError``
of the temporary (it cannot be created, written or renamed) is raised as one
of the destination (:func:`named_after_destination`): the user named that
path, never the temporary.

Only a process killed outright (SIGKILL, a power cut) leaves a temporary
behind. Each temporary is therefore named after the process that writes
it::

    .NAME.<host>-<pid>-<random>.tmp        (.old: a zarr store being replaced)

and the next write of NAME removes those whose process, on this host, no
longer runs. Temporaries it cannot attribute (written by an older version, or
by another host sharing the directory) are reported with a warning, never
removed.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import functools
import hashlib
import os
import re
import secrets
import shutil
import socket
import sys
import warnings
from pathlib import Path

#: Suffixes of the temporaries: a destination being written, an old zarr store being replaced.
SUFFIXES = (".tmp", ".old")

_OWNED = re.compile(r"\.(?P<host>[0-9a-f]{6})-(?P<pid>[0-9]+)-[0-9a-f]{8}(?P<suffix>\.tmp|\.old)$")
_UNOWNED = re.compile(r"\.[0-9a-f]{8}(\.tmp|\.old)$")


class StaleTemporaryWarning(UserWarning):
    """A hidden temporary of an interrupted write that could not be attributed."""


#: Errors a write of any file gives, whether or not the error names it.
_WRITE_ERRNOS = frozenset(
    getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EFBIG", "EROFS") if hasattr(errno, name)
)


@contextlib.contextmanager
def named_after_destination(path: Path, made: list[Path]):
    """Raise an ``OSError`` of the temporaries in ``made`` (or of a file inside one: a zarr
    store's chunk) as the same error of ``path``: ``filename`` is the destination.

    ``/proc/x.png`` said "No such file or directory: /proc/.x.png.0a7c9c-1234-5ef55aa3.tmp",
    a name the caller never gave. An error naming no file is the destination's when only
    a write gives it (no space, a read-only file system); one naming another file (an
    input read while the output is written) is left as it is.
    """
    try:
        yield
    except OSError as exc:
        if exc.errno is None or not _of_temporaries(exc, made):
            raise
        raise OSError(exc.errno, exc.strerror, str(path)) from exc


def _of_temporaries(exc: OSError, made: list[Path]) -> bool:
    """Whether ``exc`` is about one of the temporaries ``made`` (or a file inside one)."""
    names = [name for name in (exc.filename, exc.filename2) if name is not None]
    if not names:
        return exc.errno in _WRITE_ERRNOS
    temporaries = [os.path.abspath(temporary) for temporary in made]
    for name in names:
        if not isinstance(name, (str, bytes, os.PathLike)):  # a file descriptor
            continue
        name = os.path.abspath(os.fsdecode(name))
        if any(name == t or name.startswith(t + os.sep) for t in temporaries):
            return True
    return False


@contextlib.contextmanager
def published(made: list[Path], path: Path, *, overwrite: bool):
    """Move the temporary file the block makes (:func:`create_temporary`, into ``made``) to
    ``path`` once the block has written it; remove it on failure.

    The temporary is made inside the block, so that an interruption at any
    moment after it exists (Ctrl-C, SIGTERM) removes it. ``os.replace``
    with ``overwrite``; otherwise a hard link that refuses to clobber a file
    created in the meantime. An error of the temporary is raised as ``path``'s
    (:func:`named_after_destination`).
    """
    with named_after_destination(path, made):
        try:
            yield
            if overwrite:
                os.replace(made[-1], path)
            else:
                _link_no_clobber(made[-1], path)
        except BaseException:
            for temporary in made:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(temporary)
            raise


def create_temporary(directory: Path, name: str, made: list[Path]):
    """A new hidden file beside the destination, opened for binary writing.

    Its path is put in ``made`` before it is created: an interruption handled
    as the file is made (Python runs signal handlers as a call returns)
    leaves the caller a path to remove.
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    remove_stale_temporaries(directory, name)
    while True:
        temporary = directory / temporary_name(name)
        made.append(temporary)
        try:
            fd = os.open(temporary, flags, 0o666)  # the umask applies, unlike mkstemp
        except FileExistsError:
            made.pop()  # not made here
            continue
        os.close(fd)
        # Opened again by name: writers such as tifffile want a named file.
        return temporary, open(temporary, "wb")


def create_temporary_directory(directory: Path, name: str, made: list[Path]) -> Path:
    """A new hidden directory beside the destination, its path put in ``made`` before it is
    created (see :func:`create_temporary`)."""
    remove_stale_temporaries(directory, name)
    while True:
        temporary = directory / temporary_name(name)
        made.append(temporary)
        try:
            os.mkdir(temporary)
        except FileExistsError:
            made.pop()  # not made here
            continue
        return temporary


def publish_directory(temporary: Path, path: Path, *, overwrite: bool) -> None:
    """Give the directory ``temporary`` the name ``path``, replacing it only with ``overwrite``."""
    if not overwrite or not os.path.lexists(path):
        _rename_no_replace(temporary, path)
        return
    old = path.parent / temporary_name(path.name, ".old")
    os.rename(path, old)
    try:
        os.rename(temporary, path)
    except BaseException:
        os.rename(old, path)
        raise
    if old.is_dir() and not old.is_symlink():
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.unlink(old)


def _link_no_clobber(temporary: Path, path: Path) -> None:
    """Give ``temporary`` the name ``path`` unless ``path`` exists; remove ``temporary``."""
    try:
        os.link(temporary, path)
    except FileExistsError:
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)") from None
    except OSError:
        # No hard links on this file system: check, then rename (a small window).
        if os.path.lexists(path):
            raise FileExistsError(f"{path} already exists (use overwrite to replace it)") from None
        os.replace(temporary, path)
        return
    os.unlink(temporary)


def _rename_no_replace(source: Path, destination: Path) -> None:
    """Rename ``source`` to ``destination`` unless that exists (atomically where supported)."""
    exists = FileExistsError(f"{destination} already exists (use overwrite to replace it)")
    renameat2 = _renameat2()
    if renameat2 is not None:
        at_fdcwd, noreplace = -100, 1
        names = os.fsencode(source), os.fsencode(destination)
        if renameat2(at_fdcwd, names[0], at_fdcwd, names[1], noreplace) == 0:
            return
        code = ctypes.get_errno()
        if code == errno.EEXIST:
            raise exists
        if code not in (errno.EINVAL, errno.ENOSYS, getattr(errno, "ENOTSUP", errno.EINVAL)):
            raise OSError(code, os.strerror(code), str(destination))
    if os.path.lexists(destination):  # no renameat2 here: check, then rename (a small window)
        raise exists
    try:
        os.rename(source, destination)
    except OSError as exc:
        if exc.errno in (errno.EEXIST, errno.ENOTEMPTY):
            raise exists from None
        raise


@functools.lru_cache(maxsize=1)
def _renameat2():
    """libc's ``renameat2`` (Linux), or None."""
    try:
        function = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError, TypeError):
        return None
    function.argtypes = [
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_uint,
    ]
    function.restype = ctypes.c_int
    return function


def temporary_name(name: str, suffix: str = ".tmp") -> str:
    """A new hidden name beside ``name`` that says which process writes it."""
    return f".{name}.{_host()}-{os.getpid()}-{secrets.token_hex(4)}{suffix}"


def stale_temporaries(directory: Path, name: str) -> tuple[list[Path], list[Path]]:
    """Temporaries of ``name`` in ``directory``: (left by a process that is gone, unattributed).

    A ``.old`` store whose destination is missing is the only copy left of
    it: never counted as removable.
    """
    removable, unknown = [], []
    prefix = f".{name}."
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return [], []
    for entry in entries:
        if not entry.name.startswith(prefix):
            continue
        tail = entry.name[len(name) + 1 :]
        owned = _OWNED.fullmatch(tail)
        path = Path(directory) / entry.name
        if owned is None:
            if _UNOWNED.fullmatch(tail):
                unknown.append(path)
            continue
        mine = owned["host"] == _host()
        gone = mine and not _running(int(owned["pid"]))
        if owned["suffix"] == ".old" and not os.path.lexists(Path(directory) / name):
            gone = False
        if gone:
            removable.append(path)
        elif not mine:
            unknown.append(path)
    return removable, unknown


def remove_stale_temporaries(directory: Path, name: str) -> list[Path]:
    """Remove the temporaries of ``name`` whose writer is gone; warn about unattributed ones.

    Returns the paths removed. Never raises: a temporary that cannot be
    removed is reported as unattributed ones are.
    """
    removable, unknown = stale_temporaries(directory, name)
    removed = []
    for path in removable:
        try:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                os.unlink(path)
        except OSError:
            unknown.append(path)
        else:
            removed.append(path)
    if unknown:
        shown = ", ".join(str(path) for path in unknown)
        warnings.warn(
            f"hidden temporaries of interrupted writes of {name}: {shown} (remove them if no "
            "other run is writing there)",
            StaleTemporaryWarning,
            stacklevel=3,
        )
    return removed


def _running(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine (True when it cannot be told)."""
    if sys.platform == "win32":
        return True  # os.kill(pid, 0) would terminate it there
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True
    return True


@functools.lru_cache(maxsize=1)
def _host() -> str:
    """Six hex digits naming this machine (temporaries of other hosts are never removed)."""
    return hashlib.sha1(socket.gethostname().encode()).hexdigest()[:6]
