"""Image files in and out: reading, atomic writing, zarr and TIFF stacks.

TIFF files go through tifffile (any dtype, any number of dimensions); PNG,
JPEG and BMP through imageio's pillow plugin; zarr stores (``.zarr``
directories) through zarr and dask. Writes are atomic: the data go to a
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
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import errno
import functools
import logging
import os
import re
import shutil
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._budget import declared_refusal, pillow_header, refusal
from ._atomic import remove_stale_temporaries, temporary_name

#: Lower-case file suffix -> format name.
FORMATS = {
    ".tif": "TIFF",
    ".tiff": "TIFF",
    ".png": "PNG",
    ".jpg": "JPEG",
    ".jpeg": "JPEG",
    ".bmp": "BMP",
    ".zarr": "ZARR",
}

#: Formats that lose information when written: an output in one of them
#: needs the caller's consent (the command line's ``--lossy``).
LOSSY_FORMATS = ("JPEG",)

#: Formats that hold no provenance record when written.
FORMATS_WITHOUT_METADATA = ("BMP",)

#: A TIFF file holding more than one plane is read lazily (a dask array read
#: plane by plane) when its pixels take more bytes than this; smaller files
#: are read into memory at once.
LAZY_TIFF_BYTES = 1 << 30

#: Upper bound on the bytes of the block a lazily read image is cut into:
#: whole planes, as many as the store's chunks hold along the stack axes
#: (so each chunk is read once), but no more than fit in this.
BLOCK_BYTES = 256 << 20

ProgressCallback = Callable[[int, int], Any]


class ImageFileError(ValueError):
    """An image file that cannot be read, or an array that cannot be stored.

    ``str(error)`` is ``"<path>: <reason>"``; ``reason`` alone is also kept.
    """

    def __init__(self, path: str | os.PathLike, reason: str):
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")


def image_format(path: str | os.PathLike) -> str:
    """Format name (``"TIFF"``, ``"PNG"``, ``"JPEG"``, ``"BMP"`` or ``"ZARR"``) of a path.

    The suffix decides, except that a path inside a ``.zarr`` directory
    (``stack.zarr/0``: an array of a zarr group) is ``"ZARR"``.

    Raises
    ------
    ImageFileError
        (a ValueError) if the suffix is not one of ``FORMATS``.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS and zarr_root(path) is not None:
        return "ZARR"
    try:
        return FORMATS[suffix]
    except KeyError:
        known = ", ".join(FORMATS)
        what = f"unknown image format {suffix!r}" if suffix else "no file suffix"
        raise ImageFileError(path, f"{what}; use one of {known}") from None


def read_image(path: str | os.PathLike) -> np.ndarray:
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
        :func:`open_image`), read whole.

    Returns
    -------
    image : ndarray

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ImageFileError
        (a ValueError) naming the file, for an unknown suffix, a file that
        cannot be read (corrupt, truncated, not an image, a directory, no
        permission), or one whose pixels would be read wrongly or lossily:
        see :func:`read_metadata`.
    """
    path = Path(path)
    kind = image_format(path)
    if kind == "ZARR":
        array = _open_zarr_array(path)
        _refuse_unaffordable(path, refusal(array.shape, array.dtype))
        image = np.asarray(array[...])
        return _native(image)
    _require_file(path)
    try:
        if kind == "TIFF":
            with _tiff_file(path) as tif:
                series = tif.series[0]  # what the header declares, from the file open here
                _refuse_unaffordable(path, refusal(series.shape, series.dtype))
                image = tif.asarray()
        else:
            import imageio.v3 as iio

            _refuse_unaffordable(path, declared_refusal(path, kind))
            with pillow_header(path) as header:
                mode, from_transparency = _pillow_mode(path, kind, header)
            # imageio's own conversions otherwise (palette to RGB, PNG "I" to uint16)
            image = iio.imread(
                path, plugin="pillow", mode=mode if from_transparency else None, rotate=True
            )
    except ImageFileError:
        raise
    except Exception as exc:  # readers raise many types for a bad file
        reason = _reason(exc)
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
        :func:`_tiff_options`), else it has a JSON description.

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
    _check_storable(path, kind, array, metadata)
    if path.is_dir():
        raise ImageFileError(path, "is a directory")
    if not overwrite and os.path.lexists(path):
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)")
    made: list[Path] = []
    with _published(made, path, overwrite=overwrite):
        _, handle = _create_temporary(path.parent, path.name, made)
        with handle:
            _write(handle, kind, path.suffix.lower(), array, metadata)
            handle.flush()
            os.fsync(handle.fileno())
    return path


@contextlib.contextmanager
def _published(made: list[Path], path: Path, *, overwrite: bool):
    """Move the temporary file the block makes (:func:`_create_temporary`, into ``made``) to
    ``path`` once the block has written it; remove it on failure.

    The temporary is made inside the block, so that an interruption at any
    moment after it exists (Ctrl-C, SIGTERM) removes it. ``os.replace``
    with ``overwrite``; otherwise a hard link that refuses to clobber a file
    created in the meantime.
    """
    try:
        yield
        if overwrite:
            os.replace(made[-1], path)
        else:
            _link_no_clobber(made[-1], path)
    except BaseException:
        for temporary in made:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(temporary)
        raise


def _refuse_unaffordable(path: Path, reason: str | None) -> None:
    """Refuse, before reading, an image that needs more memory than the run may use."""
    if reason is not None:
        raise ImageFileError(path, reason)


def _require_file(path: Path) -> None:
    """Raise a clear error unless ``path`` is an existing file."""
    if not path.exists():
        raise FileNotFoundError(errno.ENOENT, "no such file", str(path))
    if path.is_dir():
        raise ImageFileError(path, "is a directory, not an image file")


def _reason(exc: BaseException) -> str:
    """One line describing an exception, without a traceback."""
    if isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


def _check_storable(
    path: Path, kind: str, array: Any, metadata: ImageMetadata | None = None
) -> None:
    if array.size == 0:
        raise ImageFileError(path, f"cannot write an empty image (shape {array.shape})")
    if kind in ("TIFF", "ZARR"):
        if array.dtype.kind not in "biuf" and array.dtype.kind != "c":
            raise ImageFileError(path, f"{kind} cannot store {array.dtype} data")
        return
    if metadata is not None and metadata.ambiguous and metadata.channel_axis is None:
        if array.ndim == 3:  # read as planes: the format would show them as one colour image
            planes, rows, columns = array.shape
            raise ImageFileError(
                path,
                f"cannot store {planes} planes of {rows}x{columns} pixels as {kind} (the "
                f"input's last axis was read as planes); use a .tif or .zarr file, or read "
                f"that axis as colour (channel_axis=-1, --channel-axis -1)",
            )
    extra = () if metadata is None else metadata.extra_samples
    if any(sample != "unassalpha" for sample in extra):
        raise ImageFileError(
            path,
            f"cannot store the extra samples {', '.join(extra)} of the input as {kind} "
            f"({kind} holds only unassociated alpha); use a .tif file",
        )
    grey = array.ndim == 2
    channels = array.shape[-1] if array.ndim == 3 else None
    if kind == "PNG":
        ok = (array.dtype == np.uint8 and (grey or channels in (2, 3, 4))) or (
            array.dtype == np.uint16 and grey
        )
        holds = "uint8 grey, grey+alpha, RGB or RGBA images, or uint16 grey images"
    else:  # JPEG, BMP
        ok = array.dtype == np.uint8 and (grey or channels == 3)
        holds = "uint8 grey or RGB images"
    if not ok:
        raise ImageFileError(
            path,
            f"cannot store {array.dtype} data of shape {array.shape} as {kind} "
            f"({kind} holds {holds}); use a .tif file",
        )


def _create_temporary(directory: Path, name: str, made: list[Path]):
    """A new hidden file beside the destination, opened for binary writing.

    Its path is put in ``made`` before it is created: an interruption handled
    as the file is made (Python runs signal handlers as a call returns)
    leaves the caller a path to remove.
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    remove_stale_temporaries(directory, name)
    while True:
        temporary = directory / temporary_name(name)
        made.append(temporary)
        try:
            fd = os.open(temporary, flags, 0o666)  # the umask applies, unlike mkstemp
        except FileExistsError:
            made.pop()  # not made here
            continue
        os.close(fd)
        # Opened again by name: writers such as tifffile want a named file.
        return temporary, open(temporary, "wb")


def _write(
    handle, kind: str, suffix: str, array: np.ndarray, metadata: ImageMetadata | None
) -> None:
    if kind == "TIFF":
        import tifffile

        tifffile.imwrite(handle, array, **_tiff_options(array.shape, array.dtype, metadata))
        return
    import imageio.v3 as iio

    options: dict[str, Any] = {"quality": 95} if kind == "JPEG" else {}
    resolution = None if metadata is None else metadata.resolution
    if resolution is not None and resolution[2] is not None:  # Pillow writes dots per inch
        per_inch = _PER_INCH[resolution[2]]
        options["dpi"] = (resolution[0] * per_inch, resolution[1] * per_inch)
    if metadata is not None and metadata.icc_profile is not None and kind in ("PNG", "JPEG"):
        options["icc_profile"] = metadata.icc_profile
    record = metadata.provenance if metadata is not None else None
    if record is not None and kind == "PNG":
        from PIL.PngImagePlugin import PngInfo

        from ..provenance import KEY, to_json

        options["pnginfo"] = PngInfo()
        options["pnginfo"].add_itxt(KEY, to_json(record))
    elif record is not None and kind == "JPEG":
        from ..provenance import to_json

        options["comment"] = to_json(record).encode()
    iio.imwrite(handle, np.ascontiguousarray(array), plugin="pillow", extension=suffix, **options)


def _link_no_clobber(temporary: Path, path: Path) -> None:
    """Give ``temporary`` the name ``path`` unless ``path`` exists; remove ``temporary``."""
    try:
        os.link(temporary, path)
    except FileExistsError:
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)") from None
    except OSError:
        # No hard links on this file system: check, then rename (a small window).
        if os.path.lexists(path):
            raise FileExistsError(f"{path} already exists (use overwrite to replace it)") from None
        os.replace(temporary, path)
        return
    os.unlink(temporary)


# -- lazy images: zarr stores and large TIFF files ------------------------------------------------


def enclosing_zarr_store(path: str | os.PathLike) -> Path | None:
    """The nearest existing zarr store (a directory holding zarr metadata) that holds
    ``path`` below it, or None."""
    for parent in Path(path).parents:
        if _is_zarr_store(parent):
            return parent
    return None


def zarr_root(path: str | os.PathLike) -> tuple[Path, str] | None:
    """``(store, component)`` of a path in a ``.zarr`` directory, or None.

    ``a.zarr`` gives ``(a.zarr, "")``, ``a.zarr/0`` and ``a.zarr/0/`` give
    ``(a.zarr, "0")``.
    """
    parts = Path(path).parts
    for index in range(len(parts) - 1, -1, -1):
        name = parts[index]
        if name.lower().endswith(".zarr") and len(name) > len(".zarr"):
            return Path(*parts[: index + 1]), "/".join(parts[index + 1 :])
    return None


def open_image(
    path: str | os.PathLike, *, lazy: bool | None = None, channel_axis: int | None = None
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
        None (default): zarr stores are opened lazily, TIFF files lazily when
        they hold more than one plane and more than ``LAZY_TIFF_BYTES`` bytes
        of pixels, everything else is read into memory. True: zarr stores
        and TIFF files lazily. False: everything into memory. PNG, JPEG and
        BMP files (one image each) are always read into memory.
    channel_axis : int, optional
        The colour axis, kept whole in each block of a lazy array.

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
    kind = image_format(path)
    if kind == "ZARR":
        array = _open_zarr_array(path)
        if lazy is False:
            _refuse_unaffordable(path, refusal(array.shape, array.dtype))
            return _native(np.asarray(array[...]))
        import dask.array as da

        chunks = _block_chunks(array.shape, array.chunks, array.dtype, channel_axis)
        return _native(da.from_zarr(array, chunks=chunks))
    if kind != "TIFF" or lazy is False:
        return read_image(path)
    _require_file(path)
    try:
        shape, dtype, store_chunks = _tiff_layout(path)
    except ImageFileError:
        raise
    except Exception as exc:  # tifffile raises many types for a bad file
        raise ImageFileError(path, f"cannot read TIFF file: {_reason(exc)}") from exc
    if 0 in shape:
        raise ImageFileError(path, f"the file holds no pixels (shape {shape})")
    planes = int(np.prod(shape[:-2]))
    large = np.prod(shape) * dtype.itemsize > LAZY_TIFF_BYTES or refusal(shape, dtype)
    if lazy is None and not (planes > 1 and large):
        return read_image(path)
    import dask.array as da

    source = _LazyTiff(path, shape, dtype)
    chunks = _block_chunks(shape, store_chunks, dtype, channel_axis)
    meta = np.empty((0,) * len(shape), dtype=dtype)
    return _native(da.from_array(source, chunks=chunks, lock=False, meta=meta))


def _native(image):
    """The image with its dtype in the machine's byte order (the API's dtypes are native)."""
    if image.dtype.isnative:
        return image
    return image.astype(image.dtype.newbyteorder("="))


def _block_chunks(
    shape: tuple[int, ...],
    store_chunks: tuple[int, ...],
    dtype: np.dtype,
    channel_axis: int | None,
) -> tuple[int, ...]:
    """dask chunks of whole planes, following the store's chunks along the stack axes."""
    ndim = len(shape)
    whole = set()
    if ndim >= 2:
        axes = [
            axis for axis in range(ndim) if channel_axis is None or axis != channel_axis % ndim
        ]
        whole = set(axes[-2:])
        if channel_axis is not None and ndim >= 3:
            whole.add(channel_axis % ndim)
    plane_bytes = int(np.prod([shape[axis] for axis in whole])) * np.dtype(dtype).itemsize
    room = max(1, BLOCK_BYTES // max(plane_bytes, 1))
    chunks = list(shape)
    for axis in reversed(range(ndim)):
        if axis in whole:
            continue
        size = max(1, min(int(store_chunks[axis]), shape[axis], room))
        chunks[axis] = size
        room = max(1, room // size)
    return tuple(chunks)


def _open_zarr_array(path: Path):
    """The zarr array at ``path``: a store, an OME-Zarr image, a group of one array."""
    root, component = zarr_root(path)
    if not root.exists():
        raise FileNotFoundError(errno.ENOENT, "no such file or directory", str(root))
    try:
        import zarr
    except ImportError:
        raise ImageFileError(
            path, "reading zarr needs zarr and dask: pip install 'napari-labyrinth[dask]'"
        ) from None
    try:
        node = zarr.open(store=os.path.abspath(root), mode="r", path=component or None)
    except Exception as exc:  # zarr raises many types for what is not a store
        raise ImageFileError(path, f"cannot read zarr store: {_reason(exc)}") from exc
    if isinstance(node, zarr.Group):
        node = _array_of_group(path, node)
    if node.size == 0:
        raise ImageFileError(path, f"the store holds no pixels (shape {node.shape})")
    return node


def _array_of_group(path: Path, group):
    attributes = dict(group.attrs)
    multiscales = attributes.get("multiscales") or attributes.get("ome", {}).get("multiscales")
    if multiscales:
        try:
            return group[multiscales[0]["datasets"][0]["path"]]
        except (KeyError, IndexError, TypeError) as exc:
            raise ImageFileError(path, f"bad OME-Zarr multiscales metadata: {exc}") from None
    arrays = sorted(group.array_keys())
    if len(arrays) == 1:
        return group[arrays[0]]
    if not arrays:
        groups = sorted(group.group_keys())
        if groups:  # a bioformats2raw layout: its images are groups 0, 1, ...
            shown = ", ".join(groups[:5]) + (", ..." if len(groups) > 5 else "")
            raise ImageFileError(
                path,
                f"is a zarr group of groups ({shown}), no array; name one: {path / groups[0]}",
            )
        raise ImageFileError(path, "is a zarr group without arrays")
    shown = ", ".join(arrays[:5]) + (", ..." if len(arrays) > 5 else "")
    raise ImageFileError(
        path, f"is a zarr group of {len(arrays)} arrays ({shown}); name one: {path / arrays[0]}"
    )


def _tiff_layout(path: Path) -> tuple[tuple[int, ...], np.dtype, tuple[int, ...]]:
    """Shape, dtype and chunks of the image in a TIFF file, without reading pixels."""
    import zarr

    with _tiff_file(path) as tif, tif.aszarr(series=0, level=0) as store:
        array = zarr.open(store, mode="r")
        return tuple(array.shape), np.dtype(array.dtype), tuple(array.chunks)


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


@functools.lru_cache(maxsize=8)
def _cached_zarr_for_writing(path: str):
    import zarr

    return zarr.open_array(store=path, mode="r+")


def release_files() -> None:
    """Close the TIFF files opened for lazy reading in this process, and forget those and
    the stores opened for writing."""
    _cached_tiff.cache_clear()
    while _OPEN_TIFF_STORES:
        _OPEN_TIFF_STORES.pop().close()
    _cached_zarr_for_writing.cache_clear()


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
        fit OME-Zarr's rules.

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
        return _write_zarr(
            path,
            array,
            overwrite=overwrite,
            plane_axes=plane_axes,
            progress=progress,
            metadata=metadata,
        )
    from ..lazy import is_lazy

    if not is_lazy(array):
        write_image(path, array, overwrite=overwrite, metadata=metadata)
    elif kind == "TIFF":
        _write_tiff_lazily(
            path,
            array,
            overwrite=overwrite,
            plane_axes=plane_axes,
            progress=progress,
            metadata=metadata,
        )
    else:
        from ..lazy import computing

        _check_writable(path, kind, array, overwrite, metadata)
        with computing():
            computed = np.asarray(array.compute())
        write_image(path, computed, overwrite=overwrite, metadata=metadata)
    if progress is not None:
        total = _planes(array.shape, plane_axes)
        progress(total, total)
    return path


def _planes(shape: tuple[int, ...], plane_axes: Sequence[int]) -> int:
    axes = {axis % len(shape) for axis in plane_axes}
    return int(np.prod([size for axis, size in enumerate(shape) if axis not in axes]))


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
        a directory at ``path`` (but a zarr store: its writer decides), or an
        existing directory it cannot write into (no permission, a read-only
        file system).
    FileExistsError
        If a file is at ``path`` (not a zarr store) and ``overwrite`` is False.
    """
    path = Path(path)
    kind = image_format(path)
    placeholder = np.broadcast_to(np.zeros((), dtype), tuple(shape))  # no memory
    if kind == "ZARR":  # a directory: the store's writer has its own rules for one there
        _check_storable(path, kind, placeholder, metadata)
    else:
        _check_writable(path, kind, placeholder, overwrite, metadata)
    parent = path.parent
    if parent.is_dir() and not os.access(parent, os.W_OK):
        raise ImageFileError(
            path,
            f"cannot write {path}: its directory takes no new file (no permission, or a "
            "read-only file system)",
        )


def _check_writable(
    path: Path, kind: str, array: Any, overwrite: bool, metadata: ImageMetadata | None = None
) -> None:
    _check_storable(path, kind, array, metadata)
    if path.is_dir():
        raise ImageFileError(path, "is a directory")
    if not overwrite and os.path.lexists(path):
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)")


def _write_tiff_lazily(path: Path, array, *, overwrite, plane_axes, progress, metadata) -> None:
    import tifffile

    from ..lazy import run_blocks

    _check_writable(path, "TIFF", array, overwrite)
    array = _native(array)
    made: list[Path] = []
    with _published(made, path, overwrite=overwrite):
        temporary, handle = _create_temporary(path.parent, path.name, made)
        handle.close()
        offset, _ = tifffile.imwrite(
            temporary,
            shape=array.shape,
            dtype=array.dtype,
            returnoffset=True,
            **_tiff_options(array.shape, array.dtype, metadata),
        )
        with tifffile.TiffFile(temporary) as created:  # the planes must be contiguous
            if created.series[0].dataoffset != offset:
                raise ImageFileError(path, "tifffile did not lay the planes out contiguously")
        fd = os.open(temporary, os.O_RDWR | getattr(os, "O_BINARY", 0))
        try:
            write = functools.partial(
                _write_contiguous, fd, offset, tuple(array.shape), array.dtype.itemsize
            )
            run_blocks(array, write, plane_axes=plane_axes, on_client=True, progress=progress)
            os.fsync(fd)
        finally:
            os.close(fd)


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


def _write_zarr(path: Path, array, *, overwrite, plane_axes, progress, metadata) -> Path:
    from ..lazy import is_lazy, run_blocks

    if zarr_root(path) != (path, ""):
        raise ImageFileError(path, "a zarr output is a path ending in .zarr, not inside one")
    _check_storable(path, "ZARR", array)
    if os.path.lexists(path):
        if not overwrite:
            raise FileExistsError(f"{path} already exists (use overwrite to replace it)")
        if not _is_zarr_store(path):
            raise ImageFileError(path, "exists and is not a zarr store; not replacing it")
    try:
        import zarr
    except ImportError:
        raise ImageFileError(
            path, "writing zarr needs zarr and dask: pip install 'napari-labyrinth[dask]'"
        ) from None
    axes = {axis % array.ndim for axis in plane_axes}
    chunks = tuple(size if axis in axes else 1 for axis, size in enumerate(array.shape))
    array = _native(array)
    made: list[Path] = []
    try:
        temporary = _create_temporary_directory(path.parent, path.name, made)
        lazy = is_lazy(array)
        store = _waited_for(
            _create_zarr_array,
            zarr,
            os.path.abspath(temporary),
            array,
            chunks,
            metadata,
            None if lazy else np.asarray(array),
        )
        if lazy:
            array = array.rechunk({axis: -1 for axis in axes})  # no-op for rendered arrays
            write = functools.partial(_write_zarr_block, store)
            run_blocks(array, write, plane_axes=tuple(axes), progress=progress)
        elif progress is not None:
            total = _planes(array.shape, plane_axes)
            progress(total, total)
        _publish_directory(temporary, path, overwrite=overwrite)
    except BaseException:
        for temporary in made:
            shutil.rmtree(temporary, ignore_errors=True)
        raise
    finally:
        _cached_zarr_for_writing.cache_clear()
    return path


def _create_zarr_array(zarr, directory: str, array, chunks, metadata, values) -> str:
    """Create the zarr array ``array`` will be written to in ``directory``, and its path.

    With its attributes (an OME-Zarr image is a group holding the array), and
    filled with ``values`` unless they are None.
    """
    store = directory
    attributes, component = _zarr_attributes(array.shape, metadata)
    if component:
        group = zarr.open_group(store=store, mode="w")
        group.attrs.update(attributes)
        store = os.path.join(store, component)
    target = zarr.create_array(
        store=store, shape=array.shape, chunks=chunks, dtype=array.dtype, fill_value=0
    )
    if not component:
        target.attrs.update(attributes)
    if values is not None:
        target[...] = values
    return store


def _waited_for(function, *args):
    """``function(*args)`` run in a thread of its own, and waited for even through Ctrl-C.

    zarr does its I/O on an event loop of its own, which a KeyboardInterrupt
    in the waiting thread does not stop: a store removed after Ctrl-C was
    written into again, and left behind, by the writes still under way. The
    interruption (the first, if several) is raised once the function ends.
    """
    outcome = {}
    ended = threading.Event()  # not Thread.join: interrupted, it can take the thread as ended

    def run():
        try:
            outcome["value"] = function(*args)
        except BaseException as error:  # noqa: BLE001 - raised again in the caller's thread
            outcome["error"] = error
        finally:
            ended.set()

    threading.Thread(target=run, name="napari-labyrinth-zarr-write", daemon=True).start()
    interruption = None
    while not ended.is_set():
        try:
            ended.wait()
        except BaseException as error:  # noqa: BLE001 - raised once the write has ended
            interruption = interruption or error
    if interruption is not None:
        raise interruption
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def _write_zarr_block(store: str, block, location) -> None:
    if not os.path.isfile(os.path.join(store, "zarr.json")):  # abandoned after a failure
        raise FileNotFoundError(errno.ENOENT, "the output being written was removed", store)
    target = _cached_zarr_for_writing(store)
    target[tuple(slice(start, stop) for start, stop in location)] = block


def _is_zarr_store(path: Path) -> bool:
    return path.is_dir() and any(
        (path / name).is_file() for name in ("zarr.json", ".zarray", ".zgroup")
    )


def _create_temporary_directory(directory: Path, name: str, made: list[Path]) -> Path:
    """A new hidden directory beside the destination, its path put in ``made`` before it is
    created (see :func:`_create_temporary`)."""
    remove_stale_temporaries(directory, name)
    while True:
        temporary = directory / temporary_name(name)
        made.append(temporary)
        try:
            os.mkdir(temporary)
        except FileExistsError:
            made.pop()  # not made here
            continue
        return temporary


def _publish_directory(temporary: Path, path: Path, *, overwrite: bool) -> None:
    """Give the directory ``temporary`` the name ``path``, replacing it only with ``overwrite``."""
    if not overwrite or not os.path.lexists(path):
        _rename_no_replace(temporary, path)
        return
    old = path.parent / temporary_name(path.name, ".old")
    os.rename(path, old)
    try:
        os.rename(temporary, path)
    except BaseException:
        os.rename(old, path)
        raise
    if old.is_dir() and not old.is_symlink():
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.unlink(old)


def _rename_no_replace(source: Path, destination: Path) -> None:
    """Rename ``source`` to ``destination`` unless that exists (atomically where supported)."""
    exists = FileExistsError(f"{destination} already exists (use overwrite to replace it)")
    renameat2 = _renameat2()
    if renameat2 is not None:
        at_fdcwd, noreplace = -100, 1
        names = os.fsencode(source), os.fsencode(destination)
        if renameat2(at_fdcwd, names[0], at_fdcwd, names[1], noreplace) == 0:
            return
        code = ctypes.get_errno()
        if code == errno.EEXIST:
            raise exists
        if code not in (errno.EINVAL, errno.ENOSYS, getattr(errno, "ENOTSUP", errno.EINVAL)):
            raise OSError(code, os.strerror(code), str(destination))
    if os.path.lexists(destination):  # no renameat2 here: check, then rename (a small window)
        raise exists
    try:
        os.rename(source, destination)
    except OSError as exc:
        if exc.errno in (errno.EEXIST, errno.ENOTEMPTY):
            raise exists from None
        raise


@functools.lru_cache(maxsize=1)
def _renameat2():
    """libc's ``renameat2`` (Linux), or None."""
    try:
        function = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError, TypeError):
        return None
    function.argtypes = [
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_uint,
    ]
    function.restype = ctypes.c_int
    return function


# -- metadata: colour, axes, pixel sizes, provenance ----------------------------------------------

#: Axis letters (tifffile's, OME's) of the spatial axes, which carry physical sizes.
SPATIAL_AXES = "ZYX"

#: OME-Zarr unit names and the OME-XML symbols of the same units.
_UNIT_SYMBOLS = {
    "angstrom": "Å",
    "nanometer": "nm",
    "micrometer": "µm",
    "millimeter": "mm",
    "centimeter": "cm",
    "meter": "m",
}

#: OME-Zarr's names of time units -> OME-TIFF's symbols (``TimeIncrementUnit``).
_TIME_UNIT_SYMBOLS = {
    "second": "s",
    "millisecond": "ms",
    "microsecond": "µs",
    "nanosecond": "ns",
    "minute": "min",
    "hour": "h",
    "day": "d",
}

#: PIL image modes (PNG, JPEG, BMP) read as colour, with what the mode means.
_PIL_COLOUR_MODES = {
    "RGB": "RGB",
    "RGBA": "RGBA",
    "LA": "grey + alpha",
    "PA": "palette + alpha",
    "P": "palette",
}

#: PIL image modes read as grey; a mode in neither table (CMYK, YCbCr) is refused.
_PIL_GREY_MODES = ("1", "L", "I", "I;16", "I;16B")

#: PNG colour types (the IHDR chunk's; PNG specification, section 11.2.2), in words.
_PNG_COLOUR_TYPES = {0: "grey", 2: "RGB", 3: "palette", 4: "grey + alpha", 6: "RGBA"}

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

def _tiff_colour(photometric: str) -> str:
    """How ``ImageMetadata.colour`` of a TIFF starts: its photometric interpretation."""
    return f"TIFF photometric {photometric}, "


#: TIFF extra samples (tifffile's ``EXTRASAMPLE`` names, lower case) that are alpha.
_ALPHA_SAMPLES = ("unassalpha", "assocalpha")

#: Units of ``ImageMetadata.resolution`` (tifffile's ``RESUNIT`` names, lower case) per inch.
_PER_INCH = {"inch": 1.0, "centimeter": 2.54, "millimeter": 25.4, "micrometer": 25400.0}

#: The EXIF orientation tag, and the orientations whose transformation swaps rows and columns.
_EXIF_ORIENTATION = 0x0112
_EXIF_TRANSPOSING = (5, 6, 7, 8)

#: ImageJ's spellings of units (``unit=`` of its description) -> the OME-Zarr name of the unit
#: (as in ``ImageMetadata.pixel_sizes``); the first spelling of a unit is the one written.
_IMAGEJ_UNITS = {
    "um": "micrometer",
    "micron": "micrometer",
    "microns": "micrometer",
    "µm": "micrometer",
    "μm": "micrometer",
    "\\u00b5m": "micrometer",
    "nm": "nanometer",
    "mm": "millimeter",
    "cm": "centimeter",
    "m": "meter",
}

#: OME-Zarr axis type of each axis letter (letters not here get no type).
_OME_ZARR_TYPES = {"T": "time", "C": "channel", "Z": "space", "Y": "space", "X": "space"}


@dataclasses.dataclass(frozen=True)
class ImageMetadata:
    """What an image file says about its pixels (see :func:`read_metadata`).

    Attributes
    ----------
    axes : str or None
        One letter per axis of the array, as tifffile and OME name them
        (``T`` time, ``Z`` depth, ``C`` channel, ``Y``, ``X``, ``S`` colour
        samples, ``Q`` other); None when the file does not say.
    channel_axis : int or None
        The colour axis the file declares (TIFF photometric RGB samples, a
        PNG/JPEG/BMP colour type), or None for a grey image or planes.
    colour : str
        How the colour was read, in words (``"TIFF photometric RGB"``), or
        ``""`` when the file says nothing about colour.
    pixel_sizes : dict
        Axis letter (``"X"``, ``"Y"``, ``"Z"``) -> ``(size, unit)``, the
        unit an OME-Zarr name (``"micrometer"``), the file's own word for a
        unit without one (an ImageJ ``unit`` such as ``"inch"``), or None.
    ome : bool
        Whether axes and pixel sizes come from OME metadata (OME-TIFF,
        OME-Zarr); an output given them is written as OME too.
    provenance : dict or None
        The provenance record of a rendering (:mod:`napari_labyrinth.provenance`).
    ambiguous : bool
        A last axis of 3 or 4 that no metadata names colour or not: it is
        read as planes, and ``channel_axis=-1`` reads it as colour.
    grey_alpha : bool
        A grey image with an alpha channel (the colour axis: grey, alpha).
    extra_samples : tuple of str
        What the colour axis holds after its grey or RGB samples, one
        TIFF extra sample each, as tifffile names them (lower case):
        ``"unassalpha"`` (alpha), ``"assocalpha"`` (alpha that the colours
        are premultiplied by) or ``"unspecified"``. A TIFF output stores
        them back.
    resolution : tuple or None
        ``(x, y, unit)``: pixels per unit along X and Y as the file states
        them (TIFF resolution tags, PNG ``pHYs``, JPEG or BMP density),
        ``unit`` one of ``"inch"``, ``"centimeter"`` (or tifffile's
        ``"millimeter"``, ``"micrometer"``) or None (an aspect ratio only);
        None when the file states none.
    imagej : bool
        Whether axes and pixel sizes come from an ImageJ hyperstack (a TIFF
        file of ImageJ or Fiji); a TIFF output given them is written as one
        too where ImageJ can hold it (see :func:`_imagej_options`).
    icc_profile : bytes or None
        The ICC colour profile the file embeds (a TIFF's InterColorProfile
        tag, a PNG's iCCP chunk, a JPEG's APP2 segments): the meaning of its
        values, which the rendering keeps. A TIFF, PNG or JPEG output embeds
        it again; a BMP or zarr output holds none.
    time_increment : tuple or None
        ``(interval, unit)``: the time between two planes along the ``T``
        axis, the unit an OME-Zarr name (``"second"``) or the file's own
        word: an OME-TIFF's ``TimeIncrement``, an OME-Zarr image's scale of
        its time axis; None when the file states none. A TIFF or zarr
        output states it again.
    channel_names : tuple of str
        The names of the channels (``"DAPI"``, ``"GFP"``), one for each
        plane along the ``C`` axis, or a single one for an image without
        one: an OME-TIFF's ``Channel`` names, an OME-Zarr image's ``omero``
        channel labels (or those this package writes beside the axes where
        OME cannot hold them); ``()`` when the file names none (or not
        all). A TIFF or zarr output names them again.
    """

    axes: str | None = None
    channel_axis: int | None = None
    colour: str = ""
    pixel_sizes: dict = dataclasses.field(default_factory=dict)
    ome: bool = False
    provenance: dict | None = None
    ambiguous: bool = False
    grey_alpha: bool = False
    extra_samples: tuple[str, ...] = ()
    resolution: tuple[float, float, str | None] | None = None
    imagej: bool = False
    icc_profile: bytes | None = dataclasses.field(default=None, repr=False)
    channel_names: tuple[str, ...] = ()
    time_increment: tuple[float, str | None] | None = None

    def for_output(self, extra_axis: str | None, provenance: dict | None) -> ImageMetadata:
        """The metadata of a rendering of this image.

        ``extra_axis`` is the letter of a leading axis the rendering adds
        (the passes of a stack, the values of a sweep), or None.
        """
        axes = self.axes
        if axes is not None and extra_axis is not None:
            axes = extra_axis + axes
        axis = self.channel_axis
        if axis is not None and extra_axis is not None and axis >= 0:
            axis += 1
        return dataclasses.replace(self, axes=axes, channel_axis=axis, provenance=provenance)

    def with_channel_axis(self, axis: int | None) -> ImageMetadata:
        """The metadata of this image read with the colour axis ``axis`` (None: planes).

        Where ``axis`` is another axis than the file's, the file's samples
        (extra samples, grey + alpha) describe it no longer, and that axis is
        the colour samples (``S``) of the axes, or another axis (``Q``) for
        the file's colour axis read as planes: an output stores the colour
        as it was rendered (an RGB TIFF, not planes of 3 pixels).
        """
        if axis == self.channel_axis:
            return self
        axes = self.axes
        if axes is not None:
            letters = ["Q" if letter == "S" else letter for letter in axes]
            if axis is not None:
                letters[axis % len(letters)] = "S"
            axes = "".join(letters)
        return dataclasses.replace(
            self,
            axes=axes,
            channel_axis=axis,
            colour="" if axis is None else f"read as colour along axis {axis}",
            ambiguous=False,
            grey_alpha=False,
            extra_samples=(),
        )

    def unrenderable_samples(self) -> str | None:
        """Why the colour axis cannot be rendered as the file describes it, or None.

        A rendering keeps at most one channel as it is, the last (alpha, or
        the fourth of four channels): an alpha extra sample among several
        would be rendered as a plane of data. The reason names the samples.
        """
        extra = self.extra_samples
        if len(extra) > 1 and any(sample in _ALPHA_SAMPLES for sample in extra):
            return (
                f"its extra samples ({', '.join(extra)}) hold alpha beside other samples: a "
                "rendering keeps only one extra sample, the last, as it is; save the image "
                "with alpha as its only extra sample"
            )
        return None

    def kept_unspecified_sample(self) -> bool:
        """An RGB image with one extra sample that is not alpha (``"unspecified"``): as the
        fourth of four channels, a rendering keeps it as it is, as it keeps alpha."""
        rgb = self.colour.startswith(_tiff_colour("RGB"))
        return rgb and self.extra_samples == ("unspecified",)


def read_metadata(path: str | os.PathLike) -> ImageMetadata:
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
      and pixel sizes a fallback stored in it (see :func:`_tiff_options`).
    - PNG, JPEG, BMP (Pillow): the colour type (``RGB``, ``RGBA``, grey +
      alpha, palette: colour axis -1; grey: none; a PNG transparency chunk
      makes an RGB or palette image RGBA and a grey one grey + alpha); the
      resolution in dots per inch; an EXIF orientation, applied when the
      pixels are read (said in ``colour``; the resolution follows it); the
      record in a PNG text chunk or a JPEG comment.
    - zarr: OME-Zarr ``multiscales`` axes and scale of the full-resolution
      level; the record in the attributes (of the group, or of the array).

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
    kind = image_format(path)
    if kind == "ZARR":
        return _zarr_metadata(path)
    _require_file(path)
    try:
        if kind == "TIFF":
            return _tiff_metadata(path)
        return _pillow_metadata(path, kind)
    except ImageFileError:
        raise
    except Exception as exc:  # readers raise many types for a bad file
        raise ImageFileError(path, f"cannot read {kind} metadata: {_reason(exc)}") from exc


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


def _record(text: Any, path: Path) -> dict | None:
    from ..provenance import ProvenanceError, check, from_json

    if text is None:
        return None
    try:
        if isinstance(text, (str, bytes)):
            return from_json(text)
        check(text)
        return dict(text)
    except ProvenanceError as exc:
        raise ImageFileError(path, str(exc)) from None


def _ambiguous(shape: Sequence[int], channel_axis: int | None, axes: str | None) -> bool:
    return channel_axis is None and len(shape) >= 3 and shape[-1] in (3, 4) and not axes


def _tiff_metadata(path: Path) -> ImageMetadata:
    import tifffile

    from ..provenance import KEY

    with _tiff_file(path) as tif:
        series = tif.series[0]
        axes, shape = series.axes, series.shape
        page = series.keyframe
        icc_profile = _tiff_icc_profile(page)  # a large tag: read while the file is open
        channel_axis, colour, extra = None, "", _extra_samples(page)
        photometric = tifffile.PHOTOMETRIC(page.photometric)
        if "S" in axes:
            samples = page.samplesperpixel
            colour = f"{_tiff_colour(photometric.name)}{samples} samples per pixel"
            if extra:
                colour += f" (extra samples: {', '.join(extra)})"
            channel_axis = axes.index("S")
            if photometric != tifffile.PHOTOMETRIC.RGB:  # grey and extra samples
                channel_axis -= len(axes)  # as a PNG's -1: the command line keeps its alpha
        record, sizes, ome = None, {}, bool(tif.is_ome and tif.ome_metadata)
        channel_names: tuple[str, ...] = ()
        time_increment = None
        imagej = None if ome else tif.imagej_metadata
        if ome:
            ome_xml = tifffile.xml2dict(tif.ome_metadata)["OME"]
            image = _first(ome_xml.get("Image"))
            pixels = (image or {}).get("Pixels", {})
            for letter in SPATIAL_AXES:
                size = pixels.get(f"PhysicalSize{letter}")
                if size is not None:
                    unit = pixels.get(f"PhysicalSize{letter}Unit", "µm")
                    sizes[letter] = (float(size), _unit_name(unit))
            channel_names = _names(
                channel.get("Name") if isinstance(channel, dict) else None
                for channel in _all(pixels.get("Channel"))
            )
            if pixels.get("TimeIncrement") is not None:
                unit = _time_unit_name(pixels.get("TimeIncrementUnit", "s"))
                time_increment = (float(pixels["TimeIncrement"]), unit)
            annotations = ome_xml.get("StructuredAnnotations", {})
            for comment in _all(annotations.get("CommentAnnotation")):
                if isinstance(comment, dict) and comment.get("Namespace") == KEY:
                    record = _record(str(comment.get("Value")), path)
        elif imagej is not None:
            sizes = _imagej_pixel_sizes(imagej, _tiff_resolution(page))
            properties = imagej.get("Properties")
            if isinstance(properties, dict):
                record = _record(properties.get(KEY), path)
        elif tif.shaped_metadata:
            description = tif.shaped_metadata[0]
            record = _record(description.get(KEY), path)
            for letter, (size, unit) in description.get("pixel_sizes", {}).items():
                sizes[letter] = (float(size), unit)
            names = description.get("channel_names")
            channel_names = _names(names if isinstance(names, list) else ())
            time_increment = _time_pair(description.get("time_increment"))
    tifffile_default = not ome and imagej is None and set(axes) <= set("QSYX")
    return ImageMetadata(
        axes=None if tifffile_default else axes,
        channel_axis=channel_axis,
        colour=colour,
        pixel_sizes=sizes,
        ome=ome,
        provenance=record,
        ambiguous=_ambiguous(shape, channel_axis, None if tifffile_default else axes),
        grey_alpha=photometric != tifffile.PHOTOMETRIC.RGB
        and len(extra) == 1
        and extra[0] in _ALPHA_SAMPLES,
        extra_samples=extra,
        resolution=_tiff_resolution(page),
        icc_profile=icc_profile,
        imagej=imagej is not None,
        channel_names=channel_names,
        time_increment=time_increment,
    )


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
        unit = _IMAGEJ_UNITS.get(str(unit).lower(), str(unit))
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


#: The TIFF tag of an embedded ICC profile (InterColorProfile).
_ICC_PROFILE_TAG = 34675


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


def _pillow_metadata(path: Path, kind: str) -> ImageMetadata:
    from ..provenance import KEY

    with pillow_header(path) as image:  # past Pillow's size limit: the budget judges size
        stored = image.mode
        mode, from_transparency = _pillow_mode(path, kind, image)
        if kind == "PNG":
            text = getattr(image, "text", {}).get(KEY)
        elif kind == "JPEG":
            text = image.info.get("comment") or None
        else:
            text = None
        dpi = image.info.get("dpi")
        icc_profile = image.info.get("icc_profile") or None
        orientation = image.getexif().get(_EXIF_ORIENTATION, 1)
    if text is not None and kind == "JPEG" and not text.lstrip().startswith(b"{"):
        text = None  # a comment of another program
    colour = _PIL_COLOUR_MODES.get(mode)
    words = f"{kind} colour type {colour}" if colour else f"{kind} grey ({mode})"
    if from_transparency:
        read = _PIL_COLOUR_MODES.get(stored, f"grey ({stored})")
        words = f"{kind} {read} with a transparency chunk (tRNS), read as {colour}"
    resolution = None if dpi is None else (float(dpi[0]), float(dpi[1]), "inch")
    if orientation != 1:
        words += f"; EXIF orientation {orientation} applied (pixels read upright)"
        if resolution is not None and orientation in _EXIF_TRANSPOSING:
            resolution = (resolution[1], resolution[0], "inch")
    return ImageMetadata(
        axes="YXS" if colour else "YX",
        channel_axis=-1 if colour else None,
        colour=words,
        provenance=_record(text, path),
        grey_alpha=mode == "LA",
        extra_samples=("unassalpha",) if mode in ("RGBA", "LA", "PA") else (),
        resolution=resolution,
        icc_profile=icc_profile,
    )


def _pillow_mode(path: Path, kind: str, image) -> tuple[str, bool]:
    """The Pillow mode a PNG, JPEG or BMP file is read in, refusing what Pillow misreads.

    Parameters
    ----------
    path : Path
        The file, for error messages.
    kind : str
        Its format by suffix (``"PNG"``, ``"JPEG"``, ``"BMP"``); the
        format Pillow found decides the checks.
    image : PIL.Image.Image
        The file opened by Pillow (its header).

    Returns
    -------
    mode : str
        Pillow's mode of the file, or ``"RGBA"`` / ``"LA"`` for a PNG whose
        transparency chunk (``tRNS``: transparent palette entries, or one
        transparent grey level or colour) is read as an alpha channel.
    from_transparency : bool
        Whether ``mode`` is such a conversion (the pixels are read in it).

    Raises
    ------
    ImageFileError
        For a CMYK (or other unsupported mode) image, a 16-bit PNG that is
        not plain grey (Pillow reads those as 8 bits), and a transparent
        grey level that Pillow cannot read exactly (16-, 2- and 4-bit grey).
    """
    mode, found = image.mode, image.format or kind
    if mode == "CMYK":
        raise ImageFileError(
            path, f"is a CMYK {found} file; CMYK is not supported: convert it to RGB first"
        )
    if mode not in _PIL_COLOUR_MODES and mode not in _PIL_GREY_MODES:
        raise ImageFileError(
            path,
            f"is a {found} file in Pillow mode {mode}, which is not supported; "
            "convert it to grey or RGB first",
        )
    if found != "PNG":
        return mode, False
    depth, colour_type = _png_header(path)
    if depth == 16 and colour_type != 0:
        raise ImageFileError(
            path,
            f"is a 16-bit {_PNG_COLOUR_TYPES.get(colour_type, 'colour')} PNG, which Pillow "
            "reads only as 8 bits; convert it to a 16-bit TIFF first",
        )
    if image.info.get("transparency") is None:
        return mode, False
    if colour_type == 0 and depth != 8 and mode != "1":
        # Pillow compares the key with the grey levels scaled to 8 bits (2, 4-bit)
        # or cuts them to 8 bits (16-bit) to make the alpha channel
        raise ImageFileError(
            path,
            f"is a {depth}-bit grey PNG with a transparent grey level (tRNS), which Pillow "
            "cannot read exactly; convert it to a grey + alpha TIFF or 8-bit PNG first",
        )
    return ("RGBA" if mode in ("P", "RGB") else "LA"), True


def _png_header(path: Path) -> tuple[int, int | None]:
    """Bit depth and colour type of a PNG file, from its IHDR chunk (8 and None if unreadable).

    The PNG specification fixes where they are: the IHDR chunk comes first,
    after the 8-byte signature, and holds width, height (4 bytes each), bit
    depth and colour type (1 byte each).
    """
    with open(path, "rb") as file:
        head = file.read(26)
    if len(head) < 26 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return 8, None  # Pillow read a header: let it say what it found
    return head[24], head[25]


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

    from ..core.colour import LUMINANCE_CHANNELS

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


def _zarr_metadata(path: Path) -> ImageMetadata:
    from ..provenance import KEY

    array = _open_zarr_array(path)
    root, component = zarr_root(path)
    import zarr

    node = zarr.open(store=os.path.abspath(root), mode="r", path=component or None)
    attributes = dict(node.attrs)
    record = attributes.get(KEY, dict(array.attrs).get(KEY))
    multiscales = attributes.get("multiscales") or attributes.get("ome", {}).get("multiscales")
    axes, sizes, ome, channel_names, time_increment = None, {}, False, (), None
    if isinstance(node, zarr.Group) and multiscales:
        ome = True
        omero = attributes.get("omero") or attributes.get("ome", {}).get("omero") or {}
        channels = omero.get("channels") if isinstance(omero, dict) else None
        channel_names = _names(
            channel.get("label") if isinstance(channel, dict) else None
            for channel in (channels if isinstance(channels, list) else ())
        )
        scale = multiscales[0]
        names = [a["name"] if isinstance(a, dict) else a for a in scale.get("axes", ())]
        units = [a.get("unit") if isinstance(a, dict) else None for a in scale.get("axes", ())]
        if len(names) == array.ndim:
            axes = "".join(name[0].upper() if len(name) == 1 else "Q" for name in names)
            factors = _zarr_scale(scale["datasets"][0])
            whole = _zarr_scale(scale)  # the multiscale's own transform, after the dataset's
            if factors is not None and whole is not None and len(whole) == len(factors):
                factors = [a * b for a, b in zip(factors, whole)]
            for letter, unit, factor in zip(axes, units, factors or (), strict=False):
                if letter in SPATIAL_AXES:
                    sizes[letter] = (float(factor), unit)
                elif letter == "T" and (factor != 1 or unit is not None):
                    time_increment = (float(factor), unit)
        else:
            ome = False
    elif isinstance(attributes.get("axes"), str) and len(attributes["axes"]) == array.ndim:
        axes = attributes["axes"]  # written by _zarr_attributes where OME-Zarr does not fit
        sizes = {k: (float(v[0]), v[1]) for k, v in attributes.get("pixel_sizes", {}).items()}
        names = attributes.get("channel_names")
        channel_names = _names(names if isinstance(names, list) else ())
        time_increment = _time_pair(attributes.get("time_increment"))
    return ImageMetadata(
        axes=axes,
        pixel_sizes=sizes,
        ome=ome,
        provenance=_record(record, path),
        ambiguous=_ambiguous(array.shape, None, axes),
        channel_names=channel_names,
        time_increment=time_increment,
    )


def _time_pair(value) -> tuple[float, str | None] | None:
    """A time increment as this package writes it beside the axes (``[interval, unit]``)."""
    if isinstance(value, list) and len(value) == 2 and isinstance(value[0], (int, float)):
        return float(value[0]), value[1] if isinstance(value[1], str) else None
    return None


def _time_unit_name(symbol: str | None) -> str | None:
    names = {symbol: name for name, symbol in _TIME_UNIT_SYMBOLS.items()}
    return names.get(symbol, symbol)


def _zarr_scale(node: dict) -> list[float] | None:
    """The scale of an OME-Zarr dataset's (or multiscale's) coordinate transformations."""
    for transform in node.get("coordinateTransformations", ()) or ():
        if isinstance(transform, dict) and transform.get("type") == "scale":
            return transform.get("scale")
    return None


def _names(names) -> tuple[str, ...]:
    """Channel names, all of them or none: ``()`` when one is missing or empty."""
    names = tuple(names)
    if not names or not all(isinstance(name, str) and name for name in names):
        return ()
    return names


def _named_channels(metadata: ImageMetadata, shape: Sequence[int]) -> tuple[str, ...]:
    """The channel names an OME output of ``shape`` keeps: one for each plane along its C
    axis (one for an image without one), else none."""
    names, axes = metadata.channel_names, metadata.axes or ""
    count = int(shape[axes.index("C")]) if "C" in axes and len(axes) == len(shape) else 1
    return names if len(names) == count else ()


def _first(value: Any) -> Any:
    return value[0] if isinstance(value, list) else value


def _all(value: Any) -> list:
    if value is None:
        return []
    return value if isinstance(value, list) else [value]


def _unit_name(symbol: str | None) -> str | None:
    names = {symbol: name for name, symbol in _UNIT_SYMBOLS.items()}
    return names.get(symbol, symbol)


def _unit_symbol(name: str | None) -> str | None:
    return _UNIT_SYMBOLS.get(name, name)


def _tiff_options(shape: Sequence[int], dtype: Any, metadata: ImageMetadata | None) -> dict:
    """Keyword arguments of ``tifffile.imwrite``: the samples, resolution and metadata.

    Colour samples where the input had them, as it had them (see
    :func:`_tiff_samples`); OME-XML (axes, physical sizes, the record as a
    ``CommentAnnotation``) when the metadata come from OME and tifffile can
    write the axes as OME; an ImageJ hyperstack when they come from ImageJ
    and ImageJ can hold the image (see :func:`_imagej_options`); otherwise
    tifffile's JSON description with the record, and the axes and pixel
    sizes if known (an OME or ImageJ input whose axes or dtype the format
    cannot hold keeps them there, and its resolution in the TIFF tags).
    """
    from ..provenance import KEY, to_json

    dtype = np.dtype(dtype)
    if metadata is None:
        rgb = len(shape) >= 3 and shape[-1] in (3, 4) and dtype.kind in "uif"
        options: dict[str, Any] = {"photometric": "rgb" if rgb else "minisblack"}
    else:
        options = _tiff_samples(shape, metadata)
    if metadata is not None and metadata.resolution is not None:
        x, y, unit = metadata.resolution
        options.update(resolution=(x, y), resolutionunit=(unit or "none").upper())
    if metadata is not None and metadata.icc_profile is not None:
        options["iccprofile"] = metadata.icc_profile
    record = None if metadata is None else metadata.provenance
    if metadata is not None and metadata.ome and metadata.axes and _ome_tiff_ok(metadata, shape):
        ome: dict[str, Any] = {"axes": metadata.axes}
        for letter, (size, unit) in metadata.pixel_sizes.items():
            ome[f"PhysicalSize{letter}"] = size
            if unit is not None:
                ome[f"PhysicalSize{letter}Unit"] = _unit_symbol(unit)
        if names := _named_channels(metadata, shape):
            ome["Channel"] = {"Name": list(names)}
        if metadata.time_increment is not None and "T" in metadata.axes:
            interval, unit = metadata.time_increment
            ome["TimeIncrement"] = interval
            if unit is not None:
                ome["TimeIncrementUnit"] = _TIME_UNIT_SYMBOLS.get(unit, unit)
        if record is not None:
            ome["CommentAnnotation"] = {"Namespace": KEY, "Value": to_json(record)}
        options.update(ome=True, metadata=ome)
    elif metadata is not None and metadata.imagej and (
        imagej := _imagej_options(shape, dtype, metadata, options)
    ):
        options.update(imagej)
    else:
        description: dict[str, Any] = {} if record is None else {KEY: record}
        if metadata is not None and metadata.axes and len(metadata.axes) == len(shape):
            description["axes"] = metadata.axes  # tifffile reads it back as the series' axes
            if metadata.pixel_sizes:
                description["pixel_sizes"] = {k: list(v) for k, v in metadata.pixel_sizes.items()}
            if names := _named_channels(metadata, shape):
                description["channel_names"] = list(names)
            if metadata.time_increment is not None and "T" in metadata.axes:
                description["time_increment"] = list(metadata.time_increment)
        options.update(ome=False, metadata=description)
    return options


def _imagej_options(
    shape: Sequence[int], dtype: np.dtype, metadata: ImageMetadata, options: dict
) -> dict | None:
    """``tifffile.imwrite`` options of an ImageJ hyperstack, or None if ImageJ cannot hold it.

    The axes are ImageJ's (``TZCYXS``, in that order); a leading ``Q`` (the
    passes of a stack, the values of a sweep) becomes ``T`` when there is no
    ``T``. The pixel sizes are one unit, X and Y as the resolution (when
    the metadata state none), Z as ``spacing``; the record is the
    ``napari_labyrinth`` entry of ``Properties``. None, and the caller
    writes a JSON description, for other axes (a ``Q`` beside a ``T``),
    pixel sizes in several units, a dtype ImageJ does not store (tifffile
    writes uint8, uint16, int16 and float32) and colour samples other than
    contiguous uint8 RGB. The other ImageJ entries of an input (display
    mode, ranges and colour tables, labels, frame interval, ROIs) are not
    kept.
    """
    import tifffile

    from ..provenance import KEY, to_json

    axes = metadata.axes
    if not axes or len(axes) != len(shape):
        return None
    if axes[0] == "Q" and "T" not in axes:
        axes = "T" + axes[1:]
    rgb = (
        options["photometric"] == "rgb"
        and options.get("planarconfig") == "contig"
        and "extrasamples" not in options
        and dtype == np.uint8
    )
    if dtype.char not in "BHhf" or ("S" in axes) != rgb:
        return None
    try:
        tifffile.imagej_description(shape, axes=axes)  # checks the axes, their order, samples
    except ValueError:
        return None
    units = {unit for _, unit in metadata.pixel_sizes.values()}
    if len(units) > 1 or not set(metadata.pixel_sizes) <= set(SPATIAL_AXES):
        return None
    entries: dict[str, Any] = {"axes": axes}
    if "Z" in metadata.pixel_sizes:
        entries["spacing"] = metadata.pixel_sizes["Z"][0]
    if units and None not in units:
        (unit,) = units
        entries["unit"] = next((k for k, v in _IMAGEJ_UNITS.items() if v == unit), unit)
    if metadata.provenance is not None:
        entries["Properties"] = {KEY: to_json(metadata.provenance)}
    written = {"imagej": True, "ome": False, "metadata": entries}
    if metadata.resolution is None and {"X", "Y"} <= set(metadata.pixel_sizes):
        x, y = metadata.pixel_sizes["X"][0], metadata.pixel_sizes["Y"][0]
        written.update(resolution=(1.0 / x, 1.0 / y), resolutionunit="NONE")
    return written


def _tiff_samples(shape: Sequence[int], metadata: ImageMetadata) -> dict:
    """``photometric``, ``planarconfig`` and ``extrasamples`` of a TIFF output.

    The colour axis (RGB or grey, then the extra samples) is stored as
    samples per pixel: contiguous when it is the last axis, planar when it
    is the third from last (as tifffile reads them); anything else is grey
    planes.
    """
    axis, ndim = metadata.channel_axis, len(shape)
    if axis is None or axis % ndim not in (ndim - 1, ndim - 3):
        return {"photometric": "minisblack"}
    extra = metadata.extra_samples
    if not extra and (shape[axis] == 4 or metadata.grey_alpha):  # alpha, as the API reads it
        extra = ("unassalpha",)
    colours = shape[axis] - len(extra)
    if colours not in (1, 3) or (colours, extra) == (1, ()):
        return {"photometric": "minisblack"}
    options: dict[str, Any] = {
        "photometric": "rgb" if colours == 3 else "minisblack",
        "planarconfig": "contig" if axis % ndim == ndim - 1 else "separate",
    }
    if extra:
        options["extrasamples"] = list(extra)
    return options


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
    if kind == "TIFF" and not _ome_tiff_ok(metadata, shape):
        holds = "OME-TIFF"
    elif kind == "ZARR" and not (
        len(metadata.axes) == len(shape) and _ome_zarr_ok(metadata.axes)
    ):
        holds = "OME-Zarr (2 to 5 axes: [time] [channel or another] then 2 or 3 of space)"
    else:
        return None
    return (
        f"{holds} cannot hold the axes {metadata.axes}: written with them in this package's "
        "own description instead (read back by napari-labyrinth, not by other OME readers)"
    )


def _ome_tiff_ok(metadata: ImageMetadata, shape: Sequence[int]) -> bool:
    """Whether tifffile can write these axes as OME-XML (else a JSON description)."""
    from tifffile import OmeXml, OmeXmlError

    try:
        xml = OmeXml()
        storedshape = (1, 1, 1, int(shape[-2]), int(shape[-1]), 1)
        if metadata.axes.endswith("S"):
            storedshape = (1, 1, 1, int(shape[-3]), int(shape[-2]), int(shape[-1]))
        pages = int(np.prod(shape[: -3 if metadata.axes.endswith("S") else -2]))
        storedshape = (pages,) + storedshape[1:]
        xml.addimage("uint8", tuple(shape), storedshape, axes=metadata.axes)
    except (OmeXmlError, ValueError):
        return False
    return len(metadata.axes) == len(shape)


def _zarr_attributes(shape: Sequence[int], metadata: ImageMetadata | None) -> tuple[dict, str]:
    """The attributes of a zarr output and the array's path in it ("" for a plain array).

    An OME-Zarr image (version 0.5: a group with ``ome.multiscales`` and its
    array at ``0``) when the metadata come from OME and the axes fit the
    specification (2 to 5 axes: time, then channel or another kind, then 2
    or 3 spatial ones); otherwise a plain array with the record (and the
    axes, if known) in its attributes.
    """
    from ..provenance import KEY

    attributes: dict[str, Any] = {}
    if metadata is None:
        return attributes, ""
    if metadata.provenance is not None:
        attributes[KEY] = metadata.provenance
    axes, ndim = metadata.axes, len(shape)
    if not (metadata.ome and axes and len(axes) == ndim and _ome_zarr_ok(axes)):
        if axes and len(axes) == ndim:  # read back by _zarr_metadata
            attributes["axes"] = axes
            attributes["pixel_sizes"] = {k: list(v) for k, v in metadata.pixel_sizes.items()}
            if names := _named_channels(metadata, shape):
                attributes["channel_names"] = list(names)
            if metadata.time_increment is not None and "T" in axes:
                attributes["time_increment"] = list(metadata.time_increment)
        return attributes, ""
    entries, scale = [], []
    for letter in axes:
        entry: dict[str, Any] = {"name": letter.lower() if letter in "TCZYX" else "q"}
        if letter in _OME_ZARR_TYPES:
            entry["type"] = _OME_ZARR_TYPES[letter]
        size, unit = metadata.pixel_sizes.get(letter, (1.0, None))
        if letter == "T" and metadata.time_increment is not None:
            size, unit = metadata.time_increment
        if unit is not None:
            entry["unit"] = unit
        entries.append(entry)
        scale.append(float(size))
    attributes["ome"] = {
        "version": "0.5",
        "multiscales": [
            {
                "axes": entries,
                "datasets": [
                    {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": scale}]}
                ],
            }
        ],
    }
    if names := _named_channels(metadata, shape):
        attributes["ome"]["omero"] = {"channels": [{"label": name} for name in names]}
    return attributes, "0"


def _ome_zarr_ok(axes: str) -> bool:
    """Whether the axes follow OME-Zarr: 2-5 of them, [time] [channel/other] 2-3 space."""
    space = axes.lstrip("TCQ")
    head = axes[: len(axes) - len(space)]
    return (
        2 <= len(axes) <= 5
        and 2 <= len(space) <= 3
        and set(space) <= set(SPATIAL_AXES)
        and head in ("", "T", "C", "Q", "TC", "TQ")
    )
