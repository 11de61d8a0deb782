"""The "Auto" button beside V: find the window of V on the input and show its curve.

A click measures :func:`napari_labyrinth.find_window` on the data the next run
would render (the whole layer, or the plane on screen), with the form's other
parameters, in a worker; the result sets the V field (so the run and its
metadata record carry it like a typed value) and the plot shows the edge
enhancement against V with the window shaded and the chosen V marked.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from magicgui.widgets import Container, PushButton
from napari.qt.threading import thread_worker
from qtpy.QtCore import QPointF, QRectF, Qt
from qtpy.QtGui import QColor, QPainter, QPen
from qtpy.QtWidgets import QSizePolicy

from ..widget.choices import Choices, LayerSnapshot
from ..widget.plan import make_plan
from ..window import Window, window_for
from .collector import hold_while_running
from .form import ParameterForm
from .plot_layout import INSET, SWATCH, FittedPlot, PlotLayout, compact_font, plot_layout

#: The field the button fills.
FIELD = "variance_threshold"

_CURVE = "#f0a030"
_WINDOW = QColor(64, 176, 240, 60)


class AutoWindow:
    """The button beside the V field, and the plot of the last window found.

    Parameters
    ----------
    form : ParameterForm
        The form whose V field the button sits beside and sets.
    snapshot, choices : callable
        Return the input layer's snapshot and the user's choices now.
    report : callable
        Called with a line for the user.

    Attributes
    ----------
    button : magicgui.widgets.PushButton
    plot : WindowPlot
    window : Window or None
        The last window found.
    worker : napari worker or None
        The search in flight.
    """

    def __init__(
        self,
        form: ParameterForm,
        snapshot: Callable[[], LayerSnapshot | None],
        choices: Callable[[], Choices],
        report: Callable[[str], None],
    ) -> None:
        self.form = form
        self._snapshot, self._choices, self._report = snapshot, choices, report
        self.window: Window | None = None
        self.worker = None
        self.button = PushButton(text="Auto")
        self.button.tooltip = (
            "Measure where the labyrinth follows the edges of this input (the window of V) "
            "with the other parameters, and set V to its best value."
        )
        self.button.changed.connect(self.find)
        self.plot = WindowPlot()
        field = form.fields[FIELD]
        box = form.parameter_box
        index = list(box).index(field)
        box.remove(field)
        row = Container(widgets=[field, self.button], layout="horizontal", labels=False)
        row.margins = (0, 0, 0, 0)
        row.label = field.label
        box.insert(index, row)

    def find(self, *_args, start: bool = True):
        """Search the window of V on the current input in a worker (returned unstarted
        with ``start=False``)."""
        try:
            choices = dataclasses.replace(self._choices(), mode="single")
            plan = make_plan(self._snapshot(), choices)
        except (ValueError, TypeError) as exc:
            self._report(f"Auto V: {exc}")
            return None
        self.button.enabled = False
        self._report("Auto V: measuring the window of V…")
        worker = thread_worker(window_for, start_thread=False)(plan.data, **plan.arguments)
        worker.returned.connect(self._on_found)
        worker.errored.connect(self._on_failed)
        worker.finished.connect(self._on_finished)
        hold_while_running(worker)
        self.worker = worker
        if start:
            worker.start()
        return worker

    def close(self) -> None:
        """The widget is closing: a search in flight ends without touching it."""
        worker, self.worker = self.worker, None
        if worker is not None:
            for signal, slot in (
                (worker.returned, self._on_found),
                (worker.errored, self._on_failed),
                (worker.finished, self._on_finished),
            ):
                signal.disconnect(slot)
            worker.quit()

    def _on_found(self, window: Window) -> None:
        self.window = window
        self.form.fields[FIELD].value = window.best
        self.plot.show_window(window)
        self._report(f"Auto {window.summary()}")

    def _on_failed(self, error: Exception) -> None:
        self._report(f"Auto V failed: {error}")

    def _on_finished(self) -> None:
        self.button.enabled = True
        self.worker = None


#: What the Auto plot's curve is (its legend entry).
CURVE_CAPTION = "edge enhancement"


class WindowPlot(FittedPlot):
    """Edge enhancement against V (log scale), the window shaded, the chosen V marked."""

    def __init__(self) -> None:
        super().__init__()
        self.window: Window | None = None
        self.setFont(compact_font(self.font()))
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.setToolTip(
            "Edge enhancement of the probe against V (log scale): the shaded band is the "
            "window (at least 90 % of the best), the line the chosen V. A window that "
            "reaches the lowest or highest V probed may go on beyond it."
        )
        self.setVisible(False)

    def show_window(self, window: Window | None) -> None:
        """Plot ``window``'s curve and show the plot (None hides it)."""
        self.window = window
        self.setVisible(window is not None)
        if window is not None:
            self.fit_height()
        self.update()

    def plot_rects(self) -> PlotLayout:
        """Where the curve, the V axis and the caption go at the widget's width."""
        thresholds = [v for v in self.window.thresholds if v > 0]
        axis = (f"{thresholds[0]:.3g}", "V (log scale)", f"{thresholds[-1]:.3g}")
        note = [self.window.open_note] if self.window.open_note else []  # a line of its own
        captions = [CURVE_CAPTION, self.window.summary(note=False), *note]
        return plot_layout(self.width(), self.fontMetrics(), axis, captions)

    def has_data(self) -> bool:
        return self.window is not None

    def x_of(self, value: float, frame: QRectF) -> float:
        """Horizontal position of ``value`` in ``frame`` (log scale over the probed V)."""
        thresholds = [v for v in self.window.thresholds if v > 0]
        low, high = math.log(thresholds[0]), math.log(thresholds[-1])
        where = (math.log(max(value, thresholds[0])) - low) / ((high - low) or 1.0)
        return frame.left() + frame.width() * where

    def paintEvent(self, _event) -> None:  # noqa: N802 - Qt's name
        window = self.window
        if window is None:
            return
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        text = self.palette().windowText().color()
        rects = self.plot_rects()
        box = rects.data
        frame = box.adjusted(INSET, INSET, -INSET, -INSET)  # the end dots clear the box
        if window.found:
            left, right = self.x_of(window.low, frame), self.x_of(window.high, frame)
            band = QRectF(left - 2, box.top(), right - left + 4, box.height())
            painter.fillRect(band, _WINDOW)
        painter.setPen(QPen(text, 1))
        painter.drawRect(box)
        finite = [v for v in window.edge_enhancement if math.isfinite(v)]
        low, high = min(0.0, *finite, 0.0), max(0.0, *finite, 0.0)
        high += 0.1 * ((high - low) or 1.0)
        scale = (high - low) or 1.0

        def y_of(value: float) -> float:
            return frame.bottom() - frame.height() * (value - low) / scale

        painter.setPen(QPen(text, 1, Qt.PenStyle.DotLine))
        painter.drawLine(QPointF(frame.left(), y_of(0.0)), QPointF(frame.right(), y_of(0.0)))
        points = [
            QPointF(self.x_of(v, frame), y_of(e))
            for v, e in zip(window.thresholds, window.edge_enhancement)
            if math.isfinite(e) and v > 0
        ]
        painter.setPen(QPen(QColor(_CURVE), 2))
        for a, b in zip(points, points[1:]):
            painter.drawLine(a, b)
        for point in points:
            painter.drawEllipse(point, 2.5, 2.5)
        best = self.x_of(window.best, frame)
        painter.setPen(QPen(text, 1, Qt.PenStyle.DashLine))
        painter.drawLine(QPointF(best, frame.top()), QPointF(best, frame.bottom()))
        (curve_rect, curve), (caption_rect, caption), *notes = rects.legend
        middle = caption_rect.center().y()
        painter.drawLine(  # the caption's swatch: the dashed line of the chosen V
            QPointF(caption_rect.left() - SWATCH + 1, middle),
            QPointF(caption_rect.left() - 4, middle),
        )
        painter.setPen(QPen(QColor(_CURVE), 2))
        middle = curve_rect.center().y()
        painter.drawLine(  # the curve's swatch
            QPointF(curve_rect.left() - SWATCH + 1, middle), QPointF(curve_rect.left() - 4, middle)
        )
        painter.setPen(QPen(text, 1))
        painter.drawText(curve_rect, int(Qt.AlignmentFlag.AlignLeft), curve)
        for rect, flags, axis_text in rects.axis:
            painter.drawText(rect, flags, axis_text)
        painter.drawText(caption_rect, int(Qt.AlignmentFlag.AlignLeft), caption)
        for note_rect, note in notes:  # the window may go on beyond the V probed
            painter.drawText(note_rect, int(Qt.AlignmentFlag.AlignLeft), note)
        painter.end()
