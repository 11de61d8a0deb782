"""The algorithm, with numpy and numba only: the parameter table, presets, the kernel and its oracle.

Nothing here imports the rest of the package, dask, zarr, Qt or napari.
"""
