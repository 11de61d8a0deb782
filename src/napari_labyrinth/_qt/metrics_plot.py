"""A small plot of two metrics of a stack against the pass: edge enhancement and cover."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from qtpy.QtCore import QPointF, Qt
from qtpy.QtGui import QColor, QPainter, QPen
from qtpy.QtWidgets import QSizePolicy

from .plot_layout import INSET, SWATCH, FittedPlot, PlotLayout, compact_font, plot_layout

#: The plotted metrics: (key, legend, colour).
CURVES = (
    ("edge_enhancement", "edge enhancement", "#f0a030"),
    ("labyrinth_cover", "labyrinth cover", "#40b0f0"),
)


class MetricsPlot(FittedPlot):
    """The plotted metrics after pass 1, 2, …, each on its own 0-to-max scale.

    The passes run along the bottom of the data rectangle (first and last
    under its ends), the legend (each curve's last value) under it: see
    :mod:`.plot_layout`; the widget is as tall as they need.
    """

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[Mapping[str, float]] = []
        self.setFont(compact_font(self.font()))
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.setToolTip(
            "Per pass, on the plane on screen: edge enhancement (correlation of the added "
            "texture with the input's edges) and labyrinth cover (fraction covered by walls); "
            "each curve on its own scale, its last value in the legend."
        )
        self.setVisible(False)

    def show_passes(self, rows: Sequence[Mapping[str, float]]) -> None:
        """Plot the metric rows of a run (one dict per pass) and show the plot."""
        self.rows = list(rows)
        self.setVisible(bool(self.rows))
        self.fit_height()
        self.update()

    def clear(self) -> None:
        """Forget the plotted run and hide the plot."""
        self.show_passes([])

    def _curves(self) -> list[tuple[str, str, list[float]]]:
        """(legend caption, colour, values) of each curve with a finite value."""
        curves = []
        for key, label, colour in CURVES:
            values = [row.get(key, math.nan) for row in self.rows]
            finite = [v for v in values if math.isfinite(v)]
            if finite:
                curves.append((f"{label} {finite[-1]:.3g}", colour, values))
        return curves

    def plot_rects(self) -> PlotLayout:
        """Where the data, the pass axis and the legend go at the widget's width."""
        passes = [row["pass"] for row in self.rows] or [1]
        axis = (str(min(passes)), "pass", str(max(passes)))
        captions = [caption for caption, _, _ in self._curves()]
        return plot_layout(self.width(), self.fontMetrics(), axis, captions)

    def paintEvent(self, _event) -> None:  # noqa: N802 - Qt's name
        if not self.rows:
            return
        rects = self.plot_rects()
        frame = rects.data
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        text = self.palette().windowText().color()
        painter.setPen(QPen(text, 1))
        painter.drawRect(frame)
        passes = [row["pass"] for row in self.rows]
        first, span = min(passes), max(1, max(passes) - min(passes))

        def x_of(p: float) -> float:  # inset: the first and last dots clear the frame
            return frame.left() + INSET + (frame.width() - 2 * INSET) * (p - first) / span

        for p in passes:  # a tick under each pass
            bottom = frame.bottom()
            painter.drawLine(QPointF(x_of(p), bottom), QPointF(x_of(p), bottom - 3))
        for rect, flags, caption in rects.axis:
            painter.drawText(rect, flags, caption)
        for (caption, colour, values), (rect, shown) in zip(self._curves(), rects.legend):
            finite = [v for v in values if math.isfinite(v)]
            low, high = min(0.0, *finite), max(finite)
            high += 0.1 * (high - low)  # headroom above the highest point
            scale = (high - low) or 1.0
            height = frame.height() - INSET
            points = [
                QPointF(x_of(p), frame.bottom() - INSET - height * (v - low) / scale)
                for p, v in zip(passes, values)
                if math.isfinite(v)
            ]
            pen = QPen(QColor(colour), 2)
            painter.setPen(pen)
            for a, b in zip(points, points[1:]):
                painter.drawLine(a, b)
            for point in points:
                painter.drawEllipse(point, 2.5, 2.5)
            middle = rect.center().y()
            painter.drawLine(
                QPointF(rect.left() - SWATCH + 1, middle), QPointF(rect.left() - 4, middle)
            )
            painter.setPen(QPen(text, 1))
            painter.drawText(rect, int(Qt.AlignmentFlag.AlignLeft), shown)
        painter.end()
