"""`python -m generator` runs the ipgen command (CMake uses this: no dependence on PATH)."""

from generator.cli import main

if __name__ == "__main__":
    main()
