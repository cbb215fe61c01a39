"""Occlusion protocols on real annotated people, and their scores, as pure functions.

Real keypoint files carry their own occlusions: joints nobody annotated, or
annotated but flagged invisible. The protocols here hide joints of COMPLETE
real poses (so the truth is known) the way real poses lose them:

* :func:`transplant_masks` gives each pose the missing pattern of another
  real pose drawn from a pool (a photo protocol: real patterns of occlusion
  instead of uniform random joints);
* :func:`transplant_track_mask` moves the missing runs of another real track
  (a joint's consecutive unseen frames) onto a complete clip (the video
  protocol).

Both keep at least :data:`~sparseedm.normalize.MIN_OBSERVED_JOINTS` joints
observed in every pose or frame (what recovery needs).

The scores (:func:`hidden_errors`, :func:`error_summary`,
:func:`group_summaries`): the distance of each hidden joint to its annotation
as a percentage of the body size (:func:`body_size`: head top to the ankles'
midpoint), its median, and PCKh@0.5 (a hit when the distance is at most half
the head size, MPII's normaliser) where a head size is known, per joint group
(:data:`JOINT_GROUPS`) and overall.

Examples
--------
>>> pool = np.zeros((2, 14), bool); pool[0, [4, 7]] = True; pool[1, 10] = True
>>> masks, donors = transplant_masks(3, pool, random_state=0)
>>> bool((masks == pool[donors]).all())
True
"""

from __future__ import annotations

from numbers import Integral
from typing import NamedTuple

import numpy as np

from ._validation import Interval, check_mask, validate_params
from .exceptions import PoseError
from .normalize import MIN_OBSERVED_JOINTS
from .skeleton import SKELETON_14

__all__ = ["JOINT_GROUPS", "body_size", "usable_patterns", "transplant_masks",
           "transplant_track_mask", "HiddenErrors", "hidden_errors", "error_summary",
           "group_summaries"]

_J = SKELETON_14.index
#: joint groups the scores are broken down by (indices of the 14 joints)
JOINT_GROUPS = {
    "head": (_J("head_top"), _J("neck")),
    "shoulders": (_J("right_shoulder"), _J("left_shoulder")),
    "elbows": (_J("right_elbow"), _J("left_elbow")),
    "wrists": (_J("right_wrist"), _J("left_wrist")),
    "hips": (_J("right_hip"), _J("left_hip")),
    "knees": (_J("right_knee"), _J("left_knee")),
    "ankles": (_J("right_ankle"), _J("left_ankle")),
}
_HEAD_TOP = _J("head_top")
_ANKLES = [_J("right_ankle"), _J("left_ankle")]


def body_size(poses):
    """Each pose's body size: the distance from the head top to the ankles' midpoint.

    Parameters
    ----------
    poses : array_like (n, 14, 2)

    Returns
    -------
    ndarray (n,)
        In the poses' units (pixels); NaN where one of the three joints is NaN.

    Examples
    --------
    >>> p = np.zeros((1, 14, 2)); p[0, 10] = [-10, 170]; p[0, 13] = [10, 170]
    >>> body_size(p).tolist()
    [170.0]
    """
    p = np.asarray(poses, dtype=float)
    return np.linalg.norm(p[:, _HEAD_TOP] - p[:, _ANKLES].mean(axis=1), axis=-1)


def usable_patterns(pool, min_observed=MIN_OBSERVED_JOINTS):
    """The rows of a pool of missing patterns that hide a joint and keep enough.

    Parameters
    ----------
    pool : array_like of bool (k, N)
        True = missing (not annotated or flagged invisible).
    min_observed : int, default MIN_OBSERVED_JOINTS (3)

    Returns
    -------
    ndarray of int
        Indices of the rows hiding at least one joint and observing at least
        `min_observed`.

    Examples
    --------
    >>> pool = np.zeros((3, 14), bool); pool[1, :12] = True; pool[2, 0] = True
    >>> usable_patterns(pool).tolist()
    [2]
    """
    pool = np.asarray(pool, dtype=bool)
    hidden = pool.sum(axis=1)
    return np.flatnonzero((hidden >= 1) & (pool.shape[1] - hidden >= min_observed))


def transplant_masks(n_poses, pool, *, min_observed=MIN_OBSERVED_JOINTS, random_state=None):
    """Seeded masks for `n_poses` poses, each the pattern of a random pool row.

    Parameters
    ----------
    n_poses : int
    pool : array_like of bool (k, N)
        Real missing patterns (True = missing), e.g. the incomplete poses of
        the same dataset. Only the rows :func:`usable_patterns` keeps are drawn.
    min_observed : int, default 3
    random_state : int or numpy.random.Generator, optional

    Returns
    -------
    masks : ndarray of bool (n_poses, N)
    donors : ndarray of int (n_poses,)
        The pool row each mask was copied from.

    Raises
    ------
    PoseError
        When no pool row is usable.

    Examples
    --------
    >>> pool = np.zeros((2, 14), bool); pool[0, 4] = True; pool[1] = True
    >>> masks, donors = transplant_masks(4, pool, random_state=1)
    >>> donors.tolist(), masks.sum(axis=1).tolist()
    ([0, 0, 0, 0], [1, 1, 1, 1])
    """
    validate_params("transplant_masks", dict(n_poses=n_poses, min_observed=min_observed), {
        "n_poses": [Interval(Integral, 0, None)], "min_observed": [Interval(Integral, 1, None)]})
    pool = check_mask(pool, "transplant_masks", "pool")
    if pool.ndim != 2:
        raise PoseError(f"transplant_masks: pool must have shape (k, N), got {pool.shape}")
    rows = usable_patterns(pool, min_observed)
    if rows.size == 0:
        raise PoseError(f"transplant_masks: no pool pattern hides a joint and keeps "
                        f"{min_observed} observed ({len(pool)} patterns given)")
    donors = rows[np.random.default_rng(random_state).integers(0, rows.size, int(n_poses))]
    return pool[donors].copy(), donors


def transplant_track_mask(n_frames, donors, *, min_observed=MIN_OBSERVED_JOINTS,
                          random_state=None):
    """A clip's mask made of another real track's missing runs.

    One donor (T_d, N) mask is drawn among those hiding something; a window
    of `n_frames` consecutive frames is cut from it at a seeded offset (a
    shorter donor is placed at a seeded offset in the clip, the rest
    observed). Frames left with fewer than `min_observed` observed joints get
    random hidden joints back until they have that many.

    Parameters
    ----------
    n_frames : int
    donors : sequence of array_like of bool (T_d, N)
        Real tracks' missing masks (True = missing), rows in frame order.
    min_observed : int, default 3
    random_state : int or numpy.random.Generator, optional

    Returns
    -------
    mask : ndarray of bool (n_frames, N)
    donor : int
        Index of the donor in `donors`.

    Raises
    ------
    PoseError
        When no donor hides anything.

    Examples
    --------
    >>> donor = np.zeros((5, 14), bool); donor[1:4, 7] = True
    >>> mask, k = transplant_track_mask(5, [np.zeros((9, 14), bool), donor], random_state=0)
    >>> k, mask[:, 7].astype(int).tolist()
    (1, [0, 1, 1, 1, 0])
    """
    validate_params("transplant_track_mask", dict(n_frames=n_frames, min_observed=min_observed), {
        "n_frames": [Interval(Integral, 1, None)], "min_observed": [Interval(Integral, 1, None)]})
    donors = [np.asarray(d, dtype=bool) for d in donors]
    live = [k for k, d in enumerate(donors) if d.ndim == 2 and d.any()]
    if not live:
        raise PoseError("transplant_track_mask: no donor track has a missing joint")
    rng = np.random.default_rng(random_state)
    k = live[int(rng.integers(len(live)))]
    donor, T = donors[k], int(n_frames)
    mask = np.zeros((T, donor.shape[1]), bool)
    if len(donor) >= T:
        start = int(rng.integers(0, len(donor) - T + 1))
        mask[:] = donor[start:start + T]
    else:
        start = int(rng.integers(0, T - len(donor) + 1))
        mask[start:start + len(donor)] = donor
    for t in np.flatnonzero(mask.shape[1] - mask.sum(axis=1) < min_observed):
        hidden = np.flatnonzero(mask[t])
        back = mask.shape[1] - hidden.size
        mask[t, rng.choice(hidden, min_observed - back, replace=False)] = False
    return mask, k


class HiddenErrors(NamedTuple):
    """The scored hidden joints of one method (what :func:`hidden_errors` returns).

    Attributes
    ----------
    pose, joint : ndarray of int (h,)
        Row and joint of each hidden joint, in row-major order of the mask.
    error : ndarray (h,)
        Distance to the annotation, % of the body size; NaN where the method
        gave no coordinates (unfilled).
    hit : ndarray (h,)
        1.0 when the distance is at most ``pckh`` x the head size, 0.0 when
        not, NaN where there is no head size or no answer.
    """

    pose: np.ndarray
    joint: np.ndarray
    error: np.ndarray
    hit: np.ndarray


def hidden_errors(filled, truth, missing, size, head_size=None, *, pckh=0.5):
    """Errors of the hidden joints: % of the body size, and PCKh hits.

    Parameters
    ----------
    filled, truth : array_like (n, N, 2)
        A method's answer and the annotation, pixels.
    missing : array_like of bool (n, N)
        The joints that were hidden (only these are scored).
    size : array_like (n,)
        Each pose's body size (:func:`body_size`, or a clip's median).
    head_size : array_like (n,), optional
        PCKh's normaliser per pose (NaN where unknown); None: no PCKh.
    pckh : float, default 0.5

    Returns
    -------
    HiddenErrors

    Examples
    --------
    A wrist 10 px off in a 200 px body with a 30 px head: 5 %, within 0.5 x 30 px.

    >>> truth = np.zeros((1, 14, 2)); filled = truth.copy(); filled[0, 4] = [6, 8]
    >>> missing = np.zeros((1, 14), bool); missing[0, 4] = True
    >>> e = hidden_errors(filled, truth, missing, [200.0], [30.0])
    >>> e.error.tolist(), e.hit.tolist()
    ([5.0], [1.0])
    """
    missing = np.asarray(missing, dtype=bool)
    pose, joint = np.nonzero(missing)
    dist = np.linalg.norm(np.asarray(filled, float) - np.asarray(truth, float), axis=-1)
    dist = dist[pose, joint]
    error = dist / np.asarray(size, float)[pose] * 100.0
    hit = np.full(dist.shape, np.nan)
    if head_size is not None:
        head = np.asarray(head_size, float)[pose]
        known = np.isfinite(head) & np.isfinite(dist)
        hit[known] = (dist[known] <= pckh * head[known]).astype(float)
    return HiddenErrors(pose, joint, error, hit)


def error_summary(error, hit, keep=None):
    """Mean, median and PCKh of scored errors, and how many there were.

    Parameters
    ----------
    error, hit : ndarray (h,)
        As :class:`HiddenErrors`.
    keep : ndarray of bool (h,), optional
        The errors to pool (e.g. those every compared method filled); default
        the finite ones.

    Returns
    -------
    dict
        ``n`` (errors given), ``scored`` (pooled), ``mean``, ``median``
        (NaN when none), ``pckh`` (fraction of hits among the pooled errors
        with a head size; NaN when none has one), ``pckh_n`` (how many had),
        ``unfilled`` (NaN errors), ``mean_own`` (the mean of every finite
        error, pooled or not).

    Examples
    --------
    >>> s = error_summary(np.array([1.0, 3.0, np.nan]), np.array([1.0, 0.0, np.nan]))
    >>> s["mean"], s["median"], s["pckh"], s["unfilled"]
    (2.0, 2.0, 0.5, 1)
    """
    error = np.asarray(error, float)
    hit = np.asarray(hit, float)
    keep = np.isfinite(error) if keep is None else np.asarray(keep, bool) & np.isfinite(error)
    e, h = error[keep], hit[keep]
    h = h[np.isfinite(h)]
    own = error[np.isfinite(error)]
    nan = float("nan")
    return {"n": int(error.size), "scored": int(e.size),
            "mean": float(e.mean()) if e.size else nan,
            "median": float(np.median(e)) if e.size else nan,
            "pckh": float(h.mean()) if h.size else nan, "pckh_n": int(h.size),
            "unfilled": int(error.size - own.size),
            "mean_own": float(own.mean()) if own.size else nan}


def group_summaries(errors, keep=None, groups=JOINT_GROUPS):
    """:func:`error_summary` per joint group and ``"overall"``.

    Parameters
    ----------
    errors : HiddenErrors
    keep : ndarray of bool (h,), optional
        As :func:`error_summary`.
    groups : dict, default JOINT_GROUPS
        Group name -> joint indices.

    Returns
    -------
    list of dict
        One :func:`error_summary` per group, with its ``group`` name, in the
        order of `groups`, then ``"overall"``.

    Examples
    --------
    >>> e = HiddenErrors(np.array([0, 0]), np.array([0, 4]), np.array([2.0, 4.0]),
    ...                  np.array([1.0, 0.0]))
    >>> [(r["group"], r["n"], r["mean"]) for r in group_summaries(e) if r["n"]]
    [('head', 1, 2.0), ('wrists', 1, 4.0), ('overall', 2, 3.0)]
    """
    keep = np.isfinite(errors.error) if keep is None else np.asarray(keep, bool)
    rows = []
    for name, joints in list(groups.items()) + [("overall", None)]:
        sel = np.ones(errors.joint.shape, bool) if joints is None \
            else np.isin(errors.joint, joints)
        rows.append({"group": name, **error_summary(errors.error[sel], errors.hit[sel],
                                                    keep[sel])})
    return rows
