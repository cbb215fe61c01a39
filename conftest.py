"""Repository-level pytest hook: doctests that need an optional extra skip without it.

``pip install -e ".[test]"`` installs neither torch nor matplotlib, and the README
promises that ``python -m pytest`` then passes. The modules import their extra
lazily, so their doctests are collected; a doctest that stops on the missing
extra (an ImportError of it, or sparseedm's error naming ``sparseedm[EXTRA]``)
is reported as skipped with a reason naming the extra, and the module's other
doctests still run.
"""

import doctest
import importlib.util

import pytest

#: extra -> the module it installs
EXTRAS = {"torch": "torch", "plot": "matplotlib", "dask": "distributed", "dlc": "pandas"}


def _have(module):
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def _missing_extra(exc):
    """The absent extra `exc` is about, or None."""
    for extra, module in EXTRAS.items():
        if _have(module):
            continue
        if isinstance(exc, ImportError) and (exc.name or "").split(".")[0] == module:
            return extra
        if f"sparseedm[{extra}]" in str(exc):
            return extra
    return None


def _skipping_missing_extras(item):
    runtest = item.runtest

    def run():
        try:
            runtest()
        except doctest.UnexpectedException as failure:
            extra = _missing_extra(failure.exc_info[1])
            if extra is None:
                raise
            pytest.skip(f"doctest {item.name} needs the [{extra}] extra: pip install -e \".[{extra}]\"")
    return run


def pytest_collection_modifyitems(config, items):
    if all(_have(m) for m in EXTRAS.values()):
        return
    for item in items:
        if type(item).__name__ == "DoctestItem":
            item.runtest = _skipping_missing_extras(item)
