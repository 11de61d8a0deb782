"""The numba kernel against the pure-Python oracle and hand-computed cases."""

import itertools
import math

import numpy as np
import pytest

from napari_labyrinth import PRESETS
from napari_labyrinth._engine import run_pass
from napari_labyrinth.core._kernel import stream_key
from napari_labyrinth.core._reference import reference_pass, splitmix64, uniform
from napari_labyrinth.core.parameters import (
    DIAGNOSTIC_FIELDS,
    PARAMETERS,
    equal_tone_ranges,
    make_parameters,
)

LIMITS = equal_tone_ranges(3)
TONES = tuple(zip(LIMITS[:-1], LIMITS[1:]))


def run_kernel(
    plane, *, limits=LIMITS, tones=TONES, seed=0, plane_index=0, pass_index=0,
    variance_floor=-1.0, **options,
):  # fmt: skip
    """One kernel pass on a copy; returns (plane, counts dict)."""
    values = dict(PRESETS["paper"], tone_ranges=limits, tones=tones)
    values.update(options)
    work = np.ascontiguousarray(plane, dtype=np.float32).copy()
    counts = run_pass(
        work,
        make_parameters(**values),
        seed=seed,
        plane_index=plane_index,
        pass_index=pass_index,
        variance_floor=variance_floor,
    )
    return work, dict(zip(DIAGNOSTIC_FIELDS, counts.tolist()))


def run_reference(plane, *, limits=LIMITS, tones=TONES, **options):
    options.setdefault("mean_threshold", 0.12)
    options.setdefault("variance_threshold", 0.5)
    options.setdefault("max_tries", 10)
    options.setdefault("seed", 0)
    return reference_pass(plane, range_limits=limits, tones=tones, **options)


def assert_bitwise_equal(a, b):
    assert a.dtype == b.dtype == np.float32
    np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))


def random_planes():
    rng = np.random.default_rng(20240601)
    planes = {
        "uniform": rng.uniform(0, 255, (9, 11)),
        "smooth+edges": np.where(np.arange(10)[:, None] < 5, 40.0, 200.0)
        + rng.normal(0, 12, (10, 8)),
        "dark": rng.uniform(0, 20, (6, 7)),
        "row": rng.uniform(0, 255, (1, 9)),
        "column": rng.uniform(0, 255, (8, 1)),
        "2x2": rng.uniform(0, 255, (2, 2)),
        "single": np.array([[77.0]]),
    }
    with_holes = rng.uniform(0, 255, (8, 9))
    with_holes[2, 3] = np.nan
    with_holes[0, 0] = np.inf
    with_holes[5, 8] = -np.inf
    with_holes[4, :] = np.nan
    planes["non-finite"] = with_holes
    return {name: np.clip(p, 0, 255).astype(np.float32) for name, p in planes.items()}


PLANES = random_planes()
#: Every parameter with a finite set of values (the options the paper leaves
#: open), from the parameter table: adding an option adds it to the grid.
OPTIONS = {
    name: parameter.choices if parameter.kind == "choice" else (False, True)
    for name, parameter in PARAMETERS.items()
    if parameter.kind in ("choice", "bool")
}
OPTION_GRID = [dict(zip(OPTIONS, values)) for values in itertools.product(*OPTIONS.values())]


#: Noise gate floors (tones²) of the grid: off, and one that gates the dark and smooth
#: planes' quieter pixels but not the others.
VARIANCE_FLOORS = (-1.0, 60.0)


@pytest.mark.parametrize("variance_floor", VARIANCE_FLOORS, ids=["gate-off", "gate-on"])
@pytest.mark.parametrize(
    "grid_options", OPTION_GRID, ids=["-".join(map(str, o.values())) for o in OPTION_GRID]
)
def test_kernel_matches_reference_bit_for_bit(grid_options, variance_floor):
    options = dict(
        grid_options,
        seed=12345,
        plane_index=3,
        pass_index=2,
        variance_floor=variance_floor,
    )
    seen = dict.fromkeys(DIAGNOSTIC_FIELDS, 0)
    for name, plane in PLANES.items():
        for thresholds in ((0.12, 0.5), (0.05, 0.2), (0.3, 0.05)):
            options["mean_threshold"], options["variance_threshold"] = thresholds
            got, got_counts = run_kernel(plane, **options)
            want, want_counts = run_reference(plane, **options)
            assert_bitwise_equal(got, want), name
            assert got_counts == want_counts, name
            for field in seen:
                seen[field] += got_counts[field]
    # the images were chosen so that every branch of the algorithm runs
    if grid_options["variance_action"] == "leave":
        assert seen.pop("pushed") == 0
    if variance_floor < 0:
        assert seen.pop("noise_gated") == 0
    assert all(count > 0 for count in seen.values()), seen


def test_kernel_matches_reference_with_custom_tones_and_many_ranges():
    limits = (5.0, 40.0, 80.0, 130.0, 200.0, 250.0)
    tones = ((0.0, 20.0), (30.0, 30.0), (60.0, 120.0), (100.0, 160.0), (180.0, 255.0))
    for plane in PLANES.values():
        for max_tries in (0, 1, 25):
            got, got_counts = run_kernel(plane, limits=limits, tones=tones, max_tries=max_tries)
            want, want_counts = run_reference(
                plane, limits=limits, tones=tones, max_tries=max_tries
            )
            assert_bitwise_equal(got, want)
            assert got_counts == want_counts


def test_stream_key_matches_reference_hash():
    for seed, plane, pass_ in [(0, 0, 0), (2**64 - 1, 7, 3), (123456789, 2**40, 99)]:
        want = splitmix64(splitmix64(splitmix64(seed) ^ plane) ^ pass_)
        assert int(stream_key(np.uint64(seed), plane, pass_)) == want


def test_uniform_is_in_unit_interval_and_looks_uniform():
    draws = np.array([uniform(1, 0, 0, i, 0) for i in range(20000)])
    assert draws.min() >= 0.0 and draws.max() < 1.0
    assert abs(draws.mean() - 0.5) < 0.01
    counts, _ = np.histogram(draws, bins=10, range=(0, 1))
    assert counts.min() > 1800 and counts.max() < 2200


def test_diagnostics_add_up_to_the_pixel_count():
    for plane in PLANES.values():
        _, counts = run_kernel(plane)
        assert sum(counts.values()) == plane.size


# Hand-computed cases on a 1 x 3 row [a, b, c] with the "inside" border:
# pixel 0 has the single neighbour b, pixel 1 has a and c, pixel 2 has b.


def test_eq2_keeps_pixels_close_to_their_mean():
    plane = np.array([[100.0, 105.0, 110.0]], dtype=np.float32)
    out, counts = run_kernel(plane)
    assert_bitwise_equal(out, plane)
    assert counts == dict(
        kept_by_mean=3, left_by_variance=0, pushed=0, redrawn=0, out_of_tries=0, skipped=0,
        noise_gated=0,
    )  # fmt: skip


def _gate_plane():
    """5 x 5 tones: 102 around a ring of 100 and 104 (mean 102, V of Eq. 1 exactly 4)
    around g = 125, which Eq. 2 does not keep (|125 - 102| / 102 > 0.12); Eq. 2 keeps
    every other pixel."""
    plane = np.full((5, 5), 102.0, dtype=np.float32)
    plane[1:4, 1:4] = [[100.0, 104.0, 100.0], [104.0, 125.0, 104.0], [100.0, 104.0, 100.0]]
    return plane


@pytest.mark.parametrize("condition_order", ["mean_first", "variance_first"])
def test_the_noise_gate_leaves_a_pixel_whose_variance_is_at_most_the_floor(condition_order):
    plane = _gate_plane()
    options = dict(condition_order=condition_order, max_tries=100)
    out, counts = run_kernel(plane, variance_floor=4.0, **options)
    assert_bitwise_equal(out, plane)
    # Eq. 4 first: the gate comes before Eq. 2, and takes quiet pixels Eq. 2 would keep too
    gated = 1 if condition_order == "mean_first" else 17
    assert counts["noise_gated"] == gated and counts["kept_by_mean"] == 25 - gated
    reference, reference_counts = run_reference(plane, variance_floor=4.0, **options)
    assert_bitwise_equal(out, reference) and counts == reference_counts


@pytest.mark.parametrize("condition_order", ["mean_first", "variance_first"])
def test_the_noise_gate_passes_a_pixel_whose_variance_is_just_above_the_floor(condition_order):
    plane = _gate_plane()
    options = dict(condition_order=condition_order, max_tries=100)
    just_below_four = float(np.nextafter(4.0, 0.0))
    out, counts = run_kernel(plane, variance_floor=just_below_four, **options)
    # g is redrawn; Eq. 4 first, the quiet pixels around it are gated before Eq. 2 keeps them
    gated = 0 if condition_order == "mean_first" else 20
    assert counts["noise_gated"] == gated and counts["redrawn"] == 1
    others = np.delete(np.arange(25), 12)  # every pixel but g
    assert out[2, 2] != 125.0 and (out.ravel()[others] == plane.ravel()[others]).all()
    reference, reference_counts = run_reference(plane, variance_floor=just_below_four, **options)
    assert_bitwise_equal(out, reference)
    assert counts == reference_counts


def test_eq2_threshold_is_inclusive():
    # pixel 1 of [100, 112]: |112 - 100| / 100 == 0.12 exactly
    plane = np.array([[100.0, 112.0]], dtype=np.float32)
    _, counts = run_kernel(plane, mean_threshold=0.12)
    assert counts["kept_by_mean"] == 2
    _, counts = run_kernel(plane, mean_threshold=0.1199, max_tries=0)
    assert counts["kept_by_mean"] == 1 and counts["out_of_tries"] == 1


def test_eq4_leaves_pixels_in_high_variance_neighbourhoods():
    # pixel 1: M = (200 + 20) / 2 = 110, |30 - 110| / 110 = 0.73 > t;
    # V = 90**2, sqrt(V / 2) / M = 63.6 / 110 = 0.579 > 0.5: left as it is.
    plane = np.array([[200.0, 30.0, 20.0]], dtype=np.float32)
    out, counts = run_kernel(plane, max_tries=0)
    assert out[0, 1] == 30.0
    assert counts["left_by_variance"] == 1
    # pixel 0 (M = 30) and pixel 2 (M = 30) have one neighbour, V = 0: never Eq. 4
    assert counts["out_of_tries"] == 2
    # with V = 0.6 the pixel is no longer protected
    _, counts = run_kernel(plane, variance_threshold=0.6, max_tries=0)
    assert counts["left_by_variance"] == 0 and counts["out_of_tries"] == 3
    # sqrt(V) / M = 90 / 110 = 0.818: protected up to V = 0.8
    _, counts = run_kernel(plane, variance_threshold=0.8, variance_ratio="sqrt(V)/M", max_tries=0)
    assert counts["left_by_variance"] == 1


def test_eq3_draws_in_the_range_of_g_until_eq2_holds():
    # pixel 2 of [200, 30, 20]: M = 30, |20 - 30| / 30 = 0.33 > t, V = 0.
    # g = 20 lies in range 1 [10, 91.67]; the first draw within 12 % of 30 wins.
    plane = np.array([[200.0, 30.0, 20.0]], dtype=np.float32)
    seed = 7
    low, high = TONES[0]
    expected = None
    for attempt in range(10):
        draw = float(np.float32(low + uniform(seed, 0, 0, 2, attempt) * (high - low)))
        if abs(draw - 30.0) / 30.0 <= 0.12:
            expected = draw
            break
    assert expected is not None, "pick a seed whose draws succeed"
    out, counts = run_kernel(plane, seed=seed)
    assert out[0, 2] == np.float32(expected)
    assert counts["redrawn"] == 1
    # pixel 0 (g = 200, range 3 [173, 255]) can never come within 12 % of M = 30
    assert out[0, 0] == 200.0


def test_exhausted_tries_keep_g_or_the_last_draw():
    plane = np.array([[200.0, 30.0, 20.0]], dtype=np.float32)
    out, counts = run_kernel(plane, on_exhausted="keep")
    assert out[0, 0] == 200.0 and counts["out_of_tries"] >= 1
    out, _ = run_kernel(plane, on_exhausted="last_draw", seed=3)
    low, high = TONES[2]
    last = np.float32(low + uniform(3, 0, 0, 0, 9) * (high - low))
    assert out[0, 0] == last


def test_include_centre_joins_the_mean():
    # [100, 140, 100] at t = 0.25, no draws. Neighbours only: pixel 0 has
    # M = 140 -> 0.286, pixel 1 M = 100 -> 0.4, pixel 2 0.286: all fail Eq. 2.
    # With the centre: pixel 0 M = 120 -> 0.167, pixel 1 M = 113.3 -> 0.235,
    # pixel 2 0.167: all pass.
    plane = np.array([[100.0, 140.0, 100.0]], dtype=np.float32)
    _, without = run_kernel(plane, mean_threshold=0.25, max_tries=0)
    assert without["kept_by_mean"] == 0 and without["out_of_tries"] == 3
    _, with_centre = run_kernel(plane, mean_threshold=0.25, max_tries=0, include_centre=True)
    assert with_centre["kept_by_mean"] == 3


@pytest.mark.parametrize(
    "variance_action,high",
    [("push_full_scale", 110.0), ("push_in_range", LIMITS[1])],
)
def test_push_draws_further_from_the_mean_on_the_side_of_g(variance_action, high):
    # pixel 1 of [200, 30, 20]: Eq. 4 holds (0.579 > 0.5), g = 30 < M = 110 with
    # |g - M| / M = 0.727. A push draws below M, from L_inf^1 = 10 up to M
    # (full scale) or up to L_sup^1 = 91.7 (g's range), until
    # |g* - 110| / 110 > 0.727, i.e. g* < 30.
    plane = np.array([[200.0, 30.0, 20.0]], dtype=np.float32)
    seed = 2
    expected = None
    for attempt in range(10):
        draw = float(np.float32(10.0 + uniform(seed, 0, 0, 1, attempt) * (high - 10.0)))
        if (110.0 - draw) / 110.0 > 80.0 / 110.0:
            expected = draw
            break
    assert expected is not None and expected < 30.0, "pick a seed whose draws succeed"
    out, counts = run_kernel(plane, seed=seed, variance_action=variance_action)
    assert out[0, 1] == np.float32(expected)
    assert counts["pushed"] == 1


def test_push_in_range_stays_in_the_tone_range_of_g():
    rng = np.random.default_rng(4)
    plane = rng.uniform(0, 255, (24, 24)).astype(np.float32)
    out, counts = run_kernel(
        plane, variance_action="push_in_range", variance_threshold=0.01, max_tries=0
    )
    assert counts["pushed"] == 0  # no tries, no push
    out, counts = run_kernel(plane, variance_action="push_in_range", variance_threshold=0.01)
    assert counts["pushed"] > 50
    ranges = np.searchsorted(np.asarray(LIMITS[1:-1]), plane, side="right")
    new_ranges = np.searchsorted(np.asarray(LIMITS[1:-1]), out, side="right")
    changed = out != plane
    np.testing.assert_array_equal(ranges[changed], new_ranges[changed])


def test_variance_first_acts_on_pixels_close_to_their_mean():
    # pixel 1 of [250, 100, 10]: M = 130, |100 - 130| / 130 = 0.23; with
    # t = 0.3 Eq. 2 holds, and sqrt(V) / M = 120 / 130 = 0.92 > 0.5 holds too.
    plane = np.array([[250.0, 100.0, 10.0]], dtype=np.float32)
    options = dict(mean_threshold=0.3, variance_ratio="sqrt(V)/M", max_tries=50)
    out, counts = run_kernel(plane, variance_action="push_full_scale", **options)
    assert out[0, 1] == 100.0  # mean first: kept by Eq. 2
    out, counts = run_kernel(
        plane, variance_action="push_full_scale", condition_order="variance_first", **options
    )
    assert out[0, 1] < 100.0 and counts["pushed"] >= 1  # pushed towards black


def test_zero_mean_never_divides():
    # pixel 0 of [40, 0]: M = 0 and g > 0 -> ratio inf, Eq. 4's 0/0 counts as 0;
    # no draw g* > 0 can satisfy Eq. 2, so g stays.
    plane = np.array([[40.0, 0.0]], dtype=np.float32)
    out, counts = run_kernel(plane)
    assert out[0, 0] == 40.0
    assert np.isfinite(out).all()
    assert counts["out_of_tries"] >= 1
    zeros = np.zeros((4, 5), dtype=np.float32)
    out, counts = run_kernel(zeros)
    assert_bitwise_equal(out, zeros)
    assert counts["kept_by_mean"] == zeros.size


def test_non_finite_pixels_are_skipped_and_never_neighbours():
    plane = np.full((3, 3), 100.0, dtype=np.float32)
    plane[1, 1] = np.nan
    plane[0, 1] = np.inf
    out, counts = run_kernel(plane)
    assert math.isnan(out[1, 1]) and out[0, 1] == np.inf
    assert counts["skipped"] == 2 and counts["kept_by_mean"] == 7
    lonely = np.array([[np.nan, 50.0, np.nan]], dtype=np.float32)
    out, counts = run_kernel(lonely)
    assert out[0, 1] == 50.0 and counts["skipped"] == 3


def test_in_place_updates_are_seen_by_later_pixels():
    # pixel 1 of [20, 30, 34]: when scanned, its left neighbour has been redrawn.
    plane = np.array([[20.0, 30.0, 34.0]], dtype=np.float32)
    out, _ = run_kernel(plane, seed=11)
    fresh, _ = run_reference(plane, seed=11)
    assert_bitwise_equal(out, fresh)
    if out[0, 0] != 20.0:  # pixel 0 changed: pixel 1 saw the new value
        m_new = (float(out[0, 0]) + 34.0) / 2
        m_old = (20.0 + 34.0) / 2
        assert m_new != m_old


def test_serpentine_changes_only_the_order_of_odd_rows():
    rng = np.random.default_rng(5)
    plane = rng.uniform(0, 255, (2, 64)).astype(np.float32)
    raster, _ = run_kernel(plane, scan="raster")
    serpentine, _ = run_kernel(plane, scan="serpentine")
    # row 0 is scanned identically and sees the same (untouched) row 1
    assert_bitwise_equal(raster[0], serpentine[0])
    assert not np.array_equal(raster[1], serpentine[1])


def test_random_stream_depends_on_seed_plane_and_pass():
    plane = np.random.default_rng(9).uniform(0, 255, (16, 16)).astype(np.float32)
    base, _ = run_kernel(plane)
    for change in (dict(seed=1), dict(plane_index=1), dict(pass_index=1)):
        other, _ = run_kernel(plane, **change)
        assert not np.array_equal(base, other), change
    again, _ = run_kernel(plane)
    assert_bitwise_equal(base, again)


def smooth_plane(shape, seed):
    """A plane with smooth regions (runs of pixels Eq. 2 keeps) and edges."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[: shape[0], : shape[1]]
    plane = 60 + 40 * np.sin(x / 5.0) + np.where(y > shape[0] // 2, 90, 0)
    return np.clip(plane + rng.normal(0, 3, shape), 0, 255).astype(np.float32)


@pytest.mark.parametrize("preset", sorted(PRESETS))
@pytest.mark.parametrize("include_centre", [False, True])
@pytest.mark.parametrize("variance_ratio", ["sqrt(V/N)/M", "sqrt(V)/M"])
def test_kernel_matches_reference_on_larger_planes(preset, include_centre, variance_ratio):
    # long runs of kept interior pixels take the kernel's fast loop
    plane = smooth_plane((23, 37), seed=len(preset))
    options = {
        name: PRESETS[preset][name]
        for name in ("mean_threshold", "variance_threshold", "variance_action")
        + ("condition_order", "border", "on_exhausted", "scan")
    }
    options.update(include_centre=include_centre, variance_ratio=variance_ratio, seed=5)
    got, got_counts = run_kernel(plane, **options)
    want, want_counts = run_reference(plane, **options)
    assert_bitwise_equal(got, want)
    assert got_counts == want_counts
    assert got_counts["kept_by_mean"] > 0


def _interior_ratios(plane, y, x, include_centre, variance_ratio):
    """Eq. 2's and Eq. 4's ratios of an interior pixel, computed as the oracle does."""
    values = [float(plane[y + dy, x + dx]) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    g = values.pop(4)
    total = 0.0
    for value in values:
        total += value
    if include_centre:
        values.append(g)
        mean = (total + g) / 9
    else:
        mean = total / 8
    squares = 0.0
    for value in values:
        squares += (value - mean) * (value - mean)
    variance = squares / len(values)
    if variance_ratio == "sqrt(V/N)/M":
        variance /= len(values)
    return abs(g - mean) / mean, math.sqrt(variance) / mean


@pytest.mark.parametrize("condition_order", ["mean_first", "variance_first"])
@pytest.mark.parametrize("include_centre", [False, True])
@pytest.mark.parametrize("variance_ratio", ["sqrt(V/N)/M", "sqrt(V)/M"])
def test_thresholds_equal_to_a_pixel_s_ratios_decide_as_the_oracle(
    condition_order, include_centre, variance_ratio
):
    # t and V exactly at (and one float beside) the ratios of interior pixels:
    # the kernel's division-free comparisons must decide as the divisions do
    plane = smooth_plane((7, 9), seed=3)
    for y, x in [(2, 3), (3, 4), (4, 6)]:
        mean_ratio, spread_ratio = _interior_ratios(plane, y, x, include_centre, variance_ratio)
        for t in (mean_ratio, np.nextafter(mean_ratio, 0), np.nextafter(mean_ratio, 1)):
            for v in (spread_ratio, np.nextafter(spread_ratio, 0), np.nextafter(spread_ratio, 1)):
                options = dict(
                    mean_threshold=float(t),
                    variance_threshold=float(v),
                    condition_order=condition_order,
                    include_centre=include_centre,
                    variance_ratio=variance_ratio,
                    variance_action="push_in_range",
                    max_tries=3,
                )
                got, got_counts = run_kernel(plane, **options)
                want, want_counts = run_reference(plane, **options)
                assert_bitwise_equal(got, want)
                assert got_counts == want_counts


def test_eq2_threshold_is_inclusive_for_interior_pixels():
    # the centre of a 3 x 3 plane: M = 100, |112 - 100| / 100 == 0.12 exactly
    plane = np.full((3, 3), 100.0, dtype=np.float32)
    plane[1, 1] = 112.0
    options = dict(max_tries=0, variance_threshold=10.0)
    _, counts = run_kernel(plane, mean_threshold=0.12, **options)
    assert counts["kept_by_mean"] == 9
    _, counts = run_kernel(plane, mean_threshold=float(np.nextafter(0.12, 0)), **options)
    assert counts["kept_by_mean"] == 8 and counts["out_of_tries"] == 1
