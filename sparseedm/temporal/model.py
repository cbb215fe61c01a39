"""The temporal model of one segment: time and the pose model, blended by weight.

Every joint of a segment (one track, consecutive frames) is one trajectory of
:func:`sparseedm.temporal.smoothing.smooth_trajectory`: observed frames fixed,
penalties ``acceleration`` and ``jerk`` on its second and third differences,
and the per-frame sparse answer as a prior whose weight grows with the
distance ``d`` (frames) to the joint's nearest observation,

    w(d) = clip((d - ramp_start) / (ramp_full - ramp_start), 0, 1)

times a confidence (1 for a certified per-frame answer, :data:`INACCURATE`
for one whose duality gap stayed above tolerance, 0 where it was refused).
Near observations (short gaps) the answer is the smoothest curve through
them, a spline; deep inside long gaps and past a clip's ends it follows the
pose model. Only the frames where some missing joint has ``d > ramp_start``
need a per-frame answer at all (:func:`needs_prior`), and of those only every
fourth is asked for (``prior_stride``, :func:`prior_frames`): the answers
between are interpolated (the per-frame model is most of the video path's
time, and the acceleration penalty smooths its answers over many frames
anyway; on the validation sequences stride 4 moved the error over all hidden
joint-frames by +0.08 % and +0.02 % of itself, stride 6 by +0.16 % and
+0.47 %).

The constants (acceleration 30, jerk 300, ramp from 6 to 30 frames, at 30
frames/s) were chosen on validation sequences across sources, by the error
over all hidden joint-frames against the best gap filler
(``dictionaries/select_temporal.py``, ``dictionaries/selection_temporal.json``;
the grid spanned acceleration 3-3000, jerk 0-3000, ramp start 1-6 and full
12-90). Both penalties and the prior are squared pixels, so the settings do
not depend on the image's scale; they do depend on the frame rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .smoothing import smooth_trajectory
from .tracks import distance_to_observed

__all__ = ["TemporalSettings", "prior_weights", "needs_prior", "prior_frames",
           "spread_prior", "fill_segment", "time_filled"]


@dataclass(frozen=True)
class TemporalSettings:
    """The temporal model's constants (see the module docstring).

    Attributes
    ----------
    acceleration : float
        The acceleration penalty ``lam`` (the prior's full weight is 1).
    jerk : float
        The penalty on third differences.
    ramp_start, ramp_full : float
        Distances (frames) to the nearest observation where the prior's weight
        starts to grow and where it reaches 1.
    inaccurate : float
        Confidence of a per-frame answer whose duality gap is above tolerance.
    prior_stride : int
        Per-frame answers are computed on every ``prior_stride``-th frame of
        a stretch of frames that needs them (and its last frame); the frames
        between take the answers, and their confidences, interpolated linearly
        (:func:`prior_frames`, :func:`spread_prior`). 1: every frame. The
        default 4 asks the per-frame model for 3.5x fewer frames at 0.1 % of
        the error on the validation sequences
        (``dictionaries/selection_temporal_stride.json``).
    """

    acceleration: float = 30.0
    jerk: float = 300.0
    ramp_start: float = 6.0
    ramp_full: float = 30.0
    inaccurate: float = 0.25
    prior_stride: int = 4


DEFAULT_SETTINGS = TemporalSettings()


def _ramp(distance, settings):
    span = max(settings.ramp_full - settings.ramp_start, 1e-9)
    return np.clip((distance - settings.ramp_start) / span, 0.0, 1.0)


def needs_prior(free, settings=DEFAULT_SETTINGS):
    """Frames (T,) where some unknown joint gives a per-frame answer weight."""
    w = _ramp(distance_to_observed(free), settings)
    return ((w > 0) & free).any(axis=1)


def _runs(need):
    """Indices of the True frames of `need` and the id of the run each is in."""
    idx = np.flatnonzero(need)
    run = np.concatenate([[0], np.cumsum(np.diff(idx) != 1)]) if len(idx) else idx
    return idx, run


def prior_frames(free, settings=DEFAULT_SETTINGS):
    """Frames (T,) whose per-frame answer is computed: every
    ``settings.prior_stride``-th frame of each run of :func:`needs_prior`
    frames, counted from the run's first, and the run's last frame.

    Examples
    --------
    >>> free = np.zeros((40, 1), bool); free[5:35] = True
    >>> s = TemporalSettings(ramp_start=6, prior_stride=4)
    >>> np.flatnonzero(prior_frames(free, s)).tolist()
    [11, 15, 19, 23, 27, 28]
    """
    return _strided(needs_prior(free, settings), int(settings.prior_stride))


def _strided(need, stride):
    """:func:`prior_frames` from the :func:`needs_prior` frames `need`."""
    if stride <= 1:
        return need
    idx, run = _runs(need)
    first = np.flatnonzero(np.diff(run, prepend=-1) != 0)
    last = np.append(first[1:] - 1, len(idx) - 1) if len(idx) else first
    keep = (idx - idx[first][run]) % stride == 0
    keep[last] = True
    out = np.zeros_like(need)
    out[idx[keep]] = True
    return out


def spread_prior(free, prior, confidence, settings=DEFAULT_SETTINGS):
    """Per-frame answers and confidences interpolated onto the frames that
    :func:`prior_frames` skipped (from the nearest answered frames of the
    same run on either side; NaN and 0 where either side has none).

    Returns new ``(prior, confidence)``; unchanged when ``prior_stride`` is 1.
    """
    if int(settings.prior_stride) <= 1:
        return prior, confidence
    need = needs_prior(free, settings)  # once: prior_frames would compute it again
    idx, run = _runs(need)
    target = ~_strided(need, int(settings.prior_stride))[idx]
    have = ~target & np.isfinite(prior[idx]).all(axis=(1, 2))
    src, src_run = idx[have], run[have]
    t, t_run = idx[target], run[target]
    if not len(t) or not len(src):
        return prior, confidence
    k = np.clip(np.searchsorted(src, t), 1, len(src) - 1)
    lo, hi = src[k - 1], src[k]
    ok = (src_run[k - 1] == t_run) & (src_run[k] == t_run) & (lo < t) & (t < hi)
    frac = np.where(ok, (t - lo) / np.maximum(hi - lo, 1), 0.0)
    prior, confidence = prior.copy(), confidence.copy()
    prior[t] = np.where(ok[:, None, None], (1 - frac)[:, None, None] * prior[lo]
                        + frac[:, None, None] * prior[hi], np.nan)
    confidence[t] = np.where(ok, (1 - frac) * confidence[lo] + frac * confidence[hi], 0.0)
    return prior, confidence


def prior_weights(free, confidence, settings=DEFAULT_SETTINGS):
    """Weights (T, N) of the per-frame answers: ramp of the distance times confidence."""
    return _ramp(distance_to_observed(free), settings) * confidence[:, None] * free


def fill_segment(values, free, prior, confidence, settings=DEFAULT_SETTINGS):
    """Every unknown joint of one segment from time and the per-frame prior.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        Coordinates over the segment's frame range (read where not free).
    free : ndarray of bool (T, N)
        Unknown joints (missing, or in a frame absent from the track).
    prior : ndarray (T, N, 2)
        Per-frame answers (NaN where none); frames that :func:`prior_frames`
        skipped take them interpolated (:func:`spread_prior`).
    confidence : ndarray (T,)
        Confidence of each frame's per-frame answer, 0 where there is none.
    settings : TemporalSettings

    Returns
    -------
    filled : ndarray (T, N, 2)
        Observed joints as given; NaN where nothing anchors a joint.
    weight : ndarray (T, N)
        The prior's weight at each unknown joint (0: time alone).
    residual : ndarray (N,)
        Each trajectory's relative residual (the certificate).

    Examples
    --------
    A joint that moves at constant speed, hidden for three frames, comes back
    on its line; the rest of the pose needs no prior:

    >>> import numpy as np
    >>> values = np.zeros((9, 2, 2)); values[:, 0, 0] = np.arange(9.0)
    >>> free = np.zeros((9, 2), bool); free[3:6, 0] = True
    >>> out, w, r = fill_segment(values, free, np.full_like(values, np.nan), np.zeros(9))
    >>> out[3:6, 0, 0].round(6).tolist(), float(w.max())
    ([3.0, 4.0, 5.0], 0.0)
    """
    prior, confidence = spread_prior(free, prior, confidence, settings)
    confidence = np.where(np.isfinite(prior).all(axis=(1, 2)), confidence, 0.0)
    weight = prior_weights(free, confidence, settings)
    filled = values.copy()
    residual = np.zeros(values.shape[1])
    for j in range(values.shape[1]):
        if free[:, j].any():
            filled[:, j], residual[j] = smooth_trajectory(
                values[:, j], free[:, j], prior[:, j], weight[:, j], settings.acceleration,
                settings.jerk)
    return filled, weight, residual


def time_filled(values, free, near, settings=DEFAULT_SETTINGS):
    """Frames whose every unknown joint is within `near` frames of an
    observation of it, filled by time alone (the prior-free spline of
    :func:`fill_segment`): near-complete poses a clip offers to adaptation.

    Parameters
    ----------
    values : ndarray (T, N, 2)
    free : ndarray of bool (T, N)
    near : int
        0: the complete frames only.
    settings : TemporalSettings

    Returns
    -------
    rows : ndarray of bool (T,)
    filled : ndarray (T, N, 2)
        The segment with every unknown joint filled by time (read at `rows`).

    Examples
    --------
    >>> values = np.zeros((9, 2, 2)); values[:, 0, 0] = np.arange(9.0)
    >>> free = np.zeros((9, 2), bool); free[3:6, 0] = True
    >>> rows, filled = time_filled(values, free, 1)
    >>> rows.astype(int).tolist(), filled[3, 0].round(6).tolist()
    ([1, 1, 1, 1, 0, 1, 1, 1, 1], [3.0, 0.0])
    """
    rows = (np.where(free, distance_to_observed(free), 0.0) <= near).all(axis=1)
    if not (rows & free.any(axis=1)).any():
        return rows, values
    nothing = np.full_like(values, np.nan)
    return rows, fill_segment(values, free, nothing, np.zeros(len(values)), settings)[0]
