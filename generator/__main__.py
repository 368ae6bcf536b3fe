"""`python -m ipgen` runs the ipgen command (CMake uses this: no dependence on PATH)."""

from ipgen.command.cli import main

if __name__ == "__main__":
    main()
