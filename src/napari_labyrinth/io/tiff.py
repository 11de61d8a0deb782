"""TIFF files: OME-TIFF, ImageJ hyperstacks and plain TIFF, read whole or lazily, written.

Through tifffile: a file is read only if it holds one intact image whose
pixels are read exactly (:func:`_tiff_file` refuses the others, saying what
to convert them to); what it says about its pixels (:func:`tiff_metadata`)
comes from its OME-XML, its ImageJ description or tifffile's JSON
description, and its tags. A large stack is read plane by plane on demand
(:func:`open_tiff_lazily`) and written plane by plane as its blocks are
computed (:func:`write_tiff_lazily`); what an output stores beside its
pixels is in :mod:`._tiff_options`. tifffile and zarr are imported where they
are used, so that ``import napari_labyrinth.io`` stays quick.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import re
import threading
from pathlib import Path
from typing import Any

import numpy as np

from .._budget import refusal
from ..core.colour import LUMINANCE_CHANNELS
from ..lazy import run_blocks
from ..provenance import KEY
from ._arrays import block_chunks, native
from ._atomic import create_temporary, published
from ._errors import ImageFileError, refuse_unaffordable_file
from ._formats import check_writable
from ._tiff_options import tiff_options
from .metadata import (
    ALPHA_SAMPLES,
    IMAGEJ_UNITS,
    SPATIAL_AXES,
    ImageMetadata,
    complete_names,
    image_name,
    is_ambiguous,
    read_record,
    tiff_colour,
    time_pair,
    time_unit_name,
    unit_name,
)

#: TIFF photometric interpretations refused, with why and what to do ("is a ... TIFF").
_TIFF_PHOTOMETRIC_REFUSALS = {
    "MINISWHITE": (
        "MINISWHITE TIFF (0 is white: its grey levels are inverted), which would be rendered "
        "and written as MINISBLACK; convert it to a MINISBLACK grey TIFF first"
    ),
    "PALETTE": (
        "palette (indexed colour) TIFF, whose colour map would be dropped; convert it to an "
        "RGB TIFF first"
    ),
    "SEPARATED": "CMYK (separated) TIFF; CMYK is not supported: convert it to an RGB TIFF first",
}


#: The TIFF photometric interpretations read: grey (planes, or grey and extra samples) and
#: RGB(A) samples.
_TIFF_PHOTOMETRICS = ("MINISBLACK", "RGB")


#: The TIFF tag of an embedded ICC profile (InterColorProfile).
_ICC_PROFILE_TAG = 34675


def read_tiff(path: Path) -> np.ndarray:
    """The pixels of a TIFF file (every page of its one series), refused before reading if
    they need more memory than the run may use."""
    with _tiff_file(path) as tif:
        series = tif.series[0]  # what the header declares, from the file open here
        refuse_unaffordable_file(path, refusal(series.shape, series.dtype))
        return tif.asarray()


def tiff_metadata(path: Path) -> ImageMetadata:
    """What a TIFF file says about its pixels (see ``read_metadata``)."""
    import tifffile

    with _tiff_file(path) as tif:
        series = tif.series[0]
        axes, shape = series.axes, series.shape
        page = series.keyframe
        icc_profile = _tiff_icc_profile(page)  # a large tag: read while the file is open
        channel_axis, colour, extra = None, "", _extra_samples(page)
        photometric = tifffile.PHOTOMETRIC(page.photometric)
        if "S" in axes:
            samples = page.samplesperpixel
            colour = f"{tiff_colour(photometric.name)}{samples} samples per pixel"
            if extra:
                colour += f" (extra samples: {', '.join(extra)})"
            channel_axis = axes.index("S")
            if photometric != tifffile.PHOTOMETRIC.RGB:  # grey and extra samples
                channel_axis -= len(axes)  # as a PNG's -1: the command line keeps its alpha
        record, sizes, ome = None, {}, bool(tif.is_ome and tif.ome_metadata)
        channel_names: tuple[str, ...] = ()
        time_increment, stated_name = None, None
        imagej = None if ome else tif.imagej_metadata
        if ome:
            ome_xml = tifffile.xml2dict(tif.ome_metadata)["OME"]
            image = _first(ome_xml.get("Image"))
            pixels = (image or {}).get("Pixels", {})
            stated_name = image_name((image or {}).get("Name"))
            for letter in SPATIAL_AXES:
                size = pixels.get(f"PhysicalSize{letter}")
                if size is not None:
                    unit = pixels.get(f"PhysicalSize{letter}Unit", "µm")
                    sizes[letter] = (float(size), unit_name(unit))
            channel_names = complete_names(
                channel.get("Name") if isinstance(channel, dict) else None
                for channel in _all(pixels.get("Channel"))
            )
            if pixels.get("TimeIncrement") is not None:
                unit = time_unit_name(pixels.get("TimeIncrementUnit", "s"))
                time_increment = (float(pixels["TimeIncrement"]), unit)
            annotations = ome_xml.get("StructuredAnnotations", {})
            for comment in _all(annotations.get("CommentAnnotation")):
                if isinstance(comment, dict) and comment.get("Namespace") == KEY:
                    record = read_record(str(comment.get("Value")), path)
        elif imagej is not None:
            sizes = _imagej_pixel_sizes(imagej, _tiff_resolution(page))
            properties = imagej.get("Properties")
            if isinstance(properties, dict):
                record = read_record(properties.get(KEY), path)
        elif tif.shaped_metadata:
            description = tif.shaped_metadata[0]
            record = read_record(description.get(KEY), path)
            for letter, (size, unit) in description.get("pixel_sizes", {}).items():
                sizes[letter] = (float(size), unit)
            names = description.get("channel_names")
            channel_names = complete_names(names if isinstance(names, list) else ())
            time_increment = time_pair(description.get("time_increment"))
            stated_name = image_name(description.get("image_name"))
    tifffile_default = not ome and imagej is None and set(axes) <= set("QSYX")
    return ImageMetadata(
        axes=None if tifffile_default else axes,
        channel_axis=channel_axis,
        colour=colour,
        pixel_sizes=sizes,
        ome=ome,
        provenance=record,
        ambiguous=is_ambiguous(shape, channel_axis, None if tifffile_default else axes),
        grey_alpha=photometric != tifffile.PHOTOMETRIC.RGB
        and len(extra) == 1
        and extra[0] in ALPHA_SAMPLES,
        extra_samples=extra,
        resolution=_tiff_resolution(page),
        icc_profile=icc_profile,
        imagej=imagej is not None,
        channel_names=channel_names,
        time_increment=time_increment,
        image_name=stated_name,
    )


def tiff_layout(path: Path) -> tuple[tuple[int, ...], np.dtype, tuple[int, ...]]:
    """Shape, dtype and chunks of the image in a TIFF file, without reading pixels."""
    import zarr

    with _tiff_file(path) as tif, tif.aszarr(series=0, level=0) as store:
        array = zarr.open(store, mode="r")
        return tuple(array.shape), np.dtype(array.dtype), tuple(array.chunks)


def open_tiff_lazily(
    path: Path,
    shape: tuple[int, ...],
    dtype: np.dtype,
    store_chunks: tuple[int, ...],
    channel_axis: int | None,
):
    """A TIFF file of the layout :func:`tiff_layout` found as a dask array of whole planes,
    read block by block when computed."""
    import dask.array as da

    source = _LazyTiff(path, shape, dtype)
    chunks = block_chunks(shape, store_chunks, dtype, channel_axis)
    meta = np.empty((0,) * len(shape), dtype=dtype)
    return native(da.from_array(source, chunks=chunks, lock=False, meta=meta))


def write_tiff(handle, array: np.ndarray, metadata: ImageMetadata | None) -> None:
    """Write ``array`` with ``metadata`` as a TIFF file into the open file ``handle``."""
    import tifffile

    tifffile.imwrite(handle, array, **tiff_options(array.shape, array.dtype, metadata))


def write_tiff_lazily(path: Path, array, *, overwrite, plane_axes, progress, metadata) -> None:
    """Write a dask array to a TIFF file block by block, atomically (see ``write_array``)."""
    check_writable(path, "TIFF", array, overwrite)
    array = native(array)
    with tiff_being_written(
        path, array.shape, array.dtype, overwrite=overwrite, metadata=metadata
    ) as write:
        run_blocks(array, write, plane_axes=plane_axes, on_client=True, progress=progress)


@contextlib.contextmanager
def tiff_being_written(path: Path, shape, dtype, *, overwrite, metadata):
    """A TIFF file of ``shape`` and ``dtype`` created beside ``path`` with its final size and
    metadata, uncompressed, its pixels contiguous; yields ``write(block, location)``, which
    writes a block of C-contiguous pixels at its place (``location``: a ``(start, stop)``
    per axis); the file takes ``path``'s name once the block ends, and is removed if it
    fails or is interrupted."""
    import tifffile

    shape, dtype = tuple(int(n) for n in shape), np.dtype(dtype)
    made: list[Path] = []
    with published(made, path, overwrite=overwrite):
        temporary, handle = create_temporary(path.parent, path.name, made)
        handle.close()
        offset, _ = tifffile.imwrite(
            temporary,
            shape=shape,
            dtype=dtype,
            returnoffset=True,
            **tiff_options(shape, dtype, metadata),
        )
        with tifffile.TiffFile(temporary) as created:  # the planes must be contiguous
            if created.series[0].dataoffset != offset:
                raise ImageFileError(path, "tifffile did not lay the planes out contiguously")
        fd = os.open(temporary, os.O_RDWR | getattr(os, "O_BINARY", 0))
        try:
            yield functools.partial(_write_contiguous, fd, offset, shape, dtype.itemsize)
            os.fsync(fd)
        finally:
            os.close(fd)


def close_lazy_files() -> None:
    """Close the TIFF files opened for lazy reading in this process, and forget them."""
    _cached_tiff.cache_clear()
    while _OPEN_TIFF_STORES:
        _OPEN_TIFF_STORES.pop().close()


@contextlib.contextmanager
def _tiff_file(path: Path):
    """The TIFF file at ``path`` opened by tifffile, if it holds one intact image read exactly.

    Yields
    ------
    tif : tifffile.TiffFile

    Raises
    ------
    ImageFileError
        If tifffile logs an error while the file is opened or the block
        runs (a broken chain of pages: a truncated or corrupted file, whose
        readable pages tifffile would return as the whole), if the file
        holds more than one series (images of different shapes, or several
        OME images), or if its photometric interpretation is not grey
        (MINISBLACK) or RGB, or is grey of 3 or 4 samples per pixel.
    """
    import tifffile

    with _tifffile_errors(path), tifffile.TiffFile(path) as tif:
        if not tif.series:
            raise ImageFileError(path, "is a TIFF file holding no image")
        if len(tif.series) > 1:
            shapes = ", ".join(str(tuple(series.shape)) for series in tif.series[:4])
            more = ", ..." if len(tif.series) > 4 else ""
            raise ImageFileError(
                path,
                f"holds {len(tif.series)} images (TIFF series) of shapes {shapes}{more}; "
                "only files holding one image are supported: save each image to its own file",
            )
        code = tif.series[0].keyframe.photometric
        try:
            photometric = tifffile.PHOTOMETRIC(code).name
        except ValueError:
            photometric = f"photometric code {int(code)}"
        if photometric not in _TIFF_PHOTOMETRICS:
            reason = _TIFF_PHOTOMETRIC_REFUSALS.get(
                photometric,
                f"{photometric} TIFF (photometric interpretation), which is not supported; "
                "convert it to a MINISBLACK grey or RGB TIFF first",
            )
            raise ImageFileError(path, f"is a {reason}")
        samples = tif.series[0].keyframe.samplesperpixel
        if photometric == "MINISBLACK" and samples in LUMINANCE_CHANNELS:
            raise ImageFileError(
                path,
                f"is a MINISBLACK TIFF of {samples} samples per pixel (grey and "
                f"{samples - 1} extra samples), which would be rendered as the luminance of "
                "RGB(A); save its samples as planes (one page each) or as an RGB TIFF first",
            )
        yield tif


class _ThreadErrors(logging.Handler):
    """Keeps the messages of the error records one thread logs."""

    def __init__(self):
        super().__init__(logging.ERROR)
        self.thread = threading.get_ident()
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.thread == self.thread:
            self.messages.append(record.getMessage())


@contextlib.contextmanager
def _tifffile_errors(path: Path):
    """Raise an ImageFileError for errors tifffile logs in the block (it raises none for them).

    tifffile reads what it can of a file whose chain of pages is broken and
    only logs the break; the error records this thread logs meanwhile are
    collected, and the first is the reason given.
    """
    logger = logging.getLogger("tifffile")
    handler = _ThreadErrors()
    logger.addHandler(handler)
    try:
        yield
    except Exception as exc:
        if handler.messages:  # the cause of what the block found wrong
            raise ImageFileError(path, _corrupted(handler.messages)) from exc
        raise
    finally:
        logger.removeHandler(handler)
    if handler.messages:
        raise ImageFileError(path, _corrupted(handler.messages))


def _corrupted(messages: list[str]) -> str:
    detail = re.sub(r"^<[^>]*>\s*", "", messages[0])  # tifffile's "<tifffile.TiffPages @8> "
    return f"is a corrupted or truncated TIFF file (tifffile: {detail}); get an intact copy"


def _imagej_pixel_sizes(entries: dict, resolution: tuple | None) -> dict:
    """``ImageMetadata.pixel_sizes`` of an ImageJ hyperstack, from its metadata and resolution.

    ImageJ's calibration is one unit (its ``unit``, else the resolution
    unit): X and Y are the inverse of the resolution (pixels per unit), Z
    is the ``spacing``.
    """
    unit = entries.get("unit")
    if unit is None and resolution is not None:
        unit = resolution[2]
    elif unit is not None:
        unit = IMAGEJ_UNITS.get(str(unit).lower(), str(unit))
    sizes = {}
    if resolution is not None:
        sizes["X"] = (1.0 / resolution[0], unit)
        sizes["Y"] = (1.0 / resolution[1], unit)
    if entries.get("spacing") is not None:
        sizes["Z"] = (float(entries["spacing"]), unit)
    return sizes


def _extra_samples(page) -> tuple[str, ...]:
    """The extra samples of a TIFF page by name; those its tags omit are unspecified."""
    import tifffile

    named = tuple(tifffile.EXTRASAMPLE(code).name.lower() for code in page.extrasamples)
    colours = 3 if page.photometric == tifffile.PHOTOMETRIC.RGB else 1
    return named + ("unspecified",) * max(page.samplesperpixel - colours - len(named), 0)


def _tiff_icc_profile(page) -> bytes | None:
    """The ICC profile a TIFF page embeds, or None."""
    tag = page.tags.get(_ICC_PROFILE_TAG)
    return None if tag is None else bytes(tag.value)


def _tiff_resolution(page) -> tuple[float, float, str | None] | None:
    """``ImageMetadata.resolution`` of a TIFF page; None for tifffile's default (1, 1, none)."""
    if "XResolution" not in page.tags:
        return None
    unit = page.resolutionunit.name.lower()
    x, y = page.resolution
    if unit == "none" and (x, y) == (1.0, 1.0):
        return None
    return float(x), float(y), None if unit == "none" else unit


def _first(value: Any) -> Any:
    return value[0] if isinstance(value, list) else value


def _all(value: Any) -> list:
    if value is None:
        return []
    return value if isinstance(value, list) else [value]


class _LazyTiff:
    """The first series of a TIFF file, read on demand (opened once per process).

    Pickles as its path, so that ``dask.distributed`` workers open the file
    themselves.
    """

    def __init__(self, path: Path, shape: tuple[int, ...], dtype: np.dtype):
        self.path = os.path.abspath(path)
        self.shape = tuple(shape)
        self.dtype = np.dtype(dtype)
        stat = os.stat(self.path)
        self.stamp = (stat.st_mtime_ns, stat.st_size)

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __getitem__(self, key):
        return np.asarray(_cached_tiff(self.path, self.stamp)[key])

    def __dask_tokenize__(self):
        return ("napari-labyrinth-tiff", self.path, self.stamp, self.shape, str(self.dtype))


#: The TIFF files :func:`_cached_tiff` opened, closed by :func:`release_files`.
_OPEN_TIFF_STORES: list = []


@functools.lru_cache(maxsize=8)
def _cached_tiff(path: str, stamp: tuple[int, int]):
    import tifffile
    import zarr

    store = tifffile.imread(path, aszarr=True, series=0, level=0)
    _OPEN_TIFF_STORES.append(store)
    return zarr.open(store, mode="r")


def _write_contiguous(fd, offset, shape, itemsize, block, location) -> None:
    """Write a block of a C-ordered array stored from ``offset`` of the file ``fd``."""
    block = np.ascontiguousarray(block)
    ndim = len(shape)
    # the block is contiguous in the file from the first axis on which it is
    # cut, when it spans every axis after that one
    split = ndim
    while split > 0 and block.shape[split - 1] == shape[split - 1]:
        split -= 1
    split = max(split - 1, 0)
    strides = np.cumprod((1,) + tuple(shape[:0:-1]))[::-1]
    starts = [start for start, _ in location]
    for index in np.ndindex(block.shape[:split]):
        first = sum(
            (starts[axis] + (index[axis] if axis < split else 0)) * int(strides[axis])
            for axis in range(ndim)
        )
        _pwrite(fd, memoryview(block[index]).cast("B"), offset + first * itemsize)


def _pwrite(fd: int, data: memoryview, position: int) -> None:
    while data:
        if hasattr(os, "pwrite"):
            written = os.pwrite(fd, data, position)
        else:  # Windows: no pwrite; seek and write under a lock
            with _SEEK_LOCK:
                os.lseek(fd, position, os.SEEK_SET)
                written = os.write(fd, data)
        data = data[written:]
        position += written


_SEEK_LOCK = threading.Lock()
