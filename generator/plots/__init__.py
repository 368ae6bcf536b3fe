"""Pictures of runs (matplotlib, imported on use): the animated GIF of a simulator CSV drawn to
scale and the PNG of a plan against a closed-loop run (`animation`)."""
