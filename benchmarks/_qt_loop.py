"""The Qt event loop driven from a benchmark's script: run it a while, or until something holds.

The benchmarks that open a viewer (``bench_widget``, ``bench_lazy_scroll``,
``bench_multiscale``) wait for a widget's worker this way, without pytest-qt.
"""

from __future__ import annotations

import time
from collections.abc import Callable


def process_events(seconds: float = 0.0, nap: float = 0.001) -> None:
    """Process Qt's events once, then again every ``nap`` s for ``seconds`` s."""
    from qtpy.QtWidgets import QApplication  # Qt only where a viewer is opened

    end = time.perf_counter() + seconds
    QApplication.processEvents()
    while time.perf_counter() < end:
        QApplication.processEvents()
        time.sleep(nap)


def wait_until(
    condition: Callable[[], bool], timeout: float, what: str = "the widget did not finish"
) -> None:
    """Process events until ``condition()`` holds; TimeoutError (``what``) after ``timeout`` s."""
    end = time.perf_counter() + timeout
    while not condition():
        if time.perf_counter() > end:
            raise TimeoutError(f"{what} in {timeout:g} s")
        process_events(0.005)
