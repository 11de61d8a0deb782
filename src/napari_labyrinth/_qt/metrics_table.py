"""The per-pass metrics of a stack run: one row per metric, one column per pass."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from qtpy.QtCore import Qt
from qtpy.QtWidgets import (
    QAbstractItemView,
    QHeaderView,
    QLabel,
    QSizePolicy,
    QTableWidget,
    QTableWidgetItem,
)

from ..widget.text import metric_cells, metric_row_headers
from .plot_layout import compact_font


class MetricsTable(QTableWidget):
    """A read-only table of the metrics after every pass, hidden until a stack run fills it.

    The table is as tall as its rows (the dock scrolls, not the table) and
    fits the dock's width: its font is compact, and when the passes do not
    fit beside the row headers the headers wrap onto two lines; only beyond
    that a horizontal scrollbar appears, and the table grows by its height.

    Attributes
    ----------
    title : QLabel
        The table's title, shown with it.
    """

    def __init__(self) -> None:
        self._headers = metric_row_headers()
        super().__init__(len(self._headers), 0)
        self.title = QLabel("Metrics after pass 1, 2, … (plane on screen)")
        font = compact_font(self.font())
        self.setFont(font)
        for header in (self.horizontalHeader(), self.verticalHeader()):
            header.setFont(font)
            header.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.wrap_row_headers(wrapped=False)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setVerticalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.setSizeAdjustPolicy(QAbstractItemView.SizeAdjustPolicy.AdjustIgnored)
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self.title.setWordWrap(True)
        self.title.setVisible(False)
        self.setVisible(False)

    def wrap_row_headers(self, wrapped: bool) -> None:
        """Row headers on one line, or the long ones split at their first space."""
        metrics = self.verticalHeader().fontMetrics()
        texts = [header for header, _ in self._headers]
        if wrapped:
            split = [header.replace(" ", "\n", 1) for header in texts]
            widest = max(
                metrics.horizontalAdvance(line) for text in split for line in text.split("\n")
            )
            texts = [
                two if metrics.horizontalAdvance(one) > widest else one
                for one, two in zip(texts, split)
            ]
        for row, (text, (_, tooltip)) in enumerate(zip(texts, self._headers)):
            item = self.verticalHeaderItem(row)
            if item is None:
                item = QTableWidgetItem()
                self.setVerticalHeaderItem(row, item)
            item.setText(text)
            item.setToolTip(tooltip)

    def clear_passes(self) -> None:
        """Empty and hide the table (another mode, input or plane is on screen)."""
        self.setColumnCount(0)
        self.title.setVisible(False)
        self.setVisible(False)

    def show_passes(self, passes: Sequence[Mapping[str, float]]) -> None:
        """Fill the table from the metric rows of a run (one dict per pass) and show it."""
        headers, cells = metric_cells(passes)
        self.setColumnCount(len(headers))
        self.setHorizontalHeaderLabels(headers)
        for row, texts in enumerate(cells):
            for column, text in enumerate(texts):
                item = QTableWidgetItem(text)
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                self.setItem(row, column, item)
        self.title.setVisible(True)
        self.setVisible(True)
        self.fit()

    def content_width(self) -> int:
        """Width the row headers and every column need, frame included."""
        self.resizeColumnsToContents()
        columns = sum(self.columnWidth(column) for column in range(self.columnCount()))
        return self.verticalHeader().sizeHint().width() + columns + 2 * self.frameWidth()

    def needs_scrollbar(self) -> bool:
        """Whether the passes are wider than the table even with wrapped row headers."""
        return self.content_width() > self.width()

    def fit(self) -> bool:
        """Wrap the row headers if the passes need the room, and take the rows' height.

        Returns
        -------
        bool
            Whether the height changed.
        """
        if self.columnCount() == 0:
            return False
        self.wrap_row_headers(wrapped=False)
        if self.content_width() > self.width():
            self.wrap_row_headers(wrapped=True)
        self.resizeRowsToContents()
        height = self.horizontalHeader().sizeHint().height() + 2 * self.frameWidth()
        height += sum(self.rowHeight(row) for row in range(self.rowCount()))
        if self.needs_scrollbar():
            height += self.horizontalScrollBar().sizeHint().height()
        if height == self.height():
            return False
        self.setFixedHeight(height)
        return True

    def resizeEvent(self, event) -> None:  # noqa: N802 - Qt's name
        super().resizeEvent(event)
        if event.size().width() != event.oldSize().width():
            self.fit()
