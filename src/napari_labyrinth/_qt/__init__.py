"""The napari plugin's Qt layer: the only part of the package that imports napari or Qt.

It holds no algorithm and no plan (:mod:`napari_labyrinth.widget` decides what a
run does): it lays out the widget, reads the user's choices and a snapshot of
the input layer, runs the plan's generator in a napari thread worker and adds
the layer it hands back.
"""
