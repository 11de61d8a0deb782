"""What a run can afford: the memory an image declares against the memory available.

A file's header says how many pixels it holds before a single pixel is read,
and a 76 KB compressed TIFF can declare 100000 x 100000 of them. Before an
image is read (``io``) or its planes are rendered lazily (``lazy``), the
memory that rendering needs is estimated from the declared shape and dtype
and compared with what the machine has available; an image that cannot fit
is refused with one line saying how big it is and what to do, instead of
being read until the machine swaps or the process is killed.

The limit is the memory available now (``MemAvailable`` on Linux, psutil
elsewhere), or the environment variable ``NAPARI_LABYRINTH_MEMORY`` (bytes, or
a number with a unit: ``512M``, ``8G``, ``1.5GiB``).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

#: Environment variable that sets the memory a run may use (overrides what is available).
MEMORY_ENV = "NAPARI_LABYRINTH_MEMORY"

#: Bytes of work per pixel of the plane being rendered: float32 tones before and
#: after the pass, the mask of changed tones, and float64 values of the changes.
WORK_BYTES_PER_PIXEL = 4 + 4 + 1 + 8

#: Memory assumed when the machine does not say (no /proc/meminfo, no psutil).
FALLBACK_MEMORY = 4 << 30

_UNITS = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


class MemoryBudgetError(ValueError):
    """An image that needs more memory than the run may use (one line)."""


def parse_size(text: str) -> int:
    """Bytes of ``"8G"``, ``"512M"``, ``"1.5GiB"``, ``"1000000"`` (binary units).

    Raises
    ------
    ValueError
        Naming ``NAPARI_LABYRINTH_MEMORY`` and the forms it takes.
    """
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([kmgt]?)(i?b)?\s*", text.lower())
    if match is None:
        raise ValueError(
            f"{MEMORY_ENV} must be a size such as 512M, 8G or 1.5GiB, got {text!r}"
        )
    number, unit = float(match.group(1)), match.group(2)
    return int(number * _UNITS[unit])


def memory_limit() -> int:
    """Bytes a run may use: ``NAPARI_LABYRINTH_MEMORY`` if set, else the memory available."""
    text = os.environ.get(MEMORY_ENV, "").strip()
    if text:
        return parse_size(text)
    return available_memory()


def available_memory() -> int:
    """Memory available to a new allocation without swapping (bytes), as the OS says."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        import psutil

        return int(psutil.virtual_memory().available)
    except Exception:  # noqa: BLE001 - psutil missing or unable to tell
        return FALLBACK_MEMORY


def render_bytes(shape: Sequence[int], dtype: np.dtype, planes: int | None = None) -> int:
    """Bytes, about, to render an image of ``shape`` held in memory.

    The image and its result (``planes`` of its planes, default all of them)
    and the work arrays of one plane (``WORK_BYTES_PER_PIXEL``; a plane as
    :func:`_plane_pixels` counts it).
    """
    shape = tuple(int(n) for n in shape)
    plane_pixels = _plane_pixels(shape)
    per_plane = math.prod(shape) // max(plane_pixels, 1)
    held = planes * plane_pixels * per_plane if planes is not None else math.prod(shape)
    return 2 * held * np.dtype(dtype).itemsize + WORK_BYTES_PER_PIXEL * plane_pixels


def _plane_pixels(shape: tuple[int, ...]) -> int:
    """Pixels of a plane: the last two axes, or the two before a trailing colour axis of at
    most 4."""
    return math.prod(shape[-3:-1] if len(shape) >= 3 and shape[-1] <= 4 else shape[-2:])


def refusal(shape: Sequence[int], dtype: np.dtype, *, what: str = "it", planes=None) -> str | None:
    """Why an image of ``shape`` and ``dtype`` cannot be rendered here, or None if it can.

    ``planes``: how many planes are held at once (None: all; 1 for a lazy
    image rendered plane by plane).
    """
    needed = render_bytes(shape, dtype, planes)
    limit = memory_limit()
    if needed <= limit:
        return None
    return (
        f"{what} {declared(shape, dtype)}; rendering "
        f"needs about {_bytes_text(needed)}, more than the {_bytes_text(limit)} this run "
        f"may use: crop or downsample it, store it as a zarr store or TIFF file (the command "
        f"line renders a stack plane by plane, and one plane band by band into a .zarr or .tif "
        f"output), or set {MEMORY_ENV} to allow more"
    )


def declared(shape: Sequence[int], dtype: np.dtype) -> str:
    """``"declares 100000 x 100000 uint8 pixels (9.3 GiB)"``: an image's size, in words."""
    dims = " x ".join(str(int(n)) for n in shape)
    size = _bytes_text(math.prod(int(n) for n in shape) * np.dtype(dtype).itemsize)
    return f"declares {dims} {np.dtype(dtype).name} pixels ({size})"


def refuse_unaffordable(
    name: str, shape: Sequence[int], dtype: np.dtype, *, planes=None, what: str = "it"
) -> None:
    """Raise :class:`MemoryBudgetError` naming ``name`` if :func:`refusal` gives a reason."""
    reason = refusal(shape, dtype, what=what, planes=planes)
    if reason is not None:
        raise MemoryBudgetError(f"{name}: {reason}")


#: Results below this size are not weighed against the memory available: such an
#: allocation cannot exhaust a machine that runs napari, and reading what is available
#: costs tens of µs a call.
WEIGHED_RESULT_BYTES = 64 << 20


def refuse_unaffordable_result(
    shape: Sequence[int], dtype: np.dtype, copies: int, what: str, *, lazy: bool = False
) -> None:
    """Raise :class:`MemoryBudgetError` if ``copies`` arrays of ``shape`` and ``dtype`` (the
    result of a rendering of an image already in memory: 1, a pass each in a stack, or a
    rendering each, stacked, in a sweep) and the work of one plane exceed the memory
    this run may use; ``what`` names the result in the message. ``lazy``: the result of
    one block of a dask image (a plane and its passes), which being lazy does not help."""
    result = copies * math.prod(int(n) for n in shape) * np.dtype(dtype).itemsize
    if result < WEIGHED_RESULT_BYTES:
        return
    shape = tuple(int(n) for n in shape)
    needed = result + WORK_BYTES_PER_PIXEL * _plane_pixels(shape)
    limit = memory_limit()
    if needed > limit:
        dims = " x ".join(str(n) for n in shape)
        raise MemoryBudgetError(
            f"{what} of {dims} {np.dtype(dtype).name} pixels needs about {_bytes_text(needed)}, "
            f"more than the {_bytes_text(limit)} this run may use: render fewer passes or "
            f"values, crop the image, {'' if lazy else _LAZY_ADVICE}or set {MEMORY_ENV} to "
            "allow more"
        )


_LAZY_ADVICE = "pass it as a dask array (rendered lazily, plane by plane), "


def declared_refusal(path: Path, kind: str) -> str | None:
    """Why the image file at ``path`` cannot be read into memory here, from its header alone.

    ``kind`` is the format (``"TIFF"``, ``"PNG"``, ``"JPEG"``, ``"BMP"``). A
    header that cannot be parsed gives None: the reader then says what is
    wrong with the file.
    """
    declared = _declared(path, kind)
    if declared is None:
        return None
    return refusal(*declared)


def _declared(path: Path, kind: str) -> tuple[tuple[int, ...], np.dtype] | None:
    """Shape and dtype the file's header declares, without decoding pixels."""
    try:
        if kind == "TIFF":
            import tifffile

            with tifffile.TiffFile(path) as tiff:
                series = tiff.series[0]
                return tuple(series.shape), np.dtype(series.dtype)
        with pillow_header(path) as image:
            width, height = image.size
            bands = len(image.getbands())
            dtype = _PIL_DTYPES.get(image.mode.split(";")[0], np.uint8)
            if image.mode.startswith("I;16"):
                dtype = np.uint16
            shape = (height, width) if bands == 1 else (height, width, bands)
            return shape, np.dtype(dtype)
    except Exception:  # noqa: BLE001 - a bad header is the reader's to report
        return None


_PIL_DTYPES = {"I": np.int32, "F": np.float32}


def pillow_header(path: Path):
    """The image at ``path`` opened by Pillow for its header, even past Pillow's own limit.

    ``Image.open`` refuses more than twice ``Image.MAX_IMAGE_PIXELS`` with a
    message about attacks; the format classes themselves read the header
    without that check, so that the size can be reported as for any image.
    """
    from PIL import BmpImagePlugin, Image, JpegImagePlugin, PngImagePlugin

    try:
        return Image.open(path)
    except Image.DecompressionBombError:
        pass
    for opener in (PngImagePlugin.PngImageFile, JpegImagePlugin.JpegImageFile,
                   BmpImagePlugin.BmpImageFile):
        try:
            return opener(path)
        except Exception:  # noqa: BLE001 - not this format
            continue
    raise ValueError("no header Pillow can read")


def bytes_text(size: int) -> str:
    """``"1.5 GiB"``: a size in words, to a tenth of its unit."""
    for unit, scale in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if size >= scale:
            return f"{size / scale:.1f} {unit}"
    return f"{size} B"


_bytes_text = bytes_text


def budget_text(size: int) -> str:
    """The least ``NAPARI_LABYRINTH_MEMORY`` of at least ``size`` bytes, as it is typed: in
    whole MiB (``"394M"``), in whole KiB below 64 MiB (``"1700K"``); :func:`parse_size`
    reads it back as that many bytes exactly."""
    unit, letter = (1 << 20, "M") if size >= 64 << 20 else (1 << 10, "K")
    return f"{-(-int(size) // unit)}{letter}"
