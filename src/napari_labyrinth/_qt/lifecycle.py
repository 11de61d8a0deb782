"""When a widget's dock or viewer closes: the widget is told once, through ``close_down``."""

from __future__ import annotations

from qtpy.QtCore import QEvent


class ClosesWithItsDock:
    """Mixin for a docked QWidget: calls ``self.close_down()`` when its dock or window closes.

    napari closes a dock by taking the widget out of it (its parent becomes
    None); a viewer closes its main window, whose Close event the widget
    watches once it is docked. No reference to the window is kept (only its
    id), so a closed viewer can be collected.
    """

    _watched_window = 0

    def close_down(self) -> None:  # pragma: no cover - the widget's
        raise NotImplementedError

    def event(self, event) -> bool:  # noqa: D102 - Qt's event handler
        if event.type() == QEvent.Type.ParentChange and self.parent() is None:
            self.close_down()  # napari took the widget out of its dock: the dock was closed
        return super().event(event)

    def showEvent(self, event) -> None:  # noqa: N802 - Qt's name
        self._watch_window()  # docked by now: the viewer's main window
        super().showEvent(event)

    def _watch_window(self) -> None:
        window = self.window()
        if window is not self and id(window) != self._watched_window:
            window.installEventFilter(self)
            self._watched_window = id(window)

    def eventFilter(self, watched, event) -> bool:  # noqa: N802 - Qt's name
        if event.type() == QEvent.Type.Close and watched is self.window():
            self.close_down()  # the viewer's window closes
        return super().eventFilter(watched, event)
