"""The temporal model's convex core: one coordinate trajectory, solved exactly.

For one joint of one track over its frame range ``t = 0 .. T-1`` the unknowns
are the joint's coordinates ``x_t`` in the frames where it is missing (frames
absent from the track are missing too); observed frames are fixed exactly as
given, so they are eliminated rather than penalised. The trajectory minimises

    sum_t w_t ||x_t - p_t||^2 + lam * sum_t ||x_{t-1} - 2 x_t + x_{t+1}||^2

where ``p_t`` is a prior (the per-frame pose model's answer) with weight
``w_t >= 0`` (zero where there is none) and ``lam > 0`` penalises
acceleration. Both terms are squared pixels, so only ``w / lam`` matters and
it is free of the pixel scale. The Hessian is pentadiagonal; keeping only the
free frames (in order) keeps it pentadiagonal, so
:func:`scipy.linalg.solveh_banded` solves it exactly in O(T). The relative
residual ``||H x - b|| / ||b||`` of that solve is the certificate.

With no weight anywhere the answer is the discrete natural cubic spline
through the observations (the smoothest interpolant: least summed squared
second differences); with weight it bends towards the prior where the
observations are far away, and past the last observation it follows the prior
instead of extrapolating a line.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import LinAlgError, solveh_banded

__all__ = ["smooth_trajectory"]

#: weight of the first-difference (velocity) term added only when a
#: trajectory has fewer than two anchors (observations or weighted priors):
#: it makes the problem strictly convex by holding the one value constant
VELOCITY_RIDGE = 1e-6


def _full_bands(T, lam, ridge):
    """Bands (diagonal, first and second off-diagonal) of
    ``lam * D2.T @ D2 + ridge * D1.T @ D1`` (T x T), D2 / D1 the second /
    first differences."""
    d0, d1, d2 = np.zeros(T), np.zeros(max(T - 1, 0)), np.zeros(max(T - 2, 0))
    if T >= 3:
        d0[:-2] += lam
        d0[1:-1] += 4.0 * lam
        d0[2:] += lam
        d1[:-1] -= 2.0 * lam
        d1[1:] -= 2.0 * lam
        d2[:] = lam
    if ridge and T >= 2:
        d0[:-1] += ridge
        d0[1:] += ridge
        d1 -= ridge
    return d0, d1, d2


def _reduced_bands(free_idx, bands, weight):
    """Upper banded form (3, n) of the Hessian restricted to `free_idx`: the
    frames kept in order, so entries further than two frames apart vanish."""
    d0, d1, d2 = bands
    n = len(free_idx)
    ab = np.zeros((3, n))
    ab[2] = d0[free_idx] + weight[free_idx]
    if n >= 2:
        lo, step = free_idx[:-1], np.diff(free_idx)
        one = d1[np.minimum(lo, len(d1) - 1)] if len(d1) else np.zeros(n - 1)
        two = d2[np.minimum(lo, len(d2) - 1)] if len(d2) else np.zeros(n - 1)
        ab[1, 1:] = np.where(step == 1, one, np.where(step == 2, two, 0.0))
    if n >= 3:
        lo, step = free_idx[:-2], free_idx[2:] - free_idx[:-2]
        two = d2[np.minimum(lo, len(d2) - 1)] if len(d2) else np.zeros(n - 2)
        ab[0, 2:] = np.where(step == 2, two, 0.0)
    return ab


def _bands_times(bands, x):
    """The full banded matrix of :func:`_full_bands` times x (T, k)."""
    d0, d1, d2 = bands
    y = d0[:, None] * x
    if len(d1):
        y[1:] += d1[:, None] * x[:-1]
        y[:-1] += d1[:, None] * x[1:]
    if len(d2):
        y[2:] += d2[:, None] * x[:-2]
        y[:-2] += d2[:, None] * x[2:]
    return y


def _banded_times(ab, x):
    """Symmetric upper-banded (3, n) matrix times x (n, k)."""
    y = ab[2][:, None] * x
    y[1:] += ab[1, 1:, None] * x[:-1]
    y[:-1] += ab[1, 1:, None] * x[1:]
    y[2:] += ab[0, 2:, None] * x[:-2]
    y[:-2] += ab[0, 2:, None] * x[2:]
    return y


def smooth_trajectory(values, free, prior, weight, lam):
    """Fill the free frames of one trajectory: the exact minimiser above.

    Parameters
    ----------
    values : ndarray (T, k)
        Coordinates; used where ``free`` is False (kept exactly).
    free : ndarray of bool (T,)
        Frames whose coordinates are unknown.
    prior : ndarray (T, k)
        The prior ``p_t``; read only where ``weight > 0``.
    weight : ndarray (T,)
        Prior weight ``w_t >= 0``, read at free frames.
    lam : float
        Acceleration penalty, > 0.

    Returns
    -------
    x : ndarray (T, k)
        The trajectory: ``values`` at fixed frames, the minimiser at free
        ones; NaN at free frames when nothing anchors the trajectory.
    residual : float
        ``||H x - b|| / ||b||`` of the banded solve (0 when nothing was free).

    Examples
    --------
    A straight line with a gap comes back on the line (a spline through it):

    >>> import numpy as np
    >>> t = np.arange(8.0)[:, None]
    >>> free = np.isin(np.arange(8), [3, 4])
    >>> x, r = smooth_trajectory(2 * t, free, np.zeros_like(t), np.zeros(8), 1.0)
    >>> x[3:5, 0].round(6).tolist(), r < 1e-12
    ([6.0, 8.0], True)
    """
    values = np.asarray(values, dtype=float)
    free = np.asarray(free, dtype=bool)
    x = np.where(free[:, None], 0.0, values)
    free_idx = np.flatnonzero(free)
    if not len(free_idx):
        return x, 0.0
    w = np.where(free, np.asarray(weight, dtype=float), 0.0)
    anchors = int((~free).sum() + (w > 0).sum())
    if anchors == 0:
        x[free_idx] = np.nan
        return x, np.nan
    ridge = VELOCITY_RIDGE * lam if anchors < 2 else 0.0
    bands = _full_bands(len(x), lam, ridge)
    ab = _reduced_bands(free_idx, bands, w)
    b = w[:, None] * np.where(w[:, None] > 0, prior, 0.0) - _bands_times(bands, x)
    b = b[free_idx]
    try:
        sol = solveh_banded(ab, b, lower=False, check_finite=False)
    except LinAlgError:
        x[free_idx] = np.nan
        return x, np.nan
    x[free_idx] = sol
    scale = max(float(np.linalg.norm(b)), np.finfo(float).tiny)
    residual = float(np.linalg.norm(_banded_times(ab, sol) - b)) / scale
    return x, residual

