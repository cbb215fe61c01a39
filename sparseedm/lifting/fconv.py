"""DMR's fully convolutional 2D EDM -> 3D EDM regressor as a lifter (torch extra).

Wraps the FConv network of :mod:`sparseedm.fconv` (two convolutions, two
deconvolutions on the N x N EDM; :mod:`sparseedm.fconv.network` states the
reading of the layer sizes) and trains it with that package's seeded loop
(Adam, mini-batches, early stopping on held-out clips,
:func:`sparseedm.fconv.training.fit_network`). torch is imported only when
the network is trained or run; loading and describing a file need no torch.

3D units: the lifter's normalisation, not metres
-----------------------------------------------
:func:`sparseedm.fconv.fit_edm_lifter` regresses 3D EDMs in metres. Here the
target is the 3D EDM vector in the *lifter base's* normalisation
(:func:`sparseedm.lifting.base.training_pairs`; ``"tied"`` by default: the
camera-frame pose times ``f / (Z s)``, the units of the normalised 2D input).
Chosen so that every lifter hands the shared steps the same thing: the MDS +
SMACOF + camera alignment of :mod:`.mds` and the size-prior scaling of
:func:`sparseedm.lifting.lift.poses_from_vectors` then apply unchanged, and
the network does not have to guess absolute size from a scale-free 2D input
(a metric target asks it to; a tied target's scale follows the 2D input).
Metric poses come from the lifter's size prior, as for the other lifters.

Occluded input
--------------
The network reads the whole 2D EDM vector in ``representation``
(``"average"`` or ``"zero"``, as :func:`sparseedm.normalize.represent`
builds them). ``occluded=(0, 0)`` (default) trains on complete poses, DMR's
setting; ``occluded=(1, 3)`` retrains end to end on occluded input with a
fresh count of 1-3 occluded joints per pose and epoch (the paper's
``zero+basl`` / ``ave+basl``). :meth:`FConvNetLifter.predict` turns an
'average' vector into the 'zero' one when the lifter wants 'zero' and the
mask is given (same normalisation, occluded entries zeroed), so
:func:`sparseedm.lift` feeds either kind correctly.

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(0)
>>> X2 = rng.random((300, 91)); X3 = 0.5 * X2
>>> lf = FConvNetLifter(channels=(4, 8), batch_size=32, max_epochs=2).fit(X2, X3)
>>> lf.predict(X2[:2])[0].shape
(2, 91)
"""

from __future__ import annotations

import numpy as np

from ..edm import num_joints_from_dim, observed_entries
from ..exceptions import ModelError, SparseEDMError
from ..fconv.model import PARAM_PREFIX, FConvModel  # numpy only: torch loads lazily
from ..fconv.network import output_paddings, require_torch
from ..fconv.training import check_representation, fit_network, occlusion_range
from ..normalize import represent
from .base import Lifter, LifterError, check_pairs

__all__ = ["FConvNetLifter"]


class FConvNetLifter(Lifter):
    """FConv: the fully convolutional network on the whole 2D EDM.

    Parameters
    ----------
    representation : {"average", "zero"}
        How occluded joints appear in the input vector.
    occluded : (int, int), default (0, 0)
        Occluded joints per training pose, drawn afresh each epoch; (0, 0)
        is DMR's complete-input training, (1, 3) the end-to-end retraining.
    channels, kernel, symmetrize
        The architecture (:mod:`sparseedm.fconv.network`).
    batch_size, max_epochs, patience, learning_rate
        The training loop (:func:`sparseedm.fconv.fit_edm_lifter`).
    normalization : {"tied", "unit"}
        The 3D EDM units the network regresses (see the module docstring).
    random_state : int
    device : str, default "cpu"

    Attributes
    ----------
    model_ : sparseedm.fconv.FConvModel
        The network (float32 weights); ``model_.meta["training"]`` holds the
        epochs, losses and split.
    """

    method = "fconv"
    _params = ("representation", "occluded", "channels", "kernel", "symmetrize", "batch_size",
               "max_epochs", "patience", "learning_rate", "normalization", "random_state")

    def __init__(self, *, representation="average", occluded=(0, 0), channels=(32, 64),
                 kernel=3, symmetrize=False, batch_size=256, max_epochs=30, patience=4,
                 learning_rate=1e-3, normalization="tied", random_state=0, device="cpu"):
        super().__init__(normalization=normalization, random_state=random_state)
        self.representation = representation
        self.occluded = tuple(int(k) for k in occluded)
        self.channels = tuple(int(c) for c in channels)
        self.kernel = int(kernel)
        self.symmetrize = bool(symmetrize)
        self.batch_size = int(batch_size)
        self.max_epochs = int(max_epochs)
        self.patience = int(patience)
        self.learning_rate = float(learning_rate)
        self.device = device

    # -- fitting -----------------------------------------------------------
    def _fit(self, X2, X3):
        if self.occluded != (0, 0):
            raise SparseEDMError(
                f"occluded={self.occluded}: training on occluded input needs the 2D poses "
                "(to draw fresh masks each epoch); use fit_poses / sparseedm.lifting.fit_lifter")
        self._train(lambda rows, rng: (X2[rows], X3[rows]), X2.shape, None)

    def _fit_from_poses(self, X2, X3, poses2d, clips):
        X2, X3 = check_pairs(X2, X3)
        poses2d = np.asarray(poses2d, float)

        N = poses2d.shape[1]

        def pairs(rows, rng):
            mask = occlusion_range(len(rows), N, self.occluded, rng)
            return represent(poses2d[rows], mask, self.representation)[0], X3[rows]

        self._train(pairs, X2.shape, clips)

    def _train(self, pairs, shape, clips):
        require_torch()  # names the extra when torch is absent
        check_representation(self.representation)
        n, m = shape
        N = num_joints_from_dim(m)
        meta = {"kind": "lift", "occluded": list(self.occluded),
                "output_units": f"3D EDM in the lifter's {self.normalization!r} normalisation"}
        self.model_ = fit_network(
            pairs, n, N, clips, meta, representation=self.representation,
            channels=self.channels, kernel=self.kernel, symmetrize=self.symmetrize,
            batch_size=self.batch_size, max_epochs=self.max_epochs, patience=self.patience,
            tol=1e-3, learning_rate=self.learning_rate, random_state=self.random_state,
            device=self.device, progress=False, max_train=None, provenance=None)

    def fit_poses(self, *args, **kwargs):
        super().fit_poses(*args, **kwargs)
        t = self.model_.meta["training"]
        self.provenance_["training"] = {k: t[k] for k in (
            "n_train", "n_val", "validation", "epochs", "best_val_loss", "seconds", "history")}
        return self

    # -- prediction --------------------------------------------------------
    def predict(self, X2, missing=None, *, n_jobs=1):
        """3D EDM vectors from whole 2D EDM vectors in the lifter's representation.

        With ``representation="zero"`` and `missing` given, the occluded
        entries are zeroed first (an 'average' vector becomes the 'zero' one).
        `n_jobs` is not used (torch chooses its threads).
        """
        X = np.atleast_2d(np.asarray(X2, float))
        m = self.model_.n_joints * (self.model_.n_joints - 1) // 2
        if X.ndim != 2 or X.shape[1] != m:
            raise LifterError(f"the network takes {m}-entry vectors, got shape {X.shape}")
        if missing is not None and self.representation == "zero":
            X = np.where(observed_entries(np.atleast_2d(np.asarray(missing, bool))), X, 0.0)
        Y = np.full(X.shape, np.nan)
        finite = np.isfinite(X).all(axis=1)
        if finite.any():
            Y[finite] = self.model_.predict(X[finite])
        ok = np.isfinite(Y).all(axis=1)
        return Y, {"status": np.where(ok, "optimal", "failed")}

    # -- file format -------------------------------------------------------
    def meta(self):
        out = super().meta()
        out["params"]["n_joints_network"] = self.model_.n_joints  # checked on load
        return out

    def _describe_model(self):
        occ = ("complete input" if self.occluded == (0, 0) else
               f"{self.occluded[0]}-{self.occluded[1]} occluded joints per pose (end to end)")
        t = (self.provenance_ or {}).get("training", {})
        ep = f"; {t['epochs']} epochs, best validation loss {t['best_val_loss']:.4g}" if t else ""
        return (f"fully convolutional network (DMR's FConv): channels {self.channels}, kernel "
                f"{self.kernel}, {'with' if self.symmetrize else 'without'} symmetrisation; "
                f"'{self.representation}' input, trained on {occ}{ep}")

    def _arrays(self):
        return {PARAM_PREFIX + k: v for k, v in self.model_.params.items()}

    @classmethod
    def _from_arrays(cls, arrays, params, where):
        weights = {k[len(PARAM_PREFIX):]: v for k, v in arrays.items() if k.startswith(PARAM_PREFIX)}
        if not weights:
            raise LifterError(f"{where}: no network weights (param.* arrays)")
        for name, v in weights.items():
            if v.dtype != np.float32:
                raise LifterError(f"{where}: weight {name} must be float32, got {v.dtype}")
        kw = {k: params[k] for k in cls._params if k in params}
        lf = cls(**kw)
        lf._weights = weights
        lf._n_joints_network = int(params["n_joints_network"])
        return lf

    def _check_dims(self, n_joints, where):
        """Build the network for `n_joints` from the loaded weights (checks every shape)."""
        weights = getattr(self, "_weights", None)
        if weights is None:  # a fitted lifter: its model knows its N
            if self.model_.n_joints != n_joints:
                raise LifterError(f"{where}: network is for {self.model_.n_joints} joints, "
                                  f"not {n_joints}")
            return
        if self._n_joints_network != n_joints:
            raise LifterError(f"{where}: the network was trained for {self._n_joints_network} "
                              f"joints, the file names {n_joints}")
        meta = {"kind": "lift", "n_joints": int(n_joints), "representation": self.representation,
                "channels": list(self.channels), "kernel": self.kernel,
                "symmetrize": self.symmetrize, "occluded": list(self.occluded)}
        try:
            output_paddings(n_joints, self.kernel)
            self.model_ = FConvModel(weights, meta)
        except (ModelError, SparseEDMError) as exc:
            raise LifterError(f"{where}: network weights do not fit {n_joints} joints "
                              f"({exc})") from None
        del self._weights, self._n_joints_network
