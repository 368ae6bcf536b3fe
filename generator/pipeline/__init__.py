"""Each command's work as a library function, the stages put together: the command stage
(generator/command/) only parses arguments and prints, and the Python API (`ipgen.write_header`,
`ipgen.identify`, `ipgen.excitation`, sweeps) calls the same functions.

    job.py        a generation job: options or a scene, validated in one place
    generate.py   derive once, render every requested target, write them all or none
    simulator.py  a scene's simulator, compiled once per model content and cached
    run.py        a scene through its simulator: .cfg, CSV, PNG, summary
    identify.py   fit a scene to measurements and write the estimates, the report, the plot
    excite.py     design the identification experiment and write its scene
"""
