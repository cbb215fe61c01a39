"""Link poses without track ids into tracks, frame by frame.

A detector run over a video without a tracker (OpenPose without
``--tracking``, a top-down detector's per-frame results, a CSV with a
``frame`` column and several people per frame) gives each frame's people in
no particular order. :func:`link_tracks` gives them track ids the way the
simple trackers of pose estimation do (the greedy / Hungarian pose-distance
matching of the PoseTrack baselines): each frame's poses are matched to the
tracks seen in the frames just before by the Hungarian algorithm
(:func:`scipy.optimize.linear_sum_assignment`) on the mean distance of their
common observed joints, in units of the pose's extent, each track's joints
carried forward at the body's last velocity (the median of its joints'
moves; per-joint velocities switched identities 157 / 69 times against 58 /
39 on the two sources' validation scenes of ``studies/temporal/probe_linking.py``);
a pose no track is near enough to starts a new track. Occluded joints are no
obstacle: a track remembers each joint's last observed position.

:func:`recover_temporal` links when it is given frames and no tracks and
some frame holds more than one pose (all one track is then impossible), and
says so (``TemporalResult.linked_tracks``).

The same measure guards every track, given or linked: :func:`split_at_jumps`
cuts a track's stretch of frames where its pose jumps further between two
rows than linking would ever join (a cut in the video, an identity switch of
the tracker, or files that are not a video at all, such as a folder of
photos numbered IMG_4501, IMG_4502...): time must not carry a joint from
one person or shot to another. Its unit is at least the track's body extent
(:func:`body_extent`; on a track without a complete frame, the largest
distance between two joints seen together, :func:`pair_extent`), so that
frames showing only a few close joints (an arm) do not read a fast move as a
jump.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from .tracks import MAX_SKIP, frame_numbers

__all__ = ["link_tracks", "needs_linking", "split_at_jumps", "step_distances", "body_extent",
           "pair_extent", "PAIR_MIN_ROWS",
           "MAX_LINK_DISTANCE", "MIN_COMMON_JOINTS", "MAX_MEDIAN_STEP", "JUMP_REASON"]

#: a pose joins a track only when the mean distance of their common joints is
#: at most this many times the larger of their extents (the diagonal of the
#: observed joints' bounding box, about a body height), scaled by the square
#: root of the frames between them
MAX_LINK_DISTANCE = 0.5
#: fewest observed joints a pose and a track must share to be compared
MIN_COMMON_JOINTS = 3
#: a stretch of frames whose median step (:func:`step_distances`) is above this
#: is not a video (a folder of photos, frame numbers that are not frames):
#: :func:`split_at_jumps` cuts it at every row. On the video protocols'
#: sequences (both sources and splits, 30 frames/s, clean and with 1 % of
#: jitter) the median step is at most 0.074 and no step exceeds 0.15; 40
#: unrelated photos numbered in a row step 1.3 in the median
MAX_MEDIAN_STEP = 0.25
#: why a row cut off on both sides by :func:`split_at_jumps` is answered alone
JUMP_REASON = ("its pose jumps from the frames before and after it (a cut in the video, "
               "another person, or not a video)")


def needs_linking(tracks, frames):
    """True when `tracks` is None and some usable frame number repeats.

    Parameters
    ----------
    tracks : array_like or None
        The caller's track ids, if any.
    frames : array_like of int or None
        Frame number of each pose, if any.

    Returns
    -------
    bool
        Whether :func:`link_tracks` should give the poses track ids.

    Examples
    --------
    >>> needs_linking(None, [0, 1, 1, 2]), needs_linking(None, [0, 1, 2])
    (True, False)
    >>> needs_linking(["a", "b"], [0, 0])
    False
    """
    if tracks is not None or frames is None:
        return False
    values, reason = frame_numbers(frames, len(np.asarray(frames)))
    good = values[reason == ""]
    return len(np.unique(good)) < len(good)


def _extents(poses):
    """Diagonal of the bounding box of each pose's observed joints (NaN: < 2)."""
    seen = ~np.isnan(poses[..., :1])
    span = np.where(seen, poses, -np.inf).max(axis=-2) - np.where(seen, poses, np.inf).min(axis=-2)
    return np.where(seen[..., 0].sum(axis=-1) >= 2, np.linalg.norm(span, axis=-1), np.nan)


class _Track:
    """Each joint's last observed position and when, and the body's velocity:
    the median of its joints' moves over the frames since each was seen."""

    def __init__(self, ident, pose, frame):
        self.id = ident
        self.last = pose.copy()
        self.seen = np.where(np.isnan(pose[:, 0]), -1, frame).astype(np.int64)
        self.velocity = np.zeros(2)
        self.frame = frame

    def predict(self, frame):
        """Joint positions expected at `frame` (NaN: never observed)."""
        return self.last + self.velocity * (frame - self.seen)[:, None]

    def update(self, pose, frame):
        seen = ~np.isnan(pose[:, 0])
        moved = seen & (self.seen >= 0)
        if moved.any():
            v = np.sort((pose[moved] - self.last[moved]) / (frame - self.seen[moved])[:, None],
                        axis=0)
            self.velocity = (v[(len(v) - 1) // 2] + v[len(v) // 2]) / 2  # the median
        self.last[seen] = pose[seen]
        self.seen[seen] = frame
        self.frame = frame


def _costs(live, poses, frame):
    """Mean common-joint distance of each (track, pose) pair over the larger
    extent, divided by sqrt(frames apart); inf below MIN_COMMON_JOINTS."""
    if not live:
        return np.zeros((0, len(poses)))
    guess = np.stack([t.predict(frame) for t in live])              # (L, N, 2)
    scale = np.fmax(_extents(np.stack([t.last for t in live]))[:, None],
                    _extents(poses)[None, :])                         # (L, P)
    skip = np.sqrt(frame - np.array([t.frame for t in live], dtype=float))[:, None]
    d = np.linalg.norm(guess[:, None] - poses[None], axis=-1)        # (L, P, N), NaN unseen
    common = (~np.isnan(d)).sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(common > 0, np.nansum(d, axis=-1) / np.maximum(common, 1), np.nan)
        cost = mean / scale / skip
    ok = (common >= MIN_COMMON_JOINTS) & (scale > 0)
    return np.where(ok & np.isfinite(cost), cost, np.inf)


def _match(cost, max_distance):
    """Pairs (track index, pose index) of the cheapest assignment within reach."""
    if cost.size == 0:
        return []
    finite = np.isfinite(cost)
    big = (np.nanmax(cost[finite]) + 1.0) * (cost.size + 1) if finite.any() else 1.0
    rows, cols = linear_sum_assignment(np.where(finite, cost, big))
    return [(a, b) for a, b in zip(rows, cols) if cost[a, b] <= max_distance]


def link_tracks(poses, missing=None, *, frames, max_distance=MAX_LINK_DISTANCE,
                max_skip=MAX_SKIP):
    """Track ids for poses given without them.

    Parameters
    ----------
    poses : array_like (n, N, 2)
        Pixels; NaN (or `missing`) where a joint is not observed.
    missing : array_like of bool (n, N), optional
    frames : array_like (n,)
        Frame number of each pose; several poses may share one.
    max_distance : float
        :data:`MAX_LINK_DISTANCE`.
    max_skip : int
        A track not seen for more than this many frames is not continued.

    Returns
    -------
    ndarray of int64 (n,)
        Track id of each pose, numbered from 0 in the order the tracks start
        (by frame; tracks starting in one frame left to right), whatever
        the order of the rows. A pose with an unusable frame number or fewer
        than :data:`MIN_COMMON_JOINTS` observed joints gets an id of its
        own, after those.

    Examples
    --------
    Two people in the frames 0-2, given in no order:

    >>> a = np.zeros((14, 2)); a[:, 0] = np.arange(14); a[:, 1] = np.arange(14) ** 1.5
    >>> b = a + [40.0, 0.0]
    >>> poses = np.stack([a, b, b + 1, a + 1, a + 2, b + 2])
    >>> link_tracks(poses, frames=[0, 0, 1, 1, 2, 2]).tolist()
    [0, 1, 1, 0, 0, 1]
    """
    poses = np.array(poses, dtype=float)
    n = len(poses)
    if missing is not None:
        poses[np.asarray(missing, dtype=bool)] = np.nan
    poses[~np.isfinite(poses).all(axis=2)] = np.nan
    values, reason = frame_numbers(frames, n)
    ids = np.full(n, -1, dtype=np.int64)
    usable = (reason == "") & ((~np.isnan(poses[:, :, 0])).sum(axis=1) >= MIN_COMMON_JOINTS)
    tracks, next_id = [], 0
    rows = np.flatnonzero(usable)
    rows = rows[np.argsort(values[rows], kind="stable")]
    for group in np.split(rows, np.flatnonzero(np.diff(values[rows])) + 1):
        if not len(group):
            continue
        frame = int(values[group[0]])
        live = [t for t in tracks if frame - t.frame <= max_skip + 1]
        pairs = _match(_costs(live, poses[group], frame), max_distance)
        for a, b in pairs:
            ids[group[b]] = live[a].id
            live[a].update(poses[group[b]], frame)
        for r in _left_to_right(poses, group[ids[group] < 0]):
            tracks.append(_Track(next_id, poses[r], frame))
            ids[r] = next_id
            next_id += 1
        tracks = [t for t in tracks if frame - t.frame <= max_skip + 1]
    alone = np.flatnonzero(ids < 0)
    ids[alone] = next_id + np.arange(len(alone))
    return ids


def _left_to_right(poses, rows):
    """`rows` by the mean x, then y, of their observed joints: new tracks are
    numbered the same whatever order a frame's rows came in."""
    centre = np.nanmean(poses[rows], axis=1) if len(rows) else np.zeros((0, 2))
    return rows[np.lexsort((centre[:, 1], centre[:, 0]))]


def step_distances(poses, frames, body=None):
    """How far a track's pose moves from each row to the next, in linking's units.

    Parameters
    ----------
    poses : ndarray (T, N, 2)
        One track's rows in frame order; NaN where a joint is not observed.
    frames : ndarray of int (T,)
        Their frame numbers, increasing.
    body : float, optional
        The track's body extent (:func:`body_extent`): the unit is at least
        this, so that a step judged on a few close joints (two wrists and an
        elbow) is not read against their own small extent, where a person's
        ordinary fast motion looks like a jump.

    Returns
    -------
    ndarray (T - 1,)
        The mean distance of the joints observed in both rows, over the
        smaller of the two poses' extents on those joints, divided by the
        square root of the frames between them (as :func:`link_tracks`
        compares with :data:`MAX_LINK_DISTANCE`; the smaller extent, so that
        one wild coordinate, which inflates its own pose's extent, still reads
        as a jump); NaN where the rows share fewer than
        :data:`MIN_COMMON_JOINTS` joints (nothing to judge by).

    Examples
    --------
    >>> a = np.zeros((14, 2)); a[:, 1] = np.arange(14.0)
    >>> b = a.copy(); b[1] = [1e6, 0.0]                 # one wild coordinate
    >>> steps = step_distances(np.stack([a, a + 0.13, a + 100, b]), np.array([0, 1, 2, 3]))
    >>> steps.round(3).tolist()
    [0.014, 10.864, 5504.058]
    """
    poses = np.where(np.isfinite(poses).all(axis=-1, keepdims=True), poses, np.nan)
    if len(poses) < 2:
        return np.zeros(0)
    a, b = poses[:-1], poses[1:]
    seen = ~np.isnan(a[..., 0]) & ~np.isnan(b[..., 0])      # (T - 1, N): in both rows
    common = seen.sum(axis=-1)
    with np.errstate(all="ignore"):  # a wild coordinate overflows: inf, a jump
        d = np.where(seen, np.linalg.norm(a - b, axis=-1), 0.0)
        scale = np.fmin(_extents(np.where(seen[..., None], a, np.nan)),
                        _extents(np.where(seen[..., None], b, np.nan)))
        if body is not None and np.isfinite(body):
            scale = np.fmax(scale, body)
        out = d.sum(axis=-1) / np.maximum(common, 1) / scale / np.sqrt(
            np.diff(frames).astype(float))
    # inf: a distance beyond floating point (a wild coordinate) is a jump too
    return np.where((common >= MIN_COMMON_JOINTS) & (scale > 0) & ~np.isnan(out), out, np.nan)


def body_extent(poses):
    """The median extent (:func:`step_distances`' unit) of a track's rows with every
    joint observed; when no row is complete, :func:`pair_extent`; NaN when
    neither has anything to read.

    Examples
    --------
    >>> a = np.zeros((14, 2)); a[:, 1] = np.arange(14.0)
    >>> b = a.copy(); b[3] = np.nan
    >>> float(body_extent(np.stack([a, b]))), bool(np.isnan(body_extent(b[None])))
    (13.0, True)
    """
    full = np.isfinite(poses).all(axis=(-2, -1))
    return float(np.median(_extents(poses[full]))) if full.any() else pair_extent(poses)


#: rows two joints must be seen together in for :func:`pair_extent` to read
#: their distance (a median of three or more is not moved by one wild row)
PAIR_MIN_ROWS = 3


def pair_extent(poses):
    """A track's extent read without a complete row: the largest median distance
    between two joints over the rows that show both (at least
    :data:`PAIR_MIN_ROWS` of them).

    Joints seen in different rows are never compared, so a person who walks
    while showing different joints is not stretched by the walk; the extent
    is at most the body's (the diagonal of its bounding box bounds every
    distance within it).

    Parameters
    ----------
    poses : ndarray (T, N, 2)
        One track's rows; NaN where a joint is not observed.

    Returns
    -------
    float
        The extent, NaN when no two joints are seen together often enough.

    Examples
    --------
    Head and ankle never in one row, a hip with each of them:

    >>> pose = np.array([[0.0, 0.0], [0.0, 6.0], [0.0, 10.0]])   # head, hip, ankle
    >>> rows = np.repeat(pose[None], 6, axis=0); rows[:3, 2] = np.nan; rows[3:, 0] = np.nan
    >>> rows[3:] += [50.0, 0.0]                                   # walked meanwhile
    >>> pair_extent(rows)
    6.0
    """
    seen = np.isfinite(poses).all(axis=-1)
    i, k = np.triu_indices(poses.shape[1], 1)
    both = seen[:, i] & seen[:, k]
    enough = both.sum(axis=0) >= PAIR_MIN_ROWS
    if not enough.any():
        return float("nan")
    with np.errstate(all="ignore"):  # a wild coordinate overflows: inf, outvoted
        d = np.linalg.norm(poses[:, i[enough]] - poses[:, k[enough]], axis=-1)
    # every pair at once, each over the rows that show both (NaN elsewhere)
    return float(np.nanmax(np.nanmedian(np.where(both[:, enough], d, np.nan), axis=0)))


def split_at_jumps(layout, poses, missing, max_distance=MAX_LINK_DISTANCE):
    """The track layout with every segment cut where its pose jumps.

    Parameters
    ----------
    layout : TrackLayout
        From :func:`sparseedm.temporal.tracks.split_tracks`.
    poses : ndarray (n, N, 2)
        Every row's pose (rows with a non-finite coordinate are not judged).
    missing : ndarray of bool (n, N)
    max_distance : float
        :data:`MAX_LINK_DISTANCE`: a step further than linking would join
        (:func:`step_distances`) cuts the segment (the video protocols'
        sequences step at most 0.15; the unit is at least the segment's body
        extent, :func:`body_extent`). A segment whose median step is above
        :data:`MAX_MEDIAN_STEP` is cut at every row.

    Returns
    -------
    TrackLayout
        The same rows; a row cut off on both sides is answered alone, with
        :data:`JUMP_REASON`.
    """
    posed = np.where(missing[..., None], np.nan, poses)
    segments, offsets = [], []
    alone, reason = layout.alone.copy(), layout.reason.astype(object)
    for rows, off in zip(layout.segments, layout.offsets):
        steps = step_distances(posed[rows], off, body_extent(posed[rows]))
        judged = steps[np.isfinite(steps)]
        if len(judged) and np.median(judged) > MAX_MEDIAN_STEP:
            steps[:] = np.inf  # not a video: every row on its own
        with np.errstate(invalid="ignore"):
            cuts = np.flatnonzero(steps > max_distance) + 1
        for part, part_off in zip(np.split(rows, cuts), np.split(off, cuts)):
            if len(part) == 1:
                alone[part], reason[part] = True, JUMP_REASON
            else:
                segments.append(part)
                offsets.append(part_off - part_off[0])
    return replace(layout, segments=segments, offsets=offsets, alone=alone,
                   reason=reason.astype(str))
