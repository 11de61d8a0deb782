"""The ``napari-labyrinth`` command: render image files, or write a demo.

::

    napari-labyrinth render INPUT... -o OUTPUT [options]
    napari-labyrinth reproduce OUTPUT [--input INPUT]
    napari-labyrinth demo [-o DIR] [--overwrite]
    napari-labyrinth --version

Heavy modules (numba, tifffile, imageio, tqdm, scikit-image, dask) are
imported only when a command needs them, so ``--help`` answers at once.
Nothing here imports napari or Qt: the command runs without a display.

zarr stores and large TIFF stacks are rendered lazily, block by block (see
``io.open_image`` and ``io.write_array``), locally or on a
``dask.distributed`` cluster (``--scheduler``).

The modules import one way: :mod:`~napari_labyrinth.cli._common` (exit
codes, errors, output, interrupts) <- :mod:`~napari_labyrinth.cli.options`
(the render flags, from the parameter table) <- the commands
(:mod:`~napari_labyrinth.cli.render`, :mod:`~napari_labyrinth.cli.reproduce`,
:mod:`~napari_labyrinth.cli.demo`) <- :mod:`~napari_labyrinth.cli.main` (the
parser and :func:`main`).
"""

from ._common import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_TERMINATED, EXIT_USAGE, PROG
from .main import main

__all__ = [
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_TERMINATED",
    "EXIT_USAGE",
    "PROG",
    "main",
]
