"""Each preset draws its pattern (measured with the metrics, with margins)."""

import numpy as np
import pytest
from skimage import color, data, util

from napari_labyrinth import labyrinth, labyrinth_stack, metrics, samples


def _gray(image):
    return util.img_as_ubyte(color.rgb2gray(image))


IMAGES = {
    "portrait": lambda: _gray(data.astronaut())[20:148, 150:278],
    "landscape": lambda: _gray(data.rocket())[150:278, 100:228],
    "microscopy": lambda: _gray(data.immunohistochemistry())[150:278, 150:278],
    "liquid-crystal": lambda: util.img_as_ubyte(samples.nematic_schlieren((128, 128), seed=0)),
}


@pytest.fixture(scope="module", params=sorted(IMAGES))
def case(request):
    return request.param, IMAGES[request.param]()


@pytest.fixture(scope="module")
def image(case):
    return case[1]


def test_labyrinth_preset_draws_walls_that_the_literal_reading_does_not(case):
    name, image = case
    literal = labyrinth(image, preset="paper", passes=4)
    tiled = labyrinth(image, preset="labyrinth")
    literal_cover = metrics.labyrinth_cover(literal)
    tiled_cover = metrics.labyrinth_cover(tiled)
    assert tiled_cover > 1.5 * literal_cover + 0.01
    # the walls follow the contours: the texture is added on the input's edges
    # (tissue is textured all over, and so are its walls: a weaker relation)
    assert metrics.edge_enhancement(image, tiled) > (0.02 if name == "microscopy" else 0.1)
    assert metrics.edge_enhancement(image, literal) < 0


def test_the_labyrinth_needs_its_window_of_variance_threshold(image):
    # far below the window the walls flood the image, far above they vanish; the noise gate
    # (off here) leaves alone the flat pixels whatever the window, and would cap the flood
    flooded = labyrinth(image, variance_threshold=0.005, noise_gate=0)
    vanished = labyrinth(image, variance_threshold=0.5, noise_gate=0)
    tiled = labyrinth(image, noise_gate=0)
    assert np.mean(flooded != image) > np.mean(tiled != image) + 0.1
    assert metrics.edge_enhancement(image, flooded) < metrics.edge_enhancement(image, tiled)
    assert metrics.labyrinth_cover(vanished) < metrics.labyrinth_cover(tiled)


def test_the_literal_reading_stays_literal(image):
    out, diagnostics = labyrinth(image, preset="paper", return_diagnostics=True)
    assert diagnostics["pushed"].sum() == 0
    assert np.mean(out != image) < 0.2
    # it smooths: less fine-scale energy than the input
    assert metrics.texture_added(image, out) < 1.0


def test_labyrinth_walls_stay_on_the_edges_pass_after_pass(image):
    stack = labyrinth_stack(image, passes=8)
    for k in (1, 4, 8):
        assert metrics.edge_enhancement(image, stack[k]) > 0.2, k


def test_near_black_tones_stay_in_their_own_range_in_the_labyrinth_preset():
    dark = samples.smectic_batonnets((96, 96), seed=1)
    out = labyrinth(dark, seed=2)
    below = dark < 10  # under the paper's L_inf^1: the black range [0, 10]
    changed = out != dark
    assert (changed & below).any()
    assert (out[changed & below] <= 10).all()
    # the paper's ranges push the same pixels up into the first range
    paper_ranges = labyrinth(dark, seed=2, tone_ranges=3)
    assert (paper_ranges[below & (paper_ranges != dark)] >= 10).all()


def test_the_black_range_adds_edge_enhancement_on_a_dark_field_image():
    dark = samples.smectic_batonnets((128, 128), seed=0)
    with_black = metrics.edge_enhancement(dark, labyrinth(dark, noise_gate=0))
    without = metrics.edge_enhancement(dark, labyrinth(dark, tone_ranges=3, noise_gate=0))
    assert with_black > without + 0.03
