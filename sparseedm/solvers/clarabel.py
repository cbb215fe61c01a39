"""Lasso backend on the Clarabel interior-point solver (directly, or through cvxpy).

Two methods give the same answer (the lasso minimiser, to solver accuracy,
certified by the shared duality gap of :mod:`sparseedm.solvers.base`):

``method="working-set"`` (default, fast)
    For each signal, Clarabel solves the lasso restricted to a small *working
    set* W of atoms, called directly (``clarabel.DefaultSolver``) on the
    Gram-form QP ``min 0.5 c'G c - b'c + alpha 1't, -t <= c <= t`` with
    ``G = D_W' D_W``, ``b = D_W' x`` (for ``positive=True``: ``c >= 0`` and no
    ``t``). The answer is then *checked on the full lasso*: the residual gives
    a dual-feasible point and a duality gap over all atoms. If the gap is not
    below ``tol`` the working set grows by the atoms closest to violating the
    optimality conditions (priority ``(alpha - |d_j' theta|) / ||d_j||``, as in
    Celer, Massias et al. 2018), after discarding every atom that the gap-safe
    sphere test (Fercoq, Gramfort, Salmon 2015) proves to be zero at the
    optimum; then Clarabel solves again. The loop stops only on a full-problem
    certificate, so the working set can never change the answer; it only
    avoids 2000-atom interior-point factorisations (about 250 ms each).
    W starts (``seed="lars"``, the default) as the support of the LARS-lasso
    homotopy's answer (:mod:`.fast`, a few milliseconds), so one Clarabel
    solve on ~30 atoms usually certifies the pose; with ``seed="correlation"``
    as the ``init_size`` atoms most correlated with x. It grows by
    ``grow_size`` atoms per round. The seed only picks the atoms Clarabel
    looks at first: the answer is Clarabel's, certified on the full lasso.

``method="dpp"``
    One compiled cvxpy problem per ``(key, n_features, positive)``: the
    residual form ``min 0.5 ||r||^2 + alpha ||c||_1  s.t.  r = x - D c``, where
    the observed vector x **and alpha** are ``cp.Parameter``s, so one
    compilation serves every signal of a missing-joint pattern and every
    alpha. Compiled problems live in a bounded LRU cache (``cache_size``) and
    are re-solved with ``warm_start=True`` so cvxpy also re-uses Clarabel's
    KKT structure. It is exact but slow at k = 2000 (the full KKT system).

Both methods finish with a *polish* step: on the support S and signs s of
Clarabel's answer, solve ``D_S' D_S c_S = D_S' x - alpha s`` (the lasso's
optimality equations on S) and keep that point only if it has the same signs
and a smaller full-problem duality gap. It removes the interior-point's
residual ~1e-9 noise on the zero coefficients; it never moves away from the
optimum.

The solver object is picklable (joblib/loky workers): the cache of compiled
problems is dropped in ``__getstate__`` and rebuilt on demand.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from .base import FAILED, INACCURATE, OPTIMAL, BaseSolver

__all__ = ["ClarabelSolver"]

#: Clarabel's status strings -> ours. Anything else ("MaxIterations",
#: "PrimalInfeasible", "NumericalError", "InsufficientProgress", ...) is failed.
_CLARABEL_STATUS = {"Solved": OPTIMAL, "AlmostSolved": INACCURATE}
#: cvxpy's status strings -> ours.
_CVXPY_STATUS = {"optimal": OPTIMAL, "optimal_inaccurate": INACCURATE}


def _import_clarabel():
    import clarabel

    return clarabel


def _full_gap(D, x, c_support, support, alpha, positive):
    """(primal, gap, corr, shrink) of the full lasso at c (given on `support`)."""
    r = x - D[:, support] @ c_support
    corr = D.T @ r
    dual_norm = corr.max() if positive else np.abs(corr).max()
    shrink = max(1.0, max(dual_norm, 0.0) / alpha)
    theta = r / shrink
    primal = 0.5 * (r @ r) + alpha * np.abs(c_support).sum()
    dual = 0.5 * (x @ x) - 0.5 * np.sum((x - theta) ** 2)
    return primal, max(primal - dual, 0.0), corr, shrink


def _triu_csc(G, n):
    """The upper triangle of the square G, top-left of an n x n CSC matrix."""
    ks = len(G)
    rows, cols = np.triu_indices(ks)
    order = np.lexsort((rows, cols))  # column-major
    nnz = ks * (ks + 1) // 2
    indptr = np.concatenate([[0], np.cumsum(np.arange(1, ks + 1)), np.full(n - ks, nnz)])
    return sp.csc_matrix((G[rows[order], cols[order]], rows[order], indptr), shape=(n, n))


def _box_csc(ks):
    """``[[I, -I], [-I, -I]]`` in CSC form: the rows of ``-t <= c <= t``."""
    j = np.arange(ks)
    indices = np.stack([j, ks + j], axis=1).ravel()
    data = np.concatenate([np.tile([1.0, -1.0], ks), np.full(2 * ks, -1.0)])
    indptr = np.arange(0, 4 * ks + 1, 2)
    return sp.csc_matrix((data, np.concatenate([indices, indices]), indptr),
                         shape=(2 * ks, 2 * ks))


def _polish_candidates(D, x, c, alpha, positive, levels=(1e-6, 1e-4, 1e-3, 1e-2)):
    """Solutions of the optimality equations on candidate supports of c.

    For each relative threshold, the support S = {|c_j| > level * max|c|}
    with the signs s of c on it gives ``D_S' D_S c_S = D_S' x - alpha s``.
    Yields the solutions that are finite and reproduce the signs (a lasso
    optimum on S, hence a candidate global optimum to check by its gap).
    Several levels because an interior-point answer near a degenerate atom
    (|d_j' r| ~ alpha) leaves it at ~1e-4 rather than ~1e-10.
    """
    amax = np.abs(c).max() if c.size else 0.0
    if amax == 0.0:
        return
    seen = set()
    for level in levels:
        support = np.flatnonzero(np.abs(c) > level * amax)
        sig = support.tobytes()
        if sig in seen or support.size > D.shape[0]:
            continue
        seen.add(sig)
        signs = np.sign(c[support])
        if positive and (signs < 0).any():
            continue
        DS = D[:, support]
        try:
            cho = scipy.linalg.cho_factor(DS.T @ DS, check_finite=False)
            cS = scipy.linalg.cho_solve(cho, DS.T @ x - alpha * signs, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            continue
        if not np.isfinite(cS).all() or (np.sign(cS) != signs).any():
            continue
        out = np.zeros_like(c)
        out[support] = cS
        yield out


def _omp_atoms(D, x, n_atoms, positive):
    """Atoms chosen by orthogonal matching pursuit (a working-set *guess* only)."""
    chosen = []
    r = x
    for _ in range(min(n_atoms, D.shape[0], D.shape[1])):
        corr = D.T @ r
        score = corr if positive else np.abs(corr)
        score[chosen] = -np.inf
        j = int(np.argmax(score))
        if not score[j] > 0:
            break
        chosen.append(j)
        DS = D[:, chosen]
        coef, *_ = np.linalg.lstsq(DS, x, rcond=None)
        r = x - DS @ coef
    return np.asarray(chosen, dtype=int)


class ClarabelSolver(BaseSolver):
    """Lasso by the Clarabel interior-point solver.

    Parameters
    ----------
    tol : float, default 1e-6
        Relative duality-gap tolerance of the certificate (see
        :class:`~sparseedm.solvers.base.BaseSolver`); the working-set loop
        runs until the full-problem gap is below ``tol / 10`` times the
        objective.
    method : {"working-set", "dpp"}, default "working-set"
        See the module docstring.
    seed : {"lars", "correlation"}, default "lars"
        Initial working set (``method="working-set"``): the support of the
        LARS homotopy's answer (padded to ``init_size`` atoms by correlation
        when smaller), or the ``init_size`` atoms most correlated with x.
    init_size : int, default 16
        Initial working-set size (``method="working-set"``).
    init_omp : int, default 0
        Of the initial working set, this many atoms are picked by orthogonal
        matching pursuit, the rest by correlation with x (0: correlation only).
    grow_size : int, default 8
        Atoms added per working-set round (the most violating survivors).
    gram_max : int, default 64
        Largest working set solved in Gram form (beyond: residual form).
    max_outer : int, default 50
        Maximum working-set rounds per signal.
    cache_size : int, default 32
        Compiled cvxpy problems kept (``method="dpp"``), least recently used
        dropped first. One k = 2000 problem holds a few MB.
    polish : bool, default True
        Polish Clarabel's answer on its support (see the module docstring).
    clarabel_tol : float, default 1e-9
        Clarabel's ``tol_gap_abs``, ``tol_gap_rel`` and ``tol_feas``.
    max_iter : int, default 200
        Clarabel's interior-point iteration limit.

    Attributes
    ----------
    n_compilations_ : int
        cvxpy problems compiled so far by this object (``method="dpp"``).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> D = rng.normal(size=(20, 50)); D /= np.linalg.norm(D, axis=0)
    >>> X = D[:, [3, 7]] @ np.array([[1.0, -2.0]]).T
    >>> res = ClarabelSolver().solve(D, X.T, alpha=0.01)
    >>> res.status.tolist(), np.flatnonzero(np.abs(res.coef[0]) > 0.1).tolist()
    (['optimal'], [3, 7])
    """

    name = "clarabel"

    def __init__(
        self,
        tol=1e-6,
        *,
        method="working-set",
        seed="lars",
        init_size=16,
        grow_size=8,
        init_omp=0,
        gram_max=64,
        max_outer=50,
        cache_size=32,
        polish=True,
        clarabel_tol=1e-9,
        max_iter=200,
    ):
        super().__init__(tol=tol)
        if method not in ("working-set", "dpp"):
            raise ValueError(
                f"method must be 'working-set' or 'dpp', got {method!r}"
            )
        if seed not in ("lars", "correlation"):
            raise ValueError(f"seed must be 'lars' or 'correlation', got {seed!r}")
        self.method = method
        self.seed = seed
        self.init_size = int(init_size)
        self.grow_size = max(int(grow_size), 1)
        self.init_omp = int(init_omp)
        self.gram_max = int(gram_max)
        self.max_outer = int(max_outer)
        self.cache_size = int(cache_size)
        self.polish = bool(polish)
        self.clarabel_tol = float(clarabel_tol)
        self.max_iter = int(max_iter)
        self.n_compilations_ = 0
        self._init_runtime()

    # -- pickling: drop what cannot (or should not) travel --------------------
    def _init_runtime(self):
        self._lars = None  # a FastSolver: the LARS seeds and its Gram cache
        self._cache = OrderedDict()
        self._lock = threading.RLock()
        self._settings = None

    def __getstate__(self):
        state = self.__dict__.copy()
        for name in ("_cache", "_lock", "_settings", "_lars"):
            state.pop(name, None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._init_runtime()

    # -- shared ---------------------------------------------------------------
    def _clarabel_settings(self):
        if self._settings is None:
            clarabel = _import_clarabel()
            st = clarabel.DefaultSettings()
            st.verbose = False
            st.tol_gap_abs = st.tol_gap_rel = st.tol_feas = self.clarabel_tol
            st.max_iter = self.max_iter
            self._settings = st
        return self._settings

    def _maybe_polish(self, D, x, c, alpha, positive):
        if not self.polish:
            return c
        nz = np.flatnonzero(c)
        best, best_gap = c, _full_gap(D, x, c[nz], nz, alpha, positive)[1]
        for cand in _polish_candidates(D, x, c, alpha, positive):
            nz = np.flatnonzero(cand)
            gap = _full_gap(D, x, cand[nz], nz, alpha, positive)[1]
            if gap < best_gap:
                best, best_gap = cand, gap
        return best

    def _solve(self, D, X, alpha, positive, key):
        if self.method == "dpp":
            return self._solve_dpp(D, X, alpha, positive, key)
        return self._solve_working_set(D, X, alpha, positive, self._seeds(D, X, alpha, positive,
                                                                          key))

    def _seeder(self):
        if self._lars is None:
            from .fast import FastSolver

            self._lars = FastSolver(fallback=None)
        return self._lars

    def _seeds(self, D, X, alpha, positive, key):
        """LARS codes whose supports seed the working sets (None: by correlation)."""
        if self.seed != "lars":
            return None
        return self._seeder()._solve(D, X, alpha, positive, key)[0]

    def _solve_masked(self, D, X, observed, alpha, positive, key):
        if self.method == "dpp" or self.seed != "lars":
            return super()._solve_masked(D, X, observed, alpha, positive, key)
        # every row's seed in one call (one cached Gram matrix for all patterns)
        seeds = self._seeder()._solve_masked(D, X, observed, alpha, positive, key)[0]
        return self._by_pattern(
            D, X, observed, alpha, key,
            lambda Ds, Xs, a, sub_key, rows: self._solve_working_set(Ds, Xs, a, positive,
                                                                     seeds[rows]))

    # -- method="working-set": Clarabel called directly on small QPs ----------
    def _reduced(self, DW, x, alpha, positive):
        """Clarabel on the lasso restricted to the columns DW.

        Up to ``gram_max`` columns: the Gram form (dense P = D_W' D_W, no
        equality rows); beyond: the residual form (P = I on r, r + D_W c = x),
        whose KKT factorisation grows like ks * m^2 rather than ks^3.
        """
        clarabel = _import_clarabel()
        m, ks = DW.shape
        if ks <= self.gram_max:
            # built straight in CSC form (scipy's sparse constructors cost more
            # than the solve at these sizes)
            b = DW.T @ x
            if positive:
                P, q = _triu_csc(DW.T @ DW, ks), alpha - b
                A, h = -sp.identity(ks, format="csc"), np.zeros(ks)
                cones = [clarabel.NonnegativeConeT(ks)]
            else:
                P = _triu_csc(DW.T @ DW, 2 * ks)
                q = np.concatenate([-b, np.full(ks, alpha)])
                A, h = _box_csc(ks), np.zeros(2 * ks)
                cones = [clarabel.NonnegativeConeT(2 * ks)]
        else:
            # variables (c, [t,] r): min 0.5 ||r||^2 + alpha 1't  s.t.  D_W c + r = x
            eye = sp.identity(ks, format="csc")
            nt = 0 if positive else ks
            n = ks + nt + m
            P = sp.csc_matrix(
                (np.ones(m), (np.arange(n - m, n), np.arange(n - m, n))), shape=(n, n)
            )
            q = np.concatenate([np.full(ks, alpha) if positive else np.zeros(ks),
                                np.full(nt, alpha), np.zeros(m)])
            Dsp, Im = sp.csc_matrix(DW), sp.identity(m, format="csc")
            if positive:
                A = sp.bmat([[Dsp, Im], [-eye, None]], format="csc")
            else:
                A = sp.bmat([[Dsp, None, Im], [eye, -eye, None], [-eye, -eye, None]],
                            format="csc")
            h = np.concatenate([x, np.zeros(A.shape[0] - m)])
            cones = [clarabel.ZeroConeT(m), clarabel.NonnegativeConeT(A.shape[0] - m)]
        sol = clarabel.DefaultSolver(P, q, A, h, cones, self._clarabel_settings()).solve()
        c = np.asarray(sol.x[:ks], dtype=float)
        return c, _CLARABEL_STATUS.get(str(sol.status), FAILED), int(sol.iterations)

    def _solve_working_set(self, D, X, alpha, positive, seeds=None):
        n, k = X.shape[0], D.shape[1]
        coef = np.zeros((n, k))
        status = np.empty(n, dtype=object)
        n_iter = np.zeros(n, dtype=int)
        norms = np.linalg.norm(D, axis=0)
        norms_safe = np.where(norms > 0, norms, 1.0)
        corr0 = X @ D  # (n, k): D' x for every signal at once
        target = 0.1 * self.tol
        for i in range(n):
            x = X[i]
            score = corr0[i] if positive else np.abs(corr0[i])
            score = np.where(norms > 0, score, -np.inf)  # zero atoms never help
            W = np.argsort(-score)[: min(self.init_size, k)]
            if seeds is not None:
                support = np.flatnonzero(seeds[i])
                W = support if len(support) >= self.init_size else np.union1d(
                    support, W[: self.init_size - len(support)])
            if self.init_omp > 0:
                W = np.union1d(W[: max(self.init_size - self.init_omp, 0)],
                               _omp_atoms(D, x, self.init_omp, positive))
            W = np.sort(W)
            st_i, it_i = FAILED, 0
            W_sol, c_sol = W[:0], np.zeros(0)
            for _ in range(max(self.max_outer, 1)):
                cW, st_i, it = self._reduced(D[:, W], x, alpha, positive)
                it_i += it
                if not np.isfinite(cW).all():
                    W_sol, c_sol, st_i = W[:0], np.zeros(0), FAILED
                    break
                if self.polish:
                    full = np.zeros(k)
                    full[W] = cW
                    cW = self._maybe_polish(D, x, full, alpha, positive)[W]
                W_sol, c_sol = W, cW
                primal, gap, corr, shrink = _full_gap(D, x, cW, W, alpha, positive)
                if gap <= target * max(primal, np.finfo(float).tiny):
                    break
                # Gap-safe sphere test on the full problem: atoms with
                # |d_j' theta| + sqrt(2 gap) ||d_j|| < alpha are zero at the optimum.
                tcorr = (corr if positive else np.abs(corr)) / shrink
                alive = tcorr + np.sqrt(2.0 * gap) * norms >= alpha
                alive &= norms > 0
                prio = np.where(alive, (alpha - tcorr) / norms_safe, np.inf)
                inW = np.zeros(k, dtype=bool)
                inW[W] = True
                keepW = W[alive[W]]
                prio[inW] = np.inf
                n_new = int(np.isfinite(prio).sum())
                if n_new == 0:
                    break  # every surviving atom is in W: nothing left to add
                grow = min(self.grow_size, n_new)
                new = np.argpartition(prio, grow - 1)[:grow] if grow < k else np.flatnonzero(np.isfinite(prio))
                W = np.union1d(keepW, new[np.isfinite(prio[new])])
            coef[i, W_sol] = c_sol
            status[i] = st_i
            n_iter[i] = it_i
        return coef, status, n_iter

    # -- method="dpp": one compiled cvxpy problem per key ---------------------
    def _compiled(self, D, positive, key):
        import cvxpy as cp

        ckey = (key, D.shape, positive)
        with self._lock:
            entry = self._cache.get(ckey) if key is not None else None
            if entry is not None and np.array_equal(entry["D"], D):
                self._cache.move_to_end(ckey)
                return entry
            m, k = D.shape
            x = cp.Parameter(m, name="x")
            a = cp.Parameter(nonneg=True, name="alpha")
            c = cp.Variable(k, nonneg=positive, name="c")
            r = cp.Variable(m, name="r")
            objective = 0.5 * cp.sum_squares(r) + a * (cp.sum(c) if positive else cp.norm1(c))
            problem = cp.Problem(cp.Minimize(objective), [r == x - D @ c])
            entry = {"D": D.copy(), "problem": problem, "x": x, "alpha": a, "c": c,
                     "lock": threading.Lock()}
            self.n_compilations_ += 1
            if key is not None:
                self._cache[ckey] = entry
                while len(self._cache) > max(self.cache_size, 0):
                    self._cache.popitem(last=False)
            return entry

    def _solve_dpp(self, D, X, alpha, positive, key):
        import cvxpy as cp

        entry = self._compiled(D, positive, key)
        n, k = X.shape[0], D.shape[1]
        coef = np.zeros((n, k))
        status = np.empty(n, dtype=object)
        n_iter = np.zeros(n, dtype=int)
        tol = self.clarabel_tol
        with entry["lock"]:
            entry["alpha"].value = alpha
            for i in range(n):
                entry["x"].value = X[i]
                try:
                    entry["problem"].solve(
                        solver=cp.CLARABEL, warm_start=True, max_iter=self.max_iter,
                        tol_gap_abs=tol, tol_gap_rel=tol, tol_feas=tol,
                    )
                    st = _CVXPY_STATUS.get(entry["problem"].status, FAILED)
                    c = entry["c"].value
                    n_iter[i] = entry["problem"].solver_stats.num_iters or 0
                except cp.error.SolverError:
                    st, c = FAILED, None
                if c is None or not np.isfinite(c).all():
                    st, c = FAILED, np.zeros(k)
                elif st != FAILED:
                    c = self._maybe_polish(D, X[i], np.asarray(c, dtype=float), alpha, positive)
                coef[i] = c
                status[i] = st
        return coef, status, n_iter
