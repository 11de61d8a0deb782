"""Where a small plot of the dock puts its data, its axis and its legend, none over another.

The data rectangle takes the width of the widget; under it one line of axis
text (the first and last x value at the ends, the axis name in the middle),
and under that the legend, its captions flowing onto as many lines as the
width needs (a caption wider than the widget is elided). The widget's height
follows from the lines, so nothing is cut at any dock width.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from qtpy.QtCore import QRectF, Qt
from qtpy.QtGui import QFont, QFontMetrics
from qtpy.QtWidgets import QWidget

#: Size of the font of the metrics displays against the dock's: with it four passes of the
#: metrics table fit beside its row headers at napari's default dock width.
COMPACT_FONT = 0.9
#: Space around the data rectangle and between the lines of text, in pixels.
MARGIN = 8
GAP = 3
#: Pixels between the data rectangle's sides and the data, so that no dot sits on its border.
INSET = 5
#: Room left of a legend caption for its colour swatch, and between two captions.
SWATCH = 14
SPACING = 12
#: Height of the data rectangle.
DATA_HEIGHT = 72


def compact_font(font: QFont) -> QFont:
    """A copy of ``font`` at the compact size of the metrics displays."""
    font = QFont(font)
    font.setPointSizeF(font.pointSizeF() * COMPACT_FONT)
    return font


@dataclasses.dataclass(frozen=True)
class PlotLayout:
    """The rectangles of a plot, in widget coordinates.

    Attributes
    ----------
    data : QRectF
        Where the curves go.
    axis : list of (QRectF, int, str)
        Axis texts under the data: rectangle, Qt alignment flags, text.
    legend : list of (QRectF, str)
        One rectangle per legend caption (its swatch at the left of it).
    height : int
        The height the widget needs.
    """

    data: QRectF
    axis: list[tuple[QRectF, int, str]]
    legend: list[tuple[QRectF, str]]
    height: int

    def texts(self) -> list[QRectF]:
        """Every rectangle that holds text."""
        return [rect for rect, _, _ in self.axis] + [rect for rect, _ in self.legend]


def plot_layout(
    width: int,
    metrics: QFontMetrics,
    axis: tuple[str, str, str],
    legend: Sequence[str],
    data_height: int = DATA_HEIGHT,
) -> PlotLayout:
    """Lay out a plot ``width`` pixels wide.

    Parameters
    ----------
    width : int
        The widget's width.
    metrics : QFontMetrics
        Of the font the texts are drawn in.
    axis : (str, str, str)
        The texts under the data at its left end, middle and right end.
    legend : sequence of str
        Legend captions, in order.
    data_height : int, optional
        Height of the data rectangle.
    """
    line = metrics.height()
    inner = max(1, width - 2 * MARGIN)
    data = QRectF(MARGIN, MARGIN, inner, data_height)
    top = data.bottom() + GAP
    left, middle, right = axis
    align_top = Qt.AlignmentFlag.AlignTop
    axis_rects = []
    ends = max(metrics.horizontalAdvance(left), metrics.horizontalAdvance(right))
    for text, where in (
        (left, Qt.AlignmentFlag.AlignLeft),
        (right, Qt.AlignmentFlag.AlignRight),
    ):
        if text:
            rect = QRectF(data.left(), top, inner, line)
            rect = _aligned(rect, metrics.horizontalAdvance(text), where)
            axis_rects.append((rect, int(where | align_top), text))
    if middle:
        room = inner - 2 * (ends + SPACING)
        text = metrics.elidedText(middle, Qt.TextElideMode.ElideRight, max(0, room))
        if text:
            rect = QRectF(data.left(), top, inner, line)
            rect = _aligned(rect, metrics.horizontalAdvance(text), Qt.AlignmentFlag.AlignHCenter)
            axis_rects.append((rect, int(Qt.AlignmentFlag.AlignHCenter | align_top), text))
    top += line + GAP

    legend_rects = []
    x = data.left()
    for caption in legend:
        text_width = metrics.horizontalAdvance(caption)
        if x > data.left() and x + SWATCH + text_width > data.right():
            x, top = data.left(), top + line + GAP
        room = int(data.right() - x - SWATCH)
        if text_width > room:
            caption = metrics.elidedText(caption, Qt.TextElideMode.ElideRight, room)
            text_width = metrics.horizontalAdvance(caption)
        legend_rects.append((QRectF(x + SWATCH, top, text_width, line), caption))
        x += SWATCH + text_width + SPACING
    if legend_rects:
        top += line
    return PlotLayout(data, axis_rects, legend_rects, int(top + MARGIN / 2 + 0.5))


def _aligned(rect: QRectF, text_width: float, where) -> QRectF:
    """The part of ``rect`` a text ``text_width`` wide takes when aligned ``where``."""
    if where == Qt.AlignmentFlag.AlignRight:
        return QRectF(rect.right() - text_width, rect.top(), text_width, rect.height())
    if where == Qt.AlignmentFlag.AlignHCenter:
        left = rect.center().x() - text_width / 2
        return QRectF(left, rect.top(), text_width, rect.height())
    return QRectF(rect.left(), rect.top(), text_width, rect.height())


class FittedPlot(QWidget):
    """A small plot whose height follows its width: subclasses say where things go."""

    def plot_rects(self) -> PlotLayout:
        """Where the data, the axis and the captions go at the widget's width."""
        raise NotImplementedError

    def has_data(self) -> bool:
        """Whether there is anything to lay out (the height is kept until there is)."""
        return True

    def fit_height(self) -> bool:
        """Take the height the layout needs at the current width; whether it changed."""
        height = self.plot_rects().height
        if height == self.height():
            return False
        self.setFixedHeight(height)
        return True

    def resizeEvent(self, event) -> None:  # noqa: N802 - Qt's name
        super().resizeEvent(event)
        if self.has_data():
            self.fit_height()
