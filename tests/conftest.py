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


# Every kernel numba compiles in the run's processes, and in those they start, is noted in
# one file (napari_labyrinth.core._jit.COMPILE_LOG); the summary counts them. From an install
# that carries compiled kernels the count is the kernels they lack. Tests that compile on
# purpose (the fallbacks of tests/core/test_shipped.py) note theirs in files of their own.
_COMPILE_LOG = "NAPARI_LABYRINTH_COMPILE_LOG"
os.environ.setdefault(_COMPILE_LOG, os.path.join(_scratch, "compiled-kernels.tsv"))


def pytest_sessionstart(session):
    from napari_labyrinth.core import _jit

    _jit.note_compiles()


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if hasattr(config, "workerinput"):  # an xdist worker: the controller sums up
        return
    import collections
    import napari_labyrinth

    path = os.environ[_COMPILE_LOG]
    lines = []
    if os.path.exists(path):
        with open(path, encoding="utf-8") as log:
            lines = [line.rstrip("\n").split("\t") for line in log if line.strip()]
    tests = collections.Counter(fields[2] or "(outside a test)" for fields in lines)
    signatures = {(fields[0], fields[1]) for fields in lines}
    write = terminalreporter.write_line
    write(
        f"numba compiled {len(lines)} kernels of napari_labyrinth in this run "
        f"({len(signatures)} signatures, in {len(tests)} tests; package from "
        f"{os.path.dirname(napari_labyrinth.__file__)})"
    )
    for test, count in tests.most_common(10 if lines else 0):
        write(f"  {count:4d}  {test}")
