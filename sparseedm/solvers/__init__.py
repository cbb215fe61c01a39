"""The lasso layer: one public ``solve`` (in :mod:`.base`), one module per backend.

Backends by name (:data:`SOLVERS`):

* ``"clarabel"`` -- :class:`~sparseedm.solvers.clarabel.ClarabelSolver`
  (Clarabel interior point on small working sets, certified on the full lasso);
* ``"cvxpy-naive"`` -- :class:`~sparseedm.solvers.reference.NaiveCvxpySolver`
  (a fresh cvxpy problem per signal: the reference);
* ``"fast"`` -- ``sparseedm.solvers.fast.FastSolver`` (numba LARS), imported
  only when asked for.

Examples
--------
>>> from sparseedm.solvers import get_solver, SOLVERS
>>> SOLVERS
('clarabel', 'cvxpy-naive', 'fast')
>>> get_solver("clarabel", tol=1e-7).tol
1e-07
"""

from __future__ import annotations

from .base import SOLVERS, BaseSolver, LassoResult, duality_gap, get_solver, lasso_objective

__all__ = [
    "SOLVERS",
    "get_solver",
    "BaseSolver",
    "LassoResult",
    "duality_gap",
    "lasso_objective",
]
