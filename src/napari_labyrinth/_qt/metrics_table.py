"""The per-pass metrics of a stack run: one row per metric, one column per pass."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from qtpy.QtCore import Qt
from qtpy.QtWidgets import QAbstractItemView, QHeaderView, QLabel, QTableWidget, QTableWidgetItem

from ..plan import metric_cells, metric_row_headers


class MetricsTable(QTableWidget):
    """A read-only table of the metrics after every pass, hidden until a stack run fills it.

    Attributes
    ----------
    title : QLabel
        The table's title, shown with it.
    """

    def __init__(self) -> None:
        headers = metric_row_headers()
        super().__init__(len(headers), 0)
        self.title = QLabel("Metrics after pass 1, 2, … (plane on screen)")
        self.setVerticalHeaderLabels([header for header, _ in headers])
        for row, (_, tooltip) in enumerate(headers):
            self.verticalHeaderItem(row).setToolTip(tooltip)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.verticalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.title.setVisible(False)
        self.setVisible(False)

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
        self.resizeColumnsToContents()
        height = self.horizontalHeader().sizeHint().height() + 2 * self.frameWidth()
        height += sum(self.rowHeight(row) for row in range(self.rowCount()))
        if self.horizontalScrollBar().isVisible() or self.columnCount() > 6:
            height += self.horizontalScrollBar().sizeHint().height()
        self.setFixedHeight(height)
