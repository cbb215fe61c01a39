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

import functools

import numpy as np
from scipy.linalg import LinAlgError, solveh_banded

__all__ = ["smooth_trajectory"]

#: weight of the first-difference (velocity) term added only when a
#: trajectory has fewer than two anchors (observations or weighted priors):
#: it makes the problem strictly convex by holding the one value constant
VELOCITY_RIDGE = 1e-6


def _stencil(order):
    """Coefficients of the `order`-th forward difference: (1 -2 1), (-1 3 -3 1)."""
    c = np.array([1.0])
    for _ in range(order):
        c = np.convolve(c, [-1.0, 1.0])
    return c


def _full_bands(T, penalties):
    """Bands 0 .. K of ``sum_k lam_k * Dk.T @ Dk`` (T x T) for `penalties`
    {order k: lam_k}, Dk the k-th differences; band s holds entries (i, i+s)."""
    K = max(penalties)
    bands = [np.zeros(max(T - s, 0)) for s in range(K + 1)]
    for order, lam in penalties.items():
        if not lam or T <= order:
            continue
        c = _stencil(order)
        for s in range(order + 1):
            for a in range(order + 1 - s):
                bands[s][a:a + T - order] += lam * c[a] * c[a + s]
    return bands


@functools.lru_cache(maxsize=16)
def _bands_for(T, ridge, lam, jerk):
    """:func:`_full_bands` of one trajectory length and set of penalties, built
    once: every joint of a segment, in both passes of the temporal model, has
    the same (read-only)."""
    bands = _full_bands(T, {1: ridge, 2: lam, 3: jerk})
    for band in bands:
        band.flags.writeable = False
    return tuple(bands)


def _reduced_bands(free_idx, bands, weight):
    """Upper banded form (K+1, n) of the Hessian restricted to `free_idx`: the
    frames kept in order, so entries more than K frames apart vanish."""
    K = len(bands) - 1
    n = len(free_idx)
    ab = np.zeros((K + 1, n))
    ab[K] = bands[0][free_idx] + weight[free_idx]
    for q in range(1, min(K, n - 1) + 1):
        lo, step = free_idx[:-q], free_idx[q:] - free_idx[:-q]
        vals = np.zeros(n - q)
        for s in range(q, K + 1):
            hit = step == s
            if hit.any():
                vals[hit] = bands[s][lo[hit]]
        ab[K - q, q:] = vals
    return ab


def _banded_times(ab, x):
    """Symmetric upper-banded (K+1, n) matrix times x (n, k)."""
    K = len(ab) - 1
    y = ab[K][:, None] * x
    for q in range(1, min(K, len(x) - 1) + 1):
        y[q:] += ab[K - q, q:, None] * x[:-q]
        y[:-q] += ab[K - q, q:, None] * x[q:]
    return y


def _bands_times(bands, x):
    """The full banded matrix of :func:`_full_bands` times x (T, k)."""
    y = bands[0][:, None] * x
    for s, band in enumerate(bands[1:], start=1):
        if len(band):
            y[s:] += band[:, None] * x[:-s]
            y[:-s] += band[:, None] * x[s:]
    return y


def smooth_trajectory(values, free, prior, weight, lam, jerk=0.0):
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
    jerk : float, default 0
        Penalty on third differences (the same form, one band wider).

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
    bands = _bands_for(len(x), float(ridge), float(lam), float(jerk))
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

