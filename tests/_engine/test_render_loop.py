"""The run generator: progress events, the result, and cancellation by closing it."""

import threading

import numpy as np
import pytest
from skimage import data

from napari_labyrinth import (
    Progress,
    Result,
    _engine,
    labyrinth,
    labyrinth_stack,
    labyrinth_steps,
    labyrinth_sweep,
    resolve_parameters,
)
from napari_labyrinth._engine import render_loop
from napari_labyrinth._engine.changes import gather_changes


@pytest.fixture(scope="module")
def camera():
    return data.camera()[::4, ::4].copy()


def _drain(steps):
    events = list(steps)
    return events[:-1], events[-1]


@pytest.mark.parametrize("workers", [1, 2])
def test_events_count_every_plane_pass_then_the_result(camera, workers):
    stack = np.stack([camera, camera.T, camera[::-1]])
    progress, result = _drain(labyrinth_steps(stack, passes=3, seed=4, workers=workers))
    assert all(isinstance(event, Progress) for event in progress)
    assert [event.done for event in progress] == list(range(1, 10))
    assert {event.total for event in progress} == {9}
    assert sorted((event.plane, event.pass_number) for event in progress) == [
        (plane, pass_number) for plane in range(3) for pass_number in (1, 2, 3)
    ]
    assert isinstance(result, Result)
    want, diagnostics = labyrinth(stack, passes=3, seed=4, return_diagnostics=True)
    np.testing.assert_array_equal(result.image, want)
    np.testing.assert_array_equal(result.diagnostics, diagnostics)


def test_stack_and_sweep_modes_give_what_the_functions_give(camera):
    *_, stack = labyrinth_steps(camera, "stack", passes=2)
    np.testing.assert_array_equal(stack.image, labyrinth_stack(camera, passes=2))
    events = list(labyrinth_steps(camera, "sweep", parameter="passes", values=[1, 3]))
    assert [event.run for event in events[:-1]] == [0, 1, 1, 1]
    assert events[-2].total == 4
    np.testing.assert_array_equal(events[-1].image, labyrinth_sweep(camera, "passes", [1, 3]))
    assert len(events[-1].diagnostics) == 2


def test_rgba_progress_counts_only_the_rendered_planes(camera):
    rgba = np.dstack([camera, camera, camera, np.full_like(camera, 7)])
    progress, result = _drain(labyrinth_steps(rgba, passes=2, channel_axis=-1, colour="channels"))
    assert progress[-1].done == progress[-1].total == 6  # alpha is not rendered
    np.testing.assert_array_equal(result.image[..., 3], rgba[..., 3])


def test_bad_arguments_are_refused_at_the_call_not_at_the_first_step(camera):
    with pytest.raises(ValueError, match="passes"):
        labyrinth_steps(camera, passes=-1)
    with pytest.raises(ValueError, match="mode"):
        labyrinth_steps(camera, "film")
    with pytest.raises(TypeError, match="sweep"):
        labyrinth_steps(camera, parameter="passes", values=[1])
    with pytest.raises(TypeError, match="unknown parameter"):
        labyrinth_steps(camera, palette=3)


@pytest.mark.parametrize("workers", [1, 2])
def test_closing_cancels_within_one_pass_and_leaves_nothing_running(camera, workers, monkeypatch):
    calls = []
    real = render_loop.run_pass

    def counting_pass(*args, **kwargs):
        calls.append(threading.current_thread().name)
        return real(*args, **kwargs)

    monkeypatch.setattr(render_loop, "run_pass", counting_pass)
    real_banded = render_loop.banded_pass  # integer planes on one thread each

    def counting_banded_pass(*args, **kwargs):
        calls.append(threading.current_thread().name)
        return real_banded(*args, **kwargs)

    monkeypatch.setattr(render_loop, "banded_pass", counting_banded_pass)
    stack = np.stack([data.camera()] * 8)  # ~5 ms a pass: the run takes far longer than close()
    steps = labyrinth_steps(stack, passes=4, workers=workers)
    first = next(steps)
    assert first.done == 1 and first.total == 32
    before = len(calls)
    steps.close()
    after = len(calls)
    # threads stop after the pass they are running: at most one pass per thread may start
    # between close() and the moment the threads see it, far from the 32 of the whole run
    assert after - before <= workers
    assert after < 32
    assert not [t for t in threading.enumerate() if t.name.startswith("napari-labyrinth")]
    assert len(calls) == after  # nothing runs after close() returned
    with pytest.raises(StopIteration):
        next(steps)


def test_an_error_in_a_plane_reaches_the_caller_and_stops_the_pool(camera, monkeypatch):
    def failing_pass(*args, **kwargs):
        raise MemoryError("no room")

    monkeypatch.setattr(render_loop, "run_pass", failing_pass)
    monkeypatch.setattr(render_loop, "banded_pass", failing_pass)  # integer planes on one thread
    with pytest.raises(MemoryError, match="no room"):
        list(labyrinth_steps(np.stack([camera] * 4), workers=2))
    assert not [t for t in threading.enumerate() if t.name.startswith("napari-labyrinth")]


def test_dask_input_yields_only_the_lazy_result(camera):
    da = pytest.importorskip("dask.array")
    events = list(labyrinth_steps(da.from_array(np.stack([camera, camera]))))
    assert len(events) == 1 and isinstance(events[0], Result)
    assert isinstance(events[0].image, da.Array) and events[0].diagnostics is None


def test_a_stack_s_partial_result_holds_each_pass_as_soon_as_it_is_reported(camera):
    stack = np.stack([camera, camera.T])
    want = labyrinth_stack(stack, passes=3, workers=1)
    events = list(labyrinth_steps(stack, "stack", passes=3, workers=2))
    for event in events[:-1]:
        np.testing.assert_array_equal(
            event.partial[event.pass_number, event.plane], want[event.pass_number, event.plane]
        )
    assert "partial" not in repr(events[0])  # events print short


# Integer planes: tones in one pass and a fused write-back, as the numpy path.

from napari_labyrinth.core.tone_scale import (  # noqa: E402
    ToneScale,
    integer_plane_tones,
    write_changed_values,
)

INTEGER_SCALES = [(0.0, 255.0), (12.0, 3000.5), (-100.0, 100.0), (0.0, 1.0), (-5e9, 5e9)]
# limits or a gain that float32 does not hold: float64, as ToneScale.to_tones
INTEGER_SCALES += [(-1e38, 1e38), (0.0, 1e-31), (-1e300, 1e300)]


@pytest.mark.parametrize("dtype", [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32])
def test_integer_tones_and_write_back_equal_the_numpy_path(dtype):
    info = np.iinfo(dtype)
    if np.dtype(dtype).itemsize <= 2:  # every value of the type
        values = np.arange(info.min, info.max + 1, dtype=np.int64).astype(dtype).reshape(-1, 256)
    else:
        rng = np.random.default_rng(0)
        values = rng.integers(info.min, info.max, (64, 128), endpoint=True).astype(dtype)
        values[0, :4] = [info.min, info.max, 0, 1]
    rng = np.random.default_rng(1)
    for low, high in INTEGER_SCALES:
        scale = ToneScale(low, high)
        tones = integer_plane_tones(scale, values)
        want = scale.to_tones(values)
        np.testing.assert_array_equal(tones.view(np.uint32), want.view(np.uint32))
        # a pass changes some tones (to any tone, the ends and the same tone included)
        work = tones.copy()
        changed = rng.random(values.shape) < 0.3
        work[changed] = rng.uniform(0, 255, int(changed.sum())).astype(np.float32)
        work.flat[:3] = [0.0, 255.0, tones.flat[2]]
        got = values.copy()
        write_changed_values(scale, got, values, work)
        expected = values.copy()
        _engine.write_changes(expected, want, work, scale)
        np.testing.assert_array_equal(got, expected)


def test_a_non_contiguous_or_float_plane_takes_the_numpy_path():
    scale = ToneScale(0.0, 255.0)
    assert integer_plane_tones(scale, np.zeros((4, 6), np.uint8)[:, ::2]) is None
    assert integer_plane_tones(scale, np.zeros((4, 6), np.float32)) is None


def test_uint8_on_the_paper_scale_rounds_every_tone_half_to_even():
    scale = ToneScale(0.0, 255.0)
    values = np.array([[0, 1, 2, 254, 7, 255, 9]], np.uint8)
    work = np.array([[0.5, 1.5, 2.5, 254.5, -0.0, 255.0, 9.0]], np.float32)
    got = values.copy()
    write_changed_values(scale, got, values, work)
    np.testing.assert_array_equal(got, [[0, 2, 2, 254, 0, 255, 9]])
    expected = values.copy()
    _engine.write_changes(expected, scale.to_tones(values), work, scale)
    np.testing.assert_array_equal(got, expected)


# The pixels a pass writes are noted, so that the write-back visits only them.


def _noisy_plane(shape, seed):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[: shape[0], : shape[1]]
    plane = 90 + 60 * np.sin(x / 4.0 + y / 7.0) + rng.normal(0, 40, shape)
    return np.clip(plane, 0, 255).astype(np.float32)


@pytest.mark.parametrize("preset", ["paper", "labyrinth"])
@pytest.mark.parametrize(
    "scan, workers, tile", [("raster", 1, None), ("raster", 3, (4, 9)), ("checkerboard", 2, None)]
)
def test_every_pixel_a_pass_changes_is_noted(preset, scan, workers, tile):
    from napari_labyrinth.core.codes import OUT_OF_TRIES, PUSHED, REDRAWN

    parameters = resolve_parameters(preset, scan=scan, on_exhausted="last_draw")
    plane = _noisy_plane((37, 53), seed=len(preset))
    before = plane.copy()
    changes = _engine.new_changes(plane.size)
    counts = _engine.run_pass(plane, parameters, workers=workers, tile=tile, changes=changes)
    listed = _engine.listed_changes(changes)
    changed = np.flatnonzero(plane.view(np.uint32) != before.view(np.uint32))
    assert changed.size > 0
    assert set(changed) <= set(listed.tolist())
    assert len(listed) == counts[PUSHED] + counts[REDRAWN] + counts[OUT_OF_TRIES]


@pytest.mark.parametrize("banded", [False, True])
def test_more_changes_than_noted_fall_back_to_visiting_every_pixel(monkeypatch, banded):
    image = (_noisy_plane((40, 50), seed=3) * 200).astype(np.uint16)
    want = labyrinth_stack(image, passes=2)
    if not banded:
        monkeypatch.setattr(render_loop, "_banded_render", lambda *arguments: False)
    for room in (0, 1, 5):  # no room, or past it during the first or the second pass
        room_for = lambda pixels, room=room: np.zeros(room + 1, np.int64)  # noqa: E731
        monkeypatch.setattr(render_loop, "new_changes", room_for)
        np.testing.assert_array_equal(labyrinth_stack(image, passes=2), want)


def test_the_threads_notes_are_gathered_unless_they_do_not_fit():
    parts = [np.array([1, 7, 0]), np.array([2, 8, 9])]  # one write noted, then two
    changes = np.zeros(4, np.int64)
    gather_changes(changes, parts)
    np.testing.assert_array_equal(_engine.listed_changes(changes), [7, 8, 9])
    changes = np.zeros(3, np.int64)
    gather_changes(changes, parts)
    assert _engine.listed_changes(changes) is None
    overflowed = np.array([5, 1, 2], np.int64)  # five writes, room for two
    changes = np.zeros(10, np.int64)
    gather_changes(changes, [overflowed])
    assert _engine.listed_changes(changes) is None


# Integer planes on one thread: tones made and values written band of rows by band of rows.


@pytest.fixture
def narrow_bands(monkeypatch):
    """Bands of 2**18 bytes of tones (15 rows at W 4099, 31 at W 2100): the planes below
    hold several bands, and a ring, as large planes do with the default bands."""
    from napari_labyrinth.core import _banded_pass

    monkeypatch.setattr(_banded_pass, "band_rows", lambda width: max(4, (1 << 18) // (4 * width)))


def _unbanded(monkeypatch, render, *args, **kwargs):
    """``render(*args, **kwargs)`` with the tones, passes and write-back each over the plane."""
    with monkeypatch.context() as patched:
        patched.setattr(render_loop, "_banded_render", lambda *arguments: False)
        return render(*args, **kwargs)


BANDED_CASES = [
    # dtype, tone limits, shape (W 4099: bands of 15 rows; a ring unless the plane is as short)
    (np.uint16, None, (75, 4099)),
    (np.uint8, None, (46, 4099)),
    (np.uint8, (10, 200), (31, 4099)),
    (np.int16, None, (16, 4099)),
    (np.uint32, None, (33, 4099)),
    (np.uint16, None, (3, 5000)),
    (np.uint16, None, (40, 1)),
]


@pytest.mark.usefixtures("narrow_bands")
@pytest.mark.parametrize("dtype, limits, shape", BANDED_CASES)
@pytest.mark.parametrize("preset", ["paper", "labyrinth"])
@pytest.mark.parametrize("passes", [1, 3])
def test_the_banded_pass_equals_the_whole_plane_path(monkeypatch, dtype, limits, shape, preset,
                                                     passes):  # fmt: skip
    info = np.iinfo(dtype)
    plane = _noisy_plane(shape, seed=shape[0]) / 255.0
    image = (info.min + plane * (min(info.max, 2**20) - info.min)).astype(dtype)
    options = dict(preset=preset, passes=passes, tone_limits=limits, workers=1, seed=5)
    assert render_loop._banded_render(image, image, [()], resolve_parameters(preset), 1)
    got, got_counts = labyrinth(image, return_diagnostics=True, **options)
    want, want_counts = _unbanded(monkeypatch, labyrinth, image, return_diagnostics=True,
                                  **options)  # fmt: skip
    assert not np.array_equal(want, image)  # the pass changed something
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got_counts, want_counts)


@pytest.mark.usefixtures("narrow_bands")
@pytest.mark.parametrize("border", ["inside", "mirror", "nearest", "wrap"])
@pytest.mark.parametrize("scan", ["raster", "serpentine"])
@pytest.mark.parametrize("passes", [1, 2])
def test_the_banded_pass_keeps_every_border_and_scan(monkeypatch, border, scan, passes):
    image = (_noisy_plane((47, 4099), seed=2) * 200).astype(np.uint16)
    options = dict(preset="labyrinth", passes=passes, border=border, scan=scan, workers=1)
    want = _unbanded(monkeypatch, labyrinth, image, **options)
    np.testing.assert_array_equal(labyrinth(image, **options), want)


@pytest.mark.usefixtures("narrow_bands")
def test_stacks_and_alpha_are_banded_too(monkeypatch):
    rng = np.random.default_rng(4)
    stack = (_noisy_plane((3 * 40, 2100), seed=1) * 200).astype(np.uint16).reshape(3, 40, 2100)
    want = _unbanded(monkeypatch, labyrinth_stack, stack, passes=2, workers=1)
    np.testing.assert_array_equal(labyrinth_stack(stack, passes=2, workers=1), want)
    # an RGBA image with its channels first: the alpha plane is copied, never rendered
    rgba = rng.integers(0, 256, (4, 30, 2100)).astype(np.uint8)
    options = dict(channel_axis=0, alpha=True, passes=1, workers=1, colour="channels")
    want = _unbanded(monkeypatch, labyrinth, rgba, **options)
    got = labyrinth(rgba, **options)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got[3], rgba[3])


def test_planes_the_bands_cannot_take_take_the_whole_plane_path():
    parameters = resolve_parameters("paper")
    image = np.zeros((300, 300), np.uint16)
    assert render_loop._banded_render(image, image, [()], parameters, 1)
    assert not render_loop._banded_render(image, image, [()], parameters, 2)  # tiles
    floats = image.astype(np.float32)
    assert not render_loop._banded_render(floats, floats, [()], parameters, 1)
    checkerboard = resolve_parameters("paper", scan="checkerboard")
    assert not render_loop._banded_render(image, image, [()], checkerboard, 1)
    strided = np.zeros((300, 600), np.uint16)[:, ::2]
    assert not render_loop._banded_render(strided, strided, [()], parameters, 1)
    assert not render_loop._banded_render(image, image, [()], resolve_parameters(passes=0), 1)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("passes", [1, 3])
def test_bands_with_few_changes_write_only_those(monkeypatch, dtype, passes):
    # a photograph, enlarged: the paper's preset changes a few pixels of most bands
    # (240 x 4096: the default bands, 64 rows, four of them in a ring)
    image = np.repeat(np.repeat(data.camera()[250:310], 4, axis=0), 8, axis=1).astype(dtype)
    if dtype == np.uint16:
        image = image * 256
    options = dict(preset="paper", passes=passes, workers=1)
    want = _unbanded(monkeypatch, labyrinth, image, **options)
    assert 0 < np.count_nonzero(want != image) < image.size // 32  # under 1/16 of a band
    np.testing.assert_array_equal(labyrinth(image, **options), want)
    stack = np.stack([image, image[::-1]])  # every pass written out, from the same notes
    want = _unbanded(monkeypatch, labyrinth_stack, stack, **options)
    np.testing.assert_array_equal(labyrinth_stack(stack, **options), want)
