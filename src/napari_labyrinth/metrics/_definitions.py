"""What the metrics are and the bounds they apply: their names in order, the windows,
the thresholds of the wall map, the bounds of the structure tensor's sigma."""

from __future__ import annotations

import dataclasses

from ..core.parameters import Parameter

#: Window (Gaussian sigma, pixels) over which local statistics are averaged.
WINDOW_SIGMA = 2.0

#: Local lag-1 correlation along the walls above which texture counts as walls.
ALONG_THRESHOLD = 0.3

#: Walls alternate with gaps across them: the local correlation across at lag w
#: (w = 1 or 2 pixels, the wall width) must be below -ALTERNATION_THRESHOLD and
#: at lag 2w above +ALTERNATION_THRESHOLD. A single edge anti-correlates at lag
#: w but does not come back at 2w.
ALTERNATION_THRESHOLD = 0.1

#: Local RMS of the fine-scale component (tones) below which a region is flat.
ENERGY_FLOOR = 6.0

#: Least fraction of wall pixels for the wall metrics to be defined (else NaN).
MIN_COVER = 0.01

#: Gaussian sigma of the input's contours in :func:`contour_alignment`.
CONTOUR_SIGMA = 4.0

#: The Gaussian sigma (pixels) of a structure tensor's window: :func:`orientation`'s
#: ``sigma``. Below the least, every window is one pixel wide (from about 0.08 on, the
#: next weight is below float32's resolution). The largest, the scale of a large image's
#: broadest contours, bounds the rows a thread holds smoothed (``16 * sigma + 2`` of a
#: tile: ``_FULL_WIDTH_RING_BYTES``) and the time, which grows with sigma (at the
#: largest, about a minute for a 2048 x 2048 plane on two cores).
SIGMA = Parameter(
    name="sigma",
    kind="float",
    paper=None,
    low=0.01,
    high=256.0,
    label="sigma",
    equation="metrics",
    doc="Gaussian sigma (pixels) of the structure tensor's window",
)

#: :func:`contour_alignment`'s ``contour_sigma``: the bounds of :data:`SIGMA`.
CONTOUR_SIGMA_PARAMETER = dataclasses.replace(
    SIGMA,
    name="contour_sigma",
    label="contour sigma",
    doc="Gaussian sigma (pixels) of the structure tensor of the input's contours",
)

#: The metrics, in the order :func:`describe` and :func:`describe_steps` give them.
METRICS = (
    "texture_added",
    "labyrinth_cover",
    "wall_width",
    "orientation_coherence",
    "contour_alignment",
    "edge_enhancement",
)
