"""A local ridge code: Tikhonov regularisation on each row's nearest atoms.

Not the lasso
-------------
This backend solves a different convex problem from the other solvers. For
each row x with observed entries M (a diagonal 0/1 mask), it takes the
working set S of the K atoms most correlated with the observed entries (score
``(x_M . a_M) / ||a_M||``, the cosine of the observed parts up to the row's
norm) and solves the ridge problem on those atoms alone:

    min_c  0.5 * ||M (x - A_S c)||^2 + 0.5 * mu * sum_j w_j c_j^2,
    mu = lam * trace(A_S^T M A_S) / K,
    w_j = (1 - cos_j)^power / mean over S of (1 - cos)^power,

with cos_j the cosine between the observed parts of x and of atom j: the
farther an atom, the more its coefficient costs (``power=0``: the plain ridge,
every w_j = 1). Its normal equations ``(A_S^T M A_S + mu W) c = A_S^T M x``
are solved exactly (a K x K system per row, batched). The code has exactly K non-zeros
(fewer only by rounding to zero); atoms outside S get 0. The weight mu is
relative to the working set's mean squared observed atom norm, so `lam` does
not depend on the atoms' scale.

With a first pass (``first_atoms``), that problem is first solved on the
row's `first_atoms` most correlated atoms, and its fit fills the row's
unobserved entries; S is then the K atoms of highest cosine with the whole
filled row among its :data:`REFINE_POOL` most correlated by the observed
entries, and cos_j those cosines (the fit is still on the observed entries
alone). The observed entries alone can rank first an atom that matches them
but not the hidden rest of the pose; the filled row ranks atoms on the whole
pose. On CMU validation files it lowered the error by 6-8 % at K = 64 (a first
pass of 32 atoms) and by 3-4 % at K = 48 (16), for 5-20 % more time
(``studies/fast/README.md``).

Over a file's own complete poses as atoms (``recover(preset="fast")``) this is
a nearest-exemplar interpolation, several times faster than the exact lasso
over thousands of atoms (whose support is spread over the whole dictionary);
with ``power=3`` it was about as accurate on CMU validation files
(``studies/fast/README.md``).

What it reports
---------------
The :class:`~.base.LassoResult` of every backend, for the ridge problem above:
``objective`` its value at the code (on the observed entries), ``gap`` the
normal equations' residual ``||(A_S^T M A_S + mu W) c - A_S^T M x||``
relative to ``||A_S^T M x||`` (the gradient of that strongly convex problem:
0 at its unique optimum up to rounding), ``status`` ``"optimal"`` when the gap
is at most `tol`, ``n_iter`` K. Signed codes only (``positive=True`` is
refused).

One guard: a row whose fill, at an unobserved entry, leaves the envelope of
its working set's atoms (each scaled to the row) by more than its width
(:func:`outside_envelope`) is an extrapolation its neighbours do not support,
typically an ill-conditioned system on few observed entries (on Bonn PoseTrack
validation photos under real missing patterns, 2 rows of 500 filled joints
thousands of body sizes away). That row is solved again with the ridge weight
10 times larger, up to 4 times (its objective and gap are then those of the
larger weight); a row still outside is coded by the lasso
(:class:`~.fast.FastSolver`, with the `alpha` given and its certificate) and
``fallback`` is True for it; the lasso's `alpha` is otherwise unused.
"""

from __future__ import annotations

import numpy as np

from ..exceptions import SparseEDMError
from .base import INACCURATE, OPTIMAL, BaseSolver, LassoResult
from .fast import FastSolver

__all__ = ["LocalRidgeSolver", "local_ridge_codes", "outside_envelope", "penalty_weights",
           "working_sets", "observed_scores", "scoring_arrays", "ENVELOPE_MARGIN",
           "REFINE_POOL"]

_TINY = np.finfo(float).tiny

#: A fill further outside its neighbours' envelope than this times its width
#: sends the row to the lasso (:func:`outside_envelope`)
ENVELOPE_MARGIN = 1.0

#: With a first pass, the working set is refined among each row's REFINE_POOL
#: atoms most correlated with its observed entries (on the CMU validation files
#: of ``studies/fast/select_fast.py``, K = 64: 128, 256, 512 and every atom gave
#: 1.135 / 0.927, 1.130 / 0.922, 1.127 / 0.920, 1.125 / 0.919 % Err_ave; the
#: search over every atom costs a second scoring product)
REFINE_POOL = 256

#: Such a row is solved again with the ridge weight times ESCALATION_FACTOR,
#: up to ESCALATIONS times, before the lasso codes it
ESCALATION_FACTOR, ESCALATIONS = 10.0, 4


class LocalRidgeSolver(BaseSolver):
    """Ridge codes on each row's `n_atoms` most correlated atoms (not the lasso).

    Parameters
    ----------
    n_atoms : int, default 64
        K, the atoms of each row's working set (all atoms when there are fewer).
    lam : float > 0, default 1e-3
        The ridge weight relative to the working set's mean squared observed
        atom norm.
    power : float >= 0, default 0
        Each coefficient's penalty grows as ``(1 - cos)^power`` of its atom
        (0: the plain ridge).
    tol : float, default 1e-6
        A row is "optimal" when its relative normal-equation residual is at most
        `tol`.
    block : int, default 256
        Rows solved together (memory: about ``block * (k + 2 K m + K^2)`` floats).
    first_atoms : int >= 1, optional
        A first pass: each row's ridge code on its `first_atoms` most correlated
        atoms fills its unobserved entries; the working set is then the K atoms
        of highest cosine with the whole filled row (among its
        :data:`REFINE_POOL` most correlated), and those cosines weight the
        penalty (the fit is still on the observed entries). None: no first
        pass.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.solvers import get_solver
    >>> rng = np.random.default_rng(0)
    >>> D = np.abs(rng.standard_normal((6, 40))); X = np.abs(rng.standard_normal((3, 6)))
    >>> obs = np.ones((3, 6), bool); obs[1, 2] = False
    >>> res = get_solver("local-ridge", n_atoms=4).solve_masked(D, X, obs, 0.1)
    >>> (res.coef != 0).sum(axis=1), list(res.status)
    (array([4, 4, 4]), ['optimal', 'optimal', 'optimal'])
    """

    name = "local-ridge"

    def __init__(self, n_atoms=64, lam=1e-3, tol=1e-6, block=256, power=0.0,
                 first_atoms=None):
        super().__init__(tol=tol)
        if not (isinstance(n_atoms, (int, np.integer)) and n_atoms >= 1):
            raise SparseEDMError(f"n_atoms must be an integer >= 1, got {n_atoms!r}")
        if not (np.isscalar(lam) and lam > 0):
            raise SparseEDMError(f"lam must be a number > 0, got {lam!r}")
        if not (np.isscalar(power) and power >= 0):
            raise SparseEDMError(f"power must be a number >= 0, got {power!r}")
        if not (isinstance(block, (int, np.integer)) and block >= 1):
            raise SparseEDMError(f"block must be an integer >= 1, got {block!r}")
        if not (first_atoms is None or (isinstance(first_atoms, (int, np.integer))
                                        and first_atoms >= 1)):
            raise SparseEDMError(f"first_atoms must be None or an integer >= 1, got "
                                 f"{first_atoms!r}")
        self.n_atoms, self.lam, self.block = int(n_atoms), float(lam), int(block)
        self.power = float(power)
        self.first_atoms = None if first_atoms is None else int(first_atoms)

    def solve(self, D, X, alpha=1.0, *, positive=False, key=None):
        """:meth:`solve_masked` with every entry observed."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return self.solve_masked(D, X, np.ones(X.shape, dtype=bool), alpha,
                                 positive=positive, key=key)

    def solve_masked(self, D, X, observed, alpha=1.0, *, positive=False, key=None):
        """The ridge code of each row on its observed entries and working set.

        Parameters
        ----------
        D : ndarray, shape (n_features, n_components)
            Atoms as columns.
        X : ndarray, shape (n_samples, n_features)
            Values at unobserved entries are ignored (may be NaN).
        observed : ndarray of bool, shape (n_samples, n_features)
        alpha : float or ndarray, optional
            Checked as the lasso's (> 0) and ignored.
        positive : bool, default False
            True is refused: the ridge code is signed.
        key : hashable, optional
            Ignored (nothing is cached).

        Returns
        -------
        LassoResult
            As described in the module docstring (the ridge problem's objective
            and relative normal-equation residual).
        """
        D, X, observed, alpha = self._check_masked(D, X, observed, alpha)
        if positive:
            raise SparseEDMError("the local-ridge solver's codes are signed: positive=True "
                                 "needs a lasso solver ('fast' or 'clarabel')")
        n = len(X)
        K = min(self.n_atoms, D.shape[1])
        coef = np.zeros((n, D.shape[1]))
        support = np.zeros((n, K), dtype=np.intp)
        objective, gap = np.zeros(n), np.zeros(n)
        atoms = np.ascontiguousarray(D.T)
        scoring = scoring_arrays(atoms)
        todo = np.arange(n)
        for step in range(ESCALATIONS + 1):  # a stronger ridge for the extrapolating rows
            outside = np.zeros(len(todo), dtype=bool)
            for start in range(0, len(todo), self.block):
                rows = todo[start:start + self.block]
                # the first round's rows are a slice of the still-zero coef: written in
                # place; an escalation's rows are cleared first (their earlier set)
                first = step == 0
                sub = coef[rows[0]:rows[-1] + 1] if first else np.zeros((len(rows), D.shape[1]))
                objective[rows], gap[rows], outside[start:start + len(rows)] = \
                    local_ridge_codes(atoms, X[rows], observed[rows], K,
                                      self.lam * ESCALATION_FACTOR ** step, sub, scoring,
                                      self.power, self.first_atoms, support, rows)
                if not first:
                    coef[rows] = sub
            todo = todo[outside]
            if not len(todo):
                break
        ok = np.isfinite(gap) & (gap <= self.tol)
        status = np.where(ok, OPTIMAL, INACCURATE).astype(object)
        result = LassoResult(coef, objective, gap, status, np.full(n, K), support=support)
        if len(todo):  # the lasso, with its certificate, for what is still outside
            rows = todo
            lasso = FastSolver(working_set=True).solve_masked(
                D, X[rows], observed[rows], np.broadcast_to(alpha, (n,))[rows], key=key)
            for name in ("coef", "objective", "gap", "status", "n_iter"):
                getattr(result, name)[rows] = getattr(lasso, name)
            result.fallback[rows] = True
        return result


def local_ridge_codes(atoms, X, observed, K, lam, coef, scoring=None, power=0.0, first=None,
                      support=None, rows=None):
    """Ridge codes of rows on their K most correlated atoms (see the module
    docstring), written into `coef`.

    Parameters
    ----------
    atoms : ndarray, shape (k, m)
        The atoms as rows.
    X : ndarray, shape (n, m)
        The rows, 0 at unobserved entries.
    observed : ndarray of bool, shape (n, m)
    K : int
        Atoms per working set, at most k.
    lam : float > 0
        The relative ridge weight.
    coef : ndarray, shape (n, k)
        Zeros; each row's K coefficients are written at its working set.
    scoring : tuple of ndarray, optional
        :func:`scoring_arrays` of `atoms` (blocks of rows share them); the
        working sets are chosen by single-precision scores.
    power : float >= 0, default 0
        The penalty weights' power of ``1 - cos``.
    first : int, optional
        A first pass on this many atoms fills each row; the working set is
        then the K atoms of highest cosine with the whole filled row among its
        :data:`REFINE_POOL` most correlated (by the observed entries), and
        those cosines weight the penalty. None: no first pass.
    support : ndarray of int, shape (n_all, K), optional
        Each row's working set is also written at its index in `rows` of it.
    rows : ndarray of int, shape (n,), optional
        Where the rows go in `support` (default 0, 1, ... n - 1).

    Returns
    -------
    objective : ndarray, shape (n,)
        The ridge objective at the code.
    gap : ndarray, shape (n,)
        The relative normal-equation residual.
    outside : ndarray of bool, shape (n,)
        Rows whose fit leaves its neighbours' envelope at an unobserved entry
        (:func:`outside_envelope`).
    """
    n, k = len(X), len(atoms)
    scoring = scoring or scoring_arrays(atoms)
    if first is None:
        idx = _nearest(X, observed, K, k, scoring)
        U, cos = atoms[idx], None                           # None: the observed parts'
    else:
        idx, U, cos = _refined(atoms, X, observed, K, lam, power, first, scoring)
    A = U * observed[:, None, :]                            # (n, K, m), masked
    c, H, b, mu, w = _ridge(A, X, lam, power, cos)
    residual = np.einsum("nkl,nl->nk", H, c) - b
    gap = np.linalg.norm(residual, axis=1) / np.maximum(np.linalg.norm(b, axis=1), _TINY)
    R = X - np.einsum("nk,nkm->nm", c, A)
    objective = 0.5 * np.einsum("nm,nm->n", R, R) + 0.5 * mu * np.einsum("nk,nk->n", w * c, c)
    np.put_along_axis(coef, idx, c, axis=1)
    if support is not None:
        support[np.arange(n) if rows is None else rows] = idx
    return objective, gap, outside_envelope(U, c, b, np.diagonal(H, axis1=1, axis2=2)
                                            - mu[:, None] * w, observed)


def scoring_arrays(atoms):
    """What choosing working sets reads, once per call: the atoms (k, m) and their
    transposed squares in single precision, and their norms."""
    return (atoms.astype(np.float32), (atoms.T ** 2).astype(np.float32),
            np.linalg.norm(atoms, axis=1))


def _nearest(X, observed, K, k, scoring):
    """The working sets by the observed entries (every atom when K >= k)."""
    if K < k:
        return working_sets(X, observed, K, *scoring[:2])
    return np.broadcast_to(np.arange(k), (len(X), k))


def _refined(atoms, X, observed, K, lam, power, first, scoring):
    """The first pass (`first` atoms) and the working sets it refines among each
    row's REFINE_POOL most correlated atoms: (n, K) indices, their atoms
    (n, K, m) and cosines with the whole filled rows."""
    score = observed_scores(X, observed, *scoring[:2])
    pool = _top(score, REFINE_POOL)
    U = atoms[np.take_along_axis(pool, _top(np.take_along_axis(score, pool, axis=1), first),
                                 axis=1)]
    c = _ridge(U * observed[:, None, :], X, lam, power)[0]
    filled = np.where(observed, X, np.einsum("nk,nkm->nm", c, U))
    norms = scoring[2]
    whole = np.einsum("npm,nm->np", scoring[0][pool], filled.astype(np.float32)) / np.maximum(
        norms[pool], _TINY).astype(np.float32)
    idx = np.take_along_axis(pool, _top(whole, K), axis=1)
    U = atoms[idx]
    cos = np.einsum("nkm,nm->nk", U, filled) / np.maximum(
        norms[idx] * np.linalg.norm(filled, axis=1)[:, None], _TINY)
    return idx, U, cos


def _top(score, K):
    """(n, K) column indices of each row's K highest scores (every column when K
    is at least their number)."""
    if K >= score.shape[1]:
        return np.broadcast_to(np.arange(score.shape[1]), score.shape)
    return np.argpartition(-score, K - 1, axis=1)[:, :K]


def _ridge(A, X, lam, power, cos=None):
    """The ridge codes on the masked working sets `A` (n, K, m): the codes, the
    regularised normal matrices, ``A x``, the weights mu and w (`cos`: the
    penalty's cosines; None: those of the observed parts)."""
    K = A.shape[1]
    H = A @ A.transpose(0, 2, 1)
    norms2 = np.diagonal(H, axis1=1, axis2=2).copy()
    mu = np.maximum(lam * norms2.sum(axis=1) / K, _TINY)
    b = np.einsum("nkm,nm->nk", A, X)
    if cos is None:
        cos = b / np.maximum(np.sqrt(norms2 * np.einsum("nm,nm->n", X, X)[:, None]), _TINY)
    w = penalty_weights(cos, power)
    H[:, np.arange(K), np.arange(K)] += mu[:, None] * w
    return np.linalg.solve(H, b[..., None])[..., 0], H, b, mu, w


def outside_envelope(U, c, b, norms2, observed, margin=ENVELOPE_MARGIN):
    """Rows whose ridge fit ``c U`` leaves, at an unobserved entry, the envelope of
    their working set's atoms each scaled to the row (``t_j = a_jM . x / ||a_jM||^2``)
    by more than `margin` times the envelope's width there: an extrapolation the
    neighbours do not support (an ill-conditioned system on few observed entries).

    Parameters
    ----------
    U : ndarray, shape (n, K, m)
        The working sets' atoms, unmasked.
    c : ndarray, shape (n, K)
        The codes.
    b : ndarray, shape (n, K)
        ``a_jM . x`` per atom.
    norms2 : ndarray, shape (n, K)
        ``||a_jM||^2`` per atom.
    observed : ndarray of bool, shape (n, m)
    margin : float, default ENVELOPE_MARGIN

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    scaled = (b / np.maximum(norms2, _TINY))[..., None] * U
    lo, hi = scaled.min(axis=1), scaled.max(axis=1)
    fit = np.einsum("nk,nkm->nm", c, U)
    width = margin * (hi - lo)
    out = (fit < lo - width) | (fit > hi + width) | ~np.isfinite(fit)
    return (out & ~observed).any(axis=1)


def penalty_weights(cos, power):
    """(n, K) weights ``(1 - cos)^power``, mean 1 per row, of the cosines `cos`
    (n, K) between each row and its working set's atoms."""
    if power == 0:
        return np.ones(cos.shape)
    far = np.maximum(1.0 - cos, 1e-12) ** power
    return far / far.mean(axis=1, keepdims=True)


def working_sets(X, observed, K, atoms32, squares32):
    """Each row's K atoms of highest ``(x_M . a_M) / ||a_M||`` (single precision),
    (n, K) indices (:func:`observed_scores`)."""
    return np.argpartition(-observed_scores(X, observed, atoms32, squares32), K - 1,
                           axis=1)[:, :K]


def observed_scores(X, observed, atoms32, squares32):
    """(n, k) scores ``(x_M . a_M) / ||a_M||`` of the rows against the atoms (single
    precision); rows of one missing pattern share their atoms' norms."""
    patterns, which = np.unique(observed, axis=0, return_inverse=True)
    which = which.reshape(-1)
    inv_norms = 1.0 / np.maximum(np.sqrt(patterns.astype(np.float32) @ squares32),
                                 np.finfo(np.float32).tiny)
    score = X.astype(np.float32) @ atoms32.T
    order = np.argsort(which, kind="stable")
    bounds = np.flatnonzero(np.diff(which[order])) + 1
    for rows in np.split(order, bounds):
        if rows[-1] - rows[0] + 1 == len(rows) and (np.diff(rows) == 1).all():
            score[rows[0]:rows[-1] + 1] *= inv_norms[which[rows[0]]]
        else:
            score[rows] *= inv_norms[which[rows[0]]]
    return score
