"""Repository-level pytest hook: the FConv doctests need the optional torch extra."""

import importlib.util


def _have_torch():
    try:
        return importlib.util.find_spec("torch") is not None
    except (ImportError, ValueError):
        return False


# without torch the sparseedm.fconv doctests are not collected (tests/test_fconv.py
# skips itself with a reason, beyond its torch-free import check)
collect_ignore_glob = [] if _have_torch() else ["sparseedm/fconv/*.py"]
