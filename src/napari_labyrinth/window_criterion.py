"""Which V Auto chooses from the curves of its probe, and why (the criterion of the window of V).

:func:`napari_labyrinth.find_window` renders a probe of the image at every V it
probes and measures, at each, what a person sees of the labyrinth: its cover
(:func:`napari_labyrinth.metrics.labyrinth_cover`), how well its walls run
along the image's contours (:func:`~napari_labyrinth.metrics.contour_alignment`),
the texture it adds on the edges
(:func:`~napari_labyrinth.metrics.edge_enhancement`) and the share of pixels it
changed. :func:`choose` reads the V from those curves; it is a pure function of
them, so it is tested on hand-made curves. The study behind the thresholds is
``docs/study/auto.md``.

The rule, in order:

1. A V *draws walls* where walls cover at least ``MIN_COVER`` more of the
   probe than of its input (walls the input has, such as a JPEG's blocks, are
   not the labyrinth's) and at least ``MIN_CHANGED`` of its pixels changed; its walls are *aligned*
   where their contour alignment is at least ``ALIGNED``. Among the V that
   draw aligned walls, those whose cover is at least ``COVER_FRACTION`` of the
   best such cover are the candidates, and Auto takes the candidate with the
   best edge enhancement (ties: the larger cover, then the lower V).
2. When walls are drawn but at no V along the contours, the V that draw walls
   are the candidates, chosen the same way.
3. When no V draws walls (objects too small or too sparse for 1 % of the
   probe), the edge enhancement alone decides, as before the cover was
   measured: its best V.

So Auto never returns a V at which (almost) nothing is drawn while another V
draws walls, and its cover is never far below what the most covering V with
aligned walls reaches.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from .metrics import MIN_COVER

__all__ = [
    "ALIGNED",
    "COVER_FRACTION",
    "MIN_CHANGED",
    "WINDOW_FRACTION",
    "Choice",
    "choose",
]

#: Least share of the probe's pixels a V must change to count as drawing walls.
MIN_CHANGED = 0.01

#: Least contour alignment (``metrics.contour_alignment``: 0.5 for walls unrelated to the
#: contours, 1 for walls along them) of walls that follow the contours. On the probes of
#: the study's images and the hard cases (``benchmarks/auto_table.py``), 98 % of the
#: alignments of walls with their own image's contours reach it, against 36 % of those
#: with the same crops turned by 180 degrees (walls and contours unrelated but for the
#: image's overall orientations): ``docs/study/auto.md``.
ALIGNED = 0.65

#: Auto's cover is at least this fraction of the best cover of the V with aligned walls.
COVER_FRACTION = 0.9

#: The window holds the V around the chosen one, of its rule's candidates, whose edge
#: enhancement is at least this fraction of the chosen V's (the study's 90 %).
WINDOW_FRACTION = 0.9


@dataclasses.dataclass(frozen=True)
class Choice:
    """The V chosen from a probe's curves, as indices into them, and why.

    Attributes
    ----------
    best, low, high : int
        Index of the chosen V and of the window's ends.
    found : bool
        Whether some V draws walls or adds texture on the edges.
    reason : str
        One line on what the chosen V draws, e.g. ``"cover 0.21, aligned 0.74"``.
    """

    best: int
    low: int
    high: int
    found: bool
    reason: str


def choose(
    edge_enhancement: Sequence[float],
    cover: Sequence[float],
    alignment: Sequence[float],
    changed: Sequence[float],
    *,
    input_cover: float = 0.0,
    cover_fraction: float = COVER_FRACTION,
    aligned: float = ALIGNED,
) -> Choice:
    """The V to choose from the curves of a probe, measured at V increasing (see the module).

    Parameters
    ----------
    edge_enhancement, cover, alignment, changed : sequence of float
        The probe's edge enhancement, labyrinth cover, contour alignment and
        share of changed pixels at each V, all of one length (NaN where a
        metric is undefined: no walls, non-finite pixels).
    input_cover : float, optional
        The cover of the probe's input itself: a V draws walls where its cover
        exceeds it by ``MIN_COVER`` (walls the input had, such as a JPEG's
        blocks, are not the labyrinth's).
    cover_fraction, aligned : float, optional
        ``COVER_FRACTION`` and ``ALIGNED``.

    Returns
    -------
    Choice
    """
    curves = [np.asarray(c, dtype=float) for c in (edge_enhancement, cover, alignment, changed)]
    if len({len(c) for c in curves}) != 1 or not len(curves[0]):
        raise ValueError("the curves must be non-empty and of one length")
    edges, covers, alignments, changes = (np.where(np.isfinite(c), c, -np.inf) for c in curves)
    baseline = input_cover if math.isfinite(input_cover) else 0.0
    draws = (covers >= baseline + MIN_COVER) & (changes >= MIN_CHANGED)
    along = draws & (alignments >= aligned)
    if along.any():
        candidates = along & (covers >= cover_fraction * covers[along].max())
        best = _best(edges, covers, candidates)
        reason = f"cover {covers[best]:.2f}, aligned {alignments[best]:.2f}"
    elif draws.any():
        candidates = draws
        best = _best(edges, covers, candidates)
        shown = f"{alignments[best]:.2f}" if math.isfinite(alignments[best]) else "unmeasured"
        reason = f"cover {covers[best]:.2f}, aligned {shown}: no V draws walls along the contours"
    else:
        candidates = np.ones(len(edges), dtype=bool)
        best = _best(edges, np.zeros(len(edges)), candidates)
        if not edges[best] > 0:
            return Choice(best, best, best, False, "no V draws the labyrinth on the edges")
        reason = (
            f"no V draws walls on {MIN_COVER:.0%} of the probe; edge enhancement {edges[best]:.2f}"
        )
    floor = WINDOW_FRACTION * edges[best] if edges[best] > 0 else -np.inf
    inside = candidates & (edges >= floor)
    low = best
    while low > 0 and inside[low - 1]:
        low -= 1
    high = best
    while high < len(edges) - 1 and inside[high + 1]:
        high += 1
    return Choice(best, low, high, True, reason)


def _best(edges: np.ndarray, covers: np.ndarray, candidates: np.ndarray) -> int:
    """The candidate of the best edge enhancement; ties: the larger cover, then the lower V."""
    indices = np.flatnonzero(candidates)
    return int(min(indices, key=lambda k: (-edges[k], -covers[k], k)))
