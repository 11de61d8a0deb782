import os
import tempfile

# napari and Qt write settings and caches here: keep them out of the user's home.
_scratch = tempfile.mkdtemp(prefix="napari-labyrinth-tests-")
os.environ.setdefault("XDG_CONFIG_HOME", os.path.join(_scratch, "config"))
os.environ.setdefault("XDG_CACHE_HOME", os.path.join(_scratch, "cache"))

# The widget starts a process that compiles numba's kernels into their cache
# (napari_labyrinth._warmup); the tests compile in process and test it apart.
os.environ.setdefault("NAPARI_LABYRINTH_NO_WARMUP", "1")
