"""What an image file says about its pixels: :class:`ImageMetadata`, and its words and units.

An :class:`ImageMetadata` holds the colour axis and samples, the axes (OME's
letters), the physical pixel sizes and their units, the time increment, the
channel names, the resolution, the ICC profile and the provenance record of
a file. Each format module reads it from its files and writes it back
(:mod:`.tiff`, :mod:`.pillow`, :mod:`.zarr`); this module holds the object
and what they share: unit names and symbols, channel names, the record.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..provenance import ProvenanceError, check, from_json
from ._errors import ImageFileError

#: Axis letters (tifffile's, OME's) of the spatial axes, which carry physical sizes.
SPATIAL_AXES = "ZYX"


@dataclasses.dataclass(frozen=True)
class ImageMetadata:
    """What an image file says about its pixels (see :func:`read_metadata`).

    Attributes
    ----------
    axes : str or None
        One letter per axis of the array, as tifffile and OME name them
        (``T`` time, ``Z`` depth, ``C`` channel, ``Y``, ``X``, ``S`` colour
        samples, ``Q`` other); None when the file does not say.
    channel_axis : int or None
        The colour axis the file declares (TIFF photometric RGB samples, a
        PNG/JPEG/BMP colour type), or None for a grey image or planes.
    colour : str
        How the colour was read, in words (``"TIFF photometric RGB"``), or
        ``""`` when the file says nothing about colour.
    pixel_sizes : dict
        Axis letter (``"X"``, ``"Y"``, ``"Z"``) -> ``(size, unit)``, the
        unit an OME-Zarr name (``"micrometer"``), the file's own word for a
        unit without one (an ImageJ ``unit`` such as ``"inch"``), or None.
    ome : bool
        Whether axes and pixel sizes come from OME metadata (OME-TIFF,
        OME-Zarr); an output given them is written as OME too.
    provenance : dict or None
        The provenance record of a rendering (:mod:`napari_labyrinth.provenance`).
    ambiguous : bool
        A last axis of 3 or 4 that no metadata names colour or not: it is
        read as planes, and ``channel_axis=-1`` reads it as colour.
    grey_alpha : bool
        A grey image with an alpha channel (the colour axis: grey, alpha).
    extra_samples : tuple of str
        What the colour axis holds after its grey or RGB samples, one
        TIFF extra sample each, as tifffile names them (lower case):
        ``"unassalpha"`` (alpha), ``"assocalpha"`` (alpha that the colours
        are premultiplied by) or ``"unspecified"``. A TIFF output stores
        them back.
    resolution : tuple or None
        ``(x, y, unit)``: pixels per unit along X and Y as the file states
        them (TIFF resolution tags, PNG ``pHYs``, JPEG or BMP density),
        ``unit`` one of ``"inch"``, ``"centimeter"`` (or tifffile's
        ``"millimeter"``, ``"micrometer"``) or None (an aspect ratio only);
        None when the file states none.
    imagej : bool
        Whether axes and pixel sizes come from an ImageJ hyperstack (a TIFF
        file of ImageJ or Fiji); a TIFF output given them is written as one
        too where ImageJ can hold it (see :func:`_imagej_options`).
    icc_profile : bytes or None
        The ICC colour profile the file embeds (a TIFF's InterColorProfile
        tag, a PNG's iCCP chunk, a JPEG's APP2 segments): the meaning of its
        values, which the rendering keeps. A TIFF, PNG or JPEG output embeds
        it again; a BMP or zarr output holds none.
    time_increment : tuple or None
        ``(interval, unit)``: the time between two planes along the ``T``
        axis, the unit an OME-Zarr name (``"second"``) or the file's own
        word: an OME-TIFF's ``TimeIncrement``, an OME-Zarr image's scale of
        its time axis; None when the file states none. A TIFF or zarr
        output states it again.
    channel_names : tuple of str
        The names of the channels (``"DAPI"``, ``"GFP"``), one for each
        plane along the ``C`` axis, or a single one for an image without
        one: an OME-TIFF's ``Channel`` names, an OME-Zarr image's ``omero``
        channel labels (or those this package writes beside the axes where
        OME cannot hold them); ``()`` when the file names none (or not
        all). A TIFF or zarr output names them again.
    image_name : str or None
        The name of the image: an OME-TIFF's ``Image`` ``Name``, an
        OME-Zarr image's ``multiscales`` ``name``, the OME image name or
        scene name bioio reads (not the ``Image:0`` it makes up); None when
        the file names none. A TIFF or zarr output names it again.
    scene : str or None
        The scene read from a file of several (bioio's name for it), None
        for a file the package reads itself.
    """

    axes: str | None = None
    channel_axis: int | None = None
    colour: str = ""
    pixel_sizes: dict = dataclasses.field(default_factory=dict)
    ome: bool = False
    provenance: dict | None = None
    ambiguous: bool = False
    grey_alpha: bool = False
    extra_samples: tuple[str, ...] = ()
    resolution: tuple[float, float, str | None] | None = None
    imagej: bool = False
    icc_profile: bytes | None = dataclasses.field(default=None, repr=False)
    channel_names: tuple[str, ...] = ()
    time_increment: tuple[float, str | None] | None = None
    image_name: str | None = None
    scene: str | None = None

    def for_output(self, extra_axis: str | None, provenance: dict | None) -> ImageMetadata:
        """The metadata of a rendering of this image.

        ``extra_axis`` is the letter of a leading axis the rendering adds
        (the passes of a stack, the values of a sweep), or None.
        """
        axes = self.axes
        if axes is not None and extra_axis is not None:
            axes = extra_axis + axes
        axis = self.channel_axis
        if axis is not None and extra_axis is not None and axis >= 0:
            axis += 1
        return dataclasses.replace(self, axes=axes, channel_axis=axis, provenance=provenance)

    def with_channel_axis(self, axis: int | None) -> ImageMetadata:
        """The metadata of this image read with the colour axis ``axis`` (None: planes).

        Where ``axis`` is another axis than the file's, the file's samples
        (extra samples, grey + alpha) describe it no longer, and that axis is
        the colour samples (``S``) of the axes, or another axis (``Q``) for
        the file's colour axis read as planes: an output stores the colour
        as it was rendered (an RGB TIFF, not planes of 3 pixels).
        """
        if axis == self.channel_axis:
            return self
        axes = self.axes
        if axes is not None:
            letters = ["Q" if letter == "S" else letter for letter in axes]
            if axis is not None:
                letters[axis % len(letters)] = "S"
            axes = "".join(letters)
        return dataclasses.replace(
            self,
            axes=axes,
            channel_axis=axis,
            colour="" if axis is None else f"read as colour along axis {axis}",
            ambiguous=False,
            grey_alpha=False,
            extra_samples=(),
        )

    def unrenderable_samples(self) -> str | None:
        """Why the colour axis cannot be rendered as the file describes it, or None.

        A rendering keeps at most one channel as it is, the last (alpha, or
        the fourth of four channels): an alpha extra sample among several
        would be rendered as a plane of data. The reason names the samples.
        """
        extra = self.extra_samples
        if len(extra) > 1 and any(sample in ALPHA_SAMPLES for sample in extra):
            return (
                f"its extra samples ({', '.join(extra)}) hold alpha beside other samples: a "
                "rendering keeps only one extra sample, the last, as it is; save the image "
                "with alpha as its only extra sample"
            )
        return None

    def kept_unspecified_sample(self) -> bool:
        """An RGB image with one extra sample that is not alpha (``"unspecified"``): as the
        fourth of four channels, a rendering keeps it as it is, as it keeps alpha."""
        rgb = self.colour.startswith(tiff_colour("RGB"))
        return rgb and self.extra_samples == ("unspecified",)


def read_record(text: Any, path: Path) -> dict | None:
    """The provenance record a file holds (JSON text, or a mapping), checked; None if none."""
    if text is None:
        return None
    try:
        if isinstance(text, (str, bytes)):
            return from_json(text)
        check(text)
        return dict(text)
    except ProvenanceError as exc:
        raise ImageFileError(path, str(exc)) from None


def is_ambiguous(shape: Sequence[int], channel_axis: int | None, axes: str | None) -> bool:
    """A last axis of 3 or 4 that no metadata names colour or not (see ``ImageMetadata``)."""
    return channel_axis is None and len(shape) >= 3 and shape[-1] in (3, 4) and not axes


def complete_names(names) -> tuple[str, ...]:
    """Channel names, all of them or none: ``()`` when one is missing or empty."""
    names = tuple(names)
    if not names or not all(isinstance(name, str) and name for name in names):
        return ()
    return names


#: The names readers and writers make up for an image without one (tifffile's ``Image0``,
#: bioio's ``Image:0``): never the image's own name.
_MADE_UP_IMAGE_NAME = re.compile(r"Image:?\d+")


def image_name(name: Any) -> str | None:
    """An image's name as a file states it, or None for none, an empty one or one made up."""
    if not isinstance(name, str) or not name or _MADE_UP_IMAGE_NAME.fullmatch(name):
        return None
    return name


def named_channels(metadata: ImageMetadata, shape: Sequence[int]) -> tuple[str, ...]:
    """The channel names an OME output of ``shape`` keeps: one for each plane along its C
    axis (one for an image without one), else none."""
    names, axes = metadata.channel_names, metadata.axes or ""
    count = int(shape[axes.index("C")]) if "C" in axes and len(axes) == len(shape) else 1
    return names if len(names) == count else ()


#: TIFF extra samples (tifffile's ``EXTRASAMPLE`` names, lower case) that are alpha.
ALPHA_SAMPLES = ("unassalpha", "assocalpha")


def tiff_colour(photometric: str) -> str:
    """How ``ImageMetadata.colour`` of a TIFF starts: its photometric interpretation."""
    return f"TIFF photometric {photometric}, "


#: OME-Zarr unit names and the OME-XML symbols of the same units.
_UNIT_SYMBOLS = {
    "angstrom": "Å",
    "nanometer": "nm",
    "micrometer": "µm",
    "millimeter": "mm",
    "centimeter": "cm",
    "meter": "m",
}


def unit_name(symbol: str | None) -> str | None:
    """The OME-Zarr name of an OME-XML length unit symbol (an unknown one as it is)."""
    names = {symbol: name for name, symbol in _UNIT_SYMBOLS.items()}
    return names.get(symbol, symbol)


def unit_symbol(name: str | None) -> str | None:
    """The OME-XML symbol of an OME-Zarr length unit name (an unknown one as it is)."""
    return _UNIT_SYMBOLS.get(name, name)


#: OME-Zarr's names of time units -> OME-TIFF's symbols (``TimeIncrementUnit``).
_TIME_UNIT_SYMBOLS = {
    "second": "s",
    "millisecond": "ms",
    "microsecond": "µs",
    "nanosecond": "ns",
    "minute": "min",
    "hour": "h",
    "day": "d",
}


def time_unit_name(symbol: str | None) -> str | None:
    """The OME-Zarr name of an OME-TIFF time unit symbol (an unknown one as it is)."""
    names = {symbol: name for name, symbol in _TIME_UNIT_SYMBOLS.items()}
    return names.get(symbol, symbol)


def time_unit_symbol(name: str | None) -> str | None:
    """The OME-TIFF symbol of an OME-Zarr time unit name (an unknown one as it is)."""
    return _TIME_UNIT_SYMBOLS.get(name, name)


def time_pair(value) -> tuple[float, str | None] | None:
    """A time increment as this package writes it beside the axes (``[interval, unit]``)."""
    if isinstance(value, list) and len(value) == 2 and isinstance(value[0], (int, float)):
        return float(value[0]), value[1] if isinstance(value[1], str) else None
    return None


#: ImageJ's spellings of units (``unit=`` of its description) -> the OME-Zarr name of the unit
#: (as in ``ImageMetadata.pixel_sizes``); the first spelling of a unit is the one written.
IMAGEJ_UNITS = {
    "um": "micrometer",
    "micron": "micrometer",
    "microns": "micrometer",
    "µm": "micrometer",
    "μm": "micrometer",
    "\\u00b5m": "micrometer",
    "nm": "nanometer",
    "mm": "millimeter",
    "cm": "centimeter",
    "m": "meter",
}
