"""The planes of a lazy result rendered by a thread worker, where the user looks first.

A run on a lazy (dask) layer shows its result at once, with the plane on
screen rendered and the others blank
(:class:`~napari_labyrinth.widget.lazy_result.LazyResult`: a store on disk the
layer reads). :class:`PlaneQueue` renders the others in a napari thread
worker, never on the main thread: the plane on screen first, then its
neighbours; a move of the slider re-prioritises what is left. Each plane
rendered comes back to the main thread as the worker's ``yielded`` signal,
where the layer is refreshed if it shows that plane (the worker touches no
layer and no Qt object). The queue also owns the store's life
(:class:`~.result_store.StoreKeeper`): it is removed when the layer leaves the
viewer, when the layer is given other data, when the viewer's window closes,
and at interpreter exit.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from napari.layers import Image
from napari.qt.threading import create_worker
from napari.viewer import Viewer
from qtpy.QtCore import QObject, Signal
from qtpy.QtWidgets import QProgressBar, QWidget

from ..widget.choices import visible_plane
from ..widget.lazy_result import LazyResult
from .result_store import StoreKeeper

__all__ = ["PlaneQueue"]


class PlaneQueue(QObject):
    """Renders the planes left of ``background`` in the background for ``layer``.

    Parameters
    ----------
    viewer : napari.viewer.Viewer
    layer : napari.layers.Image
        The result layer, showing ``background.data``.
    background : LazyResult
    window : QWidget, optional
        The viewer's main window: the store is removed when it is deleted (napari
        deletes it once it has closed).

    Signals
    -------
    progressed(int)
        Planes rendered so far (of ``total``), after each plane.
    ended()
        The rendering ended: every plane is rendered, or it was stopped.
    """

    progressed = Signal(int)
    ended = Signal()

    def __init__(
        self,
        viewer: Viewer,
        layer: Image,
        background: LazyResult,
        window: QWidget | None = None,
    ) -> None:
        super().__init__()
        self.viewer = viewer
        self.layer = layer
        self.background = background
        self.worker = None
        self.seconds = 0.0
        self._started = 0.0
        self._progress_bar: QProgressBar | None = None
        self._say: Callable[[str], None] | None = None
        self._description = "the result"
        self._format = ""
        self._shown_rendered: bool | None = None  # whether the plane on screen is, as said
        self._released = False
        viewer.dims.events.current_step.connect(self._on_step)
        # the keeper holds this queue (its release) until the layer goes
        self._keeper = StoreKeeper(viewer, layer, self._remove, window)

    @property
    def total(self) -> int:
        """Number of planes of the result (of the input's leading axes)."""
        return self.background.order.total

    @property
    def done(self) -> int:
        """Number of planes rendered."""
        return self.background.order.done_count

    @property
    def running(self) -> bool:
        """Whether the worker is rendering."""
        return self.worker is not None

    def start(
        self,
        progress_bar: QProgressBar | None = None,
        say: Callable[[str], None] | None = None,
        description: str = "the result",
    ) -> None:
        """Start rendering in a thread worker (the plane on screen first).

        ``progress_bar`` counts the planes (``progressed`` sets its value) and
        ``say`` tells the user what goes on, and how it ended, with the
        ``description`` of the result.
        """
        self._on_step()
        self._started = time.perf_counter()
        self._progress_bar, self._say, self._description = progress_bar, say, description
        if progress_bar is not None:
            self._format = progress_bar.format()  # given back at the end
            progress_bar.setRange(0, self.total)
            progress_bar.setFormat("%v of %m planes")
            progress_bar.setValue(self.done)
        self._shown_rendered = None
        self._say_whether_shown(True)  # the run rendered the plane on screen
        order = self.background.order
        worker = create_worker(self.background.renders, lambda: order.cancelled)
        worker.yielded.connect(self._on_rendered)
        worker.finished.connect(self._on_finished)
        self.worker = worker
        worker.start()

    def quit(self) -> None:
        """Render no more planes (the widget's Cancel, as for a run's worker); the plane
        being rendered stops at its next pass. The planes rendered stay in the layer."""
        self.background.stop()
        if self.worker is not None:
            self.worker.quit()

    def release(self) -> None:
        """Stop, and remove the store (the layer is gone or shows other data)."""
        self._keeper.release()

    def _remove(self) -> None:
        if self._released:
            return
        self._released = True
        self.quit()
        self.background.remove()
        self.viewer.dims.events.current_step.disconnect(self._on_step)

    # -- the plane on screen -----------------------------------------------------------------

    def shown_plane(self) -> tuple[int, ...]:
        """The input plane whose rendering the layer shows where the viewer stands."""
        axis = self.background.axis
        shape = self.background.order.shape
        coordinates = self.layer.world_to_data(self.viewer.dims.point)
        return visible_plane(coordinates[axis : axis + len(shape)], shape)

    def _on_step(self, *_args) -> None:
        if self._released:
            return
        plane = self.shown_plane()
        self.background.order.move_focus(plane)
        if self.worker is not None:
            self._say_whether_shown(self.background.order.is_done(plane))

    def _on_rendered(self, index: tuple[int, ...]) -> None:
        if self._released:
            return
        if self.viewer.dims.ndisplay == 3 or index == self.shown_plane():
            self.layer.refresh()  # read back from the store, on the main thread
            self._say_whether_shown(True)
        self.progressed.emit(self.done)

    def _say_whether_shown(self, rendered: bool) -> None:
        """Tell the user whether the plane on screen is rendered or blank for now (only
        when that changes: each change of the text repaints the window)."""
        if rendered == self._shown_rendered:
            return
        self._shown_rendered = rendered
        if rendered:
            self._tell(
                f"Added {self._description}; rendering the other planes in the background …"
            )
        else:
            self._tell(
                f"Added {self._description}; rendering the other planes in the background: "
                "the plane on screen is blank until it is rendered (it is next) …"
            )

    def _on_finished(self) -> None:
        self.worker = None
        self.seconds = time.perf_counter() - self._started
        done, total = self.done, self.total
        if self._progress_bar is not None:
            try:
                self._progress_bar.setFormat(self._format)
            except RuntimeError:  # the widget's Qt object is gone (its viewer closed)
                pass
        if done == total:
            self._tell(f"Added {self._description}: {total} planes ({self.seconds:.1f} s)")
        else:
            self._tell(f"Stopped: {done} of {total} planes rendered, the others blank")
        self.ended.emit()

    def _tell(self, text: str) -> None:
        if self._say is not None:
            try:
                self._say(text)
            except RuntimeError:  # the widget's Qt object is gone (its viewer closed)
                pass
