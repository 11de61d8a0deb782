"""Colours at the ends of float64's range: recoloured without a warning."""

import warnings

import numpy as np

from napari_labyrinth import labyrinth
from napari_labyrinth.core.colour import luminance, recolour


def test_a_colour_brightened_beyond_float64s_range_is_clipped_without_a_warning():
    largest = np.finfo(np.float64).max
    colours = np.array([[largest, largest / 2, largest / 4]])
    old = luminance(colours)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = recolour(colours, old, np.full_like(old, largest), np.float64)
    assert result[0, 0] == largest  # beyond the range: its end
    assert np.all(np.isfinite(result))


def test_a_colour_image_near_float64s_largest_value_renders_without_a_warning():
    image = np.random.default_rng(0).random((24, 24, 3)) * np.finfo(np.float64).max
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rendered = labyrinth(image, channel_axis=-1)
    with np.errstate(over="ignore"):
        expected = labyrinth(image, channel_axis=-1)
    np.testing.assert_array_equal(rendered, expected)
    assert np.all(np.isfinite(rendered))
