"""Where a multiscale result rendered band by band goes: a temporary zarr per level, on disk.

A multiscale layer's full level may not fit in memory, and neither would its
result: the run renders it band of rows by band of rows
(:mod:`.streamed_level`) and writes each band here, to the full level and,
halved as it comes (``io._pyramid.halved``, the 2 × 2 mean), to every lower
level. A band of ``rows`` rows, a multiple of ``2 ** (levels - 1)`` (all but
the last), halves on its own into the rows of the level below that the whole
level's halving would give, so the levels are those
:func:`.multiscale.lower_levels` makes from the full level in memory, bit for
bit. Chunks are a band's rows by at most :data:`CHUNK_COLUMNS` columns,
uncompressed: napari reads the tiles it shows at the speed of the disk.

The store's directory is a :class:`.plane_store.StoreDirectory`: removed with
its layer, its viewer, or at exit.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..io._pyramid import halved, halved_shape
from .plane_store import StoreDirectory

__all__ = ["CHUNK_COLUMNS", "PyramidStore"]

#: The most columns of a chunk of a level (a chunk holds a band's rows).
CHUNK_COLUMNS = 2048


class PyramidStore(StoreDirectory):
    """The levels of a 2-D result on disk, written band by band, each level half the one above.

    Parameters
    ----------
    shape : (int, int)
        The full level's shape.
    dtype : dtype
    levels : int
        Number of levels, the full one included.
    rows : int
        Rows of the bands written (all but the last), a multiple of ``2 ** (levels - 1)``.
    directory : path, optional
        Where the store's directory goes (default: the system's temporary directory).

    Attributes
    ----------
    path : Path
    arrays : list of zarr.Array
        The levels, full level first: a multiscale layer's data.

    Raises
    ------
    ValueError
        If zarr is not installed, or ``rows`` is not a positive multiple of ``2 ** (levels - 1)``.
    """

    def __init__(
        self,
        shape: Sequence[int],
        dtype: Any,
        levels: int,
        rows: int,
        directory: str | os.PathLike | None = None,
    ) -> None:
        if levels < 1 or rows < 1 or rows % 2 ** (levels - 1):
            raise ValueError(
                f"bands of {rows} rows do not halve evenly into {levels} levels"
            )
        super().__init__(directory)
        self.rows = int(rows)
        self.arrays = []
        level_shape = tuple(int(n) for n in shape)
        for level in range(levels):
            chunks = (max(1, rows >> level), min(level_shape[1], CHUNK_COLUMNS))
            self.arrays.append(self._create_array(str(level), level_shape, chunks, dtype))
            level_shape = halved_shape(level_shape, (0, 1))

    def write(self, start: int, band: np.ndarray) -> None:
        """Write the full level's rows ``start ..`` (``band``; ``start`` a multiple of
        :attr:`rows`) and their halvings into the levels below."""
        if start % self.rows:
            raise ValueError(f"a band starts at a multiple of {self.rows} rows, not at {start}")
        for array in self.arrays:
            self._write(array, slice(start, start + band.shape[0]), band)
            start //= 2
            if array is not self.arrays[-1]:
                band = halved(band, (0, 1))
