"""Numbers that describe a labyrinthine tiling and the edges it enhances.

Every metric works on 2-D grayscale planes of any real dtype and is
deterministic. Images are compared on the same footing by converting them to
float64; metrics that compare an input with its rendering take both on the
same tone scale (for uint8, the paper's 0-255).

The fine-scale component of an image, used by several metrics, is
``h = g - G_1 * g`` (the image minus its Gaussian blur with sigma 1 pixel):
it holds the 1-3 pixel structure that the tiling draws.

:func:`describe` computes every metric at once, sharing the maps they have in
common; :func:`describe_steps` yields them one at a time (a caller can stop
between two), and :class:`Comparison` keeps the maps of an original for the
renderings of it that follow (the passes of a stack). The heavy work runs in
numba kernels (:mod:`._kernels`) that release the GIL, on
``workers`` threads. The Gaussian windows, the fine-scale component and the
wall map are those of ``scipy.ndimage.gaussian_filter``, bit for bit; the
structure tensors are float32, and those behind ``orientation_coherence``
and ``contour_alignment`` are decimated: the window is within a few per cent
of :func:`orientation`'s (see :mod:`._kernels` and ``docs/metrics.md``).

Where things are: the definitions and bounds in ``_definitions``; one module
per family of metrics (``_texture``, ``_walls``, ``_orientation``,
``_edges``); every metric at once in ``_comparison`` (:class:`Comparison`)
and ``_describe``; the maps the metrics share in ``_maps`` (kept between
calls in ``_caches``), the structure tensor in ``_tensor``; the kernels in
``_kernels``, run on bands of rows by ``_bands``.
"""

from ._comparison import Comparison
from ._definitions import (
    ALONG_THRESHOLD,
    ALTERNATION_THRESHOLD,
    CONTOUR_SIGMA,
    CONTOUR_SIGMA_PARAMETER,
    ENERGY_FLOOR,
    METRICS,
    MIN_COVER,
    SIGMA,
    WINDOW_SIGMA,
)
from ._describe import describe, describe_steps
from ._edges import edge_enhancement
from ._orientation import contour_alignment, orientation, orientation_coherence
from ._texture import fine_scale, texture_added
from ._walls import labyrinth_cover, wall_map, wall_width

__all__ = [
    "ALONG_THRESHOLD",
    "ALTERNATION_THRESHOLD",
    "CONTOUR_SIGMA",
    "CONTOUR_SIGMA_PARAMETER",
    "ENERGY_FLOOR",
    "METRICS",
    "MIN_COVER",
    "SIGMA",
    "WINDOW_SIGMA",
    "Comparison",
    "contour_alignment",
    "describe",
    "describe_steps",
    "edge_enhancement",
    "fine_scale",
    "labyrinth_cover",
    "orientation",
    "orientation_coherence",
    "texture_added",
    "wall_map",
    "wall_width",
]
