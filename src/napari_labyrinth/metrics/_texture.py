"""The fine-scale component of a plane and the texture a rendering adds to it."""

from __future__ import annotations

import math

import numpy as np

from ._maps import _Maps
from ._planes import _kernel_plane, _plane


def fine_scale(image) -> np.ndarray:
    """The fine-scale component ``h = g - G_1 * g`` of a plane."""
    fine, _ = _Maps(_kernel_plane(_plane(image)), walls=False).fine()
    return fine  # a new array, the caller's own


def texture_added(original, rendered) -> float:
    """Fine-scale energy of ``rendered`` over that of ``original``.

    ``E(g) = mean(h**2)`` with h the fine-scale component. 1 means no texture
    was added, above 1 texture was added, below 1 the image was smoothed.
    """
    before = _Maps(_kernel_plane(_plane(original, "original")))
    after = _Maps(_kernel_plane(_plane(rendered, "rendered")))
    before.measure_fine()
    after.measure_fine()
    return _texture_added(before, after)


def _texture_added(before: _Maps, after: _Maps) -> float:
    energy_before = before._fine().total / before.plane.size
    energy_after = after._fine().total / after.plane.size
    if energy_before == 0.0:
        return math.inf if energy_after > 0 else 1.0
    return energy_after / energy_before
