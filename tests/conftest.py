import os
import signal
import tempfile

# A shell starts a background job with Ctrl-C ignored, and Python then leaves SIGINT
# ignored: the tests of interrupts need Python's own handler, as in a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

# napari and Qt write settings and caches here: keep them out of the user's home.
_scratch = tempfile.mkdtemp(prefix="napari-labyrinth-tests-")
os.environ.setdefault("XDG_CONFIG_HOME", os.path.join(_scratch, "config"))
os.environ.setdefault("XDG_CACHE_HOME", os.path.join(_scratch, "cache"))

# The widget starts a process that compiles numba's kernels into their cache
# (napari_labyrinth._warmup); the tests compile in process and test it apart.
os.environ.setdefault("NAPARI_LABYRINTH_NO_WARMUP", "1")


def pytest_collection_modifyitems(config, items):
    """Every test under tests/_qt drives a viewer: it is in the ``qt`` lane."""
    import pytest

    for item in items:
        if "_qt" in item.path.parent.parts:
            item.add_marker(pytest.mark.qt)
