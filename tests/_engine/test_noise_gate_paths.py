"""The noise gate renders the same image whichever path takes the plane.

A plane's noise is measured once, on its values, before its passes: the whole-plane
path, the banded pass of integer planes, the exact-order tiles, the checkerboard's
bands and the blocks of a dask image all take the same floor, and agree bit for bit.
"""

import numpy as np
import pytest

from napari_labyrinth import labyrinth, labyrinth_stack, labyrinth_steps, samples
from napari_labyrinth._engine import render_loop
from napari_labyrinth.core.presets import resolve_parameters


def _dark_stack(shape=(2, 180, 150)):
    """Batonnets on a black field with camera noise, one per plane, uint16 (not on the
    paper's scale: the tones are a map of the values)."""
    return np.stack(
        [
            samples.smectic_batonnets(shape[1:], seed=k).astype(np.uint16) * 40
            for k in range(shape[0])
        ]
    )


def _gated(diagnostics) -> int:
    return int(diagnostics["noise_gated"].sum())


def _unbanded(monkeypatch, render, *args, **kwargs):
    with monkeypatch.context() as patched:
        patched.setattr(render_loop, "_banded_render", lambda *arguments: False)
        return render(*args, **kwargs)


@pytest.mark.parametrize("passes", [1, 3])
def test_the_banded_pass_equals_the_whole_plane_path_with_the_gate_on(monkeypatch, passes):
    from napari_labyrinth.core import _banded_pass

    monkeypatch.setattr(_banded_pass, "band_rows", lambda width: 16)  # several bands
    image = _dark_stack()
    options = dict(passes=passes, workers=1, seed=5, return_diagnostics=True)
    assert render_loop._banded_render(image, image, [(0,)], resolve_parameters("labyrinth"), 1)
    got, got_counts = labyrinth(image, **options)
    want, want_counts = _unbanded(monkeypatch, labyrinth, image, **options)
    assert _gated(want_counts) > 0
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got_counts, want_counts)


def test_tiles_and_planes_on_threads_equal_one_thread_with_the_gate_on(monkeypatch):
    from napari_labyrinth._engine import passes

    monkeypatch.setattr(passes, "idle_cores", lambda: 8)
    calls = []
    real = passes.run_exact_order
    monkeypatch.setattr(passes, "run_exact_order", lambda *a: calls.append(a[8]) or real(*a))
    plane = _dark_stack((1, 400, 300))[0]
    one, one_counts = labyrinth(plane, passes=2, workers=1, return_diagnostics=True)
    many, many_counts = labyrinth(plane, passes=2, workers=3, return_diagnostics=True)
    assert calls and _gated(one_counts) > 0
    np.testing.assert_array_equal(many, one)
    np.testing.assert_array_equal(many_counts, one_counts)
    stack = _dark_stack()
    np.testing.assert_array_equal(labyrinth(stack, workers=2), labyrinth(stack, workers=1))


def test_the_checkerboard_s_bands_equal_one_thread_with_the_gate_on():
    image = _dark_stack((1, 120, 100))[0].astype(np.float32)
    options = dict(scan="checkerboard", passes=2, return_diagnostics=True)
    one, one_counts = labyrinth(image, workers=1, **options)
    many, many_counts = labyrinth(image, workers=3, **options)
    assert _gated(one_counts) > 0
    np.testing.assert_array_equal(many, one)
    np.testing.assert_array_equal(many_counts, one_counts)


def test_a_stack_measures_each_plane_once_and_ends_as_the_single_rendering():
    image = _dark_stack()
    result = list(labyrinth_steps(image, passes=2))[-1]
    assert len(result.noise_sigma) == 2 and result.noise_sigma[0] != result.noise_sigma[1]
    np.testing.assert_array_equal(labyrinth_stack(image, passes=2)[-1], result.image)


def test_a_lazy_image_renders_as_in_memory_with_the_gate_on():
    da = pytest.importorskip("dask.array")
    image = _dark_stack((3, 96, 90))
    lazy = da.from_array(image, chunks=(2, 48, 45))  # split planes: rechunked whole
    np.testing.assert_array_equal(labyrinth(lazy, seed=2).compute(), labyrinth(image, seed=2))


def test_a_colour_image_gates_its_luminance_and_renders_as_its_blocks():
    da = pytest.importorskip("dask.array")
    grey = samples.smectic_batonnets((96, 90), seed=1)
    rgb = np.stack([grey, grey // 2, grey], axis=-1)
    result = list(labyrinth_steps(rgb, channel_axis=-1))[-1]
    assert len(result.noise_sigma) == 1 and _gated(result.diagnostics) > 0
    lazy = da.from_array(np.stack([rgb, rgb[::-1]]), chunks=(1, 48, 90, 3))
    np.testing.assert_array_equal(
        labyrinth(lazy, channel_axis=-1).compute()[0], labyrinth(rgb, channel_axis=-1)
    )


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_plane_on_threads_measures_makes_and_writes_on_them_as_one_thread(monkeypatch, dtype):
    # its noise, its tones and its values, each shared by the threads of its tiles
    from napari_labyrinth import _engine, _threads
    from napari_labyrinth._engine import changes, passes
    from napari_labyrinth.core import noise

    for module in (passes, render_loop, _engine):
        monkeypatch.setattr(module, "idle_cores", lambda: 2)  # as on an idle machine
    monkeypatch.setattr(changes, "_MIN_SHARE", 16)  # a short list of changes shared too
    shared = []

    def counted(share, count):
        shared.append(count)
        _threads.run_shares(share, count)

    for module in (noise, render_loop, changes):
        monkeypatch.setattr(module, "run_shares", counted)
    plane = _dark_stack((1, 600, 480))[0]  # large enough for threads to share its noise
    plane = (plane // 40).astype(dtype) if dtype == np.uint8 else plane
    quiet = np.full_like(plane, plane.max() // 2)
    quiet[100:110, ::7] = plane.max()  # few changes: listed, and written where listed
    written_on_two = 0
    for image in (plane, quiet):
        for count in (1, 2):
            options = dict(passes=count, seed=3, return_diagnostics=True)
            one, one_counts = labyrinth(image, workers=1, **options)
            shared.clear()
            two, two_counts = labyrinth(image, workers=2, **options)
            assert shared[:2] == [2, 2]  # the noise, the tones; then the values written
            written_on_two += shared[2:] == [2]
            np.testing.assert_array_equal(two, one)
            np.testing.assert_array_equal(two_counts, one_counts)
        stack = labyrinth_stack(image, passes=2, workers=2)
        np.testing.assert_array_equal(stack, labyrinth_stack(image, passes=2, workers=1))
    assert written_on_two >= 2
    sigma = list(labyrinth_steps(plane, workers=2))[-1].noise_sigma
    assert sigma == list(labyrinth_steps(plane, workers=1))[-1].noise_sigma
