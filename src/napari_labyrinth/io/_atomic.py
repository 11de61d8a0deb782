"""Hidden temporaries of writes that never finished: named after their writer, cleared later.

Every write goes to a hidden temporary beside its destination (a file, or a
directory for a zarr store) that takes the destination's name at the end, and
is removed on any error or Ctrl-C. Only a process killed outright (SIGKILL,
a power cut) leaves one behind. Each temporary is therefore named after the
process that writes it::

    .NAME.<host>-<pid>-<random>.tmp        (.old: a zarr store being replaced)

and the next write of NAME removes those whose process, on this host, no
longer runs. Temporaries it cannot attribute (written by an older version, or
by another host sharing the directory) are reported with a warning, never
removed.
"""

from __future__ import annotations

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

