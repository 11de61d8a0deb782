"""Which format a path names, and which arrays each format can store.

The suffix names the format (:data:`FORMATS`), except that a path inside a
``.zarr`` directory names an array of a zarr store (:func:`zarr_root`); an
input of any other suffix is read through bioio (:func:`input_format`). The
checks here refuse, before anything is computed or written, an array that
the format cannot hold or a destination that would be clobbered.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ._errors import ImageFileError
from .metadata import ImageMetadata

#: Lower-case file suffix -> format name.
FORMATS = {
    ".tif": "TIFF",
    ".tiff": "TIFF",
    ".png": "PNG",
    ".jpg": "JPEG",
    ".jpeg": "JPEG",
    ".bmp": "BMP",
    ".zarr": "ZARR",
}


#: The format of an input the package does not read itself: bioio reads it, through the
#: reader plugin of its format (``io.bioio_reader``).
BIOIO = "BIOIO"


#: Formats that lose information when written: an output in one of them
#: needs the caller's consent (the command line's ``--lossy``).
LOSSY_FORMATS = ("JPEG",)


#: Formats that hold no provenance record when written.
FORMATS_WITHOUT_METADATA = ("BMP",)


def image_format(path: str | os.PathLike) -> str:
    """Format name (``"TIFF"``, ``"PNG"``, ``"JPEG"``, ``"BMP"`` or ``"ZARR"``) of a path.

    The suffix decides, except that a path inside a ``.zarr`` directory
    (``stack.zarr/0``: an array of a zarr group) is ``"ZARR"``.

    Raises
    ------
    ImageFileError
        (a ValueError) if the suffix is not one of ``FORMATS``.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS and zarr_root(path) is not None:
        return "ZARR"
    try:
        return FORMATS[suffix]
    except KeyError:
        known = ", ".join(FORMATS)
        what = f"unknown image format {suffix!r}" if suffix else "no file suffix"
        raise ImageFileError(path, f"{what}; use one of {known}") from None


def input_format(path: str | os.PathLike) -> str:
    """Format name of an input: :func:`image_format`'s, or :data:`BIOIO` for any other
    suffix (a file bioio's reader plugins may read; outputs are only of ``FORMATS``)."""
    if Path(path).suffix.lower() in FORMATS or zarr_root(path) is not None:
        return image_format(path)
    return BIOIO


def zarr_root(path: str | os.PathLike) -> tuple[Path, str] | None:
    """``(store, component)`` of a path in a ``.zarr`` directory, or None.

    ``a.zarr`` gives ``(a.zarr, "")``, ``a.zarr/0`` and ``a.zarr/0/`` give
    ``(a.zarr, "0")``.
    """
    parts = Path(path).parts
    for index in range(len(parts) - 1, -1, -1):
        name = parts[index]
        if name.lower().endswith(".zarr") and len(name) > len(".zarr"):
            return Path(*parts[: index + 1]), "/".join(parts[index + 1 :])
    return None


def enclosing_zarr_store(path: str | os.PathLike) -> Path | None:
    """The nearest existing zarr store (a directory holding zarr metadata) that holds
    ``path`` below it, or None."""
    for parent in Path(path).parents:
        if is_zarr_store(parent):
            return parent
    return None


def is_zarr_store(path: Path) -> bool:
    """Whether ``path`` is a directory holding zarr metadata (version 2 or 3)."""
    return path.is_dir() and any(
        (path / name).is_file() for name in ("zarr.json", ".zarray", ".zgroup")
    )


def check_storable(
    path: Path, kind: str, array: Any, metadata: ImageMetadata | None = None
) -> None:
    """Refuse an array (and its extra samples) that the format ``kind`` cannot store."""
    if array.size == 0:
        raise ImageFileError(path, f"cannot write an empty image (shape {array.shape})")
    if kind in ("TIFF", "ZARR"):
        if array.dtype.kind not in "biuf" and array.dtype.kind != "c":
            raise ImageFileError(path, f"{kind} cannot store {array.dtype} data")
        return
    if metadata is not None and metadata.ambiguous and metadata.channel_axis is None:
        if array.ndim == 3:  # read as planes: the format would show them as one colour image
            planes, rows, columns = array.shape
            raise ImageFileError(
                path,
                f"cannot store {planes} planes of {rows}x{columns} pixels as {kind} (the "
                f"input's last axis was read as planes); use a .tif or .zarr file, or read "
                f"that axis as colour (channel_axis=-1, --channel-axis -1)",
            )
    extra = () if metadata is None else metadata.extra_samples
    if any(sample != "unassalpha" for sample in extra):
        raise ImageFileError(
            path,
            f"cannot store the extra samples {', '.join(extra)} of the input as {kind} "
            f"({kind} holds only unassociated alpha); use a .tif file",
        )
    grey = array.ndim == 2
    channels = array.shape[-1] if array.ndim == 3 else None
    if kind == "PNG":
        ok = (array.dtype == np.uint8 and (grey or channels in (2, 3, 4))) or (
            array.dtype == np.uint16 and grey
        )
        holds = "uint8 grey, grey+alpha, RGB or RGBA images, or uint16 grey images"
    else:  # JPEG, BMP
        ok = array.dtype == np.uint8 and (grey or channels == 3)
        holds = "uint8 grey or RGB images"
    if not ok:
        raise ImageFileError(
            path,
            f"cannot store {array.dtype} data of shape {array.shape} as {kind} "
            f"({kind} holds {holds}); use a .tif file",
        )


def check_writable(
    path: Path, kind: str, array: Any, overwrite: bool, metadata: ImageMetadata | None = None
) -> None:
    """Refuse, as :func:`check_storable`, an array the format cannot store, and a directory
    or (without ``overwrite``) a file at ``path``."""
    check_storable(path, kind, array, metadata)
    if path.is_dir():
        raise ImageFileError(path, "is a directory")
    if not overwrite and os.path.lexists(path):
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)")
