"""The solver layer: one public ``solve`` that validates, then calls ``_solve``.

Every backend solves, for each row x of X, the lasso

    min_c  0.5 * ||x - D c||^2 + alpha * ||c||_1        (c >= 0 if positive)

with D of shape (n_features, n_components) (atoms as columns), and returns a
:class:`LassoResult` of the same form, with the duality gap computed here by
one shared function so that backends are judged by the same certificate.

Duality gap
-----------
With residual r = x - D c, the point theta = r / max(1, ||D^T r||_inf / alpha)
(for positive codes, max(D^T r) in place of the sup-norm) is dual feasible and

    gap = P(c) - (0.5 ||x||^2 - 0.5 ||x - theta||^2) >= P(c) - P(c*) >= 0,

so the gap is an upper bound on the sub-optimality of c: a certificate.

The registry of backends by name (:func:`get_solver`, :data:`SOLVERS`) lives here
too, at the end: the fallback solver is found through it, and the package
``__init__`` only re-exports it.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

import numpy as np

from ..exceptions import SparseEDMError

__all__ = ["LassoResult", "BaseSolver", "lasso_objective", "duality_gap"]

#: Status strings every backend uses.
OPTIMAL = "optimal"
INACCURATE = "inaccurate"
FAILED = "failed"
#: LassoResult's per-row arrays a fallback replaces
_FIELDS = ("coef", "objective", "gap", "status", "n_iter")


@dataclass
class LassoResult:
    """The answer of one solve over a batch of signals.

    Parameters
    ----------
    coef : ndarray, shape (n_samples, n_components)
    objective : ndarray, shape (n_samples,)
        ``0.5 ||x - D c||^2 + alpha ||c||_1`` at `coef`.
    gap : ndarray, shape (n_samples,)
        Duality gap at `coef`: an upper bound on ``objective - optimum``.
    status : ndarray of str, shape (n_samples,)
        ``"optimal"`` when ``gap <= tol * max(objective, tiny)``,
        ``"inaccurate"`` otherwise, ``"failed"`` if the backend gave up.
    n_iter : ndarray of int, shape (n_samples,)
        Backend-specific iteration count (interior-point iterations, LARS steps).
    fallback : ndarray of bool, shape (n_samples,)
        True where the backend handed the row to its fallback solver.
    support : ndarray of int, shape (n_samples, s), optional
        Columns that hold every non-zero coefficient of each row that did not
        fall back (a backend that knows them, e.g. a working set, says so and
        spares its callers a scan of `coef`); None: unknown.
    """

    coef: np.ndarray
    objective: np.ndarray
    gap: np.ndarray
    status: np.ndarray
    n_iter: np.ndarray
    fallback: np.ndarray = None
    support: np.ndarray = None

    def __post_init__(self):
        if self.fallback is None:
            self.fallback = np.zeros(len(self.objective), dtype=bool)


def lasso_objective(D, X, coef, alpha):
    """``0.5 ||x - D c||^2 + alpha ||c||_1`` for each row (vectorised).

    Parameters
    ----------
    D : ndarray, shape (d, k)
        Atoms as columns (as every solver takes them).
    X : ndarray, shape (n, d)
        Signals.
    coef : ndarray, shape (n, k)
        Codes.
    alpha : float or ndarray, shape (n,)
        Penalty (per row).

    Returns
    -------
    ndarray, shape (n,)
        The objectives.
    """
    R = X - coef @ D.T
    return 0.5 * np.einsum("ij,ij->i", R, R) + alpha * np.abs(coef).sum(axis=1)


def duality_gap(D, X, coef, alpha, positive=False, observed=None):
    """Primal objective and duality gap for each row, as documented above.

    `alpha` may be one value per row. With `observed` (bool, the shape of X),
    row i is judged on its observed entries only -- the lasso of
    ``D[observed[i]]`` and ``X[i, observed[i]]`` -- so one call certifies rows
    of many sub-dictionaries of one D.

    Parameters
    ----------
    D : ndarray, shape (d, k)
        Atoms as columns (as every solver takes them).
    X : ndarray, shape (n, d)
        Signals.
    coef : ndarray, shape (n, k)
        Codes.
    alpha : float or ndarray, shape (n,)
        Penalty (per row).
    positive : bool
        Non-negative codes.
    observed : ndarray of bool, shape (n, d), optional
        Entries of each signal the problem sees (all by default).

    Returns
    -------
    objective, gap : ndarray, shape (n,)
        Each row's primal objective and duality gap.

    Examples
    --------
    >>> import numpy as np
    >>> D = np.eye(2); X = np.array([[3.0, 0.5]])
    >>> primal, gap = duality_gap(D, X, np.array([[2.0, 0.0]]), alpha=1.0)
    >>> bool(gap[0] < 1e-12)   # soft-thresholding is the exact optimum here
    True
    """
    R = X - coef @ D.T
    if observed is not None:
        X = np.where(observed, X, 0.0)
        R = np.where(observed, R, 0.0)
    corr = R @ D
    dual_norm = corr.max(axis=1) if positive else np.abs(corr).max(axis=1)
    shrink = np.maximum(1.0, np.maximum(dual_norm, 0.0) / alpha)
    theta = R / shrink[:, None]
    primal = 0.5 * np.einsum("ij,ij->i", R, R) + alpha * np.abs(coef).sum(axis=1)
    dual = 0.5 * np.einsum("ij,ij->i", X, X) - 0.5 * np.einsum(
        "ij,ij->i", X - theta, X - theta
    )
    return primal, np.maximum(primal - dual, 0.0)


class BaseSolver:
    """Base class: validate once, let the backend solve, certify the result.

    Parameters
    ----------
    tol : float, default 1e-6
        Relative duality-gap tolerance: a row is "optimal" when
        ``gap <= tol * objective``.

    Notes
    -----
    A backend with ``refine = True`` and a ``_refiner`` (the function that
    finishes rows from the backend's own answer, e.g. the feature-sign search
    of :mod:`._active_set`) has every row the certificate rejects finished by
    it first (the rows it certifies become "optimal"). A backend
    with a ``fallback`` attribute (a solver name or instance) has every row
    still rejected re-solved by that solver; those rows are flagged in
    ``LassoResult.fallback``.
    """

    name = "base"
    fallback = None
    #: finish rejected rows by ``_refiner`` before any fallback
    refine = False
    #: ``_refiner(D, X, coef, alpha, rows, positive=..., observed=...)`` returns
    #: the finished coefficients of `rows` (:func:`._active_set.refine_rows`)
    _refiner = None

    def __init__(self, tol=1e-6):
        self.tol = tol

    def solve(self, D, X, alpha, *, positive=False, key=None):
        """Solve the lasso for every row of X.

        Parameters
        ----------
        D : ndarray, shape (n_features, n_components)
            The (sub-)dictionary, atoms as columns.
        X : ndarray, shape (n_samples, n_features)
        alpha : float > 0
        positive : bool, default False
            Restrict codes to c >= 0.
        key : hashable, optional
            Identifies D for backends that cache per-dictionary work (a
            compiled problem, a Gram matrix); equal keys must mean equal D.

        Returns
        -------
        LassoResult
        """
        D = np.asarray(D, dtype=float)
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if D.ndim != 2:
            raise SparseEDMError(f"D must be 2-D (n_features, n_components), got {D.shape}")
        if X.ndim != 2 or X.shape[1] != D.shape[0]:
            raise SparseEDMError(
                f"X must have shape (n_samples, {D.shape[0]}), got {X.shape}"
            )
        if not (np.isfinite(D).all() and np.isfinite(X).all()):
            raise SparseEDMError("D and X must be finite (no NaN or inf)")
        if not np.isscalar(alpha) or not alpha > 0:
            raise SparseEDMError(f"alpha must be a number > 0, got {alpha!r}")
        coef, status, n_iter = self._solve(D, X, float(alpha), bool(positive), key)
        return self._certify(D, X, coef, status, n_iter, float(alpha), bool(positive), key)

    def solve_masked(self, D, X, observed, alpha, *, positive=False, key=None):
        """Solve, for each row, the lasso on its observed entries only.

        Row i is the lasso of ``D[observed[i]]`` and ``X[i, observed[i]]``
        with penalty ``alpha[i]``: what :meth:`solve` gives on each pattern's
        sub-dictionary, in one call for rows of many patterns. Backends that
        can work from ``D`` itself (the fast one: a Gram downdate from one
        cached ``D^T D``) override ``_solve_masked``; the default solves each
        pattern's rows with ``_solve``. One certificate per row, as in
        :meth:`solve`; ``key`` identifies D.

        Parameters
        ----------
        D : ndarray, shape (n_features, n_components)
        X : ndarray, shape (n_samples, n_features)
            Values at unobserved entries are ignored (may be NaN).
        observed : ndarray of bool, shape (n_samples, n_features)
        alpha : float or ndarray, shape (n_samples,)
        positive : bool, default False
        key : hashable, optional

        Returns
        -------
        LassoResult

        Examples
        --------
        >>> import numpy as np
        >>> from sparseedm.solvers import get_solver
        >>> rng = np.random.default_rng(0)
        >>> D = rng.standard_normal((6, 10)); X = rng.standard_normal((2, 6))
        >>> obs = np.ones((2, 6), bool); obs[1, 2] = False
        >>> solver = get_solver("clarabel")
        >>> res = solver.solve_masked(D, X, obs, 0.5)
        >>> one = solver.solve(D[obs[1]], X[1:, obs[1]], 0.5)
        >>> bool(abs(res.objective[1] - one.objective[0]) < 1e-6 * one.objective[0])
        True
        """
        D, X, observed, alpha = self._check_masked(D, X, observed, alpha)
        positive = bool(positive)
        coef, status, n_iter = self._solve_masked(D, X, observed, alpha, positive, key)
        return self._certify(D, X, coef, status, n_iter, alpha, positive, key, observed)

    @staticmethod
    def _check_masked(D, X, observed, alpha):
        """:meth:`solve_masked`'s arguments checked: (D, X zeroed where unobserved,
        observed, alpha per row)."""
        D = np.asarray(D, dtype=float)
        X = np.atleast_2d(np.asarray(X, dtype=float))
        observed = np.atleast_2d(np.asarray(observed, dtype=bool))
        if D.ndim != 2 or not np.isfinite(D).all():
            raise SparseEDMError(f"D must be 2-D and finite, got shape {D.shape}")
        if X.ndim != 2 or X.shape[1] != D.shape[0] or observed.shape != X.shape:
            raise SparseEDMError(
                f"X and observed must have shape (n_samples, {D.shape[0]}), got "
                f"{X.shape} and {observed.shape}"
            )
        X = np.where(observed, X, 0.0)
        if not np.isfinite(X).all():
            raise SparseEDMError("X must be finite at its observed entries")
        alpha = np.broadcast_to(np.asarray(alpha, dtype=float), (len(X),)).copy()
        if not (alpha > 0).all():
            raise SparseEDMError(f"alpha must be > 0, got {alpha[~(alpha > 0)][:1]}")
        return D, X, observed, alpha

    def _solve_masked(self, D, X, observed, alpha, positive, key):
        """Default: each (pattern, alpha) group's rows through ``_solve``."""
        return self._by_pattern(D, X, observed, alpha, key,
                                lambda Ds, Xs, a, sub_key, rows: self._solve(Ds, Xs, a, positive,
                                                                             sub_key))

    @staticmethod
    def _by_pattern(D, X, observed, alpha, key, solve_group):
        """(coef, status, n_iter) with ``solve_group(D_sub, X_sub, alpha, key, rows)``
        run on each (pattern, alpha) group of rows."""
        n = len(X)
        coef = np.zeros((n, D.shape[1]))
        status = np.empty(n, dtype=object)
        n_iter = np.zeros(n, dtype=int)
        for rows, obs in _pattern_groups(observed, alpha):
            sub_key = None if key is None else (key, obs.tobytes())
            c, st, it = solve_group(D[obs], X[rows][:, obs], float(alpha[rows[0]]), sub_key, rows)
            coef[rows], status[rows], n_iter[rows] = c, st, it
        return coef, status, n_iter

    def _certify(self, D, X, coef, status, n_iter, alpha, positive, key, observed=None):
        """The shared certificate on every row, then the fallback for the rejected."""
        objective, gap = duality_gap(D, X, coef, alpha, positive, observed)
        status = np.asarray(status, dtype=object)
        certified = gap <= self.tol * np.maximum(objective, np.finfo(float).tiny)
        status = np.where(
            status == FAILED, FAILED, np.where(certified, OPTIMAL, INACCURATE)
        ).astype(object)
        result = LassoResult(coef, objective, gap, status, np.asarray(n_iter))
        if self.refine and self._refiner is not None:
            self._refine(result, D, X, alpha, positive, observed)
        bad = result.status != OPTIMAL
        if self.fallback is not None and bad.any():
            if observed is None:
                self._fall_back(result, bad, D, X, alpha, positive, key)
            else:  # per pattern, on its sub-dictionary
                rows_bad = np.flatnonzero(bad)
                for rows, obs in _pattern_groups(observed[rows_bad], alpha[rows_bad]):
                    idx = rows_bad[rows]
                    sub = LassoResult(*(getattr(result, name)[idx] for name in _FIELDS))
                    sub_key = None if key is None else (key, obs.tobytes())
                    self._fall_back(sub, np.ones(len(idx), dtype=bool), D[obs], X[idx][:, obs],
                                    float(alpha[idx[0]]), positive, sub_key)
                    for name in _FIELDS:
                        getattr(result, name)[idx] = getattr(sub, name)
                    result.fallback[idx] = True
        return result

    def _refine(self, result, D, X, alpha, positive, observed):
        """``_refiner`` on the rows the certificate rejected, in place; the rows
        it certifies become optimal."""
        rows = np.flatnonzero(result.status == INACCURATE)
        if not len(rows):
            return
        coef = self._refiner(D, X, result.coef, alpha, rows, positive=positive,
                             observed=observed)
        a = alpha if np.isscalar(alpha) else np.asarray(alpha)[rows]
        objective, gap = duality_gap(D, X[rows], coef, a, positive,
                                     None if observed is None else observed[rows])
        ok = gap <= self.tol * np.maximum(objective, np.finfo(float).tiny)
        idx = rows[ok]
        result.coef[idx] = coef[ok]
        result.objective[idx], result.gap[idx] = objective[ok], gap[ok]
        result.status[idx] = OPTIMAL

    def _fall_back(self, result, bad, D, X, alpha, positive, key):
        """Re-solve the uncertified rows with the fallback solver, in place."""
        backup = (get_solver(self.fallback, tol=self.tol) if isinstance(self.fallback, str)
                  else get_solver(self.fallback))
        res = backup.solve(D, X[bad], alpha, positive=positive, key=key)
        for name in _FIELDS:
            getattr(result, name)[bad] = getattr(res, name)
        result.fallback[bad] = True

    def _solve(self, D, X, alpha, positive, key):  # pragma: no cover - abstract
        """Return (coef, status, n_iter) for validated inputs."""
        raise NotImplementedError


def _pattern_groups(observed, alpha):
    """(rows, observed entries) of each group of rows sharing a pattern and an alpha."""
    keys = np.concatenate([observed.astype(float), alpha[:, None]], axis=1)
    _, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind="stable")
    bounds = np.flatnonzero(np.diff(inverse[order])) + 1
    for rows in np.split(order, bounds):
        yield rows, observed[rows[0]]


#: name -> (module, class); modules are imported lazily by :func:`get_solver`.
_REGISTRY = {
    "clarabel": ("sparseedm.solvers.clarabel", "ClarabelSolver"),
    "cvxpy-naive": ("sparseedm.solvers.reference", "NaiveCvxpySolver"),
    "fast": ("sparseedm.solvers.fast", "FastSolver"),
    "local-ridge": ("sparseedm.solvers.local_ridge", "LocalRidgeSolver"),
}

#: Names :func:`get_solver` accepts.
SOLVERS = tuple(_REGISTRY)


def get_solver(name_or_instance="clarabel", **kwargs):
    """A solver from its name, or the given :class:`BaseSolver` unchanged.

    Parameters
    ----------
    name_or_instance : str or BaseSolver
        One of :data:`SOLVERS`, or an instance (returned as is; passing
        keyword arguments with an instance is an error).
    **kwargs
        Passed to the solver's constructor (e.g. ``tol``).

    Returns
    -------
    BaseSolver
        The solver.

    Raises
    ------
    SparseEDMError
        Unknown name (the message lists the known ones), or a backend whose
        module cannot be imported.
    """
    if isinstance(name_or_instance, BaseSolver):
        if kwargs:
            raise SparseEDMError(
                "solver options cannot be applied to an existing solver instance; "
                f"got {sorted(kwargs)} with {type(name_or_instance).__name__}"
            )
        return name_or_instance
    if not isinstance(name_or_instance, str) or name_or_instance not in _REGISTRY:
        raise SparseEDMError(
            f"unknown solver {name_or_instance!r}; known solvers: " + ", ".join(SOLVERS)
        )
    module_name, class_name = _REGISTRY[name_or_instance]
    try:
        module = importlib.import_module(module_name)
        cls = getattr(module, class_name)
    except (ImportError, AttributeError) as exc:
        raise SparseEDMError(
            f"solver {name_or_instance!r} is not available: cannot import "
            f"{module_name}.{class_name} ({exc})"
        ) from exc
    return cls(**kwargs)
