"""Video occlusion protocols: which joints of a clip are hidden, frame by frame.

Two protocols make the (T, N) ``missing`` masks the video evaluation
(:mod:`sparseedm.temporal.evaluation`) hides and scores:

**A. Contiguous gaps** (:func:`gap_mask`): gaps of one length (3, 10, 30 or
90 frames in the evaluation, :data:`GAP_LENGTHS`) on 1-3 joints at a time,
placed at seeded random frames until a fraction of the joint-frames
(:data:`GAP_FRACTION`, 17 %) is hidden. A fifth of the gaps are put at a clip
end (the others may touch one by chance); two gaps of one joint never touch,
so every run is exactly the requested length; no frame loses more than
`max_missing` joints, and every joint keeps at least one observed frame.

**B. Self-occlusion** (:func:`self_occlusion_mask`, :func:`dropout_mask`): a
limb joint (head top, elbows, wrists, knees, ankles) is hidden while it is
behind the torso as seen from the camera, from the clip's 3D joints and its
camera. The torso is the quadrilateral of the shoulders and hips; a joint is
behind it when

1. its image point falls inside the torso's image (the convex hull of the
   four projected corners), grown by `margin` metres at the torso's depth, and
2. along the camera ray through the joint, the joint lies more than
   `depth_margin` metres beyond the torso's plane (the plane through the
   torso's centroid whose normal is the cross product of its diagonals).

Short dropouts (runs of 1-5 frames on random joints, :data:`DROPOUT_FRACTION`
= 5 % of the joint-frames) are added on top, as a detector's misses.

**Runs.** Results are reported per *run*: a maximal stretch of consecutive
missing frames of one joint. :func:`run_lengths` gives each missing
joint-frame its run's length and whether the run touches a clip end (its
first or last frame); :func:`run_bin` puts lengths into :data:`RUN_BINS`
(1-5, 6-15, 16-45, 46+ frames: the four gap lengths fall one in each).

Examples
--------
>>> m = gap_mask(40, 10, random_state=0)
>>> lengths, at_end = run_lengths(m)
>>> sorted(set(lengths[m].tolist()))
[10]
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np

from .._validation import Interval, validate_params
from ..exceptions import PoseError
from ..skeleton import SKELETON_14

__all__ = ["GAP_LENGTHS", "GAP_FRACTION", "DROPOUT_FRACTION", "RUN_BINS", "LIMB_JOINTS",
           "TORSO_CORNERS", "gap_mask", "self_occlusion_mask", "dropout_mask",
           "run_lengths", "run_bin"]

#: Protocol A's gap lengths, frames
GAP_LENGTHS = (3, 10, 30, 90)
#: Protocol A hides this fraction of a clip's joint-frames per gap length
GAP_FRACTION = 0.17
#: Protocol B adds short dropouts on this fraction of the joint-frames
DROPOUT_FRACTION = 0.05
#: run-length bins (first, last frame count; None: no upper end) and their labels
RUN_BINS = ((1, 5, "1-5"), (6, 15, "6-15"), (16, 45, "16-45"), (46, None, "46+"))
#: the torso's corners (right shoulder, left shoulder, left hip, right hip)
TORSO_CORNERS = tuple(SKELETON_14.index(n) for n in (
    "right_shoulder", "left_shoulder", "left_hip", "right_hip"))
#: joints Protocol B may hide behind the torso
LIMB_JOINTS = tuple(SKELETON_14.index(n) for n in (
    "head_top", "right_elbow", "right_wrist", "left_elbow", "left_wrist",
    "right_knee", "right_ankle", "left_knee", "left_ankle"))


def gap_mask(n_frames, length, *, n_joints=14, fraction=GAP_FRACTION, joints_per_gap=(1, 2, 3),
             end_fraction=0.2, max_missing=7, random_state=None):
    """Protocol A: seeded contiguous gaps of one length.

    Parameters
    ----------
    n_frames : int
        Frames T of the clip.
    length : int
        Every gap's length, frames. A clip of ``length`` frames or fewer
        gets no gap (the joint would never be observed).
    n_joints : int, default 14
    fraction : float, default 0.17
        Gaps are added until at least this fraction of the joint-frames is
        hidden (or no more fit).
    joints_per_gap : sequence of int, default (1, 2, 3)
        Each gap hides this many joints (drawn uniformly from the sequence)
        over the same frames.
    end_fraction : float, default 0.2
        Probability that a gap is placed at a clip end (start or end, evenly).
    max_missing : int, default 7
        No frame loses more joints than this.
    random_state : int or numpy.random.Generator, optional

    Returns
    -------
    ndarray of bool (T, n_joints)

    Examples
    --------
    >>> m = gap_mask(100, 30, random_state=1)
    >>> bool(m.mean() >= 0.17), int(m.sum(axis=1).max()) <= 7
    (True, True)
    >>> gap_mask(20, 30, random_state=1).any()
    np.False_
    """
    validate_params("gap_mask", dict(n_frames=n_frames, length=length, fraction=fraction,
                                     end_fraction=end_fraction, max_missing=max_missing), {
        "n_frames": [Interval(Integral, 1, None)], "length": [Interval(Integral, 1, None)],
        "fraction": [Interval(Real, 0, 1)], "end_fraction": [Interval(Real, 0, 1)],
        "max_missing": [Interval(Integral, 1, None)]})
    rng = np.random.default_rng(random_state)
    T, L = int(n_frames), int(length)
    missing = np.zeros((T, n_joints), bool)
    if L >= T:
        return missing
    target = fraction * T * n_joints
    for _ in range(200 + 20 * int(np.ceil(target / L))):
        if missing.sum() >= target:
            break
        joints = rng.choice(n_joints, int(rng.choice(joints_per_gap)), replace=False)
        if rng.random() < end_fraction:
            start = 0 if rng.random() < 0.5 else T - L
        else:
            start = int(rng.integers(0, T - L + 1))
        near = missing[max(start - 1, 0):start + L + 1][:, joints]
        if near.any() or (missing[start:start + L].sum(axis=1) + joints.size > max_missing).any():
            continue
        missing[start:start + L, joints] = True
    return missing


def dropout_mask(n_frames, n_joints=14, *, fraction=DROPOUT_FRACTION, max_length=5,
                 random_state=None):
    """Short seeded dropouts: runs of 1..`max_length` frames on random joints.

    Runs are added (uniform length, joint and start) until `fraction` of the
    joint-frames is hidden; they may touch or overlap one another.

    Parameters
    ----------
    n_frames : int
        Frames of the clip.
    n_joints : int, default 14
        Joints per pose.
    fraction : float, optional
        Share of the joint-frames to hide (default :data:`DROPOUT_FRACTION`).
    max_length : int, default 5
        Longest run, in frames.
    random_state : int or numpy.random.Generator, optional
        Seed or generator of the runs.

    Returns
    -------
    ndarray of bool (n_frames, n_joints)
        True at the hidden joint-frames.

    Examples
    --------
    >>> m = dropout_mask(200, random_state=0)
    >>> round(float(m.mean()), 2)
    0.05
    >>> int(run_lengths(m)[0].max()) <= 10
    True
    """
    rng = np.random.default_rng(random_state)
    T = int(n_frames)
    missing = np.zeros((T, n_joints), bool)
    target = fraction * T * n_joints
    for _ in range(100 + int(4 * target)):
        if missing.sum() >= target:
            break
        length = int(rng.integers(1, max_length + 1))
        start = int(rng.integers(0, max(T - length, 0) + 1))
        missing[start:start + length, int(rng.integers(n_joints))] = True
    return missing


def self_occlusion_mask(poses3d, R, t, f, c=None, *, margin=0.05, depth_margin=0.05):
    """Protocol B's geometric rule: limb joints behind the torso from the camera.

    Parameters
    ----------
    poses3d : array_like (T, 14, 3)
        World joint positions, metres.
    R : array_like (3, 3)
        World -> camera rotation (``x_cam = R @ X + t``, z forward; as
        :class:`sparseedm.cameras.Cameras`).
    t : array_like (3,)
    f : float
        Focal length, pixels.
    c : array_like (2,), optional
        Principal point; it does not change the answer (kept for symmetry
        with the cameras' arrays).
    margin : float, default 0.05
        The torso's image is grown by this many metres (at the torso
        centroid's depth): the body's surface lies outside its joint centres.
    depth_margin : float, default 0.05
        A joint must lie this far beyond the torso plane along its camera ray.

    Returns
    -------
    ndarray of bool (T, 14)
        True for a limb joint (:data:`LIMB_JOINTS`) behind the torso.

    Examples
    --------
    A camera 4 m in front of a standing torso (looking along -z from +z): a
    wrist 0.3 m behind the chest is hidden, the same wrist 0.3 m in front is not.

    >>> from sparseedm.cameras import look_at
    >>> pose = np.zeros((2, 14, 3))
    >>> pose[:, [2, 5, 11, 8]] = [[-0.2, 1.4, 0], [0.2, 1.4, 0], [0.15, 0.9, 0], [-0.15, 0.9, 0]]
    >>> pose[:, [0, 3, 6, 9, 10, 12, 13]] = [0.0, 5.0, 0.0]  # out of the way, above
    >>> pose[0, 4] = [0.0, 1.2, -0.3]; pose[1, 4] = [0.0, 1.2, 0.3]
    >>> pose[:, 7] = [0.6, 1.0, 0.0]                        # beside the body
    >>> eye = np.array([0.0, 1.2, 4.0])
    >>> R = look_at(eye, [0.0, 1.2, 0.0])[0]
    >>> hidden = self_occlusion_mask(pose, R, -R @ eye, 1000.0)
    >>> hidden[:, 4].tolist(), hidden[:, 7].tolist()
    ([True, False], [False, False])
    """
    X = np.asarray(poses3d, dtype=float)
    if X.ndim != 3 or X.shape[1:] != (14, 3):
        raise PoseError(f"poses3d must have shape (T, 14, 3), got {X.shape}")
    cam = np.einsum("ij,tkj->tki", np.asarray(R, float), X) + np.asarray(t, float)
    if np.any(cam[..., 2] <= 1e-9):
        raise PoseError("a joint is at or behind the camera")
    uv = float(f) * cam[..., :2] / cam[..., 2:3]
    corners = cam[:, TORSO_CORNERS]                      # (T, 4, 3): rs, ls, lh, rh
    centroid = corners.mean(axis=1)
    normal = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
    limbs = cam[:, LIMB_JOINTS]                          # (T, K, 3): rays from the camera
    along = np.einsum("ti,tki->tk", normal, limbs)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.einsum("ti,ti->t", normal, centroid)[:, None] / along  # plane at s * ray
    beyond = (1.0 - s) * np.linalg.norm(limbs, axis=-1)
    behind = np.isfinite(s) & (s > 0) & (beyond > depth_margin)
    grow = float(f) * margin / centroid[:, 2]
    inside = _distance_to_hull(uv[:, TORSO_CORNERS], uv[:, LIMB_JOINTS]) <= grow[:, None]
    hidden = np.zeros(X.shape[:2], bool)
    hidden[:, LIMB_JOINTS] = behind & inside
    return hidden


def _distance_to_hull(quad, points):
    """Distance of `points` (T, K, 2) to the convex hull of `quad` (T, 4, 2), 0 inside.

    The hull of four points is the union of the four triangles of three of
    them; outside it, the nearest hull point lies on one of the six segments
    between two of them.
    """
    inside = np.zeros(points.shape[:2], bool)
    for a, b, c in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        inside |= _in_triangle(points, quad[:, a, None], quad[:, b, None], quad[:, c, None])
    dist = np.full(points.shape[:2], np.inf)
    for a in range(4):
        for b in range(a + 1, 4):
            dist = np.minimum(dist, _to_segment(points, quad[:, a, None], quad[:, b, None]))
    return np.where(inside, 0.0, dist)


def _cross2(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _in_triangle(p, a, b, c):
    d1, d2, d3 = _cross2(b - a, p - a), _cross2(c - b, p - b), _cross2(a - c, p - c)
    neg = (d1 < 0) | (d2 < 0) | (d3 < 0)
    pos = (d1 > 0) | (d2 > 0) | (d3 > 0)
    return ~(neg & pos)


def _to_segment(p, a, b):
    ab = b - a
    denom = np.maximum(np.sum(ab * ab, axis=-1), 1e-12)
    u = np.clip(np.sum((p - a) * ab, axis=-1) / denom, 0.0, 1.0)
    return np.linalg.norm(p - (a + u[..., None] * ab), axis=-1)


def run_lengths(missing):
    """Each missing joint-frame's run length, and whether its run touches a clip end.

    Parameters
    ----------
    missing : array_like of bool (T, N)

    Returns
    -------
    lengths : ndarray of int (T, N)
        The length of the run (maximal consecutive missing frames of the
        joint) the joint-frame belongs to; 0 where observed.
    at_end : ndarray of bool (T, N)
        True where that run includes the clip's first or last frame.

    Examples
    --------
    >>> m = np.array([[1, 0], [1, 0], [0, 1], [1, 1], [0, 0]], bool)
    >>> lengths, at_end = run_lengths(m)
    >>> lengths.T.tolist(), at_end.T.tolist()
    ([[2, 2, 0, 1, 0], [0, 0, 2, 2, 0]], [[True, True, False, False, False], [False, False, False, False, False]])
    """
    m = np.asarray(missing, dtype=bool)
    T = m.shape[0]
    lengths = np.zeros(m.shape, int)
    at_end = np.zeros(m.shape, bool)
    for j in range(m.shape[1]):
        edges = np.diff(np.concatenate([[0], m[:, j].astype(np.int8), [0]]))
        for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            lengths[start:stop, j] = stop - start
            at_end[start:stop, j] = start == 0 or stop == T
    return lengths, at_end


def run_bin(lengths):
    """The :data:`RUN_BINS` label of each run length (``""`` for 0).

    Parameters
    ----------
    lengths : array_like of int
        Run lengths, in frames.

    Returns
    -------
    ndarray of str
        The bin label of each length, same shape as `lengths`.

    Examples
    --------
    >>> run_bin([0, 1, 5, 6, 15, 16, 45, 46, 300]).tolist()
    ['', '1-5', '1-5', '6-15', '6-15', '16-45', '16-45', '46+', '46+']
    """
    lengths = np.asarray(lengths)
    out = np.full(lengths.shape, "", dtype="<U8")
    for low, high, label in RUN_BINS:
        out[(lengths >= low) & ((lengths <= high) if high is not None else True)] = label
    return out
