"""The distributions: the root napari.yaml is the manifest npe2 reads, installed editable or
from a wheel; the sdist and the wheel carry the license and the citation; the metadata states
the license as an SPDX expression."""

import email.message
import email.parser
import os
import subprocess
import sys
import tarfile
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


@pytest.mark.subprocess
def test_npe2_validates_the_installed_plugin():
    result = subprocess.run(
        NPE2 + ["validate", "napari-labyrinth"], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "valid" in result.stdout


@pytest.mark.subprocess
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


@pytest.fixture(scope="module")
def distributions(tmp_path_factory):
    """The sdist, and the wheel built from it, as an index gets them (``python -m build``)."""
    if not (ROOT / "pyproject.toml").exists():
        pytest.skip("needs the source tree")
    pytest.importorskip("build")
    out = tmp_path_factory.mktemp("dist")
    build = subprocess.run(
        [sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stdout + build.stderr
    (sdist,) = out.glob("napari_labyrinth-*.tar.gz")
    (wheel,) = out.glob("napari_labyrinth-*.whl")
    return sdist, wheel


def _wheel_files(wheel: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(wheel) as archive:
        return {name: archive.read(name) for name in archive.namelist()}


def _sdist_files(sdist: Path) -> dict[str, bytes]:
    with tarfile.open(sdist) as archive:
        return {
            member.name.split("/", 1)[1]: archive.extractfile(member).read()
            for member in archive.getmembers()
            if member.isfile()
        }


def _metadata(text: str) -> email.message.Message:
    return email.parser.Parser().parsestr(text)


@pytest.mark.subprocess
def test_distributions_carry_the_license_and_the_citation(distributions):
    sdist, wheel = distributions
    license_text = (ROOT / "LICENSE").read_bytes()
    citation = (ROOT / "CITATION.cff").read_bytes()
    assert b"BSD 3-Clause License" in license_text
    assert b"napari-labyrinth developers" in license_text

    in_sdist = _sdist_files(sdist)
    assert in_sdist["LICENSE"] == license_text
    assert in_sdist["CITATION.cff"] == citation

    in_wheel = _wheel_files(wheel)
    dist_info = f"{wheel.name.split('-py3')[0]}.dist-info"
    assert in_wheel[f"{dist_info}/licenses/LICENSE"] == license_text
    assert in_wheel[f"{dist_info}/extra_metadata/CITATION.cff"] == citation


@pytest.mark.subprocess
def test_metadata_states_the_license_as_an_spdx_expression(distributions):
    sdist, wheel = distributions
    in_wheel = _wheel_files(wheel)
    (metadata_name,) = [n for n in in_wheel if n.endswith(".dist-info/METADATA")]
    for text in (in_wheel[metadata_name].decode(), _sdist_files(sdist)["PKG-INFO"].decode()):
        metadata = _metadata(text)
        assert tuple(map(int, metadata["Metadata-Version"].split("."))) >= (2, 4)
        assert metadata["License-Expression"] == "BSD-3-Clause"
        assert metadata.get_all("License-File") == ["LICENSE"]
        # PEP 639: no License field and no License :: classifier beside an expression.
        assert metadata["License"] is None
        classifiers = metadata.get_all("Classifier")
        assert not [c for c in classifiers if c.startswith("License ::")]
        assert "Framework :: napari" in classifiers


def test_citation_cites_the_package_and_the_paper():
    citation = (ROOT / "CITATION.cff").read_text()
    assert citation.startswith("cff-version: 1.2.0\n")
    assert "title: Non-photorealistic image rendering with a labyrinthine tiling" in citation
    for name in ("family-names: Sparavigna", "family-names: Montrucchio"):
        assert name in citation
    assert "license: BSD-3-Clause" in citation
