"""
Fig. 5: branching structures
============================

The paper's Fig. 5 renders a tree: the main branches are enhanced and the small details
suppressed. Retinal vessels (scikit-image's ``retina``, its green channel, where the
vessels contrast best) and a rocket on its launch tower stand in for it.
"""

from _display import show_grid
from skimage import color, data, transform, util

from napari_labyrinth import labyrinth

retina = data.retina()[..., 1]
retina = util.img_as_ubyte(transform.resize(retina, (480, 480), anti_aliasing=True))[
    100:420, 80:400
]
rocket = util.img_as_ubyte(color.rgb2gray(data.rocket()))[60:380, 120:440]

rows, labels = [], []
for name, image in (("retina", retina), ("rocket", rocket)):
    rows.append([image, labyrinth(image, seed=0)])
    labels.append([name, 'preset "labyrinth"'])
show_grid(rows, labels=labels, title="Main branches enhanced, small details suppressed")
