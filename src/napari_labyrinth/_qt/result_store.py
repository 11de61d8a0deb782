"""A result kept on disk lives as long as a layer shows it.

A lazy result's planes (:mod:`~napari_labyrinth.widget.plane_store`) and a
multiscale result rendered band by band
(:mod:`~napari_labyrinth.widget.pyramid_store`) are stores in the system's
temporary directory that their layer reads. A :class:`StoreKeeper` keeps the
store while its layer shows it, and releases it (removes it, after what its
owner must stop first) once the layer leaves the viewer, is given other data,
or the viewer's window is deleted (napari deletes it once it has closed);
what is left at interpreter exit goes then.
"""

from __future__ import annotations

from collections.abc import Callable

from napari.layers import Image
from napari.viewer import Viewer
from qtpy.QtWidgets import QWidget

__all__ = ["StoreKeeper", "unwrapped"]

#: The keepers whose store is still in use (napari's events hold a method weakly: each is
#: kept here until its layer goes).
_LIVE: set[StoreKeeper] = set()


class StoreKeeper:
    """Calls ``release`` once, when ``layer`` stops showing the data it shows now.

    Parameters
    ----------
    viewer : napari.viewer.Viewer
    layer : napari.layers.Image
        The result layer (or napari's proxy of it: never compared by identity).
    release : callable
        Removes the store (and stops what writes to it).
    window : QWidget, optional
        The viewer's main window.
    """

    def __init__(
        self,
        viewer: Viewer,
        layer: Image,
        release: Callable[[], None],
        window: QWidget | None = None,
    ) -> None:
        self.viewer, self.layer = viewer, layer
        # what it shows of the store (a multiscale layer's: napari's list of its levels); a
        # run that updates the layer in place gives it other data
        self.data = unwrapped(layer).data
        self._release = release
        self.released = False
        viewer.layers.events.removed.connect(self._on_layer_removed)
        layer.events.data.connect(self._on_data)
        if window is not None:
            window.destroyed.connect(self._on_window_destroyed)
        _LIVE.add(self)

    def release(self) -> None:
        """Release the store now (once; later calls do nothing)."""
        if self.released:
            return
        self.released = True
        self.viewer.layers.events.removed.disconnect(self._on_layer_removed)
        self.layer.events.data.disconnect(self._on_data)
        _LIVE.discard(self)
        self._release()

    def _on_layer_removed(self, event) -> None:
        if unwrapped(event.value) is unwrapped(self.layer):
            self.release()

    def _on_data(self, *_args) -> None:
        if unwrapped(self.layer).data is not self.data:
            self.release()

    def _on_window_destroyed(self, *_args) -> None:
        self.release()  # the viewer has closed


def unwrapped(layer):
    """The layer behind ``layer``: napari hands a plugin proxies of its objects, and a
    proxy and the layer it wraps are not the same object."""
    return getattr(layer, "__wrapped__", layer)
