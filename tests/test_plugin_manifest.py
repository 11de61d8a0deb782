"""The napari manifest: what the plugin contributes, and that npe2 accepts it.

These tests need npe2 but no display; the widget itself is tested in
``tests/_qt/``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

npe2 = pytest.importorskip("npe2")

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = "napari-labyrinth"


@pytest.fixture(scope="module")
def manifest():
    return npe2.PluginManifest.from_distribution(PLUGIN)


def test_the_package_manifest_is_a_symlink_to_the_root_file():
    packaged = ROOT / "src" / "napari_labyrinth" / "napari.yaml"
    assert packaged.is_symlink()
    assert packaged.resolve() == (ROOT / "napari.yaml").resolve()


@pytest.mark.subprocess
def test_npe2_validates_the_manifest_and_imports_every_python_name():
    result = subprocess.run(
        [sys.executable, "-m", "npe2", "validate", PLUGIN, "--imports"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "valid" in result.stdout


def test_the_widget_is_offered_in_the_plugins_and_filter_menus(manifest):
    (widget,) = manifest.contributions.widgets
    assert widget.display_name == "Labyrinthine tiling"
    commands = {command.id: command for command in manifest.contributions.commands}
    assert commands[widget.command].python_name == "napari_labyrinth._qt.widget:LabyrinthWidget"
    filter_menu = manifest.contributions.menus["napari/layers/filter"]
    assert [item.command for item in filter_menu] == [
        "napari-labyrinth.show_widget",  # the docked widget if there is one, never a second
        "napari-labyrinth.render_selected_layer",
        "napari-labyrinth.stack_selected_layer",
    ]
    assert all(menu_id.startswith("napari/") for menu_id in manifest.contributions.menus)


def test_samples_include_the_liquid_crystal_textures_and_a_micrograph(manifest):
    keys = [sample.key for sample in manifest.contributions.sample_data]
    assert keys == ["nematic_schlieren", "cholesteric_fingerprint", "cell", "immunohistochemistry"]


@pytest.mark.parametrize(
    "function_name, shape, dtype",
    [
        ("nematic_schlieren_sample", (512, 512), np.float32),
        ("cholesteric_fingerprint_sample", (512, 512), np.float32),
        ("cell_sample", (660, 550), np.uint8),
        ("immunohistochemistry_sample", (512, 512, 3), np.uint8),
    ],
)
def test_sample_functions_return_layer_data_tuples(function_name, shape, dtype):
    from napari_labyrinth import _sample_data

    ((data, kwargs, layer_type),) = getattr(_sample_data, function_name)()
    assert layer_type == "image"
    assert data.shape == shape and data.dtype == dtype
    assert kwargs["name"]
    assert kwargs.get("rgb", False) == (len(shape) == 3)


@pytest.mark.subprocess
def test_sample_data_and_the_library_do_not_import_napari_or_qt():
    code = (
        "import sys, napari_labyrinth, napari_labyrinth._sample_data as s;"
        "s.nematic_schlieren_sample();"
        "print(sorted(m for m in ('napari', 'qtpy', 'PyQt6', 'magicgui') if m in sys.modules))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"
