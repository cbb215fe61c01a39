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
need a per-frame answer at all (:func:`needs_prior`).

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

__all__ = ["TemporalSettings", "prior_weights", "needs_prior", "fill_segment"]


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
    """

    acceleration: float = 30.0
    jerk: float = 300.0
    ramp_start: float = 6.0
    ramp_full: float = 30.0
    inaccurate: float = 0.25


DEFAULT_SETTINGS = TemporalSettings()


def _ramp(distance, settings):
    span = max(settings.ramp_full - settings.ramp_start, 1e-9)
    return np.clip((distance - settings.ramp_start) / span, 0.0, 1.0)


def needs_prior(free, settings=DEFAULT_SETTINGS):
    """Frames (T,) where some unknown joint gives a per-frame answer weight."""
    w = _ramp(distance_to_observed(free), settings)
    return ((w > 0) & free).any(axis=1)


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
        Per-frame answers (NaN where none).
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
