"""The source files a kernel's compiled code depends on, and their digest.

numba takes a kernel's cached code as current while its own file keeps its
modification time and size; the helpers it calls from other files and the
NamedTuple classes of its arguments are compiled into it too. The digest of
:func:`source_digest` covers all those files' contents, each named by its path
relative to the package, so that it is the same for an install anywhere.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import inspect
from pathlib import Path

#: The folder holding the package: paths in a digest are relative to it.
PACKAGE_PARENT = Path(__file__).resolve().parents[2]


def source_digest(function) -> str:
    """The digest of the contents of ``function``'s file and of the files of the jitted
    helpers and NamedTuple classes it reaches (:func:`_source_files`), each named by its
    path relative to the package's parent folder (where it lies inside it)."""
    digest = hashlib.sha256()
    for path in sorted(_source_files(function)):
        digest.update(_relative(path).encode() + b"\0" + _file_digest(path))
    return digest.hexdigest()


def _relative(path: str) -> str:
    try:
        return Path(path).resolve().relative_to(PACKAGE_PARENT).as_posix()
    except ValueError:  # not the package's: its absolute path
        return path


@functools.lru_cache(maxsize=None)
def _file_digest(path: str) -> bytes:
    """The digest of ``path``'s contents, read once a process: the kernels of a module
    and their helpers share their files."""
    with open(path, "rb") as source:
        return hashlib.sha256(source.read()).digest()


def _source_files(function, seen: set[str] | None = None) -> set[str]:
    """The file of ``function`` and those of the jitted functions it reaches through its
    globals (helpers, tuples of kernels), as the decorator sees them: helpers come from
    imports at the top of a module or are defined above their caller. The files of the
    NamedTuple classes in those globals too: the kernels' arguments, imported at the top
    of their modules."""
    seen = set() if seen is None else seen
    try:
        path = inspect.getsourcefile(function)
    except TypeError:
        return seen
    if path is None or path in seen:
        return seen
    seen.add(path)
    values = list(getattr(function, "__globals__", {}).values())
    while values:
        value = values.pop()
        if isinstance(value, tuple):
            values.extend(value)
        elif hasattr(value, "py_func") and hasattr(value, "overloads"):  # a dispatcher
            _source_files(value.py_func, seen)
        elif isinstance(value, type) and issubclass(value, tuple) and hasattr(value, "_fields"):
            with contextlib.suppress(TypeError, OSError):  # a NamedTuple of no file
                seen.add(inspect.getsourcefile(value) or "")
    seen.discard("")
    return seen
