"""Large results in plain pages (``_pages``): the advice Linux took, and the values."""

import sys

import numpy as np
import pytest

from napari_labyrinth import _pages, labyrinth_stack

linux_only = pytest.mark.skipif(
    not sys.platform.startswith("linux") or _pages._MADV_NOHUGEPAGE is None,
    reason="madvise advice is Linux's",
)


def _vm_flags(array: np.ndarray) -> set[str]:
    """The flags of the memory area that holds ``array``'s first whole page (smaps)."""
    address = -(-array.__array_interface__["data"][0] // _pages._PAGE) * _pages._PAGE
    flags: set[str] = set()
    inside = False
    with open("/proc/self/smaps") as smaps:
        for line in smaps:
            head = line.split()[0]
            if "-" in head and not head.endswith(":"):
                start, stop = (int(part, 16) for part in head.split("-"))
                inside = start <= address < stop
            elif inside and head == "VmFlags:":
                flags = set(line.split()[1:])
    return flags


@linux_only
def test_an_array_malloc_never_recycles_is_advised_plain_pages():
    array = _pages.empty_in_plain_pages((_pages.FRESH_BYTES // 2 + 4096,), np.uint16)
    assert "nh" in _vm_flags(array)  # VM_NOHUGEPAGE
    assert "hg" not in _vm_flags(array)


@linux_only
def test_a_smaller_array_keeps_numpys_advice():
    from numpy._core import multiarray

    array = _pages.empty_in_plain_pages((_pages.FRESH_BYTES // 4,), np.uint8)
    assert "nh" not in _vm_flags(array)
    if multiarray._get_madvise_hugepage():  # numpy's own advice for arrays of 4 MB or more
        assert "hg" in _vm_flags(array)


def test_advice_on_less_than_a_whole_page_is_not_given():
    assert not _pages.advise_plain_pages(np.empty(10, np.uint8)[1:3])


def test_a_stack_in_plain_pages_holds_the_same_values_as_in_numpys():
    """A stack result of 40 MB (plain pages) equals the same passes rendered plane by
    plane (each result under the threshold, in numpy's own memory), bit for bit."""
    rng = np.random.default_rng(3)
    image = rng.integers(0, 65536, (4, 1024, 1024), dtype=np.uint16)  # 8 MB
    options = dict(passes=4, seed=5, tone_limits=(0, 65535))  # one scale for all planes
    stack = labyrinth_stack(image, **options)  # (5, 4, 1024, 1024) uint16: 40 MB
    assert stack.nbytes >= _pages.FRESH_BYTES
    if sys.platform.startswith("linux") and _pages._MADV_NOHUGEPAGE is not None:
        assert "nh" in _vm_flags(stack)
    for k in range(4):
        alone = labyrinth_stack(image[k], plane_offset=k, **options)
        np.testing.assert_array_equal(stack[:, k], alone)
