"""Errors the user can fix, in a module of their own so that the command can report them
without importing the (slower to load) modules that raise them.

Every such error is an `Error`: its message is one line saying what is wrong and how to fix it,
the same line the `ipgen` command prints after "ipgen: error: ".
"""

from __future__ import annotations


class Error(Exception):
    """Base of every error ipgen reports to its user (`ipgen.Error`): one line, what is wrong and
    how to fix it, the message the command prints.

    Examples
    --------
    >>> import ipgen
    >>> try:
    ...     ipgen.Pendulum("rotary", 1, m=[0.1, -0.024], l=[0.085, 0.129], delta=[0, 0])
    ... except ipgen.Error as error:
    ...     print(error)  # doctest: +ELLIPSIS
    m[1] = -0.024: ...
    """


class SceneError(Error):
    """A scene file that cannot be used; the message is one line: `<file>: <problem>`."""
