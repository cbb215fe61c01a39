"""Optional extras checked before any work: a missing one is a clear error at once.

``pip install sparseedm`` leaves out matplotlib (``[plot]``), dask.distributed
(``[dask]``), torch (``[torch]``) and pandas with PyTables (``[dlc]``, for
DeepLabCut ``.h5`` files); a command that will need one checks it first, so
that it does not fail after minutes of adaptation.

>>> from sparseedm._extras import require
>>> require("nonexistent-extra", "this")
Traceback (most recent call last):
...
sparseedm.exceptions.SparseEDMError: unknown extra 'nonexistent-extra'
"""

from __future__ import annotations

import importlib.util

from .exceptions import SparseEDMError

__all__ = ["EXTRAS", "have", "require"]

#: extra -> (the module(s) it installs, how to install it)
EXTRAS = {
    "plot": ("matplotlib", "pip install 'sparseedm[plot]'"),
    "dask": ("distributed", "pip install 'sparseedm[dask]'"),
    "torch": ("torch", "on a CPU machine `pip install torch==2.13.0` first, then "
              "`pip install 'sparseedm[torch]'`"),
    "dlc": (("pandas", "tables"), "pip install 'sparseedm[dlc]' (pandas and PyTables)"),
}


def _modules(extra):
    """The module names `extra` installs."""
    if extra not in EXTRAS:
        raise SparseEDMError(f"unknown extra {extra!r}")
    module = EXTRAS[extra][0]
    return (module,) if isinstance(module, str) else module


def have(extra) -> bool:
    """Whether `extra`'s modules can be imported (found, not imported: fast).

    >>> have("plot") in (True, False)
    True
    """
    modules = _modules(extra)  # an unknown extra: an error, not "not installed"
    try:
        return all(importlib.util.find_spec(m) is not None for m in modules)
    except (ImportError, ValueError):
        return False


def require(extra, what):
    """Raise :class:`SparseEDMError` saying that `what` needs `extra`, unless installed."""
    if not have(extra):
        install = EXTRAS[extra][1]
        raise SparseEDMError(f"{what} needs {' and '.join(_modules(extra))} (the "
                             f"sparseedm[{extra}] extra): {install}")
