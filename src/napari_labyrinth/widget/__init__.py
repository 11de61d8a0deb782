"""What a widget run does, without napari or Qt: the plan (:mod:`.plan`), the run (:mod:`.run`)."""
