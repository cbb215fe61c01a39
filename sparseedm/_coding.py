"""What the masked lasso's callers share: the sparse recovery kernel
(:mod:`sparseedm._recovery_kernel`) and the dictionary lifter
(:mod:`sparseedm.lifting.dictionary`) both sort rows by missing pattern (a
backend that works per pattern sees whole groups) and key the solver's Gram
cache by the dictionary's atoms; their chunks come from
:func:`sparseedm._parallel.chunk_tasks`.

Their alpha scaling stays with each caller: the two round the same rule
``alpha * m_obs / m`` in a different order, and each one's answers are
frozen in tests.
"""

from __future__ import annotations

import numpy as np

from .solvers.gram import atoms_key

__all__ = ["pattern_order", "atoms_key"]


def pattern_order(mask):
    """Row indices sorting `mask` (n, N) by missing pattern, stably.

    Examples
    --------
    >>> pattern_order(np.array([[True, False], [False, False], [True, False]])).tolist()
    [1, 0, 2]
    """
    return np.lexsort(mask.T[::-1])
