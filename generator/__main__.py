"""`python -m ipgen` runs the ipgen command (CMake uses this: no dependence on PATH)."""

import sys

try:
    from ipgen.cli import main
except KeyboardInterrupt:  # Ctrl-C while importing (sympy takes a while): nothing was written yet
    sys.stderr.write("ipgen: interrupted; no file was written\n")
    sys.exit(130)

if __name__ == "__main__":
    main()
