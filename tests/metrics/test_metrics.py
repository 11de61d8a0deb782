"""Each metric separates a synthetic labyrinth from noise, blur and the unchanged image."""

import inspect
import math
import threading

import numpy as np
import pytest
from scipy import ndimage

from napari_labyrinth import labyrinth, metrics, samples
from napari_labyrinth.core.parameters import WORKERS
from napari_labyrinth.metrics import (
    _bands,
    _caches,
    _comparison,
    _lazy_kernels,
    _maps,
    _planes,
    _tensor,
)
from napari_labyrinth.samples import cholesteric_fingerprint

SIZE = 160


def walls(pattern):
    """Binary walls (30 / 230 tones) from a pattern in [0, 1]."""
    return np.where(pattern > np.median(pattern), 230.0, 30.0)


@pytest.fixture(scope="module")
def cases():
    """A smooth input and five renderings of it (rendered, on the 0-255 scale)."""
    y, x = np.mgrid[:SIZE, :SIZE]
    radius = np.hypot(y - SIZE / 2, x - SIZE / 2)
    # input: a bright disk with soft circular contours on a darker ramp
    original = 60 + 0.3 * x + 120 / (1 + np.exp((radius - 45) / 3.0))
    near_contour = np.abs(radius - 45) < 14
    # labyrinth: 2-pixel walls running along the circular contour
    rings = walls(np.cos(2 * np.pi * radius / 4.0))
    labyrinth = np.where(near_contour, rings, original)
    rng = np.random.default_rng(0)
    salt_pepper = original.copy()
    hit = rng.random(original.shape) < 0.02
    salt_pepper[hit] = rng.choice([0.0, 255.0], hit.sum())
    return {
        "original": original,
        "labyrinth": labyrinth,
        "noise": np.clip(original + rng.normal(0, 10, original.shape), 0, 255),
        "salt_pepper": salt_pepper,
        "blur": ndimage.gaussian_filter(original, 3),
        "unchanged": original.copy(),
    }


OTHERS = ("noise", "salt_pepper", "blur", "unchanged")


def test_texture_added(cases):
    original = cases["original"]
    value = {name: metrics.texture_added(original, cases[name]) for name in cases}
    assert value["unchanged"] == 1.0
    assert value["blur"] < 1.0
    assert value["labyrinth"] > 3 * max(value[name] for name in OTHERS)


def test_labyrinth_cover(cases):
    value = {name: metrics.labyrinth_cover(cases[name]) for name in cases}
    assert value["labyrinth"] > 0.2
    for name in OTHERS:
        assert value[name] < 0.01, name


def test_labyrinth_cover_of_a_fingerprint_texture_is_high():
    fingerprint = walls(cholesteric_fingerprint((SIZE, SIZE), pitch=8, seed=3, noise=0.0))
    assert metrics.labyrinth_cover(fingerprint) > 0.5


def test_wall_width(cases):
    assert metrics.wall_width(cases["labyrinth"]) == pytest.approx(2.0, abs=0.8)
    y, x = np.mgrid[:SIZE, :SIZE]
    assert metrics.wall_width(walls(np.cos(np.pi * x))) == pytest.approx(1.0, abs=0.3)
    diagonal = walls(np.cos(np.pi * (x * np.cos(0.4) + y * np.sin(0.4)) / 2))
    assert metrics.wall_width(diagonal) == pytest.approx(2.0, abs=0.3)
    assert metrics.wall_width(walls(np.cos(np.pi * x / 3))) == pytest.approx(3.0, abs=0.5)
    for name in OTHERS:
        assert math.isnan(metrics.wall_width(cases[name])), name


def test_orientation_coherence(cases):
    assert metrics.orientation_coherence(cases["labyrinth"]) > 0.6
    for name in OTHERS:
        assert math.isnan(metrics.orientation_coherence(cases[name])), name
    # straight walls are fully coherent, whatever their direction
    y, x = np.mgrid[:SIZE, :SIZE]
    for pattern in (np.cos(np.pi * x / 2), np.cos(np.pi * (x + y) / 2), np.cos(np.pi * y)):
        assert metrics.orientation_coherence(walls(pattern)) > 0.9


def test_contour_alignment(cases):
    original = cases["original"]
    assert metrics.contour_alignment(original, cases["labyrinth"]) > 0.8
    y, x = np.mgrid[:SIZE, :SIZE]
    angle = np.arctan2(y - SIZE / 2, x - SIZE / 2)
    spokes = walls(np.cos(2 * np.pi * (angle * 45) / 4.0))  # walls across the circle
    near = np.abs(np.hypot(y - SIZE / 2, x - SIZE / 2) - 45) < 14
    across = np.where(near, spokes, original)
    assert metrics.contour_alignment(original, across) < 0.3
    for name in OTHERS:
        assert math.isnan(metrics.contour_alignment(original, cases[name])), name


def test_edge_enhancement(cases):
    original = cases["original"]
    value = {name: metrics.edge_enhancement(original, cases[name]) for name in cases}
    assert value["labyrinth"] > 0.5
    assert abs(value["noise"]) < 0.2 and abs(value["salt_pepper"]) < 0.2
    assert value["blur"] < 0
    assert value["unchanged"] == 0.0


def test_metrics_are_deterministic_and_leave_inputs_alone(cases):
    original, rendered = cases["original"], cases["labyrinth"]
    before = (original.copy(), rendered.copy())
    first = metrics.describe(original, rendered)
    second = metrics.describe(original, rendered)
    assert first == second
    np.testing.assert_array_equal(original, before[0])
    np.testing.assert_array_equal(rendered, before[1])
    assert set(first) == {
        "texture_added",
        "labyrinth_cover",
        "wall_width",
        "orientation_coherence",
        "contour_alignment",
        "edge_enhancement",
    }


def test_metrics_accept_integer_images_and_reject_bad_ones():
    image = (np.random.default_rng(1).random((32, 32)) * 255).astype(np.uint8)
    assert metrics.texture_added(image, image) == 1.0
    with pytest.raises(ValueError, match="2-D"):
        metrics.labyrinth_cover(np.zeros((3, 8, 8)))
    with pytest.raises(ValueError, match="at least 3 x 3"):
        metrics.labyrinth_cover(np.zeros((2, 8)))
    with pytest.raises(TypeError, match="real numbers"):
        metrics.labyrinth_cover(np.zeros((8, 8), complex))
    with pytest.raises(ValueError, match="differ in shape"):
        metrics.edge_enhancement(np.zeros((8, 8)), np.zeros((9, 8)))


# --- describe_steps, Comparison, threads ----------------------------------------------------


def test_describe_steps_yields_every_metric_in_the_order_of_describe(cases):
    original, rendered = cases["original"], cases["labyrinth"]
    steps = metrics.describe_steps(original, rendered)
    assert inspect.isgenerator(steps)
    pairs = list(steps)
    assert [name for name, _ in pairs] == list(metrics.METRICS)
    assert dict(pairs) == metrics.describe(original, rendered)
    assert list(metrics.describe(original, rendered)) == list(metrics.METRICS)


def _count_calls(monkeypatch, *names):
    """Each call of the kernels ``names`` (looked up on their package, as the metrics do)."""
    from napari_labyrinth.metrics import _kernels

    calls = []

    def counting(kernel):
        def count(*arguments):
            calls.append(arguments)
            return kernel(*arguments)

        return count

    for name in names:
        monkeypatch.setattr(_kernels, name, counting(getattr(_kernels, name)))
    return calls


def _count_tensors(monkeypatch):
    """The calls of both structure-tensor kernels (the walls' and the contours'), in one list."""
    return _count_calls(monkeypatch, "orientation_band", "decimated_tensor_band")


def test_stopping_between_metrics_skips_the_work_of_the_others(cases, monkeypatch):
    tensors = _count_tensors(monkeypatch)
    steps = metrics.Comparison(cases["original"]).describe_steps(cases["labyrinth"])
    assert next(steps)[0] == "texture_added"
    assert next(steps)[0] == "labyrinth_cover"
    steps.close()
    assert tensors == []  # neither the walls' nor the contours' structure tensor
    with pytest.raises(StopIteration):
        next(steps)


def test_a_comparison_computes_the_originals_maps_once(cases, monkeypatch):
    tensors = _count_tensors(monkeypatch)  # one call per band of rows
    comparison = metrics.Comparison(cases["original"], workers=1)
    renderings = [cases["labyrinth"], cases["labyrinth"][:, ::-1].copy(), cases["noise"]]
    rows = [comparison.describe(rendered) for rendered in renderings]
    # contours of the original once; the walls of the two labyrinths (noise has none)
    assert len(tensors) == 3
    for rendered, row in zip(renderings, rows):
        assert row == metrics.describe(cases["original"], rendered)
    assert comparison.shape == cases["original"].shape
    with pytest.raises(ValueError, match="differ in shape"):
        comparison.describe(np.zeros((9, 8)))


def test_a_comparisons_edge_enhancement_is_the_one_describe_gives(cases, monkeypatch):
    tensors = _count_tensors(monkeypatch)
    comparison = metrics.Comparison(cases["original"], workers=1)
    for rendered in (cases["labyrinth"], cases["noise"], cases["labyrinth"]):
        value = comparison.edge_enhancement(rendered)
        assert value == metrics.edge_enhancement(cases["original"], rendered)
    assert tensors == []  # none of the structure tensors of the other metrics
    assert value == comparison.describe(cases["labyrinth"])["edge_enhancement"]
    with pytest.raises(ValueError, match="differ in shape"):
        comparison.edge_enhancement(np.zeros((9, 8)))


def test_a_comparison_measures_the_metrics_asked_for_only(cases, monkeypatch):
    comparison = metrics.Comparison(cases["original"], workers=1)
    expected = metrics.describe(cases["original"], cases["labyrinth"])
    asked = ["edge_enhancement", "labyrinth_cover"]
    tensors = _count_tensors(monkeypatch)
    measured = comparison.measure(cases["labyrinth"], asked)
    assert measured == {name: expected[name] for name in ("labyrinth_cover", "edge_enhancement")}
    assert tensors == []  # neither the walls' orientation nor the contours
    wanted = ("contour_alignment", "labyrinth_cover", "edge_enhancement")
    assert comparison.measure(cases["labyrinth"], wanted) == {
        name: expected[name] for name in metrics.METRICS if name in wanted
    }
    with pytest.raises(ValueError, match=r"unknown metrics \['cover'\]; the metrics are"):
        comparison.measure(cases["labyrinth"], ["cover"])


def test_the_originals_contours_are_computed_where_walls_need_them_once(monkeypatch):
    """Rows of column tiles holding walls, each once; the same values as everywhere."""
    from napari_labyrinth.metrics import _kernels

    rng = np.random.default_rng(3)
    height, width = 96, 1400  # three column tiles
    original = ndimage.gaussian_filter(rng.random((height, width)) * 255, 4)
    walls = np.zeros((height, width), dtype=bool)
    walls[10:14, 30:40] = True  # tile 0
    walls[70, 1200] = True  # tile 2
    sigma = metrics.CONTOUR_SIGMA
    radius = _lazy_kernels._weights(_kernels.decimated_sigma(sigma)).shape[0] - 1
    assert _kernels.tensor_tiles(width, radius) == 3
    everywhere = _maps._Maps(original.copy(), workers=1).contours(sigma, np.ones_like(walls))
    maps = _maps._Maps(original.copy(), workers=1)
    calls = _count_calls(monkeypatch, "decimated_tensor_band")
    partial = maps.contours(sigma, walls)
    assert len(calls) == 1
    needed = calls[0][4]  # (rows, tiles) computed
    assert needed.sum() == 5 and needed[10:14, 0].all() and needed[70, 2]
    for part, whole in zip(partial, everywhere):
        np.testing.assert_array_equal(part[walls], whole[walls])
    maps.contours(sigma, np.zeros_like(walls))  # no wall: nothing to compute
    maps.contours(sigma, walls)
    assert len(calls) == 1
    maps.contours(sigma, np.ones_like(walls))  # the rest, once
    assert len(calls) == 2 and calls[1][4].sum() == 3 * height - 5
    for part, whole in zip(maps.contours(sigma, walls), everywhere):
        np.testing.assert_array_equal(part, whole)


def test_a_comparison_keeps_its_own_copy_of_the_original(cases):
    original = cases["original"].copy()
    comparison = metrics.Comparison(original)
    expected = metrics.describe(cases["original"], cases["labyrinth"])
    original[:] = 0
    assert comparison.describe(cases["labyrinth"]) == expected


def test_describe_reuses_an_original_by_content_not_by_identity(cases, monkeypatch):
    original, rendered = cases["original"], cases["labyrinth"]
    metrics.describe(original, rendered, workers=1)
    tensors = _count_tensors(monkeypatch)  # one call per band of rows
    metrics.describe(original.copy(), rendered, workers=1)  # same content: contours reused
    assert len(tensors) == 1  # the walls' tensor only
    changed = original.copy()
    changed[0, 0] += 1
    metrics.describe(changed, rendered, workers=1)
    assert len(tensors) == 3  # a new original: its contours as well


def _in_units(tones, low, high):
    """Values of which ``tones`` are the tones on the scale (low, high)."""
    return low + tones * (high - low) / 255.0


@pytest.mark.parametrize("limits", [(0.0, 1.0), (1000.0, 61000.0), (-3e6, 5e6)])
def test_tone_limits_measure_planes_of_any_units_on_the_tone_scale(cases, limits):
    from napari_labyrinth.core.tone_scale import ToneScale

    original, rendered = (_in_units(cases[k], *limits) for k in ("original", "labyrinth"))
    scale = ToneScale(*limits)
    expected = metrics.describe(scale.to_tones(original), scale.to_tones(rendered))
    assert expected["labyrinth_cover"] > 0.1  # walls, in tones
    measured = metrics.describe(original, rendered, tone_limits=limits)
    assert measured == expected
    assert metrics.Comparison(original, tone_limits=limits).describe(rendered) == expected
    steps = dict(metrics.describe_steps(original, rendered, tone_limits=limits))
    assert steps == expected
    # without them the planes are read as tones: the walls' flatness bound is missed
    assert metrics.describe(original, rendered) != expected


def test_describe_keeps_an_original_apart_for_each_tone_scale(cases):
    original, rendered = cases["original"], cases["labyrinth"]
    on_its_own = metrics.describe(original, rendered)
    stretched = metrics.describe(original, rendered, tone_limits=(50.0, 200.0))
    assert stretched != on_its_own
    assert metrics.describe(original, rendered) == on_its_own
    assert metrics.describe(original, rendered, tone_limits=(50, 200)) == stretched


@pytest.mark.parametrize("limits", [(1, 1), (2, 1), (0, math.inf), "0 255", (0,), {0, 1}])
def test_bad_tone_limits_are_refused_by_name(cases, limits):
    with pytest.raises((TypeError, ValueError), match="tone_limits"):
        metrics.describe(cases["original"], cases["labyrinth"], tone_limits=limits)
    with pytest.raises((TypeError, ValueError), match="tone_limits"):
        metrics.Comparison(cases["original"], tone_limits=limits)


def test_workers_do_not_change_the_results(cases):
    original, rendered = cases["original"], cases["labyrinth"]
    expected = metrics.describe(original, rendered, workers=1)
    for workers in (2, 3, 8):
        assert metrics.Comparison(original, workers=workers).describe(rendered) == expected


def test_metrics_run_on_threads_beside_the_renderer(cases):
    """Several threads describe passes while the numba renderer runs on others."""
    from concurrent.futures import ThreadPoolExecutor

    from napari_labyrinth import labyrinth

    original = cases["original"]
    passes = [labyrinth(original, passes=k, seed=k) for k in (1, 2, 3)]
    expected = [metrics.describe(original, rendered) for rendered in passes]
    comparison = metrics.Comparison(original)
    with ThreadPoolExecutor(6) as pool:
        renders = [pool.submit(labyrinth, original, passes=2, seed=k) for k in range(2)]
        rows = [pool.submit(comparison.describe, rendered) for rendered in passes * 3]
        singles = [pool.submit(metrics.wall_width, rendered) for rendered in passes]
        assert [row.result() for row in rows] == expected * 3
        assert [w.result() for w in singles] == [row["wall_width"] for row in expected]
        for render in renders:
            render.result()


def _kernel_dispatchers() -> dict:
    """Every numba dispatcher of the metrics kernels' modules (kernels and helpers), by name."""
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    from napari_labyrinth.metrics import _kernels

    dispatchers = {}
    for module in pkgutil.iter_modules(_kernels.__path__):
        found = vars(importlib.import_module(f"{_kernels.__name__}.{module.name}"))
        for value in found.values():
            if isinstance(value, CPUDispatcher):
                dispatchers[value.py_func.__name__] = value
    return dispatchers


def test_the_kernels_release_the_gil():
    kernels = list(_kernel_dispatchers().values())
    assert len(kernels) > 10
    for kernel in kernels:
        assert kernel.targetoptions.get("nogil"), kernel.py_func.__name__


def test_wall_map_is_shared_and_read_only(cases):
    walls = metrics.wall_map(cases["labyrinth"])
    assert walls.dtype == bool and not walls.flags.writeable
    assert np.shares_memory(metrics.wall_map(cases["labyrinth"].copy()), walls)
    fine = metrics.fine_scale(cases["labyrinth"])
    assert fine.flags.writeable and fine.dtype == np.float64


@pytest.mark.parametrize("workers", [2, 3, 7])
def test_bands_and_threads_do_not_change_a_single_bit(monkeypatch, workers):
    """A plane cut into many bands of rows of uneven sizes (walls in some only) gives the
    numbers and maps of one thread on the whole plane, bit for bit."""
    from napari_labyrinth import labyrinth

    original = (cholesteric_fingerprint((333, 140), seed=5) * 255).astype(np.uint8)
    original[:120] = 128  # a flat band: no texture, no walls, little work there
    rendered = labyrinth(original, seed=2)
    expected = metrics.Comparison(original, workers=1).describe(rendered)
    walls = _maps._Maps(rendered.astype(float), workers=1).walls()[0]
    assert 0.02 < walls.mean() < 0.6  # the test needs walls, not everywhere
    monkeypatch.setattr(_bands, "_MIN_BAND_ROWS", 7)  # 333 rows: up to 47 bands
    assert metrics.Comparison(original, workers=workers).describe(rendered) == expected
    maps = _maps._Maps(rendered.astype(float), workers=workers)
    np.testing.assert_array_equal(maps.walls()[0], walls)


@pytest.mark.parametrize("tone", [1.0, 1e30])
def test_maps_made_without_walls_give_the_same_walls_when_asked(cases, tone):
    """An original's maps skip h's float32 copy; asked for walls, they make it as the kernel
    does (scaled by a power of two for huge tones)."""
    plane = cases["labyrinth"] * tone
    expected = _maps._Maps(plane.copy(), workers=1).walls()
    lazy = _maps._Maps(plane.copy(), workers=1, walls=False)
    assert lazy.fine()[1] == _maps._Maps(plane.copy()).fine()[1]  # h first, without the copy
    walls = lazy.walls()
    assert walls[0].any()
    np.testing.assert_array_equal(walls[0], expected[0])
    np.testing.assert_array_equal(walls[1], expected[1])


def _derived(components):
    """The contours' coherent strength, cos and sin of twice the angle, from their tensor
    (the kernels' ``_derived``, in numpy)."""
    jrr, jrc, jcc = (component.astype(np.float64) for component in components)
    trace = jrr + jcc
    along = jrr - jcc
    across = 2.0 * jrc
    difference = np.sqrt(along * along + across * across)
    coherence = np.where(trace > 0, (difference / np.maximum(trace, 1e-12)) ** 2, 0.0)
    oriented = difference > 0
    divisor = np.where(oriented, difference, 1.0)
    cosine = np.where(oriented, along / divisor, 1.0).astype(np.float32)
    sine = np.where(oriented, across / divisor, 0.0).astype(np.float32)
    coherent = (coherence * trace).astype(np.float32)
    return [coherent, coherent, cosine, sine]


def test_the_decimated_contour_tensor_is_close_to_the_doubled_grids(monkeypatch):
    """The contours' window (1-2-1 on the doubled grid, then a Gaussian on the original
    grid) against the doubled grid's Gaussian of the same variance: the coherent strength
    within 1 % of its largest value, the angles within 2 degrees where there is one."""
    from napari_labyrinth import samples

    original = samples.camera()[100:356, 150:406].astype(float)
    everywhere = np.ones(original.shape, dtype=bool)
    sigma = metrics.CONTOUR_SIGMA
    decimated = _derived(_maps._Maps(original.copy(), workers=1).contours(sigma, everywhere))
    monkeypatch.setattr(_tensor, "_DECIMATED_SIGMA", math.inf)  # the doubled grid's
    exact = _derived(_maps._Maps(original.copy(), workers=1).contours(sigma, everywhere))
    largest = exact[0].max()
    assert np.abs(decimated[0] - exact[0]).max() < 1e-2 * largest
    assert np.abs(decimated[0] - exact[0]).max() > 1e-6 * largest  # not the same window
    oriented = exact[0] > 1e-2 * largest
    cosine = decimated[2] * exact[2] + decimated[3] * exact[3]  # cos of twice the difference
    assert np.all(cosine[oriented] > np.cos(np.radians(4)))


@pytest.mark.parametrize("sigma", [0.5, 2.0, metrics.CONTOUR_SIGMA])
def test_the_structure_tensor_sees_no_edge_at_the_frame(sigma):
    """The tensor is that of the plane extended by its edge values: a flat plane has no
    contour anywhere (zero padding drew one along its frame, as strong as its brightness),
    and a plane plus a constant has the plane's tensor. From sigma 1 on the contours'
    window is decimated: both windows are checked."""
    everywhere = np.ones((40, 52), dtype=bool)
    for value in (0.0, 130.0, 1e5):
        flat = np.full(everywhere.shape, value)
        assert np.all(metrics.orientation(flat, sigma)[2] == 0)
        for component in _maps._Maps(flat, workers=1).contours(sigma, everywhere):
            assert np.all(component == 0)
    plane = samples.camera()[200:240, 300:352].astype(float) / 2
    expected = metrics.orientation(plane, sigma)
    tensor = _maps._Maps(plane.copy(), workers=1).contours(sigma, everywhere)
    largest = expected[2].max()
    for offset in (100.0, 1000.0):
        angle, coherence, strength = metrics.orientation(plane + offset, sigma)
        np.testing.assert_allclose(strength, expected[2], rtol=0, atol=1e-5 * largest)
        oriented = expected[2] > 1e-2 * largest
        np.testing.assert_allclose(np.cos(2 * (angle - expected[0]))[oriented], 1, atol=1e-6)
        shifted = _maps._Maps(plane + offset, workers=1).contours(sigma, everywhere)
        for got, component in zip(shifted, tensor):
            np.testing.assert_allclose(got, component, rtol=0, atol=1e-5 * largest)


def test_contour_alignment_does_not_depend_on_the_originals_offset():
    """A camera's baseline (100 counts on many sCMOS cameras) moved the camera image's
    alignment from 0.711 to 0.274: the frame, a contour under zero padding, outweighed
    the image's own contours."""
    original = samples.camera()[:256, :256] // 2
    rendered = labyrinth(original, passes=2, seed=0)
    expected = metrics.contour_alignment(original, rendered)
    assert expected > 0.9  # the walls follow the contours
    for offset in (100, 1000):
        shifted = original.astype(np.float64) + offset
        assert metrics.contour_alignment(shifted, rendered) == pytest.approx(expected, rel=1e-5)
        assert metrics.contour_alignment(shifted, rendered, contour_sigma=0.5) == pytest.approx(
            metrics.contour_alignment(original, rendered, contour_sigma=0.5), rel=1e-5
        )


@pytest.mark.parametrize("workers", [1, 3])
def test_an_originals_energy_without_h_is_the_energy_from_h(cases, monkeypatch, workers):
    """An original's maps make the energy from rows of h they do not keep, and the Sobel
    edges in the same pass: the floats of h's map smoothed (energy, sums, finiteness,
    largest tone) and of the Sobel kernel alone, bit for bit, in any bands."""
    monkeypatch.setattr(_bands, "_MIN_BAND_ROWS", 5)
    rng = np.random.default_rng(4)
    holes = cases["labyrinth"].copy()
    holes[7, 9] = np.nan
    holes[150, 3] = np.inf
    planes = [
        cases["labyrinth"],
        cases["original"] * 1e30,
        cases["noise"] * 1e-30,
        holes,
        rng.normal(0, 1e200, (40, 23)),  # h**2 overflows
        rng.integers(0, 256, (3, 3)).astype(float),
        rng.integers(0, 256, (5, 7)).astype(float),
        rng.integers(0, 256, (20, 4)).astype(float),
    ]
    for plane in planes:
        original = _maps._Maps(plane.copy(), workers=workers, walls=False)
        whole = _maps._Maps(plane.copy(), workers=workers)
        energy, total = original.energy()
        expected_energy, expected_total = whole.energy()
        np.testing.assert_array_equal(energy, expected_energy)
        assert total == expected_total or (math.isnan(total) and math.isnan(expected_total))
        for map_, expected in zip(original.edges(), whole.edges()):
            np.testing.assert_array_equal(map_, expected)
        summary, full = original._fine(), whole._fine()
        assert summary.fine is None and "fine" not in original._values
        for field in ("total", "largest_square", "finite", "largest_tone"):
            a, b = getattr(summary, field), getattr(full, field)
            assert a == b or (math.isnan(a) and math.isnan(b)), field


@pytest.mark.parametrize("angle", [0.0, 0.5, 1.0, 2.0])
def test_the_decimated_tensor_of_a_ramp_is_the_doubled_grids(monkeypatch, angle):
    """On a linear ramp the tensor products are constant away from the edges: every
    normalised window gives them back, so both windows agree there (float32 rounding),
    with coherence 1 and the ramp's direction (twice its angle)."""
    y, x = np.mgrid[:80, :90].astype(float)
    ramp = 100 + 3 * (np.cos(angle) * y + np.sin(angle) * x)
    everywhere = np.ones(ramp.shape, dtype=bool)
    decimated = _derived(_maps._Maps(ramp.copy(), workers=1).contours(2.0, everywhere))
    monkeypatch.setattr(_tensor, "_DECIMATED_SIGMA", math.inf)
    exact = _derived(_maps._Maps(ramp.copy(), workers=1).contours(2.0, everywhere))
    inside = (slice(20, -20), slice(20, -20))
    for d, e in zip(decimated, exact):
        np.testing.assert_allclose(d[inside], e[inside], rtol=1e-5, atol=1e-6)
    # the ramp rises 3 / 2 a doubled pixel; the kernel's unnormalised Sobel (1-2-1 across a
    # difference two rows apart) reads 8 times that: strength (8 * 3 / 2)**2, coherence 1
    np.testing.assert_allclose(decimated[0][inside], 144.0, rtol=1e-5)
    np.testing.assert_allclose(decimated[2][inside], np.cos(2 * angle), atol=1e-5)
    np.testing.assert_allclose(decimated[3][inside], np.sin(2 * angle), atol=1e-5)


def _poisoned(shape, count=12):
    """Plane-shaped arrays of every dtype the maps use, filled with values no map holds."""
    arrays = []
    for _ in range(count):
        arrays.append(np.full(shape, np.nan))
        arrays.append(np.full(shape, np.nan, dtype=np.float32))
        arrays.append(np.frombuffer(np.full(shape, 7, np.uint8).tobytes(), bool).reshape(shape))
    return [np.array(a) for a in arrays]  # arrays of their own (the pool keeps no views)


def test_maps_made_in_the_arrays_of_earlier_maps_are_the_same(cases, monkeypatch):
    """Comparisons take their arrays from a pool that earlier maps gave back: arrays full of
    stale values (NaN, bools that are neither 0 nor 1) give the same metrics as new ones."""
    original, rendered = cases["original"], cases["labyrinth"]
    monkeypatch.setattr(_comparison, "_SHARED_POOL", _caches._Pool(pixel_bytes=10**6))
    expected = metrics.Comparison(original, workers=1).describe(rendered)
    _comparison._SHARED_POOL.clear()
    _comparison._SHARED_POOL.give(_poisoned(original.shape))
    comparison = metrics.Comparison(original, workers=2)
    assert _comparison._SHARED_POOL.nbytes < 12 * 13 * original.size  # arrays were taken
    for _ in range(2):  # the second pass on the arrays the first gave back
        assert comparison.describe(rendered) == expected


def test_the_pool_keeps_one_shape_a_bounded_number_of_bytes_for_a_while():
    pool = _caches._Pool(pixel_bytes=20, idle=0.05)
    pool.give([np.empty((4, 5)), np.empty((4, 5)), np.empty((4, 5)), np.empty((4, 5), "f4")])
    assert pool.nbytes == (8 + 8 + 4) * 20  # 20 bytes a pixel: a third float64 is not kept
    kept = pool.take((4, 5), np.float32)
    assert kept.dtype == np.float32 and pool.nbytes == 16 * 20
    assert pool.take((5, 4), np.float64).shape == (5, 4)  # another shape: a new array
    pool.give([np.empty((3, 3)), np.empty((4, 5))[:, :2].copy()])
    assert pool.nbytes == 8 * 8  # the last shape given back only
    pool.give([np.ones(9).reshape(3, 3)])  # a view: not kept (its base may be in use)
    assert pool.nbytes == 8 * 8
    for _ in range(1000):  # the timer drops the arrays 0.05 s after the last given back
        if pool.nbytes == 0:
            break
        threading.Event().wait(0.01)
    assert pool.nbytes == 0


def test_a_comparison_gives_its_originals_maps_back_when_it_is_gone(cases, monkeypatch):
    import gc

    original, rendered = cases["original"], cases["labyrinth"]
    monkeypatch.setattr(_comparison, "_SHARED_POOL", _caches._Pool(pixel_bytes=10**6))
    comparison = metrics.Comparison(original, workers=1)
    comparison.describe(rendered)
    after_pass = _comparison._SHARED_POOL.nbytes  # the rendering's maps
    assert after_pass > 0
    del comparison
    gc.collect()
    assert _comparison._SHARED_POOL.nbytes > after_pass  # the original's plane and maps too


def test_a_finalizer_gives_arrays_back_without_waiting_for_the_pool():
    """The garbage collector may finalize a Comparison in a thread inside the pool (holding
    its lock): the arrays wait for the pool's next use instead of a deadlock."""
    pool = _caches._Pool(idle=60.0)
    with pool._lock:  # held, as by a thread inside give()
        finalizer = threading.Thread(target=pool.give_later, args=([np.empty((4, 5))],))
        finalizer.start()
        finalizer.join(timeout=30)
        assert not finalizer.is_alive()  # it did not wait for the lock
    assert pool.nbytes == 8 * 20  # kept at the pool's next use
    pool.clear()


@pytest.mark.parametrize("height", [128, 129, 200, 333, 512, 2048, 4097])
@pytest.mark.parametrize("workers", [2, 3, 8])
def test_guided_bands_cover_the_rows_once_and_shrink(height, workers):
    """The bands of ``_in_bands`` cover every row once, in order, none shorter than
    ``_MIN_BAND_ROWS``, each no longer than the one before but the last (a remainder)."""
    edges = _bands._guided_edges(height, workers)
    sizes = np.diff(edges)
    assert edges[0] == 0 and edges[-1] == height
    assert np.all(sizes >= _bands._MIN_BAND_ROWS)
    assert np.all(np.diff(sizes[:-1]) <= 0)
    assert sizes[-1] < 2 * _bands._MIN_BAND_ROWS or len(sizes) == 1


def test_guided_bands_of_a_2048_row_plane_on_two_threads():
    """Each band a quarter of the rows left (rounded up), at least 64 rows; the last
    takes the 76 rows left after two bands of 64."""
    edges = _bands._guided_edges(2048, 2)
    assert np.diff(edges).tolist() == [512, 384, 288, 216, 162, 122, 91, 69, 64, 64, 76]


@pytest.mark.parametrize("workers", [1, 2, 3])
def test_a_copy_in_bands_is_the_plane_in_float64(workers):
    rng = np.random.default_rng(1)
    source = rng.integers(0, 65536, size=(300, 257), dtype=np.uint16)[:, ::2]  # strided
    target = np.full(source.shape, np.nan)
    _bands._copy_in_bands(target, source, workers)
    np.testing.assert_array_equal(target, source.astype(np.float64))


def test_the_pool_keeps_one_shape_and_lets_everything_go_when_cleared():
    pool = _caches._Pool(idle=60.0)
    pool.give([np.empty((8, 8)), np.empty((8, 8), np.float32)])
    assert pool.nbytes == 8 * 8 * 12
    pool.give([np.empty((4, 4))])  # another shape: the first shape's arrays go
    assert pool.nbytes == 4 * 4 * 8
    pool.clear()
    assert pool.nbytes == 0
    pool._timer.cancel()


@pytest.mark.parametrize("dtype, top", [(np.uint8, 255), (np.uint16, 65535)])
def test_planes_read_in_their_own_dtype_give_the_float64_planes_numbers_bit_for_bit(dtype, top):
    """uint8 and uint16 planes are copied and read as they are (``_KERNEL_DTYPES``): the
    metrics and maps are those of their float64 copies, down to the last bit, with tones
    at both ends of the range (a sum of two largest tones does not wrap)."""
    from napari_labyrinth import labyrinth

    original = (cholesteric_fingerprint((150, 170), seed=3) * top).astype(dtype)
    original[:20] = top  # saturated rows: largest sums and squares
    original[-20:, :30] = 0
    rendered = labyrinth(original, seed=1)
    assert rendered.dtype == dtype and rendered.max() == top and rendered.min() == 0
    as_floats = original.astype(np.float64), rendered.astype(np.float64)
    comparison = metrics.Comparison(original, workers=2)
    assert comparison._maps.plane.dtype == dtype  # the copy the kernels read
    expected = metrics.Comparison(as_floats[0], workers=2).describe(as_floats[1])
    assert comparison.describe(rendered) == expected
    assert metrics.describe(original, rendered) == expected
    assert not math.isnan(expected["contour_alignment"])
    single = _maps._Maps(_planes._kernel_plane(rendered), workers=2)
    floats = _maps._Maps(as_floats[1], workers=2)
    for ours, theirs in zip(single.walls(), floats.walls()):
        np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(single.fine()[0], floats.fine()[0])
    np.testing.assert_array_equal(single.above_local_mean(), floats.above_local_mean())
    assert metrics.edge_enhancement(original, rendered) == expected["edge_enhancement"]
    assert metrics.wall_width(rendered) == expected["wall_width"]


def test_planes_of_every_dtype_run_the_same_compiled_kernels():
    """numba compiles each kernel once, whatever the planes' dtypes (they come in one tuple,
    ``metrics._kernels.plane_tuple``), and each helper once per float type it smooths (no
    copy for a literal argument). Read-only arrays, which a caller may pass, are numba's
    other types: not counted."""
    from numba.core import types

    original = (cholesteric_fingerprint((96, 140), seed=2) * 250).astype(np.uint8)
    rendered = labyrinth(original, seed=4)
    for dtype in (np.uint8, np.uint16, np.float32, np.float64):
        values = metrics.describe(original.astype(dtype), rendered.astype(dtype), workers=2)
        assert values["contour_alignment"] > 0  # every kernel of the walls ran
        metrics.Comparison(original.astype(dtype)).edge_enhancement(rendered.astype(dtype))

    def writeable(argument):
        if isinstance(argument, types.BaseTuple):
            return all(writeable(member) for member in argument)
        return not isinstance(argument, types.Array) or argument.mutable

    dispatchers = _kernel_dispatchers()
    assert {"_gauss", "_load_row", "fine_scale_band", "alignment_sums"} <= dispatchers.keys()
    for name, dispatcher in dispatchers.items():
        compiled = [s for s in dispatcher.signatures if all(map(writeable, s))]
        assert len(compiled) <= (2 if name == "_gauss" else 1), (name, compiled)


def test_other_dtypes_are_read_as_float64():
    for dtype in (np.int8, np.int16, np.int32, np.uint32, np.float32, np.float64):
        assert _planes._kernel_dtype(dtype) == np.float64
    assert _planes._kernel_plane(np.zeros((4, 4), np.int16)).dtype == np.float64


def test_the_originals_contours_are_made_in_the_bytes_of_the_renderings_h(cases, monkeypatch):
    """h and its float32 copy are done with once the walls' orientation is made: the
    contours that follow take their bytes (no new memory), and the numbers are those of
    maps made in arrays of their own."""
    pool = _caches._Pool(idle=60.0)
    monkeypatch.setattr(_comparison, "_SHARED_POOL", pool)
    original, rendered = cases["original"], cases["labyrinth"]
    comparison = metrics.Comparison(original, workers=2)
    after = comparison._rendering_maps(rendered)
    fine = after._full_fine()
    values = dict(comparison._steps(after))
    contours = comparison._maps._values[("contours", metrics.CONTOUR_SIGMA)][0]
    assert contours[0] is fine.fine32
    assert np.shares_memory(contours[1], fine.fine) and np.shares_memory(contours[2], fine.fine)
    assert values["contour_alignment"] == metrics.contour_alignment(original, rendered)
    assert values == metrics.Comparison(original, workers=2).describe(rendered)
    pool._timer.cancel()


def test_the_local_mean_at_the_walls_is_scipys_gaussian_bit_for_bit(cases):
    """``above_local_mean`` compares each wall pixel with scipy's Gaussian of sigma 2
    (``reflect``) of the plane, float for float; the other pixels are False."""
    wide = np.tile(cases["labyrinth"], (1, 7))[:, :1100]  # a column tile inside the plane
    for plane in (cases["labyrinth"], cases["labyrinth"][:, :150] * 3.7, wide):
        maps = _maps._Maps(np.ascontiguousarray(plane), workers=2)
        walls = maps.walls()[0]
        assert 0.02 < walls.mean() < 0.6
        expected = plane > ndimage.gaussian_filter(plane, metrics.WINDOW_SIGMA, mode="reflect")
        np.testing.assert_array_equal(maps.above_local_mean(), expected & walls)


# --- hostile parameters and magnitudes ------------------------------------------------------


@pytest.mark.parametrize("exponent", [-1070, -1000, -700, -100, 100, 700])
def test_orientation_of_a_plane_of_any_magnitude_is_that_of_its_tones(exponent):
    """A power of two times a plane (down to subnormal values) has its angle and coherence;
    the strength is scaled by the power's square, 0 or infinite beyond float64's range."""
    tones = np.rint(255 * cholesteric_fingerprint(shape=(48, 40)).astype(np.float64))
    expected = metrics.orientation(tones)
    angle, coherence, strength = metrics.orientation(np.ldexp(tones, exponent))
    np.testing.assert_array_equal(angle, expected[0])
    np.testing.assert_array_equal(coherence, expected[1])
    with np.errstate(over="ignore", under="ignore"):
        np.testing.assert_array_equal(strength, np.ldexp(expected[2], 2 * exponent))


def test_a_subnormal_plane_has_every_metric():
    plane = np.full((8, 8), 1e-320)
    angle, coherence, strength = metrics.orientation(plane)
    assert np.all(np.isfinite(angle)) and np.all((0 <= coherence) & (coherence <= 1))
    assert metrics.labyrinth_cover(plane) == 0.0
    rendered = cholesteric_fingerprint(shape=(8, 8)).astype(np.float64)
    assert set(metrics.describe(plane, rendered)) == set(metrics.METRICS)


BAD_SIGMAS = [
    (0, ValueError),
    (-1, ValueError),
    (1e-300, ValueError),
    (math.inf, ValueError),
    (math.nan, ValueError),
    (1e300, ValueError),
    (1e6, ValueError),
    (None, TypeError),
    ("a", TypeError),
    (True, TypeError),
]


@pytest.mark.parametrize(("sigma", "error"), BAD_SIGMAS)
def test_a_bad_sigma_is_named_with_its_range(sigma, error):
    image = np.zeros((16, 16))
    message = "sigma must be" if error is TypeError else f"sigma must be .*{metrics.SIGMA.high:g}"
    with pytest.raises(error, match=message):
        metrics.orientation(image, sigma=sigma)


@pytest.mark.parametrize(("sigma", "error"), BAD_SIGMAS)
def test_a_bad_contour_sigma_is_named_with_its_range_whatever_the_images(cases, sigma, error):
    bounds = metrics.CONTOUR_SIGMA_PARAMETER.bounds_text
    message = "contour_sigma must be" + ("" if error is TypeError else f" finite and {bounds}")
    original = cases["original"]
    for rendered in (cases["labyrinth"], original):  # with walls and without
        with pytest.raises(error, match=message):
            metrics.contour_alignment(original, rendered, contour_sigma=sigma)


def test_the_bounds_of_sigma_are_usable(cases):
    original, rendered = cases["original"][:40, :48], cases["labyrinth"][:40, :48]
    for sigma in (metrics.SIGMA.low, metrics.SIGMA.high):
        angle, coherence, strength = metrics.orientation(original, sigma)
        assert np.all(np.isfinite(strength)) and np.all(coherence <= 1)
        value = metrics.contour_alignment(original, rendered, contour_sigma=sigma)
        assert math.isnan(value) or 0 <= value <= 1


def test_a_wide_windows_tensor_in_column_tiles_is_the_whole_rows(monkeypatch):
    """Past ``_FULL_WIDTH_RING_BYTES`` the rows are cut into tiles: the same numbers."""
    plane = np.tile(cholesteric_fingerprint(shape=(24, 64)), (1, 40)).astype(np.float64)
    radius = _lazy_kernels._weights(2 * 40.0, np.float32).shape[0] - 1
    assert _tensor._ring_bytes(radius, plane.shape[1]) > _tensor._FULL_WIDTH_RING_BYTES
    tiled = metrics.orientation(plane, 40.0)
    monkeypatch.setattr(_tensor, "_FULL_WIDTH_RING_BYTES", math.inf)
    for got, expected in zip(tiled, metrics.orientation(plane, 40.0)):
        np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("workers", [-1, 0, 1.5, True, "2", "two", 10**6, 2**64])
def test_bad_workers_get_the_message_of_labyrinth(cases, workers):
    from napari_labyrinth import labyrinth

    original, rendered = cases["original"], cases["labyrinth"]
    with pytest.raises((TypeError, ValueError)) as expected:
        labyrinth(original[:8, :8], workers=workers)
    calls = (
        lambda: metrics.describe(original, rendered, workers=workers),
        lambda: metrics.describe_steps(original, rendered, workers=workers),
        lambda: metrics.Comparison(original, workers=workers),
    )
    for call in calls:
        with pytest.raises(expected.type, match="workers") as got:
            call()
        assert str(got.value) == str(expected.value)


def test_workers_none_is_every_core_within_the_bound(cases):
    assert 1 <= _bands._default_workers() <= WORKERS.high
    original, rendered = cases["original"], cases["labyrinth"]
    assert metrics.describe(original, rendered, workers=None) == metrics.describe(
        original, rendered, workers=1
    )
