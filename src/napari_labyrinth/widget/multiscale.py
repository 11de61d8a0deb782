"""Multiscale (pyramid) layers: which level a run renders, where it sits, and the result's levels.

A multiscale layer holds its image at several resolutions, level 0 the full
one; napari shows the level that fits the zoom (``layer.data_level``) and
draws pixel ``i`` of level ``k`` at the full level's pixel ``i * f``, ``f``
the level's downsampling factor (the full level's shape over the level's).

- A preview renders the level on screen (:func:`shown_level`), placed over
  the layer as napari places it: the layer's scale times the level's factor,
  its translate kept (:func:`level_snapshot`); of that level, only the part on
  screen, as napari loads it, and a margin (:func:`shown_part`), so that a
  preview zoomed in on a large image costs what the screen shows.
- Run renders the full level, and the result is a multiscale layer of as many
  levels as the input, each lower level the 2 × 2 mean of the one above
  (:func:`lower_levels`, the package's own pyramid code), so that every zoom
  shows one pattern, walls one or two pixels wide included.

No napari, no Qt: a snapshot's ``data`` is any sequence of arrays, full level
first (napari's ``MultiScaleData``, a list of numpy, dask or zarr arrays).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from ..io._pyramid import halved, halved_shape
from .choices import LayerSnapshot

__all__ = [
    "PREVIEW_GRID",
    "PREVIEW_MARGIN",
    "downsample_factors",
    "level_snapshot",
    "lower_levels",
    "pyramid_axes",
    "shown_level",
    "shown_part",
]

#: Pixels of the level rendered around the part on screen by a preview: a little panning
#: shows rendered pixels, and the rim the algorithm leaves (``border``) stays off screen.
PREVIEW_MARGIN = 32

#: The part of a level a preview renders starts and ends at multiples of this, in pixels.
PREVIEW_GRID = 256


def downsample_factors(levels: Sequence[Any], ndim: int) -> np.ndarray:
    """The ``(levels, ndim)`` factors of each level over the layer's dimensions, as napari
    computes them: the full level's shape over the level's (a colour axis left out)."""
    shapes = np.array([tuple(level.shape)[:ndim] for level in levels], dtype=float)
    return shapes[0] / shapes


def shown_level(snapshot: LayerSnapshot) -> int:
    """The level the viewer shows (the snapshot's ``data_level``, within the levels)."""
    return int(np.clip(snapshot.data_level, 0, len(snapshot.data) - 1))


def level_snapshot(snapshot: LayerSnapshot, level: int) -> LayerSnapshot:
    """``snapshot`` of a multiscale layer as a plain layer of its ``level``, placed over it.

    The level's scale is the layer's times the level's factor and its
    translate the layer's (rotation, shear and affine kept), so that it sits
    where napari draws it; the plane on screen is the level's plane at the
    full level's ``visible_index``.

    Raises
    ------
    ValueError
        If ``level`` is not one of the layer's levels.
    """
    if not 0 <= level < len(snapshot.data):
        raise ValueError(f"level must be 0 to {len(snapshot.data) - 1}, got {level}")
    factors = downsample_factors(snapshot.data, snapshot.ndim)[level]
    data = snapshot.data[level]
    n_leading = snapshot.ndim - 2
    full_index = np.asarray(snapshot.visible_index, dtype=float)
    visible_index = tuple(
        int(np.clip(np.round(position), 0, size - 1))
        for position, size in zip(
            full_index / factors[:n_leading], data.shape[:n_leading], strict=True
        )
    )
    return dataclasses.replace(
        snapshot,
        data=data,
        multiscale=False,
        data_level=0,
        scale=np.asarray(snapshot.scale, dtype=float) * factors,
        visible_index=visible_index,
        shown_region=snapshot.shown_region if level == shown_level(snapshot) else None,
    )


def shown_part(snapshot: LayerSnapshot, margin: int = PREVIEW_MARGIN) -> LayerSnapshot:
    """``snapshot`` (a level's, :func:`level_snapshot`) cut to its ``shown_region`` and
    ``margin`` pixels around it, out to multiples of ``PREVIEW_GRID`` (a small pan
    keeps the part, and the preview's pattern, as they are), its translate moved so that the part sits where napari
    draws it; the snapshot as it is when no region is known, the region covers the level,
    or the layer is rotated or sheared (its translate would move along other axes).
    """
    region = snapshot.shown_region
    if region is None or not _unrotated(snapshot):
        return snapshot
    y_axis, x_axis = pyramid_axes(snapshot.rgb)
    shape = tuple(snapshot.data.shape)
    bounds = []
    for (start, stop), size in zip(region, (shape[y_axis], shape[x_axis]), strict=True):
        start = max(0, (int(start) - margin) // PREVIEW_GRID * PREVIEW_GRID)
        stop = min(size, -(-(int(stop) + margin) // PREVIEW_GRID) * PREVIEW_GRID)
        if stop - start < 3:  # nothing of the level on screen: render it whole
            return snapshot
        bounds.append((start, stop))
    if [stop - start for start, stop in bounds] == [shape[y_axis], shape[x_axis]]:
        return snapshot
    key = [slice(None)] * len(shape)
    key[y_axis], key[x_axis] = (slice(start, stop) for start, stop in bounds)
    translate = np.array(snapshot.translate, dtype=float)
    scale = np.asarray(snapshot.scale, dtype=float)
    translate[-2:] += scale[-2:] * [start for start, _ in bounds]
    return dataclasses.replace(
        snapshot,
        data=snapshot.data[tuple(key)],
        translate=translate,
        shown_region=tuple(bounds),
    )


def _unrotated(snapshot: LayerSnapshot) -> bool:
    """Whether the layer is neither rotated nor sheared (its data axes are the world's)."""
    shear = np.asarray(snapshot.shear, dtype=float)
    no_shear = np.allclose(shear, np.eye(len(shear))) if shear.ndim == 2 else not shear.any()
    return no_shear and np.allclose(snapshot.rotate, np.eye(len(snapshot.rotate)))


def pyramid_axes(rgb: bool) -> tuple[int, int]:
    """The axes a result's levels halve: Y and X (before the colour axis of RGB data)."""
    return (-3, -2) if rgb else (-2, -1)


def lower_levels(full: Any, count: int, rgb: bool) -> Iterator[Any]:
    """The ``count - 1`` levels below a rendered ``full`` level, each the 2 × 2 mean of the
    one above in Y and X (``io._pyramid``), the levels of other axes kept.

    A numpy level gives numpy levels; a dask level gives lazy levels, each plane
    halved when napari shows it; any other array (a lazy result's store on disk,
    whose planes are rendered in the background) gives :class:`HalvedOnRead`
    levels, which halve the planes as they are when napari reads them.
    """
    axes = tuple(axis % len(full.shape) for axis in pyramid_axes(rgb))
    level = full
    for _ in range(count - 1):
        if isinstance(level, np.ndarray):
            level = halved(level, axes)
        elif _is_dask(level):
            level = _halved_lazily(level, axes)
        else:
            level = HalvedOnRead(level, axes)
        yield level


class HalvedOnRead:
    """An array ``source`` halved along ``axes`` (``io._pyramid.halved``) each time it is read.

    A level of a result whose planes are still being written (a dask level
    would keep what napari's cache held of a plane read before it was
    rendered): reading ``level[key]`` reads the planes ``key`` selects, whole
    over ``axes``, from the source and halves them.

    Parameters
    ----------
    source : array-like
        ``shape``, ``dtype`` and ``source[key]`` for ints and slices.
    axes : sequence of int
        The axes halved (non-negative).
    """

    def __init__(self, source: Any, axes: Sequence[int]) -> None:
        self.source = source
        self.axes = tuple(sorted({int(axis) % len(source.shape) for axis in axes}))
        self.shape = halved_shape(tuple(source.shape), self.axes)
        self.dtype = np.dtype(source.dtype)
        self.ndim = len(self.shape)

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        whole = self[(slice(None),) * self.ndim]
        return whole if dtype is None else whole.astype(dtype)

    def __getitem__(self, key: Any) -> np.ndarray:
        key = _full_key(key, self.ndim)
        if not all(isinstance(k, (slice, int, np.integer)) for k in key):
            return np.asarray(self)[key]  # fancy indexing: from the whole level
        outer = tuple(slice(None) if axis in self.axes else k for axis, k in enumerate(key))
        block = np.asarray(self.source[outer])
        kept = [axis for axis, k in enumerate(key) if axis in self.axes or isinstance(k, slice)]
        small = halved(block, [kept.index(axis) for axis in self.axes])
        return small[tuple(key[axis] if axis in self.axes else slice(None) for axis in kept)]


def _full_key(key: Any, ndim: int) -> tuple[Any, ...]:
    """``key`` as a tuple of one entry per axis (an ``Ellipsis`` expanded, the rest padded)."""
    key = key if isinstance(key, tuple) else (key,)
    if any(k is Ellipsis for k in key):
        at = next(i for i, k in enumerate(key) if k is Ellipsis)
        key = key[:at] + (slice(None),) * (ndim - len(key) + 1) + key[at + 1 :]
    return key + (slice(None),) * (ndim - len(key))


def _is_dask(data: Any) -> bool:
    return type(data).__module__.startswith("dask.")


def _halved_lazily(image: Any, axes: tuple[int, ...]):
    """A dask ``image`` halved along ``axes``, block by block, each block a whole plane."""
    whole = image.rechunk({axis: -1 for axis in axes})
    shape = halved_shape(image.shape, axes)
    chunks = tuple(
        (shape[axis],) if axis in axes else sizes for axis, sizes in enumerate(whole.chunks)
    )
    return whole.map_blocks(halved, axes=axes, chunks=chunks, dtype=image.dtype)
