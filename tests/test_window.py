"""find_window: the window of V measured on a probe, and variance_threshold="auto"."""

from __future__ import annotations

import numpy as np
import pytest

from napari_labyrinth import find_window, labyrinth, labyrinth_stack, metrics, samples
from napari_labyrinth.cli import main
from napari_labyrinth.core.parameters import AUTO, PARAMETERS, without_auto
from napari_labyrinth.core.presets import resolve_parameters
from napari_labyrinth.core.tone_scale import resolve_tone_scale
from napari_labyrinth.io import read_image, write_image
from napari_labyrinth.window import window_of


def small_images(size=192):
    """Images like the study's, small: a photograph, a texture, dark, 16-bit, bright."""
    from skimage import data

    return {
        "camera": np.ascontiguousarray(data.camera()[100 : 100 + size, 150 : 150 + size]),
        "schlieren": np.rint(samples.nematic_schlieren((size, size)) * 255).astype(np.uint8),
        "dark-field": samples.smectic_batonnets((size, size)),
        "fluorescence-16bit": samples.fluorescence_stack((size, size), planes=1)[0],
    }


def full_window(image, thresholds):
    """The window read from the whole image rendered at every V (the study's sweep)."""
    scale = resolve_tone_scale(image, None)
    before = scale.to_tones(image)
    curve = [
        metrics.edge_enhancement(before, scale.to_tones(labyrinth(image, variance_threshold=v)))
        for v in thresholds
    ]
    return window_of(thresholds, curve, default=np.nan)


def test_window_of_a_hand_made_curve():
    thresholds = [0.01, 0.02, 0.04, 0.08, 0.16]
    assert window_of(thresholds, [0.1, 0.5, 0.6, 0.55, 0.58], default=0) == (
        0.04,
        0.04,
        0.16,
        True,
    )
    # a value at 90 % beyond a dip does not join the window
    assert window_of(thresholds, [0.55, 0.2, 0.6, 0.1, 0.58], default=0)[::2] == (0.04, 0.04)
    assert window_of(thresholds, [-0.1, 0.0, np.nan, -0.3, 0.0], default=0.5) == (
        0.5,
        0.5,
        0.5,
        False,
    )


def test_find_window_is_deterministic_for_a_seed():
    image = small_images()["dark-field"]
    first = find_window(image, seed=3, crops=3, crop_size=64)
    assert find_window(image, seed=3, crops=3, crop_size=64, workers=1) == first
    assert first.low <= first.best <= first.high
    assert first.best in first.thresholds
    assert len(first.crops) == 3 and first.crop_size == 64
    assert len(first.edge_enhancement) == len(first.thresholds) == len(first.changed)


@pytest.mark.parametrize("name", list(small_images(32)))
def test_the_chosen_v_lies_inside_the_window_of_the_whole_image(name):
    image = small_images()[name]
    window = find_window(image, crops=4, crop_size=64)  # a third of the image
    low, _, high, found = full_window(image, window.thresholds)
    assert window.found and found
    assert low <= window.best <= high, (window.summary(), low, high)


def test_a_stack_gets_one_v_from_a_sample_of_its_planes():
    stack = samples.fluorescence_stack((96, 96), planes=6)
    window = find_window(stack, crops=4, crop_size=48, max_planes=3)
    assert {plane for plane, _, _ in window.crops} <= {0, 1, 2}
    assert window.found


def test_find_window_names_bad_arguments():
    image = np.zeros((32, 32), np.uint8)
    with pytest.raises(TypeError, match="variance_threshold"):
        find_window(image, variance_threshold=0.1)
    with pytest.raises(ValueError, match="crops"):
        find_window(image, crops=0)
    with pytest.raises(ValueError, match="thresholds"):
        find_window(image, thresholds=[0.2, 0.1])
    with pytest.raises(ValueError, match="passes"):
        find_window(image, passes=-1)


def test_auto_in_the_api_renders_with_the_chosen_v():
    image = small_images(96)["camera"]
    chosen = find_window(image).best
    np.testing.assert_array_equal(
        labyrinth(image, variance_threshold=AUTO), labyrinth(image, variance_threshold=chosen)
    )
    np.testing.assert_array_equal(
        labyrinth_stack(image, passes=2, variance_threshold=AUTO),
        labyrinth_stack(image, passes=2, variance_threshold=find_window(image, passes=2).best),
    )


def test_auto_is_a_value_of_the_table_not_of_a_parameter_set():
    parameter = PARAMETERS["variance_threshold"]
    assert parameter.automatic and parameter.parse(" Auto ") == AUTO
    assert not PARAMETERS["mean_threshold"].automatic
    with pytest.raises(ValueError, match="mean_threshold must be a number; got 'auto'"):
        PARAMETERS["mean_threshold"].parse("auto")
    with pytest.raises(ValueError, match="chosen from the image"):
        resolve_parameters(variance_threshold=AUTO)
    with pytest.raises(TypeError, match="variance_threshold must be a real number or 'auto'"):
        labyrinth(np.zeros((8, 8), np.uint8), variance_threshold="automatic")
    assert without_auto({"variance_threshold": AUTO, "passes": 2}) == {"passes": 2}


def test_the_cli_prints_the_v_it_chose_and_renders_with_it(tmp_path, capsys):
    image = small_images(96)["fluorescence-16bit"]
    source, target = tmp_path / "cells.tif", tmp_path / "out.tif"
    write_image(source, image)
    assert main(["render", str(source), "-o", str(target), "--variance-threshold", "auto"]) == 0
    window = find_window(image)
    assert f"variance threshold auto: {window.summary()}" in capsys.readouterr().err
    expected = labyrinth(image, variance_threshold=window.best)
    np.testing.assert_array_equal(read_image(target), expected)
    assert main(["reproduce", str(target)]) == 0  # the record holds the chosen V
    assert main(["render", str(source), "-o", str(tmp_path / "set.tif"), "--set",
                 "variance_threshold=auto"]) == 0  # fmt: skip
    np.testing.assert_array_equal(read_image(tmp_path / "set.tif"), expected)
