"""The snapshot of the input layer, against napari's own transforms."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from napari.layers import Image

from napari_labyrinth._qt.inputs import layer_snapshot
from napari_labyrinth.widget.layer_kwargs import result_layer_kwargs

from .helpers import noise

#: A layer whose every transform differs from the identity.
TRANSFORMS = {
    "scale": (10.0, 2.0, 3.0),
    "translate": (3.0, -4.0, 5.0),
    "rotate": (30.0, 10.0, 5.0),
    "shear": (0.2, 0.1, -0.3),
    "affine": np.array(
        [
            [1.0, 0.1, 0.0, 2.0],
            [0.0, 0.9, 0.2, -1.0],
            [0.1, 0.0, 1.1, 0.5],
            [0.0, 0.0, 0.0, 1.0],
        ]
    ),
}


def test_the_snapshot_holds_the_layer_settings_as_plain_values(viewer):
    data = noise((3, 16, 16))
    # napari 0.5's add_image takes no units nor axis labels (a sequence asks for channel_axis)
    layer = viewer.add_layer(
        Image(
            data,
            name="movie",
            units=("s", "um", "um"),
            axis_labels=("t", "y", "x"),
            contrast_limits=(10, 200),
            gamma=0.8,
            colormap="magma",
            **TRANSFORMS,
        )
    )
    snapshot = layer_snapshot(layer, viewer.dims.point)
    assert snapshot.name == "movie" and snapshot.data is layer.data
    assert snapshot.ndim == 3 and not snapshot.rgb and not snapshot.multiscale
    np.testing.assert_allclose(snapshot.scale, TRANSFORMS["scale"])
    np.testing.assert_allclose(snapshot.translate, TRANSFORMS["translate"])
    np.testing.assert_allclose(snapshot.rotate, layer.rotate)
    np.testing.assert_allclose(snapshot.shear, TRANSFORMS["shear"])
    np.testing.assert_allclose(snapshot.affine, TRANSFORMS["affine"])
    assert snapshot.units == ("second", "micrometer", "micrometer")
    assert snapshot.axis_labels == ("t", "y", "x")
    assert snapshot.contrast_limits == (10, 200) and snapshot.gamma == 0.8
    assert snapshot.colormap.name == "magma"
    assert layer_snapshot(None, viewer.dims.point) is None


def test_the_visible_plane_follows_the_dims_and_is_clipped_to_the_layer(viewer):
    small = viewer.add_image(noise((3, 4, 16, 16)), name="small", scale=(2, 1, 1, 1))
    viewer.dims.set_current_step(0, 2)  # world 4: plane 2 of "small"
    viewer.dims.set_current_step(1, 3)
    assert layer_snapshot(small, viewer.dims.point).visible_index == (2, 3)
    viewer.add_image(noise((9, 4, 16, 16)), name="long")
    viewer.dims.set_current_step(0, 8)  # beyond the end of "small"
    assert layer_snapshot(small, viewer.dims.point).visible_index == (2, 3)


def test_a_plane_rendered_alone_sits_where_napari_draws_it_in_the_input(viewer):
    data = noise((4, 16, 16))
    source = viewer.add_image(data, **TRANSFORMS)
    snapshot = layer_snapshot(source, viewer.dims.point)
    for extra_axis in (None, "pass"):
        kwargs = result_layer_kwargs(snapshot, "plane", extra_axis, (2,))
        shape = (1, 16, 16) if extra_axis is None else (3, 1, 16, 16)
        result = Image(np.zeros(shape, np.uint8), **kwargs)
        for y, x in ((0, 0), (5, 11), (15, 15)):
            position = (0, y, x) if extra_axis is None else (0, 0, y, x)
            world = np.asarray(result.data_to_world(position))
            expected = np.asarray(source.data_to_world((2, y, x)))
            np.testing.assert_allclose(world[-3:], expected, atol=1e-9)


def test_an_extra_axis_leaves_the_input_axes_as_napari_draws_them(viewer):
    source = viewer.add_image(noise((4, 16, 16)), **TRANSFORMS)
    kwargs = result_layer_kwargs(layer_snapshot(source, viewer.dims.point), "stack", "pass", None)
    np.testing.assert_allclose(kwargs["affine"], source.affine.expand_dims([0]).affine_matrix)
    result = Image(np.zeros((3, 4, 16, 16), np.uint8), **kwargs)
    for position in ((1, 2, 3), (3, 15, 0)):
        world = np.asarray(result.data_to_world((2, *position)))
        np.testing.assert_allclose(world[1:], source.data_to_world(position), atol=1e-9)
