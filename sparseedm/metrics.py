"""The paper's evaluation protocol and metrics, as pure functions.

* :func:`random_occlusion` draws the seeded occlusion of 1, 2 or 3 joints per
  pose, or their Mix (each pose draws its count uniformly from 1..3).
* :func:`err_ave` is the paper's Err_ave: the mean over the N^2 - N
  off-diagonal entries of ``|E_f - E_gt| / E_gt * 100``.
* :func:`joint_error` is the per-joint Euclidean error of recovered
  coordinates, in the pose's own units (pixels for image keypoints).
* :func:`occlusion_masks` gives the evaluation protocol's seeded masks, one
  array per count (:mod:`sparseedm.evaluation` re-exports it; it lives here so
  that adaptation's guard uses the protocol without importing the evaluation
  above it).
"""

from __future__ import annotations

import numpy as np

from .edm import num_joints_from_dim
from .exceptions import PoseError, SparseEDMError

__all__ = ["OCCLUSION_COUNTS", "random_occlusion", "occlusion_masks", "check_counts", "err_ave",
           "err_entries", "joint_error"]

#: The protocol's settings: 1, 2, 3 occluded joints and their Mix.
OCCLUSION_COUNTS = (1, 2, 3, "mix")


def random_occlusion(n_poses, n_joints=14, n_occluded=1, random_state=None):
    """Seeded random occlusion masks.

    Parameters
    ----------
    n_poses : int
        Poses (rows) of the mask.
    n_joints : int, default 14
        Joints per pose.
    n_occluded : {1, 2, 3, ..., "mix"}
        Joints occluded per pose; ``"mix"`` draws 1, 2 or 3 uniformly per pose.
    random_state : int, numpy.random.Generator or None
        Seed or generator; None: unseeded.

    Returns
    -------
    missing : ndarray of bool, shape (n_poses, n_joints)
        Exactly the requested number of True per row; the same seed gives
        the same masks.

    Examples
    --------
    >>> m = random_occlusion(4, 14, 2, random_state=0)
    >>> m.shape, m.sum(axis=1).tolist()
    ((4, 14), [2, 2, 2, 2])
    >>> bool((m == random_occlusion(4, 14, 2, random_state=0)).all())
    True
    """
    rng = np.random.default_rng(random_state)
    if n_occluded == "mix":
        if n_joints < 6:
            raise ValueError(f"'mix' occludes up to 3 joints: needs n_joints >= 6, got {n_joints}")
        counts = rng.integers(1, 4, size=n_poses)
    else:
        k = int(n_occluded)
        if not 0 <= k <= n_joints - 3:
            raise ValueError(
                f"n_occluded={n_occluded!r}: must leave at least 3 of "
                f"{n_joints} joints observed"
            )
        counts = np.full(n_poses, k)
    # Rank random keys per pose: the `count` smallest keys are occluded.
    keys = rng.random((n_poses, n_joints))
    ranks = keys.argsort(axis=1).argsort(axis=1)
    return ranks < counts[:, None]


def _as_vectors(vectors):
    vectors = np.asarray(vectors, dtype=float)
    if vectors.ndim < 1:
        raise PoseError("EDM vectors need at least one axis")
    num_joints_from_dim(vectors.shape[-1])
    return vectors


def err_entries(edm_f, edm_gt):
    """Per-entry relative error ``|E_f - E_gt| / E_gt * 100``.

    Takes upper-triangle EDM vectors (..., N(N-1)/2) (pass full EDMs through
    :func:`sparseedm.edm.edm_to_vector` first: a square array is never
    guessed to be a matrix) and returns the per-entry errors; entries whose
    ground truth is 0 (coincident joints) are NaN, as the ratio is undefined.

    Parameters
    ----------
    edm_f : array_like (..., N(N-1)/2)
        Completed (or recovered) EDM vectors.
    edm_gt : array_like (..., N(N-1)/2)
        Ground-truth EDM vectors, same shape.

    Returns
    -------
    ndarray (..., N(N-1)/2)
        Per-entry relative errors, per cent; NaN where the ground truth is 0.

    Raises
    ------
    PoseError
        If the shapes differ.
    """
    f = _as_vectors(edm_f)
    gt = _as_vectors(edm_gt)
    if f.shape != gt.shape:
        raise PoseError(f"EDM shapes differ: {f.shape} vs {gt.shape}")
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.abs(f - gt) / gt * 100.0
    return np.where(gt > 0, out, np.nan)


def err_ave(edm_f, edm_gt):
    """The paper's Err_ave per pose, in per cent.

    The mean over the N^2 - N off-diagonal entries equals the mean over the
    upper triangle, since both EDMs are symmetric. Entries with a zero ground
    truth distance are left out of the mean.

    Parameters
    ----------
    edm_f : array_like (..., N(N-1)/2)
        Completed (or recovered) EDM vectors.
    edm_gt : array_like (..., N(N-1)/2)
        Ground-truth EDM vectors, same shape.

    Returns
    -------
    ndarray (...)
        Err_ave of each pose, per cent.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.array([3.0, 5.0, 4.0])
    >>> float(err_ave([3.0, 5.5, 4.0], gt))  # one entry 10 % off, of 3
    3.3333333333333335
    """
    return np.nanmean(err_entries(edm_f, edm_gt), axis=-1)


def joint_error(poses_f, poses_gt, missing=None):
    """Euclidean error of each joint, in the poses' own units.

    Parameters
    ----------
    poses_f : array_like, shape (..., N, d)
        The filled (or recovered) poses.
    poses_gt : array_like, shape (..., N, d)
        The ground-truth poses, same shape.
    missing : array_like of bool, shape (..., N), optional
        If given, errors of joints that were not missing are NaN, so that
        ``np.nanmean`` averages over the recovered joints only.

    Returns
    -------
    error : ndarray, shape (..., N)
        Distance of each joint to its ground truth.

    Examples
    --------
    >>> joint_error([[0., 0.], [3., 4.]], [[0., 0.], [0., 0.]]).tolist()
    [0.0, 5.0]
    """
    f = np.asarray(poses_f, dtype=float)
    gt = np.asarray(poses_gt, dtype=float)
    if f.shape != gt.shape:
        raise PoseError(f"pose shapes differ: {f.shape} vs {gt.shape}")
    err = np.linalg.norm(f - gt, axis=-1)
    if missing is not None:
        err = np.where(np.asarray(missing, dtype=bool), err, np.nan)
    return err


#: each count's seed key in the protocol's masks (:func:`occlusion_masks`)
_COUNT_KEYS = {1: 1, 2: 2, 3: 3, "mix": 0}


def check_counts(counts):
    """The occlusion counts as the protocol keys them (1, 2, 3, "mix"); unknown ones raise.

    Parameters
    ----------
    counts : iterable of int or str
        Occlusion counts: 1, 2, 3 or ``"mix"`` (strings such as ``"2"`` or
        ``"MIX"`` too).

    Returns
    -------
    tuple
        The counts as ints 1-3 and ``"mix"``, in the order given.

    Raises
    ------
    SparseEDMError
        If a count is none of those.
    """
    out = []
    for c in counts:
        c = str(c).lower()
        if c == "mix":
            out.append("mix")
        elif c in ("1", "2", "3"):
            out.append(int(c))
        else:
            raise SparseEDMError(f"unknown occlusion count {c!r}; use 1, 2, 3 or mix")
    return tuple(out)


def occlusion_masks(n_poses, n_joints, counts=(1, 2, 3, "mix"), random_state=0):
    """The protocol's seeded masks, one (n_poses, n_joints) array per count.

    Each count's seed is ``(random_state, count)``: the same masks whatever
    other counts or methods are run.

    Parameters
    ----------
    n_poses : int
        Poses (rows) per mask.
    n_joints : int
        Joints per pose.
    counts : iterable of {1, 2, 3, "mix"}
        The occlusion counts, as :func:`check_counts` reads them.
    random_state : int or None, default 0
        The protocol's seed; None: unseeded.

    Returns
    -------
    dict
        ``{count: ndarray of bool (n_poses, n_joints)}``.

    Raises
    ------
    SparseEDMError
        If a count is unknown.

    Examples
    --------
    >>> m = occlusion_masks(5, 14, (2, "mix"), random_state=0)
    >>> m[2].sum(axis=1).tolist()
    [2, 2, 2, 2, 2]
    >>> bool((m["mix"] == occlusion_masks(5, 14, ("mix",), 0)["mix"]).all())
    True
    """
    out = {}
    for c in check_counts(counts):
        seed = None if random_state is None else np.random.SeedSequence(
            [int(random_state), _COUNT_KEYS[c]])
        out[c] = random_occlusion(n_poses, n_joints, c, random_state=np.random.default_rng(seed))
    return out
