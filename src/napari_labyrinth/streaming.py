"""One plane larger than memory, rendered from a file to a file band of rows by band of rows.

A grey plane whose rendering in memory would need more than the run may use
(``_budget``) is rendered by :func:`render_plane_file` from a zarr store or
TIFF file to a zarr store or TIFF file: its tone limits found in a streamed
pass over the file (unless given), then every pass of the algorithm in one
sweep of bands of rows (``_engine.stream``), each band of the result written
as soon as the last pass has finished it. Memory holds a few bands, whatever
the plane's size; the result is the in-memory rendering's bit for bit. The
command line takes this path for such a plane (:func:`streams`).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ._budget import MEMORY_ENV, budget_text, bytes_text, declared, memory_limit, refusal
from ._engine.counts import DIAGNOSTICS_DTYPE
from ._engine.stream import stream_bytes, stream_bytes_per_row, stream_plane, streaming_refusal
from ._inputs import validate_workers
from .core.codes import DIAGNOSTIC_FIELDS
from .core.parameters import DEFAULT_SEED, SEED, LabyrinthParameters, is_auto
from .core.presets import DEFAULT_PRESET, resolve_parameters
from .core.noise import tone_noise_sigma, variance_floor
from .core.tone_scale import ToneScale, resolve_tone_scale
from .io import ImageFileError, ImageMetadata, release_files
from .io.bands import BAND_BYTES, PlaneBands, open_plane_bands, plane_bands_written
from .lazy import default_tone_limits


@dataclasses.dataclass(frozen=True)
class StreamedRendering:
    """What :func:`render_plane_file` wrote.

    Attributes
    ----------
    path : Path
        The output.
    tone_limits : (float, float)
        The values mapped to tones 0 and 255.
    diagnostics : structured ndarray, shape (passes,)
        The counts of each pass, as :func:`napari_labyrinth.labyrinth` returns them.
    rows : int
        Rows of the bands the plane was read, rendered and written in.
    noise_sigma : float
        The plane's noise in tones, which the noise gate compared the local
        variance with (``core.noise.tone_noise_sigma``); 0 with the gate off.
    """

    path: Path
    tone_limits: tuple[float, float]
    diagnostics: np.ndarray
    rows: int
    noise_sigma: float = 0.0


def streams(path: str | os.PathLike) -> PlaneBands | None:
    """The plane of ``path`` if it is rendered band by band: one 2-D plane of a zarr store
    or TIFF file too large to render in memory here; else None (the file is read as usual).

    Raises
    ------
    ImageFileError
        As the readers do for a file they refuse.
    """
    plane = open_plane_bands(path)
    if plane is None or refusal(plane.shape, plane.dtype) is None:
        return None
    return plane


def streamed_parameters(preset: str = DEFAULT_PRESET, **parameters: Any) -> LabyrinthParameters:
    """The parameters of a rendering band by band, refused if it needs the whole plane.

    Raises
    ------
    TypeError, ValueError
        Naming a bad parameter, ``variance_threshold="auto"``, ``border="wrap"`` or
        ``scan="checkerboard"``.
    """
    if is_auto(parameters.get("variance_threshold")):
        raise ValueError(
            "variance_threshold='auto' probes the whole plane, which does not fit in memory "
            "here: give a value"
        )
    rendering = resolve_parameters(preset, **parameters)
    reason = streaming_refusal(rendering)
    if reason is not None:
        raise ValueError(f"a plane larger than memory is rendered band by band, and {reason}")
    return rendering


def plane_tone_limits(plane: PlaneBands, rows: int | None = None) -> tuple[float, float]:
    """The default tone limits of ``plane`` (those :func:`napari_labyrinth.labyrinth` would
    use), found by a streamed pass over its bands of ``rows`` rows: read by as many of
    dask's threads at once as the bands' share of the memory holds (one at least)."""
    import dask  # dask is optional: imported on first use
    import dask.array as da

    if plane.dtype == np.uint8:
        return 0.0, 255.0
    rows = rows or plane_rows(plane, 1)
    meta = np.empty((0, 0), dtype=plane.dtype)
    image = da.from_array(plane, chunks=(rows, plane.shape[1]), lock=False, meta=meta)
    band = rows * plane.shape[1] * plane.dtype.itemsize
    threads = max(1, min(os.cpu_count() or 1, memory_limit() // BAND_SHARE // band))
    with dask.config.set(num_workers=threads):
        return default_tone_limits(image)


def plane_noise_sigma(plane: PlaneBands, scale: ToneScale, rows: int | None = None) -> float:
    """The noise of ``plane`` in the tones of ``scale`` (``core.noise.tone_noise_sigma``),
    read in bands of ``rows`` rows: the number the noise gate takes for the plane held whole."""
    return tone_noise_sigma(plane, scale, band_rows=rows or plane_rows(plane, 1))


def render_plane_file(
    input: str | os.PathLike,
    output: str | os.PathLike,
    *,
    preset: str = DEFAULT_PRESET,
    seed: int = DEFAULT_SEED,
    tone_limits: tuple[float, float] | None = None,
    noise_sigma: float | None = None,
    overwrite: bool = False,
    metadata: ImageMetadata | None = None,
    progress: Callable[[int, int], Any] | None = None,
    workers: int | None = None,
    **parameters: Any,
) -> StreamedRendering:
    """Render the one plane of a zarr store or TIFF file into another, band by band.

    Parameters
    ----------
    input : str or path-like
        A zarr store or TIFF file holding one 2-D grey plane, read a band of
        rows at a time (zarr chunks, TIFF strips or tiles of fewer rows than a
        band's memory; contiguous TIFF pixels are read row by row).
    output : str or path-like
        A ``.zarr`` store (chunked by bands of rows) or ``.tif`` file
        (uncompressed), written atomically.
    preset, seed, tone_limits, **parameters
        As for :func:`napari_labyrinth.labyrinth`; without ``tone_limits`` the
        default ones are found in a pass over the file first.
    noise_sigma : float, optional
        The plane's noise in tones, for the noise gate (``noise_gate`` > 0);
        without it, measured in a pass over the file first
        (:func:`plane_noise_sigma`).
        ``variance_threshold="auto"``, ``scan="checkerboard"`` and
        ``border="wrap"`` are refused: each needs the whole plane at once.
    overwrite : bool, optional
        Replace an existing output.
    metadata : ImageMetadata, optional
        Stored with the pixels, as :func:`napari_labyrinth.io.write_array` stores it.
    progress : callable, optional
        ``progress(rows_written, rows)``.
    workers : int, optional
        Threads (default: every core): each pass's rows run in the exact-order
        tiles, as a plane's in memory do. The result does not depend on it.

    Returns
    -------
    StreamedRendering

    Raises
    ------
    ImageFileError
        For an input that is not one plane of a zarr store or TIFF file, or
        whose chunks do not fit in memory, or an output that cannot hold it.
    FileExistsError
        If the output exists and ``overwrite`` is False.
    TypeError, ValueError
        Naming a bad parameter.
    """
    rendering = streamed_parameters(preset, **parameters)
    seed = SEED.validate(seed)
    workers = validate_workers(workers)
    input, output = Path(input), Path(output)
    if input.resolve() == output.resolve():
        raise ValueError(f"{output}: the output would replace the input")
    try:
        plane = open_plane_bands(input)
        if plane is None:
            raise ImageFileError(input, "does not hold one 2-D grey plane to render band by band")
        stream = plane_stream(
            plane, rendering, seed, tone_limits=tone_limits, noise_sigma=noise_sigma,
            workers=workers,
        )  # fmt: skip
        height = plane.shape[0]
        with plane_bands_written(
            output, plane.shape, plane.dtype, stream.rows, overwrite=overwrite, metadata=metadata
        ) as write:
            for start, values in stream.bands:
                write(start, values)
                if progress is not None:
                    progress(start + len(values), height)
    finally:
        release_files()
    return StreamedRendering(
        output, stream.tone_limits, stream.diagnostics, stream.rows, stream.noise_sigma
    )


@dataclasses.dataclass
class PlaneStream:
    """A plane's rendering band by band, set up (:func:`plane_stream`) and run as its
    :attr:`bands` are taken.

    Attributes
    ----------
    rows : int
        Rows of the result's bands (the last one shorter).
    scale : ToneScale
        The plane's tone scale (its tone limits).
    noise_sigma : float
        The plane's noise in tones, for the noise gate; 0 with the gate off.
    counts : (passes, len(DIAGNOSTIC_FIELDS)) int64 array
        The diagnostics, counted as the bands are rendered.
    bands : iterator of (int, ndarray)
        ``(first_row, values)``: the result's bands of :attr:`rows` rows, in order; the
        array is reused for the next band.
    """

    rows: int
    scale: ToneScale
    noise_sigma: float
    counts: np.ndarray
    bands: Iterator[tuple[int, np.ndarray]]

    @property
    def tone_limits(self) -> tuple[float, float]:
        """The values mapped to tones 0 and 255."""
        return float(self.scale.low), float(self.scale.high)

    @property
    def diagnostics(self) -> np.ndarray:
        """The counts of each pass so far, as :func:`napari_labyrinth.labyrinth` returns them."""
        return self.counts.view(DIAGNOSTICS_DTYPE)[:, 0]


def plane_stream(
    plane: PlaneBands,
    rendering: LabyrinthParameters,
    seed: int,
    *,
    tone_limits: tuple[float, float] | None = None,
    noise_sigma: float | None = None,
    workers: int = 1,
    row_multiple: int = 1,
) -> PlaneStream:
    """Set up the rendering of ``plane`` band by band with the parameters ``rendering``
    (:func:`streamed_parameters`): its tone limits and noise found first, in passes over
    its bands, when not given.

    ``row_multiple``: the result's bands (all but the last) hold a multiple of it rows
    (a pyramid's levels halve each band on its own). Raises as :func:`render_plane_file`.
    """
    plan = band_plan(plane, rendering.passes, row_multiple)
    if tone_limits is None:
        tone_limits = plane_tone_limits(plane, plan.read)
    scale = resolve_tone_scale(np.empty(0, plane.dtype), tone_limits)
    if rendering.noise_gate <= 0:
        noise_sigma = 0.0
    elif noise_sigma is None:
        noise_sigma = plane_noise_sigma(plane, scale, plan.read)
    elif not (isinstance(noise_sigma, (int, float)) and 0 <= noise_sigma < np.inf):
        raise ValueError(f"noise_sigma must be a finite number >= 0, got {noise_sigma!r}")
    counts = np.zeros((rendering.passes, len(DIAGNOSTIC_FIELDS)), np.int64)
    rendered = stream_plane(
        _pieces(plane, plan.read, plan.rendered),
        plane.shape,
        plane.dtype,
        scale,
        rendering,
        seed,
        rows=plan.rendered,
        counts=counts,
        workers=workers,
        variance_floor=variance_floor(rendering.noise_gate, float(noise_sigma)),
    )
    bands = _aligned(rendered, plan.written, plane.shape, plane.dtype)
    return PlaneStream(plan.written, scale, float(noise_sigma), counts, bands)


#: The share of the memory a run may use that the bands of a plane rendered band by band
#: may hold: ``1 / BAND_SHARE`` of it. The rest is the process's own (Python, numpy, numba's
#: kernels, dask, zarr: 200-300 MB) and the bounded temporaries of reading, measuring and
#: writing a band (a few tens of MB), which do not grow with the bands.
BAND_SHARE = 4

#: Bytes of the tones and buffers of the passes of a plane rendered band by band, at most
#: (a band of fewer rows of a wide plane); the rows read at a time are bounded apart.
STREAM_BYTES = 256 << 20


@dataclasses.dataclass(frozen=True)
class BandPlan:
    """How a plane is read, rendered and written band by band (:func:`band_plan`).

    Attributes
    ----------
    read : int
        Rows read at a time: a multiple of the file's chunks' rows, so that each chunk is
        read once (a chunk of rows is read whole, whatever its size).
    rendered : int
        Rows the passes take at a time: pieces of a band read.
    written : int
        Rows of the result's bands (the chunks of a zarr output), a multiple of the
        ``row_multiple`` asked for.
    bytes : int
        What the bands hold at most (:func:`plan_bytes`).
    """

    read: int
    rendered: int
    written: int
    bytes: int


def plan_bytes(shape, dtype, passes: int, read: int, rendered: int, written: int) -> int:
    """Bytes the bands of a plane of ``shape`` and ``dtype`` hold at most, read, rendered and
    written in bands of those rows: the larger of :func:`_rendering_bytes` (the passes')
    and ``2 * read`` rows of values (a pass over the file's, for the tone limits or the noise
    gate: a band read and a copy of it)."""
    reading = 2 * read * int(shape[1]) * np.dtype(dtype).itemsize
    return max(_rendering_bytes(shape, dtype, passes, read, rendered, written), reading)


def _rendering_bytes(shape, dtype, passes: int, read: int, rendered: int, written: int) -> int:
    """Bytes the passes' bands hold: a band read (its raw values: the pieces rendered are
    views of it), the tones and buffers of a piece (``_engine.stream.stream_bytes``), and a
    band written and its encoding."""
    width = int(shape[1])
    row = width * np.dtype(dtype).itemsize
    return read * row + stream_bytes(width, dtype, passes, rendered) + 2 * written * row


def band_plan(
    plane: PlaneBands, passes: int, row_multiple: int = 1, limit: int | None = None
) -> BandPlan:
    """The bands ``plane`` is read, rendered (in ``passes`` passes) and written in, within a
    ``1 / BAND_SHARE`` share of the memory the run may use (``limit``, default
    ``memory_limit()``): read and written in about ``BAND_BYTES`` of values a band (one
    chunk of the file's rows, whatever its size, at least), rendered in pieces of at most
    ``STREAM_BYTES``; in fewer rows where the memory is short.

    Raises
    ------
    ImageFileError
        If even the smallest bands do not fit (one chunk of the file's rows read, pieces of
        one row rendered, bands of ``row_multiple`` rows written), naming the least
        ``NAPARI_LABYRINTH_MEMORY`` under which they would.
    """
    limit = memory_limit() if limit is None else int(limit)
    share = limit // BAND_SHARE
    height, width = plane.shape
    row = width * plane.dtype.itemsize
    chunk = max(1, min(plane.chunk_rows, height))
    multiple = max(1, int(row_multiple))
    wanted = max(1, BAND_BYTES // row)
    # a band read and a band written take an eighth of the share each, at most, unless one
    # chunk of rows is more: the pieces of the passes get the rest
    ample = max(1, min(wanted, height, share // (8 * row)))
    read = max(chunk, ample // chunk * chunk)
    unit = math.lcm(chunk, multiple)
    unit = unit if unit <= min(read, ample) else multiple  # the output's bands line up
    written = max(multiple, min(read, ample) // unit * unit)
    plan = _fitted(plane, passes, share, read, written)
    if plan is not None:
        return plan
    while True:  # one chunk of rows read; bands written halved until the pieces fit
        plan = _fitted(plane, passes, share, chunk, written)
        if plan is not None and (plan.rendered >= min(written, chunk) or written == multiple):
            return plan
        if written == multiple:
            break
        written = max(multiple, written // 2 // multiple * multiple)
    least = plan_bytes(plane.shape, plane.dtype, passes, chunk, 1, multiple) * BAND_SHARE
    what = f"its chunks of {chunk} rows need" if chunk > 1 else "one of its rows needs"
    raise ImageFileError(
        plane.path,
        f"{declared(plane.shape, plane.dtype)}, too large to render in memory here and so "
        f"rendered band by band, but {what} more memory than this run may use "
        f"({bytes_text(limit)}): band by band it needs {MEMORY_ENV}={budget_text(least)} at "
        "least; set it so, or store it in chunks (or strips, tiles) of fewer rows",
    )


def _fitted(plane: PlaneBands, passes: int, share: int, read: int, written: int):
    """The plan of bands of ``read`` and ``written`` rows with the largest pieces that fit
    in ``share`` bytes (at most ``STREAM_BYTES`` of them, at most a band read), or None."""
    shape, dtype = plane.shape, plane.dtype
    if plan_bytes(shape, dtype, passes, read, 0, written) > share:
        return None
    per_row = stream_bytes_per_row(shape[1], dtype, passes)
    spare = share - _rendering_bytes(shape, dtype, passes, read, 0, written)
    rendered = min(read, max(1, STREAM_BYTES // per_row), spare // per_row)
    if rendered < 1:
        return None
    held = plan_bytes(shape, dtype, passes, read, rendered, written)
    return BandPlan(read, rendered, written, held)


def plane_rows(plane: PlaneBands, passes: int) -> int:
    """Rows of the bands ``plane`` is read in, rendered in ``passes`` passes
    (:func:`band_plan`'s ``read``).

    Raises
    ------
    ImageFileError
        If even one chunk of the file's rows needs more memory than the run may use.
    """
    return band_plan(plane, passes).read


def rendered_rows(plane: PlaneBands, passes: int, rows: int) -> int:
    """Rows the passes take at a time from bands of ``rows`` rows read, at most: those
    whose tones and buffers (``stream_bytes_per_row``) fit in ``STREAM_BYTES``, at most
    ``rows`` (:func:`band_plan` takes fewer where the memory is short)."""
    per_row = stream_bytes_per_row(plane.shape[1], plane.dtype, passes)
    return max(1, min(rows, STREAM_BYTES // per_row))


def written_rows(plane: PlaneBands, passes: int, row_multiple: int = 1) -> int:
    """Rows of the result's bands of ``plane`` rendered in ``passes`` passes
    (:func:`band_plan`'s ``written``), a multiple of ``row_multiple``. Raises as
    :func:`plane_rows`."""
    return band_plan(plane, passes, row_multiple).written


def _pieces(plane: PlaneBands, read: int, rendered: int) -> Iterator[np.ndarray]:
    """The plane's rows in pieces of ``rendered`` rows, read ``read`` rows at a time: a band
    read is dropped before the next one is read."""
    height = plane.shape[0]
    for start in range(0, height, read):
        band = plane.read(start, min(height, start + read))
        for first in range(0, len(band), rendered):
            yield band[first : first + rendered]
        del band


def _aligned(
    bands: Iterator[tuple[int, np.ndarray]], rows: int, shape, dtype
) -> Iterator[tuple[int, np.ndarray]]:
    """``bands`` (consecutive rows, in order) regrouped into bands of ``rows`` rows from row
    0 on (the last one shorter): each fills whole chunks of the output."""
    height, width = shape
    buffer = np.empty((rows, width), dtype)
    start = filled = 0
    for _, values in bands:
        taken = 0
        while taken < len(values):
            count = min(rows - filled, len(values) - taken)
            buffer[filled : filled + count] = values[taken : taken + count]
            filled, taken = filled + count, taken + count
            if filled == rows or start + filled == height:
                yield start, buffer[:filled]
                start, filled = start + filled, 0
