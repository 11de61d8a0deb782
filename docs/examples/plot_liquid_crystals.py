"""
Liquid-crystal textures
=======================

The textures liquid-crystal researchers see under a polarising microscope are what the
labyrinthine tiling evokes. :mod:`napari_labyrinth.samples` makes two of them: a nematic
film with point defects between crossed polarisers (Schlieren brushes), and the stripes of
a cholesteric whose helix lies in the plane of the film (a fingerprint texture). The same
samples are in napari's **File > Open Sample** menu.
"""

from _display import show_grid
from skimage import util

from napari_labyrinth import labyrinth, metrics, samples

textures = {
    "nematic Schlieren": samples.nematic_schlieren((320, 320), seed=0),
    "cholesteric fingerprint": samples.cholesteric_fingerprint((320, 320), seed=0, pitch=24),
}

rows, labels = [], []
for name, texture in textures.items():
    image = util.img_as_ubyte(texture)  # the samples are floats in [0, 1]
    rendered = labyrinth(image, seed=0)
    values = metrics.describe(image, rendered)
    print(name + ": " + ", ".join(f"{key} {value:.3g}" for key, value in values.items()))
    rows.append([image, rendered])
    labels.append([name, 'preset "labyrinth"'])
show_grid(rows, labels=labels, title="Nematic Schlieren and cholesteric fingerprint textures")
