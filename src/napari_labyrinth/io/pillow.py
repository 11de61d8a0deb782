"""PNG, JPEG and BMP files, through imageio's pillow plugin.

One image each, read whole: grey, grey + alpha, RGB or RGBA, a palette
expanded to RGB, a PNG transparency chunk read as alpha, an EXIF orientation
applied. What Pillow would misread (CMYK, 16-bit colour PNG) is refused, saying
what to convert it to. What a file says about its pixels
(:func:`pillow_metadata`) comes from Pillow's header; the provenance record
is a PNG iTXt chunk or a JPEG comment (a BMP file holds none). imageio and
Pillow are imported where they are used, so that ``import napari_labyrinth.io``
stays quick.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .._budget import declared_refusal, pillow_header
from ..provenance import KEY, to_json
from ._errors import ImageFileError, refuse_unaffordable_file
from .metadata import ImageMetadata, read_record

#: PIL image modes (PNG, JPEG, BMP) read as colour, with what the mode means.
_PIL_COLOUR_MODES = {
    "RGB": "RGB",
    "RGBA": "RGBA",
    "LA": "grey + alpha",
    "PA": "palette + alpha",
    "P": "palette",
}


#: PIL image modes read as grey; a mode in neither table (CMYK, YCbCr) is refused.
_PIL_GREY_MODES = ("1", "L", "I", "I;16", "I;16B")


#: PNG colour types (the IHDR chunk's; PNG specification, section 11.2.2), in words.
_PNG_COLOUR_TYPES = {0: "grey", 2: "RGB", 3: "palette", 4: "grey + alpha", 6: "RGBA"}


#: The EXIF orientation tag, and the orientations whose transformation swaps rows and columns.
_EXIF_ORIENTATION = 0x0112
_EXIF_TRANSPOSING = (5, 6, 7, 8)


#: Units of ``ImageMetadata.resolution`` (tifffile's ``RESUNIT`` names, lower case) per inch.
_PER_INCH = {"inch": 1.0, "centimeter": 2.54, "millimeter": 25.4, "micrometer": 25400.0}


def read_pillow(path: Path, kind: str) -> np.ndarray:
    """The pixels of a PNG, JPEG or BMP file (``kind``), upright, refused before decoding if
    they need more memory than the run may use."""
    import imageio.v3 as iio

    refuse_unaffordable_file(path, declared_refusal(path, kind))
    with pillow_header(path) as header:
        mode, from_transparency = _pillow_mode(path, kind, header)
    # imageio's own conversions otherwise (palette to RGB, PNG "I" to uint16)
    return iio.imread(path, plugin="pillow", mode=mode if from_transparency else None, rotate=True)


def pillow_metadata(path: Path, kind: str) -> ImageMetadata:
    """What a PNG, JPEG or BMP file says about its pixels (see ``read_metadata``)."""
    with pillow_header(path) as image:  # past Pillow's size limit: the budget judges size
        stored = image.mode
        mode, from_transparency = _pillow_mode(path, kind, image)
        if kind == "PNG":
            text = getattr(image, "text", {}).get(KEY)
        elif kind == "JPEG":
            text = image.info.get("comment") or None
        else:
            text = None
        dpi = image.info.get("dpi")
        icc_profile = image.info.get("icc_profile") or None
        orientation = image.getexif().get(_EXIF_ORIENTATION, 1)
    if text is not None and kind == "JPEG" and not text.lstrip().startswith(b"{"):
        text = None  # a comment of another program
    colour = _PIL_COLOUR_MODES.get(mode)
    words = f"{kind} colour type {colour}" if colour else f"{kind} grey ({mode})"
    if from_transparency:
        read = _PIL_COLOUR_MODES.get(stored, f"grey ({stored})")
        words = f"{kind} {read} with a transparency chunk (tRNS), read as {colour}"
    resolution = None if dpi is None else (float(dpi[0]), float(dpi[1]), "inch")
    if orientation != 1:
        words += f"; EXIF orientation {orientation} applied (pixels read upright)"
        if resolution is not None and orientation in _EXIF_TRANSPOSING:
            resolution = (resolution[1], resolution[0], "inch")
    return ImageMetadata(
        axes="YXS" if colour else "YX",
        channel_axis=-1 if colour else None,
        colour=words,
        provenance=read_record(text, path),
        grey_alpha=mode == "LA",
        extra_samples=("unassalpha",) if mode in ("RGBA", "LA", "PA") else (),
        resolution=resolution,
        icc_profile=icc_profile,
    )


def write_pillow(
    handle, kind: str, suffix: str, array: np.ndarray, metadata: ImageMetadata | None
) -> None:
    """Write ``array`` with ``metadata`` as a PNG, JPEG or BMP file (``kind``, its file
    ``suffix``) into the open file ``handle``."""
    import imageio.v3 as iio

    options: dict[str, Any] = {"quality": 95} if kind == "JPEG" else {}
    resolution = None if metadata is None else metadata.resolution
    if resolution is not None and resolution[2] is not None:  # Pillow writes dots per inch
        per_inch = _PER_INCH[resolution[2]]
        options["dpi"] = (resolution[0] * per_inch, resolution[1] * per_inch)
    if metadata is not None and metadata.icc_profile is not None and kind in ("PNG", "JPEG"):
        options["icc_profile"] = metadata.icc_profile
    record = metadata.provenance if metadata is not None else None
    if record is not None and kind == "PNG":
        from PIL.PngImagePlugin import PngInfo

        options["pnginfo"] = PngInfo()
        options["pnginfo"].add_itxt(KEY, to_json(record))
    elif record is not None and kind == "JPEG":
        options["comment"] = to_json(record).encode()
    iio.imwrite(handle, np.ascontiguousarray(array), plugin="pillow", extension=suffix, **options)


def _pillow_mode(path: Path, kind: str, image) -> tuple[str, bool]:
    """The Pillow mode a PNG, JPEG or BMP file is read in, refusing what Pillow misreads.

    Parameters
    ----------
    path : Path
        The file, for error messages.
    kind : str
        Its format by suffix (``"PNG"``, ``"JPEG"``, ``"BMP"``); the
        format Pillow found decides the checks.
    image : PIL.Image.Image
        The file opened by Pillow (its header).

    Returns
    -------
    mode : str
        Pillow's mode of the file, or ``"RGBA"`` / ``"LA"`` for a PNG whose
        transparency chunk (``tRNS``: transparent palette entries, or one
        transparent grey level or colour) is read as an alpha channel.
    from_transparency : bool
        Whether ``mode`` is such a conversion (the pixels are read in it).

    Raises
    ------
    ImageFileError
        For a CMYK (or other unsupported mode) image, a 16-bit PNG that is
        not plain grey (Pillow reads those as 8 bits), and a transparent
        grey level that Pillow cannot read exactly (16-, 2- and 4-bit grey).
    """
    mode, found = image.mode, image.format or kind
    if mode == "CMYK":
        raise ImageFileError(
            path, f"is a CMYK {found} file; CMYK is not supported: convert it to RGB first"
        )
    if mode not in _PIL_COLOUR_MODES and mode not in _PIL_GREY_MODES:
        raise ImageFileError(
            path,
            f"is a {found} file in Pillow mode {mode}, which is not supported; "
            "convert it to grey or RGB first",
        )
    if found != "PNG":
        return mode, False
    depth, colour_type = _png_header(path)
    if depth == 16 and colour_type != 0:
        raise ImageFileError(
            path,
            f"is a 16-bit {_PNG_COLOUR_TYPES.get(colour_type, 'colour')} PNG, which Pillow "
            "reads only as 8 bits; convert it to a 16-bit TIFF first",
        )
    if image.info.get("transparency") is None:
        return mode, False
    if colour_type == 0 and depth != 8 and mode != "1":
        # Pillow compares the key with the grey levels scaled to 8 bits (2, 4-bit)
        # or cuts them to 8 bits (16-bit) to make the alpha channel
        raise ImageFileError(
            path,
            f"is a {depth}-bit grey PNG with a transparent grey level (tRNS), which Pillow "
            "cannot read exactly; convert it to a grey + alpha TIFF or 8-bit PNG first",
        )
    return ("RGBA" if mode in ("P", "RGB") else "LA"), True


def _png_header(path: Path) -> tuple[int, int | None]:
    """Bit depth and colour type of a PNG file, from its IHDR chunk (8 and None if unreadable).

    The PNG specification fixes where they are: the IHDR chunk comes first,
    after the 8-byte signature, and holds width, height (4 bytes each), bit
    depth and colour type (1 byte each).
    """
    with open(path, "rb") as file:
        head = file.read(26)
    if len(head) < 26 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return 8, None  # Pillow read a header: let it say what it found
    return head[24], head[25]
