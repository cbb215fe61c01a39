"""The coupled-dictionary lifter: one lasso recovers and lifts (the toolkit's own, convex).

Training: online dictionary learning (:mod:`sparseedm.learning`) over the
concatenated vectors ``[x2 ; w * x3]`` of complete training poses (x2 the
normalised 2D EDM vector, x3 the 3D one, see :mod:`.base`); each atom is unit
norm over both halves.

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

import hashlib
import os

import numpy as np
from joblib import Parallel, delayed
from threadpoolctl import threadpool_limits

from ..edm import num_joints_from_dim, observed_entries
from ..learning import OnlineDictionaryLearning
from ..solvers import get_solver
from .base import Lifter, LifterError

__all__ = ["DictionaryLifter"]


class DictionaryLifter(Lifter):
    """Coupled [2D ; w 3D] dictionary; lasso on the observed 2D entries.

    Parameters
    ----------
    n_components : int, default 2000
    alpha : float, default 1.6
        Lasso penalty while learning (defaults: the settings chosen on CMU
        validation clips, ``lifters/selection.json``).
    alpha_lift : float, default 0.002
        Lasso penalty when lifting (scaled by observed entries / M).
    weight : float, default 1.0
        w, the weight of the 3D half in the training vectors.
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
    _params = ("n_components", "alpha", "alpha_lift", "weight", "batch_size", "n_passes",
               "normalization", "random_state")

    def __init__(self, n_components=2000, *, alpha=1.6, alpha_lift=0.002, weight=1.0,
                 batch_size=512, n_passes=1, normalization="tied", solver="fast",
                 random_state=0):
        super().__init__(normalization=normalization, random_state=random_state)
        self.n_components = n_components
        self.alpha = alpha
        self.alpha_lift = alpha_lift
        self.weight = weight
        self.batch_size = batch_size
        self.n_passes = n_passes
        self.solver = solver

    def _fit(self, X2, X3):
        if not self.weight > 0:
            raise LifterError(f"weight must be > 0, got {self.weight!r}")
        X = np.hstack([X2, self.weight * X3])
        odl = OnlineDictionaryLearning(self.n_components, alpha=self.alpha,
                                       batch_size=self.batch_size, n_passes=self.n_passes,
                                       random_state=self.random_state)
        self.components_ = odl.fit(X).components_

    def _describe_model(self):
        k, m2 = self.components_.shape
        return f"coupled dictionary: {k} atoms over [2D ; {self.weight:g} x 3D] ({m2} entries)"

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
        lf = cls(**{k: params[k] for k in cls._params if k in params})
        lf.components_ = C.astype(float)
        return lf

    def _check_dims(self, n_joints, where):
        m = self.components_.shape[1] // 2
        if num_joints_from_dim(m) != n_joints:
            raise LifterError(f"{where}: atoms have {m} entries per half, not the "
                              f"{n_joints * (n_joints - 1) // 2} of {n_joints} joints")

    def predict(self, X2, missing=None, *, n_jobs=1, chunk_size=2048):
        """3D EDM vectors from the observed entries of 2D EDM vectors.

        Parameters
        ----------
        X2 : (n, M) normalised 2D EDM vectors (entries touching a missing
            joint are ignored)
        missing : (n, N) bool, optional
            None: every entry is used.
        n_jobs : threads over chunks (the fast solver releases the GIL)

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
        N = num_joints_from_dim(m)
        mask = np.zeros((n, N), bool) if missing is None else np.asarray(missing, bool)
        solver = get_solver(self.solver)
        key = (hashlib.sha1(np.ascontiguousarray(C).tobytes()).hexdigest(), "2d-half")
        workers = os.cpu_count() or 1 if n_jobs == -1 else max(int(n_jobs or 1), 1)
        observed = observed_entries(mask)
        alpha = self.alpha_lift * observed.sum(axis=1) / m
        # rows of every pattern in one masked solve per chunk (as recover() does):
        # the fast solver downdates one cached Gram of the 2D halves per row;
        # rows are sorted by pattern, and with several workers each gets a share
        order = np.lexsort(mask.T[::-1])
        n_chunks = max(-(-n // chunk_size), workers if workers > 1 else 1)
        tasks = [t for t in np.array_split(order, max(1, min(n_chunks, n))) if len(t)]
        D2 = C[:, :m].T

        def run(rows):
            res = solver.solve_masked(D2, X2[rows], observed[rows], alpha[rows], key=key)
            return res.coef @ C, res

        with threadpool_limits(1, user_api="blas"):
            if n_jobs in (None, 1):
                out = [run(t) for t in tasks]
            else:
                out = Parallel(n_jobs=n_jobs, backend="threading")(delayed(run)(t) for t in tasks)
        full = np.full((n, 2 * m), np.nan)
        info = {"status": np.full(n, "failed", dtype=object), "objective": np.full(n, np.nan),
                "gap": np.full(n, np.nan), "n_active": np.zeros(n, int),
                "fallback": np.zeros(n, bool)}
        for rows, (rec, res) in zip(tasks, out):
            full[rows] = rec
            info["status"][rows] = res.status
            info["objective"][rows] = res.objective
            info["gap"][rows] = res.gap
            info["n_active"][rows] = (res.coef != 0).sum(axis=1)
            info["fallback"][rows] = res.fallback
        info["status"] = info["status"].astype(str)
        info["vectors2d"] = full[:, :m]
        return full[:, m:] / self.weight, info
