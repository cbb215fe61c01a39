"""Optional extras checked before any work: a missing one is a clear error at once.

``pip install sparseedm`` leaves out matplotlib (``[plot]``), dask.distributed
(``[dask]``) and torch (``[torch]``); a command that will need one checks it
first, so that it does not fail after minutes of adaptation.

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

#: extra -> (the module it installs, how to install it)
EXTRAS = {
    "plot": ("matplotlib", "pip install 'sparseedm[plot]'"),
    "dask": ("distributed", "pip install 'sparseedm[dask]'"),
    "torch": ("torch", "on a CPU machine `pip install torch==2.13.0` first, then "
              "`pip install 'sparseedm[torch]'`"),
}


def have(extra) -> bool:
    """Whether `extra`'s module can be imported (found, not imported: fast)."""
    if extra not in EXTRAS:
        raise SparseEDMError(f"unknown extra {extra!r}")
    try:
        return importlib.util.find_spec(EXTRAS[extra][0]) is not None
    except (ImportError, ValueError):
        return False


def require(extra, what):
    """Raise :class:`SparseEDMError` saying that `what` needs `extra`, unless installed."""
    if not have(extra):
        module, install = EXTRAS[extra]
        raise SparseEDMError(f"{what} needs {module} (the sparseedm[{extra}] extra): "
                             f"{install}")
