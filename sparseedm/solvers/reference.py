"""The naive cvxpy reference: a fresh problem per signal, default solver settings.

It is what agreement tests and benchmarks compare faster backends against:
no caching, no parameters, no tuning, nothing clever to get wrong.
"""

from __future__ import annotations

import numpy as np

from .base import FAILED, INACCURATE, OPTIMAL, BaseSolver

__all__ = ["NaiveCvxpySolver"]

_STATUS = {"optimal": OPTIMAL, "optimal_inaccurate": INACCURATE}


class NaiveCvxpySolver(BaseSolver):
    """Lasso by cvxpy, building ``0.5 sum_squares(x - D c) + alpha norm1(c)`` anew per row.

    Parameters
    ----------
    tol : float, default 1e-6
        Certificate tolerance (see :class:`~sparseedm.solvers.base.BaseSolver`).
    solver : str or None, default "CLARABEL"
        cvxpy solver name, used with its default settings. Not cvxpy's own
        choice (None): for this QP cvxpy 1.9 picks OSQP, whose default
        answer is only ~1e-5 relatively accurate (the shared certificate
        marks it "inaccurate"), too loose for a reference.
    solver_opts : dict, optional
        Extra keyword arguments for ``Problem.solve`` (e.g. tighter tolerances
        for a high-accuracy reference).

    Examples
    --------
    >>> import numpy as np
    >>> res = NaiveCvxpySolver().solve(np.eye(2), [[3.0, 0.5]], alpha=1.0)
    >>> (np.round(res.coef, 6) + 0.0).tolist(), res.status.tolist()
    ([[2.0, 0.0]], ['optimal'])
    """

    name = "cvxpy-naive"

    def __init__(self, tol=1e-6, *, solver="CLARABEL", solver_opts=None):
        super().__init__(tol=tol)
        self.solver = solver
        self.solver_opts = dict(solver_opts or {})

    def _solve(self, D, X, alpha, positive, key):
        import cvxpy as cp

        n, k = X.shape[0], D.shape[1]
        coef = np.zeros((n, k))
        status = np.empty(n, dtype=object)
        n_iter = np.zeros(n, dtype=int)
        for i in range(n):
            c = cp.Variable(k, nonneg=positive)
            problem = cp.Problem(
                cp.Minimize(0.5 * cp.sum_squares(X[i] - D @ c) + alpha * cp.norm1(c))
            )
            try:
                problem.solve(solver=self.solver, **self.solver_opts)
            except cp.error.SolverError:
                status[i] = FAILED
                continue
            if c.value is None or not np.isfinite(c.value).all():
                status[i] = FAILED
                continue
            coef[i] = c.value
            status[i] = _STATUS.get(problem.status, FAILED)
            n_iter[i] = problem.solver_stats.num_iters or 0
        return coef, status, n_iter
