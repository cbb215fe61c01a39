"""DMR's fully connected regressor (FConn), 2D EDM -> 3D EDM, via scikit-learn.

Trained with :class:`sklearn.neural_network.MLPRegressor` (ReLU, Adam, early
stopping on a held-out tenth) from normalised 2D EDM vectors to 3D EDM
vectors in the lifter's normalisation. Only the weight arrays are stored
(``coef_0``, ``intercept_0``, ...; never a pickle) and the forward pass is
numpy, so loading needs no scikit-learn object.

Layer sizes: three hidden layers of 400 units by default, our reading of
DMR's FConn (Moreno-Noguer, CVPR 2017); the paper's exact sizes could not be
checked offline here, so ``hidden_layer_sizes`` is a parameter.

Occluded input is fed as is, in the ``representation`` (``"average"`` or
``"zero"``) the caller builds: the network has no notion of missing entries.

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> X2 = rng.random((300, 6)); X3 = 2 * X2
>>> lf = MLPLifter(hidden_layer_sizes=(16,), max_iter=50).fit(X2, X3)
>>> lf.predict(X2[:2])[0].shape
(2, 6)
"""

from __future__ import annotations

import warnings

import numpy as np

from .. import _progress
from ..edm import num_joints_from_dim
from .base import Lifter, LifterError

__all__ = ["MLPLifter"]


class MLPLifter(Lifter):
    """FConn: fully connected ReLU network on the whole 2D EDM vector.

    Parameters
    ----------
    hidden_layer_sizes : tuple of int, default (400, 400, 400)
    alpha : float, default 1e-4
        L2 penalty (scikit-learn's).
    max_iter : int, default 200
        Epochs at most (early stopping usually ends sooner).
    normalization : {"tied", "unit"}
    random_state : int

    Attributes
    ----------
    coefs_, intercepts_ : lists of ndarray
    """

    method = "mlp"
    _params = ("hidden_layer_sizes", "alpha", "max_iter", "normalization", "random_state")

    def __init__(self, hidden_layer_sizes=(400, 400, 400), *, alpha=1e-4, max_iter=200,
                 normalization="tied", random_state=0):
        super().__init__(normalization=normalization, random_state=random_state)
        self.hidden_layer_sizes = tuple(int(h) for h in hidden_layer_sizes)
        self.alpha = alpha
        self.max_iter = max_iter

    def _fit(self, X2, X3):
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.neural_network import MLPRegressor

        net = MLPRegressor(hidden_layer_sizes=self.hidden_layer_sizes, alpha=self.alpha, max_iter=self.max_iter,
                           early_stopping=True, random_state=self.random_state,
                           batch_size=min(256, max(1, len(X2) * 9 // 10)))
        _progress.say(f"training the MLP {self.hidden_layer_sizes} on {len(X2):,} poses "
                      f"(at most {self.max_iter} epochs, early stopping)")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            net.fit(X2, X3)
        self.coefs_ = [c.copy() for c in net.coefs_]
        self.intercepts_ = [b.copy() for b in net.intercepts_]
        self.n_iter_ = int(net.n_iter_)

    def predict(self, X2, missing=None, *, n_jobs=1):
        """3D EDM vectors from whole 2D EDM vectors (`missing` is not used)."""
        H = np.atleast_2d(np.asarray(X2, float))
        if H.shape[1] != self.coefs_[0].shape[0]:
            raise LifterError(f"the network takes {self.coefs_[0].shape[0]}-entry vectors, "
                              f"got {H.shape[1]}")
        for i, (W, b) in enumerate(zip(self.coefs_, self.intercepts_)):
            H = H @ W + b
            if i < len(self.coefs_) - 1:
                np.maximum(H, 0, out=H)
        ok = np.isfinite(H).all(axis=1)
        return H, {"status": np.where(ok, "optimal", "failed")}

    def _describe_model(self):
        sizes = [self.coefs_[0].shape[0]] + [W.shape[1] for W in self.coefs_]
        return "fully connected ReLU network (FConn), layers " + " -> ".join(map(str, sizes))

    def _arrays(self):
        out = {}
        for i, (W, b) in enumerate(zip(self.coefs_, self.intercepts_)):
            out[f"coef_{i}"] = W
            out[f"intercept_{i}"] = b
        return out

    @classmethod
    def _from_arrays(cls, arrays, params, where):
        coefs, inter = [], []
        i = 0
        while f"coef_{i}" in arrays:
            W, b = arrays[f"coef_{i}"], arrays.get(f"intercept_{i}")
            if b is None or W.dtype.kind != "f" or W.ndim != 2 or b.shape != (W.shape[1],):
                raise LifterError(f"{where}: layer {i} has bad weights")
            if coefs and coefs[-1].shape[1] != W.shape[0]:
                raise LifterError(f"{where}: layer {i} does not fit layer {i - 1}")
            coefs.append(W.astype(float))
            inter.append(b.astype(float))
            i += 1
        if not coefs or not all(np.isfinite(c).all() for c in coefs + inter):
            raise LifterError(f"{where}: no finite network weights")
        kw = {k: params[k] for k in cls._params if k in params}
        lf = cls(**kw)
        lf.coefs_, lf.intercepts_ = coefs, inter
        return lf

    def _check_dims(self, n_joints, where):
        m_in, m_out = self.coefs_[0].shape[0], self.coefs_[-1].shape[1]
        if m_in != m_out or num_joints_from_dim(m_in) != n_joints:
            raise LifterError(f"{where}: network maps {m_in} -> {m_out} entries, not the "
                              f"{n_joints * (n_joints - 1) // 2} of {n_joints} joints")
