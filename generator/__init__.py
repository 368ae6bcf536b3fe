"""ipgen: equations of motion for n-link inverted pendulums."""

__version__ = "0.1.0"


def __getattr__(name: str) -> object:
    """Lazy public API: `ipgen.linearize` and `ipgen.lqr` (control.py) import numpy and scipy on
    first use only, so that the ipgen command starts fast."""
    if name in ("linearize", "lqr"):
        from ipgen import control

        return getattr(control, name)
    raise AttributeError(f"module 'ipgen' has no attribute {name!r}")
