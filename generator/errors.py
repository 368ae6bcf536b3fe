"""Errors the user can fix, in a module of their own so that the command can report them
without importing the (slower to load) modules that raise them.

Every such error is an `Error`: its message is one line saying what is wrong and how to fix it,
the same line the `ipgen` command prints after "ipgen: error: ".
"""

from __future__ import annotations


class Error(Exception):
    """Base of every error ipgen reports to its user (`ipgen.Error`)."""


class SceneError(Error):
    """A scene file that cannot be used; the message is one line: `<file>: <problem>`."""
