"""
Finding V: the window of the labyrinth
======================================

The labyrinth appears only in a window of the variance threshold V, and where it lies
depends on the image. :func:`~napari_labyrinth.find_window` renders a probe of the image
(crops drawn from strata of local contrast) at V from 0.0025 to 0.32, measures at each V
the labyrinth's cover, the alignment of its walls with the contours and the edge
enhancement, and takes, among the V whose walls run along the contours and cover at least
90 % of the best such cover, the V of the best edge enhancement; ``window.choice`` says
why. ``labyrinth(image, variance_threshold="auto")`` chooses the same V.
"""

import matplotlib.pyplot as plt
from _display import show_grid
from skimage import data

from napari_labyrinth import find_window, labyrinth

image = data.camera()
window = find_window(image)
print(window.summary())

figure, axes = plt.subplots(figsize=(6, 3.2), dpi=100, layout="constrained")
axes.semilogx(window.thresholds, window.edge_enhancement, "o-", label="edge enhancement")
axes.semilogx(window.thresholds, window.cover, "s-", label="labyrinth cover")
axes.axvspan(window.low, window.high, color="0.85", label="window")
axes.axvline(window.best, color="C3", lw=1, label=window.choice)
axes.set_xlabel("variance threshold V")
axes.set_ylabel("probe")
axes.legend(frameon=False, fontsize="small")

# %%
# The rendering below the window, in it, and above it: below, the walls flood the smooth
# regions; above, they fade.

crop = image[100:356, 150:406]
values = [window.thresholds[0], window.best, window.thresholds[-1]]
renderings = [labyrinth(crop, variance_threshold=value, seed=0) for value in values]
show_grid([[crop, *renderings]], labels=[["input"] + [f"V = {v:g}" for v in values]])
