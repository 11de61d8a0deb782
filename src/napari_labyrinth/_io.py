"""Reading and writing image files for the command line.

TIFF files go through tifffile (any dtype, any number of dimensions); PNG,
JPEG and BMP through imageio's pillow plugin. Writes are atomic: the data go
to a temporary file in the destination directory, which then takes the
destination's name in one step, so a reader never sees a half-written file
and an error leaves nothing behind.
"""

from __future__ import annotations

import errno
import os
import secrets
from pathlib import Path

import numpy as np

#: Lower-case file suffix -> format name.
FORMATS = {
    ".tif": "TIFF",
    ".tiff": "TIFF",
    ".png": "PNG",
    ".jpg": "JPEG",
    ".jpeg": "JPEG",
    ".bmp": "BMP",
}


class ImageFileError(ValueError):
    """An image file that cannot be read, or an array that cannot be stored.

    ``str(error)`` is ``"<path>: <reason>"``; ``reason`` alone is also kept.
    """

    def __init__(self, path: str | os.PathLike, reason: str):
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")


def image_format(path: str | os.PathLike) -> str:
    """Format name (``"TIFF"``, ``"PNG"``, ``"JPEG"`` or ``"BMP"``) of a path's suffix.

    Raises
    ------
    ImageFileError
        (a ValueError) if the suffix is not one of ``FORMATS``.
    """
    suffix = Path(path).suffix.lower()
    try:
        return FORMATS[suffix]
    except KeyError:
        known = ", ".join(FORMATS)
        what = f"unknown image format {suffix!r}" if suffix else "no file suffix"
        raise ImageFileError(path, f"{what}; use one of {known}") from None


def read_image(path: str | os.PathLike) -> np.ndarray:
    """Read an image file into an array.

    Parameters
    ----------
    path : str or path-like
        A ``.tif``/``.tiff`` file (read with tifffile: every page of the
        first series, any dtype) or a ``.png``, ``.jpg``/``.jpeg`` or
        ``.bmp`` file (read with imageio's pillow plugin: grey images are
        2-D, colour images ``(rows, columns, 3 or 4)``; palette images are
        expanded to RGB(A)).

    Returns
    -------
    image : ndarray

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ImageFileError
        (a ValueError) naming the file, for an unknown suffix or a file
        that cannot be read (corrupt, truncated, not an image, a directory,
        no permission).
    """
    path = Path(path)
    kind = image_format(path)
    if not path.exists():
        raise FileNotFoundError(errno.ENOENT, "no such file", str(path))
    if path.is_dir():
        raise ImageFileError(path, "is a directory, not an image file")
    try:
        if kind == "TIFF":
            import tifffile

            image = tifffile.imread(path)
        else:
            import imageio.v3 as iio

            image = iio.imread(path, plugin="pillow")
    except Exception as exc:  # readers raise many types for a bad file
        reason = _reason(exc)
        if "can not handle the given uri" in reason:  # imageio's words for "not an image"
            reason = "not an image pillow can identify (corrupt, or another format)"
        raise ImageFileError(path, f"cannot read {kind} file: {reason}") from exc
    image = np.asarray(image)
    if image.size == 0:
        raise ImageFileError(path, f"the file holds no pixels (shape {image.shape})")
    return image


def write_image(path: str | os.PathLike, array: np.ndarray, *, overwrite: bool = False) -> Path:
    """Write an array to an image file, atomically.

    Parameters
    ----------
    path : str or path-like
        Destination; its suffix sets the format. TIFF (``.tif``, ``.tiff``)
        stores any dtype and any number of dimensions (a last axis of
        length 3 or 4 is stored as RGB(A) samples). PNG stores uint8 grey,
        grey + alpha, RGB or RGBA images and uint16 grey images; JPEG
        (quality 95, lossy) and BMP store uint8 grey or RGB images.
    array : array_like
        The image.
    overwrite : bool, optional
        Replace an existing file. Without it an existing file is left as it
        is, even if it appears while this call runs.

    Returns
    -------
    path : Path
        The file written.

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False.
    ImageFileError
        (a ValueError) naming the file, for an unknown suffix, a directory,
        or an array that the format cannot store (it suggests ``.tif``).
    OSError
        If writing fails (no space, no permission); no temporary file is
        left behind.

    Notes
    -----
    The data are written to a hidden temporary file in the destination's
    directory, flushed to disk, then renamed over the destination
    (``os.replace``), or hard-linked to it when ``overwrite`` is False so
    that a file created meanwhile is not clobbered.
    """
    path = Path(path)
    kind = image_format(path)
    array = np.asarray(array)
    _check_storable(path, kind, array)
    if path.is_dir():
        raise ImageFileError(path, "is a directory")
    if not overwrite and os.path.lexists(path):
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)")
    directory = path.parent
    temporary, handle = _create_temporary(directory, path.name)
    try:
        with handle:
            _write(handle, kind, path.suffix.lower(), array)
            handle.flush()
            os.fsync(handle.fileno())
        if overwrite:
            os.replace(temporary, path)
        else:
            _link_no_clobber(temporary, path)
    except BaseException:
        try:
            os.unlink(temporary)
        except FileNotFoundError:
            pass
        raise
    return path


def _reason(exc: BaseException) -> str:
    """One line describing an exception, without a traceback."""
    if isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


def _check_storable(path: Path, kind: str, array: np.ndarray) -> None:
    if array.size == 0:
        raise ImageFileError(path, f"cannot write an empty image (shape {array.shape})")
    if kind == "TIFF":
        if array.dtype.kind not in "biuf" and array.dtype.kind != "c":
            raise ImageFileError(path, f"TIFF cannot store {array.dtype} data")
        return
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


def _create_temporary(directory: Path, name: str):
    """A new hidden file beside the destination, opened for binary writing."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    while True:
        temporary = directory / f".{name}.{secrets.token_hex(4)}.tmp"
        try:
            fd = os.open(temporary, flags, 0o666)  # the umask applies, unlike mkstemp
        except FileExistsError:
            continue
        os.close(fd)
        # Opened again by name: writers such as tifffile want a named file.
        return temporary, open(temporary, "wb")


def _write(handle, kind: str, suffix: str, array: np.ndarray) -> None:
    if kind == "TIFF":
        import tifffile

        rgb = array.ndim >= 3 and array.shape[-1] in (3, 4) and array.dtype.kind in "uif"
        tifffile.imwrite(handle, array, photometric="rgb" if rgb else "minisblack")
        return
    import imageio.v3 as iio

    options = {"quality": 95} if kind == "JPEG" else {}
    iio.imwrite(handle, np.ascontiguousarray(array), plugin="pillow", extension=suffix, **options)


def _link_no_clobber(temporary: Path, path: Path) -> None:
    """Give ``temporary`` the name ``path`` unless ``path`` exists; remove ``temporary``."""
    try:
        os.link(temporary, path)
    except FileExistsError:
        raise FileExistsError(f"{path} already exists (use overwrite to replace it)") from None
    except OSError:
        # No hard links on this file system: check, then rename (a small window).
        if os.path.lexists(path):
            raise FileExistsError(f"{path} already exists (use overwrite to replace it)") from None
        os.replace(temporary, path)
        return
    os.unlink(temporary)
