"""The coupled-dictionary lifter: one lasso recovers and lifts (the toolkit's own, convex).

Training: online dictionary learning (:mod:`sparseedm.learning`) over the
concatenated vectors ``[x2 ; w * x3]`` of complete training poses (x2 the
normalised 2D EDM vector, x3 the 3D one, see :mod:`.base`); each atom is unit
norm over both halves. Then (``decoder_ridge``, on by default) the 3D halves
are re-fitted to the training poses given the codes the lifter will actually
compute: the codes ``c_i`` of the 2D halves alone (the lifting lasso), and
``D3 = argmin sum_i ||w x3_i - D3 c_i||^2 + n rho ||D3 - D3_learned||_F^2``,
a ridge regression shrunk towards the learned halves (one k x k solve).
Learning fits ``[x2 ; w x3]`` jointly, but a lifted pose is coded on x2 only,
so its 3D read-out is not the one learning optimised; the re-fit is the best
linear read-out of the 2D codes (docs/explanation/settings.md).

Lifting a pose: keep the entries of its 2D EDM vector that touch no occluded
joint, solve the lasso ``min_c 0.5 ||x2_obs - D2_obs c||^2 + alpha_eff ||c||_1``
on the same rows of the 2D half (``alpha_eff = alpha_lift * m_obs / M``, as
recovery scales it), and read ``x3 = D3 c / w`` from the 3D half. An occluded
pose thus needs no separate recovery step: the code that explains its
observed distances also gives its 3D distances. The lasso is solved by the
solver layer (:func:`sparseedm.solvers.get_solver`, certified "fast" LARS with
the Clarabel fallback), grouped by missing pattern so each pattern's Gram
matrix is built once.

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> X3 = np.abs(rng.standard_normal((200, 6)))
>>> X2 = X3 * 0.8 + 0.05 * rng.standard_normal((200, 6))
>>> lf = DictionaryLifter(n_components=20, alpha=0.05, alpha_lift=0.001,
...                       batch_size=50, random_state=0).fit(X2, X3)
>>> Y, info = lf.predict(X2[:3])
>>> Y.shape, info["status"].tolist()
((3, 6), ['optimal', 'optimal', 'optimal'])
"""

from __future__ import annotations

import numpy as np
from joblib import Parallel, delayed
from threadpoolctl import threadpool_limits

from .. import _progress
from .._coding import atoms_key, pattern_order
from .._parallel import chunk_tasks, leaves_cores_idle, numba_threads
from .._validation import usable_jobs
from ..edm import num_joints_from_dim, observed_entries, triu_indices
from ..learning import OnlineDictionaryLearning
from ..solvers import get_solver
from .base import Lifter, LifterError

__all__ = ["DictionaryLifter", "WEIGHTED_GROUP_MIN"]

#: weighted rows sharing one weighted sub-dictionary are solved together from this
#: many on: the solve then forms its k x k Gram once (about 0.3 s at k = 2000)
#: and takes about 3 ms a row against 7 ms a row alone (benchmarks/lift_weighted.py:
#: 60 rows together 0.7x, 200 rows 1.6x, 400 rows 1.85x on 2 loaded cores)
WEIGHTED_GROUP_MIN = 100


class DictionaryLifter(Lifter):
    """Coupled [2D ; w 3D] dictionary; lasso on the observed 2D entries.

    Parameters
    ----------
    n_components : int, default 2000
    alpha : float, default 1.6
        Lasso penalty while learning (defaults: the settings chosen on CMU
        validation clips, ``studies/lifting/selection.json``).
    alpha_lift : float, default 0.002
        Lasso penalty when lifting (scaled by observed entries / M).
    weight : float, default 1.0
        w, the weight of the 3D half in the training vectors.
    decoder_ridge : float or None, default 0.01
        rho, the per-pose ridge penalty of the 3D-half re-fit (see the module
        docstring); None keeps the learned 3D halves.
    batch_size, n_passes : learner settings
    normalization : {"tied", "unit"}
    solver : str, default "fast"
    random_state : int

    Attributes
    ----------
    components_ : ndarray (n_components, 2 M)
    """

    method = "dictionary"
    codes_observed_only = True
    _params = ("n_components", "alpha", "alpha_lift", "weight", "decoder_ridge", "batch_size",
               "n_passes", "normalization", "random_state")

    def __init__(self, n_components=2000, *, alpha=1.6, alpha_lift=0.002, weight=1.0,
                 decoder_ridge=0.01, batch_size=512, n_passes=2, normalization="tied",
                 solver="fast", random_state=0):
        super().__init__(normalization=normalization, random_state=random_state)
        self.n_components = n_components
        self.alpha = alpha
        self.alpha_lift = alpha_lift
        self.weight = weight
        self.decoder_ridge = decoder_ridge
        self.batch_size = batch_size
        self.n_passes = n_passes
        self.solver = solver

    def _fit(self, X2, X3):
        if not self.weight > 0:
            raise LifterError(f"weight must be > 0, got {self.weight!r}")
        rho = self.decoder_ridge
        if rho is not None and not (np.isfinite(rho) and rho > 0):
            raise LifterError(f"decoder_ridge must be > 0 or None, got {rho!r}")
        X = np.hstack([X2, self.weight * X3])
        odl = OnlineDictionaryLearning(self.n_components, alpha=self.alpha,
                                       batch_size=self.batch_size, n_passes=self.n_passes,
                                       random_state=self.random_state)
        self.components_ = odl.fit(X).components_
        if rho is not None:
            self.components_ = self._refit_decoder(X2, self.weight * X3, rho)

    def _refit_decoder(self, X2, Y, rho):
        """Components with the 3D halves re-fitted to ``Y`` (= w X3) given the 2D codes."""
        return self._solve_decoder(*self._decoder_stats(X2, Y), rho, len(X2))

    def _decoder_stats(self, X2, Y, chunk_size=2048):
        """``(Z'Z, Z'Y)`` over the lifting codes Z of the complete 2D vectors X2."""
        from scipy.sparse import csr_matrix

        k = self.components_.shape[0]
        G, B = np.zeros((k, k)), np.zeros((k, Y.shape[1]))
        _progress.say(f"re-fitting the 3D halves of the atoms to the lifting codes of "
                      f"{len(X2):,} training poses")

        def stats(rows, res):
            Z = csr_matrix(res.coef)
            return (Z.T @ Z).toarray(), Z.T @ Y[rows]

        for g, b in self._lasso_chunks(X2, None, 1, chunk_size, stats):
            G += g
            B += b
        return G, B

    def _solve_decoder(self, G, B, rho, n):
        from scipy.linalg import cho_factor, cho_solve

        C = self.components_
        m = C.shape[1] // 2
        lam = rho * n
        D3 = cho_solve(cho_factor(G + lam * np.eye(len(G))), B + lam * C[:, m:])
        return np.hstack([C[:, :m], D3])

    def _describe_model(self):
        k, m2 = self.components_.shape
        refit = ("" if self.decoder_ridge is None
                 else f", 3D halves re-fitted to the 2D codes (ridge {self.decoder_ridge:g})")
        return (f"coupled dictionary: {k} atoms over [2D ; {self.weight:g} x 3D] ({m2} entries)"
                + refit)

    def _arrays(self):
        return {"components": self.components_}

    @classmethod
    def _from_arrays(cls, arrays, params, where):
        if "components" not in arrays:
            raise LifterError(f"{where}: dictionary lifter without 'components'")
        C = arrays["components"]
        if C.dtype.kind != "f" or C.ndim != 2 or C.shape[1] % 2 or not np.isfinite(C).all():
            raise LifterError(f"{where}: components must be finite floats (k, 2M), got "
                              f"{C.dtype} {C.shape}")
        # files written before the 3D-half re-fit existed hold learned halves
        params = dict({"decoder_ridge": None}, **params)
        lf = cls(**{k: params[k] for k in cls._params if k in params})
        lf.components_ = C.astype(float)
        return lf

    def _check_dims(self, n_joints, where):
        m = self.components_.shape[1] // 2
        if num_joints_from_dim(m) != n_joints:
            raise LifterError(f"{where}: atoms have {m} entries per half, not the "
                              f"{n_joints * (n_joints - 1) // 2} of {n_joints} joints")

    def _lasso_chunks(self, X2, missing, n_jobs, chunk_size, fn, progress=False):
        """``fn(rows, result)`` for every chunk of the lasso on the observed 2D entries.

        Rows of every missing pattern go through one masked solve per chunk (as
        recover() does): the fast solver downdates one cached Gram of the 2D
        halves per row; rows are sorted by pattern, and with several workers
        each gets a share. `fn` runs in the worker, so a chunk's dense codes
        never outlive it. `progress`: a tqdm bar over the chunks. Returns the
        list of `fn`'s values.
        """
        from tqdm.auto import tqdm

        n, m = X2.shape
        C = self.components_
        N = num_joints_from_dim(m)
        mask = np.zeros((n, N), bool) if missing is None else np.asarray(missing, bool)
        solver = get_solver(self.solver)
        key = (atoms_key(C[:, :m]), "2d-half")
        observed = observed_entries(mask)
        alpha = self.alpha_lift * observed.sum(axis=1) / m
        # pattern-sorted rows in tasks as recover() cuts them: a share per worker,
        # none under the compiled kernel's size
        tasks = chunk_tasks(pattern_order(mask), chunk_size, n_jobs)
        D2 = C[:, :m].T

        def run(rows, threads=None):
            # a joblib worker's kernels on one numba thread, as recover()'s
            # (_recovery_kernel.solve_chunk): workers x numba's threads would
            # oversubscribe the cores; in-process, numba's threads are left as set
            with numba_threads(threads):
                return fn(rows, solver.solve_masked(D2, X2[rows], observed[rows], alpha[rows],
                                                    key=key))

        bar = dict(total=len(tasks), disable=not progress, unit="chunk", desc="lift")
        with threadpool_limits(1, user_api="blas"):
            n_jobs = usable_jobs(n_jobs, len(tasks))
            if n_jobs == 1 or leaves_cores_idle(n_jobs):  # in-process: every core
                return [run(t) for t in tqdm(tasks, **bar)]
            return list(tqdm(Parallel(n_jobs=n_jobs, backend="threading", return_as="generator")(
                delayed(run)(t, 1) for t in tasks), **bar))

    def _weighted_rows(self, X2, missing, weights):
        """The lasso of each row on its observed entries scaled by ``sqrt(w_i w_j)``
        (joint weights `weights`), no cached Gram: one solve per row, except that
        :data:`WEIGHTED_GROUP_MIN` or more rows sharing their observed entries and
        weights (one weighted sub-dictionary) are solved together."""
        m = X2.shape[1]
        C = self.components_
        rows, cols = triu_indices(num_joints_from_dim(m))
        keep = observed_entries(missing)
        sw = np.where(keep, np.sqrt(weights[:, rows] * weights[:, cols]), 0.0)
        _, group = np.unique(np.hstack([keep, sw]), axis=0, return_inverse=True)
        group = group.reshape(-1)
        solver = get_solver(self.solver)
        groups = np.split(np.argsort(group, kind="stable"),
                          np.flatnonzero(np.diff(np.sort(group))) + 1)
        out = []
        for idx in [g for g in groups if len(g) >= WEIGHTED_GROUP_MIN] + [
                g[i:i + 1] for g in groups if len(g) < WEIGHTED_GROUP_MIN for i in range(len(g))]:
            k, w = keep[idx[0]], sw[idx[0], keep[idx[0]]]
            res = solver.solve(C[:, :m][:, k].T * w[:, None], X2[idx][:, k] * w,
                               self.alpha_lift * k.sum() / m)
            out.append((idx, res.coef @ C, res.status, res.objective, res.gap,
                        (res.coef != 0).sum(axis=1), res.fallback))
        return out

    def predict(self, X2, missing=None, *, n_jobs=1, chunk_size=2048, weights=None,
                progress=False):
        """3D EDM vectors from the observed entries of 2D EDM vectors.

        Parameters
        ----------
        X2 : (n, M) normalised 2D EDM vectors (entries touching a missing
            joint are ignored)
        missing : (n, N) bool, optional
            None: every entry is used.
        n_jobs : threads over chunks (the fast solver releases the GIL)
        weights : (n, N) floats in (0, 1], optional
            Per-joint weights: the lasso's 2D entry (i, j) counts ``w_i w_j``
            (:func:`sparseedm.lifting.uncertainty3d.filled_weights` down-weights
            joints filled across time). Rows whose weights are all 1 are coded
            as without them.
        progress : bool, default False
            A progress bar over the chunks of the lasso (the rows with weights
            are coded after it, without one).

        Returns
        -------
        X3 : (n, M), info : dict with ``status``, ``objective``, ``gap``,
        ``n_active``, ``fallback`` and ``vectors2d`` (the 2D half of D c: the
        completed 2D EDM vectors)
        """
        X2 = np.atleast_2d(np.asarray(X2, float))
        n, m = X2.shape
        C = self.components_
        if C.shape[1] != 2 * m:
            raise LifterError(f"the lifter codes {C.shape[1] // 2}-entry vectors, got {m}")
        mask = np.zeros((n, num_joints_from_dim(m)), bool) if missing is None else missing
        plain = np.ones(n, bool) if weights is None else (weights >= 1).all(axis=1)
        sub = np.flatnonzero(plain)
        out = [] if not len(sub) else self._lasso_chunks(
            X2[sub], mask[sub], n_jobs, chunk_size,
            lambda rows, res: (sub[rows], res.coef @ C, res.status, res.objective, res.gap,
                               (res.coef != 0).sum(axis=1), res.fallback), progress)
        if not plain.all():
            other = np.flatnonzero(~plain)
            for rows, *rest in self._weighted_rows(X2[other], mask[other], weights[other]):
                out.append((other[rows], *rest))
        full = np.full((n, 2 * m), np.nan)
        info = {"status": np.full(n, "failed", dtype=object), "objective": np.full(n, np.nan),
                "gap": np.full(n, np.nan), "n_active": np.zeros(n, int),
                "fallback": np.zeros(n, bool)}
        for rows, rec, *values in out:
            full[rows] = rec
            for name, v in zip(("status", "objective", "gap", "n_active", "fallback"), values):
                info[name][rows] = v
        info["status"] = info["status"].astype(str)
        info["vectors2d"] = full[:, :m]
        return full[:, m:] / self.weight, info
