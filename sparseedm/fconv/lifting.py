"""2D -> 3D: DMR's distance-matrix regression with the FConv layers.

:func:`lift_edm_vectors` maps 2D poses (pixels, occluded joints as NaN or a
mask) to 3D EDM vectors in the training 3D units (metres for
:mod:`sparseedm.dataset` files) with a ``kind="lift"`` model from
:func:`~sparseedm.fconv.fit_edm_lifter`; :class:`FConvEDMLifter` is its
scikit-learn-style shell. (Metric 3D joints and a ``LiftResult`` come from
:func:`sparseedm.lift`, whose ``fconv`` lifter, :mod:`sparseedm.lifting.fconv`,
wraps this network.) The older names ``lift`` and ``FConvLifter`` still
work and warn (:mod:`sparseedm._deprecated`). Turning a 3D EDM into
joint coordinates (multidimensional scaling) is left to the caller, e.g. the
3D lifting module, which can wrap these.
"""

from __future__ import annotations

import numpy as np

from .._deprecated import alias_getattr
from .._recovery_base import screen, validate_poses
from .model import load_model
from .training import NetworkShell, fit_edm_lifter

__all__ = ["lift_edm_vectors", "FConvEDMLifter"]


def lift_edm_vectors(model, poses2d, missing=None, *, batch_size=4096):
    """3D EDM vectors (n, N(N-1)/2) predicted from 2D poses.

    Parameters
    ----------
    model : FConvModel, str or path
        A ``kind="lift"`` model.
    poses2d : array_like (n, N, 2)
        Pixels; occluded joints NaN or marked in `missing`.
    missing : array_like of bool (n, N), optional
    batch_size : int, default 4096
        Poses per forward pass.

    Returns
    -------
    ndarray (n, N(N-1)/2)
        Upper-triangle 3D distances (row-major over i < j), in the training
        3D units; NaN rows for poses with fewer than 3 observed joints or
        invalid coordinates.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> p3 = rng.normal(size=(64, 14, 3)); p2 = p3[..., :2] * 100
    >>> from sparseedm.fconv import fit_edm_lifter
    >>> m = fit_edm_lifter(p2, p3, channels=(4, 8), batch_size=16, max_epochs=1)
    >>> lift_edm_vectors(m, p2[:3]).shape
    (3, 91)
    """
    model = load_model(model, kind="lift")
    poses, mask, bad_coord = validate_poses(poses2d, missing, model.n_joints, caller="lift",
                                       model="model")
    screened = screen(poses, mask, bad_coord, model.representation)
    status, vectors = screened.status, screened.vectors
    ok = np.isin(status, ("recovered", "complete"))
    out = np.full(vectors.shape, np.nan)
    if ok.any():
        out[ok] = model.predict(vectors[ok], batch_size=batch_size)
    return out


class FConvEDMLifter(NetworkShell):
    """scikit-learn-style shell: ``fit(X2d, y3d)`` trains, ``predict(X2d)`` lifts.

    ``__init__`` stores the arguments of :func:`~sparseedm.fconv.fit_edm_lifter`
    (``occluded=None`` means its default, complete inputs); the trained model
    is ``model_``; :meth:`predict` returns 3D EDM vectors.

    Parameters
    ----------
    representation : {"average", "zero"}
        How occluded joints enter the network.
    occluded : (int, int), optional
        Range of occluded joints drawn per pose and epoch.
    channels, kernel, symmetrize
        The architecture (:mod:`sparseedm.fconv.network`).
    batch_size, max_epochs, patience, learning_rate
        Adam on mini-batches; early stopping on held-out clips.
    random_state : int
        Seeds the weights, the masks and the batch order.
    device : str
        A torch device.
    """

    def fit(self, X, y, clips=None):
        """X: 2D poses (n, N, 2); y: their 3D poses (n, N, 3)."""
        self.model_ = fit_edm_lifter(X, y, clips, **self._options((0, 0)))
        return self

    def predict(self, X, missing=None):
        """3D EDM vectors (n, N(N-1)/2) of 2D poses X."""
        return lift_edm_vectors(self.model_, X, missing)


__getattr__ = alias_getattr(__name__, globals())  # the older names, deprecated
