"""The window of V: where the labyrinth is drawn along the image's contours, measured on a probe.

The labyrinth appears only in a range of the variance threshold V of Eq. 4
(the paper's Fig. 3): below it the walls flood smooth and dark regions, above
it they fade and the smoothing of Eq. 2 takes over. Its position moves with
the image's brightness, because the ratios of Eq. 2 and 4 are relative to the
local mean M. The study behind the presets (``docs/study/``) measured it by
the *edge enhancement* (:func:`napari_labyrinth.metrics.edge_enhancement`);
on smooth noisy textures that score is best where almost nothing is drawn,
so Auto weighs what a person sees: the walls' cover, their alignment with the
contours and the edge enhancement (:mod:`napari_labyrinth.window_criterion`).

:func:`find_window` measures those curves on a *probe* of the image instead of
the whole image: a few crops at full resolution (the pattern is 1-2 pixels
wide, so a downsampled copy would be another image), drawn from strata of
local contrast so that edges, texture and flat background each get their
share. ``benchmarks/bench_window.py`` checks that the probe's window predicts
the full image's, and times it.
"""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor
from typing import Any, NamedTuple

import numpy as np

from . import metrics
from ._engine import run_pass
from ._inputs import prepare_image, validate_workers
from .core.parameters import FLOAT_DECIMALS, PARAMETERS, SEED, as_float
from .core.planes import normalise_channel_axis
from .core.presets import DEFAULT_PRESET, resolve_parameters
from .lazy import checked_lazy, is_lazy
from .window_criterion import WINDOW_FRACTION, Choice, choose

__all__ = [
    "CROPS",
    "CROP_SIZE",
    "THRESHOLD_FACTORS",
    "WIDEN_STEPS",
    "WINDOW_FRACTION",
    "Window",
    "find_window",
]

#: V probed, as factors of the preset's V: 1/16 to 8 times it in steps of
#: sqrt(2) (0.0025 to 0.32 around the labyrinth preset's 0.04: bright images
#: want a low V, dark ones a high V). Factors keep the grid on the scale of
#: either variance ratio of Eq. 4. The V probed are rounded to ``FLOAT_DECIMALS``
#: (the parameter table's precision of a typed V), so that the V chosen is
#: the V a form shows and runs.
THRESHOLD_FACTORS = tuple(float(f) for f in np.round(2.0 ** (np.arange(-8, 7) / 2.0), 4))

#: V probed above the grid, at most, when the best V is its highest (the grid's
#: step continued). Only upwards: as V falls to 0 every pixel with any variance
#: passes Eq. 4's test and the rendering tends to a limit, so the curve flattens
#: there (the lowest four V of the default grid agree within 1 % on the test
#: images) and a best V at the bottom only says the window goes on; above the
#: grid the curve may still rise, until the smoothing of Eq. 2 takes over.
WIDEN_STEPS = 4

#: Crops of the probe and their side in pixels.
CROPS = 6
CROP_SIZE = 128

#: Planes of a stack the crops are drawn from (evenly spaced).
MAX_PLANES = 4

#: Subsampling step of the contrast map that ranks the candidate crops.
_RANK_STEP = 4


@dataclasses.dataclass(frozen=True)
class Window:
    """The window of V of an image, the V chosen in it and why, and the curves they were read from.

    Attributes
    ----------
    low, best, high : float
        The window's ends and the V chosen (Eq. 4's V, on the scale of the
        preset's ``variance_ratio``): see :mod:`napari_labyrinth.window_criterion`.
        When no V draws walls or adds texture on the edges (``found`` is
        False), all three are the preset's V.
    found : bool
        Whether some V draws walls or gives a positive edge enhancement.
    thresholds : tuple of float
        The V probed, increasing.
    edge_enhancement : tuple of float
        The probe's edge enhancement at each V.
    changed : tuple of float
        Fraction of the probe's pixels each V changed.
    crops : tuple of (int, int, int)
        Where the probe was taken: ``(plane, top, left)`` of each crop, plane
        being the flat index of a rendered plane (or luminance position).
    crop_size : int
        Side of the crops (smaller when the image is).
    low_open, high_open : bool
        Whether the window reaches the lowest (highest) V probed: the V there
        still met the window's test, so the window may extend beyond it
        (and, when ``best`` is that V, a better V may lie beyond it).
    cover : tuple of float
        The probe's labyrinth cover at each V (``metrics.labyrinth_cover``).
    alignment : tuple of float
        The contour alignment of the probe's walls at each V
        (``metrics.contour_alignment``; NaN where walls cover less than 1 %).
    input_cover : float
        The labyrinth cover of the probe's input itself: walls a rendering
        draws are those beyond it.
    reason : str
        Why ``best`` was chosen, in one line: ``"cover 0.21, aligned 0.74"``.
    """

    low: float
    best: float
    high: float
    found: bool
    thresholds: tuple[float, ...]
    edge_enhancement: tuple[float, ...]
    changed: tuple[float, ...]
    crops: tuple[tuple[int, int, int], ...]
    crop_size: int
    low_open: bool = False
    high_open: bool = False
    cover: tuple[float, ...] = ()
    alignment: tuple[float, ...] = ()
    input_cover: float = 0.0
    reason: str = ""

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in ``[low, high]``."""
        return self.found and self.low <= value <= self.high

    @property
    def open_note(self) -> str:
        """``"it reaches the lowest V probed"`` (highest, both) or ``""``: see ``low_open``."""
        ends = [end for end, is_open in (("lowest", self.low_open), ("highest", self.high_open))
                if is_open]  # fmt: skip
        return f"it reaches the {' and '.join(ends)} V probed" if ends else ""

    @property
    def explanation(self) -> str:
        """Why ``best``, in one line: ``reason``, or what kept every V from being measured."""
        if not self.found and all(math.isnan(value) for value in self.edge_enhancement):
            return "the probe's crops hold NaN or infinite pixels: no V could be measured"
        if not self.found:
            return self.reason or "no V draws the labyrinth on the edges"
        return self.reason

    @property
    def choice(self) -> str:
        """The V chosen and why, in one line: ``V = 0.04: cover 0.11, aligned 0.99`` (what the
        widget's plot and the command line show)."""
        chosen = f"V = {self.best:.4g}"
        return f"{chosen}: {self.explanation}" if self.explanation else chosen

    @property
    def range_note(self) -> str:
        """``window 0.03-0.06``, and ``open_note`` after it; ``""`` when nothing was found."""
        if not self.found:
            return ""
        extra = f"; {self.open_note}" if self.open_note else ""
        return f"window {self.low:.4g}-{self.high:.4g}{extra}"

    def summary(self, *, note: bool = True) -> str:
        """One line: ``V = 0.04: cover 0.11, aligned 0.99 (window 0.03-0.06)``: ``choice`` and
        the window, with ``open_note`` unless ``note`` is False."""
        if not self.found:
            return self.choice
        extra = f"; {self.open_note}" if note and self.open_note else ""
        return f"{self.choice} (window {self.low:.4g}-{self.high:.4g}{extra})"


def find_window(
    image,
    *,
    preset: str = DEFAULT_PRESET,
    seed: int = 0,
    channel_axis: int | None = None,
    alpha: bool | None = None,
    colour: str | None = None,
    tone_limits: tuple[float, float] | None = None,
    thresholds=None,
    widen: int = WIDEN_STEPS,
    crops: int = CROPS,
    crop_size: int = CROP_SIZE,
    max_planes: int = MAX_PLANES,
    workers: int | None = None,
    **parameters: Any,
) -> Window:
    """Find the variance threshold V (Eq. 4) at which the labyrinth is drawn along the contours.

    Renders a probe of the image (``crops`` crops of ``crop_size`` pixels,
    full resolution, from up to ``max_planes`` planes of a stack) at every V
    of ``thresholds`` with the preset's other parameters, measures each
    rendering's labyrinth cover, contour alignment, edge enhancement and
    changed pixels, and chooses V from those curves by the criterion of
    :func:`napari_labyrinth.window_criterion.choose`: among the V whose walls
    run along the contours and cover at least ``COVER_FRACTION`` of the best
    such cover, the V of the best edge enhancement; never a V that draws no
    walls while another does. The result says why (``Window.reason``). One V
    serves every plane of a stack.

    Parameters
    ----------
    image : array_like or dask array
        As for :func:`napari_labyrinth.labyrinth`. Of a dask array only the
        sampled planes are computed (and, without ``tone_limits``, their
        percentiles set the tone scale; ``labyrinth(variance_threshold="auto")``
        of a dask image passes the whole image's, as its rendering streams
        them: ``lazy.rendering_tone_limits``).
    preset : str, optional
        The parameter set the window is measured for.
    seed : int, optional
        Seed of the random draws (Eq. 3) and of the choice of crops: the
        result is a pure function of the image, the parameters and the seed.
    channel_axis, alpha, colour, tone_limits : optional
        As for :func:`napari_labyrinth.labyrinth`: the probe is taken on the
        tones the rendering would see.
    thresholds : sequence of float, optional
        The V to probe, increasing. Default: the preset's V times
        ``THRESHOLD_FACTORS``, rounded to ``FLOAT_DECIMALS``.
    widen : int, optional
        When the V chosen is the highest of ``thresholds``, up to this many
        more V are probed above it, the grid's last step continued (rounded
        to ``FLOAT_DECIMALS``); 0 probes ``thresholds`` only.
    crops : int, optional
        Crops of the probe (>= 1).
    crop_size : int, optional
        Their side in pixels (>= 16); a smaller image is probed whole.
    max_planes : int, optional
        Planes of a stack the crops are drawn from (>= 1).
    workers : int, optional
        Threads (default: every core). The result does not depend on it.
    **parameters
        Any parameter of the algorithm but ``variance_threshold``
        (``passes``, ``tone_ranges``, ...), as for ``labyrinth``.

    Returns
    -------
    Window
        ``low``, ``best``, ``high``, the measured curves, the reason for
        ``best``, and whether the window reaches an end of the V probed
        (``low_open``, ``high_open``).

    Raises
    ------
    TypeError, ValueError
        Naming the argument at fault.

    Notes
    -----
    The crops are the cells of a grid of ``crop_size`` over each sampled
    plane, ranked by their local contrast (mean absolute difference of
    neighbouring pixels, on a subsampled copy) and drawn one from each of
    ``crops`` equal strata of that ranking, so that edges, texture and
    flat or dark background are each represented as in the image. A cell
    drawn that holds a NaN or infinite pixel gives way to the finite cell of
    its stratum nearest in rank, if there is one (the edge enhancement of a
    crop with such a pixel is undefined). Each crop
    is rendered on its own, at full resolution, with the tone scale of the
    whole image; the metrics are measured on the crops side by side.
    Only the crops and the ranking's subsampled cells are put on the tone
    scale; the V are rendered on ``workers`` threads, one V per task.

    Examples
    --------
    >>> from skimage import data
    >>> from napari_labyrinth import find_window, labyrinth
    >>> window = find_window(data.camera())
    >>> window.low <= window.best <= window.high
    True
    >>> rendered = labyrinth(data.camera(), variance_threshold=window.best)
    """
    if parameters.get("variance_threshold") is not None:
        raise TypeError("find_window chooses variance_threshold; do not pass it")
    parameters.pop("variance_threshold", None)
    base = resolve_parameters(preset, **parameters)
    seed = SEED.validate(seed)
    widen = _positive_int("widen", widen, 0)
    crops = _positive_int("crops", crops, 1)
    crop_size = _positive_int("crop_size", crop_size, 16)
    max_planes = _positive_int("max_planes", max_planes, 1)
    workers = validate_workers(workers)
    values = _thresholds(thresholds, base.variance_threshold)

    planes, scale = _sampled_planes(image, channel_axis, alpha, colour, tone_limits, max_planes)
    plane_shape = tuple(planes[0].shape[-2:])
    if min(plane_shape) < 3:  # the measure of edges needs a pixel with all 8 neighbours
        raise ValueError(
            f"image planes must be at least 3 x 3 pixels to find the window of V (as "
            f"variance_threshold='auto' does), got {plane_shape[0]} x {plane_shape[1]}"
        )
    rng = np.random.default_rng(seed)
    where, size = _choose_crops(planes, scale, crops, crop_size, rng)
    originals = [
        scale(planes[plane][top : top + size[0], left : left + size[1]])
        for plane, top, left in where
    ]
    probe = _Probe(originals, base, seed)
    with ThreadPoolExecutor(workers) as pool:
        measured = dict(zip(values, pool.map(probe.measure, values)))
        choice = _choice(values, measured, probe.input_cover)
        if choice.found and widen and choice.best == len(values) - 1:
            more = _above(values, widen)
            measured.update(zip(more, pool.map(probe.measure, more)))
            values = sorted(measured)
            choice = _choice(values, measured, probe.input_cover)
    low, best, high = (
        (values[choice.low], values[choice.best], values[choice.high])
        if choice.found
        else (base.variance_threshold,) * 3
    )
    curves = {
        name: tuple(measured[v][k] for v in values) for k, name in enumerate(_Measures._fields)
    }
    return Window(
        low=low,
        best=best,
        high=high,
        found=choice.found,
        thresholds=tuple(values),
        crops=tuple(where),
        crop_size=int(min(size)),
        low_open=choice.found and choice.low == 0,
        high_open=choice.found and choice.high == len(values) - 1,
        input_cover=probe.input_cover,
        reason=choice.reason,
        **curves,
    )


def _choice(values: list[float], measured: dict, input_cover: float) -> Choice:
    """The criterion's choice (``window_criterion.choose``) on the curves measured at
    ``values``."""
    curves = [[measured[v][k] for v in values] for k in range(len(_Measures._fields))]
    return choose(*curves, input_cover=input_cover)


def window_of(thresholds, curve, *, default: float, fraction: float = WINDOW_FRACTION):
    """``(low, best, high, found)`` of a curve of edge enhancement against V, as the study
    defines the window (``benchmarks/study.py``, ``bench_window.py``).

    The window is the run of consecutive V around the best whose value is at
    least ``fraction`` of the best (the study's definition, with the run kept
    contiguous so that a stray point far off does not widen it). No
    positive value: ``(default, default, default, False)``.
    """
    values = np.asarray(curve, dtype=float)
    usable = np.where(np.isfinite(values), values, -np.inf)
    best = int(np.argmax(usable))
    if not usable[best] > 0:
        return default, default, default, False
    floor = fraction * usable[best]
    low = best
    while low > 0 and usable[low - 1] >= floor:
        low -= 1
    high = best
    while high < len(values) - 1 and usable[high + 1] >= floor:
        high += 1
    return float(thresholds[low]), float(thresholds[best]), float(thresholds[high]), True


def window_for(image, **options: Any) -> Window:
    """:func:`find_window` for a call of ``labyrinth(image, **options)``.

    ``options`` are keyword arguments of :func:`napari_labyrinth.labyrinth`
    (None meaning "not given"); those that do not bear on the window
    (``variance_threshold`` itself, ``plane_offset``) are ignored.
    """
    ignored = ("variance_threshold", "plane_offset")
    given = {k: v for k, v in options.items() if v is not None and k not in ignored}
    return find_window(image, **given)


def _positive_int(name: str, value: Any, low: int) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
    return int(value)


#: The variance threshold's entry in the table: its bounds bound the V probed.
_V = PARAMETERS["variance_threshold"]


def _thresholds(thresholds: Any, centre: float) -> list[float]:
    if thresholds is None:
        return sorted({round(centre * factor, FLOAT_DECIMALS) for factor in THRESHOLD_FACTORS})
    if isinstance(thresholds, (str, bytes)) or not hasattr(thresholds, "__len__"):
        raise TypeError(f"thresholds must be a sequence of numbers, got {thresholds!r}")
    values = []
    for value in thresholds:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
            raise TypeError(f"thresholds must hold numbers, got {value!r}")
        number = as_float(value)
        if not (math.isfinite(number) and _V.low <= number <= _V.high):
            raise ValueError(f"thresholds must be finite and {_V.bounds_text}, got {value!r}")
        values.append(number)
    if not values:
        raise ValueError("thresholds must not be empty")
    if any(b <= a for a, b in zip(values, values[1:])):
        raise ValueError(f"thresholds must be increasing, got {values}")
    return values


def _above(values: list[float], steps: int) -> list[float]:
    """Up to ``steps`` V above the top of ``values``, its last step continued (a ratio;
    sqrt(2) from a single V), rounded to ``FLOAT_DECIMALS``; those that rounding leaves
    on the top are dropped (a top of 0 has nothing above it on a ratio scale), as are those
    beyond V's bound."""
    top = values[-1]
    ratio = top / values[-2] if len(values) > 1 and values[-2] > 0 else math.sqrt(2.0)
    above = {round(top * ratio**k, FLOAT_DECIMALS) for k in range(1, steps + 1)}
    return sorted(v for v in above if top < v <= _V.high)


def _sampled_planes(image, channel_axis, alpha, colour, tone_limits, max_planes):
    """Up to ``max_planes`` evenly spaced planes of the image, and the map of their values
    to C-contiguous float32 tones (the whole image's tone scale).

    The planes are views: only what the probe reads of them is put on the tone scale.
    """
    if is_lazy(image):
        checked_lazy(image, channel_axis, alpha)  # its shape, before a plane is computed
        image = _sampled_lazy(image, channel_axis, max_planes)
        channel_axis = None if channel_axis is None else -1
    array, layout, scale, grey = prepare_image(image, channel_axis, tone_limits, colour, alpha)
    if grey is not None:
        tones = grey.tones.reshape((-1,) + layout.plane_shape)
        return [tones[k] for k in _evenly(len(tones), max_planes)], np.ascontiguousarray
    indices = list(layout.rendered_indices())
    source = layout.to_planes(array)
    planes = [source[indices[k]] for k in _evenly(len(indices), max_planes)]
    return planes, lambda values: np.ascontiguousarray(scale.to_tones(values))


def _sampled_lazy(image, channel_axis, max_planes) -> np.ndarray:
    """A dask image's evenly spaced positions (all channels kept), computed."""
    axis = normalise_channel_axis(channel_axis, image.ndim)
    moved = image if axis is None else _moveaxis(image, axis, -1)
    spatial = 2 if axis is None else 3
    leading = moved.shape[: moved.ndim - spatial]
    flat = moved.reshape((-1,) + moved.shape[moved.ndim - spatial :])
    chosen = _evenly(max(1, math.prod(leading)), max_planes)
    return np.asarray(flat[chosen])


def _moveaxis(array, source, destination):
    import dask.array as da

    return da.moveaxis(array, source, destination)


def _evenly(count: int, most: int) -> list[int]:
    """``min(count, most)`` evenly spaced indices of ``range(count)``, first and last included."""
    if count <= most:
        return list(range(count))
    return sorted({int(round(i)) for i in np.linspace(0, count - 1, most)})


def _choose_crops(planes, to_tones, crops, crop_size, rng):
    """``(plane, top, left)`` of the probe's crops and their shape (see find_window's Notes)."""
    height, width = planes[0].shape
    size = (min(crop_size, height), min(crop_size, width))
    candidates = []  # (contrast, plane, top, left, all its pixels finite)
    for p, plane in enumerate(planes):
        floats = plane.dtype.kind in "fc"
        for top in range(0, height - size[0] + 1, size[0]):
            for left in range(0, width - size[1] + 1, size[1]):
                cell = plane[top : top + size[0] : _RANK_STEP, left : left + size[1] : _RANK_STEP]
                whole = plane[top : top + size[0], left : left + size[1]]
                finite = not floats or bool(np.isfinite(whole).all())
                candidates.append((_contrast(to_tones(cell)), p, top, left, finite))
    candidates.sort(key=lambda c: (c[0], c[1], c[2], c[3]))
    count = min(crops, len(candidates))
    bounds = np.linspace(0, len(candidates), count + 1).astype(int)
    chosen = []
    for start, stop in zip(bounds, bounds[1:]):
        drawn = int(rng.integers(start, stop))
        if not candidates[drawn][4]:  # a non-finite pixel: the finite cell nearest in rank
            finite = [k for k in range(start, stop) if candidates[k][4]]
            drawn = min(finite, key=lambda k: (abs(k - drawn), k), default=drawn)
        chosen.append(candidates[drawn][1:4])
    return [tuple(int(v) for v in c) for c in chosen], size


def _contrast(cell: np.ndarray) -> float:
    finite = np.where(np.isfinite(cell), cell, 0.0)
    return float(
        np.mean(np.abs(np.diff(finite, axis=0))) + np.mean(np.abs(np.diff(finite, axis=1)))
        if min(cell.shape) > 1
        else 0.0
    )


#: The metrics of the probe at each V, in the order of ``_Measures``.
_PROBED = ("edge_enhancement", "labyrinth_cover", "contour_alignment")


class _Measures(NamedTuple):
    """What the probe measures at one V (the curves of :class:`Window`)."""

    edge_enhancement: float
    cover: float
    alignment: float
    changed: float


class _Probe:
    """The crops rendered at one V, side by side, and measured against the originals.

    ``measure`` is called from several threads at once (one V each): the
    kernel releases the GIL and the comparison keeps the originals' maps.
    """

    def __init__(self, originals: list[np.ndarray], parameters, seed: int):
        self.originals = originals
        self.nonfinite = [not np.isfinite(original).all() for original in originals]
        self.mosaic = np.concatenate(originals, axis=0)
        self.parameters = parameters
        self.seed = seed
        # one thread per V: the comparison's own bands would only add threads
        self.comparison = metrics.Comparison(self.mosaic, workers=1)
        # walls the input has already (a JPEG's blocks, fine texture) are not the labyrinth's
        self.input_cover = self.comparison.measure(self.mosaic, ["labyrinth_cover"])[
            "labyrinth_cover"
        ]

    def measure(self, value: float) -> _Measures:
        """The probe rendered with V = ``value``, measured."""
        parameters = dataclasses.replace(self.parameters, variance_threshold=value)
        rendered = []
        for index, original in enumerate(self.originals):
            work = original.copy()
            for pass_index in range(parameters.passes):
                run_pass(
                    work,
                    parameters,
                    seed=self.seed,
                    plane_index=index,
                    pass_index=pass_index,
                    has_nonfinite=self.nonfinite[index],
                )
            rendered.append(work)
        mosaic = np.concatenate(rendered, axis=0)
        measured = self.comparison.measure(mosaic, _PROBED)
        changed = float(np.mean(mosaic != self.mosaic))
        return _Measures(*(measured[name] for name in _PROBED), changed)
