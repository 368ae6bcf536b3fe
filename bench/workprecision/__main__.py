"""python -m bench.workprecision: see run.py."""

from bench.workprecision.run import main

main()
