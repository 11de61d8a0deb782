"""The root napari.yaml is the manifest npe2 reads, installed editable or from a wheel."""

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NPE2 = [sys.executable, "-m", "npe2"]


def test_installed_manifest_is_the_root_file():
    from npe2 import PluginManifest

    manifest = PluginManifest.from_distribution("napari-labyrinth")
    assert manifest.name == "napari-labyrinth"
    import napari_labyrinth

    packaged = Path(napari_labyrinth.__file__).parent / "napari.yaml"
    assert packaged.read_bytes() == (ROOT / "napari.yaml").read_bytes()


def test_npe2_validates_the_installed_plugin():
    result = subprocess.run(
        NPE2 + ["validate", "napari-labyrinth"], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "valid" in result.stdout


@pytest.mark.skipif(not (ROOT / "pyproject.toml").exists(), reason="needs the source tree")
def test_wheel_carries_the_root_manifest_and_validates(tmp_path):
    wheel_dir = tmp_path / "wheel"
    build = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(wheel_dir),
            str(ROOT),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stdout + build.stderr
    (wheel,) = wheel_dir.glob("napari_labyrinth-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        assert archive.read("napari_labyrinth/napari.yaml") == (ROOT / "napari.yaml").read_bytes()
        entry_points = archive.read(
            next(n for n in archive.namelist() if n.endswith("entry_points.txt"))
        ).decode()
    assert "napari-labyrinth = napari_labyrinth:napari.yaml" in entry_points

    target = tmp_path / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--target", str(target), str(wheel)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert install.returncode == 0, install.stdout + install.stderr
    env = dict(os.environ, PYTHONPATH=str(target))
    where = subprocess.run(
        [
            sys.executable,
            "-c",
            "import napari_labyrinth, importlib.metadata as m;"
            "print(napari_labyrinth.__file__);"
            "print(m.distribution('napari-labyrinth').locate_file(''))",
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert where.stdout.startswith(str(target)), where.stdout + where.stderr
    validate = subprocess.run(
        NPE2 + ["validate", "napari-labyrinth"],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert validate.returncode == 0, validate.stdout + validate.stderr
