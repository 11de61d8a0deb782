"""The previous implementation of ``napari_labyrinth.metrics``, kept as the tests' oracle.

Unchanged but for this paragraph: scipy and scikit-image filters over
float64 planes, one metric at a time. ``tests/metrics/test_metrics_reference.py``
checks the current implementation against it; ``benchmarks/bench_metrics.py``
times both.

Numbers that describe a labyrinthine tiling and the edges it enhances.

Every metric works on 2-D grayscale planes of any real dtype and is
deterministic. Images are compared on the same footing by converting them to
float64; metrics that compare an input with its rendering take both on the
same tone scale (for uint8, the paper's 0-255).

The fine-scale component of an image, used by several metrics, is
``h = g - G_1 * g`` (the image minus its Gaussian blur with sigma 1 pixel):
it holds the 1-3 pixel structure that the tiling draws.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np

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

# Lag vectors (dy, dx) of the four lattice directions and of their normals.
_DIRECTIONS = ((0, 1), (1, 0), (1, 1), (1, -1))
_NORMALS = ((1, 0), (0, 1), (1, -1), (1, 1))


def _memoise_on_plane(function):
    """Cache the last few results of ``function(plane)`` by the plane's content.

    :func:`describe` asks several metrics for the same wall map and
    orientation field; the cache makes it compute each once.
    """
    cache: dict = {}

    @functools.wraps(function)
    def wrapper(image):
        plane = _plane(image)
        key = (plane.shape, hashlib.blake2b(plane.tobytes(), digest_size=16).digest())
        if key not in cache:
            if len(cache) >= 4:
                cache.pop(next(iter(cache)))
            result = function(plane)
            for array in result if isinstance(result, tuple) else (result,):
                array.flags.writeable = False  # shared by every caller
            cache[key] = result
        return cache[key]

    return wrapper


def _plane(image, name="image") -> np.ndarray:
    array = np.asarray(image)
    if array.ndim != 2:
        raise ValueError(f"{name} must be a 2-D grayscale plane, got shape {array.shape}")
    if array.dtype.kind not in "uif" or array.dtype == np.bool_:
        raise TypeError(f"{name} must hold real numbers, got dtype {array.dtype}")
    if min(array.shape) < 3:
        raise ValueError(f"{name} must be at least 3 x 3 pixels, got shape {array.shape}")
    return array.astype(np.float64)


def fine_scale(image) -> np.ndarray:
    """The fine-scale component ``h = g - G_1 * g`` of a plane."""
    from scipy import ndimage

    plane = _plane(image)
    return plane - ndimage.gaussian_filter(plane, 1.0, mode="reflect")


def texture_added(original, rendered) -> float:
    """Fine-scale energy of ``rendered`` over that of ``original``.

    ``E(g) = mean(h**2)`` with h the fine-scale component. 1 means no texture
    was added, above 1 texture was added, below 1 the image was smoothed.
    """
    before = float(np.mean(fine_scale(original) ** 2))
    after = float(np.mean(fine_scale(rendered) ** 2))
    if before == 0.0:
        return np.inf if after > 0 else 1.0
    return after / before


def _local_correlation(h: np.ndarray, energy: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """``G * (h(p) h(p + d)) / G * h**2``, symmetric in d, with G a Gaussian window."""
    from scipy import ndimage

    product = h * np.roll(h, (-dy, -dx), axis=(0, 1))
    product = 0.5 * (product + np.roll(product, (dy, dx), axis=(0, 1)))
    return ndimage.gaussian_filter(product, WINDOW_SIGMA) / np.maximum(energy, 1e-12)


@_memoise_on_plane
def wall_map(image) -> np.ndarray:
    """Boolean map of pixels covered by oriented, wall-like fine texture.

    A pixel is on a wall where, for one of the four lattice directions d
    with normal n, the fine-scale component h is locally correlated along d
    (``C(d) > ALONG_THRESHOLD``: walls continue) and alternates across it
    (``C(w n) < -ALTERNATION_THRESHOLD`` and ``C(2 w n) > ALTERNATION_THRESHOLD``
    for a wall width w of 1 or 2 pixels), in a region that is not flat (local
    RMS of h above ``ENERGY_FLOOR`` tones). ``C`` is the local lag
    correlation over a Gaussian window of sigma ``WINDOW_SIGMA``. White and
    salt-and-pepper noise are not correlated along any direction; smooth
    edges and blur do not alternate.
    """
    from scipy import ndimage

    h = fine_scale(image)
    energy = ndimage.gaussian_filter(h * h, WINDOW_SIGMA)
    walls = np.zeros(h.shape, dtype=bool)
    for (ay, ax), (ny, nx) in zip(_DIRECTIONS, _NORMALS):
        along = _local_correlation(h, energy, ay, ax) > ALONG_THRESHOLD
        for w in (1, 2):
            opposite = _local_correlation(h, energy, w * ny, w * nx) < -ALTERNATION_THRESHOLD
            again = _local_correlation(h, energy, 2 * w * ny, 2 * w * nx) > ALTERNATION_THRESHOLD
            walls |= along & opposite & again
    return walls & (energy > ENERGY_FLOOR**2)


def labyrinth_cover(image) -> float:
    """Fraction of the image covered by labyrinth walls (see :func:`wall_map`)."""
    return float(np.mean(wall_map(image)))


def wall_width(image) -> float:
    """Characteristic width of the walls, in pixels, from how often tones cross over.

    Walls and gaps are the signs of ``g - G_2 * g`` (the image minus its local
    mean). Along a line at angle phi across walls of width w running at angle
    theta the sign changes ``|sin(phi - theta)| / w`` times per pixel, on
    average ``2 / (pi w)`` over all phi (Cauchy-Crofton). The rate is counted
    between neighbours on the wall map along the four lattice directions
    (diagonal steps are sqrt(2) long), averaged, and inverted:
    ``w = 2 / (pi * rate)``. NaN when walls cover less than ``MIN_COVER`` of
    the image: there is no wall to measure.
    """
    from scipy import ndimage

    plane = _plane(image)
    walls = wall_map(plane)
    if walls.mean() < MIN_COVER:
        return float("nan")
    positive = plane > ndimage.gaussian_filter(plane, 2.0)
    rates = []
    for dy, dx in _DIRECTIONS:
        both = walls & np.roll(walls, (-dy, -dx), axis=(0, 1))
        flips = positive != np.roll(positive, (-dy, -dx), axis=(0, 1))
        rates.append(flips[both].mean() / np.hypot(dy, dx))
    rate = float(np.mean(rates))
    return 2.0 / (np.pi * rate) if rate > 0 else float("inf")


def orientation(image, sigma: float = WINDOW_SIGMA):
    """Dominant local orientation and its coherence from the structure tensor.

    The plane is first upsampled twice (linear interpolation): the central
    differences of the structure tensor cannot see a pattern at the Nyquist
    frequency (1-pixel walls), its double can. The tensor of
    ``skimage.feature.structure_tensor`` with a window of ``sigma`` original
    pixels, of the doubled plane extended by its edge values (no edge at the
    frame: the tensor of a plane plus a constant is the plane's), is then
    sampled back on the original grid. Returns
    ``(angle, coherence, strength)``: the angle (radians, modulo pi) of the
    local gradient direction, the coherence ``((l1 - l2) / (l1 + l2))**2`` in
    [0, 1] of the eigenvalues ``l1 >= l2``, and ``l1 + l2``.
    """
    from scipy import ndimage
    from skimage.feature import structure_tensor

    doubled = ndimage.zoom(_plane(image), 2, order=1, grid_mode=True, mode="nearest")
    reach = int(4 * 2 * sigma + 0.5) + 2  # the Gaussian's (truncated at 4 sigma), the Sobel's
    extended = np.pad(doubled, reach, mode="edge")
    inside = (slice(reach, -reach, 2), slice(reach, -reach, 2))
    jrr, jrc, jcc = (t[inside] for t in structure_tensor(extended, 2 * sigma, order="rc"))
    trace = jrr + jcc
    difference = np.sqrt((jrr - jcc) ** 2 + 4 * jrc**2)
    coherence = np.where(trace > 0, (difference / np.maximum(trace, 1e-12)) ** 2, 0.0)
    angle = 0.5 * np.arctan2(2 * jrc, jrr - jcc)
    return angle, coherence, trace


@_memoise_on_plane
def _wall_orientation(plane):
    return orientation(fine_scale(plane))


def orientation_coherence(image) -> float:
    """How parallel the walls are: mean structure-tensor coherence on the wall map.

    The coherence of :func:`orientation` of the fine-scale component,
    averaged over the pixels of :func:`wall_map` with the tensor's strength
    as weight: near 1 for long parallel walls (a fingerprint texture), lower
    for a maze of short turning walls. NaN where there are no walls.
    """
    plane = _plane(image)
    walls = wall_map(plane)
    if walls.mean() < MIN_COVER:
        return float("nan")
    _, coherence, strength = _wall_orientation(plane)
    weight = strength * walls
    return float((coherence * weight).sum() / weight.sum())


def contour_alignment(original, rendered, *, contour_sigma: float = 4.0) -> float:
    """How well the rendered walls run along the contours of the input.

    The weighted mean, over the walls of ``rendered`` (:func:`wall_map`), of
    ``cos**2`` of the angle between the local orientation of the walls and
    that of the input's contours (structure tensor at ``contour_sigma``),
    weighted by both coherences and strengths. 1: walls parallel to the
    contours; 0.5: no relation; 0: walls across the contours. NaN where walls
    cover less than ``MIN_COVER`` of the image or the input has no contours.
    """
    before, after = _plane(original, "original"), _plane(rendered, "rendered")
    if before.shape != after.shape:
        raise ValueError(f"original {before.shape} and rendered {after.shape} differ in shape")
    walls = wall_map(after)
    if walls.mean() < MIN_COVER:
        return float("nan")
    wall_angle, wall_coherence, wall_strength = _wall_orientation(after)
    contour_angle, contour_coherence, contour_strength = orientation(before, contour_sigma)
    weight = walls * wall_coherence * wall_strength * contour_coherence * contour_strength
    total = weight.sum()
    if total <= 0:
        return float("nan")
    return float((np.cos(wall_angle - contour_angle) ** 2 * weight).sum() / total)


def edge_enhancement(original, rendered) -> float:
    """Correlation of the texture a rendering adds with the edges of the input.

    Pearson correlation between the fine-scale energy added locally,
    ``G_2 * h_rendered**2 - G_2 * h_original**2``, and the Sobel gradient
    magnitude of the input. Near 1 when the rendering draws texture on the
    input's edges (the edge-detector look of the paper's Fig. 4), near 0 when
    it adds texture everywhere alike (noise), negative when it removes
    texture from the edges (blur), 0 when nothing changed.
    """
    from scipy import ndimage
    from skimage.filters import sobel

    before, after = _plane(original, "original"), _plane(rendered, "rendered")
    if before.shape != after.shape:
        raise ValueError(f"original {before.shape} and rendered {after.shape} differ in shape")
    added = ndimage.gaussian_filter(fine_scale(after) ** 2 - fine_scale(before) ** 2, WINDOW_SIGMA)
    edges = sobel(before)
    if added.std() == 0 or edges.std() == 0:
        return 0.0
    return float(np.corrcoef(added.ravel(), edges.ravel())[0, 1])


def describe(original, rendered) -> dict[str, float]:
    """Every metric of a rendering of ``original``, as a dict of floats."""
    return {
        "texture_added": texture_added(original, rendered),
        "labyrinth_cover": labyrinth_cover(rendered),
        "wall_width": wall_width(rendered),
        "orientation_coherence": orientation_coherence(rendered),
        "contour_alignment": contour_alignment(original, rendered),
        "edge_enhancement": edge_enhancement(original, rendered),
    }
