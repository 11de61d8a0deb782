"""Public API: render images with the labyrinthine tiling.

``labyrinth`` renders an image, ``labyrinth_stack`` keeps every pass (the
paper's Fig. 4) and ``labyrinth_sweep`` varies one parameter (Fig. 3). They
validate the input, map it to the 0-255 tone scale on which the paper's
thresholds live, split it into independent 2-D planes and run the numba
kernel (imported on first use) on each plane.
"""

from __future__ import annotations

import dataclasses
import functools
import numbers
import os
import queue
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from ._chunked import is_lazy
from ._tone_scale import ToneScale, resolve_tone_scale
from .parameters import (
    BORDERS,
    DIAGNOSTIC_FIELDS,
    ON_EXHAUSTED,
    PARAMETER_NAMES,
    SCANS,
    VARIANCE_ACTIONS,
    VARIANCE_RATIOS,
    LabyrinthParameters,
    make_parameters,
)
from .presets import DEFAULT_PRESET, preset_values

#: dtype of the per-pass diagnostics: one count per field of ``DIAGNOSTIC_FIELDS``.
DIAGNOSTICS_DTYPE = np.dtype([(name, np.int64) for name in DIAGNOSTIC_FIELDS])

_SUPPORTED_DTYPES = tuple(
    np.dtype(t)
    for t in (
        np.uint8,
        np.uint16,
        np.uint32,
        np.int8,
        np.int16,
        np.int32,
        np.float16,
        np.float32,
        np.float64,
    )
)

ProgressCallback = Callable[[int, int], Any]

#: Default sweep of the variance threshold around a preset's value: the paper's
#: Fig. 3 shows V = 47 %, 50 % and 53 %.
FIG3_FACTORS = (0.94, 1.0, 1.06)


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
    channel_axis: int | None = None,
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
        2-D or nD image of an integer type up to 32 bits or a float type.
        Every axis before the last two (after removing ``channel_axis``) is
        a set of independent planes (time, z, channels). A dask array gives
        a lazy dask array (see Notes).
    preset : str, optional
        Named parameter set (see ``napari_labyrinth.PRESETS``) that supplies
        every parameter not given explicitly. ``"paper"`` is the literal
        reading of the printed text.
    passes : int, optional
        Number of passes (>= 0; 0 returns a copy). The paper's Fig. 4
        iterates the algorithm to enhance edges.
    seed : int, optional
        Seed of the counter-based random generator (0 <= seed < 2**64). The
        result is a pure function of the input, the parameters and the seed.
    mean_threshold : float, optional
        t of Eq. 2 (paper: 0.12).
    variance_threshold : float, optional
        V of Eq. 4 (paper: 0.50).
    tone_ranges : int or sequence of float, optional
        A count of equal tone ranges from a low non-zero tone (10) to 255,
        or the limits ``L_inf^1 < L_sup^1 = L_inf^2 < ... <= 255`` themselves
        (paper: 3 ranges). A tone below ``L_inf^1`` belongs to the first range.
    tones : sequence of (float, float), optional
        ``(T_inf^i, T_sup^i)`` for each range (Eq. 3). By default T = L;
        setting ``tone_ranges`` without ``tones`` also resets them to T = L.
    max_tries : int, optional
        Draws of Eq. 3 per pixel before giving up (0 to 10000; paper
        preset: 10, the paper gives no number).
    border : {"inside", "mirror", "nearest", "wrap"}, optional
        Neighbours of border pixels: only those inside the image (N is their
        number; paper preset), or completed as the ``scipy.ndimage`` modes.
    variance_ratio : {"sqrt(V/N)/M", "sqrt(V)/M"}, optional
        R2 of Eq. 4: as printed, or with the local standard deviation.
    variance_action : {"leave", "push_in_range", "push_full_scale"}, optional
        Where Eq. 4 holds: leave g (as printed), or push it further from M
        with a draw on its side of M, in its tone range or up to the end of
        the tone scale (enhances the local variance).
    condition_order : {"mean_first", "variance_first"}, optional
        Whether Eq. 2 (as printed) or Eq. 4 decides first.
    on_exhausted : {"keep", "last_draw"}, optional
        What a pixel becomes when no draw satisfies Eq. 2.
    include_centre : bool, optional
        Whether the pixel joins its own M and V (the paper: neighbours only).
    scan : {"raster", "serpentine"}, optional
        Scan order: rows left to right, or alternate rows right to left.
    channel_axis : int, optional
        Axis of colour channels, each rendered as an independent plane; with
        4 channels the last one is alpha and is kept as it is.
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
    workers : int, optional
        Threads to use (default: every core). Planes run concurrently; a
        single plane uses them only with ``scan="checkerboard"``. The result
        does not depend on it.
    return_diagnostics : bool, optional
        Also return the per-pass counts (see Returns).
    progress : callable, optional
        Called as ``progress(done, total)`` after each plane and pass.

    Returns
    -------
    rendered : ndarray
        Same shape and dtype as ``image``. Pixels the algorithm did not
        change keep their exact input value; non-finite pixels stay as they
        are and never count as neighbours.
    diagnostics : structured ndarray
        Only with ``return_diagnostics``: shape ``(passes,) + plane_shape``
        where ``plane_shape`` is ``image.shape`` without the two spatial
        axes, fields ``kept_by_mean`` (Eq. 2 held), ``left_by_variance``
        (Eq. 4 held, g left), ``pushed`` (Eq. 4 held, g pushed from M),
        ``redrawn`` (Eq. 3), ``out_of_tries`` and ``skipped``
        (non-finite or without finite neighbours), which add up to the
        number of pixels of a plane.

    Raises
    ------
    TypeError, ValueError
        Naming the parameter, for bad input or parameters.

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
    parameters = resolve_parameters(
        preset,
        passes=passes,
        mean_threshold=mean_threshold,
        variance_threshold=variance_threshold,
        tone_ranges=tone_ranges,
        tones=tones,
        max_tries=max_tries,
        border=border,
        variance_ratio=variance_ratio,
        variance_action=variance_action,
        condition_order=condition_order,
        on_exhausted=on_exhausted,
        include_centre=include_centre,
        scan=scan,
    )
    ((rendered, diagnostics),) = _render(
        image,
        [(parameters, _validate_seed(seed))],
        channel_axis=channel_axis,
        tone_limits=tone_limits,
        plane_offset=plane_offset,
        workers=workers,
        record_passes=False,
        progress=progress,
        return_diagnostics=return_diagnostics,
    )
    return (rendered, diagnostics) if return_diagnostics else rendered


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
    render_options, overrides = _split_options(options)
    parameters = resolve_parameters(render_options.pop("preset"), passes=passes, **overrides)
    seed = _validate_seed(render_options.pop("seed"))
    ((stack, diagnostics),) = _render(
        image, [(parameters, seed)], record_passes=True, **render_options
    )
    return (stack, diagnostics) if render_options["return_diagnostics"] else stack


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
    if parameter not in PARAMETER_NAMES + ("seed",):
        raise ValueError(
            f"parameter must be one of {', '.join(PARAMETER_NAMES + ('seed',))}; got {parameter!r}"
        )
    if parameter in options:
        raise TypeError(f"{parameter} is swept; do not also pass it as a keyword")
    render_options, overrides = _split_options(options)
    preset, seed = render_options.pop("preset"), render_options.pop("seed")
    if values is None and parameter == "variance_threshold":
        centre = resolve_parameters(preset, **overrides).variance_threshold
        values = [round(centre * factor, 6) for factor in FIG3_FACTORS]
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__") or len(values) == 0:
        raise ValueError(f"values must be a non-empty sequence, got {values!r}")
    runs = []
    for value in values:
        if parameter == "seed":
            runs.append((resolve_parameters(preset, **overrides), _validate_seed(value)))
        else:
            parameters = resolve_parameters(preset, **dict(overrides, **{parameter: value}))
            runs.append((parameters, _validate_seed(seed)))
    results = _render(image, runs, record_passes=False, **render_options)
    renders = [rendered for rendered, _ in results]
    sweep = _stack(renders)
    if render_options["return_diagnostics"]:
        return sweep, [diagnostics for _, diagnostics in results]
    return sweep


#: Keywords of the rendering functions that are not parameters of the algorithm.
_RENDER_OPTIONS = {
    "preset": DEFAULT_PRESET,
    "seed": 0,
    "channel_axis": None,
    "tone_limits": None,
    "plane_offset": 0,
    "workers": None,
    "return_diagnostics": False,
    "progress": None,
}


def _split_options(options: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Split keyword arguments into rendering options and parameter overrides."""
    render_options = {
        name: options.get(name, default) for name, default in _RENDER_OPTIONS.items()
    }
    overrides = {name: value for name, value in options.items() if name not in _RENDER_OPTIONS}
    return render_options, overrides


def _stack(arrays):
    if is_lazy(arrays[0]):
        import dask.array as da

        return da.stack(arrays)
    return np.stack(arrays)


def _render(
    image,
    runs: list[tuple[LabyrinthParameters, int]],
    *,
    channel_axis,
    tone_limits,
    plane_offset,
    workers,
    record_passes: bool,
    progress: ProgressCallback | None,
    return_diagnostics: bool,
) -> list[tuple[Any, Any]]:
    """Render ``image`` once per ``(parameters, seed)`` run: ``[(result, diagnostics)]``."""
    if workers is None:
        workers = os.cpu_count() or 1
    if not isinstance(workers, numbers.Integral) or isinstance(workers, bool):
        raise TypeError(f"workers must be an integer or None, got {workers!r}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be callable, got {progress!r}")
    if not isinstance(plane_offset, numbers.Integral) or isinstance(plane_offset, bool):
        raise TypeError(f"plane_offset must be an integer, got {plane_offset!r}")
    if plane_offset < 0:
        raise ValueError(f"plane_offset must be >= 0, got {plane_offset}")
    if is_lazy(image):
        if return_diagnostics:
            raise ValueError("return_diagnostics is not available for dask arrays (lazy results)")
        if progress is not None:
            raise ValueError(
                "progress is not available for dask arrays: use dask.diagnostics.ProgressBar"
            )
        return [
            (
                _render_lazy(
                    image,
                    parameters,
                    seed,
                    channel_axis=channel_axis,
                    tone_limits=tone_limits,
                    plane_offset=int(plane_offset),
                    record_passes=record_passes,
                ),
                None,
            )
            for parameters, seed in runs
        ]
    prepared = _prepare(image, channel_axis, tone_limits, plane_offset=int(plane_offset))
    total = prepared.n_planes * sum(parameters.passes for parameters, _ in runs)
    results = []
    done = 0
    for parameters, seed in runs:

        def report(step, start=done):
            if progress is not None:
                progress(start + step, total)

        steps = _render_steps(
            prepared, parameters, seed, record_passes=record_passes, workers=int(workers)
        )
        results.append(_drive(steps, report))
        done += prepared.n_planes * parameters.passes
    return results


def _render_lazy(
    image,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    channel_axis,
    tone_limits,
    plane_offset: int,
    record_passes: bool,
):
    """A lazy dask array rendering ``image`` block by block, whole planes per block."""
    import dask.array as da

    _validate_dtype_and_shape(np.dtype(image.dtype), image.shape)
    channel_axis = _normalise_channel_axis(channel_axis, image.ndim)
    dtype = np.dtype(image.dtype)
    if tone_limits is None and dtype != np.uint8:
        from ._chunked import default_tone_limits  # exact, streamed over the blocks

        tone_limits = default_tone_limits(image, channel_axis)
    scale = resolve_tone_scale(np.empty(0, dtype), tone_limits)
    planes = image if channel_axis is None else da.moveaxis(image, channel_axis, -3)
    whole = {planes.ndim - 2: -1, planes.ndim - 1: -1}
    if channel_axis is not None:
        whole[planes.ndim - 3] = -1  # alpha is recognised by its position among all channels
    planes = planes.rechunk(whole)
    block_channel_axis = None if channel_axis is None else planes.ndim - 3
    leading_total = planes.shape[:-2]

    def render_block(block, block_info=None):
        location = block_info[0]["array-location"]
        prepared = _Prepared(
            block,
            block_channel_axis,
            scale,
            plane_offset=plane_offset,
            leading_origin=tuple(start for start, _ in location[:-2]),
            leading_total=leading_total,
        )
        result, _ = _drive(_render_steps(prepared, parameters, seed, record_passes=record_passes))
        return result

    if record_passes:
        rendered = planes.map_blocks(
            render_block,
            new_axis=0,
            chunks=((parameters.passes + 1,),) + planes.chunks,
            dtype=dtype,
        )
        shift = 1
    else:
        rendered = planes.map_blocks(render_block, dtype=dtype)
        shift = 0
    if channel_axis is not None:
        rendered = da.moveaxis(rendered, -3, channel_axis + shift)
    return rendered


def resolve_parameters(preset: str = DEFAULT_PRESET, **overrides: Any) -> LabyrinthParameters:
    """Parameters of ``preset`` with every non-None override applied, validated.

    Setting ``tone_ranges`` without ``tones`` resets the tones to T = L.
    """
    values = preset_values(preset)
    given = {name: value for name, value in overrides.items() if value is not None}
    unknown = set(given) - set(PARAMETER_NAMES)
    if unknown:
        raise TypeError(f"unknown parameter(s): {', '.join(sorted(unknown))}")
    if "tone_ranges" in given and "tones" not in given:
        values["tones"] = None
    values.update(given)
    return make_parameters(**values)


def _validate_seed(seed: Any) -> int:
    if not isinstance(seed, numbers.Integral) or isinstance(seed, (bool, np.bool_)):
        raise TypeError(f"seed must be an integer, got {seed!r}")
    seed = int(seed)
    if not 0 <= seed < 2**64:
        raise ValueError(f"seed must be between 0 and 2**64 - 1, got {seed}")
    return seed


@dataclasses.dataclass
class _Prepared:
    """An input image split into planes, with its tone scale."""

    image: np.ndarray  # the caller's data, never written to
    channel_axis: int | None
    scale: ToneScale
    plane_offset: int = 0
    # where the image's planes lie in the whole array it is a block of
    leading_origin: tuple[int, ...] | None = None
    leading_total: tuple[int, ...] | None = None

    def plane_index(self, index: tuple[int, ...]) -> int:
        """Index of the random stream of the plane at ``index`` of ``planes``."""
        if self.leading_total is None:
            flat = np.ravel_multi_index(index, self.planes.shape[:-2]) if index else 0
        else:
            where = tuple(o + i for o, i in zip(self.leading_origin, index))
            flat = np.ravel_multi_index(where, self.leading_total) if where else 0
        return self.plane_offset + int(flat)

    @property
    def planes(self) -> np.ndarray:
        """The image as ``leading_shape + (H, W)``, channels last of the leading axes."""
        return self.to_planes(self.image)

    def to_planes(self, array: np.ndarray) -> np.ndarray:
        """View of an array shaped like the image in the layout of ``planes``."""
        if self.channel_axis is None:
            return array
        return np.moveaxis(array, self.channel_axis, -3)

    def to_image_layout(self, leading: np.ndarray) -> np.ndarray:
        """View of ``(k,) + leading_shape`` data with the channel axis back in place."""
        if self.channel_axis is None:
            return leading
        spatial = _spatial_axes(self.image.ndim, self.channel_axis)
        position = sum(1 for axis in range(self.channel_axis) if axis not in spatial)
        return np.moveaxis(leading, -1, 1 + position)

    @property
    def n_planes(self) -> int:
        return int(np.prod(self.planes.shape[:-2]))

    def is_alpha(self, index: tuple[int, ...]) -> bool:
        return self.channel_axis is not None and self.planes.shape[-3] == 4 and index[-1] == 3


def _spatial_axes(ndim: int, channel_axis: int | None) -> tuple[int, int]:
    axes = [axis for axis in range(ndim) if axis != channel_axis]
    return axes[-2], axes[-1]


def _prepare(
    image: Any, channel_axis: int | None, tone_limits: Any, *, plane_offset: int = 0
) -> _Prepared:
    array = _validate_image(image)
    channel_axis = _normalise_channel_axis(channel_axis, array.ndim)
    prepared = _Prepared(array, channel_axis, ToneScale(0.0, 255.0), plane_offset=plane_offset)
    colour = prepared.planes
    if channel_axis is not None and colour.shape[-3] == 4:
        colour = colour[..., :3, :, :]  # the tone scale ignores alpha
    prepared.scale = resolve_tone_scale(colour, tone_limits)
    return prepared


def _normalise_channel_axis(channel_axis: Any, ndim: int) -> int | None:
    if channel_axis is None:
        return None
    if not isinstance(channel_axis, numbers.Integral) or isinstance(channel_axis, bool):
        raise TypeError(f"channel_axis must be an integer or None, got {channel_axis!r}")
    if ndim < 3:
        raise ValueError(f"channel_axis needs an image of at least 3 dimensions, got {ndim}")
    if not -ndim <= channel_axis < ndim:
        raise ValueError(
            f"channel_axis {channel_axis} is out of range for an image of {ndim} dimensions"
        )
    return int(channel_axis) % ndim


def _validate_image(image: Any) -> np.ndarray:
    if isinstance(image, (str, bytes)) or image is None:
        raise TypeError(f"image must be an array, got {type(image).__name__}")
    array = np.asarray(image)
    _validate_dtype_and_shape(array.dtype, array.shape)
    return array


def _validate_dtype_and_shape(dtype: np.dtype, shape: tuple[int, ...]) -> None:
    if dtype not in _SUPPORTED_DTYPES:
        if dtype.kind in "iu":
            hint = "; 64-bit integers usually hold labels: cast an intensity image to float32"
        else:
            hint = ""
        raise TypeError(
            f"image dtype {dtype} is not supported: use an integer type up to "
            f"32 bits or a float type{hint}"
        )
    if len(shape) < 2:
        raise ValueError(f"image must have at least 2 dimensions, got {len(shape)}")
    if 0 in shape:
        raise ValueError(f"image is empty (shape {shape})")


def _drive(
    steps: Generator[int, None, tuple[np.ndarray, np.ndarray]],
    on_step: Callable[[int], Any] | None = None,
):
    """Run a ``_render_steps`` generator to its end, calling ``on_step(done)`` on each step."""
    while True:
        try:
            done = next(steps)
        except StopIteration as finished:
            return finished.value
        if on_step is not None:
            on_step(done)


def _render_steps(
    prepared: _Prepared,
    parameters: LabyrinthParameters,
    seed: int,
    *,
    record_passes: bool,
    workers: int = 1,
) -> Generator[int, None, tuple[np.ndarray, np.ndarray]]:
    """Render plane by plane, yielding the count of plane-passes done.

    With several planes and ``workers > 1``, planes run concurrently on
    threads (the kernel holds no GIL); with one plane the workers share its
    checkerboard bands. Returns (as the
    generator's value) the rendered image, or with ``record_passes`` the
    stack of the input and every pass, and the diagnostics.
    """
    image = prepared.image
    passes = parameters.passes
    if record_passes:
        result = np.empty((passes + 1,) + image.shape, dtype=image.dtype)
        result[0] = image
        for k in range(1, passes + 1):
            result[k] = image
        targets = [prepared.to_planes(result[k]) for k in range(1, passes + 1)]
    else:
        result = image.copy()
        targets = [prepared.to_planes(result)]
    source_planes = prepared.planes
    leading_shape = source_planes.shape[:-2]
    plane_size = source_planes.shape[-2] * source_planes.shape[-1]
    counts = np.zeros((passes,) + leading_shape + (len(DIAGNOSTIC_FIELDS),), dtype=np.int64)
    planes = []
    for index in np.ndindex(leading_shape):
        if prepared.is_alpha(index):
            counts[(slice(None),) + index + (DIAGNOSTIC_FIELDS.index("skipped"),)] = plane_size
        else:
            planes.append(index)
    plane_workers = max(1, min(workers, len(planes)))
    band_workers = workers if plane_workers == 1 else 1

    def render_plane(index):
        """Every pass over one plane, yielding after each."""
        initial = np.ascontiguousarray(prepared.scale.to_tones(source_planes[index]))
        has_nonfinite = image.dtype.kind == "f" and not np.isfinite(initial).all()
        work = initial.copy()
        for pass_index in range(passes):
            run_pass(
                work,
                parameters,
                seed=seed,
                plane_index=prepared.plane_index(index),
                pass_index=pass_index,
                counts=counts[(pass_index,) + index],
                has_nonfinite=has_nonfinite,
                workers=band_workers,
            )
            if record_passes:
                _write_changes(targets[pass_index][index], initial, work, prepared.scale)
            yield
        if not record_passes and passes:
            _write_changes(targets[0][index], initial, work, prepared.scale)

    done = 0
    if plane_workers == 1:
        for index in planes:
            for _ in render_plane(index):
                done += 1
                yield done
    else:
        finished = queue.SimpleQueue()  # one item per plane-pass, or an error

        def run(index):
            try:
                for _ in render_plane(index):
                    finished.put(None)
            except BaseException as error:
                finished.put(error)

        with ThreadPoolExecutor(plane_workers) as pool:
            futures = [pool.submit(run, index) for index in planes]
            try:
                for _ in range(len(planes) * passes):
                    item = finished.get()
                    if item is not None:
                        raise item
                    done += 1
                    yield done
            finally:  # on an error or when the caller stops early
                for future in futures:
                    future.cancel()
    diagnostics = prepared.to_image_layout(counts.view(DIAGNOSTICS_DTYPE)[..., 0])
    return result, np.ascontiguousarray(diagnostics)


def run_pass(
    tones: np.ndarray,
    parameters: LabyrinthParameters,
    *,
    seed: int = 0,
    plane_index: int = 0,
    pass_index: int = 0,
    counts: np.ndarray | None = None,
    has_nonfinite: bool | None = None,
    workers: int = 1,
) -> np.ndarray:
    """Run one pass of the numba kernel on a float32 plane of 0-255 tones, in place.

    The low-level entry point under :func:`labyrinth` (no tone mapping, no
    copies, no validation of ``tones``): ``tones`` must be a C-contiguous
    2-D float32 array. ``counts``, if given, is an int64 array of
    ``len(DIAGNOSTIC_FIELDS)`` that the pass increments. With
    ``scan="checkerboard"``, ``workers`` threads share each colour's rows.
    Returns ``counts``.
    """
    from ._kernel import labyrinth_pass  # numba is imported on first use only

    if counts is None:
        counts = np.zeros(len(DIAGNOSTIC_FIELDS), dtype=np.int64)
    if has_nonfinite is None:
        has_nonfinite = not np.isfinite(tones).all()
    arguments = (
        tones,
        parameters.mean_threshold,
        parameters.variance_threshold,
        *_kernel_tables(parameters),
        parameters.max_tries,
        np.uint64(seed),
        plane_index,
        pass_index,
        BORDERS.index(parameters.border),
        VARIANCE_RATIOS.index(parameters.variance_ratio),
        VARIANCE_ACTIONS.index(parameters.variance_action),
        parameters.condition_order == "variance_first",
        ON_EXHAUSTED.index(parameters.on_exhausted),
        parameters.include_centre,
        SCANS.index(parameters.scan),
        has_nonfinite,
    )
    if parameters.scan != "checkerboard":
        labyrinth_pass(*arguments, counts)
        return counts
    height = tones.shape[0]
    bands = np.linspace(0, height, min(workers, max(1, height // 2)) + 1).astype(int)
    band_counts = np.zeros((len(bands) - 1, len(DIAGNOSTIC_FIELDS)), dtype=np.int64)
    for colour in range(4):  # the pixels of one colour are independent of each other
        if len(bands) == 2:
            labyrinth_pass(*arguments, band_counts[0], colour, 0, height)
            continue
        with ThreadPoolExecutor(len(bands) - 1) as pool:
            for future in [
                pool.submit(labyrinth_pass, *arguments, band_counts[k], colour, start, stop)
                for k, (start, stop) in enumerate(zip(bands[:-1], bands[1:]))
            ]:
                future.result()
    counts += band_counts.sum(axis=0)
    return counts


@functools.lru_cache(maxsize=64)
def _kernel_tables(parameters: LabyrinthParameters):
    """Inner range limits, T_inf and T_sup as the float64 arrays the kernel takes."""
    range_bounds = np.array(parameters.tone_ranges[1:-1], dtype=np.float64)
    tone_low = np.array([low for low, _ in parameters.tones], dtype=np.float64)
    tone_high = np.array([high for _, high in parameters.tones], dtype=np.float64)
    return range_bounds, tone_low, tone_high


def _write_changes(
    target: np.ndarray,
    initial: np.ndarray,
    work: np.ndarray,
    scale: ToneScale,
) -> None:
    """Map back into ``target`` (holding the source values) the tones that changed."""
    changed = initial.view(np.uint32) != work.view(np.uint32)
    target[changed] = scale.from_tones(work[changed], target.dtype)
