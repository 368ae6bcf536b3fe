"""ipgen: equations of motion for n-link inverted pendulums."""

__version__ = "0.1.0"
