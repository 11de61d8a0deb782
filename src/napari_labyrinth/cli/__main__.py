"""``python -m napari_labyrinth.cli``: the ``napari-labyrinth`` command."""

import sys

from . import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
