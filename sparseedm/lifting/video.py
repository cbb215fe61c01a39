"""Lifting a video: what :func:`sparseedm.lift` does with frames.

Each person's frames (a track; tracks are split where frames skip more than
:data:`sparseedm.temporal.tracks.MAX_SKIP`) are lifted in three steps
beyond the per-frame pipeline:

1. :func:`fill_in_time` -- the missing 2D joints are filled across time by
   :func:`sparseedm.temporal.recover.recover_temporal` (its defaults: the
   temporal model, one clip adapting the 2D dictionary) before lifting, so
   the lifter sees whole poses where time knows them;
2. :func:`choose_reflections` -- each track's depth reflections are chosen
   together (:func:`sparseedm.lifting.mds.reflection_path`): a frame the
   chirality prior misjudges follows its neighbours instead of flipping;
3. :func:`smooth_tracks` -- each joint's 3D trajectory is smoothed (a
   penalty on acceleration, solved exactly by
   :func:`sparseedm.temporal.smoothing.smooth_trajectory`), which removes the
   per-frame lasso's jitter.

The settings were chosen on validation sequences of two sources
(``studies/lifting/probe_video_lift.py``, docs/explanation/settings.md), never on test
clips.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..temporal.recover import recover_temporal, time_layout
from ..temporal.smoothing import smooth_trajectory
from ..uncertainty import joint_uncertainty
from .mds import reflection_path

__all__ = ["fill_in_time", "TimeFill", "choose_reflections", "smooth_tracks", "TIME_FILL_MAX_WEIGHT",
           "TRAJECTORY_SMOOTHNESS"]

#: a joint time filled is lifted as filled when the per-frame 2D model's
#: weight in its fill (``TemporalResult.prior_weight``: 0 near an
#: observation, 1 deep in a long gap) is at most this; otherwise the lifter's
#: own lasso on the observed joints places it
TIME_FILL_MAX_WEIGHT = 1.0

#: acceleration penalty of :func:`smooth_tracks` against each lifted frame's
#: squared distance (both in square metres, so the ratio is free of units);
#: 0 turns the smoothing off
TRAJECTORY_SMOOTHNESS = 30.0


class TimeFill(NamedTuple):
    """What :func:`fill_in_time` returns."""

    #: (n, N, 2) the poses with the filled joints' coordinates
    poses: np.ndarray
    #: (n, N) bool, the joints filled (a subset of the mask)
    filled: np.ndarray
    #: the segments time filled the poses in (TrackLayout)
    layout: object
    #: (n, N) the 2D 90 % radius (pixels): 0 observed, the calibrated radius of
    #: a filled joint (:mod:`sparseedm.uncertainty`), NaN where still missing
    uncertainty: np.ndarray


def fill_in_time(poses, mask, tracks, frames, *, dictionary=None, n_jobs=1, adapt="auto",
                 progress=False):
    """The poses with the 2D joints time fills, which joints, the track layout
    and the filled joints' 90 % radius.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Validated poses (coordinates at masked joints are ignored).
    mask : ndarray of bool (n, N)
        Missing joints.
    tracks, frames
        As :func:`sparseedm.recover`'s, `frames` checked
        (:func:`~sparseedm._validation.check_frames`) by the caller.
    dictionary, n_jobs, adapt, progress
        As :func:`sparseedm.recover` with frames (`adapt` of the 2D dictionary).

    Returns
    -------
    TimeFill
        ``poses`` with the filled joints' coordinates; ``filled`` the joints
        filled (a subset of `mask`; rows time cannot use fill none);
        ``layout`` the segments time filled the poses in
        (:func:`sparseedm.temporal.recover.time_layout`; its ``linked``: the
        track ids linked when none were given and a frame holds several
        poses); ``uncertainty`` the 2D radius of each joint (0 observed, NaN
        still missing).
    """
    rec_input = np.where(mask[..., None], np.nan, poses)
    rec = recover_temporal(rec_input, mask, tracks=tracks,
                           frames=frames, dictionary=dictionary, n_jobs=n_jobs,
                           adapt=adapt, progress=progress, check_input=False)
    filled = ((rec.source == "temporal") & mask & np.isfinite(rec.poses).all(axis=-1)
              & (rec.prior_weight <= TIME_FILL_MAX_WEIGHT))
    poses = np.where(filled[..., None], rec.poses, poses)
    linked = rec.linked_tracks
    layout = time_layout(rec_input, mask, tracks=tracks if linked is None else linked,
                         frames=frames, check_input=False)
    layout.linked = linked
    radius = joint_uncertainty(rec, tracks if linked is None else linked, frames)
    radius = np.where(mask & ~filled, np.nan, np.where(mask, radius, 0.0))
    return TimeFill(poses, filled, layout, radius)


def choose_reflections(front, back, score, rows, layout):
    """Which lifted rows take the ``back`` reflection.

    Parameters
    ----------
    front, back : ndarray (m, N, 3)
        The two metric reflections of the lifted rows.
    score : ndarray (m,)
        The chirality prior's log-odds of ``front``.
    rows : ndarray of int (m,)
        The lifted rows' indices among all n rows.
    layout : TrackLayout
        From :func:`fill_in_time`.

    Returns
    -------
    ndarray of bool (m,)
        Per segment :func:`~sparseedm.lifting.mds.reflection_path` over its
        lifted frames; elsewhere the prior's sign.
    """
    flip = score < 0
    local = np.full(len(layout.alone), -1)
    local[rows] = np.arange(len(rows))
    for seg, offsets in zip(layout.segments, layout.offsets):
        at = local[seg]
        keep = at >= 0
        if keep.sum() > 1:
            at = at[keep]
            flip[at] = reflection_path(front[at], back[at], score[at], offsets[keep])
    return flip


def smooth_tracks(poses3d, layout, smoothness=None):
    """Each joint's 3D trajectory per segment, smoothed (in place; returns it).

    Minimises ``sum_t w_t ||x_t - p_t||^2 + smoothness * sum_t ||x_{t-1} - 2 x_t
    + x_{t+1}||^2`` per joint over the segment's frame range, ``p_t`` the
    lifted pose and ``w_t`` 1 where the frame was lifted, 0 at skipped
    frames and refused rows (which stay NaN: nothing is invented).
    `smoothness` defaults to :data:`TRAJECTORY_SMOOTHNESS`.
    """
    smoothness = TRAJECTORY_SMOOTHNESS if smoothness is None else float(smoothness)
    if smoothness <= 0:
        return poses3d
    for seg, offsets in zip(layout.segments, layout.offsets):
        lifted = np.isfinite(poses3d[seg]).all(axis=(1, 2))
        if lifted.sum() < 3:
            continue
        T = int(offsets[-1]) + 1
        weight = np.zeros(T)
        weight[offsets[lifted]] = 1.0
        prior = np.zeros((T, poses3d[0].size))  # every joint's coordinates, one solve
        prior[offsets[lifted]] = poses3d[seg[lifted]].reshape(int(lifted.sum()), -1)
        x, _ = smooth_trajectory(prior, np.ones(T, bool), prior, weight, smoothness)
        poses3d[seg[lifted]] = x[offsets[lifted]].reshape((-1,) + poses3d.shape[1:])
    return poses3d
