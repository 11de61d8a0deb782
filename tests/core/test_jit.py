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
    # the package's kernel: its shipped entries (none in a source tree), then numba's cache
    assert dispatcher._cache.__class__.__name__ == "ShippedFirst"
    assert dispatcher._cache.users.__class__.__name__ == "FunctionCache"


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


KERNEL_HEAD = "from napari_labyrinth.core._jit import cached_njit\n"
PAIR = "from typing import NamedTuple\n\nclass Pair(NamedTuple):\n    first: int\n    second: int\n"
PAIR_KERNEL = (
    KERNEL_HEAD + "from arguments import Pair  # noqa: F401\n\n"
    "@cached_njit()\ndef kernel(pair):\n    return pair.first - pair.second\n"
)


def _kernels(tmp_path, files: dict[str, str]):
    """Modules ``files`` (name -> source) in a directory of their own, and a function that
    runs ``code`` in a new Python process importing from there, with one numba cache."""
    package = tmp_path / "kernels"
    package.mkdir()
    for name, source in files.items():
        (package / f"{name}.py").write_text(source)
    path = [str(package), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=os.pathsep.join(path))

    def run(code: str) -> str:
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
        assert done.returncode == 0, done.stderr
        return done.stdout.strip()

    return package, run


def _edit_keeping_stamp(path, old: str, new: str) -> None:
    """Replace ``old`` by ``new`` (the same length) in ``path``, its time left as it was
    (as a reinstall may leave it): numba's own stamp sees no change."""
    stamp = path.stat()
    path.write_text(path.read_text().replace(old, new))
    os.utime(path, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))


@pytest.mark.subprocess
def test_a_change_to_a_helper_in_another_file_compiles_its_kernel_again(tmp_path):
    """numba's own stamp is the kernel's file's time and size: a helper of another file,
    compiled into the kernel, changed to text of the same size, went unseen."""
    package, run = _kernels(tmp_path, {
        "helper": "from numba import njit\n\n@njit\ndef helper(x):\n    return x + 1\n",
        "kernel": KERNEL_HEAD + "from helper import helper\n\n"
        "@cached_njit()\ndef kernel(x):\n    return helper(x)\n",
    })  # fmt: skip
    assert run("from kernel import kernel; print(kernel(1))") == "2"
    _edit_keeping_stamp(package / "helper.py", "x + 1", "x + 5")
    assert run("from kernel import kernel; print(kernel(1))") == "6"


@pytest.mark.subprocess
def test_a_named_tuple_argument_with_fields_moved_compiles_its_kernel_again(tmp_path):
    """numba's cache index knows a NamedTuple by its class and its fields' types, not its
    fields' names: a kernel that imports its argument's class has that file in its stamp."""
    package, run = _kernels(tmp_path, {"arguments": PAIR, "kernel": PAIR_KERNEL})
    call = "from kernel import kernel, Pair; print(kernel(Pair(5, 2)))"
    assert run(call) == "3"
    _edit_keeping_stamp(package / "arguments.py", "first: int\n    second", "second: int\n    first")
    assert run(call) == "-3"


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
    package, run = _kernels(tmp_path, {"arguments": PAIR, "kernel": PAIR_KERNEL})
    call = "from kernel import kernel, Pair; print(kernel(Pair(5, 2)))"
    assert run(call) == "3"
    (package / "arguments.py").rename(package / "shapes.py")
    kernel = package / "kernel.py"
    kernel.write_text(kernel.read_text().replace("from arguments", "from shapes"))
    assert run(call) == "3"


FACTORY = KERNEL_HEAD + (
    "from numba import njit\n\n"
    "def made(step):\n"
    "    @cached_njit()\n"
    "    def kernel(x):\n        return x + step\n"
    "    return kernel\n\n"
    "ONE, HUNDRED = made(1), made(100)\n\n"
    "@njit\ndef both(x):\n    return ONE(x) + HUNDRED(x)\n"
)
#: numba numbers the functions it compiles in each process from 0: two processes give
#: the first function they compile the same number, as here.
SAME_NUMBERS = (
    "import itertools\nfrom numba.core.bytecode import FunctionIdentity\n"
    "FunctionIdentity._unique_ids = itertools.count(10**6)\n"
)


@pytest.mark.subprocess
def test_two_variants_of_a_factory_compiled_in_two_processes_keep_their_own_code(tmp_path):
    """A variant cached by one process and another compiled by the next, both given
    the same number by numba, were named alike: a caller of both ran one of them twice."""
    _, run = _kernels(tmp_path, {"factory": FACTORY})
    assert run(SAME_NUMBERS + "from factory import ONE; print(ONE(1))") == "2"
    assert run(SAME_NUMBERS + "from factory import HUNDRED, both; HUNDRED(1); print(both(1))") == "103"


def test_a_factory_s_kernel_is_named_by_the_values_it_closes_over():
    def made(step, name):
        def kernel(x):
            return x + step if name else x

        return kernel

    _jit._name_by_closure(kernel := made(2, "two"))
    assert kernel.__qualname__.endswith("kernel[name='two',step=2]")
    with pytest.raises(TypeError, match=r"closes over step=2\.5.*bools, ints and strings"):
        _jit._name_by_closure(made(2.5, "x"))
