"""Public API: render images with the labyrinthine tiling.

``labyrinth`` renders an image, ``labyrinth_stack`` keeps every pass (the
paper's Fig. 4) and ``labyrinth_sweep`` varies one parameter (Fig. 3). All
three drive :func:`labyrinth_steps`, a generator of progress events that ends
with the result; closing it cancels the run. They validate the input
(``_inputs``), map it to the 0-255 tone scale on which the paper's thresholds
live, split it into independent 2-D planes (``core.planes``) and hand them,
grey or in their luminance, to the run engine (``_rendering``, ``_engine``),
which runs the numba kernel on each. A dask image is rendered lazily
(``lazy``), block by block, along the same path.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Generator, Iterator, Sequence
from typing import Any

import numpy as np

from ._budget import refuse_unaffordable_result
from ._engine import DIAGNOSTICS_DTYPE, Progress, run_pass
from ._inputs import prepare_image, validate_workers
from ._rendering import noise_sigmas, render_planes
from .core.colour import LuminancePlanes
from .core.parameters import (
    DEFAULT_SEED,
    SEED,
    LabyrinthParameters,
    is_auto,
    without_auto,
)
from .core.planes import PlaneLayout, validate_plane_offset, validate_stream_range
from .core.presets import DEFAULT_PRESET, FIG3_FACTORS, resolve_parameters, resolve_sweep
from .core.tone_scale import ToneScale
from .lazy import is_lazy, render_lazy, rendering_tone_limits
from .window import window_for

__all__ = [
    "DIAGNOSTICS_DTYPE",
    "FIG3_FACTORS",
    "MODES",
    "Progress",
    "Result",
    "labyrinth",
    "labyrinth_stack",
    "labyrinth_steps",
    "labyrinth_sweep",
    "resolve_parameters",
    "run_pass",
]

ProgressCallback = Callable[[int, int], Any]

#: What a run produces: one rendering, the input and every pass (Fig. 4), or
#: one rendering per value of a parameter (Fig. 3).
MODES = ("single", "stack", "sweep")

#: Keywords of the rendering functions that are not parameters of the algorithm.
RENDER_OPTIONS = {
    "preset": DEFAULT_PRESET,
    "seed": DEFAULT_SEED,
    "channel_axis": None,
    "alpha": None,
    "colour": None,
    "tone_limits": None,
    "plane_offset": 0,
    "workers": None,
}


@dataclasses.dataclass(frozen=True)
class Result:
    """The last item a run of :func:`labyrinth_steps` yields.

    Attributes
    ----------
    image : ndarray or dask array
        The rendering: shaped as the input (``"single"``), with a leading
        axis of the input and every pass (``"stack"``) or of the renderings
        (``"sweep"``). Lazy for a dask input.
    diagnostics : structured ndarray, list of them, or None
        The per-pass counts (see :func:`labyrinth`); one array per rendering
        of a sweep; None for a lazy result.
    tone_limits : (float, float) or None
        The values mapped to tones 0 and 255 (the default limits found, or
        those given); None for a lazy result whose limits were not given.
    noise_sigma : tuple of float or None
        The noise of each plane in tones (flat, in the order of the planes,
        one per position in the luminance mode; None for alpha), which the noise gate compares the local
        variance with; None with the gate off and for a lazy result (each
        block measures its planes the same way).
    """

    image: Any
    diagnostics: Any
    tone_limits: tuple[float, float] | None = None
    noise_sigma: tuple[float | None, ...] | None = None


def labyrinth(
    image,
    *,
    preset: str = DEFAULT_PRESET,
    passes: int | None = None,
    seed: int = 0,
    mean_threshold: float | None = None,
    variance_threshold: float | None = None,
    tone_ranges: int | Sequence[float] | None = None,
    tones: Sequence[tuple[float, float]] | None = None,
    max_tries: int | None = None,
    border: str | None = None,
    variance_ratio: str | None = None,
    variance_action: str | None = None,
    condition_order: str | None = None,
    on_exhausted: str | None = None,
    include_centre: bool | None = None,
    scan: str | None = None,
    noise_gate: float | None = None,
    channel_axis: int | None = None,
    alpha: bool | None = None,
    colour: str | None = None,
    tone_limits: tuple[float, float] | None = None,
    plane_offset: int = 0,
    workers: int | None = None,
    return_diagnostics: bool = False,
    progress: ProgressCallback | None = None,
):
    """Render an image with the labyrinthine tiling of Sparavigna & Montrucchio.

    Each pass scans every 2-D plane from the top-left corner, in place, so
    that each update is seen by the pixels after it. For a pixel of tone g
    with local mean M and variance V over its 8 nearest and next-nearest
    neighbours (Eq. 1):

    1. g is kept if ``|g - M| / M <= mean_threshold`` (Eq. 2);
    2. otherwise g is left as it is if the variance ratio R2 of Eq. 4
       exceeds ``variance_threshold``;
    3. otherwise tones ``g* = T_inf + R (T_sup - T_inf)`` (Eq. 3) are drawn
       in the tone range that holds g, up to ``max_tries`` times; the first
       that satisfies Eq. 2 replaces g.

    Parameters
    ----------
    image : array_like or dask array
        2-D or nD image of an integer type up to 32 bits or a float type,
        in either byte order (a big-endian image is rendered as its
        native-order equivalent and returned in its own dtype). Every axis
        before the last two (after removing ``channel_axis``) is a set of
        independent planes (time, z, channels). A dask array gives a lazy
        dask array (see Notes).
    preset : str, optional
        Named parameter set (see ``napari_labyrinth.PRESETS``) that supplies
        every parameter not given explicitly. ``"paper"`` is the literal
        reading of the printed text.
    passes : int, optional
        Number of passes (>= 0; 0 returns a copy). The paper's Fig. 4
        iterates the algorithm to enhance edges.
    seed : int, optional
        Seed of the counter-based random generator (0 <= seed <= 2**63 - 1).
        The result is a pure function of the input, the parameters and the seed.
    mean_threshold : float, optional
        t of Eq. 2 (paper: 0.12).
    variance_threshold : float or "auto", optional
        V of Eq. 4 (paper: 0.50). ``"auto"``: the best V of the window
        :func:`napari_labyrinth.find_window` measures on a probe of this
        image with the other parameters (one V for every plane).
    tone_ranges : int or sequence of float, optional
        The ranges of Eq. 3: a count of equal tone ranges from a low non-zero tone (10) to 255,
        or the limits ``L_inf^1 < L_sup^1 = L_inf^2 < ... <= 255`` themselves
        (paper: 3 ranges). A tone below ``L_inf^1`` belongs to the first range.
    tones : sequence of (float, float), optional
        ``(T_inf^i, T_sup^i)`` for each range (Eq. 3). By default T = L;
        setting ``tone_ranges`` without ``tones`` also resets them to T = L.
    max_tries : int, optional
        Draws of Eq. 3 per pixel before giving up (0 to 10000; paper
        preset: 10, the paper gives no number).
    border : {"inside", "mirror", "nearest", "wrap"}, optional
        Neighbours of border pixels in Eq. 1: only those inside the image (N
        is their number; paper preset), or completed as the
        ``scipy.ndimage`` modes of the same names.
    variance_ratio : {"sqrt(V/N)/M", "sqrt(V)/M"}, optional
        R2 of Eq. 4: as printed, or with the local standard deviation.
    variance_action : {"leave", "push_in_range", "push_full_scale"}, optional
        Where Eq. 4 holds: leave g (as printed), or push it further from M
        with a draw on its side of M, in its tone range or up to the end of
        the tone scale (enhances the local variance).
    condition_order : {"mean_first", "variance_first"}, optional
        Whether Eq. 2 (as printed) or Eq. 4 decides first.
    on_exhausted : {"keep", "last_draw"}, optional
        What a pixel becomes when no draw of Eq. 3 satisfies Eq. 2.
    include_centre : bool, optional
        Whether the pixel joins its own M and V (Eq. 1 sums over the
        neighbours only).
    scan : {"raster", "serpentine", "checkerboard"}, optional
        Order of the in-place update from the top-left corner (Sec. 2): rows
        left to right, odd rows right to left, or (not the paper's order)
        the four checkerboard colours of ``(y % 2, x % 2)`` in turn.
    noise_gate : float, optional
        k of the noise gate (not in the paper; 0 turns it off, the paper
        preset's value; the labyrinth preset's is 2): a pixel that Eq. 2 does
        not keep first is left alone where V of Eq. 1 is at most
        ``(k sigma) ** 2``, sigma being the noise of its plane in tones,
        measured once before the passes (Immerkær's estimate,
        ``napari_labyrinth.core.noise``): black and flat backgrounds stay
        clean. ``Result.noise_sigma`` holds each plane's sigma.
    channel_axis : int, optional
        Axis of colour channels. With 4 channels the last one is alpha and
        is kept as it is. How the others are rendered is ``colour``.
    alpha : bool, optional
        Whether the last channel of ``channel_axis`` is alpha: kept as it is,
        never rendered and left out of the tone limits. Default: only with 4
        channels (RGBA); ``True`` for a grey + alpha image (2 channels).
        ``False`` with 4 channels needs ``colour="channels"``.
    colour : {"luminance", "channels"}, optional
        How an image with ``channel_axis`` is rendered. ``"luminance"``
        (default for 3 or 4 channels, R, G, B first): the luminance
        ``Y = 0.2126 R + 0.7152 G + 0.0722 B`` is rendered as a grey image,
        one plane per position (its tone limits are the luminance's), and
        each changed pixel's colour takes the new luminance Y' keeping its
        hue: darker, R, G and B are scaled by Y'/Y (hue and saturation
        kept); brighter, Y' - Y is added to each (hue kept, noise in dark
        colours not amplified); black becomes grey; integer channels that
        would leave the dtype's range move towards grey instead.
        ``"channels"`` (default for other channel counts): every channel is
        rendered as an independent plane, with its own random tones.
        ``"luminance"`` for an image without 3 or 4 channels raises a
        ValueError.
    tone_limits : (float, float), optional
        Values mapped to tones 0 and 255. Default: (0, 255) for uint8, the
        0.5th and 99.5th percentiles of the finite values for other dtypes
        (one scale for the whole image, alpha excluded). For a dask array of
        another dtype than uint8 the default costs extra passes over the data
        (streamed, exact: the same limits as in memory); pass the limits to
        keep the call lazy.
    plane_offset : int, optional
        Flat index of the image's first plane in a larger stack it was taken
        from: plane k draws the random stream of plane ``plane_offset + k``,
        so a part of a stack renders exactly as it does within the whole.
        The last plane's stream index must stay <= 2**63 - 1.
    workers : int, optional
        Threads to use (default: every core; 1 to 1024). Planes run
        concurrently; a single large plane runs on them in tiles that keep the
        scan's exact order (not with ``border="wrap"`` or
        ``scan="serpentine"``: see ``docs/algorithm.md``), on no more threads
        than cores that no other task keeps busy. The result does not
        depend on it.
    return_diagnostics : bool, optional
        Also return the per-pass counts (see Returns).
    progress : callable, optional
        Called as ``progress(done, total)`` after each pass of each plane
        (see :func:`labyrinth_steps` for a generator of progress events).

    Returns
    -------
    rendered : ndarray
        Same shape and dtype as ``image``. Pixels the algorithm did not
        change keep their exact input value; non-finite pixels (in the
        luminance mode: pixels with a non-finite R, G or B) stay as they are
        and never count as neighbours.
    diagnostics : structured ndarray
        Only with ``return_diagnostics``: shape ``(passes,) + plane_shape``
        where ``plane_shape`` is ``image.shape`` without the two spatial
        axes (with ``colour="luminance"``, also without the colour axis:
        one luminance plane per position), fields ``kept_by_mean`` (Eq. 2
        held), ``left_by_variance`` (Eq. 4 held, g left), ``pushed`` (Eq. 4
        held, g pushed from M), ``redrawn`` (Eq. 3), ``out_of_tries`` and
        ``skipped`` (non-finite or without finite neighbours), which add up
        to the number of pixels of a plane.

    Raises
    ------
    TypeError, ValueError
        Naming the parameter, for bad input or parameters; a
        ``MemoryBudgetError`` (a ValueError) for a result of a numpy image
        larger than the memory the run may use (the memory available, or
        the environment variable ``NAPARI_LABYRINTH_MEMORY``), before any of
        it is allocated.

    Notes
    -----
    The thresholds live on the paper's 0-255 tone scale, so other dtypes are
    mapped there linearly (``tone_limits``, values outside are clipped),
    processed in float32 and mapped back; changed pixels are rounded to the
    input dtype, unchanged ones are returned bit for bit.

    A dask array is rendered lazily, block by block: blocks are rechunked so
    that each holds whole planes (and all channels), never tiled, since tiles
    would change the result; every plane keeps the random stream of its
    index in the whole array, so the result equals that of the same data as
    a numpy array. Progress callbacks and diagnostics are not available for
    lazy results (use ``dask.diagnostics.ProgressBar``).

    References
    ----------
    .. [1] A. Sparavigna and B. Montrucchio, "Non-photorealistic image
           rendering with a labyrinthine tiling", Politecnico di Torino.

    Examples
    --------
    >>> from skimage import data
    >>> from napari_labyrinth import labyrinth
    >>> rendered = labyrinth(data.camera(), passes=2, seed=1)
    >>> rendered.shape, rendered.dtype
    ((512, 512), dtype('uint8'))
    """
    options = dict(locals())  # every keyword, exactly as given
    image = options.pop("image")
    return_diagnostics = options.pop("return_diagnostics")
    progress = options.pop("progress")
    result = _finish(image, "single", options, return_diagnostics, progress)
    return (result.image, result.diagnostics) if return_diagnostics else result.image


def labyrinth_stack(image, passes: int = 4, **options):
    """Render ``passes`` passes and keep the image after each one (Fig. 4).

    Parameters
    ----------
    image : array_like
        As for :func:`labyrinth`.
    passes : int, optional
        Number of passes (>= 0).
    **options
        Any keyword argument of :func:`labyrinth`.

    Returns
    -------
    stack : ndarray
        Shape ``(passes + 1,) + image.shape``, input dtype: index 0 is the
        input, index k the image after k passes. With
        ``return_diagnostics=True``, also the diagnostics of :func:`labyrinth`.

    Examples
    --------
    >>> from skimage import data
    >>> from napari_labyrinth import labyrinth_stack
    >>> labyrinth_stack(data.camera(), passes=3).shape
    (4, 512, 512)
    """
    return_diagnostics = options.pop("return_diagnostics", False)
    progress = options.pop("progress", None)
    result = _finish(image, "stack", dict(options, passes=passes), return_diagnostics, progress)
    return (result.image, result.diagnostics) if return_diagnostics else result.image


def labyrinth_sweep(
    image,
    parameter: str = "variance_threshold",
    values: Sequence[Any] | None = None,
    **options,
):
    """Render the image once per value of one parameter (the paper's Fig. 3).

    Parameters
    ----------
    image : array_like
        As for :func:`labyrinth`.
    parameter : str, optional
        Name of the parameter to vary: any parameter of the algorithm
        (``mean_threshold``, ``variance_threshold``, ``passes``, ...) or
        ``seed``.
    values : sequence, optional
        The values, at least one. Every rendering uses the same seed unless
        ``parameter`` is ``"seed"``. By default, for ``variance_threshold``
        only: the preset's V times 0.94, 1 and 1.06, as the paper's Fig. 3
        shows 47 %, 50 % and 53 % around its 50 %.
    **options
        Any other keyword argument of :func:`labyrinth`.

    Returns
    -------
    sweep : ndarray
        Shape ``(len(values),) + image.shape``, input dtype. With
        ``return_diagnostics=True``, also a list with the diagnostics of each
        rendering.

    Examples
    --------
    >>> from skimage import data
    >>> from napari_labyrinth import labyrinth_sweep
    >>> labyrinth_sweep(data.camera(), "variance_threshold", [0.47, 0.5, 0.53]).shape
    (3, 512, 512)
    """
    return_diagnostics = options.pop("return_diagnostics", False)
    progress = options.pop("progress", None)
    options = dict(options, parameter=parameter, values=values)
    result = _finish(image, "sweep", options, return_diagnostics, progress)
    return (result.image, result.diagnostics) if return_diagnostics else result.image


def labyrinth_steps(
    image,
    mode: str = "single",
    *,
    parameter: str | None = None,
    values: Sequence[Any] | None = None,
    **options,
) -> Iterator[Progress | Result]:
    """Render step by step: yield progress events, then the result.

    The generator behind :func:`labyrinth`, :func:`labyrinth_stack` and
    :func:`labyrinth_sweep`, for callers that show progress or may cancel:
    a napari thread worker, a command-line progress bar, a notebook.

    Parameters
    ----------
    image : array_like or dask array
        As for :func:`labyrinth`.
    mode : {"single", "stack", "sweep"}, optional
        Render once (:func:`labyrinth`), keep the input and every pass
        (:func:`labyrinth_stack`), or render once per value of ``parameter``
        (:func:`labyrinth_sweep`).
    parameter, values : optional
        The swept parameter and its values (``"sweep"`` only), as for
        :func:`labyrinth_sweep`.
    **options
        Any keyword argument of :func:`labyrinth` but ``return_diagnostics``
        and ``progress``: the diagnostics come with the result, the progress
        as events.

    Yields
    ------
    Progress
        After each pass of each plane: ``done`` and ``total`` plane-passes,
        the sweep's rendering, the plane and the pass. A colour image
        rendered in its luminance (``colour``) renders one plane per
        position, named by the index of its first channel's plane.
    Result
        Last: the rendering and its diagnostics. A dask input yields only
        the (lazy) result.

    Raises
    ------
    TypeError, ValueError
        At the call, not at the first step, naming the parameter at fault.

    Notes
    -----
    Closing the generator (``steps.close()``, or leaving a ``for`` loop over
    it and dropping it) cancels the run: every thread stops after the pass it
    is running, and nothing is left running or allocated when ``close``
    returns.

    Examples
    --------
    >>> from skimage import data
    >>> from napari_labyrinth import labyrinth_steps
    >>> for event in labyrinth_steps(data.camera(), passes=2):
    ...     pass  # event.done of event.total, then the Result
    >>> event.image.shape
    (512, 512)
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(map(repr, MODES))}; got {mode!r}")
    if mode != "sweep" and (parameter is not None or values is not None):
        raise TypeError("parameter and values are for mode='sweep'")
    seed_given = options.get("seed")  # None if not given: a sweep of seeds takes none
    render = {name: options.pop(name, default) for name, default in RENDER_OPTIONS.items()}
    overrides = options
    if is_lazy(image) and render["tone_limits"] is None:
        # found once, for every rendering of a sweep and for the probe of V = "auto" (the
        # whole image's, as rendered), after the checks that need no block of it
        _check_arguments(mode, render, overrides, seed_given, parameter, values)
        planes = {name: render[name] for name in ("channel_axis", "alpha", "colour")}
        render["tone_limits"] = rendering_tone_limits(image, **planes)
    if is_auto(overrides.get("variance_threshold")):
        overrides = dict(overrides, variance_threshold=_auto_threshold(image, render, overrides))
    if mode == "sweep":
        runs = resolve_sweep(
            render["preset"], overrides, seed_given, parameter or "variance_threshold", values
        )
    else:
        runs = [(resolve_parameters(render["preset"], **overrides), SEED.validate(render["seed"]))]
    workers = validate_workers(render["workers"])
    plane_offset = validate_plane_offset(render["plane_offset"])
    record_passes = mode == "stack"
    if is_lazy(image):
        lazy = [
            render_lazy(
                image,
                parameters,
                seed,
                channel_axis=render["channel_axis"],
                alpha=render["alpha"],
                colour=render["colour"],
                tone_limits=render["tone_limits"],
                plane_offset=plane_offset,
                record_passes=record_passes,
            )
            for parameters, seed in runs
        ]
        limits = render["tone_limits"]
        limits = None if limits is None else tuple(float(v) for v in limits)
        return iter([Result(_stack(lazy) if mode == "sweep" else lazy[0], None, limits)])
    array, layout, scale, grey = prepare_image(
        image, render["channel_axis"], render["tone_limits"], render["colour"], render["alpha"]
    )
    validate_stream_range(plane_offset, layout.n_planes)
    if mode == "stack":
        passes = runs[0][0].passes
        copies, what = passes + 1, f"a stack of the input and {passes} passes"
    elif mode == "sweep":  # every rendering, then their stack
        copies, what = 2 * len(runs), f"a sweep of {len(runs)} renderings"
    else:
        copies, what = 1, "the rendering"
    refuse_unaffordable_result(array.shape, array.dtype, copies, what)
    layout = dataclasses.replace(layout, plane_offset=plane_offset)
    steps = _steps(array, layout, scale, grey, runs, mode, workers)
    given = getattr(image, "dtype", None)
    if given is not None and np.dtype(given) != array.dtype:  # big-endian: back to its order
        return _in_dtype(steps, np.dtype(given))
    return steps


def _steps(
    array: np.ndarray,
    layout: PlaneLayout,
    scale: ToneScale,
    grey: LuminancePlanes | None,
    runs: list[tuple[LabyrinthParameters, int]],
    mode: str,
    workers: int,
) -> Generator[Progress | Result, None, None]:
    rendered = layout if grey is None else layout.luminance_layout()
    total = rendered.n_rendered * sum(parameters.passes for parameters, _ in runs)
    done = 0
    results = []
    limits = (float(scale.low), float(scale.high))
    sigmas = None  # measured once, for every rendering with the gate on
    if any(parameters.noise_gate > 0 for parameters, _ in runs):
        sigmas = noise_sigmas(array, layout, scale, grey, workers)
    for run, (parameters, seed) in enumerate(runs):
        rendering = render_planes(
            array,
            layout,
            scale,
            grey,
            parameters,
            seed,
            record_passes=mode == "stack",
            workers=workers,
            sigmas=sigmas,
        )
        while True:
            try:
                plane, pass_number, partial = next(rendering)
            except StopIteration as finished:
                results.append(finished.value)
                break
            done += 1
            yield Progress(done, total, run, plane, pass_number, partial, limits)
    noise = None
    if sigmas is not None:  # an alpha plane, not rendered, has none
        noise = tuple(None if np.isnan(v) else float(v) for v in sigmas.ravel())
    if mode == "sweep":
        images, diagnostics = [image for image, _ in results], [d for _, d in results]
        yield Result(_stack(images), diagnostics, limits, noise)
    else:
        yield Result(*results[0], limits, noise)


def _finish(
    image, mode: str, options: dict[str, Any], return_diagnostics: bool, progress
) -> Result:
    """Drive :func:`labyrinth_steps` to its result, reporting to a ``progress`` callback."""
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be callable, got {progress!r}")
    if is_lazy(image):  # refused before a graph is built or tone limits are streamed
        if return_diagnostics:
            raise ValueError("return_diagnostics is not available for dask arrays (lazy results)")
        if progress is not None:
            raise ValueError(
                "progress is not available for dask arrays: use dask.diagnostics.ProgressBar"
            )
    for event in labyrinth_steps(image, mode, **options):
        if isinstance(event, Result):
            return event
        if progress is not None:
            progress(event.done, event.total)
    raise AssertionError("labyrinth_steps ended without a result")  # pragma: no cover


def _check_arguments(mode, render, overrides, seed_given, parameter, values) -> None:
    """Check the parameters and options of a run (a V of "auto" aside), naming the first at
    fault, as the run itself would."""
    given = without_auto(overrides)
    if mode == "sweep":
        swept = parameter or "variance_threshold"
        resolve_sweep(render["preset"], given, seed_given, swept, values)
    else:
        resolve_parameters(render["preset"], **given)
        SEED.validate(render["seed"])
    validate_workers(render["workers"])
    validate_plane_offset(render["plane_offset"])


def _auto_threshold(image, render: dict[str, Any], overrides: dict[str, Any]) -> float:
    """The V of ``variance_threshold="auto"``: the best of :func:`find_window`'s window."""
    given = without_auto(overrides)
    resolve_parameters(render["preset"], **given)  # bad parameters are named first
    return window_for(image, **render, **given).best


def _stack(arrays):
    if is_lazy(arrays[0]):
        import dask.array as da

        return da.stack(arrays)
    return np.stack(arrays)


def _in_dtype(
    steps: Iterator[Progress | Result], dtype: np.dtype
) -> Generator[Progress | Result, None, None]:
    """``steps`` with the result cast to ``dtype``: the input's own byte order."""
    try:
        for event in steps:
            if isinstance(event, Result):
                event = dataclasses.replace(event, image=event.image.astype(dtype))
            yield event
    finally:
        steps.close()
