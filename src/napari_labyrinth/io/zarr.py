"""zarr stores: arrays, OME-Zarr images and groups, read whole or lazily, written block by block.

A ``.zarr`` directory holding an array, an OME-Zarr image (its
full-resolution level) or a group of one array is read through zarr, lazily
as a dask array of whole planes (:func:`open_zarr_lazily`). An output is
written into a hidden directory beside its destination, by the tasks that
compute its blocks, then renamed into place (:func:`write_zarr`); its axes,
pixel sizes, channel names and provenance record are its attributes, as an
OME-Zarr image where OME-Zarr can hold the axes, with lower resolution levels
(``_pyramid``) made plane by plane from its full level, and multiscale
metadata written through ome-zarr. zarr, dask and ome-zarr are optional
(``napari-labyrinth[dask]``) and imported where they are used.
"""

from __future__ import annotations

import errno
import functools
import os
import shutil
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._budget import refusal
from .._threads import start_helper, wait_through_interrupts
from ..lazy import is_lazy, run_blocks
from ..provenance import KEY
from ._arrays import block_chunks, native, plane_count
from ._atomic import create_temporary_directory, named_after_destination, publish_directory
from ._errors import ImageFileError, reason_of, refuse_unaffordable_file
from ._formats import check_storable, is_zarr_store, zarr_root
from ._pyramid import halved, halved_shape, level_count, plane_slices
from .metadata import (
    SPATIAL_AXES,
    ImageMetadata,
    complete_names,
    image_name,
    is_ambiguous,
    named_channels,
    read_record,
    time_pair,
)

#: The colour of every channel of an OME-Zarr output (its ``omero`` metadata need one):
#: white, the package keeping no channel colours.
_CHANNEL_COLOUR = "FFFFFF"

#: OME-Zarr axis type of each axis letter (letters not here get no type).
_OME_ZARR_TYPES = {"T": "time", "C": "channel", "Z": "space", "Y": "space", "X": "space"}


def read_zarr(path: Path) -> np.ndarray:
    """The array of a zarr store read whole, refused before reading if it needs more memory
    than the run may use."""
    array = _open_zarr_array(path)
    refuse_unaffordable_file(path, refusal(array.shape, array.dtype))
    return native(np.asarray(array[...]))


def open_zarr_lazily(path: Path, channel_axis: int | None):
    """The array of a zarr store as a dask array of whole planes, read block by block when
    computed."""
    array = _open_zarr_array(path)
    import dask.array as da

    chunks = block_chunks(array.shape, array.chunks, array.dtype, channel_axis)
    return native(da.from_zarr(array, chunks=chunks))


def forget_stores_written() -> None:
    """Forget the zarr stores opened in this process to write blocks into."""
    _cached_zarr_for_writing.cache_clear()


def zarr_metadata(path: Path) -> ImageMetadata:
    """What a zarr store says about its pixels (see ``read_metadata``)."""
    array = _open_zarr_array(path)
    root, component = zarr_root(path)
    import zarr

    node = zarr.open(store=os.path.abspath(root), mode="r", path=component or None)
    attributes = dict(node.attrs)
    record = attributes.get(KEY, dict(array.attrs).get(KEY))
    multiscales = attributes.get("multiscales") or attributes.get("ome", {}).get("multiscales")
    axes, sizes, ome, channel_names, time_increment = None, {}, False, (), None
    stated_name = image_name(attributes.get("image_name"))
    if isinstance(node, zarr.Group) and multiscales:
        ome = True
        omero = attributes.get("omero") or attributes.get("ome", {}).get("omero") or {}
        channels = omero.get("channels") if isinstance(omero, dict) else None
        channel_names = complete_names(
            channel.get("label") if isinstance(channel, dict) else None
            for channel in (channels if isinstance(channels, list) else ())
        )
        scale = multiscales[0]
        stated_name = image_name(scale.get("name")) or stated_name
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
        channel_names = complete_names(names if isinstance(names, list) else ())
        time_increment = time_pair(attributes.get("time_increment"))
    return ImageMetadata(
        axes=axes,
        pixel_sizes=sizes,
        ome=ome,
        provenance=read_record(record, path),
        ambiguous=is_ambiguous(array.shape, None, axes),
        channel_names=channel_names,
        time_increment=time_increment,
        image_name=stated_name,
    )


def write_zarr(path: Path, array, *, overwrite, plane_axes, progress, metadata) -> Path:
    """Write an array to a zarr store, atomically, a dask array block by block (see
    ``write_array``)."""
    if zarr_root(path) != (path, ""):
        raise ImageFileError(path, "a zarr output is a path ending in .zarr, not inside one")
    check_storable(path, "ZARR", array)
    if os.path.lexists(path):
        if not overwrite:
            raise FileExistsError(f"{path} already exists (use overwrite to replace it)")
        if not is_zarr_store(path):
            raise ImageFileError(path, "exists and is not a zarr store; not replacing it")
    try:
        import zarr
    except ImportError:
        raise ImageFileError(
            path, "writing zarr needs zarr and dask: pip install 'napari-labyrinth[dask]'"
        ) from None
    axes = {axis % array.ndim for axis in plane_axes}
    chunks = tuple(size if axis in axes else 1 for axis, size in enumerate(array.shape))
    array = native(array)
    made: list[Path] = []
    with named_after_destination(path, made):  # the error names path, not the temporary
        try:
            temporary = create_temporary_directory(path.parent, path.name, made)
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
                if store != os.path.abspath(temporary):  # an OME-Zarr image: its lower levels
                    _write_lower_levels_of(zarr, os.path.abspath(temporary), chunks)
            elif progress is not None:
                total = plane_count(array.shape, plane_axes)
                progress(total, total)
            publish_directory(temporary, path, overwrite=overwrite)
        except BaseException:
            for temporary in made:
                shutil.rmtree(temporary, ignore_errors=True)
            raise
        finally:
            _cached_zarr_for_writing.cache_clear()
    return path


def ome_zarr_ok(axes: str) -> bool:
    """Whether the axes follow OME-Zarr: 2-5 of them, [time] [channel/other] 2-3 space."""
    space = axes.lstrip("TCQ")
    head = axes[: len(axes) - len(space)]
    return (
        2 <= len(axes) <= 5
        and 2 <= len(space) <= 3
        and set(space) <= set(SPATIAL_AXES)
        and head in ("", "T", "C", "Q", "TC", "TQ")
    )


def _zarr_attributes(shape: Sequence[int], metadata: ImageMetadata | None) -> tuple[dict, str]:
    """The attributes of a zarr output and the array's path in it ("" for a plain array).

    An OME-Zarr image (version 0.5: a group with ``ome.multiscales`` and its
    array at ``0``) when the metadata come from OME and the axes fit the
    specification (2 to 5 axes: time, then channel or another kind, then 2
    or 3 spatial ones); otherwise a plain array with the record (and the
    axes, if known) in its attributes.
    """
    attributes: dict[str, Any] = {}
    if metadata is None:
        return attributes, ""
    if metadata.provenance is not None:
        attributes[KEY] = metadata.provenance
    axes, ndim = metadata.axes, len(shape)
    if not (metadata.ome and axes and len(axes) == ndim and ome_zarr_ok(axes)):
        if axes and len(axes) == ndim:  # read back by zarr_metadata
            attributes["axes"] = axes
            attributes["pixel_sizes"] = {k: list(v) for k, v in metadata.pixel_sizes.items()}
            if names := named_channels(metadata, shape):
                attributes["channel_names"] = list(names)
            if metadata.time_increment is not None and "T" in axes:
                attributes["time_increment"] = list(metadata.time_increment)
        if metadata.image_name is not None:
            attributes["image_name"] = metadata.image_name
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
    if metadata.image_name is not None:
        attributes["ome"]["multiscales"][0]["name"] = metadata.image_name
    if names := named_channels(metadata, shape):
        attributes["ome"]["omero"] = {
            "channels": [{"label": name, "color": _CHANNEL_COLOUR} for name in names]
        }  # each channel's window once its values are written (_write_lower_levels)
    return attributes, "0"


def _dimension_names(ome: dict) -> list[str]:
    """The dimension names of an OME-Zarr image's arrays: its axes' names, as OME-Zarr 0.5
    requires."""
    return [entry["name"] for entry in ome["multiscales"][0]["axes"]]


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
        raise ImageFileError(path, f"cannot read zarr store: {reason_of(exc)}") from exc
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


def _zarr_scale(node: dict) -> list[float] | None:
    """The scale of an OME-Zarr dataset's (or multiscale's) coordinate transformations."""
    for transform in node.get("coordinateTransformations", ()) or ():
        if isinstance(transform, dict) and transform.get("type") == "scale":
            return transform.get("scale")
    return None


def _create_zarr_array(zarr, directory: str, array, chunks, metadata, values) -> str:
    """Create the zarr array ``array`` will be written to in ``directory``, and its path.

    With its attributes (an OME-Zarr image is a group holding the array), and
    filled with ``values`` unless they are None.
    """
    store = directory
    attributes, component = _zarr_attributes(array.shape, metadata)
    group, names = None, None
    if component:
        group = zarr.open_group(store=store, mode="w")
        group.attrs.update(attributes)
        store = os.path.join(store, component)
        names = _dimension_names(attributes["ome"])
    target = zarr.create_array(
        store=store, shape=array.shape, chunks=chunks, dtype=array.dtype, fill_value=0,
        dimension_names=names,
    )  # fmt: skip
    if not component:
        target.attrs.update(attributes)
    if values is not None:
        target[...] = values
        if component:
            _write_lower_levels(zarr, group, values, chunks, attributes["ome"])
    return store


def _write_lower_levels_of(zarr, directory: str, chunks, rows: int | None = None) -> None:
    """Add the lower resolution levels of the OME-Zarr image written in ``directory``, read
    plane by plane (or ``rows`` rows by ``rows`` rows) from its full level (see
    ``_write_lower_levels``)."""
    group = _waited_for(functools.partial(zarr.open_group, store=directory, mode="r+"))
    _write_lower_levels(zarr, group, group["0"], chunks, dict(group.attrs)["ome"], rows)


def _write_lower_levels(zarr, group, full, chunks, ome: dict, rows: int | None = None) -> None:
    """Add the lower resolution levels of an OME-Zarr image whose full level (``full``: the
    values, or the zarr array they were written to) is at ``0``, as arrays ``1``, ``2``, ...
    of ``group``, and its metadata, through ome-zarr; without ome-zarr, the image keeps its
    one level and the metadata written by hand.

    The levels halve Y and X by a local mean (``_pyramid``), each from the one above, plane
    by plane (one plane in memory at a time, whatever the image's size; with ``rows``, a
    plane larger than memory: ``2 * rows`` of its rows at a time), until the smaller
    side is at most ``SMALLEST_SIDE`` long; each level's scale is the full level's times
    the factor, and a chunk holds one plane, as at the full level. ome-zarr's own
    ``write_multiscale`` names its levels ``s0``, ``s1``, ... and computes them through
    dask's default scheduler (a cluster's, if one is set): the arrays are written here, the
    metadata by ``write_multiscales_metadata``, which checks them against the specification.
    Each named channel (``omero``) gets the range of its values at the full level as its
    window, read as the first lower level is made (or on its own where there is none).
    """
    try:  # optional: without ome-zarr, one level
        from ome_zarr.format import FormatV05
        from ome_zarr.writer import write_multiscales_metadata
    except ImportError:
        write_multiscales_metadata = None
    multiscale = ome["multiscales"][0]
    axes = multiscale["axes"]
    planar = [axis for axis, entry in enumerate(axes) if entry["name"] in ("y", "x")]
    scale = multiscale["datasets"][0]["coordinateTransformations"][0]["scale"]
    ranges = _ChannelRanges(axes) if "omero" in ome else None
    count = level_count(full.shape, planar) if write_multiscales_metadata is not None else 1
    if ranges is not None and count == 1:
        for where in plane_slices(full.shape, planar):
            for part, _ in _halved_parts(full, where, planar[0], rows):
                ranges.add(where, part)
    above = full
    for number in range(1, count):
        shape = halved_shape(above.shape, planar)
        plane_chunks = tuple(
            shape[axis] if chunk == full.shape[axis] else chunk
            for axis, chunk in enumerate(chunks)
        )
        level = _waited_for(
            functools.partial(
                group.create_array, str(number), shape=shape, chunks=plane_chunks,
                dtype=full.dtype, fill_value=0, dimension_names=_dimension_names(ome),
            )
        )  # fmt: skip
        for where in plane_slices(shape, planar):
            for part, halved_part in _halved_parts(above, where, planar[0], rows):
                if ranges is not None and number == 1:
                    ranges.add(where, part)
                # each part's write waited for: Ctrl-C stops the pass within a plane
                _waited_for(level.__setitem__, halved_part, halved(part, range(part.ndim)))
        above = level
    if ranges is not None:
        channels = ome["omero"]["channels"]
        windows = ranges.windows(len(channels))
        omero = {"channels": [dict(c, window=w) for c, w in zip(channels, windows, strict=True)]}
        ome = dict(ome, omero=omero)
    if write_multiscales_metadata is None:
        if ranges is not None:
            _waited_for(group.attrs.__setitem__, "ome", ome)
        return
    datasets = []
    for number in range(count):
        factors = [2**number if axis in planar else 1 for axis in range(full.ndim)]
        transform = {"type": "scale", "scale": [s * f for s, f in zip(scale, factors)]}
        datasets.append({"path": str(number), "coordinateTransformations": [transform]})
    extra = {"metadata": {"omero": ome["omero"]}} if "omero" in ome else {}
    _waited_for(
        functools.partial(
            write_multiscales_metadata, group, datasets, fmt=FormatV05(), axes=axes,
            name=multiscale.get("name"), **extra,
        )
    )  # fmt: skip
    if "name" not in multiscale:  # ome-zarr names it after the group ("/") otherwise
        attributes = dict(group.attrs["ome"])
        attributes["multiscales"] = [
            {k: v for k, v in attributes["multiscales"][0].items() if k != "name"}
        ]
        _waited_for(group.attrs.__setitem__, "ome", attributes)


class _ChannelRanges:
    """The least and the greatest finite value of each channel of an image (along its
    ``channel`` axis; one channel without one), gathered plane by plane."""

    def __init__(self, axes: Sequence[dict]) -> None:
        types = [entry.get("type") for entry in axes]
        self.axis = types.index("channel") if "channel" in types else None
        self.found: dict[int, tuple[Any, Any]] = {}

    def add(self, where: tuple[Any, ...], part: np.ndarray) -> None:
        """Count ``part``, a part of the plane at ``where`` (its channel's position an int)."""
        channel = 0 if self.axis is None else int(where[self.axis])
        values = np.abs(part) if part.dtype.kind == "c" else part
        if values.dtype.kind == "f":
            values = values[np.isfinite(values)]
        if values.size == 0:
            return
        low, high = values.min(), values.max()
        if channel in self.found:
            low, high = min(low, self.found[channel][0]), max(high, self.found[channel][1])
        self.found[channel] = (low, high)

    def windows(self, count: int) -> list[dict[str, float]]:
        """The ``omero`` window of each of ``count`` channels: its range, shown from its least
        to its greatest value (a constant channel: up to one more, as a viewer needs a
        range; one without a finite value: from 0)."""
        windows = []
        for channel in range(count):
            low, high = (_json_number(v) for v in self.found.get(channel, (0, 0)))
            end = high if high > low else low + 1
            windows.append({"min": low, "max": high, "start": low, "end": end})
        return windows


def _json_number(value) -> int | float:
    """A numpy scalar as the Python int or float JSON writes."""
    return int(value) if np.asarray(value).dtype.kind in "biu" else float(value)


def _halved_parts(above, where, row_axis: int, rows: int | None):
    """The parts of the plane ``above[where]`` halved at a time, and where each one's half
    goes in the level below: the whole plane, or (``rows``) ``2 * rows`` rows at a time
    (a 2 x 2 block never straddles two parts: the same halves)."""
    if rows is None:
        yield np.asarray(above[where]), where
        return
    height = above.shape[row_axis]
    for start in range(0, height, 2 * rows):
        part, below = list(where), list(where)
        part[row_axis] = slice(start, min(height, start + 2 * rows))
        below[row_axis] = slice(start // 2, (min(height, start + 2 * rows) + 1) // 2)
        yield np.asarray(above[tuple(part)]), tuple(below)


def _waited_for(function, *args):
    """``function(*args)`` run in a thread of its own, and waited for even through Ctrl-C.

    zarr does its I/O on an event loop of its own, which a KeyboardInterrupt
    in the waiting thread does not stop: a store removed after Ctrl-C was
    written into again, and left behind, by the writes still under way. The
    thread is started without a wait (``_threads.start_helper``) that Ctrl-C
    could end with it running. The interruption (the first, if several) is
    raised once the function ends.
    """
    outcome = {}
    ended = threading.Event()

    def run():
        try:
            outcome["value"] = function(*args)
        except BaseException as error:  # noqa: BLE001 - raised again in the caller's thread
            outcome["error"] = error
        finally:
            ended.set()

    # started without waiting for it to run: a Ctrl-C in Thread.start's wait left it
    # writing, unknown to this function, into a store the caller then removed
    if start_helper(run).acquire(blocking=False) and not ended.is_set():
        run()  # no thread to be had
    _, interruption = wait_through_interrupts(ended)
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


@functools.lru_cache(maxsize=8)
def _cached_zarr_for_writing(path: str):
    import zarr

    return zarr.open_array(store=path, mode="r+")
