"""The documentation site builds, warnings as errors, so that it cannot rot.

``make docs`` builds it and runs the gallery's examples (minutes on two cores); this test
builds a copy of ``docs/`` with the gallery's pages made but not run (``plot_gallery=0``):
every page, the API reference (autosummary, numpydoc) and every cross-reference are checked.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import napari_labyrinth

for _module in ("sphinx", "myst_parser", "numpydoc", "sphinx_gallery", "pydata_sphinx_theme"):
    pytest.importorskip(_module, reason="the docs extra is not installed")

DOCS = Path(__file__).resolve().parents[1] / "docs"
#: What a build writes into its source directory, and its output: not copied.
GENERATED = ("_build", "auto_examples", "generated", "sg_execution_times.rst")


@pytest.mark.subprocess
@pytest.mark.slow
def test_the_site_builds_without_warnings(tmp_path):
    source = tmp_path / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns(*GENERATED))
    package_root = Path(napari_labyrinth.__file__).resolve().parents[1]
    env = dict(os.environ, NAPARI_LABYRINTH_NO_WARMUP="1", MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(package_root), env.get("PYTHONPATH")]))
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "-D", "plot_gallery=0", str(source), str(tmp_path / "html")],
        capture_output=True, text=True, env=env, timeout=600, check=False,
    )  # fmt: skip
    assert build.returncode == 0, build.stderr[-4000:]
    html = tmp_path / "html"
    for page in ("index", "python", "cli", "api/index", "auto_examples/index"):
        assert (html / f"{page}.html").is_file(), page
    reference = (html / "api/generated/napari_labyrinth.labyrinth.html").read_text()
    assert "variance_threshold" in reference  # the numpydoc Parameters section
