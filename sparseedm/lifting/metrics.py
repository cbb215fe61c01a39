"""3D accuracy: the paper's Err_ave on 3D EDMs, MPJPE, N-MPJPE and PA-MPJPE.

Scale: one image does not fix a person's absolute size, so every metric says
how scale is treated:

* :func:`err_ave_3d` -- Err_ave (per cent) of the lifted 3D EDM against the
  true one after one least-squares scale factor per pose (the EDM's shape,
  not its unobservable size);
* :func:`mpjpe` -- mean per-joint position error after centring both poses on
  the pelvis (mid-hips), with the lifted pose at the lifter's metric size
  prior, in the camera's axes (no rotation alignment);
* ``mpjpe(..., align="scale")`` -- N-MPJPE: also one least-squares scale;
* :func:`pa_mpjpe` -- after the best similarity transform (rotation, scale,
  translation; Procrustes, no reflection).

Poses in metres give errors in millimetres (``unit=1000``).

Examples
--------
>>> import numpy as np
>>> X = np.random.default_rng(0).standard_normal((2, 14, 3))
>>> float(pa_mpjpe(2 * X @ np.diag([1, -1, -1]) + 3, X).max()) < 1e-9
True
"""

from __future__ import annotations

import numpy as np

from ..metrics import err_ave
from ..skeleton import SKELETON_14

__all__ = ["err_ave_3d", "mpjpe", "pa_mpjpe", "pelvis", "scale_to"]

_HIPS = (SKELETON_14.index("right_hip"), SKELETON_14.index("left_hip"))


def pelvis(poses):
    """Mid-point of the hips (n, 3): the root for MPJPE."""
    poses = np.asarray(poses, float)
    return poses[..., list(_HIPS), :].mean(axis=-2)


def scale_to(vectors, target):
    """Least-squares scale per row so that ``s * vectors ~ target``."""
    v = np.asarray(vectors, float)
    t = np.asarray(target, float)
    num = np.einsum("...i,...i->...", v, t)
    den = np.einsum("...i,...i->...", v, v)
    return np.where(den > 0, num / np.where(den > 0, den, 1), np.nan)


def err_ave_3d(pred_vectors, true_vectors):
    """Err_ave (per cent) of 3D EDM vectors after one least-squares scale per pose.

    Parameters
    ----------
    pred_vectors : array_like (n, N(N-1)/2)
        Predicted 3D EDM vectors (upper-triangle entries), any scale.
    true_vectors : array_like (n, N(N-1)/2)
        The true 3D EDM vectors.

    Returns
    -------
    ndarray (n,)
        Err_ave per pose (:func:`sparseedm.metrics.err_ave`) of the prediction
        scaled by its least-squares factor onto the truth.
    """
    s = scale_to(pred_vectors, true_vectors)
    return err_ave(np.asarray(pred_vectors, float) * s[..., None], true_vectors)


def mpjpe(pred, true, *, align="root", unit=1000.0):
    """Mean per-joint position error per pose (mm for poses in metres).

    Parameters
    ----------
    pred : array_like (n, 14, 3)
        Predicted 3D poses.
    true : array_like (n, 14, 3)
        True 3D poses, in the same axes.
    align : {"root", "scale"}
        "root": pelvis-centred; "scale": pelvis-centred plus one least-squares
        scale of the prediction (N-MPJPE).
    unit : float, default 1000.0
        Factor applied to the errors (1000: metres to millimetres).

    Returns
    -------
    ndarray (n,)
        Mean over the joints of the Euclidean distance between the aligned
        poses, times `unit`.
    """
    p = np.asarray(pred, float) - pelvis(pred)[..., None, :]
    t = np.asarray(true, float) - pelvis(true)[..., None, :]
    if align == "scale":
        s = scale_to(p.reshape(len(p), -1), t.reshape(len(t), -1))
        p = p * s[:, None, None]
    return np.linalg.norm(p - t, axis=-1).mean(axis=-1) * unit


def pa_mpjpe(pred, true, *, unit=1000.0):
    """MPJPE after the best similarity transform (Procrustes, proper rotation).

    Parameters
    ----------
    pred : array_like (n, N, 3)
        Predicted 3D poses.
    true : array_like (n, N, 3)
        True 3D poses.
    unit : float, default 1000.0
        Factor applied to the errors (1000: metres to millimetres).

    Returns
    -------
    ndarray (n,)
        Mean per-joint error of each prediction after the translation,
        rotation (no reflection) and scale that best fit it to the truth,
        times `unit`.
    """
    p = np.asarray(pred, float)
    t = np.asarray(true, float)
    p = p - p.mean(axis=-2, keepdims=True)
    t = t - t.mean(axis=-2, keepdims=True)
    H = np.einsum("nji,njk->nik", p, t)
    U, S, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(U @ Vt))
    D = np.ones_like(S)
    D[:, -1] = d
    R = U @ (D[:, :, None] * Vt)
    s = (S * D).sum(axis=1) / np.einsum("nij,nij->n", p, p)
    aligned = s[:, None, None] * p @ R
    return np.linalg.norm(aligned - t, axis=-1).mean(axis=-1) * unit
