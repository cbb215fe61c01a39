"""Rows to tracks: which poses are one person over time, in frame order.

:func:`split_tracks` reads the ``tracks`` and ``frames`` a caller gives with
its poses and cuts the rows into *segments*: the rows of one track in frame
order, broken where more than :data:`MAX_SKIP` frame numbers are absent
(nothing couples a pose to one seen seconds later). Rows that cannot join a
segment are not dropped: they are recovered frame by frame, each with a
reason (a frame number that is NaN, not a number, not an integer or over
2**53 in magnitude; a (track, frame) pair given more than once; a segment of
one row).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import MAX_FRAME, frame_numbers
from ..exceptions import ParameterError

__all__ = ["MAX_SKIP", "MAX_FRAME", "TrackLayout", "split_tracks", "frame_numbers",
           "distance_to_observed", "track_chunks", "track_windows", "WINDOW_OVERLAP",
           "add_summaries", "has_time"]

#: a run of more absent frame numbers than this ends a segment
MAX_SKIP = 30
_DUPLICATE = "its (track, frame) pair is given more than once"
#: frames of context a window of a long track (:func:`track_windows`) is
#: solved with on either side of its own frames: ten times the temporal
#: model's longest reach into a gap (its prior ramp, 30 frames), more than
#: :data:`MAX_SKIP`, so each of its rows falls in the same stretch of frames
#: as in the whole track
WINDOW_OVERLAP = 300


@dataclass
class TrackLayout:
    """How the rows fall into segments.

    Parameters
    ----------
    segments : list of ndarray of int
        Row indices of each segment, in frame order.
    offsets : list of ndarray of int
        Each segment's frame numbers minus its first (0 .. T-1).
    alone : ndarray of bool (n,)
        Rows recovered frame by frame, outside any segment.
    reason : ndarray of str (n,)
        Why a row is alone (``""`` for rows in a segment).
    order : ndarray of int (n,)
        Every row, by track and frame (rows without a usable frame number
        after those of their track): an order that does not depend on the
        order the rows were given in, for what samples from them.
    linked : ndarray of int (n,) or None
        The track ids :func:`sparseedm.temporal.linking.link_tracks` gave
        rows that came without any (None when the caller's tracks were used).
    frames : ndarray of float (n,) or None
        Each row's frame number as :func:`frame_numbers` read it; NaN where
        it refused the number (what later steps use instead of reading them again).
    """

    segments: list
    offsets: list
    alone: np.ndarray
    reason: np.ndarray
    order: np.ndarray = None
    linked: np.ndarray = None
    frames: np.ndarray = None



def has_time(frames):
    """Whether `frames` (or None) hold at least two distinct usable frame
    numbers: a file whose poses all share one frame (a single image, as
    MMPose's image mode and COCO files give) is not a video.

    Parameters
    ----------
    frames : array_like or None
        Frame numbers, one per pose.

    Returns
    -------
    bool
        True when they describe a video.

    Examples
    --------
    >>> has_time([0, 0, 0]), has_time([0, 1, "x"]), has_time(None)
    (False, True, False)
    """
    if frames is None:
        return False
    values, reason = frame_numbers(frames, len(np.asarray(frames)))
    return len(np.unique(values[reason == ""])) >= 2


def _track_ids(tracks, n):
    """Integer ids (n,) of the caller's track values (all 0 when None)."""
    if tracks is None:
        return np.zeros(n, dtype=np.int64)
    arr = np.asarray(tracks)
    if arr.shape != (n,):
        raise ParameterError(f"tracks must have shape ({n},) (one per pose), got {arr.shape}")
    try:
        _, ids = np.unique(arr, return_inverse=True)
    except TypeError:  # mixed kinds (e.g. numbers and strings): compare as text
        _, ids = np.unique(arr.astype(str), return_inverse=True)
    return ids.reshape(n)


def split_tracks(n, tracks, frames):
    """Cut n rows into frame-ordered segments of one track each.

    Parameters
    ----------
    n : int
        Rows.
    tracks : array_like (n,) or None
        Person of each row (any values; None: all one track).
    frames : array_like (n,)
        Frame number of each row: integers, in any order, gaps allowed.

    Returns
    -------
    TrackLayout

    Examples
    --------
    >>> lay = split_tracks(5, ["a", "b", "a", "b", "a"], [2, 0, 1, 1, 2.5])
    >>> [s.tolist() for s in lay.segments], str(lay.reason[4])
    ([[2, 0], [1, 3]], 'frame number 2.5 is not an integer')
    """
    values, reason = frame_numbers(frames, n)
    read = np.where(reason == "", values, np.nan)
    ids = _track_ids(tracks, n)
    good = np.flatnonzero(reason == "")
    order = good[np.lexsort((values[good], ids[good]))]
    same = (np.diff(ids[order]) == 0) & (np.diff(values[order]) == 0)
    dup = np.zeros(len(order), dtype=bool)
    dup[:-1] |= same
    dup[1:] |= same
    reason[order[dup]] = _DUPLICATE
    order = order[~dup]
    breaks = np.flatnonzero((np.diff(ids[order]) != 0)
                            | (np.diff(values[order]) > MAX_SKIP + 1)) + 1
    segments, offsets = [], []
    for rows in np.split(order, breaks):
        if len(rows) == 1:
            reason[rows] = "the only frame of its track (or of its stretch of frames)"
        elif len(rows):
            segments.append(rows)
            offsets.append(values[rows] - values[rows[0]])
    bad = reason != ""
    canonical = np.lexsort((values, bad & (reason != _DUPLICATE), ids))  # stable: then by row
    return TrackLayout(segments, offsets, bad, reason.astype(str), canonical, frames=read)


def distance_to_observed(free):
    """Frames from each frame to the nearest one where the joint is observed.

    Parameters
    ----------
    free : ndarray of bool (T, N)
        True where the joint is unknown.

    Returns
    -------
    ndarray (T, N)
        0 at observed frames; ``inf`` for a joint never observed.

    Examples
    --------
    >>> free = np.array([True, False, True, True, True, False, True])[:, None]
    >>> distance_to_observed(free)[:, 0].tolist()
    [1.0, 0.0, 1.0, 2.0, 1.0, 0.0, 1.0]
    """
    T, N = free.shape
    t = np.arange(T)
    out = np.full((T, N), np.inf)
    for j in range(N):
        obs = np.flatnonzero(~free[:, j])
        if not len(obs):
            continue
        k = np.searchsorted(obs, t)
        after = np.where(k < len(obs), obs[np.minimum(k, len(obs) - 1)] - t, np.inf)
        before = np.where(k > 0, t - obs[np.maximum(k - 1, 0)], np.inf)
        out[:, j] = np.minimum(after, before)
    return out


def track_chunks(tracks, n, chunk_size):
    """Rows of whole tracks, about `chunk_size` rows a chunk.

    Tracks are never cut; a track longer than `chunk_size` is one chunk.
    When every track's rows are contiguous in the file the chunks are
    ``(start, stop)`` ranges, cut where the rows change track; when tracks
    are interleaved (several people per frame, rows in frame order) they are
    arrays of the rows of whole tracks, in file order.

    Parameters
    ----------
    tracks : array_like (n,) or None
        Track id of each row; None: one track.
    n : int
        The number of rows.
    chunk_size : int
        Rows a chunk aims at.

    Returns
    -------
    list of tuple of int or list of ndarray of int
        ``(start, stop)`` row ranges, or arrays of rows when tracks interleave;
        empty when `n` is 0.

    Examples
    --------
    >>> track_chunks(["a", "a", "b", "b", "b", "c"], 6, 3)
    [(0, 2), (2, 5), (5, 6)]
    >>> [c.tolist() for c in track_chunks(["a", "b", "a", "b", "c", "c"], 6, 4)]
    [[0, 1, 2, 3], [4, 5]]
    """
    if n == 0:
        return []
    if tracks is None:
        return [(0, n)]
    ids = _track_ids(tracks, n)
    starts = np.flatnonzero(np.diff(ids) != 0) + 1
    if len(starts) + 1 != len(np.unique(ids)):  # a track comes back later
        return _interleaved_chunks(ids, chunk_size)
    edges = [0, *starts.tolist(), n]
    bounds, begin = [], 0
    for lo, hi in zip(edges[:-1], edges[1:]):
        if lo > begin and hi - begin > chunk_size:  # this track would overfill it
            bounds.append((begin, lo))
            begin = lo
    bounds.append((begin, n))
    return bounds


def track_windows(tracks, frames, n, chunk_size, overlap=None):
    """:func:`track_chunks`, with every track longer than `chunk_size` rows
    cut into windows, so that no chunk holds much more than `chunk_size` rows.

    A long track (one person over a long video) is cut by frame number into
    windows of about `chunk_size` rows each. A window is solved with the rows
    of `overlap` frames on either side of its own as context, and keeps only
    its own rows' answers: the temporal model reaches a few dozen frames into
    a gap, so an answer differs from the whole track's only through what is
    estimated once per stretch of frames (its joints' coupling, its noise),
    here per window. Rows whose frame number is unusable go with the first
    window, which answers them frame by frame as the whole track would.

    Parameters
    ----------
    tracks : array_like (n,) or None
    frames : array_like (n,)
        As :func:`split_tracks`.
    n, chunk_size : int
    overlap : int, optional
        Frames of context on either side of a window; default
        :data:`WINDOW_OVERLAP`.

    Returns
    -------
    list of (rows, keep)
        `rows`: a ``(start, stop)`` range or an int array of rows (file
        order), as :func:`track_chunks`; `keep`: None (keep every row's
        answer) or a bool array over `rows`, the window's own rows.

    Examples
    --------
    >>> w = track_windows(None, [5, 1, 2, 3, 4, 0], 6, 3, overlap=1)
    >>> [(r.tolist(), k.tolist()) for r, k in w]
    [([1, 2, 3, 5], [True, True, False, True]), ([0, 2, 3, 4], [True, False, True, True])]
    """
    overlap = WINDOW_OVERLAP if overlap is None else overlap
    out = []
    values, reason = frame_numbers(frames, n)
    for bounds in track_chunks(tracks, n, chunk_size):
        rows = np.arange(*bounds) if isinstance(bounds, tuple) else bounds
        if len(rows) <= chunk_size:
            out.append((bounds, None))
        else:  # one track: track_chunks overfills a chunk with a single track only
            out.extend(_windows(rows, values[rows], reason[rows] == "", chunk_size, overlap))
    return out


def _windows(rows, values, usable, chunk_size, overlap):
    """(rows, keep) windows of one track's `rows` by frame number `values`."""
    frames = np.unique(values[usable])
    k = -(-int(usable.sum()) // chunk_size)
    edges = frames[(np.arange(1, k) * len(frames)) // k]
    edges = np.concatenate([[-np.inf], edges, [np.inf]])
    out = []
    for i, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
        own = usable & (values >= lo) & (values < hi)
        near = usable & (values >= lo - overlap) & (values < hi + overlap)
        if i == 0:
            own, near = own | ~usable, near | ~usable
        out.append((rows[near], own[near]))
    return out


def _interleaved_chunks(ids, chunk_size):
    """Rows (arrays, file order) of whole tracks, packed in the order the
    tracks first appear, about `chunk_size` rows each."""
    order = np.argsort(ids, kind="stable")
    per_track = np.split(order, np.flatnonzero(np.diff(ids[order])) + 1)
    per_track.sort(key=lambda rows: rows[0])
    chunks, current, size = [], [], 0
    for rows in per_track:
        if current and size + len(rows) > chunk_size:
            chunks.append(np.sort(np.concatenate(current)))
            current, size = [], 0
        current.append(rows)
        size += len(rows)
    chunks.append(np.sort(np.concatenate(current)))
    return chunks


def add_summaries(total, part):
    """Two temporal summaries (``TemporalResult.summary()["temporal"]``) added.

    Parameters
    ----------
    total : dict or None
        The running sum (None: nothing yet).
    part : dict or None
        The summary to add (None: nothing).

    Returns
    -------
    dict or None
        Segments, per-frame poses and joint counts by source added (and the
        ``alone`` reasons when either has them).
    """
    if total is None or part is None:
        return part if total is None else total
    def added(key):
        a, b = total.get(key) or {}, part.get(key) or {}
        return {k: a.get(k, 0) + b.get(k, 0) for k in {**a, **b}}

    out = {"segments": total["segments"] + part["segments"],
           "per_frame_poses": total["per_frame_poses"] + part["per_frame_poses"],
           "joints": added("joints")}
    if "alone" in total or "alone" in part:
        out["alone"] = added("alone")
    return out
