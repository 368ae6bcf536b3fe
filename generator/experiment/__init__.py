"""A scene resolved into the experiment it describes: every default filled in, numbers as floats
with their decimal text kept (`scene`: the `Scene`, `load_scene`), and what is designed from them:
the [controller]'s gain (`feedback`), the [swingup]'s plan (`swingup`), the measured loop and its
estimator (`loop`); then written out for the simulator (`config`: the .cfg) and for a specialised
header (`specialisation`). The scene stage reads and checks the file; this one computes.
"""
