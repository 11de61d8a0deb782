"""The error that names an image file, and the checks that raise it before reading.

Every reader and writer of :mod:`napari_labyrinth.io` reports a file it cannot
read, or an array a format cannot store, as an :class:`ImageFileError` naming
the file; a missing file stays a ``FileNotFoundError``.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path


class ImageFileError(ValueError):
    """An image file that cannot be read, or an array that cannot be stored.

    ``str(error)`` is ``"<path>: <reason>"``; ``reason`` alone is also kept.
    """

    def __init__(self, path: str | os.PathLike, reason: str):
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")


def require_file(path: Path) -> None:
    """Raise a clear error unless ``path`` is an existing file."""
    if not path.exists():
        raise FileNotFoundError(errno.ENOENT, "no such file", str(path))
    if path.is_dir():
        raise ImageFileError(path, "is a directory, not an image file")


def refuse_unaffordable_file(path: Path, reason: str | None) -> None:
    """Refuse, before reading, an image that needs more memory than the run may use."""
    if reason is not None:
        raise ImageFileError(path, reason)


def reason_of(exc: BaseException) -> str:
    """One line describing an exception, without a traceback."""
    if isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())
