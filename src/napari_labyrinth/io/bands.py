"""One plane larger than memory, read and written band of rows by band of rows.

A zarr store or TIFF file holding one grey plane (:func:`open_plane_bands`)
is read a band of rows at a time: a zarr array through its chunks, a TIFF
file's contiguous pixels straight from the file (``os.pread``), its strips or
tiles otherwise (tifffile's zarr store of the file), never the whole page. A
plane is written (:func:`plane_bands_written`) into a zarr store chunked by
bands of rows, or a TIFF file created with its final size and metadata,
uncompressed; each atomically, as :func:`napari_labyrinth.io.write_array`
writes: beside the destination, renamed into place once complete, removed on a
failure or Ctrl-C, and an existing one replaced only with ``overwrite``.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import uuid
from pathlib import Path

import numpy as np

from ._arrays import native
from ._atomic import create_temporary_directory, named_after_destination, publish_directory
from ._errors import ImageFileError, require_file
from ._formats import check_storable, check_writable, image_format, input_format, is_zarr_store
from .metadata import ImageMetadata


class PlaneBands:
    """The one 2-D plane of a zarr store or TIFF file, read by bands of rows.

    Attributes
    ----------
    path : Path
    shape : (int, int)
    dtype : numpy.dtype
        In native byte order, as :meth:`read` returns the rows.
    chunk_rows : int
        Rows of the file's own chunks or strips (1 for contiguous pixels): bands of a
        multiple of them read each chunk once.
    """

    def __init__(self, path: Path, shape, dtype, chunk_rows: int, read_rows, token=None):
        self.path = path
        self._token = token
        self.shape = tuple(int(n) for n in shape)
        self.dtype = np.dtype(dtype).newbyteorder("=")
        self.ndim = 2
        self.chunk_rows = int(chunk_rows)
        self._read_rows = read_rows

    def read(self, start: int, stop: int) -> np.ndarray:
        """The rows ``start .. stop - 1``, C-contiguous, in native byte order."""
        return np.ascontiguousarray(native(self._read_rows(start, stop)))

    def __getitem__(self, key) -> np.ndarray:
        """``plane[rows, columns]``: rows a slice (what dask reads a block with) or an integer
        array of rows (what the noise gate samples a plane's rows with), columns a slice."""
        rows, columns = key if isinstance(key, tuple) else (key, slice(None))
        if not isinstance(rows, slice):
            return self._rows(rows)[:, columns]
        start, stop, _ = rows.indices(self.shape[0])
        return self.read(start, stop)[:, columns]

    def _rows(self, rows) -> np.ndarray:
        """The rows at the integers ``rows``, read a chunk of rows at a time: each chunk
        they fall in once (a row alone costs its whole chunk in a compressed store)."""
        indices = np.asarray(rows)
        if indices.dtype.kind not in "iu" or indices.ndim != 1:
            raise TypeError(f"rows of a plane read band by band: a slice or 1-D integers, not {rows!r}")
        height = self.shape[0]
        if indices.size and not (0 <= indices.min() and indices.max() < height):
            raise IndexError(f"rows {rows!r} of a plane of {height} rows")
        band = np.empty((indices.size, self.shape[1]), self.dtype)
        chunks = indices // self.chunk_rows
        for chunk in np.unique(chunks):
            start = int(chunk) * self.chunk_rows
            taken = chunks == chunk
            band[taken] = self.read(start, min(height, start + self.chunk_rows))[indices[taken] - start]
        return band

    def __dask_tokenize__(self):
        if self._token is not None:
            return self._token
        stat = os.stat(self.path)
        return ("napari-labyrinth-bands", str(self.path), stat.st_mtime_ns, stat.st_size)


def open_plane_bands(path: str | os.PathLike) -> PlaneBands | None:
    """The plane of a zarr store or TIFF file holding one 2-D plane, to read by bands; None
    for any other file or image (a stack, colour samples, another format).

    Raises
    ------
    ImageFileError
        As the readers of :func:`napari_labyrinth.io.read_image` do for a file
        they refuse.
    """
    path = Path(path)
    kind = input_format(path)
    if kind == "ZARR":
        from .zarr import _open_zarr_array  # zarr is optional: imported on first use

        array = _open_zarr_array(path)
        if array.ndim != 2:
            return None
        return PlaneBands(path, array.shape, array.dtype, array.chunks[0],
                          lambda start, stop: array[start:stop])  # fmt: skip
    if kind != "TIFF":
        return None
    require_file(path)
    from .tiff import _cached_tiff, _tiff_file  # tifffile is imported on first use

    with _tiff_file(path) as tif:
        series = tif.series[0]
        if len(series.shape) != 2:
            return None
        shape, offset = series.shape, series.dataoffset
        dtype = np.dtype(series.dtype).newbyteorder(tif.byteorder)  # as the file stores it
    if offset is not None:  # the pixels are contiguous in the file: read rows at their place
        row_bytes = shape[1] * dtype.itemsize

        def read_rows(start, stop):
            with open(path, "rb", buffering=0) as file:
                data = os.pread(
                    file.fileno(), (stop - start) * row_bytes, offset + start * row_bytes
                )
            return np.frombuffer(data, dtype).reshape(stop - start, shape[1])

        return PlaneBands(path, shape, dtype, 1, read_rows)
    stat = os.stat(path)
    store = _cached_tiff(os.path.abspath(path), (stat.st_mtime_ns, stat.st_size))
    return PlaneBands(path, shape, dtype, store.chunks[0],
                      lambda start, stop: store[start:stop])  # fmt: skip


def array_plane_bands(array, name: str) -> PlaneBands:
    """A 2-D array in memory or on disk (numpy, dask, zarr) read by bands of rows as a
    file's plane is: bands of a multiple of its chunks' rows read each chunk once.

    ``name`` (a layer's) stands for the file's path in messages.
    """
    if len(array.shape) != 2:
        raise ValueError(f"{name}: a plane read band by band is 2-D, not of shape {array.shape}")
    chunks = getattr(array, "chunks", None)
    first = chunks[0] if chunks else 1
    chunk_rows = first[0] if isinstance(first, tuple) else first  # dask: each chunk's rows
    return PlaneBands(
        Path(name), array.shape, array.dtype, int(chunk_rows),
        lambda start, stop: np.asarray(array[start:stop]),
        token=("napari-labyrinth-array-bands", uuid.uuid4().hex),  # a fresh key: never cached
    )  # fmt: skip


#: Bytes of values in a band read or written at a time, about (when memory allows, and
#: the file's chunks of rows are not larger: ``streaming.band_plan``).
BAND_BYTES = 16 << 20


@contextlib.contextmanager
def plane_bands_written(
    path: str | os.PathLike,
    shape,
    dtype,
    rows: int,
    *,
    overwrite: bool = False,
    metadata: ImageMetadata | None = None,
):
    """A zarr store or TIFF file of one plane, written band by band, atomically.

    Yields ``write(first_row, values)``, which writes the rows ``values``
    from ``first_row`` on (at most ``rows`` of them; bands in any order). The
    output takes ``path``'s name once the block ends; a failure or an interruption
    removes it. A zarr store is chunked by ``rows`` rows; an OME-Zarr image gets its
    lower resolution levels from its full level, ``2 * rows`` rows at a time.

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False.
    ImageFileError
        For an output that is neither a zarr store nor a TIFF file, or one that
        cannot store the plane.
    """
    path = Path(path)
    kind = image_format(path)
    shape, dtype = tuple(int(n) for n in shape), np.dtype(dtype)
    placeholder = np.broadcast_to(np.zeros((), dtype), shape)  # no memory
    if kind == "TIFF":
        from .tiff import tiff_being_written  # tifffile is imported on first use

        check_writable(path, kind, placeholder, overwrite, metadata)
        with tiff_being_written(
            path, shape, dtype, overwrite=overwrite, metadata=metadata
        ) as write:
            yield lambda start, values: write(
                values, ((start, start + len(values)), (0, shape[1]))
            )
        return
    if kind != "ZARR":
        raise ImageFileError(path, "a plane larger than memory is written to .zarr or .tif")
    yield from _zarr_written(path, placeholder, rows, overwrite, metadata)


def _zarr_written(path: Path, placeholder, rows: int, overwrite: bool, metadata):
    """The body of :func:`plane_bands_written` for a zarr store."""
    from . import zarr as zarr_io  # zarr is optional: imported on first use

    check_storable(path, "ZARR", placeholder, metadata)
    if os.path.lexists(path):
        if not overwrite:
            raise FileExistsError(f"{path} already exists (use overwrite to replace it)")
        if not is_zarr_store(path):
            raise ImageFileError(path, "exists and is not a zarr store; not replacing it")
    import zarr

    chunks = (min(rows, placeholder.shape[0]), placeholder.shape[1])
    made: list[Path] = []
    with named_after_destination(path, made):  # the error names path, not the temporary
        try:
            temporary = os.path.abspath(create_temporary_directory(path.parent, path.name, made))
            store = zarr_io._waited_for(
                zarr_io._create_zarr_array, zarr, temporary, placeholder, chunks, metadata, None
            )
            target = zarr_io._waited_for(lambda: zarr.open_array(store=store, mode="r+"))

            def write(start, values):
                if not os.path.isdir(temporary):  # abandoned after a failure
                    raise FileNotFoundError(f"the output being written was removed: {temporary}")
                zarr_io._waited_for(target.__setitem__, slice(start, start + len(values)), values)

            yield write
            if store != temporary:  # an OME-Zarr image: its lower levels, band by band
                zarr_io._write_lower_levels_of(zarr, temporary, chunks, rows)
            publish_directory(Path(temporary), path, overwrite=overwrite)
        except BaseException:
            for temporary in made:
                shutil.rmtree(temporary, ignore_errors=True)
            raise
