"""``napari-labyrinth render`` of one plane larger than memory: band by band, file to file.

A zarr store or TIFF file holding one grey plane whose rendering in memory
would need more than the run may use (``NAPARI_LABYRINTH_MEMORY``, else the
memory available) is rendered by :func:`napari_labyrinth.streaming.render_plane_file`
into a zarr or TIFF output, with the same record and metadata as any other
rendering; progress counts rows written.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np

from ..core.presets import DEFAULT_PRESET
from ..core.tone_scale import resolve_tone_scale
from ..io import ImageFileError, image_format
from ..provenance import file_checksum, input_record, rendering_record
from ..streaming import (
    band_plan,
    plane_noise_sigma,
    plane_tone_limits,
    render_plane_file,
    streamed_parameters,
)

#: Outputs a plane larger than memory is written to, a band of rows at a time.
STREAMED_OUTPUTS = ("ZARR", "TIFF")

#: The options of a rendering that are not parameters of the algorithm.
_NOT_PARAMETERS = ("preset", "seed", "tone_limits", "colour")


def render_streamed(
    input: Path, output: Path, plane, metadata, options: dict[str, Any], *, overwrite: bool,
    progress, note,
) -> None:  # fmt: skip
    """Render the plane of ``input`` (``streaming.streams``) into ``output`` band by band.

    ``options`` are the rendering's (``cli.options.render_options``), ``metadata`` the
    input's as rendered; ``progress(done, total, unit)`` and ``note(text)`` report.

    Raises
    ------
    ImageFileError
        For an output other than a zarr store or TIFF file.
    """
    kind = image_format(output)
    if kind not in STREAMED_OUTPUTS:
        raise ImageFileError(
            input,
            f"is a plane of {plane.shape[0]} x {plane.shape[1]} pixels, too large to render in "
            "memory here: it is rendered band by band into a .zarr or .tif output, not "
            f"{output.suffix or output.name}",
        )
    parameters = {k: v for k, v in options.items() if k not in _NOT_PARAMETERS}
    preset = options.get("preset", DEFAULT_PRESET)
    rendering = streamed_parameters(preset, **parameters)
    plan = band_plan(plane, rendering.passes)  # refused now, before a pass over the file
    rows = plan.read
    note(
        f"{input}: a plane of {plane.shape[0]} x {plane.shape[1]} {plane.dtype.name} pixels, "
        f"too large to render in memory here: rendered band by band (read {plan.read} rows, "
        f"rendered {plan.rendered}, written {plan.written} at a time)"
    )
    kwargs = dict(options)
    if "tone_limits" not in kwargs and plane.dtype.name != "uint8":
        note(
            f"{input}: finding the default tone limits (0.5th and 99.5th percentiles) in a "
            "pass over the data; --tone-limits skips it"
        )
        low, high = plane_tone_limits(plane, rows)
        kwargs["tone_limits"] = (low, high)
        note(f"{input}: tone limits {low!r} {high!r}")
    source = input_record(
        input, plane.shape, plane.dtype, file_checksum(input), scene=metadata.scene
    )
    limits = kwargs.get("tone_limits", (0.0, 255.0))
    sigma = None
    if rendering.noise_gate > 0:
        note(f"{input}: measuring the plane's noise for the noise gate in a pass over the data")
        scale = resolve_tone_scale(np.empty(0, plane.dtype), limits)
        sigma = plane_noise_sigma(plane, scale, rows)
    record = rendering_record(
        "single",
        kwargs,
        source=source,
        tone_limits=limits,
        noise_sigma=None if sigma is None else [sigma],
    )
    output.parent.mkdir(parents=True, exist_ok=True)
    render_plane_file(
        input,
        output,
        overwrite=overwrite,
        metadata=metadata.for_output(None, record),
        noise_sigma=sigma,
        progress=functools.partial(progress, unit="row"),
        **kwargs,
    )
