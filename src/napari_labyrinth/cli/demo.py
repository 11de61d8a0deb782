"""``napari-labyrinth demo``: render the built-in samples into a directory."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from . import EXIT_FAILED, EXIT_OK, Refused, UsageError, describe, make_directory, print_error

#: Samples the demo renders, in order.
DEMO_SAMPLES = ("nematic_schlieren", "camera")

#: Passes of the stack the demo writes.
DEMO_STACK_PASSES = 4

#: Width in pixels of the white band between the panels of the demo's comparison.
SEPARATOR_WIDTH = 4


def demo_command(args: argparse.Namespace) -> int:
    """Run ``napari-labyrinth demo``; the exit code."""
    from ..api import labyrinth, labyrinth_stack
    from ..io import write_image
    from ..samples import SAMPLES

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
        rendered = labyrinth(image)
        stack = labyrinth_stack(image, passes=DEMO_STACK_PASSES)
        comparison = _side_by_side([image, stack[1], stack[DEMO_STACK_PASSES]])
        for path, data in (
            (input_path, image),
            (rendered_path, rendered),
            (stack_path, stack),
            (comparison_path, comparison),
        ):
            try:
                write_image(path, data, overwrite=args.overwrite)
            except (OSError, ValueError) as exc:
                print_error(f"{path}: {describe(exc, path)}")
                return EXIT_FAILED
            print(path.resolve(), flush=True)
    return EXIT_OK


def _to_uint8(image):
    """uint8 copy of a sample: floats in [0, 1] scaled by 255, other types min-max scaled."""
    import numpy as np

    image = np.asarray(image)
    if image.dtype == np.uint8:
        return image
    if image.dtype.kind == "f":
        return np.rint(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)
    low, high = float(image.min()), float(image.max())
    scaled = (image.astype(np.float64) - low) / ((high - low) or 1.0)
    return np.rint(scaled * 255.0).astype(np.uint8)


def _side_by_side(panels):
    """uint8 panels of equal height in a row, separated by thin white bands."""
    import numpy as np

    height = panels[0].shape[0]
    band = np.full((height, SEPARATOR_WIDTH), 255, dtype=np.uint8)
    row = []
    for index, panel in enumerate(panels):
        if index:
            row.append(band)
        row.append(_to_uint8(panel))
    return np.hstack(row)
