"""The lasso layer: one public ``solve`` (in :mod:`.base`), one module per backend.

Backends by name (:data:`SOLVERS`):

* ``"clarabel"`` -- :class:`~sparseedm.solvers.clarabel.ClarabelSolver`
  (Clarabel interior point on small working sets, certified on the full lasso);
* ``"cvxpy-naive"`` -- :class:`~sparseedm.solvers.reference.NaiveCvxpySolver`
  (a fresh cvxpy problem per signal: the reference);
* ``"fast"`` -- :class:`~sparseedm.solvers.fast.FastSolver` (numba LARS, its
  kernels compiled on first use);
* ``"local-ridge"`` -- :class:`~sparseedm.solvers.local_ridge.LocalRidgeSolver`
  (not the lasso: a ridge code on each row's most correlated atoms, the
  ``recover(preset="fast")`` coder).

:func:`gram_matrix` holds a dictionary's Gram matrix once per process (by
content); :func:`clear_gram_cache` lets it go.

Examples
--------
>>> from sparseedm.solvers import get_solver, SOLVERS
>>> SOLVERS
('clarabel', 'cvxpy-naive', 'fast', 'local-ridge')
>>> get_solver("clarabel", tol=1e-7).tol
1e-07
"""

from __future__ import annotations

from .base import SOLVERS, BaseSolver, LassoResult, duality_gap, get_solver, lasso_objective
from .clarabel import ClarabelSolver
from .fast import FastSolver
from .gram import clear_gram_cache, gram_matrix
from .local_ridge import LocalRidgeSolver
from .reference import NaiveCvxpySolver

__all__ = [
    "SOLVERS",
    "get_solver",
    "BaseSolver",
    "LassoResult",
    "duality_gap",
    "lasso_objective",
    "ClarabelSolver",
    "FastSolver",
    "LocalRidgeSolver",
    "NaiveCvxpySolver",
    "gram_matrix",
    "clear_gram_cache",
]
