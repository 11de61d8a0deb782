"""Files of the formats the package does not read itself, through bioio and its reader plugins.

Microscopes write their own formats (Zeiss CZI, Nikon ND2, Leica LIF, ...).
bioio reads them through one reader plugin per format, installed with the
optional extra ``napari-labyrinth[formats]``; without it such a file is
refused in one line that names the extra. bioio is imported where it is
used, so that the package imports and reads its own formats without it.

One scene of a file is read (the first unless ``scene`` names another): its
dimensions in bioio's order (``TCZYX``, ``S`` for RGB samples), without the
axes of length 1 (as tifffile reads an OME-TIFF), its physical pixel sizes
(bioio's, in micrometres), its channel names and its image name. Its pixels
come as bioio's dask array, recut into blocks of whole planes, or computed
into memory when they are few and small enough (as a TIFF file is read).
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .._budget import refusal
from ._arrays import block_chunks, native
from ._errors import ImageFileError, reason_of, refuse_unaffordable_file, require_file
from ._formats import FORMATS
from .metadata import ImageMetadata, complete_names, image_name

#: What installs the readers of the other formats.
FORMATS_EXTRA = 'pip install "napari-labyrinth[formats]"'

#: bioio's unit of physical pixel sizes, as :class:`ImageMetadata` names units.
BIOIO_UNIT = "micrometer"

#: The axis letters of bioio's dimensions that the package's axes keep as they are; any
#: other dimension (a mosaic tile, a view) is another axis, ``Q``.
_KEPT_LETTERS = "TCZYXS"

#: The loggers of bioio and its plugins, which log what they could not parse (with
#: tracebacks) while reading what they can: quiet while a file is opened.
_BIOIO_LOGGERS = ("bioio", "bioio_base", "bioio_czi", "bioio_nd2", "bioio_lif",
                  "bioio_ome_tiff", "bioio_ome_zarr", "xsdata", "ome_types")  # fmt: skip


def bioio_metadata(path: Path, scene: int | str | None = None) -> ImageMetadata:
    """What bioio says about the pixels of one scene of a file (see ``read_metadata``)."""
    image, index = _open(path, scene)
    with _quiet():
        order, shape = image.dims.order, tuple(int(n) for n in image.shape)
        kept = _kept_axes(order, shape)
        axes = "".join(letter if letter in _KEPT_LETTERS else "Q" for letter in kept)
        sizes = {}
        physical = _unless_unparsed(lambda: image.physical_pixel_sizes)
        for letter in "ZYX":
            size = getattr(physical, letter, None)
            if letter in axes and size is not None and np.isfinite(size) and size > 0:
                sizes[letter] = (float(size), BIOIO_UNIT)
        names = complete_names(
            str(name) for name in (_unless_unparsed(lambda: image.channel_names) or ())
        )
        samples = "S" in axes and shape[order.index("S")] in (3, 4)
        return ImageMetadata(
            axes=axes,
            channel_axis=axes.index("S") if samples else None,
            colour=f"bioio RGB samples ({type(image.reader).__module__})" if samples else "",
            pixel_sizes=sizes,
            ome=True,  # bioio's metadata are OME's: an output is OME-TIFF or OME-Zarr
            channel_names=names if "C" in axes or len(names) == 1 else (),
            image_name=_name_of(image, index),
            scene=str(image.scenes[index]),
        )


def read_bioio(path: Path, scene: int | str | None = None) -> np.ndarray:
    """The pixels of one scene of a file, read into memory (see :func:`bioio_in_memory`)."""
    return bioio_in_memory(path, open_bioio_lazily(path, scene, channel_axis=None))


def open_bioio_lazily(path: Path, scene: int | str | None, channel_axis: int | None):
    """One scene of a file as bioio's dask array, its axes of length 1 left out, cut into
    blocks of whole planes (the colour axis whole): nothing is read until it is computed."""
    image, _ = _open(path, scene)
    with _quiet():
        order, shape = image.dims.order, tuple(int(n) for n in image.shape)
        data = image.dask_data
    if data.size == 0:
        raise ImageFileError(path, f"the file holds no pixels (shape {shape})")
    kept = _kept_axes(order, shape)
    data = data[tuple(slice(None) if letter in kept else 0 for letter in order)]
    if channel_axis is None and "S" in kept and shape[order.index("S")] in (3, 4):
        channel_axis = kept.index("S")
    chunks = block_chunks(data.shape, data.chunksize, data.dtype, channel_axis)
    return native(data.rechunk(chunks))


def bioio_in_memory(path: Path, data) -> np.ndarray:
    """A lazy scene of :func:`open_bioio_lazily` computed, refused before reading if it
    needs more memory than the run may use; a reader's failure named in one line."""
    refuse_unaffordable_file(path, refusal(data.shape, data.dtype))
    try:
        with _quiet():
            return np.asarray(data.compute())
    except Exception as exc:  # readers raise many types for a bad file
        reason = reason_of(exc)
        raise ImageFileError(path, f"cannot read its pixels through bioio: {reason}") from exc


def _unless_unparsed(read: Callable[[], Any]) -> Any:
    """What ``read`` gives, or None where the reader cannot parse that part of the file's
    metadata (a CZI without scaling raises): the pixels are read all the same."""
    try:
        return read()
    except Exception:  # noqa: BLE001 - readers raise many types for metadata they cannot parse
        return None


def _kept_axes(order: str, shape: tuple[int, ...]) -> str:
    """The letters of the dimensions kept: Y, X and every other of more than one entry."""
    return "".join(
        letter for letter, size in zip(order, shape, strict=True) if size > 1 or letter in "YX"
    )


def _open(path: Path, scene: int | str | None):
    """``(BioImage, scene index)``: the file opened by bioio, the scene chosen.

    Raises
    ------
    ImageFileError
        One line: bioio not installed (naming the extra), no installed reader
        for the file's format, a reader that cannot read it, a scene it has not.
    """
    require_file(path)
    try:
        import bioio  # reason: an optional extra, imported only for a file that needs it
    except ImportError:
        raise ImageFileError(path, _missing_extra(path)) from None
    try:
        with _quiet():
            image = bioio.BioImage(path)
            scenes = tuple(image.scenes)
    except Exception as exc:  # bioio and its readers raise many types for a bad file
        raise ImageFileError(path, _unreadable(path, exc)) from exc
    index = _scene_index(path, scenes, scene)
    try:
        with _quiet():
            if index != image.current_scene_index:
                image.set_scene(index)
            _ = image.dask_data  # the reader parses what it needs to lay the scene out
    except Exception as exc:  # readers raise many types for metadata they cannot parse
        raise ImageFileError(path, _unreadable(path, exc)) from exc
    return image, index


def _missing_extra(path: Path) -> str:
    """Why a file of another format than the package's own cannot be read without bioio."""
    suffix = path.suffix.lower()
    what = f"{suffix} files are" if suffix else "files without a suffix are"
    return (
        f"{what} read through bioio, which is not installed: {FORMATS_EXTRA} "
        f"(napari-labyrinth itself reads {', '.join(FORMATS)})"
    )


def _unreadable(path: Path, exc: Exception) -> str:
    """One line for a file no installed bioio reader could read: which readers tried."""
    readers = _readers_for(path)
    suffix = path.suffix.lower() or "(no suffix)"
    if not readers:
        return (
            f"no installed bioio reader reads {suffix} files (readers for "
            f"{', '.join(_installed_suffixes()) or 'no format'} are installed)"
        )
    if type(exc).__name__ == "UnsupportedFileFormatError":  # every reader said no
        return f"{', '.join(readers)} cannot read it as a {suffix} file (corrupt, or another format)"
    return f"cannot read it with {', '.join(readers)}: {reason_of(exc)}"


def _readers_for(path: Path) -> list[str]:
    """The installed bioio reader plugins that claim the file by its name."""
    name = path.name.lower()
    plugins = _plugins()
    return list(
        dict.fromkeys(
            entry.entrypoint.name
            for suffix, entries in plugins.items()
            if name.endswith(suffix.lower())
            for entry in entries
        )
    )


def _installed_suffixes() -> list[str]:
    return sorted(_plugins())


def _plugins() -> dict[str, Any]:
    """bioio's installed reader plugins by file suffix (``{}`` if it cannot say)."""
    try:
        from bioio.plugins import get_plugins

        with _quiet():
            return dict(get_plugins(use_cache=True))
    except Exception:  # noqa: BLE001 - an older bioio: the message names no reader
        return {}


def _scene_index(path: Path, scenes: tuple[str, ...], scene: int | str | None) -> int:
    """The index of ``scene`` (None: the first; a name, or an index, as an int or digits)."""
    if scene is None:
        return 0
    if isinstance(scene, str) and scene in scenes:
        return scenes.index(scene)
    index = scene
    if isinstance(scene, str) and scene.strip().isdigit():
        index = int(scene)
    is_index = isinstance(index, (int, np.integer)) and not isinstance(index, bool)
    if is_index and 0 <= index < len(scenes):
        return int(index)
    listed = ", ".join(f"{number} ({name!r})" for number, name in enumerate(scenes))
    raise ImageFileError(
        path,
        f"has no scene {scene!r}; its scenes are {listed} (scene=, --scene: an index or a name)",
    )


def _name_of(image, index: int) -> str | None:
    """The name of the image read: its OME image name, else its scene's name, unless bioio
    made that up (``Image:0``)."""
    try:
        name = image.ome_metadata.images[index].name
    except Exception:  # noqa: BLE001 - a reader without OME metadata, or one it cannot parse
        name = None
    return image_name(name) or image_name(str(image.scenes[index]))


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """bioio's and its plugins' log records and warnings held back: what they could not
    parse is either not needed here or reported as this module's one-line error."""
    loggers = [logging.getLogger(name) for name in _BIOIO_LOGGERS]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)
