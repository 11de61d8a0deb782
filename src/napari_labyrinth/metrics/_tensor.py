"""The structure tensor of a plane through the kernels: every pixel (:func:`orientation`'s),
or the rows of column tiles that hold a mask's pixels, on the doubled grid or decimated
(``_DECIMATED_SIGMA``), derived maps or components."""

from __future__ import annotations

import numpy as np

from ._bands import _in_bands
from ._lazy_kernels import _numba_kernels, _weights

#: Least sigma (pixels) of the walls' and contours' structure tensors computed on the
#: original grid after a 1-2-1 filter of the doubled grid's products
#: (``_kernels.decimated_tensor_band``); below, that filter's variance would be
#: too large a part of the window's, and the tensor is the doubled grid's.
_DECIMATED_SIGMA = 1.0


def _orientation_maps(plane, scale, sigma, mode, workers, needed, outputs):
    """Structure-tensor maps of ``plane * scale`` into ``outputs`` (four float32 planes).

    ``needed``: the rows of column tiles to compute (see
    ``_kernels.orientation_band``), None for every pixel.
    """
    kernels = _numba_kernels()
    weights = _weights(2 * sigma, np.float32)
    if needed is None:
        radius = weights.shape[0] - 1
        tiles = 1
        if _ring_bytes(radius, plane.shape[1]) > _FULL_WIDTH_RING_BYTES:
            tiles = kernels.tensor_tiles(plane.shape[1], radius)
        needed = np.ones((plane.shape[0], tiles), dtype=bool)
    _in_bands(
        kernels.orientation_band,
        plane.shape[0],
        workers,
        kernels.plane_tuple(plane),
        scale,
        weights,
        mode,
        needed,
        *outputs,
    )
    return outputs


#: Bytes of the ring of smoothed rows a thread holds (``_kernels.orientation_band``'s)
#: above which a whole plane's tensor is computed in column tiles: a wide sigma's ring
#: grows with it, the tiles' recomputed margins cost time (a fifth at sigma 2).
_FULL_WIDTH_RING_BYTES = 16 * 2**20


def _ring_bytes(radius: int, tile: int) -> int:
    """Bytes of the ring of ``_kernels.orientation_band`` for a kernel ``radius`` and a
    ``tile`` of columns."""
    return 3 * (2 * radius + 2) * tile * np.dtype(np.float32).itemsize


def _tile_counts(walls: np.ndarray, tiles: int, workers) -> np.ndarray:
    """The pixels of ``walls`` in each row of ``tiles`` column tiles (see
    ``orientation_band``)."""
    counts = np.empty((walls.shape[0], tiles), dtype=np.int64)
    _in_bands(_numba_kernels().mask_counts, walls.shape[0], workers, walls, counts)
    return counts


def _wall_orientation(plane, scale, sigma, workers, walls):
    """The derived tensor maps (``TENSOR_DERIVED``) of ``plane * scale`` at the pixels of
    ``walls`` only, after the rows' starts (see :meth:`_Maps.wall_orientation`)."""
    kernels = _numba_kernels()
    counts = _tile_counts(walls, _tensor_tiles(plane.shape[1], sigma), workers)
    starts = kernels.mask_starts(counts)
    row_starts = np.append(starts[:, 0], starts[-1, -1] + counts[-1, -1])
    outputs = tuple(np.empty((1, int(row_starts[-1])), dtype=np.float32) for _ in range(4))
    if _decimated(sigma):
        _tensor(plane, scale, sigma, workers, counts > 0, outputs, starts, walls)
        return (row_starts, *(output[0] for output in outputs))
    planes = tuple(np.empty(plane.shape, dtype=np.float32) for _ in range(4))
    _tensor(plane, scale, sigma, workers, counts > 0, planes)
    return (row_starts, *(map_[walls] for map_ in planes))


def _decimated(sigma: float) -> bool:
    """Whether the structure tensor at ``sigma`` is decimated (see ``_DECIMATED_SIGMA``)."""
    return sigma >= _DECIMATED_SIGMA


def _tensor_weights(sigma: float) -> np.ndarray:
    """The float32 Gaussian half-kernel of the structure tensor at ``sigma`` (original pixels)."""
    if _decimated(sigma):
        return _weights(_numba_kernels().decimated_sigma(sigma), np.float32)
    return _weights(2 * sigma, np.float32)  # on the doubled grid


def _tensor_tiles(width: int, sigma: float) -> int:
    """Column tiles of the structure tensor at ``sigma`` when only some pixels are asked for."""
    return _numba_kernels().tensor_tiles(width, _tensor_weights(sigma).shape[0] - 1)


def _tensor(
    plane, scale, sigma, workers, needed, outputs, starts=None, mask=None, *, components=False
):
    """The derived maps (``TENSOR_DERIVED``) of the structure tensor of ``plane * scale`` at
    ``sigma`` into ``outputs``, on the rows of column tiles ``needed``; with ``components``,
    its components (``TENSOR_COMPONENTS``: three outputs).

    From ``sigma = _DECIMATED_SIGMA`` on, the decimated tensor
    (``_kernels.decimated_tensor_band``; with ``starts``, at the
    pixels of ``mask`` only, one after the other); below, the doubled
    grid's (:func:`orientation`'s).
    """
    kernels = _numba_kernels()
    mode = kernels.TENSOR_COMPONENTS if components else kernels.TENSOR_DERIVED
    if components:
        outputs = (*outputs, np.empty((1, 1), dtype=np.float32))  # not written
    if not _decimated(sigma):
        outputs = _orientation_maps(plane, scale, sigma, mode, workers, needed, outputs)
        return outputs[:3] if components else outputs
    weights = _tensor_weights(sigma)
    if starts is None:
        starts = np.empty((0, 0), dtype=np.int64)
        mask = np.empty((0, 0), dtype=bool)
    _in_bands(
        kernels.decimated_tensor_band,
        plane.shape[0],
        workers,
        kernels.plane_tuple(plane),
        scale,
        weights,
        mode,
        needed,
        starts,
        mask,
        *outputs,
    )
    return outputs[:3] if components else outputs
