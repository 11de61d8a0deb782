"""The menu commands under a Qt binding without sip (PySide2, PySide6: napari's installer)."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("napari")

#: Imports the menu commands as under PySide, whose qtpy has no ``sip`` to give (qtpy's own
#: modules, loaded first, take sip under PyQt).
_WITHOUT_SIP = """
import sys
import napari.viewer, qtpy, qtpy.QtCore, qtpy.QtGui, qtpy.QtWidgets
vars(qtpy).pop("sip", None)
sys.modules["qtpy.sip"] = None
import napari_labyrinth._qt.menus
"""


@pytest.mark.subprocess
def test_the_menu_commands_import_without_sip():
    result = subprocess.run(
        [sys.executable, "-c", _WITHOUT_SIP],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stderr
