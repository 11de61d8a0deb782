"""Invariants of the rendering, checked on generated images (hypothesis)."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from napari_labyrinth import DIAGNOSTIC_FIELDS, labyrinth
from napari_labyrinth.core._reference import reference_pass
from napari_labyrinth.core.parameters import PARAMETERS, SEED, equal_tone_ranges

from .test_kernel import OPTIONS, assert_bitwise_equal, run_kernel

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])

shapes = st.tuples(st.integers(1, 12), st.integers(1, 12))
uint8_images = shapes.flatmap(lambda shape: arrays(np.uint8, shape))
float_planes = shapes.flatmap(
    lambda shape: arrays(
        np.float32,
        shape,
        elements=st.one_of(
            st.floats(0, 255, width=32),
            st.sampled_from([np.nan, np.inf, -np.inf, 0.0, 255.0]),
        ),
    )
)
options = st.fixed_dictionaries(
    {
        "mean_threshold": st.floats(0, 1),
        "variance_threshold": st.floats(0, 2),
        "max_tries": st.integers(0, 30),
        "seed": st.integers(0, SEED.high),
        **{name: st.sampled_from(values) for name, values in OPTIONS.items()},
    }
)


#: The noise gate's floor in tones²: off, or any floor (0 included).
variance_floors = st.one_of(st.just(-1.0), st.floats(0, 5000))


@SETTINGS
@given(plane=float_planes, options=options, n_ranges=st.integers(1, 6), floor=variance_floors)
def test_kernel_equals_the_oracle_on_any_plane(plane, options, n_ranges, floor):
    limits = equal_tone_ranges(n_ranges)
    tones = tuple(zip(limits[:-1], limits[1:]))
    options = dict(options, variance_floor=floor)
    got, got_counts = run_kernel(plane, limits=limits, tones=tones, **options)
    want, want_counts = reference_pass(plane, range_limits=limits, tones=tones, **options)
    assert_bitwise_equal(got, want)
    assert got_counts == want_counts


@SETTINGS
@given(
    image=uint8_images,
    options=options,
    passes=st.integers(0, 3),
    noise_gate=st.one_of(st.just(0.0), st.floats(0, 4)),
)
def test_rendering_is_a_pure_function_that_leaves_its_input_alone(
    image, options, passes, noise_gate
):
    options = dict(options, noise_gate=noise_gate)
    before = image.copy()
    first, diagnostics = labyrinth(image, passes=passes, return_diagnostics=True, **options)
    second = labyrinth(image, passes=passes, **options)
    np.testing.assert_array_equal(image, before)
    np.testing.assert_array_equal(first, second)
    assert first.shape == image.shape and first.dtype == image.dtype
    assert diagnostics.shape == (passes,)
    for k in range(passes):
        assert sum(int(diagnostics[name][k]) for name in DIAGNOSTIC_FIELDS) == image.size


@SETTINGS
@given(image=uint8_images, seed=st.integers(0, 2**32))
def test_changed_pixels_take_tones_of_their_ranges(image, seed):
    # with the paper's ranges and T = L every redrawn tone lies in [L_inf^1, 255]
    out = labyrinth(image, seed=seed, on_exhausted="last_draw", tone_ranges=3)
    changed = out != image
    assert (out[changed] >= 10).all()


@SETTINGS
@given(image=uint8_images, seed=st.integers(0, 2**32))
def test_a_huge_mean_threshold_changes_nothing(image, seed):
    # (the literal reading: Eq. 2 decides first; the largest t the table allows)
    out = labyrinth(
        image, preset="paper", seed=seed, mean_threshold=PARAMETERS["mean_threshold"].high
    )
    np.testing.assert_array_equal(out, image)


@SETTINGS
@given(
    stack=st.tuples(st.integers(2, 4), st.integers(2, 10), st.integers(2, 10)).flatmap(
        lambda shape: arrays(np.uint8, shape)
    ),
    plane=st.integers(0, 3),
)
def test_a_plane_does_not_depend_on_the_others(stack, plane):
    plane = plane % stack.shape[0]
    out = labyrinth(stack, seed=5)
    other = stack.copy()
    other[np.arange(stack.shape[0]) != plane] = 128
    np.testing.assert_array_equal(labyrinth(other, seed=5)[plane], out[plane])


@SETTINGS
@given(
    image=shapes.flatmap(
        lambda shape: arrays(
            np.float64,
            shape,
            elements=st.one_of(st.floats(-1e3, 1e3), st.sampled_from([np.nan, np.inf])),
        )
    )
)
def test_non_finite_values_stay_where_they_are(image):
    out = labyrinth(image, passes=2)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(image))
    np.testing.assert_array_equal(np.isinf(out), np.isinf(image))
    finite = np.isfinite(image)
    if finite.any():
        unchanged = out[finite] == image[finite]
        lo, hi = np.percentile(image[finite], (0.5, 99.5))
        moved = out[finite][~unchanged]
        assert ((moved >= lo - 1e-6 * (1 + abs(lo))) & (moved <= hi + 1e-6 * (1 + abs(hi)))).all()
