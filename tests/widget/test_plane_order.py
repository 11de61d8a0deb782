"""The order in which a lazy result's planes render: where the user looks first."""

from __future__ import annotations

import threading

import pytest

from napari_labyrinth.widget.plane_order import PlaneOrder


def taken(order: PlaneOrder, count: int | None = None) -> list[tuple[int, ...]]:
    """Take ``count`` planes (all, without), each marked rendered."""
    planes = []
    while count is None or len(planes) < count:
        index = order.take()
        if index is None:
            break
        order.finish(index)
        planes.append(index)
    return planes


def test_the_plane_on_screen_first_then_its_neighbours_outward():
    order = PlaneOrder((7,), (3,))
    assert taken(order) == [(3,), (4,), (2,), (5,), (1,), (6,), (0,)]
    assert order.done_count == order.total == 7


def test_a_plane_already_rendered_is_not_handed_out():
    order = PlaneOrder((5,), (2,), done=[(2,)])
    assert taken(order) == [(3,), (1,), (4,), (0,)]


def test_a_move_reprioritises_and_the_way_moved_comes_first():
    order = PlaneOrder((10,), (0,))
    assert taken(order, 2) == [(0,), (1,)]
    order.move_focus((6,))
    assert taken(order, 3) == [(6,), (7,), (5,)]
    order.move_focus((3,))  # moved back: the planes behind come before those ahead
    assert taken(order, 3) == [(3,), (2,), (4,)]
    assert sorted(taken(order)) == [(8,), (9,)]


def test_no_plane_is_handed_out_twice_even_when_moves_come_between():
    order = PlaneOrder((6,), (0,))
    first = order.take()  # being rendered
    order.move_focus((0,))
    order.move_focus((1,))
    rest = taken(order)
    assert first == (0,) and first not in rest
    order.finish(first)
    assert sorted([first, *rest]) == [(i,) for i in range(6)]


def test_a_plane_given_back_is_handed_out_again():
    order = PlaneOrder((3,), (1,))
    assert order.take() == (1,)
    order.give_back((1,))
    assert order.take() == (1,)


def test_cancel_stops_handing_out_planes():
    order = PlaneOrder((8,), (4,))
    assert taken(order, 2) == [(4,), (5,)]
    order.cancel()
    assert order.take() is None
    assert order.cancelled and order.done_count == 2


def test_planes_of_several_leading_axes_by_their_distance():
    order = PlaneOrder((3, 4), (1, 1))
    planes = taken(order)
    assert planes[0] == (1, 1)
    assert set(planes[1:5]) == {(0, 1), (2, 1), (1, 0), (1, 2)}
    assert len(planes) == len(set(planes)) == 12


def test_a_focus_outside_the_planes_is_refused():
    with pytest.raises(ValueError, match="outside planes of shape"):
        PlaneOrder((4,), (4,))


def test_threads_taking_planes_while_the_focus_moves_render_each_once():
    order = PlaneOrder((200,), (0,))
    rendered: list[tuple[int, ...]] = []
    lock = threading.Lock()

    def render():
        while (index := order.take()) is not None:
            with lock:
                rendered.append(index)
            order.finish(index)

    threads = [threading.Thread(target=render) for _ in range(3)]
    for thread in threads:
        thread.start()
    for step in range(0, 200, 7):
        order.move_focus((step,))
    for thread in threads:
        thread.join()
    assert sorted(rendered) == [(i,) for i in range(200)]
