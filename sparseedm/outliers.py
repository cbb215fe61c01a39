"""Detection points that their track and the pose model both contradict.

A detector scores every keypoint it gives; a fixed cut-off (OpenPose's 0.05)
keeps a point scored just above it, although occluded limbs are where
detectors place low-scored points at wrong places. A point kept by the
cut-off but scored below :attr:`OutlierSettings.suspect_below` is *suspect*,
and is checked against two predictions made without it:

- the pose model: the row recovered with all its suspect points hidden
  (the sparse per-frame model on its confident joints,
  :func:`sparseedm._recovery_kernel.recover_members`), or, where that leaves
  too few joints, with each suspect point alone hidden;
- its track: the joint interpolated linearly over time between the
  confident observations of the same joint in the same track, where one lies
  within :attr:`OutlierSettings.time_reach` frames.

Both distances are in units of the row's body size (head top to the ankles'
midpoint of the pose model's answer, :func:`sparseedm.real_protocol.body_size`).
A suspect point is an *outlier* when the pose model puts it further than
``pose_limit`` body sizes away and time, where it can tell, further than
``time_limit``; in a track where time cannot tell (a joint not seen
confidently within ``time_reach`` frames: a long occlusion), when the pose
model alone puts it further than ``far_limit``; in a photo (no track), the
stricter ``alone_limit``. An
outlier is then treated as missing and filled; results and outputs name it
(source ``"outlier"``). A correct point with a low score agrees with one of the
two predictions and stays observed.

The limits were chosen on validation clips of Bonn PoseTrack written as
OpenPose folders with wrong and right low-scored points (60 % and all of the
occluded joints wrong): the least error left at the wrong points with at most
2 % of the right low-scored ones flagged
(``studies/outliers/select_outliers.py``, ``studies/outliers/selection.json``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ._recovery_kernel import recover_members
from ._validation import check_pose_shape, check_poses, frame_numbers
from .exceptions import ParameterError
from .real_protocol import body_size

__all__ = ["OutlierSettings", "OutlierCheck", "DEFAULT_OUTLIER_SETTINGS", "find_outliers",
           "mark_outliers", "check_confidence", "decide", "note_outliers", "outlier_names"]


class OutlierSettings(NamedTuple):
    """The outlier check's constants.

    Parameters
    ----------
    suspect_below : float
        Points scored below it (and kept by the reader's threshold) are checked.
    pose_limit : float
        Distance to the pose model's prediction, in body sizes, above which
        the pose model contradicts a point.
    time_limit : float
        Distance to the track's prediction, in body sizes, above which time
        contradicts a point.
    alone_limit : float
        The pose model's limit where there is no time (photos, rows outside
        any track).
    far_limit : float
        The pose model's limit in a track where time cannot tell (the joint
        not seen confidently within `time_reach` frames: a long occlusion).
    time_reach : int
        Frames within which a confident observation of the joint must lie on
        both sides (or one side, held) for time to predict it.
    """

    suspect_below: float = 0.3
    pose_limit: float = 0.08
    time_limit: float = 0.15
    alone_limit: float = 0.6
    far_limit: float = 0.1
    time_reach: int = 12


DEFAULT_OUTLIER_SETTINGS = OutlierSettings()


class OutlierCheck(NamedTuple):
    """What :func:`find_outliers` found, per joint (n, N).

    Parameters
    ----------
    outlier : ndarray of bool
        Points to treat as missing.
    suspect : ndarray of bool
        Points checked (observed, scored below ``suspect_below``).
    pose_error : ndarray
        Distance to the pose model's prediction in body sizes (NaN: not
        checked or no prediction).
    time_error : ndarray
        Distance to the track's prediction in body sizes (NaN: time cannot tell).
    tracked : ndarray of bool (n,)
        Rows in a track time can be read from.
    """

    outlier: np.ndarray
    suspect: np.ndarray
    pose_error: np.ndarray
    time_error: np.ndarray
    tracked: np.ndarray


def check_confidence(confidence, shape, caller):
    """`confidence` as an (n, N) float array of scores in [0, 1] (NaN: none).

    Parameters
    ----------
    confidence : array_like (n, N) or (N,)
        The detector's score of each joint.
    shape : tuple
        The poses' (n, N).
    caller : str
        Named in the error.

    Returns
    -------
    ndarray (n, N)
        The scores as floats.

    Raises
    ------
    ParameterError
        A shape other than `shape`, or a score outside [0, 1].

    Examples
    --------
    >>> check_confidence([[0.5, 2.0]], (1, 2), "f")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: f: confidence holds a score outside [0, 1]
    """
    conf = check_poses(confidence, caller, "confidence")
    if conf.ndim == 1:
        conf = conf[None]
    if conf.shape != shape:
        raise ParameterError(f"{caller}: confidence must have the poses' shape {shape} "
                             f"(one score per joint), got {conf.shape}")
    with np.errstate(invalid="ignore"):
        if ((conf < 0) | (conf > 1) | np.isinf(conf)).any():
            raise ParameterError(f"{caller}: confidence holds a score outside [0, 1]")
    return conf


def mark_outliers(poses, missing, confidence, dictionary, *, tracks=None, frames=None,
                  **kwargs):
    """Poses and missing mask with the outliers marked missing, and the outliers.

    What :func:`sparseedm.recover` and :func:`sparseedm.batch.recover_file`
    run when confidences are given: :func:`find_outliers` with the default
    settings, `dictionary` as the pose model.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
    missing : ndarray of bool (n, N)
        Checked already (:func:`check_confidence` for an API's scores).
    confidence : ndarray (n, N)
        Per-joint scores (NaN: none).
    dictionary : Dictionary
        The pose model.
    tracks, frames : array_like (n,), optional
        Time, when the poses have it.
    **kwargs
        The pose model's recovery settings (alpha, solver, ...).

    Returns
    -------
    poses : ndarray (n, N, 2)
        NaN at the outliers.
    missing : ndarray of bool (n, N)
        The given missing joints and the outliers.
    outlier : ndarray of bool (n, N)
    """
    mask, conf = np.asarray(missing, dtype=bool), np.asarray(confidence, dtype=float)
    poses = np.asarray(poses, dtype=float)
    check_pose_shape(poses, n_joints=dictionary.n_joints)  # the pose model's joints
    usable = np.isfinite(poses).all(axis=-1) | mask
    time_axis = None if frames is None else _whole_frames(frames, len(mask))
    outlier = find_outliers(np.where(usable[..., None], poses, np.nan), mask | ~usable,
                            np.where(usable, conf, np.nan), [dictionary],
                            tracks=None if time_axis is None else tracks,
                            frames=time_axis, **kwargs).outlier
    return np.where(outlier[..., None], np.nan, poses), mask | outlier, outlier


def _whole_frames(frames, n):
    """Frame numbers as floats when every one is usable by the one rule, else None
    (time cannot tell: the pose model alone decides)."""
    if np.shape(frames) != (n,):
        return None
    values, reason = frame_numbers(frames, n)  # the one frame-number rule
    return None if (reason != "").any() else values.astype(float)


def find_outliers(poses, missing, confidence, members, *, tracks=None, frames=None,
                  settings=None, **kwargs):
    """The suspect points of `poses` that the pose model and time both contradict.

    Inputs are trusted (validated by the caller, :func:`sparseedm.recover`).

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Poses, finite where observed.
    missing : ndarray of bool (n, N)
        Joints already missing.
    confidence : ndarray (n, N)
        The detector's scores (NaN: no score, never suspect).
    members : sequence of Dictionary
        The pose model's dictionaries (the first is used).
    tracks, frames : ndarray (n,), optional
        Each row's track and frame number; without frames the pose model
        alone decides (``alone_limit``).
    settings : OutlierSettings, optional
        Default :data:`DEFAULT_OUTLIER_SETTINGS`.
    **kwargs
        The pose model's recovery settings (alpha, solver, ...).

    Returns
    -------
    OutlierCheck

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)[None]
    >>> conf = np.full((1, 14), 0.9)
    >>> pose[0, 4], conf[0, 4] = (120, 150), 0.1   # a wrong, low-scored wrist
    >>> check = find_outliers(pose, np.zeros((1, 14), bool), conf, [load_dictionary()])
    >>> np.flatnonzero(check.outlier[0]).tolist()
    [4]
    """
    settings = DEFAULT_OUTLIER_SETTINGS if settings is None else settings
    n, N = missing.shape
    with np.errstate(invalid="ignore"):
        suspect = ~missing & (confidence < settings.suspect_below)
    pose_error = np.full((n, N), np.nan)
    time_error = np.full((n, N), np.nan)
    tracked = np.zeros(n, dtype=bool)
    rows = np.flatnonzero(suspect.any(axis=1))
    if len(rows):
        predicted, size = _pose_predictions(poses[rows], missing[rows], suspect[rows],
                                            list(members)[:1], kwargs)
        with np.errstate(invalid="ignore", divide="ignore"):
            pose_error[rows] = np.linalg.norm(predicted - poses[rows], axis=-1) / size
            if frames is not None:
                predicted, tracked = _time_predictions(poses, missing | suspect, tracks,
                                                       frames, settings.time_reach)
                time_error[rows] = np.linalg.norm(predicted[rows] - poses[rows],
                                                  axis=-1) / size
    pose_error[~suspect] = np.nan
    time_error[~suspect] = np.nan
    return OutlierCheck(decide(pose_error, time_error, tracked, settings), suspect,
                        pose_error, time_error, tracked)


def _pose_predictions(poses, missing, suspect, members, kwargs):
    """The pose model's prediction of every suspect point (m, N, 2) and each
    one's body size (m, N): each row with all its suspect points hidden; a row
    that leaves too few joints so (refused) once per suspect point, that point
    alone hidden. NaN where the pose model gave no answer."""
    hidden = missing | suspect
    kwargs = dict(kwargs, check_input=False)  # find_outliers' inputs are trusted
    res = recover_members(np.where(hidden[..., None], np.nan, poses), hidden, members, [],
                          **kwargs)
    predicted = res.poses
    size = np.repeat(body_size(predicted)[:, None], missing.shape[1], axis=1)
    r, j = np.nonzero(suspect & ~res.ok[:, None])
    if len(r):
        one = missing[r].copy()
        one[np.arange(len(r)), j] = True
        again = recover_members(np.where(one[..., None], np.nan, poses[r]), one, members,
                                [], **kwargs)
        predicted[r, j] = again.poses[np.arange(len(r)), j]
        size[r, j] = body_size(again.poses)
    return predicted, size


def decide(pose_error, time_error, tracked, settings):
    """Outliers (n, N) from the two distances (NaN: no prediction) and the limits.

    Parameters
    ----------
    pose_error, time_error : ndarray (n, N)
    tracked : ndarray of bool (n,)
        As :class:`OutlierCheck`'s.
    settings : OutlierSettings

    Returns
    -------
    ndarray of bool (n, N)
    """
    with np.errstate(invalid="ignore"):
        timed = np.isfinite(time_error)
        alone = np.where(tracked, settings.far_limit, settings.alone_limit)[:, None]
        return np.where(timed, (pose_error > settings.pose_limit)
                        & (time_error > settings.time_limit), pose_error > alone)


def _time_predictions(poses, hidden, tracks, frames, reach):
    """Each joint of each row predicted from its track's other rows where the
    joint is not `hidden`: linear in time between the nearest ones within
    `reach` frames (held from one side); NaN where none is that near, and
    for the rows of a track that holds one frame twice; and the rows (n,) of
    the tracks time was read from."""
    n, N = hidden.shape
    out = np.full(poses.shape, np.nan)
    tracked = np.zeros(n, dtype=bool)
    keys = np.zeros(n, int) if tracks is None else np.unique(
        np.asarray(tracks).astype(str), return_inverse=True)[1].ravel()
    t_all = np.asarray(frames, dtype=float)
    for key in np.unique(keys):
        rows = np.flatnonzero(keys == key)
        rows = rows[np.argsort(t_all[rows], kind="stable")]
        t = t_all[rows]
        if len(rows) < 2 or not np.all(np.diff(t) > 0):
            continue
        tracked[rows] = True
        for j in range(N):
            seen = ~hidden[rows, j]
            if seen.any():
                out[rows, j] = _interpolate(t, poses[rows, j], seen, reach)
    return out, tracked


def _interpolate(t, xy, seen, reach):
    """(T, 2): xy at every time t from the `seen` ones, linear between the
    nearest seen before and after, held from one side; NaN beyond `reach`."""
    ts, ps = t[seen], xy[seen]
    after = np.clip(np.searchsorted(ts, t), 0, len(ts) - 1)
    before = np.where(ts[after] <= t, after, np.clip(after - 1, 0, len(ts) - 1))
    gap_before, gap_after = t - ts[before], ts[after] - t
    ok_before = (gap_before >= 0) & (gap_before <= reach)
    ok_after = (gap_after >= 0) & (gap_after <= reach)
    both = ok_before & ok_after & (ts[after] > ts[before])
    w = np.where(both, gap_before / np.where(both, ts[after] - ts[before], 1.0), 0.0)
    out = np.where(ok_before[:, None], ps[before], ps[after])
    out = np.where(both[:, None], (1 - w)[:, None] * ps[before] + w[:, None] * ps[after], out)
    out[~(ok_before | ok_after)] = np.nan
    return out


def outlier_names(outlier, names):
    """Per row, the names of its outlier joints joined by spaces (``""``: none).

    Parameters
    ----------
    outlier : ndarray of bool (n, N)
    names : sequence of str (N,)

    Returns
    -------
    ndarray of str (n,)

    Examples
    --------
    >>> outlier_names(np.array([[True, False, True], [False] * 3]), ["a", "b", "c"]).tolist()
    ['a c', '']
    """
    return np.array([" ".join(names[j] for j in np.flatnonzero(row)) for row in outlier],
                    dtype=str)


def note_outliers(result, outlier):
    """`result` with its outliers named (in place; returned): ``outliers`` (n, N)
    the outlier points the result filled, and for a result with per-joint
    ``source``, those joints' source ``"outlier"``.

    Parameters
    ----------
    result : RecoveryResult
        Of the poses with the outliers marked missing.
    outlier : ndarray of bool (n, N)

    Returns
    -------
    RecoveryResult
    """
    filled = outlier & np.isfinite(result.poses).all(axis=-1)
    result.outliers = filled
    source = getattr(result, "source", None)
    if source is not None:
        result.source = np.where(filled & (source != ""), "outlier", source)
    return result
