"""The kernels' decorator: cached on disk where possible, compiled in memory elsewhere."""

import importlib.util
import os
import subprocess
import sys
import warnings

import pytest

from napari_labyrinth.core import _jit


@pytest.fixture
def fresh_warning(monkeypatch):
    monkeypatch.setattr(_jit, "_warned", False)


def _function_without_source(name):
    """A function numba can find no cache directory for: its source is no file."""
    namespace = {}
    exec(compile(f"def {name}(x):\n    return x + 1\n", "<no file>", "exec"), namespace)
    return namespace[name]


def test_a_function_with_no_cache_directory_compiles_in_memory_and_says_so_once(fresh_warning):
    with pytest.warns(_jit.UncachedKernelWarning, match="NUMBA_CACHE_DIR") as caught:
        first = _jit.cached_njit(nogil=True)(_function_without_source("first"))
        second = _jit.cached_njit()(_function_without_source("second"))
    assert len(caught) == 1
    assert (first(1), second(2.5)) == (2, 3.5)
    assert first._cache.__class__.__name__ == "NullCache"


def test_a_function_in_a_file_is_cached_without_warning(fresh_warning):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dispatcher = _jit.cached_njit()(_jit._warn_once)
    assert dispatcher._cache.__class__.__name__ == "FunctionCache"


def _new_kernel(tmp_path, name):
    """A kernel of its own module file (numba caches only functions of a file)."""
    module = tmp_path / f"{name}.py"
    module.write_text(
        "from napari_labyrinth.core._jit import cached_njit\n\n"
        "@cached_njit()\n"
        f"def {name}(x):\n    return x * 2\n"
    )
    spec = importlib.util.spec_from_file_location(name, module)
    loaded = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loaded)
    return getattr(loaded, name)


def test_is_compiled_says_whether_a_call_would_compile(tmp_path):
    kernel = _new_kernel(tmp_path, "doubled")
    assert not _jit.is_compiled(kernel, 3)
    assert kernel(3) == 6
    assert _jit.is_compiled(kernel, 4)
    assert not _jit.is_compiled(kernel, 4.5)  # another signature


@pytest.mark.subprocess
def test_is_compiled_loads_a_kernel_from_the_disk_cache(tmp_path):
    script = (
        f"import sys; sys.path.insert(0, {str(tmp_path)!r})\n"
        "import twice as module\n"
        "from napari_labyrinth.core._jit import is_compiled\n"
        "ready = is_compiled(module.twice, 1)\n"
        "print(ready, module.twice(2), len(module.twice.overloads))\n"
    )
    (tmp_path / "twice.py").write_text(
        "from napari_labyrinth.core._jit import cached_njit\n\n"
        "@cached_njit()\ndef twice(x):\n    return x * 2\n"
    )
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    outputs = []
    for _ in range(2):
        done = subprocess.run(
            [sys.executable, "-c", script], capture_output=True, text=True, env=environment
        )
        assert done.returncode == 0, done.stderr
        outputs.append(done.stdout.split())
    assert outputs == [["False", "4", "1"], ["True", "4", "1"]]


def test_compiling_names_the_kernel_numba_compiles_now(tmp_path):
    from numba.core import event

    _jit.watch_compiles()
    seen = []

    class Looker(event.Listener):
        def on_start(self, ev):
            seen.append(_jit.compiling())

        def on_end(self, ev):
            pass

    kernel = _new_kernel(tmp_path, "tripled")
    assert _jit.compiling() is None
    with event.install_listener("numba:compile", Looker()):
        kernel(1)
    assert seen and set(seen) == {"tripled"}
    assert _jit.compiling() is None


@pytest.mark.subprocess
def test_a_change_to_a_helper_in_another_file_compiles_its_kernel_again(tmp_path):
    """numba's own stamp is the kernel's file's time and size: a helper of another file,
    compiled into the kernel, changed to text of the same size, went unseen."""
    package = tmp_path / "kernels"
    package.mkdir()
    (package / "helper.py").write_text("from numba import njit\n\n@njit\ndef helper(x):\n    return x + 1\n")
    (package / "kernel.py").write_text(
        "from napari_labyrinth.core._jit import cached_njit\n"
        "from helper import helper\n\n"
        "@cached_njit()\n"
        "def kernel(x):\n    return helper(x)\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=os.pathsep.join(
        [str(package), *filter(None, [os.environ.get("PYTHONPATH")])]))

    def result():
        run = subprocess.run(
            [sys.executable, "-c", "from kernel import kernel; print(kernel(1))"],
            capture_output=True, text=True, env=env, check=True,
        )  # fmt: skip
        return run.stdout.strip()

    assert result() == "2"
    helper = package / "helper.py"
    stamp = helper.stat()
    helper.write_text(helper.read_text().replace("x + 1", "x + 5"))
    os.utime(helper, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))  # as a reinstall may leave it
    assert result() == "6"


@pytest.mark.subprocess
def test_a_named_tuple_argument_with_fields_moved_compiles_its_kernel_again(tmp_path):
    """numba's cache index knows a NamedTuple by its class and its fields' types, not its
    fields' names: a kernel that imports its argument's class has that file in its stamp."""
    package = tmp_path / "kernels"
    package.mkdir()
    arguments = package / "arguments.py"
    arguments.write_text(
        "from typing import NamedTuple\n\n"
        "class Pair(NamedTuple):\n    first: int\n    second: int\n"
    )
    (package / "kernel.py").write_text(
        "from napari_labyrinth.core._jit import cached_njit\n"
        "from arguments import Pair  # noqa: F401\n\n"
        "@cached_njit()\n"
        "def kernel(pair):\n    return pair.first - pair.second\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=os.pathsep.join(
        [str(package), *filter(None, [os.environ.get("PYTHONPATH")])]))

    def result():
        run = subprocess.run(
            [sys.executable, "-c", "from kernel import kernel, Pair; print(kernel(Pair(5, 2)))"],
            capture_output=True, text=True, env=env, check=True,
        )  # fmt: skip
        return run.stdout.strip()

    assert result() == "3"
    stamp = arguments.stat()
    moved = arguments.read_text().replace("first: int\n    second", "second: int\n    first")
    arguments.write_text(moved)  # the same size, and the same time below
    os.utime(arguments, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))
    assert result() == "-3"


def test_compiled_for_calls_the_kernel_s_code_for_the_same_types(tmp_path):
    from typing import NamedTuple

    import numpy as np

    class Span(NamedTuple):
        start: int
        stop: int

    module = tmp_path / "summed.py"
    module.write_text(
        "from napari_labyrinth.core._jit import cached_njit\n\n"
        "@cached_njit(nogil=True)\n"
        "def summed(values, span, out):\n"
        "    for i in range(span.start, span.stop):\n        out[0] += values[i]\n"
    )
    spec = importlib.util.spec_from_file_location("summed", module)
    loaded = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loaded)
    values, out = np.arange(10.0), np.zeros(1)
    code = _jit.compiled_for(loaded.summed, values, Span(0, 1), out)  # compiled here
    assert code is not loaded.summed and len(loaded.summed.overloads) == 1
    code(values, Span(2, 5), out)
    assert out[0] == 2 + 3 + 4
    assert _jit.compiled_for(len, "a") is len  # no numba dispatcher: itself


@pytest.mark.subprocess
def test_an_index_naming_a_class_no_longer_there_reads_as_stale(tmp_path):
    """numba unpickles a kernel's cache index before it compares the stamp: a NamedTuple
    argument moved to another module since the index was written must not raise."""
    package = tmp_path / "kernels"
    package.mkdir()
    pair = (
        "from typing import NamedTuple\n\n"
        "class Pair(NamedTuple):\n    first: int\n    second: int\n"
    )
    (package / "arguments.py").write_text(pair)
    kernel = package / "kernel.py"
    kernel.write_text(
        "from napari_labyrinth.core._jit import cached_njit\n"
        "from arguments import Pair  # noqa: F401\n\n"
        "@cached_njit()\n"
        "def kernel(pair):\n    return pair.first - pair.second\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=os.pathsep.join(
        [str(package), *filter(None, [os.environ.get("PYTHONPATH")])]))

    def result():
        run = subprocess.run(
            [sys.executable, "-c", "from kernel import kernel, Pair; print(kernel(Pair(5, 2)))"],
            capture_output=True, text=True, env=env,
        )  # fmt: skip
        assert run.returncode == 0, run.stderr
        return run.stdout.strip()

    assert result() == "3"
    (package / "arguments.py").unlink()
    (package / "shapes.py").write_text(pair)
    kernel.write_text(kernel.read_text().replace("from arguments", "from shapes"))
    assert result() == "3"
