"""The "Auto" button beside V: find the window of V on the input and show its curve.

A click measures :func:`napari_labyrinth.find_window` on the data the next run
would render (the whole layer, or the plane on screen), with the form's other
parameters, in a worker; the result sets the V field (so the run and its
metadata record carry it like a typed value) and the plot shows the edge
enhancement and the labyrinth cover against V, the window shaded, the chosen V
marked and why it was chosen (``Window.choice``, the line the command line prints).
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
_COVER = "#60c060"
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
        self._report(f"Auto {window.summary()}")  # the plot's caption says it too

    def _on_failed(self, error: Exception) -> None:
        self._report(f"Auto V failed: {error}")

    def _on_finished(self) -> None:
        self.button.enabled = True
        self.worker = None


#: What the Auto plot's curves are (their legend entries).
CURVE_CAPTION = "edge enhancement"
COVER_CAPTION = "cover (to its best)"


class WindowPlot(FittedPlot):
    """Edge enhancement and cover against V (log scale), the window shaded, the chosen V
    marked and why."""

    def __init__(self) -> None:
        super().__init__()
        self.window: Window | None = None
        self.setFont(compact_font(self.font()))
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.setToolTip(
            "The probe's edge enhancement and labyrinth cover (scaled to its best) against "
            "V (log scale). Auto takes, among the V whose walls run along the contours and "
            "cover at least 90 % of the best such cover, the V of the best edge enhancement "
            "(the dashed line; its caption says what it draws). The shaded band is the "
            "window around it. A window that reaches the lowest or highest V probed may go "
            "on beyond it."
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
        curves = [CURVE_CAPTION, COVER_CAPTION] if self._covers() else [CURVE_CAPTION]
        note = [self.window.range_note] if self.window.range_note else []
        captions = [*curves, self.window.choice, *note]
        return plot_layout(self.width(), self.fontMetrics(), axis, captions)

    def _covers(self) -> list[tuple[float, float]]:
        """``(V, cover)`` of the finite covers, if any is above 0."""
        pairs = [
            (v, c) for v, c in zip(self.window.thresholds, self.window.cover)
            if v > 0 and math.isfinite(c)
        ]  # fmt: skip
        return pairs if any(c > 0 for _, c in pairs) else []

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
        covers = self._covers()
        if covers:  # on its own scale: 0 at the bottom, its best near the top
            top = max(c for _, c in covers) / 0.9
            cover_points = [
                QPointF(self.x_of(v, frame), frame.bottom() - frame.height() * c / top)
                for v, c in covers
            ]
            _polyline(painter, cover_points, QColor(_COVER))
        _polyline(painter, points, QColor(_CURVE))
        best = self.x_of(window.best, frame)
        painter.setPen(QPen(text, 1, Qt.PenStyle.DashLine))
        painter.drawLine(QPointF(best, frame.top()), QPointF(best, frame.bottom()))
        swatches = [QColor(_CURVE), QColor(_COVER)][: 2 if covers else 1]
        legend = rects.legend
        for (rect, _), colour in zip(legend, swatches):  # the curves' swatches
            _swatch(painter, rect, QPen(colour, 2))
        choice_rect, _ = legend[len(swatches)]
        _swatch(painter, choice_rect, QPen(text, 1, Qt.PenStyle.DashLine))  # the chosen V's
        painter.setPen(QPen(text, 1))
        for rect, flags, axis_text in rects.axis:
            painter.drawText(rect, flags, axis_text)
        for rect, caption in legend:  # the curves, the chosen V and why, the window
            painter.drawText(rect, int(Qt.AlignmentFlag.AlignLeft), caption)
        painter.end()


def _polyline(painter: QPainter, points: list[QPointF], colour: QColor) -> None:
    """A curve through ``points``, a dot at each."""
    painter.setPen(QPen(colour, 2))
    for a, b in zip(points, points[1:]):
        painter.drawLine(a, b)
    for point in points:
        painter.drawEllipse(point, 2.5, 2.5)


def _swatch(painter: QPainter, caption: QRectF, pen: QPen) -> None:
    """The short line left of a legend caption, drawn with ``pen``."""
    painter.setPen(pen)
    middle = caption.center().y()
    painter.drawLine(
        QPointF(caption.left() - SWATCH + 1, middle), QPointF(caption.left() - 4, middle)
    )
