"""Where the rendered planes of a lazy result go: a temporary zarr on disk, one chunk per plane.

A lazy input may not fit in memory, and neither would its result: its planes
are written, as they render, to a zarr array in a temporary directory, and
the result layer reads that array (napari reads the plane it shows, and
nothing else). The chunks are stored uncompressed, so a plane reads back as
fast as the disk (or the system's file cache) gives it. A plane not written
yet reads as zeros: blank.

Every result kept on disk (a lazy result's planes here, a streamed
pyramid's levels in :mod:`.pyramid_store`) has a :class:`StoreDirectory`.
A store is removed by its ``remove()`` (its layer removed, its viewer
closed), when the object is garbage-collected, and at interpreter exit.
Only a process killed outright leaves one behind: each is named after the
process that made it,

    napari-labyrinth-planes-<host>-<pid>-<random>      (in the system's temporary directory)

and the next store made removes those whose process, on this host, no longer
runs.
"""

from __future__ import annotations

import os
import re
import secrets
import shutil
import tempfile
import threading
import weakref
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..io._atomic import _host, _running

__all__ = ["STORE_PREFIX", "PlaneStore", "StoreDirectory", "remove_stale_stores"]

#: Start of the name of every store's directory.
STORE_PREFIX = "napari-labyrinth-planes-"

_OWNED = re.compile(
    re.escape(STORE_PREFIX) + r"(?P<host>[0-9a-f]{6})-(?P<pid>[0-9]+)-[0-9a-f]{8}$"
)


class StoreDirectory:
    """A directory of the system's temporary directory that holds a result on disk.

    Named after the process that made it (the module's docstring), removed by
    :meth:`remove`, when the object is garbage-collected, and at interpreter
    exit; making one removes those left by a process that no longer runs.

    Parameters
    ----------
    directory : path, optional
        Where the store's directory goes (default: the system's temporary directory).

    Attributes
    ----------
    path : Path
        The store's directory.

    Raises
    ------
    ValueError
        If zarr is not installed (with what to install).
    """

    def __init__(self, directory: str | os.PathLike | None = None) -> None:
        try:
            import zarr  # optional: the [dask] extra
        except ImportError as missing:
            raise ValueError(
                "this result is kept on disk in a zarr store: install zarr "
                "(pip install 'napari-labyrinth[dask]'), or render the current plane only"
            ) from missing
        self._zarr = zarr
        parent = Path(tempfile.gettempdir() if directory is None else directory)
        remove_stale_stores(parent)
        self.path = parent / f"{STORE_PREFIX}{_host()}-{os.getpid()}-{secrets.token_hex(4)}"
        self.path.mkdir()
        self._lock = threading.Lock()  # a write ends before the store is removed
        self._finalizer = weakref.finalize(self, _remove, str(self.path), self._lock)

    def _create_array(self, name: str, shape: Sequence[int], chunks: Sequence[int], dtype: Any):
        """A zarr array in the store (``name`` its folder, "" the store's own), uncompressed
        so that it reads back at the speed of the disk, every chunk written (blank too)."""
        return self._zarr.create_array(
            store=str(self.path / name) if name else str(self.path),
            shape=tuple(int(n) for n in shape),
            chunks=tuple(int(n) for n in chunks),
            dtype=np.dtype(dtype),
            fill_value=0,
            compressors=None,
            filters=None,
            config={"write_empty_chunks": True},
        )

    @property
    def removed(self) -> bool:
        """Whether the store's directory is gone (removed, collected)."""
        return not self._finalizer.alive

    def _write(self, array: Any, key: Any, values: np.ndarray) -> None:
        """``array[key] = values``, unless the store is removed (zarr would make it again)."""
        with self._lock:
            if not self.removed:
                array[key] = values

    def remove(self) -> None:
        """Remove the store's directory (once; later calls do nothing)."""
        self._finalizer()


class PlaneStore(StoreDirectory):
    """A temporary zarr array holding a lazy result, one chunk per plane.

    Parameters
    ----------
    shape : sequence of int
        The result's shape.
    dtype : dtype
    plane_axes : int
        Number of trailing axes of one plane (2, or 3 with colour channels):
        a chunk holds one plane, the axes before it are chunked by one.
    directory : path, optional
        As for :class:`StoreDirectory`, which holds the array (and raises as it does).

    Attributes
    ----------
    array : zarr.Array
        The array the result layer reads.
    """

    def __init__(
        self,
        shape: Sequence[int],
        dtype: Any,
        plane_axes: int,
        directory: str | os.PathLike | None = None,
    ) -> None:
        super().__init__(directory)
        shape = tuple(int(n) for n in shape)
        chunks = (1,) * (len(shape) - plane_axes) + shape[len(shape) - plane_axes :]
        self.array = self._create_array("", shape, chunks, dtype)

    def write(self, index: Sequence[int], planes: np.ndarray, axis: int = 0) -> None:
        """Write ``planes`` at ``index`` of the axes from ``axis`` (the axes before it, a
        stack's passes or a sweep's values, whole)."""
        key = (slice(None),) * axis + tuple(int(i) for i in index)
        self._write(self.array, key, planes)


def _remove(path: str, lock: threading.Lock) -> None:
    with lock:
        shutil.rmtree(path, ignore_errors=True)


def remove_stale_stores(directory: str | os.PathLike) -> list[Path]:
    """Remove the stores in ``directory`` whose process, on this host, no longer runs.

    Returns the paths removed; never raises (a store that cannot be removed stays).
    """
    removed = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        owned = _OWNED.fullmatch(entry.name)
        if owned is None or owned["host"] != _host() or _running(int(owned["pid"])):
            continue
        path = Path(directory) / entry.name
        shutil.rmtree(path, ignore_errors=True)
        if not path.exists():
            removed.append(path)
    return removed
