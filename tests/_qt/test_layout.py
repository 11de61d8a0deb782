"""The dock's layout at napari's default window size, measured rather than looked at."""

from __future__ import annotations

import pytest

pytest.importorskip("napari")
pytest.importorskip("pytestqt")

from hypothesis import given, settings
from hypothesis import strategies as st

from napari_labyrinth._qt.plot_layout import plot_layout

from .helpers import noise, run

#: The window of docs/make_screenshot.py.
WINDOW_SIZE = (1400, 900)


@pytest.fixture
def shown_widget(make_napari_viewer):
    """The widget docked in a shown viewer at the screenshot's size, and the viewer."""
    viewer = make_napari_viewer(show=True)
    viewer.window.resize(*WINDOW_SIZE)
    _, widget = viewer.window.add_plugin_dock_widget("napari-labyrinth", "Labyrinthine tiling")
    return viewer, widget


def _rows(passes):
    values = {
        "edge_enhancement": 0.321,
        "labyrinth_cover": 0.0186,
        "wall_width": 1.28,
        "orientation_coherence": 0.409,
        "contour_alignment": 0.849,
        "texture_added": 1113.0,
        "changed": 8.44,
    }
    return [{"pass": number, **values} for number in range(1, passes + 1)]


@settings(max_examples=60, deadline=None)
@given(
    width=st.integers(120, 900),
    captions=st.lists(st.text("abcdefgh 0123.=()-", min_size=1, max_size=60), max_size=3),
    ends=st.tuples(st.text("0123.e-", max_size=6), st.text("0123.e-", max_size=6)),
)
def test_plot_texts_are_clear_of_the_data_and_inside_the_width(qapp, width, captions, ends):
    from qtpy.QtGui import QFontMetrics
    from qtpy.QtWidgets import QWidget

    metrics = QFontMetrics(QWidget().font())
    layout = plot_layout(width, metrics, (ends[0], "pass", ends[1]), captions)
    texts = layout.texts()
    assert len(layout.legend) == len(captions)
    for rect in texts:
        assert not rect.intersects(layout.data)
        assert rect.left() >= 0 and rect.right() <= width
        assert rect.bottom() <= layout.height
    legend = [rect for rect, _ in layout.legend]
    for i, a in enumerate(legend):
        assert not any(a.intersects(b) for b in legend[i + 1 :])


def test_the_metrics_of_a_stack_fit_the_dock_and_come_into_view(qtbot, shown_widget):
    viewer, widget = shown_widget
    viewer.add_image(noise((64, 64)), name="cell")
    widget.mode.value = "stack"
    widget.fields["passes"].value = 4
    run(qtbot, widget)
    table, plot = widget.metrics_table, widget.metrics_plot
    assert table.columnCount() == 4
    assert not table.needs_scrollbar()  # four passes fit beside the row headers
    qtbot.waitUntil(lambda: not table.horizontalScrollBar().isVisible())
    viewport = widget.scroll_area.viewport()

    def plot_in_view():
        top = plot.mapTo(viewport, plot.rect().topLeft()).y()
        return top >= 0 and top + plot.height() <= viewport.height()

    qtbot.waitUntil(plot_in_view)
    rects = plot.plot_rects()
    assert plot.height() >= rects.height
    assert not any(rect.intersects(rects.data) for rect in rects.texts())
    assert all(rect.right() <= plot.width() for rect in rects.texts())


def test_more_passes_wrap_the_row_headers_then_scroll_without_hiding_a_row(qtbot, shown_widget):
    _, widget = shown_widget
    table = widget.metrics_table
    table.show_passes(_rows(4))
    qtbot.waitUntil(lambda: table.isVisible() and table.width() > 0)
    seen = set()
    for passes in range(4, 13):
        table.show_passes(_rows(passes))
        wrapped = "\n" in table.verticalHeaderItem(0).text()
        scrolls = table.needs_scrollbar()
        seen.add((wrapped, scrolls))
        assert table.verticalHeaderItem(6).text() == "changed %"  # short headers: one line
        if scrolls:
            assert wrapped  # a scrollbar only once wrapping is not enough
            rows = sum(table.rowHeight(row) for row in range(table.rowCount()))
            qtbot.waitUntil(lambda: table.horizontalScrollBar().isVisible())
            assert table.viewport().height() >= rows  # the scrollbar takes no row's room
        if wrapped:  # wrapped only when the passes do not fit beside one-line headers
            table.wrap_row_headers(wrapped=False)
            assert table.content_width() > table.width()
            table.fit()
    assert (False, False) in seen and (True, True) in seen  # 4 passes fit, 12 scroll


def test_no_row_label_of_the_form_is_cut(qtbot, shown_widget):
    from qtpy.QtWidgets import QLabel

    _, widget = shown_widget
    qtbot.waitUntil(lambda: widget.form.parameter_box.native.isVisible())
    boxes = (widget.inputs.box, widget.form.parameter_box)
    labels = [
        label
        for box in boxes
        for label in box.native.findChildren(QLabel)
        if label.text() and label.isVisible() and label is not widget.edited.native
    ]
    assert any(label.text() == "variance threshold V" for label in labels)
    for label in labels:
        assert label.width() >= label.sizeHint().width(), label.text()
