"""The criterion of Auto V on hand-made curves (window_criterion.choose: no rendering)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from napari_labyrinth.window import window_of
from napari_labyrinth.window_criterion import (
    ALIGNED,
    COVER_FRACTION,
    MIN_CHANGED,
    Choice,
    choose,
)

NAN = math.nan


def test_a_v_that_draws_nothing_is_never_chosen_when_another_draws_walls():
    # the best edge score where almost nothing changes (a smooth noisy texture: the few
    # pixels that change sit on edges), walls at the low V
    edges = [0.26, 0.29, 0.32, 0.28, 0.34, 0.36]
    cover = [0.13, 0.14, 0.12, 0.07, 0.006, 0.001]
    alignment = [0.70, 0.72, 0.79, 0.76, NAN, NAN]
    changed = [0.81, 0.70, 0.50, 0.29, 0.12, 0.008]
    choice = choose(edges, cover, alignment, changed)
    assert choice.best == 1  # the best edges of the V covering >= 90 % of the best cover
    assert cover[choice.best] >= COVER_FRACTION * max(cover)
    assert choice.reason == "cover 0.14, aligned 0.72"
    assert choice.found and choice.low <= choice.best <= choice.high
    # the edge score alone took the V of 0.1 % cover
    assert window_of(range(6), edges, default=0)[1] == 5


def test_a_v_that_changes_under_one_percent_does_not_draw_walls():
    # cover above 1 % that the rendering did not draw (it changed 0.5 % of the pixels)
    choice = choose([0.1, 0.6], [0.05, 0.08], [0.9, 0.9], [0.3, MIN_CHANGED / 2])
    assert choice.best == 0


def test_the_cover_rule_takes_the_best_edges_among_the_v_covering_enough():
    edges = [0.40, 0.50, 0.60, 0.62]
    cover = [0.20, 0.185, 0.17, 0.10]  # 0.17 is 85 % of 0.20: below the cut
    choice = choose(edges, cover, [0.9] * 4, [0.9, 0.7, 0.5, 0.3])
    assert choice.best == 1
    assert choose(edges, cover, [0.9] * 4, [0.9, 0.7, 0.5, 0.3], cover_fraction=0.8).best == 2
    # the window: the run of candidates around it whose edges reach 90 % of the chosen's
    assert (choice.low, choice.high) == (1, 1)
    wide = choose([0.40, 0.56, 0.60, 0.58], [0.2] * 4, [0.9] * 4, [0.5] * 4)
    assert (wide.low, wide.best, wide.high) == (1, 2, 3)


def test_walls_across_the_contours_do_not_set_the_cover_to_reach():
    # the most covering V draws walls unrelated to the contours (alignment 0.5)
    edges = [0.2, 0.5, 0.6]
    cover = [0.40, 0.12, 0.11]
    alignment = [0.5, 0.9, 0.9]
    choice = choose(edges, cover, alignment, [0.9, 0.5, 0.4])
    assert choice.best == 2 and cover[2] >= COVER_FRACTION * 0.12
    assert choice.reason == "cover 0.11, aligned 0.90"
    assert ALIGNED > 0.5  # walls unrelated to the contours are not aligned


def test_walls_along_no_contour_are_still_preferred_to_none():
    choice = choose([0.6, 0.3, 0.1], [0.003, 0.05, 0.04], [NAN, 0.55, 0.5], [0.2, 0.5, 0.6])
    assert choice.best == 1
    assert choice.reason == "cover 0.05, aligned 0.55: no V draws walls along the contours"


def test_ties_go_to_the_larger_cover_then_to_the_lower_v():
    aligned, changed = [0.9] * 3, [0.5] * 3
    assert choose([0.5, 0.5, 0.5], [0.10, 0.11, 0.11], aligned, changed).best == 1
    assert choose([0.5, 0.5, 0.5], [0.11, 0.11, 0.11], aligned, changed).best == 0
    assert choose([0.4, 0.5, 0.5], [0.11, 0.11, 0.11], aligned, changed).best == 1


def test_walls_the_input_has_already_are_not_the_labyrinth_s():
    # a JPEG's blocks make walls of their own (cover 0.04); the renderings wipe them out
    # at low V and keep them at high V, where they smooth the edges away
    edges = [0.78, 0.77, 0.53, -0.33]
    cover = [0.015, 0.015, 0.014, 0.026]
    alignment = [0.89, 0.90, 0.94, 0.94]
    changed = [0.96, 0.96, 0.87, 0.71]
    assert choose(edges, cover, alignment, changed).best == 3  # taken for the labyrinth's
    choice = choose(edges, cover, alignment, changed, input_cover=0.04)
    assert choice.best == 0  # no V draws walls: the edge enhancement decides
    assert choice.reason == "no V draws walls on 1% of the probe; edge enhancement 0.78"


# -- the study's curves (probes of docs/study's images, 256², default preset) -------------------

#: V of the default grid: 0.04 times 2 ** (k / 2), k = -8 .. 6.
STUDY_V = (0.0025, 0.0035, 0.005, 0.0071, 0.01, 0.0141, 0.02, 0.0283, 0.04, 0.0566, 0.08,
           0.1131, 0.16, 0.2263, 0.32)  # fmt: skip

#: Probe curves (edge enhancement, cover, alignment, changed; input cover) of the images
#: whose V the edge enhancement alone chose right: walls under 1 % beyond the input's own,
#: so it still decides.
STUDY_CURVES = {
    "dark-field": (
        (0.778, 0.778, 0.778, 0.777, 0.777, 0.777, 0.776, 0.776, 0.776, 0.776, 0.718, 0.605,
         0.444, 0.210, -0.574),
        (0.007,) * 10 + (0.006, 0.009, 0.007, 0.008, 0.010),
        (NAN,) * 15,
        (0.940,) * 8 + (0.939, 0.937, 0.920, 0.900, 0.886, 0.843, 0.802),
        0.003,
        0.0025,
    ),
    "fluorescence-16bit": (
        (0.759, 0.759, 0.759, 0.759, 0.759, 0.758, 0.758, 0.757, 0.749, 0.737, 0.687, 0.618,
         0.269, -0.735, -0.755),
        (0.014,) * 8 + (0.015, 0.015, 0.016, 0.015, 0.012, 0.007, 0.007),
        (0.971, 0.970, 0.970, 0.970, 0.970, 0.970, 0.970, 0.971, 0.972, 0.971, 0.957, 0.934,
         0.948, NAN, NAN),
        (0.983,) * 4 + (0.982, 0.981, 0.980, 0.979, 0.974, 0.970, 0.963, 0.950, 0.825, 0.742,
                        0.740),
        0.0065,
        0.0025,
    ),
}  # fmt: skip


@pytest.mark.parametrize("name", list(STUDY_CURVES))
def test_the_study_s_curves_keep_their_v_where_it_was_right(name):
    edges, cover, alignment, changed, input_cover, chosen = STUDY_CURVES[name]
    choice = choose(edges, cover, alignment, changed, input_cover=input_cover)
    assert STUDY_V[choice.best] == chosen
    low, best, high, _ = window_of(STUDY_V, edges, default=NAN)
    assert (STUDY_V[choice.low], STUDY_V[choice.best], STUDY_V[choice.high]) == (low, best, high)


def test_curves_with_neither_walls_nor_edges_find_nothing():
    choice = choose([0.0, -0.1, NAN], [0.0, 0.0, NAN], [NAN] * 3, [0.0, 0.0, NAN])
    assert choice == Choice(0, 0, 0, False, "no V draws the labyrinth on the edges")


def test_the_curves_must_be_of_one_length():
    with pytest.raises(ValueError, match="one length"):
        choose([0.1, 0.2], [0.1], [0.9, 0.9], [0.5, 0.5])
    with pytest.raises(ValueError, match="non-empty"):
        choose([], [], [], [])


def test_choose_is_a_pure_function_of_its_curves():
    curves = ([0.3, 0.5], [0.1, 0.1], [0.8, 0.8], [0.5, 0.4])
    arrays = tuple(np.array(c) for c in curves)
    assert choose(*curves) == choose(*arrays)
    assert [list(a) for a in arrays] == [list(c) for c in curves]
