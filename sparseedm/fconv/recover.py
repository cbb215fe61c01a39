"""``recover(..., method="fconv")``: the FConv network in place of the lasso.

Each usable pose is screened and represented exactly as on the sparse path
(:func:`sparseedm._recovery_base.screen`: same statuses, same
:func:`~sparseedm.normalize.represent` vectors); the network maps the
occluded EDM vector to a complete one; the Eq. 10 merge keeps the observed
entries and takes the occluded ones from the network; the occluded joints are
placed from their recovered distances (:func:`sparseedm._recovery_base.place_occluded_inplace`).
Nothing is certified, so ``objective`` and ``gap`` are NaN and ``alpha`` NaN.
"""

from __future__ import annotations

import time

import numpy as np

from .. import _progress
from ..edm import observed_entries
from ..exceptions import SparseEDMError
from ..normalize import REPRESENTATIONS
from .._recovery_base import RecoveryResult, place_occluded_inplace, screen, validate_poses
from .model import load_model

__all__ = ["recover_fconv"]


def _predict(model, X, chunk_size, progress):
    """The network's output for `X`, `chunk_size` rows at a time, a bar over them."""
    from tqdm.auto import tqdm

    starts = range(0, len(X), chunk_size)
    if not progress:  # else the bar says it (shown by the command line, off in the API)
        _progress.say(f"the FConv network on {len(X):,} poses")
    out = np.empty(X.shape)
    for s in tqdm(starts, total=len(starts), disable=not progress, unit="chunk",
                  desc="recover (FConv)"):
        out[s:s + chunk_size] = model.predict(X[s:s + chunk_size], batch_size=chunk_size)
    return out


def recover_fconv(poses, missing=None, *, model=None, representation=None,
                  chunk_size=4096, progress=False):
    """Recover occluded joints with an FConv recovery model (see :func:`sparseedm.recover`).

    Parameters
    ----------
    poses : array_like, shape (n, N, 2) or (N, 2)
        Keypoints in the caller's own pixel frame; N must be the model's joint
        count.
    missing : array_like of bool, shape (n, N), optional
        True where a joint is occluded; by default NaN coordinates mark them.
    model : FConvModel, str or path
        The trained recovery network or its file (``sparseedm fit-cnn``);
        required.
    representation : {"average", "zero"}, optional
        How occluded joints enter the EDM vector. None (default) is the one the
        model was trained on; another one is refused.
    chunk_size : int, default 4096
        Poses per batch through the network.
    progress : bool, default False
        Show a progress bar over the chunks of poses through the network (on
        stderr), as the sparse path's over its chunks.

    Returns
    -------
    RecoveryResult
        The filled poses and EDM vectors with a status and reason per pose;
        ``objective``, ``gap`` and ``alpha`` are NaN (nothing is certified).
    """
    t0 = time.perf_counter()
    if model is None:
        raise SparseEDMError("method='fconv' needs model=: a file from `sparseedm fit-cnn` "
                             "or an FConvModel")
    if representation not in (*REPRESENTATIONS, None):
        raise SparseEDMError(
            f"unknown representation {representation!r}; use one of {REPRESENTATIONS}")
    model = load_model(model, representation=representation, kind="recover")
    representation = model.representation
    shape = np.shape(poses)
    if len(shape) >= 2 and shape[-2] != model.n_joints:
        load_model(model, n_joints=shape[-2])  # names the model and both joint counts
    poses, mask, bad_coord = validate_poses(poses, missing, model.n_joints)
    screened = screen(poses, mask, bad_coord, representation)
    status, reason, vectors = screened.status, screened.reason, screened.vectors
    todo = np.flatnonzero(status == "recovered")
    if len(todo):
        out = _predict(model, vectors[todo], max(1, int(chunk_size)), progress)
        keep = observed_entries(mask[todo])
        vectors[todo] = np.where(keep, vectors[todo], out)  # Eq. 10
        reason[todo] = "FConv network (not certified)"
    # unweighted placement, as when FConv was set up: the residual weights of
    # sparseedm.placement were chosen on the sparse method's answers
    place_occluded_inplace(poses, mask, screened, weight_power=0.0)
    n = len(poses)
    return RecoveryResult(
        poses=screened.filled, vectors=vectors, missing=mask, center=screened.center,
        scale=screened.scale,
        objective=np.full(n, np.nan), gap=np.full(n, np.nan), n_active=np.zeros(n, dtype=int),
        status=status.astype(str), reason=reason.astype(str), fallback=np.zeros(n, dtype=bool),
        alpha=float("nan"), seconds=time.perf_counter() - t0,
    )
