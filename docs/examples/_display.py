"""Images side by side at one figure pixel per image pixel, labelled, for the gallery.

The labyrinth is a texture of 1-2 pixel walls: any resampling of the image (a figure's
axes a few pixels smaller than the image) would alias it. Each image here gets axes of
exactly its size (``scale`` times it, by nearest neighbours), placed in pixels.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

DPI = 100
GAP = 8  # pixels between images
LABEL = 24  # pixels of a label line above each image
TITLE = 30  # pixels of the title line


def show_grid(rows, *, labels=None, title="", scale=1):
    """A figure with one row of grey images per item of ``rows``.

    Parameters
    ----------
    rows : list of list of 2-D arrays
        The images, all of one shape, row by row.
    labels : list of list of str, optional
        A label above each image (same layout as ``rows``).
    title : str, optional
        A line above the grid.
    scale : int, optional
        Every image pixel is drawn as ``scale`` x ``scale`` figure pixels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    height, width = (scale * n for n in np.shape(rows[0][0])[:2])
    columns = max(len(row) for row in rows)
    top = TITLE if title else 0
    fig_w = GAP + columns * (width + GAP)
    fig_h = top + len(rows) * (LABEL + height + GAP)
    figure = plt.figure(figsize=(fig_w / DPI, fig_h / DPI), dpi=DPI)
    if title:
        figure.text(GAP / fig_w, 1 - (TITLE / 2) / fig_h, title, va="center", fontsize=11)
    for i, row in enumerate(rows):
        y = fig_h - top - (i + 1) * (LABEL + height + GAP) + GAP  # bottom edge, in pixels
        for j, image in enumerate(row):
            x = GAP + j * (width + GAP)
            axes = figure.add_axes((x / fig_w, y / fig_h, width / fig_w, height / fig_h))
            limits = (0, 255) if np.asarray(image).dtype == np.uint8 else (None, None)
            axes.imshow(
                image, cmap="gray", interpolation="nearest", vmin=limits[0], vmax=limits[1]
            )
            axes.set_axis_off()
            if labels:
                axes.set_title(labels[i][j], fontsize=9, pad=4)
    return figure
