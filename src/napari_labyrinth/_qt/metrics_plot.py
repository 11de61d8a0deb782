"""A small plot of two metrics of a stack against the pass: edge enhancement and cover."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from qtpy.QtCore import QPointF, QRectF, Qt
from qtpy.QtGui import QColor, QPainter, QPen
from qtpy.QtWidgets import QSizePolicy, QWidget

#: The plotted metrics: (key, legend, colour).
CURVES = (
    ("edge_enhancement", "edge enhancement", "#f0a030"),
    ("labyrinth_cover", "labyrinth cover", "#40b0f0"),
)


class MetricsPlot(QWidget):
    """The plotted metrics after pass 1, 2, …, each on its own 0-to-max scale."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[Mapping[str, float]] = []
        self.setMinimumHeight(110)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
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
        self.update()

    def clear(self) -> None:
        """Forget the plotted run and hide the plot."""
        self.show_passes([])

    def paintEvent(self, _event) -> None:  # noqa: N802 - Qt's name
        if not self.rows:
            return
        painter = QPainter(self)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        text = self.palette().windowText().color()
        frame = QRectF(8, 6, self.width() - 16, self.height() - 30)
        painter.setPen(QPen(text, 1))
        painter.drawRect(frame)
        passes = [row["pass"] for row in self.rows]
        span = max(1, max(passes) - min(passes))
        legend_x = frame.left()
        for key, label, colour in CURVES:
            values = [row.get(key, math.nan) for row in self.rows]
            finite = [v for v in values if math.isfinite(v)]
            if not finite:
                continue
            low, high = min(0.0, *finite), max(finite)
            high += 0.1 * (high - low)  # headroom above the highest point
            scale = (high - low) or 1.0
            points = [
                QPointF(
                    frame.left() + frame.width() * (p - min(passes)) / span,
                    frame.bottom() - frame.height() * (v - low) / scale,
                )
                for p, v in zip(passes, values)
                if math.isfinite(v)
            ]
            painter.setPen(QPen(QColor(colour), 2))
            for a, b in zip(points, points[1:]):
                painter.drawLine(a, b)
            for point in points:
                painter.drawEllipse(point, 2.5, 2.5)
            caption = f"{label} {finite[-1]:.3g}"
            painter.drawText(QPointF(legend_x, self.height() - 8), caption)
            legend_x += painter.fontMetrics().horizontalAdvance(caption) + 14
        painter.setPen(QPen(text, 1))
        painter.drawText(
            QRectF(frame.right() - 60, frame.top(), 56, 16),
            int(Qt.AlignmentFlag.AlignRight),
            f"pass {min(passes)}–{max(passes)}",
        )
        painter.end()
