"""The input: which image layer, which planes, which tone limits; and its snapshot."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from magicgui.widgets import CheckBox, ComboBox, Container, LineEdit, RadioButtons
from napari.layers import Image
from napari.viewer import Viewer

from ..core.colour import COLOUR_MODES
from ..widget.choices import ALL_PLANES, CURRENT_PLANE, LayerSnapshot, visible_plane
from ..widget.text import tone_limit_text, tone_limits


def layer_snapshot(
    layer: Image | None, world_point: Sequence[float], planes_on_screen: bool = True
) -> LayerSnapshot | None:
    """The layer as plain values, with the plane shown at ``world_point`` (of a multiscale
    layer: its index in the full level, the level shown and, when the viewer shows planes
    of the last two axes (``planes_on_screen``), the part of it on screen); None without
    one."""
    if layer is None:
        return None
    n_leading = layer.ndim - 2
    if n_leading <= 0:
        visible_index: tuple[int, ...] = ()
    else:
        coordinates = layer.world_to_data(world_point)[:n_leading]
        visible_index = visible_plane(coordinates, layer.data.shape[:n_leading])
    return LayerSnapshot(
        name=layer.name,
        data=layer.data,
        ndim=layer.ndim,
        rgb=bool(layer.rgb),
        multiscale=bool(layer.multiscale),
        scale=np.asarray(layer.scale, dtype=float),
        translate=np.asarray(layer.translate, dtype=float),
        rotate=np.asarray(layer.rotate, dtype=float),
        shear=np.asarray(layer.shear, dtype=float),
        affine=np.asarray(layer.affine.affine_matrix, dtype=float),
        units=tuple(str(unit) for unit in layer.units),
        axis_labels=tuple(str(label) for label in layer.axis_labels),
        contrast_limits=tuple(layer.contrast_limits),
        gamma=layer.gamma,
        opacity=layer.opacity,
        blending=layer.blending,
        interpolation2d=layer.interpolation2d,
        colormap=layer.colormap,
        visible_index=visible_index,
        data_level=int(layer.data_level),
        shown_region=_shown_region(layer) if layer.multiscale and planes_on_screen else None,
    )


def _shown_region(layer: Image) -> tuple[tuple[int, int], tuple[int, int]]:
    """The rows and columns of a multiscale layer's shown level that napari loads (its
    corner pixels, inclusive, of the last two axes of the layer)."""
    corners = np.asarray(layer.corner_pixels, dtype=int)[:, -2:]
    (top, left), (bottom, right) = corners
    return (int(top), int(bottom) + 1), (int(left), int(right) + 1)


class InputSection:
    """The image layer, the planes to render and the tone limits.

    The tone limits follow the layer's contrast limits unless the user
    unticks ``follow_contrast`` and types them.

    Attributes
    ----------
    image_layer : magicgui.widgets.ComboBox
        One of the viewer's image layers.
    planes : magicgui.widgets.RadioButtons
        ``"all planes"`` or ``"current plane"`` of an nD layer.
    follow_contrast : magicgui.widgets.CheckBox
    tone_low, tone_high : magicgui.widgets.LineEdit
        Values mapped to tones 0 and 255.
    box : magicgui.widgets.Container
    """

    def __init__(self, viewer: Viewer) -> None:
        self.viewer = viewer
        self._watched_layer: Image | None = None
        self.image_layer = ComboBox(
            label="image",
            choices=self._image_layer_choices,
            tooltip="Image layer to render (grey, RGB, or an nD time/z stack).",
        )
        self.planes = RadioButtons(
            label="planes",
            choices=(ALL_PLANES, CURRENT_PLANE),
            value=ALL_PLANES,
            orientation="horizontal",
            tooltip="Render every plane of an nD layer, or only the plane on screen "
            "(a quick look; the result sits at that plane).",
        )
        self.follow_contrast = CheckBox(
            text="tone limits follow the contrast limits",
            value=True,
            tooltip="Map the layer's contrast limits to tones 0 and 255, so that what you "
            "see is what gets rendered.",
        )
        self.colour = ComboBox(
            label="colour",
            choices=list(COLOUR_MODES),
            value="luminance",
            tooltip="RGB(A) layers: " + "; ".join(f"{k}: {v}" for k, v in COLOUR_MODES.items()),
        )
        self.tone_low = LineEdit(label="tone limits", tooltip="Value mapped to tone 0.")
        self.tone_high = LineEdit(tooltip="Value mapped to tone 255.")
        tone_row = Container(
            widgets=[self.tone_low, self.tone_high],
            layout="horizontal",
            labels=False,
            label="tone limits",
        )
        tone_row.margins = (0, 0, 0, 0)
        self.box = Container(
            widgets=[self.image_layer, self.planes, self.colour, tone_row, self.follow_contrast]
        )
        self.image_layer.changed.connect(self.follow_layer)
        self.follow_contrast.changed.connect(self._on_follow_contrast)

    def _image_layer_choices(self, _widget=None) -> list[tuple[str, Image]]:
        return [(layer.name, layer) for layer in self.viewer.layers if isinstance(layer, Image)]

    def reset_choices(self) -> None:
        """Refresh the list of image layers."""
        self.image_layer.reset_choices()
        if self._watched_layer != self.image_layer.value:
            self.follow_layer()

    def follow_layer(self, *_args) -> None:
        """Watch the chosen layer's contrast limits (and stop watching the previous layer's)."""
        layer = self.image_layer.value
        if self._watched_layer is not None:
            self._watched_layer.events.contrast_limits.disconnect(self._on_contrast_limits)
        self._watched_layer = layer
        if layer is not None:
            layer.events.contrast_limits.connect(self._on_contrast_limits)
        self.planes.enabled = layer is not None and layer.ndim > 2
        self.colour.enabled = layer is not None and bool(layer.rgb)
        self._on_contrast_limits()

    def _on_contrast_limits(self, *_args) -> None:
        layer = self.image_layer.value
        if layer is None or not self.follow_contrast.value:
            return
        self.tone_low.value, self.tone_high.value = tone_limit_text(layer.contrast_limits)

    def _on_follow_contrast(self, follow: bool) -> None:
        self.tone_low.enabled = self.tone_high.enabled = not follow
        self._on_contrast_limits()

    def typed_tone_limits(self) -> tuple[str, str] | None:
        """The typed tone limits, or None when they follow the contrast limits."""
        if self.follow_contrast.value:
            return None
        return self.tone_low.value, self.tone_high.value

    def tone_limits(self) -> tuple[float, float]:
        """The values mapped to tones 0 and 255: the layer's contrast limits or the typed ones.

        Raises
        ------
        ValueError
            If the typed limits are not numbers with low < high.
        """
        layer = self.image_layer.value
        following = self.follow_contrast.value and layer is not None
        typed = (self.tone_low.value, self.tone_high.value)
        return tone_limits(layer.contrast_limits if following else None, typed)

    def snapshot(self) -> LayerSnapshot | None:
        """The chosen layer as plain values (None without one)."""
        dims = self.viewer.dims
        planes = dims.ndisplay == 2 and tuple(dims.displayed) == (dims.ndim - 2, dims.ndim - 1)
        return layer_snapshot(self.image_layer.value, dims.point, planes)
