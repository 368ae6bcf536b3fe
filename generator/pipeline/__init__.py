"""The stages put together, as library functions: the work of `ipgen` (generation), `ipgen run`,
`ipgen identify` and `ipgen excite`. The command stage (generator/command/) parses their arguments
and prints, and the Python API (`ipgen.write_header`, `ipgen.identify`, `ipgen.excitation`, sweeps)
calls the same functions. (`ipgen plot` and `ipgen animate` only call plots/.)

    job.py        a generation job: options or a scene, validated in one place
    generate.py   derive once, render every requested target, write them all or none
    simulator.py  a scene's simulator, compiled once per model content and cached
    run.py        a scene through its simulator: .cfg, CSV, PNG, summary
    identify.py   fit a scene to measurements and write the estimates, the report, the plot
    excite.py     design the identification experiment and write its scene
"""
