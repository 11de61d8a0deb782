"""The metrics of every pass of a stack, measured on the plane on screen while the run renders.

:class:`PassMetrics` receives the run's progress events, measures a pass as
soon as every plane at the position on screen has reported it, and keeps one
row per pass (the rows of :data:`~napari_labyrinth.widget.text.METRIC_ROWS`).
"""

from __future__ import annotations

import math

import numpy as np

from .. import api, metrics
from ..core.colour import luminance, resolve_colour
from ..core.planes import PlaneLayout, first_plane_index
from .plan import Cancelled, RenderPlan
from .text import METRIC_ROWS

__all__ = ["PassMetrics", "visible_planes"]


def _grey(plane: np.ndarray, rgb: bool) -> np.ndarray:
    """A 2-D plane of the values the metrics measure (in tones): the luminance of a colour
    plane."""
    if rgb:
        return luminance(np.asarray(plane), axis=-1)
    return np.asarray(plane)


class PassMetrics:
    """Pattern and edge metrics of every pass of a stack, on the plane on screen.

    A pass is measured as soon as every plane at the position on screen (one,
    or one per colour channel) has reported it; the original's own maps are
    computed once for all passes. The planes are measured on the tone scale
    the passes ran on (``Progress.tone_limits``), where the metrics' bounds
    lie (``metrics.ENERGY_FLOOR`` is in tones): the same image as uint8,
    uint16 or float in [0, 1] gets the same numbers.
    """

    def __init__(self, plan: RenderPlan, data: np.ndarray) -> None:
        self.rgb = plan.rgb
        self.index = () if plan.source_index is not None else tuple(plan.visible_index)
        self.original: np.ndarray | None = _grey(data[self.index], self.rgb)
        self.comparison: metrics.Comparison | None = None  # from the first pass measured
        colour = plan.arguments.get("colour")
        self.planes = visible_planes(data.shape, self.index, self.rgb, colour)
        self.waiting: dict[int, set[int]] = {}
        self.previous = np.asarray(data[self.index])
        self.rows: list[dict[str, float]] = []

    def ready(self, event: api.Progress) -> bool:
        """Whether ``event`` completes a pass at the position on screen."""
        if event.plane not in self.planes:
            return False
        waiting = self.waiting.setdefault(event.pass_number, set(self.planes))
        waiting.discard(event.plane)
        return not waiting

    def measure(
        self, stack: np.ndarray, pass_number: int, should_stop, tone_limits: tuple[float, float]
    ) -> None:
        """Measure pass ``pass_number`` of ``stack``, on the tone scale of ``tone_limits``;
        raise :class:`~napari_labyrinth.widget.plan.Cancelled` between metrics."""
        if self.original is not None:
            try:
                self.comparison = metrics.Comparison(self.original, tone_limits=tone_limits)
            except ValueError:  # a plane too small for the metrics' windows: rows of NaN
                self.comparison = None
            self.original = None  # the comparison holds its tones
        rendered = np.asarray(stack[(pass_number,) + self.index])
        row: dict[str, float] = {"pass": pass_number}
        row.update({key: math.nan for key, _, function in METRIC_ROWS if function})
        if self.comparison is not None:
            for name, value in self.comparison.describe_steps(_grey(rendered, self.rgb)):
                if should_stop():
                    raise Cancelled
                row[name] = value
        changed = rendered != self.previous
        if rendered.dtype.kind == "f":  # a NaN pixel that stays NaN is unchanged
            changed &= ~(np.isnan(rendered) & np.isnan(self.previous))
        row["changed"] = 100.0 * float((changed.any(axis=-1) if self.rgb else changed).mean())
        self.rows.append(row)
        self.previous = rendered


def visible_planes(
    shape: tuple[int, ...], index: tuple[int, ...], rgb: bool, colour: str | None = None
) -> set[int]:
    """Flat indices (the API's plane order, ``Progress.plane``) of the planes rendered at
    ``index`` of the data: one per colour channel but alpha, or the first channel's alone
    when the luminance is rendered."""
    channel_axis = -1 if rgb else None
    first = first_plane_index(shape, index, channel_axis)
    if not rgb or resolve_colour(colour, shape, -1) == "luminance":
        return {first}
    layout = PlaneLayout(tuple(shape), len(shape) - 1)
    return {
        first + k
        for k in range(shape[-1])
        if not layout.is_alpha(np.unravel_index(first + k, layout.leading_shape))
    }
