"""Labelled grids of grayscale images, for the study's contact sheets and the gallery."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

GAP = 6
LABEL_HEIGHT = 26
FONT_SIZE = 15


def to_uint8(image) -> np.ndarray:
    """A uint8 view of an image for display: uint8 as is, others min-max scaled."""
    image = np.asarray(image)
    if image.dtype == np.uint8:
        return image
    low, high = float(np.nanmin(image)), float(np.nanmax(image))
    scaled = (image.astype(np.float64) - low) / ((high - low) or 1.0)
    return np.rint(np.clip(scaled, 0, 1) * 255).astype(np.uint8)


def labelled_grid(
    rows: Sequence[Sequence[np.ndarray]],
    *,
    column_labels: Sequence[str] = (),
    row_labels: Sequence[str] = (),
    scale: int = 1,
    title: str = "",
) -> np.ndarray:
    """Arrange equal-sized grayscale cells in a grid with labels; returns uint8.

    Cells are upscaled ``scale`` times with nearest neighbours so that
    1-pixel walls stay visible.
    """
    from PIL import Image, ImageDraw, ImageFont

    font = ImageFont.load_default(size=FONT_SIZE)
    cell_h, cell_w = (n * scale for n in np.asarray(rows[0][0]).shape[:2])
    n_rows, n_cols = len(rows), max(len(row) for row in rows)
    left = max((int(font.getlength(text)) for text in row_labels), default=0)
    left = left + 2 * GAP if left else GAP
    top = (LABEL_HEIGHT if title else 0) + (LABEL_HEIGHT if column_labels else 0) + GAP
    width = left + n_cols * (cell_w + GAP)
    height = top + n_rows * (cell_h + GAP)
    canvas = Image.new("L", (width, height), 255)
    draw = ImageDraw.Draw(canvas)
    if title:
        draw.text((left, 4), title, fill=0, font=font)
    label_y = top - LABEL_HEIGHT + 4 - GAP // 2
    for j, text in enumerate(column_labels):
        draw.text((left + j * (cell_w + GAP), label_y), text, fill=0, font=font)
    for i, row in enumerate(rows):
        y = top + i * (cell_h + GAP)
        if i < len(row_labels):
            draw.text((GAP, y + cell_h // 2 - FONT_SIZE // 2), row_labels[i], fill=0, font=font)
        for j, cell in enumerate(row):
            pixels = np.kron(to_uint8(cell), np.ones((scale, scale), np.uint8))
            canvas.paste(Image.fromarray(pixels), (left + j * (cell_w + GAP), y))
    return np.asarray(canvas)
