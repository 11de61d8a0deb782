"""What a TIFF output stores beside its pixels: ``tifffile.imwrite``'s options.

Colour samples as the input had them, resolution, ICC profile, and the axes,
pixel sizes and provenance record as OME-XML, as an ImageJ hyperstack, or in
tifffile's JSON description, whichever of them can hold the image
(:func:`tiff_options`). tifffile is imported where it is used, so that
``import napari_labyrinth.io`` stays quick.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..provenance import KEY, to_json
from .metadata import (
    IMAGEJ_UNITS,
    SPATIAL_AXES,
    ImageMetadata,
    named_channels,
    time_unit_symbol,
    unit_symbol,
)


def tiff_options(shape: Sequence[int], dtype: Any, metadata: ImageMetadata | None) -> dict:
    """Keyword arguments of ``tifffile.imwrite``: the samples, resolution and metadata.

    Colour samples where the input had them, as it had them (see
    :func:`_tiff_samples`); OME-XML (axes, physical sizes, the record as a
    ``CommentAnnotation``) when the metadata come from OME and tifffile can
    write the axes as OME; an ImageJ hyperstack when they come from ImageJ
    and ImageJ can hold the image (see :func:`_imagej_options`); otherwise
    tifffile's JSON description with the record, and the axes and pixel
    sizes if known (an OME or ImageJ input whose axes or dtype the format
    cannot hold keeps them there, and its resolution in the TIFF tags).
    """
    dtype = np.dtype(dtype)
    if metadata is None:
        rgb = len(shape) >= 3 and shape[-1] in (3, 4) and dtype.kind in "uif"
        options: dict[str, Any] = {"photometric": "rgb" if rgb else "minisblack"}
    else:
        options = _tiff_samples(shape, metadata)
    if metadata is not None and metadata.resolution is not None:
        x, y, unit = metadata.resolution
        options.update(resolution=(x, y), resolutionunit=(unit or "none").upper())
    if metadata is not None and metadata.icc_profile is not None:
        options["iccprofile"] = metadata.icc_profile
    record = None if metadata is None else metadata.provenance
    if metadata is not None and metadata.ome and metadata.axes and ome_tiff_ok(metadata, shape):
        ome: dict[str, Any] = {"axes": metadata.axes}
        if metadata.image_name is not None:
            ome["Name"] = metadata.image_name
        for letter, (size, unit) in metadata.pixel_sizes.items():
            ome[f"PhysicalSize{letter}"] = size
            if unit is not None:
                ome[f"PhysicalSize{letter}Unit"] = unit_symbol(unit)
        if names := named_channels(metadata, shape):
            ome["Channel"] = {"Name": list(names)}
        if metadata.time_increment is not None and "T" in metadata.axes:
            interval, unit = metadata.time_increment
            ome["TimeIncrement"] = interval
            if unit is not None:
                ome["TimeIncrementUnit"] = time_unit_symbol(unit)
        if record is not None:
            ome["CommentAnnotation"] = {"Namespace": KEY, "Value": to_json(record)}
        options.update(ome=True, metadata=ome)
    elif (
        metadata is not None
        and metadata.imagej
        and (imagej := _imagej_options(shape, dtype, metadata, options))
    ):
        options.update(imagej)
    else:
        description: dict[str, Any] = {} if record is None else {KEY: record}
        if metadata is not None and metadata.axes and len(metadata.axes) == len(shape):
            description["axes"] = metadata.axes  # tifffile reads it back as the series' axes
            if metadata.pixel_sizes:
                description["pixel_sizes"] = {k: list(v) for k, v in metadata.pixel_sizes.items()}
            if names := named_channels(metadata, shape):
                description["channel_names"] = list(names)
            if metadata.time_increment is not None and "T" in metadata.axes:
                description["time_increment"] = list(metadata.time_increment)
        if metadata is not None and metadata.image_name is not None:
            description["image_name"] = metadata.image_name
        options.update(ome=False, metadata=description)
    return options


def _tiff_samples(shape: Sequence[int], metadata: ImageMetadata) -> dict:
    """``photometric``, ``planarconfig`` and ``extrasamples`` of a TIFF output.

    The colour axis (RGB or grey, then the extra samples) is stored as
    samples per pixel: contiguous when it is the last axis, planar when it
    is the third from last (as tifffile reads them); anything else is grey
    planes.
    """
    axis, ndim = metadata.channel_axis, len(shape)
    if axis is None or axis % ndim not in (ndim - 1, ndim - 3):
        return {"photometric": "minisblack"}
    extra = metadata.extra_samples
    if not extra and (shape[axis] == 4 or metadata.grey_alpha):  # alpha, as the API reads it
        extra = ("unassalpha",)
    colours = shape[axis] - len(extra)
    if colours not in (1, 3) or (colours, extra) == (1, ()):
        return {"photometric": "minisblack"}
    options: dict[str, Any] = {
        "photometric": "rgb" if colours == 3 else "minisblack",
        "planarconfig": "contig" if axis % ndim == ndim - 1 else "separate",
    }
    if extra:
        options["extrasamples"] = list(extra)
    return options


def _imagej_options(
    shape: Sequence[int], dtype: np.dtype, metadata: ImageMetadata, options: dict
) -> dict | None:
    """``tifffile.imwrite`` options of an ImageJ hyperstack, or None if ImageJ cannot hold it.

    The axes are ImageJ's (``TZCYXS``, in that order); a leading ``Q`` (the
    passes of a stack, the values of a sweep) becomes ``T`` when there is no
    ``T``. The pixel sizes are one unit, X and Y as the resolution (when
    the metadata state none), Z as ``spacing``; the record is the
    ``napari_labyrinth`` entry of ``Properties``. None, and the caller
    writes a JSON description, for other axes (a ``Q`` beside a ``T``),
    pixel sizes in several units, a dtype ImageJ does not store (tifffile
    writes uint8, uint16, int16 and float32) and colour samples other than
    contiguous uint8 RGB. The other ImageJ entries of an input (display
    mode, ranges and colour tables, labels, frame interval, ROIs) are not
    kept.
    """
    import tifffile

    axes = metadata.axes
    if not axes or len(axes) != len(shape):
        return None
    if axes[0] == "Q" and "T" not in axes:
        axes = "T" + axes[1:]
    rgb = (
        options["photometric"] == "rgb"
        and options.get("planarconfig") == "contig"
        and "extrasamples" not in options
        and dtype == np.uint8
    )
    if dtype.char not in "BHhf" or ("S" in axes) != rgb:
        return None
    try:
        tifffile.imagej_description(shape, axes=axes)  # checks the axes, their order, samples
    except ValueError:
        return None
    units = {unit for _, unit in metadata.pixel_sizes.values()}
    if len(units) > 1 or not set(metadata.pixel_sizes) <= set(SPATIAL_AXES):
        return None
    entries: dict[str, Any] = {"axes": axes}
    if "Z" in metadata.pixel_sizes:
        entries["spacing"] = metadata.pixel_sizes["Z"][0]
    if units and None not in units:
        (unit,) = units
        entries["unit"] = next((k for k, v in IMAGEJ_UNITS.items() if v == unit), unit)
    if metadata.provenance is not None:
        entries["Properties"] = {KEY: to_json(metadata.provenance)}
    written = {"imagej": True, "ome": False, "metadata": entries}
    if metadata.resolution is None and {"X", "Y"} <= set(metadata.pixel_sizes):
        x, y = metadata.pixel_sizes["X"][0], metadata.pixel_sizes["Y"][0]
        written.update(resolution=(1.0 / x, 1.0 / y), resolutionunit="NONE")
    return written


def ome_tiff_ok(metadata: ImageMetadata, shape: Sequence[int]) -> bool:
    """Whether tifffile can write these axes as OME-XML (else a JSON description)."""
    from tifffile import OmeXml, OmeXmlError

    try:
        xml = OmeXml()
        storedshape = (1, 1, 1, int(shape[-2]), int(shape[-1]), 1)
        if metadata.axes.endswith("S"):
            storedshape = (1, 1, 1, int(shape[-3]), int(shape[-2]), int(shape[-1]))
        pages = int(np.prod(shape[: -3 if metadata.axes.endswith("S") else -2]))
        storedshape = (pages,) + storedshape[1:]
        xml.addimage("uint8", tuple(shape), storedshape, axes=metadata.axes)
    except (OmeXmlError, ValueError):
        return False
    return len(metadata.axes) == len(shape)
