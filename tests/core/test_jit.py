"""The kernels' decorator: cached on disk where possible, compiled in memory elsewhere."""

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
