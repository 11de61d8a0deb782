"""Every first call a user can make, each kernel signature once: what the wheel carries.

The build of the platform wheel (``hatch_build.py``) runs these steps, through
``python -m napari_labyrinth._warmup --all``, with numba told the target CPU and
every kernel saved into the wheel (``core._shipped``): whatever a user's call
needs is then loaded, not compiled. Where no wheel carries the kernels, the same
command fills numba's cache ahead of use.

The steps cover ``labyrinth`` / ``labyrinth_stack`` / ``labyrinth_sweep`` for every
dtype the package takes, both presets, every reading option (whose kernel variants
``condition_order`` and ``include_centre`` pick), one worker and all (the
exact-order tiles), strided and byte-swapped inputs, colour, lazy (dask) arrays
and their blocks, band-by-band streaming from TIFF and zarr, ``find_window``,
every metric and ``describe``, the command line's commands, and the widget's runs
(single, stack, sweep, their previews, on grey, stacked and multiscale layers) as
its plan makes them. ``make test-wheel`` counts what the whole test suite still
compiles from the wheel.
"""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import tifffile

from . import labyrinth, labyrinth_stack, labyrinth_sweep, metrics, streaming
from .cli import main as command_line
from .core.noise import noise_sigma
from .core.parameters import PARAMETERS
from .core.percentiles import integer_percentiles
from .core.presets import PRESETS
from .core.tone_scale import SUPPORTED_DTYPES
from .io import write_image
from .widget.choices import Choices, LayerSnapshot, preview_choices
from .widget.plan import make_plan
from .widget.run import Failure, render
from .window import find_window

#: Side of the planes of :func:`every_call_steps`: above the exact-order tiles' smallest
#: plane (``_engine.tiles.MIN_PARALLEL_PIXELS``), so that a run on every core takes them.
EVERY_CALL_SIDE = 272


def _test_image(dtype, shape=(EVERY_CALL_SIDE, EVERY_CALL_SIDE), seed=0) -> np.ndarray:
    """Wavy stripes under a little noise over ``dtype``'s range (floats: 0..1): walls to
    draw and a field the noise gate measures."""
    rng = np.random.default_rng(seed)
    rows, columns = np.indices(shape[-2:])
    field = 0.5 + 0.4 * np.sin(columns / 3.0 + np.sin(rows / 9.0))
    field = np.clip(field + rng.normal(0, 0.02, shape[-2:]), 0, 1)
    field = np.broadcast_to(field, shape)
    dtype = np.dtype(dtype)
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        return (info.min + field * (float(info.max) - info.min)).astype(dtype)
    return field.astype(dtype)


def every_call_steps() -> list[tuple[str, Callable[[], object]]]:
    """Steps that make every first call a user can make, each kernel signature once:
    what the platform wheel's build compiles (``hatch_build.py``).

    ``labyrinth`` / ``labyrinth_stack`` / ``labyrinth_sweep`` for every dtype the package
    takes, both presets, every reading option's kernel variant, one worker and all
    (the exact-order tiles), colour, lazy (dask) arrays and their blocks, band-by-band
    streaming from zarr and TIFF, ``find_window``, every metric and ``describe``,
    the command line's commands, and the widget's runs (single, stack, sweep, preview,
    Auto) as its plan makes them.
    """

    steps = [(f"labyrinth() of {t} images", _calls_of_dtype(t)) for t in SUPPORTED_DTYPES]
    steps += [
        ("the default tone limits", _percentiles),
        ("the noise gate's estimate of a dark field", _noise_estimates),
        ("every reading option", _every_option),
        ("colour images", _colour),
        ("metrics", _metrics),
        ("find_window", _find_window),
        ("lazy arrays", _lazy),
        ("band-by-band streaming", _streaming),
        ("the command line", _command_line),
        ("the widget's runs", _widget_runs),
    ]
    return steps


def _calls_of_dtype(dtype) -> Callable[[], None]:
    def run():
        image = _test_image(dtype)
        for preset in PRESETS:
            for workers in (1, None):
                labyrinth(image, preset=preset, workers=workers, passes=2)
                labyrinth(image, preset=preset, workers=workers, noise_gate=0)
            labyrinth(image[:40, :40], preset=preset, return_diagnostics=True)
        labyrinth(_test_image(dtype, (2, 64, 64)), passes=1)
        labyrinth(image[::2, 1::2], passes=1)  # a strided view
        frozen = image.copy()
        frozen.setflags(write=False)  # a read-only array (a memory map, a napari layer's data)
        for workers in (1, None):
            labyrinth(frozen, passes=1, workers=workers)
            labyrinth(_quiet_image(dtype), passes=1, workers=workers)  # few pixels written
            labyrinth(_quiet_image(dtype, 640), passes=1, workers=workers)
        labyrinth(image.astype(image.dtype.newbyteorder()), passes=1)  # the other byte order
        labyrinth(image, tone_limits=(0, 1) if image.dtype.kind == "f" else None, passes=1)
        labyrinth_stack(image, passes=2)
        labyrinth_sweep(image, "variance_threshold", [0.02, 0.04], passes=1)
        labyrinth(image, variance_threshold="auto", passes=1)

    return run


def _quiet_image(dtype, side=EVERY_CALL_SIDE) -> np.ndarray:
    """A plane the passes barely change: their few writes are written back one by one."""
    image = _test_image(dtype, (side, side))
    quiet = np.full_like(image, image[0, 0])
    quiet[side // 2, :: max(side // 8, 1)] = image.max()
    return quiet


def _percentiles() -> None:
    """The default tone limits counted, as for an image of more values than
    ``percentiles.COMPILE_FROM_VALUES``, on values that take each of its routes."""
    for dtype in SUPPORTED_DTYPES:
        if dtype.kind not in "iu" or dtype.itemsize > 2:
            continue
        info = np.iinfo(dtype)
        cases = [
            np.full((7, 9), 3, dtype),
            np.array([[info.min, info.max]], dtype),
            np.array([[5] * 199 + [info.max]], dtype),
            np.arange(info.min, info.max + 1, dtype=np.int64).astype(dtype).reshape(-1, 16),
            _test_image(dtype),
        ]
        for values in cases:
            integer_percentiles(values, (0.5, 99.5))


def _noise_estimates() -> None:
    """Planes half black: the noise gate's quantile of their dark field, read in
    integers (uint8 on the scale (0, 255)) and in float tones; Immerkær's estimate of
    values (``core.noise.noise_sigma``)."""
    for dtype in (np.uint8, np.uint16):
        image = _test_image(dtype)
        image[: EVERY_CALL_SIDE // 2] = image.min()
        for workers in (1, None):
            labyrinth(image, passes=1, workers=workers)
    noise_sigma(_test_image(np.float64))


def _every_option() -> None:
    image = _test_image(np.uint8)
    for parameter in PARAMETERS.values():
        for value in getattr(parameter, "choices", None) or ():
            for workers in (1, None):
                labyrinth(image, passes=1, workers=workers, **{parameter.name: value})
    for include_centre in (False, True):
        for order in ("mean_first", "variance_first"):
            for workers in (1, None):
                labyrinth(image, passes=1, workers=workers, include_centre=include_centre,
                          condition_order=order)  # fmt: skip


def _colour() -> None:
    for dtype in (np.uint8, np.uint16, np.float32):
        rgb = np.stack([_test_image(dtype, seed=k) for k in range(3)], axis=-1)
        rgba = np.concatenate([rgb, rgb[..., :1]], axis=-1)
        for colour in ("luminance", "channels"):
            labyrinth(rgb, channel_axis=-1, colour=colour, passes=1)
        labyrinth(rgba, channel_axis=-1, passes=1)
        labyrinth_stack(rgb, channel_axis=-1, passes=1)


def _metrics() -> None:
    for dtype in SUPPORTED_DTYPES:
        image = _test_image(dtype)
        rendered = labyrinth(image, passes=1)
        metrics.describe(image, rendered)
        metrics.describe(image, rendered, workers=1)
        for _ in metrics.Comparison(image).describe_steps(rendered):
            pass
    image = _test_image(np.float32)
    rendered = labyrinth(image, passes=1)
    for function in (metrics.fine_scale, metrics.wall_map, metrics.labyrinth_cover,
                     metrics.wall_width, metrics.orientation, metrics.orientation_coherence):  # fmt: skip
        function(rendered)
    for function in (metrics.texture_added, metrics.contour_alignment, metrics.edge_enhancement):
        function(image, rendered)


def _find_window() -> None:
    for dtype in SUPPORTED_DTYPES:
        find_window(_test_image(dtype))


def _lazy() -> None:
    try:
        import dask.array as da  # the [dask] extra: optional
    except ImportError:  # not installed: no lazy arrays to prepare
        return

    for dtype in SUPPORTED_DTYPES:
        stack = da.from_array(_test_image(dtype, (3, 96, 96)), chunks=(1, 96, 96))
        labyrinth(stack, passes=1).compute()
        labyrinth(stack, passes=1, tone_limits=None, noise_gate=0).compute()
        labyrinth_stack(stack[0], passes=1).compute()
    image = _test_image(np.float32, (2, 96, 96))
    metrics.describe(da.from_array(image[0]), labyrinth(image[0], passes=1))


def _streaming() -> None:
    with _scratch() as folder:
        for dtype in SUPPORTED_DTYPES:
            image = _test_image(dtype)
            sources = [folder / f"{image.dtype}.tif"]
            tifffile.imwrite(sources[0], image, rowsperstrip=32)
            try:
                import zarr  # the [dask] extra: optional
            except ImportError:  # not installed: TIFF only
                pass
            else:
                sources.append(folder / f"{image.dtype}.zarr")
                stored = zarr.open_array(
                    str(sources[-1]), mode="w", shape=image.shape, chunks=(64, 64), dtype=image.dtype
                )
                stored[:] = image
            for source in sources:
                for preset in PRESETS:
                    for workers in (1, None):
                        output = folder / f"out-{preset}-{workers}-{source.name}"
                        streaming.render_plane_file(
                            source, output, preset=preset, workers=workers, passes=2
                        )


def _command_line() -> None:
    with _scratch() as folder:
        for dtype in (np.uint8, np.uint16, np.float32):
            source = folder / f"in-{np.dtype(dtype)}.tif"
            write_image(source, _test_image(dtype))
            for arguments in (
                [str(source), "-o", str(folder / f"out-{np.dtype(dtype)}.tif")],
                [str(source), "-o", str(folder / "stacks"), "--stack", "--passes", "2"],
                [str(source), "-o", str(folder / f"sweep-{np.dtype(dtype)}.tif"),
                 "--sweep", "variance_threshold=0.03,0.05"],
            ):  # fmt: skip
                _succeeded(command_line(["render", *arguments]))
            _succeeded(command_line(["reproduce", str(folder / f"out-{np.dtype(dtype)}.tif")]))
        png = folder / "in.png"
        write_image(png, _test_image(np.uint8))
        _succeeded(command_line(["render", str(png), "-o", str(folder / "out.png")]))


def _succeeded(code: int) -> None:
    if code != 0:
        raise RuntimeError(f"the command exited {code}")


def _widget_runs() -> None:
    for dtype in (np.uint8, np.uint16, np.float32):
        image = _test_image(dtype)
        limits = (0.0, 1.0) if image.dtype.kind == "f" else (float(image.min()), float(image.max()))
        layers = [
            LayerSnapshot.of(image, contrast_limits=limits),
            LayerSnapshot.of(_test_image(dtype, (3, 96, 96)), contrast_limits=limits),
            LayerSnapshot.of([image, image[::2, ::2]], multiscale=True, contrast_limits=limits),
        ]
        for snapshot in layers:
            for mode in ("single", "stack", "sweep"):
                choices = Choices(mode=mode, sweep_text="0.03, 0.05")
                for chosen in (choices, preview_choices(choices)):
                    _finished(render(make_plan(snapshot, chosen)))


def _finished(run):
    """The outcome of a widget run, all its steps taken; raises what the widget would show."""

    try:
        while True:
            next(run)
    except StopIteration as end:
        if isinstance(end.value, Failure):
            raise RuntimeError(end.value.message)
        return end.value


@contextlib.contextmanager
def _scratch() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="napari-labyrinth-warm-up-") as folder:
        yield Path(folder)


