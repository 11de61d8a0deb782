"""Sphinx configuration of the napari-labyrinth documentation.

Built by ``make docs`` (``python -m sphinx -W --keep-going -b html docs docs/_build/html``):
the pages are Markdown (MyST), the API reference is generated from the numpydoc docstrings
(autosummary), and the gallery runs the scripts of ``docs/examples/`` (sphinx-gallery).
``-D plot_gallery=0`` builds the gallery pages without running them (the test's fast build).
"""

from __future__ import annotations

import os

import napari_labyrinth

project = "napari-labyrinth"
author = "napari-labyrinth developers"
copyright = "the napari-labyrinth developers"
release = napari_labyrinth.__version__
version = release

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "examples", "**/GALLERY_HEADER.rst", "Thumbs.db", ".DS_Store"]

# -- MyST --------------------------------------------------------------------------------------
# Heading anchors let the pages link to each other's sections (algorithm.md#colour-...).
myst_heading_anchors = 4
myst_enable_extensions = ["colon_fence", "dollarmath"]

# -- API reference -----------------------------------------------------------------------------
autosummary_generate = True
autodoc_typehints = "none"  # the numpydoc Parameters sections say the types
autodoc_default_options = {"members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

# The pages of docs/study/ are written by benchmarks/study.py: its tables start at a lower
# heading level than a page's title would.
suppress_warnings = ["myst.header"]


def _plain_text_bars(app, what, name, obj, options, lines):
    """Keep the ``|x|`` of the parameter table's documentation as text.

    The table's one-line docs are plain text (they are also the command line's help and the
    widget's tooltips): ``|g - M|`` there is an absolute value, not a reST substitution.
    """
    if name == "napari_labyrinth.LabyrinthParameters":
        lines[:] = [line.replace("|", r"\|") for line in lines]


def setup(app):
    app.connect("autodoc-process-docstring", _plain_text_bars)


# -- Gallery -----------------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"[\\/]plot_",  # every plot_*.py runs at build time
    "ignore_pattern": r"(^|[\\/])_",  # helper modules (_display.py) are imported, not shown
    "within_subsection_order": "ExampleTitleSortKey",  # Fig. 1/2, Fig. 3, ... by their titles
    "abort_on_example_error": True,
    "remove_config_comments": True,
    "download_all_examples": False,
}

# The numba kernels compile into the package's cache on the first build; a build must not
# start the widget's warm-up process.
os.environ.setdefault("NAPARI_LABYRINTH_NO_WARMUP", "1")

# -- HTML --------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = "napari-labyrinth"
html_theme_options = {
    "secondary_sidebar_items": ["page-toc"],
    "navigation_with_keys": False,
}
html_static_path: list[str] = []
