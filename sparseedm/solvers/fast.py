"""The certified fast lasso path: batched LARS-lasso homotopy on a Gram matrix.

Why this backend exists
-----------------------
Every recovery solves a small lasso: 55-78 observed distances, k = 2000 atoms.
The optimum has at most as many non-zeros as rows, and the LARS-lasso homotopy
(Efron et al. 2004; the algorithm behind SPAMS' ``lasso``) walks to it exactly in
one step per atom that enters or leaves, each step costing O(k |A|) on the
Gram rows of the active atoms. Those rows come from one Gram matrix ``G = D^T D``
of the *whole* dictionary, computed once and cached: the sub-dictionary of a
pose lacks the rows ``D_m`` of its missing entries, and its Gram row j is
``G[j] - D_m[:, j]^T D_m`` (m_miss x k work, m_miss = 13-36 of 91 entries), so no
per-pattern Gram matrix is ever formed and rows of every pattern run in one
kernel call (:func:`lars_lasso_masked`, ``FastSolver.solve_masked``).
``FastSolver.solve`` on a given sub-dictionary keeps the per-pattern Gram
(or atom-computed rows for a handful of signals).

Batches under ``NUMPY_MAX`` rows run the same homotopy written with numpy
(:func:`_lars_masked_numpy`: the same steps, vectorised event search), so a
small first call never waits for numba to compile. A call that compiles
numba anyway (one that adapts a dictionary) asks for the compiled kernel at
any size (``FastSolver(numpy_max=0)``, via
:func:`sparseedm._recovery_kernel.compiled_solver`).

The homotopy's inner loop (scan k atoms for the next event, rank-one Cholesky
updates) is scalar code that numpy cannot batch, so it is compiled with numba;
that is what earns numba its place in the dependencies.

Working sets
------------
A file's own poses as atoms (the default path's exemplars: up to 3,000) make
the homotopy above walk ~110 steps over every atom per pose. With
``FastSolver(working_set=True)`` (:func:`lars_lasso_working_set`) a row's path
runs over a few atoms: the 64 most correlated with it, then, while any atom's
correlation with the residual exceeds alpha on the full problem (one k x m
product a round), the worst 16 join and the path goes on from the answer so
far, only the new atoms' bound falling from their correlation to alpha (no
restart, no Gram matrix of the k atoms). It stops at the full problem's
optimum, as the certificate checks. The support of this lasso is not local
(on the 6,000-pose Bandai file only 9 % of a pose's atoms are among its 100
most correlated, and 11 % are shared with its nearest pose's), so a set grows
to some 250 atoms over several rounds and the paths take ~3x the full path's
steps, each far cheaper: 1.5-2x less time per pose than the full homotopy.
A row whose active atoms come to span its observed entries (an atom could
then join only by a swap the path does not make) is solved again over all
atoms. The set's cost grows with the set, the full path's with every atom:
``FastSolver()`` (``working_set="auto"``) takes working sets from
:data:`WS_MIN_ATOMS` atoms on, where they are the faster, so the shipped
dictionaries (2,000-2,932 atoms, with or without a file's poses beside them)
are coded on them too.

Certificate and fallback
------------------------
The answer is checked by the shared duality gap of :mod:`.base` on the full
problem. A row whose gap exceeds ``tol * objective`` (rank-deficient active
sets, duplicate atoms, round-off: typically one atom's entry missed on an
active set with a condition number of 1e6-1e8) is finished from the path's
answer by feature-sign search (:mod:`._active_set`, ~1 ms a row); only a row
that search does not certify is re-solved by the Clarabel backend (~40 ms a
row), and flagged in ``LassoResult.fallback``.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import numba
import numpy as np

from .. import _progress
from ._active_set import KKT_TOL, refine_rows
from .base import BaseSolver, OPTIMAL
from .gram import gram_matrix

__all__ = ["FastSolver", "lars_lasso_gram", "lars_lasso_working_set"]


@numba.njit(cache=True, inline="always")
def _chol_solve(L, n, b, out):
    # forward: L y = b
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= L[i, j] * out[j]
        out[i] = s / L[i, i]
    # backward: L^T z = y
    for i in range(n - 1, -1, -1):
        s = out[i]
        for j in range(i + 1, n):
            s -= L[j, i] * out[j]
        out[i] = s / L[i, i]


@numba.njit(cache=True)
def _chol_rebuild(R, active, n, L):
    """Cholesky factor of G[active][:, active] from the rows R; False if not PD."""
    for i in range(n):
        for j in range(i + 1):
            s = R[i, active[j]]
            for t in range(j):
                s -= L[i, t] * L[j, t]
            if i == j:
                if s <= 0.0:
                    return False
                L[i, i] = np.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
    return True


@numba.njit(cache=True, inline="always")
def _chol_append(L, R, n, entering, new_sign, active, sign, beta, state):
    """Append `entering` (its Gram row in R[n]) to the Cholesky factor of G_AA
    and to the active set; an atom linearly dependent on the active set is
    marked excluded instead. Returns the new active count."""
    for i in range(n):
        s = R[i, entering]
        for t in range(i):
            s -= L[i, t] * L[n, t]
        L[n, i] = s / L[i, i]
    d = R[n, entering]
    for t in range(n):
        d -= L[n, t] * L[n, t]
    if d <= 1e-10 * R[n, entering]:
        state[entering] = 2  # linearly dependent on the active set
        return n
    L[n, n] = np.sqrt(d)
    active[n] = entering
    sign[n] = new_sign
    beta[n] = 0.0
    state[entering] = 1
    return n + 1


#: where `_lars_core` takes Gram rows from
_FROM_GRAM, _FROM_ATOMS, _DOWNDATE = 0, 1, 2


@numba.njit(cache=True, inline="always")
def _gram_row(G, DW, mode, miss, j, out):
    """Row j of the (sub-)dictionary's Gram matrix, by `mode`.

    _FROM_GRAM: copied from G; _FROM_ATOMS: computed from the atoms DW (k x m);
    _DOWNDATE: from the full Gram G and the full dictionary DW (features x k)
    as ``G[j] - sum_{q in miss} DW[q, j] DW[q]``, the rows `miss` being the
    features the sub-dictionary lacks (m_miss x k work instead of m_obs x k).
    """
    if mode == 0:
        for t in range(out.shape[0]):
            out[t] = G[j, t]
    elif mode == 1:
        out[:] = np.dot(DW, DW[j])  # BLAS gemv
    else:
        for t in range(out.shape[0]):
            out[t] = G[j, t]
        for q in miss:
            v = DW[q, j]
            if v != 0.0:
                for t in range(out.shape[0]):
                    out[t] -= v * DW[q, t]


def _drop_atom(active, sign, beta, R, state, best, n):
    """Drop active[best] from the n active atoms; returns the atom dropped.

    The last active atom takes its place (one Gram row moved, not all those
    after it); the caller rebuilds the Cholesky factor. Plain Python, shared
    by the compiled kernel (as `_drop_atom_jit`) and the numpy path.
    """
    dropped = active[best]
    state[dropped] = 0
    last = n - 1
    if best != last:
        active[best] = active[last]
        sign[best] = sign[last]
        beta[best] = beta[last]
        R[best, :] = R[last, :]
    return dropped


_drop_atom_jit = numba.njit(cache=True, inline="always")(_drop_atom)


@numba.njit(cache=True, inline="always")
def _atom_event(pen, rate, cj, aj, positive, tiny, gamma, event, best, j):
    """The event so far, or free atom j reaching its bound first: its
    correlation cj (changing at -aj per unit step) meets +pen (event 1) or
    -pen (event 2), the bound falling at `rate`."""
    # g = (pen -/+ c_j) / (rate -/+ a_j), compared by multiplication: a
    # division only when a new minimum is found
    d1 = rate - aj
    num = pen - cj
    if d1 > 1e-12 and num < gamma * d1 and num > tiny * d1:
        gamma = num / d1
        event = 1
        best = j
    if not positive:
        d2 = rate + aj
        num = pen + cj
        if d2 > 1e-12 and num < gamma * d2 and num > tiny * d2:
            gamma = num / d2
            event = 2
            best = j
    return gamma, event, best


@numba.njit(cache=True, inline="always")
def _drop_event(w, sign, beta, n, tiny, gamma, event, best):
    """The event so far, or an active coefficient reaching zero first (event 3)."""
    for i in range(n):
        if w[i] * sign[i] < 0.0:  # coefficient heading to zero
            g = -beta[i] / w[i]
            if g > tiny and g < gamma:
                gamma = g
                event = 3
                best = i
    return gamma, event, best


@numba.njit(cache=True, inline="always")
def _next_event(state, dropped, a, c, lam, alpha, tiny, positive, w, sign, beta, n):
    """The homotopy's next event from lam: ``(gamma, event, best)``.

    event 0: the path reaches alpha (gamma = lam - alpha); 1 / 2: atom `best`
    enters with sign + / -; 3: active coefficient `best` reaches zero. `a` is
    G w over all atoms, `c` the correlations, `dropped` the atom just dropped
    (not re-entered at once; -1 for none).
    """
    gamma = lam - alpha
    event = 0
    best = -1
    for j in range(a.shape[0]):
        if state[j] != 0 or j == dropped:
            continue
        gamma, event, best = _atom_event(lam, 1.0, c[j], a[j], positive, tiny, gamma, event,
                                         best, j)
    return _drop_event(w, sign, beta, n, tiny, gamma, event, best)


@numba.njit(cache=True, inline="always")
def _advance(beta, w, n, c, a, gamma, k):
    """One homotopy step of length gamma: the n active coefficients along w,
    the k correlations along a."""
    for i in range(n):
        beta[i] += gamma * w[i]
    for j in range(k):
        c[j] -= gamma * a[j]


@numba.njit(cache=True)
def _lars_core(G, DW, mode, miss, dtx, alpha, positive, max_steps, rank, coef):
    """LARS-lasso homotopy for one signal over k atoms; writes `coef`.

    Gram rows come from G, DW and `miss` as `_gram_row`'s `mode` says, as
    atoms enter. Returns the step count, negative if the path stopped early
    (the certificate then decides).
    """
    k = dtx.shape[0]
    c = dtx.copy()  # correlations D^T r at the current point
    # the active set never exceeds the rank (<= n_features): G_AA must be PD
    max_active = min(k, max_steps + 1, rank + 1)
    active = np.empty(max_active, np.int64)
    sign = np.empty(max_active)
    beta = np.zeros(max_active)
    L = np.zeros((max_active, max_active))
    R = np.empty((max_active + 1, k))  # Gram rows of the active atoms (+1 spare)
    w = np.empty(max_active)
    rhs = np.empty(max_active)
    a = np.empty(k)
    state = np.zeros(k, np.int8)  # 0 free, 1 active, 2 excluded (dependent)
    for j in range(k):
        coef[j] = 0.0

    lam = -1.0
    jmax = -1
    for j in range(k):
        v = c[j] if positive else abs(c[j])
        if v > lam:
            lam = v
            jmax = j
    if lam <= alpha:
        return 0
    n = 0
    new_sign = 1.0 if c[jmax] > 0 else -1.0
    entering = jmax
    dropped = -1
    tiny = 1e-14 * lam
    steps = 0
    while steps < max_steps:
        steps += 1
        if entering >= 0:
            if n >= max_active:
                return -steps
            _gram_row(G, DW, mode, miss, entering, R[n])
            n = _chol_append(L, R, n, entering, new_sign, active, sign, beta, state)
            entering = -1
        # direction: G_AA w = sign_A
        for i in range(n):
            rhs[i] = sign[i]
        _chol_solve(L, n, rhs, w)
        if n > 0:
            a[:] = np.dot(w[:n], R[:n])  # BLAS gemv: G_{:,A} w
        else:
            a[:] = 0.0
        gamma, event, best = _next_event(state, dropped, a, c, lam, alpha, tiny, positive,
                                         w, sign, beta, n)
        _advance(beta, w, n, c, a, gamma, k)
        lam -= gamma
        dropped = -1
        if event == 0:
            break
        if event == 3:
            dropped = _drop_atom_jit(active, sign, beta, R, state, best, n)
            n -= 1
            if not _chol_rebuild(R, active, n, L):
                return -steps
        else:
            entering = best
            new_sign = 1.0 if event == 1 else -1.0
    else:
        return -steps

    # polish: the exact lasso solution for this active set and signs,
    # G_AA beta = (D^T x)_A - alpha * sign_A, kept if the signs agree.
    for i in range(n):
        rhs[i] = dtx[active[i]] - alpha * sign[i]
    _chol_solve(L, n, rhs, w)
    consistent = True
    for i in range(n):
        if w[i] * sign[i] < 0.0:
            consistent = False
    for i in range(n):
        coef[active[i]] = w[i] if consistent else beta[i]
    return steps


@numba.njit(cache=True)
def _lars_one(G, dtx, alpha, positive, max_steps, rank, coef):
    return _lars_core(G, np.empty((0, 0)), 0, np.empty(0, np.int64), dtx, alpha, positive,
                      max_steps, rank, coef)


@numba.njit(cache=True, parallel=True, nogil=True)
def _lars_rows_batch(Dt, X, alpha, positive, max_steps, coef, steps):
    k, m = Dt.shape
    for i in numba.prange(X.shape[0]):
        dtx = np.dot(Dt, X[i])
        steps[i] = _lars_core(np.empty((0, 0)), Dt, 1, np.empty(0, np.int64), dtx, alpha,
                              positive, max_steps, m, coef[i])


@numba.njit(cache=True, nogil=True)
def _lars_rows_batch_serial(Dt, X, alpha, positive, max_steps, coef, steps):
    k, m = Dt.shape
    for i in range(X.shape[0]):
        dtx = np.dot(Dt, X[i])
        steps[i] = _lars_core(np.empty((0, 0)), Dt, 1, np.empty(0, np.int64), dtx, alpha,
                              positive, max_steps, m, coef[i])


def lars_lasso_rows(D, X, alpha, *, positive=False, max_steps=500):
    """As :func:`lars_lasso_gram`, without a Gram matrix: its rows are computed
    from the atoms as they enter (cheaper for a handful of signals).

    Parameters
    ----------
    D : ndarray, shape (n_features, k)
        Atoms as columns.
    X : ndarray, shape (n_samples, n_features)

    Examples
    --------
    >>> import numpy as np
    >>> coef, steps = lars_lasso_rows(np.eye(3), np.array([[3.0, -0.5, -2.0]]), 1.0)
    >>> coef.tolist()
    [[2.0, 0.0, -1.0]]
    """
    Dt = np.ascontiguousarray(np.asarray(D, dtype=np.float64).T)
    X = np.ascontiguousarray(np.atleast_2d(X), dtype=np.float64)
    coef = np.zeros((X.shape[0], Dt.shape[0]))
    steps = np.zeros(X.shape[0], dtype=np.int64)
    kernel = _lars_rows_batch if len(X) >= 4 else _lars_rows_batch_serial
    kernel(Dt, X, float(alpha), bool(positive), int(max_steps), coef, steps)
    return coef, steps


@numba.njit(cache=True, parallel=True, nogil=True)
def _lars_batch(G, DtX, alpha, positive, max_steps, rank, coef, steps):
    for i in numba.prange(DtX.shape[0]):
        steps[i] = _lars_one(G, DtX[i], alpha, positive, max_steps, rank, coef[i])


@numba.njit(cache=True, nogil=True)
def _lars_batch_serial(G, DtX, alpha, positive, max_steps, rank, coef, steps):
    for i in range(DtX.shape[0]):
        steps[i] = _lars_one(G, DtX[i], alpha, positive, max_steps, rank, coef[i])


#: below this many signals, a parallel region costs more than it gives
_PARALLEL_MIN = 64


def lars_lasso_gram(G, DtX, alpha, *, positive=False, max_steps=500, rank=None):
    """Solve ``min 0.5||x - D c||^2 + alpha ||c||_1`` for a batch from Gram data.

    Parameters
    ----------
    G : ndarray, shape (k, k)
        ``D^T D``.
    DtX : ndarray, shape (n_samples, k)
        ``X @ D`` (one row ``D^T x`` per signal).
    alpha : float > 0
    positive : bool, default False
    max_steps : int, default 500
        Homotopy steps (atoms entering or leaving) before giving up.
    rank : int, optional
        An upper bound on the rank of G (the number of features): sizes the
        per-signal buffers. Default k.

    Returns
    -------
    coef : ndarray, shape (n_samples, k)
    steps : ndarray of int, shape (n_samples,)
        Steps taken; negative where the path stopped early (uncertified).

    Examples
    --------
    With an orthonormal dictionary the lasso is soft-thresholding:

    >>> import numpy as np
    >>> coef, steps = lars_lasso_gram(np.eye(3), np.array([[3.0, -0.5, -2.0]]), 1.0)
    >>> coef.tolist()
    [[2.0, 0.0, -1.0]]
    """
    G = np.ascontiguousarray(G, dtype=np.float64)
    DtX = np.ascontiguousarray(np.atleast_2d(DtX), dtype=np.float64)
    coef = np.zeros_like(DtX)
    steps = np.zeros(DtX.shape[0], dtype=np.int64)
    kernel = _lars_batch if len(DtX) >= _PARALLEL_MIN else _lars_batch_serial
    rank = G.shape[0] if rank is None else min(int(rank), G.shape[0])
    _progress.jit(kernel, "dictionary learning")
    kernel(G, DtX, float(alpha), bool(positive), int(max_steps), rank, coef, steps)
    return coef, steps


@numba.njit(cache=True, nogil=True)
def _lars_masked_row(G, D, Dt, X0, miss, n_miss, alpha, positive, max_steps, coef, steps,
                     i):
    dtx = np.dot(Dt, X0[i])  # D_sub^T x_sub: X0 is zero off the observed entries
    steps[i] = _lars_core(G, D, 2, miss[i, :n_miss[i]], dtx, alpha[i], positive, max_steps,
                          D.shape[0] - n_miss[i], coef[i])


@numba.njit(cache=True, parallel=True, nogil=True)
def _lars_masked_batch(G, D, Dt, X0, miss, n_miss, alpha, positive, max_steps, coef, steps):
    for i in numba.prange(X0.shape[0]):
        _lars_masked_row(G, D, Dt, X0, miss, n_miss, alpha, positive, max_steps, coef, steps, i)


@numba.njit(cache=True, nogil=True)
def _lars_masked_batch_serial(G, D, Dt, X0, miss, n_miss, alpha, positive, max_steps, coef,
                              steps):
    for i in range(X0.shape[0]):
        _lars_masked_row(G, D, Dt, X0, miss, n_miss, alpha, positive, max_steps, coef, steps, i)


def lars_lasso_masked(G, D, X, observed, alpha, *, positive=False, max_steps=500,
                      numpy_max=None):
    """As :func:`lars_lasso_gram` for rows of many sub-dictionaries of one D.

    Row i is solved on ``D[observed[i]]``; every Gram row it needs is the full
    Gram's row downdated by the features it lacks, so no per-pattern Gram
    matrix is ever formed.

    Parameters
    ----------
    G : ndarray, shape (k, k)
        ``D^T D`` of the full dictionary.
    D : ndarray, shape (n_features, k)
    X : ndarray, shape (n_samples, n_features)
        Zero off the observed entries.
    observed : ndarray of bool, shape (n_samples, n_features)
    alpha : ndarray, shape (n_samples,)
    numpy_max : int, optional
        Batches under this many rows run the numpy homotopy (default
        :data:`NUMPY_MAX`); 0: always the compiled kernel.

    Examples
    --------
    >>> import numpy as np
    >>> D = np.eye(3); obs = np.array([[True, True, False]])
    >>> coef, steps = lars_lasso_masked(D.T @ D, D, np.array([[3.0, -0.5, 0.0]]), obs,
    ...                                 np.array([1.0]))
    >>> coef.tolist()
    [[2.0, 0.0, 0.0]]
    """
    D = np.ascontiguousarray(D, dtype=np.float64)
    X = np.ascontiguousarray(np.atleast_2d(X), dtype=np.float64)
    observed = np.asarray(observed, dtype=bool)
    n_miss = (~observed).sum(axis=1).astype(np.int64)
    # the unobserved features of each row first (argsort of False before True)
    miss = np.ascontiguousarray(np.argsort(observed, axis=1, kind="stable")[:, :max(
        int(n_miss.max(initial=0)), 1)].astype(np.int64))
    coef = np.zeros((X.shape[0], D.shape[1]))
    steps = np.zeros(X.shape[0], dtype=np.int64)
    G = np.ascontiguousarray(G, dtype=np.float64)
    alpha = np.ascontiguousarray(alpha, dtype=np.float64)
    numpy_max = NUMPY_MAX if numpy_max is None else int(numpy_max)
    if len(X) < numpy_max:  # by size only: an answer must not depend on cache state
        for i in range(len(X)):
            steps[i] = _lars_masked_numpy(G, D, X[i], miss[i, :n_miss[i]], alpha[i],
                                          bool(positive), int(max_steps), coef[i])
        return coef, steps
    args = (G, D, np.ascontiguousarray(D.T), X, miss, n_miss, alpha, bool(positive),
            int(max_steps), coef, steps)
    serial = numba.get_num_threads() == 1
    _progress.jit(_lars_masked_batch_serial if serial else _lars_masked_batch, "recovery")
    if serial:
        # e.g. a joblib worker thread: numba's parallel launches would
        # serialise across threads (measured: 2 jobs at 0.8 cores)
        _lars_masked_batch_serial(*args)
        return coef, steps
    # dynamic scheduling in small chunks: rows differ in cost, and on a busy
    # machine a static half per thread waits for the slower thread
    with numba.parallel_chunksize(4):
        _lars_masked_batch(*args)
    return coef, steps


# -- the working-set solve: the same lasso over a few atoms per row, checked on all --


#: rounds of the working-set solve that add no atom (their paths move atoms of
#: the set that round-off left past the bound) before a row is left to the
#: certificate; every other round adds one atom at least, so the set's size
#: bounds them
MAX_STALLS = 4
#: its first atoms per row (those most correlated with the row), the most
#: violators a round adds, and the most atoms a row's set may reach (the first
#: two timed on rows of the held-out CMU validation file: 16-128 and 16-96 all
#: within 20 % of the best; they change the time, never the answer)
WS_INIT, WS_ADD, WS_MAX = 64, 16, 2048
#: from this many atoms ``FastSolver()`` solves masked batches on working sets
#: (``working_set="auto"``): coding the occluded rows of the MPII validation
#: photo file (defaults' members) and of the Bandai-Namco file (``adapt=False``)
#: over random subsets of their dictionaries' atoms (one thread, one run),
#: the working sets took 2x the full homotopy's time at 300 atoms, 1.3x at
#: 1,000, the same at 1,500, 0.85x at 2,000 and 0.7x at 2,400-2,932; the codes
#: agreed to 1e-8 and every row kept its support
WS_MIN_ATOMS = 1500

@numba.njit(cache=True, inline="always")
def _ws_event(state, dropped, moving, a, c, mu, alpha, tiny, positive, w, sign, beta, n, K):
    """`_next_event` with two kinds of free atom: a moving one's bound is the
    path's `mu` (falling at rate 1), a fixed one's is `alpha` (rate 0)."""
    gamma = mu - alpha
    event = 0
    best = -1
    for j in range(K):
        if state[j] != 0 or j == dropped:
            continue
        pen, rate = (mu, 1.0) if moving[j] else (alpha, 0.0)
        gamma, event, best = _atom_event(pen, rate, c[j], a[j], positive, tiny, gamma, event,
                                         best, j)
    return _drop_event(w, sign, beta, n, tiny, gamma, event, best)


@numba.njit(cache=True, inline="always")
def _ws_drop(active, sign, beta, R, L, state, best, n, K):
    """Drop active[best], keeping the others' order: their Gram rows move up and
    the Cholesky factor loses row and column `best` by a rank-one update of
    the rows below (O(n^2), where `_chol_rebuild` is O(n^3))."""
    state[active[best]] = 0
    x = L[best + 1:n, best].copy()
    for i in range(best + 1, n):
        active[i - 1] = active[i]
        sign[i - 1] = sign[i]
        beta[i - 1] = beta[i]
        R[i - 1, :K] = R[i, :K]
        for j in range(best):
            L[i - 1, j] = L[i, j]
        for j in range(best, i):
            L[i - 1, j] = L[i, j + 1]
    n -= 1
    for t in range(best, n):  # L L' + x x' on the trailing block, by Givens rotations
        q = t - best
        r = np.sqrt(L[t, t] * L[t, t] + x[q] * x[q])
        cs = r / L[t, t]
        sn = x[q] / L[t, t]
        L[t, t] = r
        for i in range(t + 1, n):
            L[i, t] = (L[i, t] + sn * x[i - best]) / cs
            x[i - best] = cs * x[i - best] - sn * L[i, t]
    return n


@numba.njit(cache=True)
def _ws_path(Dw, K, c, moving, state, active, sign, beta, L, R, w, rhs, a, n, alpha,
             positive, max_steps):
    """One homotopy over the K working-set atoms: the moving atoms' bound mu
    falls from their largest correlation to alpha while the fixed atoms'
    stays alpha (all moving: plain LARS). The state (active set, its
    Cholesky factor and Gram rows, beta, correlations c) is carried in and
    out. Returns (steps, n): steps negative if the path stopped early."""
    mu = -1.0
    entering = -1
    for j in range(K):
        if state[j] == 0 and moving[j]:
            v = c[j] if positive else abs(c[j])
            if v > mu:
                mu = v
                entering = j
    if mu <= alpha:
        return 0, n
    new_sign = 1.0 if c[entering] > 0 else -1.0
    tiny = 1e-14 * mu
    dropped = -1
    steps = 0
    while steps < max_steps:
        steps += 1
        if entering >= 0:
            if n + 1 >= active.shape[0]:  # the active atoms span the observed entries
                return -steps, n
            R[n, :K] = np.dot(Dw[:K], Dw[entering])  # BLAS gemv: its Gram row
            n = _chol_append(L, R, n, entering, new_sign, active, sign, beta, state)
            entering = -1
        # only the moving active atoms' bound falls: G_AA w = (sign on them)
        for i in range(n):
            rhs[i] = sign[i] if moving[active[i]] else 0.0
        _chol_solve(L, n, rhs, w)
        a[:K] = 0.0
        for i in range(n):  # G_{:,A} w over the set (R's rows are wider than K)
            wi = w[i]
            for j in range(K):
                a[j] += wi * R[i, j]
        gamma, event, best = _ws_event(state, dropped, moving, a, c, mu, alpha, tiny,
                                       positive, w, sign, beta, n, K)
        _advance(beta, w, n, c, a, gamma, K)
        mu -= gamma
        dropped = -1
        if event == 0:
            return steps, n
        if event == 3:
            dropped = active[best]
            n = _ws_drop(active, sign, beta, R, L, state, best, n, K)
        else:
            entering = best
            new_sign = 1.0 if event == 1 else -1.0
    return -steps, n


@numba.njit(cache=True, inline="always")
def _ws_polish(Dw, x0, active, sign, beta, L, w, rhs, n, alpha, r):
    """The exact lasso answer on the active set and signs (kept in beta when
    the signs agree, as `_lars_core` ends), and its residual r."""
    for i in range(n):
        rhs[i] = np.dot(Dw[active[i]], x0) - alpha * sign[i]
    _chol_solve(L, n, rhs, w)
    consistent = True
    for i in range(n):
        if w[i] * sign[i] < 0.0:
            consistent = False
    r[:] = x0
    for i in range(n):
        if consistent:
            beta[i] = w[i]
        r -= beta[i] * Dw[active[i]]


@numba.njit(cache=True, inline="always")
def _ws_add(Dt, obsf, atoms, ws, Dw, K, R, active, n, moving, state, c, corr):
    """Append `atoms` to the working set (moving, free, their correlations
    `corr`); the active atoms' Gram rows gain their columns. Returns K."""
    m = Dt.shape[1]
    for j in atoms:
        ws[K] = j
        for q in range(m):
            Dw[K, q] = Dt[j, q] * obsf[q]
        moving[K] = True
        state[K] = 0
        c[K] = corr[j]
        for i in range(n):
            R[i, K] = np.dot(Dw[active[i]], Dw[K])
        K += 1
    return K


@numba.njit(cache=True, inline="always")
def _ws_violators(corr, ws, K, inws, c, moving, state, thr, positive, add, room):
    """After a path: the working set's free atoms that violate the optimality
    conditions move again (the others are fixed); returns the at most
    min(add, room) atoms outside it that violate them most, and how many do."""
    for t in range(K):
        c[t] = corr[ws[t]]
        if state[t] == 2:
            state[t] = 0  # excluded by a former active set: judged again
        v = c[t] if positive else abs(c[t])
        moving[t] = state[t] == 0 and v > thr
    k = corr.shape[0]
    score = np.empty(k)
    nv = 0
    for j in range(k):
        v = corr[j] if positive else abs(corr[j])
        if not inws[j] and v > thr:
            score[nv] = -v
            nv += 1
    if nv == 0:
        return np.empty(0, np.int64), 0
    cand = np.empty(nv, np.int64)
    p = 0
    for j in range(k):
        v = corr[j] if positive else abs(corr[j])
        if not inws[j] and v > thr:
            cand[p] = j
            p += 1
    take = min(nv, add, room)
    return cand[np.argsort(score[:nv])[:take]], nv


@numba.njit(cache=True, nogil=True)
def _ws_row(Dt, x0, obsf, init, alpha, positive, max_steps, max_ws, add, coef):
    """One row's lasso over all k atoms of Dt (k x m), exactly, on a working
    set: LARS over the `init` atoms, then, while atoms outside the set
    violate the optimality conditions on the full problem (one k x m product
    with the residual), the `add` worst join and the path goes on from the
    answer so far (`_ws_path`: only their bound falls). Returns the steps,
    negative if it stopped early (set full, a path cut short): the
    certificate then decides."""
    k, m = Dt.shape
    mo = 0
    for q in range(m):
        mo += obsf[q] > 0
    max_ws = min(max_ws, k)
    max_active = min(max_ws, mo + 1)
    ws = np.empty(max_ws, np.int64)
    inws = np.zeros(k, np.bool_)
    Dw = np.empty((max_ws, m))
    c, a = np.empty(max_ws), np.empty(max_ws)
    moving = np.zeros(max_ws, np.bool_)
    state = np.zeros(max_ws, np.int8)
    active = np.empty(max_active, np.int64)
    sign, beta = np.empty(max_active), np.zeros(max_active)
    w, rhs = np.empty(max_active), np.empty(max_active)
    L = np.zeros((max_active, max_active))
    R = np.empty((max_active + 1, max_ws))
    r = np.empty(m)
    corr = np.dot(Dt, x0)
    init = init[:max_ws]
    K = _ws_add(Dt, obsf, init, ws, Dw, 0, R, active, 0, moving, state, c, corr)
    for j in init:
        inws[j] = True
    n = 0
    total = 0
    thr = alpha * (1.0 + KKT_TOL)
    stalls = 0
    while stalls <= MAX_STALLS:
        steps, n = _ws_path(Dw, K, c, moving, state, active, sign, beta, L, R, w, rhs, a, n,
                            alpha, positive, max_steps)
        total += abs(steps)
        if steps < 0:
            break
        _ws_polish(Dw, x0, active, sign, beta, L, w, rhs, n, alpha, r)
        corr = np.dot(Dt, r)  # BLAS gemv: every atom's correlation with the residual
        new, nv = _ws_violators(corr, ws, K, inws, c, moving, state, thr, positive, add,
                                max_ws - K)
        if nv == 0 and not moving[:K].any():
            for i in range(n):
                coef[ws[active[i]]] = beta[i]
            return total
        if nv > len(new) and len(new) == 0:  # the set is full: left to the certificate
            break
        stalls += len(new) == 0
        K = _ws_add(Dt, obsf, new, ws, Dw, K, R, active, n, moving, state, c, corr)
        for j in new:
            inws[j] = True
    for i in range(n):
        coef[ws[active[i]]] = beta[i]
    return -max(total, 1)


@numba.njit(cache=True, parallel=True, nogil=True)
def _ws_batch(Dt, X0, obsf, init, alpha, positive, max_steps, max_ws, add, coef, steps):
    for i in numba.prange(X0.shape[0]):
        steps[i] = _ws_row(Dt, X0[i], obsf[i], init[i], alpha[i], positive, max_steps, max_ws,
                           add, coef[i])


@numba.njit(cache=True, nogil=True)
def _ws_batch_serial(Dt, X0, obsf, init, alpha, positive, max_steps, max_ws, add, coef,
                     steps):
    for i in range(X0.shape[0]):
        steps[i] = _ws_row(Dt, X0[i], obsf[i], init[i], alpha[i], positive, max_steps, max_ws,
                           add, coef[i])


@numba.njit(cache=True, nogil=True)
def _resolve_row(Dt, X, obsf, alpha, positive, max_steps, coef, steps, i):
    """Row i's lasso over all atoms on its observed entries (as
    :func:`lars_lasso_rows` solves it on ``D[observed[i]]``: Gram rows from the
    atoms as they enter)."""
    k = Dt.shape[0]
    obs = np.flatnonzero(obsf[i] > 0)
    mo = obs.shape[0]
    Do = np.empty((k, mo))
    for j in range(k):
        for p in range(mo):
            Do[j, p] = Dt[j, obs[p]]
    xo = np.empty(mo)
    for p in range(mo):
        xo[p] = X[i, obs[p]]
    dtx = np.dot(Do, xo)
    steps[i] = _lars_core(np.empty((0, 0)), Do, 1, np.empty(0, np.int64), dtx, alpha[i],
                          positive, max_steps, mo, coef[i])


@numba.njit(cache=True, parallel=True, nogil=True)
def _resolve_batch(Dt, X, obsf, alpha, positive, max_steps, coef, steps, rows):
    for t in numba.prange(rows.shape[0]):
        _resolve_row(Dt, X, obsf, alpha, positive, max_steps, coef, steps, rows[t])


@numba.njit(cache=True, nogil=True)
def _resolve_batch_serial(Dt, X, obsf, alpha, positive, max_steps, coef, steps, rows):
    for t in range(rows.shape[0]):
        _resolve_row(Dt, X, obsf, alpha, positive, max_steps, coef, steps, rows[t])


def lars_lasso_working_set(D, X, observed, alpha, *, positive=False, max_steps=500,
                           n_init=WS_INIT, add=WS_ADD, max_ws=WS_MAX, resolve=True):
    """As :func:`lars_lasso_masked`, on a working set of atoms per row: the same lasso.

    Row i starts from the `n_init` atoms most correlated with it (one matrix
    product for the batch); after each path over its set, every atom's
    correlation with the residual (on the observed entries) is checked and
    the `add` worst of those above ``alpha (1 + KKT_TOL)`` join, the path
    going on from the answer so far, until none is left: the answer then
    satisfies the full problem's optimality conditions, as the certificate
    checks. Neither a Gram matrix nor a per-row copy of D is formed: the
    cost grows with the set, not with D's atoms (but for one k x m product
    per round). A row the set cannot finish (its active atoms span the
    observed entries, so an atom can join only by a swap the path does not
    make; or the set is full) is solved again over all atoms
    (:func:`lars_lasso_rows`) when `resolve`.

    Parameters
    ----------
    D : ndarray, shape (n_features, k)
    X : ndarray, shape (n_samples, n_features)
        Zero off the observed entries.
    observed : ndarray of bool, shape (n_samples, n_features)
    alpha : ndarray, shape (n_samples,)
    positive : bool, default False
    max_steps : int, default 500
        Homotopy steps per round.
    n_init, add, max_ws : int
        First atoms, atoms added a round, and the most a row's set holds.
    resolve : bool, default True
        Solve the rows the set did not finish over all atoms; False: leave
        them as they stopped, their steps negative.

    Returns
    -------
    coef : ndarray, shape (n_samples, k)
    steps : ndarray of int, shape (n_samples,)
        Steps over all rounds; negative where a row stopped early.

    Examples
    --------
    >>> import numpy as np
    >>> D = np.eye(3); obs = np.array([[True, True, False]])
    >>> coef, steps = lars_lasso_working_set(D, np.array([[3.0, -0.5, 0.0]]), obs,
    ...                                      np.array([1.0]), n_init=1)
    >>> coef.tolist()
    [[2.0, 0.0, 0.0]]
    """
    Dt = np.ascontiguousarray(np.asarray(D, dtype=np.float64).T)
    obsf = np.ascontiguousarray(observed, dtype=np.float64)
    X = np.ascontiguousarray(np.atleast_2d(X), dtype=np.float64) * obsf
    alpha = np.ascontiguousarray(alpha, dtype=np.float64)
    k = Dt.shape[0]
    n_init = max(1, min(int(n_init), k))
    score = X @ Dt.T
    if not positive:
        score = np.abs(score)
    init = np.argpartition(-score, n_init - 1, axis=1)[:, :n_init] if n_init < k else \
        np.broadcast_to(np.arange(k), score.shape)
    init = np.ascontiguousarray(init, dtype=np.int64)
    coef = np.zeros((X.shape[0], k))
    steps = np.zeros(X.shape[0], dtype=np.int64)
    args = (Dt, X, obsf, init, alpha, bool(positive), int(max_steps), int(max_ws), int(add),
            coef, steps)
    if numba.get_num_threads() == 1 or len(X) < _PARALLEL_MIN:
        _progress.jit(_ws_batch_serial, "recovery")
        _ws_batch_serial(*args)
    else:
        _progress.jit(_ws_batch, "recovery")
        with numba.parallel_chunksize(4):
            _ws_batch(*args)
    again = np.flatnonzero(steps < 0) if resolve else ()
    if len(again):
        # each as lars_lasso_rows solves it, in one compiled batch (threads share them)
        serial = numba.get_num_threads() == 1 or len(again) < 2
        kernel = _resolve_batch_serial if serial else _resolve_batch
        _progress.jit(kernel, "recovery")
        kernel(Dt, X, obsf, alpha, bool(positive), int(max_steps), coef, steps,
               again.astype(np.int64))
    return coef, steps


def _trsolve(L, b):
    """x with L x = b, L lower triangular (LAPACK, without scipy's checks)."""
    from scipy.linalg.lapack import dtrtrs

    return dtrtrs(L, b, lower=1)[0]


def _chsolve(L, b):
    """x with L L' x = b (LAPACK, without scipy's checks)."""
    from scipy.linalg.lapack import dpotrs

    return dpotrs(L, b, lower=1)[0]


def _lars_masked_numpy(G, D, x0, miss, alpha, positive, max_steps, coef):
    """`_lars_core` in downdate mode, written with numpy instead of compiled.

    The same homotopy step for step (each event search is one vectorised
    pass where the compiled kernel loops), so the same answer to round-off:
    it serves small batches, which then never wait for numba to compile
    (several seconds on first use).
    """
    k = G.shape[0]
    dtx = D.T @ x0
    c = dtx.copy()
    max_active = min(k, max_steps + 1, D.shape[0] - len(miss) + 1)
    active = np.empty(max_active, np.int64)
    sign = np.empty(max_active)
    beta = np.zeros(max_active)
    L = np.zeros((max_active, max_active))
    R = np.empty((max_active + 1, k))
    state = np.zeros(k, np.int8)
    coef[:] = 0.0
    score = c if positive else np.abs(c)
    jmax = int(np.argmax(score))
    lam = score[jmax]
    if lam <= alpha:
        return 0
    n = 0
    new_sign = 1.0 if c[jmax] > 0 else -1.0
    entering, dropped = jmax, -1
    tiny = 1e-14 * lam
    Dm = D[miss]
    steps = 0
    while steps < max_steps:
        steps += 1
        if entering >= 0:
            if n >= max_active:
                return -steps
            R[n] = G[entering] - Dm[:, entering] @ Dm
            if n:
                L[n, :n] = _trsolve(L[:n, :n], R[:n, entering])
            d = R[n, entering] - L[n, :n] @ L[n, :n]
            if d <= 1e-10 * R[n, entering]:
                state[entering] = 2
            else:
                L[n, n] = np.sqrt(d)
                active[n], sign[n], beta[n] = entering, new_sign, 0.0
                state[entering] = 1
                n += 1
            entering = -1
        if n:
            w = _chsolve(L[:n, :n], sign[:n])
            a = w @ R[:n]
        else:
            w, a = np.zeros(0), np.zeros(k)
        gamma = lam - alpha
        event, best = 0, -1
        free = state == 0
        if dropped >= 0:
            free[dropped] = False
        # the kernel's scan, vectorised: first minimum in the order (j, +), (j, -)
        with np.errstate(divide="ignore", invalid="ignore"):
            den, num = 1.0 - a, lam - c
            g1 = np.where(free & (den > 1e-12) & (num > tiny * den), num / den, np.inf)
            j1 = int(np.argmin(g1))
            j2 = -1
            if not positive:
                den, num = 1.0 + a, lam + c
                g2 = np.where(free & (den > 1e-12) & (num > tiny * den), num / den, np.inf)
                j2 = int(np.argmin(g2))
        if j2 >= 0 and (g2[j2] < g1[j1] or (g2[j2] == g1[j1] and j2 < j1)):
            if g2[j2] < gamma:
                gamma, event, best = g2[j2], 2, j2
        elif g1[j1] < gamma:
            gamma, event, best = g1[j1], 1, j1
        if n:
            with np.errstate(divide="ignore", invalid="ignore"):
                g = np.where(w * sign[:n] < 0.0, -beta[:n] / w, np.inf)
            g = np.where(g > tiny, g, np.inf)
            i = int(np.argmin(g))
            if g[i] < gamma:
                gamma, event, best = g[i], 3, i
        beta[:n] += gamma * w
        c -= gamma * a
        lam -= gamma
        dropped = -1
        if event == 0:
            break
        if event == 3:
            dropped = _drop_atom(active, sign, beta, R, state, best, n)
            n -= 1
            try:
                L[:n, :n] = np.linalg.cholesky(R[:n][:, active[:n]]) if n else 0.0
            except np.linalg.LinAlgError:
                return -steps
        else:
            entering = best
            new_sign = 1.0 if event == 1 else -1.0
    else:
        return -steps
    A = active[:n]
    w = _chsolve(L[:n, :n], dtx[A] - alpha * sign[:n]) if n else beta[:0]
    consistent = not (w * sign[:n] < 0.0).any()
    coef[A] = w if consistent else beta[:n]
    return steps


#: below this many signals, the masked solve runs `_lars_masked_numpy`: no
#: compilation, and for a handful of poses as fast as waiting for it. A call
#: that compiles numba anyway (one that adapts: the learning is compiled)
#: asks for the kernel at any size (``FastSolver(numpy_max=0)``): 2.5-4x
#: faster per row once loaded
NUMPY_MAX = 64


class FastSolver(BaseSolver):
    """LARS-lasso homotopy on a cached per-pattern Gram matrix, certified.

    Rows the duality gap does not certify are finished by feature-sign search
    from the path's answer; those it does not certify either are re-solved by
    `fallback` (Clarabel by default) and flagged in ``LassoResult.fallback``.

    Parameters
    ----------
    tol : float, default 1e-6
        Relative duality-gap tolerance of the certificate.
    max_steps : int, default 500
    cache_size : int, default 8
        Gram matrices kept (k x k each: 32 MB at k = 2000).
    fallback : str or BaseSolver or None, default "clarabel"
        Backend for the rows that fail the certificate; None keeps them
        as they are (status "inaccurate").
    gram_min : int, default 12
        Fewer signals than this share no Gram matrix (k x k, about 15 ms to
        form at k = 2000): its rows are computed as atoms enter instead.
    refine : bool, default True
        Finish the rows the certificate rejects by feature-sign search from
        the path's answer (:mod:`._active_set`) before any fallback.
    numpy_max : int, optional
        Masked batches under this many rows run the numpy homotopy, which
        never waits for numba to compile (default :data:`NUMPY_MAX`); 0: the
        compiled kernel at any size, for callers that compile numba anyway.
    working_set : bool or "auto", default "auto"
        True: masked batches of at least `numpy_max` rows are solved on a
        working set of atoms per row, checked on all
        (:func:`lars_lasso_working_set`: the same lasso, no Gram matrix): for
        dictionaries of many atoms, such as the shipped ones beside a file's
        own poses. False: by the full homotopy over every atom. ``"auto"``:
        on working sets from :data:`WS_MIN_ATOMS` atoms, where they are the
        faster of the two (the same codes to round-off).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> D = rng.standard_normal((20, 50)); D /= np.linalg.norm(D, axis=0)
    >>> X = rng.standard_normal((3, 20))
    >>> res = FastSolver().solve(D, X, alpha=0.5)
    >>> res.status.tolist(), bool((res.gap <= 1e-6 * res.objective).all())
    (['optimal', 'optimal', 'optimal'], True)
    """

    name = "fast"
    _refiner = staticmethod(refine_rows)

    def __init__(self, tol=1e-6, max_steps=500, cache_size=8, fallback="clarabel",
                 gram_min=12, refine=True, numpy_max=None, working_set="auto"):
        super().__init__(tol=tol)
        self.working_set = working_set
        self.numpy_max = numpy_max
        self.refine = refine
        self.gram_min = gram_min
        self.max_steps = max_steps
        self.cache_size = cache_size
        self.fallback = fallback
        self._grams = OrderedDict()
        self._lock = threading.Lock()

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_grams"] = OrderedDict()
        del state["_lock"]
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def _gram(self, D, key, shared=False):
        """D's Gram from this solver's cache by `key`; formed on a miss, or
        taken from the process's (:func:`.gram.gram_matrix`) when `shared`
        (whole dictionaries only: per-pattern Grams would crowd them out)."""
        if key is None:
            return D.T @ D
        with self._lock:  # threads of one process share the cache
            G = self._grams.get(key)
            if G is not None:
                self._grams.move_to_end(key)
                return G
        G = gram_matrix(D) if shared else D.T @ D
        with self._lock:
            self._grams[key] = G
            while len(self._grams) > self.cache_size:
                self._grams.popitem(last=False)
        return G

    def _solve_masked(self, D, X, observed, alpha, positive, key):
        numpy_max = NUMPY_MAX if self.numpy_max is None else int(self.numpy_max)
        on_sets = self.working_set is True or (self.working_set == "auto"
                                               and D.shape[1] >= WS_MIN_ATOMS)
        if on_sets and len(X) >= numpy_max:  # (by size only, as below)
            coef, steps = lars_lasso_working_set(D, X, observed, alpha, positive=positive,
                                                 max_steps=self.max_steps)
            return coef, np.full(X.shape[0], OPTIMAL, dtype=object), steps
        # one Gram matrix for the whole dictionary, downdated per row as atoms
        # enter: no per-pattern set-up at all
        coef, steps = lars_lasso_masked(self._gram(D, key, shared=True), D, X, observed, alpha,
                                        positive=positive, max_steps=self.max_steps,
                                        numpy_max=self.numpy_max)
        return coef, np.full(X.shape[0], OPTIMAL, dtype=object), steps

    def _solve(self, D, X, alpha, positive, key):
        if len(X) < self.gram_min:  # (by size only: results must not depend on cache state)
            coef, steps = lars_lasso_rows(
                D, X, alpha, positive=positive, max_steps=self.max_steps)
        else:
            coef, steps = lars_lasso_gram(
                self._gram(D, key), X @ D, alpha, positive=positive,
                max_steps=self.max_steps, rank=D.shape[0])
        # the certificate, and the fallback for rows it rejects, are BaseSolver's
        return coef, np.full(X.shape[0], OPTIMAL, dtype=object), steps
