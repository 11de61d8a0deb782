"""How an image splits into planes: channel axis, alpha, stream indices, step counts."""

import numpy as np
import pytest

from napari_labyrinth import labyrinth
from napari_labyrinth.core.planes import (
    PlaneLayout,
    first_plane_index,
    normalise_channel_axis,
    plane_axes,
    step_count,
    validate_plane_offset,
    without_alpha,
)


@pytest.mark.parametrize(
    "shape, index, channel_axis, offset",
    [
        ((4, 5, 8, 8), (2, 3), None, 13),  # 2 * 5 + 3
        ((4, 8, 8, 3), (2,), -1, 6),  # every channel is a plane
        ((4, 8, 8, 4), (1,), -1, 4),  # alpha counts as a plane of the stream
        ((4, 8, 8), (0,), None, 0),
        ((4, 5, 8, 8), (2,), None, 10),  # the first of the 5 planes at index 2
        ((8, 8), (), None, 0),
    ],
)
def test_first_plane_index_is_the_flat_index_of_the_plane(shape, index, channel_axis, offset):
    assert first_plane_index(shape, index, channel_axis) == offset


def test_a_plane_cut_from_a_stack_renders_as_within_it_with_its_first_plane_index():
    rng = np.random.default_rng(1)
    stack = rng.integers(0, 256, (3, 2, 16, 16, 3)).astype(np.uint8)
    whole = labyrinth(stack, passes=2, channel_axis=-1)
    offset = first_plane_index(stack.shape, (2, 1), -1)
    part = labyrinth(stack[2, 1], passes=2, channel_axis=-1, plane_offset=offset)
    np.testing.assert_array_equal(part, whole[2, 1])


@pytest.mark.parametrize(
    "shape, channel_axis, passes, colour, steps",
    [
        ((3, 32, 32), None, 2, None, 6),
        ((2, 8, 8, 4), -1, 2, "channels", 12),  # RGBA: 3 channels render, alpha does not
        ((2, 8, 8, 4), -1, 2, None, 4),  # in the luminance (default): one plane per position
        ((8, 8, 3), 2, [1, 2], "channels", 9),  # a sweep: the passes of every rendering
        ((8, 8, 3), 2, [1, 2], "luminance", 3),
        ((4, 8, 8), 0, 3, "channels", 9),  # channels first: the fourth is alpha
        ((4, 8, 8), 0, 3, None, 3),
        ((5, 8, 8, 2), -1, 1, None, 10),  # 2 channels: rendered one by one
        ((8, 8), None, 0, None, 0),
    ],
)
def test_step_count_is_rendered_planes_times_passes(shape, channel_axis, passes, colour, steps):
    assert step_count(shape, channel_axis, passes, colour) == steps


def test_layout_of_channels_between_other_axes():
    layout = PlaneLayout((5, 3, 16, 12), channel_axis=1)
    assert layout.leading_shape == (5, 3)
    assert layout.plane_shape == (16, 12)
    assert layout.n_planes == 15 and layout.n_rendered == 15
    assert layout.stream_index((2, 1)) == 7
    image = np.arange(5 * 3 * 16 * 12).reshape(5, 3, 16, 12)
    assert layout.to_planes(image).shape == (5, 3, 16, 12)
    rgba = PlaneLayout((16, 12, 4), channel_axis=2)
    assert rgba.leading_shape == (4,)
    assert [i for i in rgba.rendered_indices()] == [(0,), (1,), (2,)]
    assert rgba.is_alpha((3,)) and rgba.n_rendered == 3


def test_a_block_of_a_larger_array_keeps_its_planes_stream_indices():
    block = PlaneLayout((2, 8, 8), leading_origin=(4,), leading_total=(10,), plane_offset=100)
    assert [block.stream_index((k,)) for k in range(2)] == [104, 105]


def test_plane_axes_hold_the_spatial_axes_and_the_channels():
    assert plane_axes(3, None) == (1, 2)
    assert plane_axes(4, -1) == (1, 2, 3)
    assert plane_axes(4, 1, extra=1) == (2, 3, 4)


def test_without_alpha_drops_the_fourth_channel_only():
    rgba = np.zeros((4, 8, 8))
    assert without_alpha(rgba, 0).shape == (3, 8, 8)
    assert without_alpha(np.zeros((3, 8, 8)), 0).shape == (3, 8, 8)
    assert without_alpha(rgba, None) is rgba


@pytest.mark.parametrize(
    "value, error, match",
    [
        (-1, ValueError, "plane_offset must be between 0 and 2\\*\\*63 - 1"),
        (2**64, ValueError, "plane_offset"),
        (1.5, TypeError, "plane_offset must be an integer"),
        (True, TypeError, "plane_offset"),
    ],
)
def test_bad_plane_offsets_name_the_parameter(value, error, match):
    with pytest.raises(error, match=match):
        validate_plane_offset(value)


def test_channel_axis_is_checked_and_normalised():
    assert normalise_channel_axis(-1, 3) == 2
    assert normalise_channel_axis(None, 2) is None
    with pytest.raises(ValueError, match="at least 3 dimensions"):
        normalise_channel_axis(0, 2)
    with pytest.raises(TypeError, match="channel_axis"):
        normalise_channel_axis(1.0, 3)
