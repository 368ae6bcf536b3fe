"""Robustness sweeps (`ipgen sweep`; `ipgen.sweep`, this package `ipgen.sweeps`): a scene run over
levels of its keys.

A sweep is a list of criteria (`spec.Criterion`), each a list of levels, each level a set of
scene-key overrides run `repeat` times with explicit seeds. A run is a pure function of (scene
text, overrides, seed) (`execute.run_one`): the overrides are applied to the scene's TOML document
in memory (`overrides.py`), the plant changes while the controller stays the one designed on the
nominal scene (unless a [controller]/[swingup] key is swept), and the cached simulator runs it.
Runs go through `concurrent.futures` (`engine.py`: a local process pool or a Dask cluster), the
table of runs is written as they finish (`table.py`, resumable), then scored (`scores.py`) and
drawn (`plots.py`). docs/sweep.md is the user's guide.
"""
