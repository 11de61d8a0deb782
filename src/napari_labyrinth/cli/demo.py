"""``napari-labyrinth demo``: render the built-in samples into a directory."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from ..api import Result, labyrinth_steps
from ..io import ImageMetadata, write_image
from ..provenance import file_checksum, input_record, rendering_record
from ..samples import SAMPLES
from ._common import (
    EXIT_FAILED,
    EXIT_OK,
    Refused,
    UsageError,
    cannot_write,
    describe,
    make_directory,
    print_error,
    print_output,
)
from .options import DEMO_STACK_PASSES

#: Samples the demo renders, in order.
DEMO_SAMPLES = ("nematic_schlieren", "camera")

#: Width in pixels of the white band between the panels of the demo's comparison.
SEPARATOR_WIDTH = 4

#: Height in pixels of the band above each panel of the comparison that holds its label.
LABEL_HEIGHT = 28


def demo_command(args: argparse.Namespace) -> int:
    """Run ``napari-labyrinth demo``; the exit code."""
    directory = Path(args.output)
    if directory.exists() and not directory.is_dir():
        raise UsageError(f"{directory} is not a directory")
    names = {
        sample: (
            directory / f"{sample}.png",
            directory / f"{sample}_labyrinth.png",
            directory / f"{sample}_labyrinth_stack.tif",
            directory / f"{sample}_comparison.png",
        )
        for sample in DEMO_SAMPLES
    }
    if not args.overwrite:
        existing = [p for paths in names.values() for p in paths if os.path.lexists(p)]
        if existing:
            raise Refused(
                *(
                    f"{p}: refusing to overwrite an existing file (use --overwrite)"
                    for p in existing
                )
            )
    make_directory(directory)
    for sample, (input_path, rendered_path, stack_path, comparison_path) in names.items():
        image = _to_uint8(SAMPLES[sample]())
        # The uint8 image is what is written and rendered, so that rendering
        # the written PNG with `napari-labyrinth render` gives the same result.
        if not _write(input_path, image, None, args.overwrite):
            return EXIT_FAILED
        # each rendering carries its provenance record, naming the input written above
        rendered, single = _render(input_path, image, "single", {})
        stack, stacked = _render(input_path, image, "stack", {"passes": DEMO_STACK_PASSES})
        comparison = _side_by_side(
            [image, stack[1], stack[DEMO_STACK_PASSES]],
            ["input", "1 pass", f"{DEMO_STACK_PASSES} passes"],
        )
        for path, data, record in (
            (rendered_path, rendered, single),
            (stack_path, stack, stacked),
            (comparison_path, comparison, None),
        ):
            if not _write(path, data, record, args.overwrite):
                return EXIT_FAILED
    return EXIT_OK


def _render(input_path: Path, image, mode: str, kwargs: dict):
    """The rendering of ``image`` (read from ``input_path``) and its provenance record."""
    for event in labyrinth_steps(image, mode, **kwargs):
        if isinstance(event, Result):
            source = input_record(input_path, image.shape, image.dtype, file_checksum(input_path))
            record = rendering_record(
                mode, kwargs, source=source, tone_limits=event.tone_limits,
                noise_sigma=event.noise_sigma,
            )  # fmt: skip
            return event.image, record
    raise AssertionError("labyrinth_steps ends with a Result")


def _write(path: Path, data, record, overwrite: bool) -> bool:
    """Write ``data`` (with its record) and print its path; False after an error message."""

    try:
        write_image(path, data, overwrite=overwrite, metadata=ImageMetadata(provenance=record))
    except (OSError, ValueError) as exc:
        print_error(cannot_write(exc, path) or f"{path}: {describe(exc, path)}")
        return False
    print_output(str(path.resolve()))
    return True


def _to_uint8(image):
    """uint8 copy of a sample: floats in [0, 1] scaled by 255, other types min-max scaled."""
    image = np.asarray(image)
    if image.dtype == np.uint8:
        return image
    if image.dtype.kind == "f":
        return np.rint(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)
    low, high = float(image.min()), float(image.max())
    scaled = (image.astype(np.float64) - low) / ((high - low) or 1.0)
    return np.rint(scaled * 255.0).astype(np.uint8)


def _side_by_side(panels, labels):
    """uint8 panels of equal height in a row, separated by thin white bands, each under
    its label."""
    panels = [_labelled(_to_uint8(panel), label) for panel, label in zip(panels, labels)]
    band = np.full((panels[0].shape[0], SEPARATOR_WIDTH), 255, dtype=np.uint8)
    row = []
    for index, panel in enumerate(panels):
        if index:
            row.append(band)
        row.append(panel)
    return np.hstack(row)


def _labelled(panel, label: str):
    """A grey uint8 panel under a white band holding ``label`` in black, centred."""
    from PIL import Image, ImageDraw, ImageFont

    band = Image.new("L", (panel.shape[1], LABEL_HEIGHT), 255)
    draw = ImageDraw.Draw(band)
    font = ImageFont.load_default(size=LABEL_HEIGHT * 2 // 3)
    left, top, right, bottom = draw.textbbox((0, 0), label, font=font)
    x = (panel.shape[1] - (right - left)) // 2 - left
    y = (LABEL_HEIGHT - (bottom - top)) // 2 - top
    draw.text((x, y), label, fill=0, font=font)
    return np.vstack([np.asarray(band), panel])
