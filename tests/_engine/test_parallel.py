"""Threads change the speed, never the result."""

import collections
import itertools
import os
import threading

import numpy as np
import pytest

from napari_labyrinth import DIAGNOSTIC_FIELDS, labyrinth, labyrinth_stack, metrics


@pytest.fixture(scope="module")
def stack():
    from skimage import data

    camera = data.camera()[::4, ::4].copy()
    return np.stack([camera, camera.T, camera[::-1], camera[:, ::-1], camera // 2])


def test_planes_in_parallel_equal_one_thread(stack):
    one = labyrinth(stack, workers=1, return_diagnostics=True)
    two = labyrinth(stack, workers=2, return_diagnostics=True)
    many = labyrinth(stack, workers=7, return_diagnostics=True)
    for result in (two, many):
        np.testing.assert_array_equal(result[0], one[0])
        np.testing.assert_array_equal(result[1], one[1])
    np.testing.assert_array_equal(
        labyrinth_stack(stack, passes=3, workers=2), labyrinth_stack(stack, passes=3, workers=1)
    )


@pytest.mark.parametrize("workers", [2, 3, 64])
def test_checkerboard_bands_equal_one_thread(stack, workers):
    plane = stack[0]
    one, counts_one = labyrinth(plane, scan="checkerboard", workers=1, return_diagnostics=True)
    many, counts_many = labyrinth(
        plane, scan="checkerboard", workers=workers, return_diagnostics=True
    )
    np.testing.assert_array_equal(many, one)
    np.testing.assert_array_equal(counts_many, counts_one)


def test_checkerboard_is_another_order_with_a_like_pattern(stack):
    plane = stack[0]
    raster = labyrinth(plane)
    checkerboard = labyrinth(plane, scan="checkerboard")
    assert not np.array_equal(raster, checkerboard)
    a, b = metrics.describe(plane, raster), metrics.describe(plane, checkerboard)
    assert abs(a["edge_enhancement"] - b["edge_enhancement"]) < 0.15
    assert b["labyrinth_cover"] == pytest.approx(a["labyrinth_cover"], rel=0.5, abs=0.02)


def test_concurrent_calls_from_python_threads_are_safe(stack):
    expected = [
        labyrinth(stack[k], scan=scan) for k in range(4) for scan in ("raster", "checkerboard")
    ]
    results = [None] * len(expected)
    errors = []

    def work(i):
        try:
            k, scan = divmod(i, 2)
            results[i] = labyrinth(stack[k], scan=("raster", "checkerboard")[scan], workers=2)
        except Exception as error:  # reported below
            errors.append(error)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(expected))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    for got, want in zip(results, expected):
        np.testing.assert_array_equal(got, want)


def test_bad_workers_are_refused(stack):
    with pytest.raises(ValueError, match="workers"):
        labyrinth(stack[0], workers=0)
    with pytest.raises(TypeError, match="workers"):
        labyrinth(stack[0], workers=1.5)


# The exact-order schedule: parallelogram tiles of the raster scan on threads.

from napari_labyrinth import PRESETS  # noqa: E402
from napari_labyrinth._engine import (  # noqa: E402
    exact_order_refusal,
    exact_order_tiles,
    new_changes,
    run_pass,
)
from napari_labyrinth._engine.passes import pass_kernel_for, pass_parameters  # noqa: E402
from napari_labyrinth.core._kernel_arguments import PassRegion, PlanePass  # noqa: E402
from napari_labyrinth.core.parameters import PARAMETERS, make_parameters  # noqa: E402

#: Every option the tiles reproduce: the choices of the parameter table but
#: the scans and the border they refuse (tested apart below).
TILED_OPTIONS = {
    name: [
        value
        for value in (parameter.choices if parameter.kind == "choice" else (False, True))
        if not (name == "border" and value == "wrap")
    ]
    for name, parameter in PARAMETERS.items()
    if parameter.kind in ("choice", "bool") and name != "scan"
}


def textured_plane(shape, seed, holes=False):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[: shape[0], : shape[1]]
    plane = 90 + 60 * np.sin(x / 4.0 + y / 7.0) + rng.normal(0, 25, shape)
    plane = np.clip(plane, 0, 255).astype(np.float32)
    if holes:
        plane[rng.random(shape) < 0.03] = np.nan
        plane[shape[0] // 2, :] = np.inf
    return plane


def serial_and_tiled(plane, parameters, workers, tile, seed=3):
    serial = plane.copy()
    serial_counts = run_pass(serial, parameters, seed=seed, plane_index=1, pass_index=2)
    tiled = plane.copy()
    tiled_counts = run_pass(
        tiled, parameters, seed=seed, plane_index=1, pass_index=2, workers=workers, tile=tile
    )
    return serial, serial_counts, tiled, tiled_counts


def assert_same(serial, serial_counts, tiled, tiled_counts):
    np.testing.assert_array_equal(tiled.view(np.uint32), serial.view(np.uint32))
    np.testing.assert_array_equal(tiled_counts, serial_counts)


@pytest.mark.parametrize(
    "values",
    [dict(zip(TILED_OPTIONS, v)) for v in itertools.product(*TILED_OPTIONS.values())],
    ids=lambda v: "-".join(map(str, v.values())),
)
def test_tiles_on_threads_equal_the_raster_scan_for_every_option(values):
    plane = textured_plane((29, 41), seed=len(str(values)), holes=values["border"] == "mirror")
    for preset in PRESETS:
        parameters = make_parameters(**dict(PRESETS[preset], **values))
        for workers, tile in [(2, (3, 5)), (3, (4, 9)), (4, (1, 1))]:
            assert_same(*serial_and_tiled(plane, parameters, workers, tile))


@pytest.mark.parametrize("shape", [(2, 3), (5, 1), (1, 7), (17, 2), (31, 33), (64, 19)])
@pytest.mark.parametrize("holes", [False, True])
def test_tiles_equal_the_raster_scan_on_odd_sizes_and_non_finite_planes(shape, holes):
    plane = textured_plane(shape, seed=shape[0], holes=holes)
    for preset in PRESETS:
        parameters = make_parameters(**PRESETS[preset])
        for workers in range(1, 6):
            for tile in [(1, 1), (2, 3), (3, 2), (7, 16), (100, 100)]:
                assert_same(*serial_and_tiled(plane, parameters, workers, tile))


def _tile_order_results(plane, parameters, rows, diagonals, order):
    """The plane after running its tiles one after the other in ``order``."""
    kernel_parameters = pass_parameters(parameters)
    labyrinth_pass = pass_kernel_for(kernel_parameters)
    work = plane.copy()
    counts = np.zeros(len(DIAGNOSTIC_FIELDS), np.int64)
    plane_pass = PlanePass(np.uint64(3), 1, 2, not np.isfinite(plane).all())
    for band, j in order:
        row_stop = min(plane.shape[0], (band + 1) * rows)
        tile = PassRegion(-1, band * rows, row_stop, j * diagonals, (j + 1) * diagonals)
        labyrinth_pass(work, kernel_parameters, plane_pass, tile, counts, new_changes(0))
    return work, counts


def test_any_order_of_the_tiles_that_keeps_their_dependencies_equals_the_raster_scan():
    # Threads may run the tiles in any order in which tile (i, j) follows tile
    # (i - 1, j) (or the whole band above) and tile (i, j - 1); run random such
    # orders one tile after the other: each must give the raster scan's plane.
    rng = np.random.default_rng(7)
    for preset in PRESETS:
        parameters = make_parameters(**PRESETS[preset])
        for shape, rows, diagonals in [((23, 31), 3, 4), ((40, 17), 5, 3), ((12, 50), 2, 9)]:
            plane = textured_plane(shape, seed=rows, holes=rows == 5)
            serial = plane.copy()
            serial_counts = run_pass(serial, parameters, seed=3, plane_index=1, pass_index=2)
            tiles = exact_order_tiles(shape, rows, diagonals)
            for _ in range(5):
                done = [0] * len(tiles)  # tiles done in each band, in order
                order = []
                while len(order) < sum(map(len, tiles)):
                    ready = [
                        band
                        for band in range(len(tiles))
                        if done[band] < len(tiles[band])
                        and (
                            band == 0
                            or done[band - 1] == len(tiles[band - 1])
                            or tiles[band - 1][done[band - 1]] > tiles[band][done[band]]
                        )
                    ]
                    band = ready[rng.integers(len(ready))]
                    order.append((band, tiles[band][done[band]]))
                    done[band] += 1
                got, counts = _tile_order_results(plane, parameters, rows, diagonals, order)
                np.testing.assert_array_equal(got.view(np.uint32), serial.view(np.uint32))
                np.testing.assert_array_equal(counts, serial_counts)


def test_rectangles_in_wave_order_would_not_equal_the_raster_scan():
    # why parallelograms: with rectangles (x instead of x + y) tile (i, j)
    # reads tile (i - 1, j + 1) updated, which the raster scan has not done yet
    parameters = make_parameters(**PRESETS["labyrinth"])
    plane = textured_plane((24, 24), seed=1)
    serial = plane.copy()
    run_pass(serial, parameters, seed=3, plane_index=1, pass_index=2)
    rectangles = plane.copy()
    kernel_parameters = pass_parameters(parameters)
    labyrinth_pass = pass_kernel_for(kernel_parameters)
    plane_pass = PlanePass(np.uint64(3), 1, 2, False)
    for wave in range(7):
        for band in range(4):
            j = wave - band
            if 0 <= j < 4:  # rows [6 band, 6 band + 6), columns [6 j, 6 j + 6)
                for y in range(6 * band, 6 * band + 6):
                    rectangle_row = PassRegion(-1, y, y + 1, 6 * j + y, 6 * j + 6 + y)
                    labyrinth_pass(
                        rectangles, kernel_parameters, plane_pass, rectangle_row,
                        np.zeros(len(DIAGNOSTIC_FIELDS), np.int64), new_changes(0),
                    )  # fmt: skip
    assert not np.array_equal(rectangles, serial)


@pytest.mark.parametrize(
    "option,value", [("border", "wrap"), ("scan", "serpentine"), ("scan", "checkerboard")]
)
def test_orders_the_tiles_cannot_follow_run_otherwise_and_say_so(option, value, caplog):
    parameters = make_parameters(**dict(PRESETS["labyrinth"], **{option: value}))
    assert exact_order_refusal(parameters) is not None
    plane = textured_plane((40, 40), seed=2)
    with caplog.at_level("INFO", logger="napari_labyrinth"):
        serial, serial_counts, tiled, tiled_counts = serial_and_tiled(plane, parameters, 3, (4, 4))
    assert_same(serial, serial_counts, tiled, tiled_counts)
    if value != "checkerboard":  # checkerboard runs its own bands on the threads
        assert value in caplog.text and "one thread" in caplog.text
    for other in ("inside", "mirror", "nearest"):
        assert exact_order_refusal(make_parameters(**dict(PRESETS["paper"], border=other))) is None


def test_a_large_plane_uses_the_tiles_by_default_with_the_same_result(monkeypatch):
    from napari_labyrinth._engine import passes

    monkeypatch.setattr(passes, "idle_cores", lambda: 8)  # as on an idle machine

    calls = []
    real = passes.run_exact_order
    monkeypatch.setattr(
        passes, "run_exact_order", lambda *args: calls.append(args[8]) or real(*args)
    )
    image = (textured_plane((300, 260), seed=4) * 200).astype(np.uint16)
    one = labyrinth(image, passes=2, workers=1, return_diagnostics=True)
    assert calls == []
    many = labyrinth(image, passes=2, workers=3, return_diagnostics=True)
    assert calls == [3, 3]
    np.testing.assert_array_equal(many[0], one[0])
    np.testing.assert_array_equal(many[1], one[1])
    small = image[:100, :100]
    np.testing.assert_array_equal(labyrinth(small, workers=2), labyrinth(small, workers=1))
    assert calls == [3, 3]  # below MIN_PARALLEL_PIXELS: one thread


def test_a_mean_first_pass_takes_bands_twice_as_tall_with_the_same_result(monkeypatch):
    from napari_labyrinth._engine import passes

    monkeypatch.setattr(passes, "idle_cores", lambda: 8)
    rows = []
    real = passes.run_exact_order
    monkeypatch.setattr(
        passes, "run_exact_order", lambda *args: rows.append(args[6]) or real(*args)
    )
    image = (textured_plane((600, 300), seed=5) * 200).astype(np.uint16)
    for preset in ("paper", "labyrinth"):
        one = labyrinth(image, preset=preset, workers=1, return_diagnostics=True)
        two = labyrinth(image, preset=preset, workers=2, return_diagnostics=True)
        np.testing.assert_array_equal(two[0], one[0])
        np.testing.assert_array_equal(two[1], one[1])
    # 600 rows on 2 threads: 8 bands a thread (600 // 16) for the paper's mean-first
    # pass, 16 (600 // 32) for the labyrinth preset's variance-first one, each pass
    assert rows == [37] + [18] * 4


def test_tiles_run_on_the_caller_alone_when_no_thread_starts(monkeypatch):
    from napari_labyrinth import _threads

    def no_thread(*args):
        raise RuntimeError("can't start new thread")

    monkeypatch.setattr(_threads._thread, "start_new_thread", no_thread)
    plane = textured_plane((130, 150), seed=6)
    assert_same(*serial_and_tiled(plane, make_parameters(**PRESETS["paper"]), 3, (16, 32)))


def test_padded_counts_give_each_thread_whole_cache_lines():
    from napari_labyrinth._engine import padded_counts

    counts = padded_counts(5)
    assert counts.shape[0] == 5 and counts.strides[0] == 64
    assert counts.ctypes.data % 64 == 0 and not counts.any()


def test_workers_left_over_by_the_planes_tile_each_plane(monkeypatch):
    from napari_labyrinth._engine import passes

    monkeypatch.setattr(passes, "idle_cores", lambda: 8)  # as on an idle machine

    calls = []
    real = passes.run_exact_order
    monkeypatch.setattr(
        passes, "run_exact_order", lambda *args: calls.append(args[8]) or real(*args)
    )
    plane = (textured_plane((280, 250), seed=6) * 200).astype(np.uint16)
    stack = np.stack([plane, plane[::-1]])
    one = labyrinth(stack, passes=1, workers=1, return_diagnostics=True)
    four = labyrinth(stack, passes=1, workers=4, return_diagnostics=True)
    assert calls == [2, 2]  # two planes at once, each on two threads
    np.testing.assert_array_equal(four[0], one[0])
    np.testing.assert_array_equal(four[1], one[1])


def test_the_default_tiles_take_no_more_threads_than_idle_cores(monkeypatch):
    from napari_labyrinth._engine import passes

    calls = []
    real = passes.run_exact_order
    monkeypatch.setattr(
        passes, "run_exact_order", lambda *args: calls.append(args[8]) or real(*args)
    )
    plane = textured_plane((300, 260), seed=5)
    parameters = make_parameters(**PRESETS["paper"])
    want = plane.copy()
    want_counts = run_pass(want, parameters)
    for idle, expected in [(1, []), (2, [2]), (8, [3])]:
        calls.clear()
        monkeypatch.setattr(passes, "idle_cores", lambda idle=idle: idle)
        got = plane.copy()
        assert_same(want, want_counts, got, run_pass(got, parameters, workers=3))
        assert calls == expected
    calls.clear()  # given tiles are the caller's: exactly as asked
    run_pass(plane.copy(), parameters, workers=3, tile=(16, 64))
    assert calls == [3]


def test_idle_cores_counts_at_least_one():
    from napari_labyrinth._engine import idle_cores

    assert 1 <= idle_cores() <= (os.cpu_count() or 1)


def test_a_task_seen_once_does_not_take_a_core(monkeypatch):
    from napari_labyrinth._engine import cores as engine_cores

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if cores < 2:
        pytest.skip("one core: nothing to take")
    readings = iter([0, 1, 0, 1, 1, 1, 1])  # other running tasks, reading after reading
    monkeypatch.setattr(engine_cores, "_other_tasks", lambda: next(readings))
    monkeypatch.setattr(engine_cores, "_READINGS", collections.deque(maxlen=16))
    monkeypatch.setattr(engine_cores, "_SETTLE", 0.0)
    assert engine_cores.idle_cores() == cores  # alone
    assert engine_cores.idle_cores() == cores  # a task now, none a moment ago: a passing one
    assert engine_cores.idle_cores() == cores  # alone again
    assert engine_cores.idle_cores() == cores  # a task, none at the last reading
    assert engine_cores.idle_cores() == cores - 1  # a task now and at the last reading: busy
    monkeypatch.setattr(engine_cores, "_READINGS", collections.deque(maxlen=16))
    assert engine_cores.idle_cores() == cores - 1  # no earlier reading: two readings, both busy
