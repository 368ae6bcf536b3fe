"""The version of ipgen: one place, read by the package, the generated files and the build."""

__version__ = "0.1.0"
