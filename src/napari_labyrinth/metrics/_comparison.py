"""The metrics of renderings of one original, its own maps computed once (:class:`Comparison`)."""

from __future__ import annotations

import weakref
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..core.tone_scale import resolve_tone_scale
from ._bands import _copy_in_bands, _validate_workers
from ._caches import _SHARED_POOL
from ._definitions import METRICS
from ._edges import _edge_enhancement
from ._maps import _Maps
from ._orientation import _contour_alignment, _orientation_coherence
from ._planes import _kernel_dtype, _plane, _same_shape
from ._texture import _texture_added
from ._walls import _wall_width


class Comparison:
    """The metrics of renderings of one original, its own maps computed once.

    The passes of a stack are renderings of the same input: the original's
    fine-scale energy, Sobel edges and contour orientation are computed on
    first use and kept for the renderings that follow (the contours only
    where the walls of some rendering need them), and the arrays of a
    rendering's maps serve the next one. Thread-safe (several threads may
    describe renderings at once); the original is copied, so the caller may
    change its array afterwards.

    Parameters
    ----------
    original : array_like
        The input plane: 2-D, real dtype, at least 3 x 3, on the tone scale
        of the renderings, or mapped there by ``tone_limits``.
    tone_limits : (float, float), optional
        The values that the rendering mapped to tones 0 and 255 (its
        ``Result.tone_limits``, or the ``tone_limits`` it was given): the
        original and every rendering are measured on that tone scale
        (``ToneScale.to_tones``, values outside clipped), where the metrics'
        bounds lie (:data:`ENERGY_FLOOR` is in tones). None: the planes are
        tones already (a uint8 image rendered on the paper's 0-255 scale).
    workers : int, optional
        Threads the heavy maps are split between (bands of rows): None for
        every core, else within the bounds of ``labyrinth(workers=...)``
        (``core.parameters.WORKERS``). The results do not depend on it.

    Examples
    --------
    >>> from skimage import data
    >>> from napari_labyrinth import labyrinth_stack
    >>> image = data.camera()
    >>> stack = labyrinth_stack(image, passes=2)
    >>> comparison = Comparison(image)
    >>> rows = [comparison.describe(rendered) for rendered in stack[1:]]
    >>> list(rows[0]) == list(METRICS)
    True
    """

    def __init__(self, original, *, tone_limits: Any = None, workers: int | None = None) -> None:
        workers = _validate_workers(workers)
        array = _plane(original, "original")
        self._scale = None if tone_limits is None else resolve_tone_scale(array, tone_limits)
        array = self._tones(array)
        self._pool = _SHARED_POOL
        plane = self._pool.take(array.shape, _kernel_dtype(array.dtype))
        _copy_in_bands(plane, array, workers)
        # the renderings' walls only; the maps' arrays go back to the pool with the object
        self._maps = _Maps(plane, workers, self._pool, walls=False)
        self._maps._taken.append(plane)
        weakref.finalize(self, self._pool.give_later, self._maps._taken)
        self.workers = workers

    @property
    def shape(self) -> tuple[int, int]:
        return self._maps.plane.shape

    def describe_steps(self, rendered) -> Iterator[tuple[str, float]]:
        """Yield ``(name, value)`` for each metric of ``rendered``, in the order of :data:`METRICS`.

        ``rendered`` is checked and copied by the call; each metric's work
        is done when the generator is asked for it, so a caller that stops
        iterating (or closes the generator) between two metrics skips the
        work of the rest. No thread works after a step (a helper that starts
        late ends without work, see ``_in_bands``; the timer that frees the
        arrays kept for the next maps, ``_Pool``, only waits).

        Examples
        --------
        >>> from skimage import data
        >>> from napari_labyrinth import labyrinth
        >>> image = data.camera()
        >>> for name, value in Comparison(image).describe_steps(labyrinth(image)):
        ...     if name == "labyrinth_cover":
        ...         break  # the other metrics are not computed
        """
        return self._steps(self._rendering_maps(rendered))

    def _tones(self, plane: np.ndarray) -> np.ndarray:
        """``plane`` on the tone scale of ``tone_limits`` (itself without them)."""
        return plane if self._scale is None else self._scale.to_tones(plane)

    def _rendering_maps(self, rendered) -> _Maps:
        """The maps of ``rendered`` (checked, on the tone scale, copied into an array of the
        pool)."""
        after_array = self._tones(_plane(rendered, "rendered"))
        _same_shape(self._maps.plane, after_array)
        plane = self._pool.take(after_array.shape, _kernel_dtype(after_array.dtype))
        _copy_in_bands(plane, after_array, self.workers)
        after = _Maps(plane, self.workers, self._pool)
        after._taken.append(plane)
        return after

    def _steps(self, after: _Maps, wanted=METRICS) -> Iterator[tuple[str, float]]:
        before = self._maps
        try:
            for name in METRICS:
                if name == "contour_alignment":
                    after.give_back_fine()  # the contours take its bytes
                if name in wanted:
                    yield name, _STEPS[name](before, after)
        finally:
            after.release()  # its arrays serve the next rendering

    def describe(self, rendered) -> dict[str, float]:
        """Every metric of ``rendered``, as a dict of floats in the order of :data:`METRICS`."""
        return dict(self.describe_steps(rendered))

    def measure(self, rendered, names) -> dict[str, float]:
        """The metrics ``names`` of ``rendered`` only, as ``describe`` gives them, without
        the work of the others (in the order of :data:`METRICS`).

        Raises
        ------
        ValueError
            For a name that is not one of :data:`METRICS`.
        """
        unknown = [name for name in names if name not in METRICS]
        if unknown:
            raise ValueError(f"unknown metrics {unknown}; the metrics are {list(METRICS)}")
        return dict(self._steps(self._rendering_maps(rendered), frozenset(names)))

    def edge_enhancement(self, rendered) -> float:
        """:func:`edge_enhancement` of ``rendered`` alone (the value ``describe`` gives),
        without the work of the other metrics."""
        after = self._rendering_maps(rendered)
        try:
            return _edge_enhancement(self._maps, after)
        finally:
            after.release()


#: Each metric of a rendering (``after``) of an original (``before``), by name.
_STEPS = {
    "texture_added": _texture_added,
    "labyrinth_cover": lambda _before, after: after.cover(),
    "wall_width": lambda _before, after: _wall_width(after),
    "orientation_coherence": lambda _before, after: _orientation_coherence(after),
    "contour_alignment": _contour_alignment,
    "edge_enhancement": _edge_enhancement,
}
