"""Threads change the speed, never the result."""

import threading

import numpy as np
import pytest

from napari_labyrinth import labyrinth, labyrinth_stack, metrics


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
