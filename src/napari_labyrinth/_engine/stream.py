"""One plane larger than memory: every pass of it in one sweep of bands of rows.

The raster scan updates row ``r`` from the row above it as this pass left it
and the row below it as the previous pass left it: a pixel writes only
itself. So pass ``k`` may update row ``r`` as soon as pass ``k - 1`` has
finished row ``r + 1``, and the passes run as a wavefront, each one row behind
the one before it. :func:`stream_plane` reads the plane once, band of rows by
band of rows, and hands each band of the result on as soon as the last pass
has finished it, holding only a band and a few rows per pass.

The pass kernel is the one of a plane held whole, called on a window of rows
(``PassRegion.row_offset``, ``plane_height``): rows, random streams (one per
pixel, from its place in the whole plane) and borders are those of the whole
plane; the tones are made and the values written back by the loops of the
in-memory path, row for row. The result is the in-memory rendering's bit for
bit (``tests/_engine/test_stream.py``).
"""

from __future__ import annotations

from collections.abc import Generator, Iterable

import numpy as np

from ..core._kernel_arguments import PassRegion, PlanePass
from ..core.codes import DIAGNOSTIC_FIELDS
from ..core.parameters import LabyrinthParameters
from ..core.tone_scale import ToneScale, integer_plane_tones, write_changed_values
from .changes import new_changes, write_changes
from .cores import idle_cores
from .passes import pass_kernel_for, pass_parameters
from .tiles import default_tile, exact_order_refusal, run_exact_order


def streaming_refusal(parameters: LabyrinthParameters) -> str | None:
    """Why the passes of ``parameters`` cannot stream a plane band by band; None if they can."""
    if parameters.scan == "checkerboard":
        return "scan='checkerboard' visits the whole plane four times in a pass"
    if parameters.border == "wrap":
        return "border='wrap' makes the first rows neighbours of the last ones"
    return None


def stream_bytes_per_row(width: int, dtype: np.dtype, passes: int) -> int:
    """Bytes :func:`stream_plane` holds per row of the bands it is given: the tones of every
    pass, the source values not written yet, and a band's tones and values while they are
    made (floats: their tones again, and the mask of finite ones). The bands it is given
    and those it yields are the caller's: :func:`stream_bytes` does not count them."""
    itemsize = np.dtype(dtype).itemsize
    floating = 4 + 1 if np.dtype(dtype).kind == "f" else 0
    return int(width) * (4 * max(passes, 0) + itemsize + 4 + itemsize + floating)


def stream_bytes(width: int, dtype: np.dtype, passes: int, rows: int) -> int:
    """Bytes :func:`stream_plane` holds at most, given bands of ``rows`` rows: those of
    :func:`stream_bytes_per_row` for each, and the few rows more that each pass keeps (the
    row above the next one it updates, and the rows the passes below it are behind)."""
    width, passes = int(width), max(int(passes), 0)
    kept = 4 * passes * (passes + 4) + np.dtype(dtype).itemsize * (2 * passes + 4)
    return int(rows) * stream_bytes_per_row(width, dtype, passes) + width * kept


class _Rows:
    """The rows ``first .. stop - 1`` of a plane, held in an array of ``capacity`` rows from
    its row ``offset`` on; rows are added below and dropped above."""

    def __init__(self, capacity: int, width: int, dtype):
        self.array = np.empty((capacity, width), dtype)
        self.offset = self.first = self.stop = 0

    def append(self, rows: np.ndarray) -> None:
        """Add ``rows``, the plane's rows from ``stop`` on."""
        count = rows.shape[0]
        if self.stop - self.offset + count > self.array.shape[0]:  # move the kept rows up
            kept = self.stop - self.first
            self.array[:kept] = self.array[self.first - self.offset : self.stop - self.offset]
            self.offset = self.first
        if self.stop - self.offset + count > self.array.shape[0]:
            raise AssertionError("a band of rows overflows its window")  # pragma: no cover
        self.array[self.stop - self.offset : self.stop - self.offset + count] = rows
        self.stop += count

    def rows(self, start: int, stop: int) -> np.ndarray:
        """The plane's rows ``start .. stop - 1`` (a view)."""
        return self.array[start - self.offset : stop - self.offset]

    def keep_from(self, row: int) -> None:
        """Rows above ``row`` are no longer needed."""
        self.first = max(self.first, row)


def stream_plane(
    bands: Iterable[np.ndarray],
    shape: tuple[int, int],
    dtype: np.dtype,
    scale: ToneScale,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    rows: int,
    plane_index: int = 0,
    counts: np.ndarray | None = None,
    workers: int = 1,
    variance_floor: float = -1.0,
) -> Generator[tuple[int, np.ndarray], None, None]:
    """Render a plane read band by band; yield ``(first_row, values)`` bands of the result.

    Parameters
    ----------
    bands : iterable of (n, W) arrays
        The plane's values, band of rows after band of rows from the top, at
        most ``rows`` rows each, in native byte order.
    shape : (H, W)
        The plane's shape.
    dtype : dtype
        Its dtype.
    scale : ToneScale
        Its tone scale (the whole plane's tone limits).
    parameters : LabyrinthParameters
        Any whose :func:`streaming_refusal` is None.
    seed, plane_index : int
        The random stream, as the plane's in-memory rendering draws it.
    rows : int
        The most rows of a band of ``bands``.
    counts : (passes, len(DIAGNOSTIC_FIELDS)) int64 array, optional
        The diagnostics, incremented pass by pass.
    workers : int, optional
        Threads: with more than one, the rows a pass updates at a time run in
        the exact-order tiles (``tiles``; the raster scan, any border but
        ``"wrap"``), on no more threads than idle cores. The result does not
        depend on it.
    variance_floor : float, optional
        The noise gate's floor (``core.noise.variance_floor`` of the whole
        plane's sigma; negative: off), as the in-memory passes take it.

    Yields
    ------
    first_row, values : int, (n, W) array of ``dtype``
        The result's rows from ``first_row`` on, in order, covering the plane.
        The array is the caller's.
    """
    height, width = (int(n) for n in shape)
    dtype = np.dtype(dtype)
    passes = parameters.passes
    refusal = streaming_refusal(parameters)
    if refusal is not None:
        raise ValueError(f"this plane cannot be rendered band by band: {refusal}")
    if counts is None:
        counts = np.zeros((passes, len(DIAGNOSTIC_FIELDS)), dtype=np.int64)
    kernel_parameters = pass_parameters(parameters)
    kernel = pass_kernel_for(kernel_parameters)
    changes = new_changes(0)  # room for none: the write-back compares every pixel
    floating = dtype.kind == "f"
    tiled = workers > 1 and exact_order_refusal(parameters) is None
    # each pass holds its kept row, the row it waits below, and what the pass above hands
    # on: a band, and at the plane's end the rows every pass above it was behind
    tones = [_Rows(rows + passes + 4, width, np.float32) for _ in range(passes)]
    # the source values of the rows not written yet: each pass is a row behind the one above
    source = _Rows(rows + 2 * passes + 4, width, dtype)
    done = [0] * passes  # rows each pass has finished
    read = written = 0
    for values in bands:
        values = np.ascontiguousarray(values)
        if values.shape[1:] != (width,) or not 0 < values.shape[0] <= rows:
            raise ValueError(f"a band of shape {values.shape} in a plane of shape {shape}")
        count = values.shape[0]
        if passes == 0:
            copied = values.copy()
            del values  # the band given is dropped before the next is read (as below)
            yield read, copied
            read += count
            continue
        source.append(values)
        tones[0].append(_tones(scale, values))
        del values  # copied: a band read whole, of which it is the last piece, goes now
        read += count
        finished = read  # rows finished by the pass above (the source's: read)
        for k in range(passes):
            # a row reads the row below it as the pass above left it
            stop = finished if finished == height else finished - 1
            start = done[k]
            if stop > start:
                window = tones[k]
                plane = window.array
                nonfinite = (
                    floating
                    and not np.isfinite(
                        window.rows(max(start - 1, window.first), min(stop + 1, window.stop))
                    ).all()
                )
                plane_pass = PlanePass(
                    np.uint64(seed), int(plane_index), k, bool(nonfinite), float(variance_floor)
                )
                region = PassRegion(-1, start, stop, 0, -1, window.offset, height)
                threads = min(workers, idle_cores()) if tiled else 1  # as run_pass takes them
                tile = default_tile((rows, width), threads, parameters)
                if threads > 1 and stop - start > tile[0]:
                    run_exact_order(
                        kernel, plane, kernel_parameters, plane_pass, counts[k], changes, *tile,
                        threads, region,
                    )  # fmt: skip
                else:
                    kernel(plane, kernel_parameters, plane_pass, region, counts[k], changes)
                if k + 1 < passes:
                    tones[k + 1].append(window.rows(start, stop))
                done[k] = stop
            finished = done[k]
        if done[-1] > written:
            stop = done[-1]
            yield (
                written,
                _values(scale, source.rows(written, stop), tones[-1].rows(written, stop)),
            )
            written = stop
            source.keep_from(written)
        for k in range(passes):
            tones[k].keep_from(done[k] - 1)  # the row above the next one it updates
    if read != height:
        raise ValueError(f"the bands held {read} rows of a plane of {height}")


def _tones(scale: ToneScale, values: np.ndarray) -> np.ndarray:
    """The float32 tones of a band of values, as the in-memory rendering makes them."""
    tones = integer_plane_tones(scale, values)
    if tones is None:
        tones = np.ascontiguousarray(scale.to_tones(values))
    return tones


def _values(scale: ToneScale, values: np.ndarray, tones: np.ndarray) -> np.ndarray:
    """The values of a band of rows after the passes (``values`` before them, ``tones``
    after), as the in-memory rendering writes them back."""
    target = values.copy()
    if values.dtype.kind in "iu":
        write_changed_values(scale, target, values, tones)
    else:
        write_changes(target, np.ascontiguousarray(scale.to_tones(values)), tones, scale)
    return target
