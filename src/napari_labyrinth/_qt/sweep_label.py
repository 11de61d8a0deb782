"""The value of the swept parameter of the plane on screen, in the viewer's text overlay."""

from __future__ import annotations

from napari.layers import Image
from napari.viewer import Viewer

from ..widget.layer_kwargs import METADATA_KEY
from ..widget.text import sweep_label


class SweepLabel:
    """Shows ``"V = 0.04"`` over the canvas while the active layer is a sweep result.

    The text follows the slider of the sweep's axis. The overlay is napari's
    own text overlay; it is hidden again when another layer becomes active,
    unless something else wrote to it meanwhile.
    """

    def __init__(self, viewer: Viewer) -> None:
        self.viewer = viewer
        self._shown = ""
        viewer.dims.events.current_step.connect(self.refresh)
        viewer.layers.selection.events.active.connect(self.refresh)

    def text(self) -> str:
        """The label of the active layer's plane on screen ("" when it is not a sweep)."""
        layer = self.viewer.layers.selection.active
        if not isinstance(layer, Image):
            return ""
        record = layer.metadata.get(METADATA_KEY) or {}
        if not record.get("sweep") or not layer.visible:
            return ""
        axis = self.viewer.dims.ndim - layer.ndim  # the sweep axis leads the layer's axes
        return sweep_label(record, self.viewer.dims.current_step[axis])

    @property
    def overlay(self):
        """napari's text overlay (``viewer.canvas.overlays["text"]`` since napari 0.6)."""
        canvas = getattr(self.viewer, "canvas", None)
        if canvas is not None and "text" in getattr(canvas, "overlays", {}):
            return canvas.overlays["text"]
        return self.viewer.text_overlay

    def refresh(self, *_args) -> None:
        overlay = self.overlay
        text = self.text()
        if text:
            overlay.text = text
            overlay.visible = True
            self._shown = text
        elif self._shown and overlay.text == self._shown:
            overlay.visible = False
            overlay.text = ""
            self._shown = ""

    def disconnect(self) -> None:
        self.viewer.dims.events.current_step.disconnect(self.refresh)
        self.viewer.layers.selection.events.active.disconnect(self.refresh)
