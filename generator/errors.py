"""Errors the user can fix, in a module of their own so that the command can report them
without importing the (slower to load) modules that raise them."""

from __future__ import annotations


class SceneError(Exception):
    """A scene file that cannot be used; the message is one line: `<file>: <problem>`."""
