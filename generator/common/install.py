"""How to install what a feature needs, said the same way in every message (issue 49).

ipgen-pendulum is installed from its checkout (`pip install ./`), not from a package index, so a
hint `pip install 'ipgen-pendulum[identify]'` fails in a fresh virtualenv ("No matching
distribution"). Each hint here names what works there: the packages themselves, from PyPI, or the
extra from the checkout (`pip install './[identify]'`, run in the checkout).
"""

from __future__ import annotations

__all__ = ["PACKAGES", "REINSTALL", "install_hint"]

# What each optional feature imports, as pip requirements (pyproject.toml's extras list them too).
PACKAGES: dict[str, tuple[str, tuple[str, ...]]] = {
    # feature: (the extra of pyproject.toml that has it, its requirements)
    "casadi": ("identify", ("casadi",)),
    "pillow": ("swingup", ("pillow",)),
    "gymnasium": ("gym", ("gymnasium",)),
    "dask": ("dask", ("'dask[distributed]'",)),
}

# A package whose own files are missing (a broken or partial installation).
REINSTALL = "reinstall ipgen from its checkout: pip install ./ (run there; PyPI's `ipgen` is another project)"


def install_hint(feature: str) -> str:
    """The command that installs `feature`'s packages ("casadi", "pillow", "gymnasium", "dask"),
    with the checkout's extra as the alternative.

    Parameters
    ----------
    feature : str
        A key of `PACKAGES`.

    Returns
    -------
    str
        E.g. ``pip install casadi (or, in ipgen's checkout, pip install './[identify]')``.

    Examples
    --------
    >>> install_hint("gymnasium")
    "pip install gymnasium (or, in ipgen's checkout, pip install './[gym]')"
    """
    extra, requirements = PACKAGES[feature]
    return f"pip install {' '.join(requirements)} (or, in ipgen's checkout, pip install './[{extra}]')"
