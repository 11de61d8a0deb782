"""Image files in and out: reading, atomic writing, zarr and TIFF stacks, metadata.

TIFF files go through tifffile (any dtype, any number of dimensions); PNG,
JPEG and BMP through imageio's pillow plugin; zarr stores (``.zarr``
directories) through zarr and dask. Files of any other format (CZI, ND2,
LIF, ...) are read through bioio and its reader plugins, the optional extra
``napari-labyrinth[formats]``, one scene at a time. Writes are atomic: the data go to a
temporary file (or directory) beside the destination, which then takes the
destination's name in one step, so a reader never sees a half-written file
and an error leaves nothing behind.

Images larger than memory stay lazy (dask arrays, see ``open_image``) and
are written block by block (``write_array``): a zarr store with one chunk
per plane, or a TIFF file whose planes are written as they are computed.

What a file says about its pixels is read by ``read_metadata`` (an
:class:`ImageMetadata`): its colour axis (TIFF photometric RGB samples, the
PNG/JPEG colour type), its axes and physical pixel sizes (OME-TIFF through
tifffile's OME-XML support, an ImageJ hyperstack through tifffile's
ImageJ support, OME-Zarr from its ``multiscales`` attributes) and the
provenance record of a rendering. The writers take the same object and
store it back: OME-XML (with the record as a ``CommentAnnotation``), an
ImageJ hyperstack (the record in its ``Properties``) or a JSON description
in a TIFF file, an iTXt chunk in a PNG file, a comment in a JPEG file,
attributes (OME-Zarr ``multiscales`` where the axes allow) in a zarr store.

The functions here choose the format by the path and hand over to one
module per format: :mod:`.tiff` (with :mod:`._tiff_options`, what a TIFF
output stores), :mod:`.pillow` (PNG, JPEG, BMP), :mod:`.zarr` and
:mod:`.bioio_reader` (the other formats, read only);
:mod:`.metadata` holds :class:`ImageMetadata`, :mod:`._formats` which format
a path names and what it can store, :mod:`._atomic` the temporaries of
writes, :mod:`._arrays` byte order and blocks, :mod:`._errors` the error.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._budget import refusal
from ..lazy import computing, is_lazy
from ._arrays import BLOCK_BYTES, plane_count
from ._atomic import create_temporary, published
from ._errors import ImageFileError, reason_of, require_file
from ._formats import (
    BIOIO,
    FORMATS,
    FORMATS_WITHOUT_METADATA,
    LOSSY_FORMATS,
    check_storable,
    check_writable,
    enclosing_zarr_store,
    image_format,
    input_format,
    zarr_root,
)
from ._tiff_options import ome_tiff_ok
from .bioio_reader import (
    FORMATS_EXTRA,
    bioio_in_memory,
    bioio_metadata,
    open_bioio_lazily,
    read_bioio,
)
from .metadata import SPATIAL_AXES, ImageMetadata
from .pillow import pillow_metadata, read_pillow, write_pillow
from .tiff import (
    close_lazy_files,
    open_tiff_lazily,
    read_tiff,
    tiff_layout,
    tiff_metadata,
    write_tiff,
    write_tiff_lazily,
)
from .zarr import (
    forget_stores_written,
    ome_zarr_ok,
    open_zarr_lazily,
    read_zarr,
    write_zarr,
    zarr_metadata,
)

__all__ = [
    # reading and writing
    "read_image",
    "write_image",
    "open_image",
    "write_array",
    "check_output",
    "release_files",
    # what a file says about its pixels
    "read_metadata",
    "read_provenance",
    "ImageMetadata",
    "ome_lost",
    "SPATIAL_AXES",
    # formats and paths
    "image_format",
    "input_format",
    "FORMATS_EXTRA",
    "zarr_root",
    "enclosing_zarr_store",
    "FORMATS",
    "LOSSY_FORMATS",
    "FORMATS_WITHOUT_METADATA",
    # lazy images
    "LAZY_TIFF_BYTES",
    "BLOCK_BYTES",
    "ProgressCallback",
    # errors
    "ImageFileError",
]

#: ``progress(planes_done, planes_total)``, called as the planes are written.
ProgressCallback = Callable[[int, int], Any]


#: A TIFF file holding more than one plane is read lazily (a dask array read
#: plane by plane) when its pixels take more bytes than this; smaller files
#: are read into memory at once.
LAZY_TIFF_BYTES = 1 << 30


def read_image(path: str | os.PathLike, *, scene: int | str | None = None) -> np.ndarray:
    """Read an image file into an array.

    Parameters
    ----------
    path : str or path-like
        A ``.tif``/``.tiff`` file (read with tifffile: every page of its
        one series, any dtype), a ``.png``, ``.jpg``/``.jpeg`` or ``.bmp``
        file (read with imageio's pillow plugin: grey images are 2-D, colour
        images ``(rows, columns, 3 or 4)``; palette images are expanded to
        RGB, a PNG transparency chunk (``tRNS``) becomes an alpha channel:
        RGBA, or grey + alpha; an EXIF orientation is applied, so the
        pixels are upright as viewers show them) or a zarr store (see
        :func:`open_image`), read whole; a file of any other suffix is
        read through bioio (see :func:`read_metadata`).
    scene : int or str, optional
        The scene of a file read through bioio: its index or its name
        (default the first). The files the package reads itself hold one.

    Returns
    -------
    image : ndarray

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ImageFileError
        (a ValueError) naming the file, for a file that cannot be read
        (corrupt, truncated, not an image, a directory, no permission, of a
        format no installed reader reads, or bioio not installed), a scene
        it has not, or one whose pixels would be read wrongly or lossily:
        see :func:`read_metadata`.
    """
    path = Path(path)
    kind = input_format(path)
    if kind == BIOIO:
        return read_bioio(path, scene)
    _refuse_scene(path, scene)
    if kind == "ZARR":
        return read_zarr(path)
    require_file(path)
    try:
        image = read_tiff(path) if kind == "TIFF" else read_pillow(path, kind)
    except ImageFileError:
        raise
    except Exception as exc:  # readers raise many types for a bad file
        reason = reason_of(exc)
        # imageio's and pillow_header's words for "not an image"
        if "can not handle the given uri" in reason or "no header Pillow can read" in reason:
            reason = "not an image pillow can identify (corrupt, or another format)"
        raise ImageFileError(path, f"cannot read {kind} file: {reason}") from exc
    image = np.asarray(image)
    if image.size == 0:
        raise ImageFileError(path, f"the file holds no pixels (shape {image.shape})")
    return image


def write_image(
    path: str | os.PathLike,
    array: np.ndarray,
    *,
    overwrite: bool = False,
    metadata: ImageMetadata | None = None,
) -> Path:
    """Write an array to an image file, atomically.

    Parameters
    ----------
    path : str or path-like
        Destination; its suffix sets the format. TIFF (``.tif``, ``.tiff``)
        stores any dtype and any number of dimensions (a last axis of
        length 3 or 4 is stored as RGB(A) samples). PNG stores uint8 grey,
        grey + alpha, RGB or RGBA images and uint16 grey images; JPEG
        (quality 95, lossy) and BMP store uint8 grey or RGB images.
    array : array_like
        The image.
    overwrite : bool, optional
        Replace an existing file. Without it an existing file is left as it
        is, even if it appears while this call runs.
    metadata : ImageMetadata, optional
        Axes, pixel sizes, colour samples, resolution and provenance record
        to store with the pixels (see :func:`read_metadata`); BMP files
        hold no record. A TIFF file stores the colour samples as they were
        read (photometric RGB or grey, extra samples, samples planar when
        the colour axis is third from last); a PNG, JPEG or BMP file holds
        no extra sample but unassociated alpha, and the others are refused.
        A TIFF file is OME-TIFF or an ImageJ hyperstack when the metadata
        come from one and the format can hold the axes and dtype (see
        ``_tiff_options.tiff_options``), else it has a JSON description.

    Returns
    -------
    path : Path
        The file written.

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False.
    ImageFileError
        (a ValueError) naming the file, for an unknown suffix, a directory,
        or an array (or extra samples) that the format cannot store (it
        suggests ``.tif``).
    OSError
        If writing fails (no space, no permission); no temporary file is
        left behind.

    Notes
    -----
    The data are written to a hidden temporary file in the destination's
    directory, flushed to disk, then renamed over the destination
    (``os.replace``), or hard-linked to it when ``overwrite`` is False so
    that a file created meanwhile is not clobbered.
    """
    path = Path(path)
    kind = image_format(path)
    array = np.asarray(array)
    check_storable(path, kind, array, metadata)
    if path.is_dir():
        raise ImageFileError(path, "is a directory")
    if not overwrite and os.path.lexists(path):
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)")
    made: list[Path] = []
    with published(made, path, overwrite=overwrite):
        _, handle = create_temporary(path.parent, path.name, made)
        with handle:
            _write(handle, kind, path.suffix.lower(), array, metadata)
            handle.flush()
            os.fsync(handle.fileno())
    return path


def open_image(
    path: str | os.PathLike,
    *,
    lazy: bool | None = None,
    channel_axis: int | None = None,
    scene: int | str | None = None,
):
    """Open an image file, into memory or lazily as a dask array.

    Parameters
    ----------
    path : str or path-like
        An image file (see :func:`read_image`) or a zarr store: a ``.zarr``
        directory holding an array, an OME-Zarr image (its full-resolution
        level is read) or a group of one array; ``store.zarr/name`` names an
        array of a group.
    lazy : bool, optional
        None (default): zarr stores are opened lazily, TIFF files and files
        read through bioio lazily when they hold more than one plane and more
        than ``LAZY_TIFF_BYTES`` bytes of pixels (or more than the run may
        hold), everything else is read into memory. True: zarr stores, TIFF
        files and files read through bioio lazily (bioio's dask array). False: everything into memory. PNG, JPEG and
        BMP files (one image each) are always read into memory.
    channel_axis : int, optional
        The colour axis, kept whole in each block of a lazy array.
    scene : int or str, optional
        The scene of a file read through bioio (see :func:`read_image`).

    Returns
    -------
    image : ndarray or dask array
        A dask array is cut into blocks of whole planes (the two spatial
        axes and the colour axis whole), as many planes as a chunk of the
        store holds along the stack axes (so each chunk is read once) up to
        ``BLOCK_BYTES``. Nothing is read until it is computed, and then only
        block by block: files are opened by path in each process that
        computes (a ``dask.distributed`` worker must see the same path).

    Raises
    ------
    FileNotFoundError
        If the file or store does not exist.
    ImageFileError
        (a ValueError) naming the file, if it cannot be read.
    """
    path = Path(path)
    kind = input_format(path)
    if kind == BIOIO:
        data = open_bioio_lazily(path, scene, channel_axis)
        planes = int(np.prod(data.shape[:-2]))
        large = data.nbytes > LAZY_TIFF_BYTES or refusal(data.shape, data.dtype)
        if lazy is False or (lazy is None and not (planes > 1 and large)):
            return bioio_in_memory(path, data)
        return data
    _refuse_scene(path, scene)
    if kind == "ZARR":
        return read_zarr(path) if lazy is False else open_zarr_lazily(path, channel_axis)
    if kind != "TIFF" or lazy is False:
        return read_image(path)
    require_file(path)
    try:
        shape, dtype, store_chunks = tiff_layout(path)
    except ImageFileError:
        raise
    except Exception as exc:  # tifffile raises many types for a bad file
        raise ImageFileError(path, f"cannot read TIFF file: {reason_of(exc)}") from exc
    if 0 in shape:
        raise ImageFileError(path, f"the file holds no pixels (shape {shape})")
    planes = int(np.prod(shape[:-2]))
    large = np.prod(shape) * dtype.itemsize > LAZY_TIFF_BYTES or refusal(shape, dtype)
    if lazy is None and not (planes > 1 and large):
        return read_image(path)
    return open_tiff_lazily(path, shape, dtype, store_chunks, channel_axis)


def write_array(
    path: str | os.PathLike,
    array,
    *,
    overwrite: bool = False,
    plane_axes: Sequence[int] = (-2, -1),
    progress: ProgressCallback | None = None,
    metadata: ImageMetadata | None = None,
) -> Path:
    """Write an in-memory or lazy (dask) array to an image file or zarr store, atomically.

    Parameters
    ----------
    path : str or path-like
        Destination: a ``.zarr`` directory or an image file (see
        :func:`write_image`).
    array : ndarray or dask array
        The image. A dask array is computed block by block and never held
        whole: into a zarr store by the tasks themselves (by the workers of
        a ``dask.distributed`` cluster, which must see ``path``), into a
        TIFF file plane by plane as the blocks arrive; a PNG, JPEG or BMP
        file holds one image and is computed at once.
    overwrite : bool, optional
        Replace an existing file or zarr store (never a directory that is
        not a zarr store). Without it an existing one is left as it is.
    plane_axes : sequence of int, optional
        The axes of one plane (the two spatial axes, and the colour axis if
        any): a zarr store gets one chunk per plane.
    progress : callable, optional
        ``progress(planes_done, planes_total)`` as planes are written.
    metadata : ImageMetadata, optional
        Axes, pixel sizes and provenance record stored with the pixels: as
        for :func:`write_image`; a zarr store keeps them in its attributes,
        as an OME-Zarr image when the metadata come from OME and the axes
        fit OME-Zarr's rules. An OME-Zarr image has lower resolution levels
        too, halved in Y and X by a local mean, when ome-zarr is installed
        (see ``io._pyramid``); a lazy one gets them once its full level is
        written, read back plane by plane.

    Returns
    -------
    path : Path

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False.
    ImageFileError
        (a ValueError) naming the file, for an array the format cannot store.
    OSError
        If writing fails; nothing is left behind.

    Notes
    -----
    A zarr store is written to a hidden directory beside ``path`` and
    renamed to it (without replacing anything that appeared meanwhile); with
    ``overwrite`` the old store is moved aside, the new one renamed into
    place and the old one removed. A lazy TIFF file is created with its
    final size and metadata, as :func:`write_image` would write them
    (uncompressed, planes contiguous; BigTIFF when it needs more than 4 GB,
    except an ImageJ hyperstack, which tifffile then writes as ImageJ does:
    a classic TIFF with the first page's tags only) and each block's planes
    are written at their place.
    """
    path = Path(path)
    kind = image_format(path)
    if kind == "ZARR":
        return write_zarr(
            path,
            array,
            overwrite=overwrite,
            plane_axes=plane_axes,
            progress=progress,
            metadata=metadata,
        )
    if not is_lazy(array):
        write_image(path, array, overwrite=overwrite, metadata=metadata)
    elif kind == "TIFF":
        write_tiff_lazily(
            path,
            array,
            overwrite=overwrite,
            plane_axes=plane_axes,
            progress=progress,
            metadata=metadata,
        )
    else:
        check_writable(path, kind, array, overwrite, metadata)
        with computing():
            computed = np.asarray(array.compute())
        write_image(path, computed, overwrite=overwrite, metadata=metadata)
    if progress is not None:
        total = plane_count(array.shape, plane_axes)
        progress(total, total)
    return path


def check_output(
    path: str | os.PathLike,
    shape: Sequence[int],
    dtype: Any,
    *,
    overwrite: bool,
    metadata: ImageMetadata | None = None,
) -> None:
    """Raise as :func:`write_array` would for an array of ``shape`` and ``dtype``, before it
    is made: a rendering that its output cannot take is refused before it runs.

    Raises
    ------
    ImageFileError
        For a format that cannot store such an array (or its extra samples),
        or a directory at ``path`` (but a zarr store: its writer decides).
    FileExistsError
        If a file is at ``path`` (not a zarr store) and ``overwrite`` is False.
    PermissionError
        If ``path``'s directory exists and takes no new file (no permission,
        a read-only file system): an ``OSError`` of ``path``, as the writer's.
    """
    path = Path(path)
    kind = image_format(path)
    placeholder = np.broadcast_to(np.zeros((), dtype), tuple(shape))  # no memory
    if kind == "ZARR":  # a directory: the store's writer has its own rules for one there
        check_storable(path, kind, placeholder, metadata)
    else:
        check_writable(path, kind, placeholder, overwrite, metadata)
    parent = path.parent
    if parent.is_dir() and not os.access(parent, os.W_OK):
        raise PermissionError(
            errno.EACCES,
            "its directory takes no new file (no permission, or a read-only file system)",
            str(path),
        )


def read_metadata(path: str | os.PathLike, *, scene: int | str | None = None) -> ImageMetadata:
    """What an image file or zarr store says about its pixels, without reading them.

    - TIFF (tifffile): the axes of its series; its ``S`` axis (samples
      per pixel, contiguous or planar) is the colour axis: RGB and extra
      samples, or grey and extra samples (grey + alpha when the one extra
      sample is alpha); OME-TIFF axes and ``PhysicalSizeX/Y/Z``; the
      resolution tags; the provenance record (an OME ``CommentAnnotation``
      of namespace ``napari_labyrinth``, or the JSON description tifffile
      writes). An ImageJ hyperstack (tifffile's ``imagej_metadata``): the
      X and Y pixel sizes are the inverse of its resolution, Z its
      ``spacing``, all in its ``unit``; the record is the ``napari_labyrinth``
      entry of its ``Properties``. A JSON description gives back the axes
      and pixel sizes a fallback stored in it (see ``_tiff_options.tiff_options``).
    - PNG, JPEG, BMP (Pillow): the colour type (``RGB``, ``RGBA``, grey +
      alpha, palette: colour axis -1; grey: none; a PNG transparency chunk
      makes an RGB or palette image RGBA and a grey one grey + alpha); the
      resolution in dots per inch; an EXIF orientation, applied when the
      pixels are read (said in ``colour``; the resolution follows it); the
      record in a PNG text chunk or a JPEG comment.
    - zarr: OME-Zarr ``multiscales`` axes and scale of the full-resolution
      level; the record in the attributes (of the group, or of the array).
    - Any other suffix (CZI, ND2, LIF, ...), through bioio and the reader
      plugin of the format (``pip install "napari-labyrinth[formats]"``):
      one scene (``scene``: its index or name, default the first); its
      dimensions in bioio's order (``TCZYX``, ``S`` for RGB samples, the
      colour axis) without those of length 1; its physical pixel sizes in
      micrometres; its channel names; its OME image name or scene name.
      Marked ``ome``: an output is OME-TIFF or OME-Zarr where OME holds it.

    A plain TIFF or zarr array whose last axis has 3 or 4 entries and no
    colour metadata is marked ``ambiguous`` (it is read as planes).

    Files whose pixels would be read wrongly or lossily are refused (here
    and by :func:`read_image`), each with what to convert it to: CMYK
    images; 16-bit PNGs other than plain grey (Pillow reads them as 8
    bits); TIFF files that are not MINISBLACK grey or RGB (MINISWHITE,
    palette, CMYK...), grey ones of 3 or 4 samples per pixel (which would
    be rendered as RGB), that hold more than one series (images of several
    shapes, several OME images), or whose chain of pages is broken (a
    truncated file, of which tifffile would read only the first pages).

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ImageFileError
        (a ValueError) naming the file, if it cannot be read or is refused.
    """
    path = Path(path)
    kind = input_format(path)
    if kind == BIOIO:
        return bioio_metadata(path, scene)
    _refuse_scene(path, scene)
    if kind == "ZARR":
        return zarr_metadata(path)
    require_file(path)
    try:
        if kind == "TIFF":
            return tiff_metadata(path)
        return pillow_metadata(path, kind)
    except ImageFileError:
        raise
    except Exception as exc:  # readers raise many types for a bad file
        raise ImageFileError(path, f"cannot read {kind} metadata: {reason_of(exc)}") from exc


def read_provenance(path: str | os.PathLike) -> dict:
    """The provenance record stored in an output of napari-labyrinth.

    Raises
    ------
    ImageFileError
        (a ValueError) if the file holds no record.
    """
    record = read_metadata(path).provenance
    if record is None:
        raise ImageFileError(path, "holds no napari-labyrinth provenance record")
    return record


def ome_lost(path: str | os.PathLike, shape: Sequence[int], metadata: ImageMetadata) -> str | None:
    """Why an output at ``path`` of ``shape`` cannot be OME as its input was, or None.

    A TIFF or zarr output of an OME input is OME where OME can hold its axes;
    otherwise it keeps the axes, pixel sizes, channel names and time
    increment in this package's own description (which it reads back, and
    other readers do not).
    """
    if not (metadata.ome and metadata.axes):
        return None
    kind = image_format(path)
    if kind == "TIFF" and not ome_tiff_ok(metadata, shape):
        holds = "OME-TIFF"
    elif kind == "ZARR" and not (len(metadata.axes) == len(shape) and ome_zarr_ok(metadata.axes)):
        holds = "OME-Zarr (2 to 5 axes: [time] [channel or another] then 2 or 3 of space)"
    else:
        return None
    return (
        f"{holds} cannot hold the axes {metadata.axes}: written with them in this package's "
        "own description instead (read back by napari-labyrinth, not by other OME readers)"
    )


def release_files() -> None:
    """Close the TIFF files opened for lazy reading in this process, and forget those and
    the stores opened for writing."""
    close_lazy_files()
    forget_stores_written()


def _refuse_scene(path: Path, scene: int | str | None) -> None:
    """Refuse a scene other than the first of a file the package reads itself (one image)."""
    if scene is not None and str(scene) != "0":
        raise ImageFileError(
            path,
            f"holds one image, not scenes: scene {scene!r} applies to files read through "
            "bioio (CZI, ND2, LIF, ...)",
        )


def _write(
    handle, kind: str, suffix: str, array: np.ndarray, metadata: ImageMetadata | None
) -> None:
    """Write ``array`` with ``metadata`` in the format ``kind`` into the open file ``handle``."""
    if kind == "TIFF":
        write_tiff(handle, array, metadata)
    else:
        write_pillow(handle, kind, suffix, array, metadata)
