"""Every metric of a rendering at once (:func:`describe`) or one at a time
(:func:`describe_steps`), the original's maps kept by content for its next renderings."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from ..core.tone_scale import validate_tone_limits
from ._bands import _validate_workers
from ._caches import _LastPlane
from ._comparison import Comparison
from ._planes import _plane

#: The :class:`Comparison` of the last original given to :func:`describe`, by content.
_ORIGINALS = _LastPlane()


def describe_steps(
    original, rendered, *, tone_limits: Any = None, workers: int | None = None
) -> Iterator[tuple[str, float]]:
    """Yield ``(name, value)`` for each metric of a rendering of ``original``, one at a time.

    The same values, in the same order, as :func:`describe`; a caller that
    stops iterating (or closes the generator) between two metrics skips the
    work of the others (see :meth:`Comparison.describe_steps`). The maps of
    the last ``original`` are kept, by content, for the next renderings of
    it: a stack's passes compute them once. :class:`Comparison` does the
    same without comparing the original each time. ``tone_limits`` and
    ``workers`` as :class:`Comparison` takes them.
    """
    limits = None if tone_limits is None else validate_tone_limits(tone_limits)
    comparison = _comparison_of(original, _validate_workers(workers), limits)
    return comparison.describe_steps(rendered)


def describe(
    original, rendered, *, tone_limits: Any = None, workers: int | None = None
) -> dict[str, float]:
    """Every metric of a rendering of ``original``, as a dict of floats.

    The keys are :data:`METRICS`, in that order. The metrics share the maps
    they have in common, and the maps of the last ``original`` are kept for
    the next renderings of it (see :func:`describe_steps`). ``tone_limits``:
    the tone scale the planes are measured on, as for :class:`Comparison`
    (for an image other than uint8, the rendering's ``Result.tone_limits``);
    ``workers``: threads, as for :class:`Comparison`; the results do not
    depend on it.
    """
    return dict(describe_steps(original, rendered, tone_limits=tone_limits, workers=workers))


def _comparison_of(original, workers, tone_limits) -> Comparison:
    """The :class:`Comparison` of ``original``, reused while its content (and the tone
    limits) are the same."""

    def make(array):
        comparison = Comparison(array, tone_limits=tone_limits, workers=workers)
        # its copy of the original, unless it holds the original's tones
        return (comparison._maps.plane if tone_limits is None else array.copy()), comparison

    return _ORIGINALS.get((workers, tone_limits), _plane(original, "original"), make)
