"""Euclidean distance matrices (EDMs) of poses and their upper-triangle vectors.

A pose of N joints in d dimensions (d = 2 or 3) has the N x N EDM
``E[i, j] = ||p_i - p_j||`` (distances, not squared). Since E is symmetric with
a zero diagonal, it is kept as the vector T of its N(N-1)/2 upper-triangle
entries in **row-major order over i < j**: (0,1), (0,2), ..., (0,N-1), (1,2), ...
This is the order of ``numpy.triu_indices(N, 1)`` and of
``scipy.spatial.distance.squareform``.

Every function works on a batch: leading axes are batch axes, no Python loop
runs per pose.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .exceptions import PoseError

__all__ = [
    "pose_to_edm",
    "edm_to_vector",
    "vector_to_edm",
    "pose_to_vector",
    "num_joints_from_dim",
    "triu_indices",
    "observed_entries",
]


@lru_cache(maxsize=32)
def triu_indices(n_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column indices of the upper triangle (i < j), row-major.

    Parameters
    ----------
    n_joints : int
        Joint count N.

    Returns
    -------
    rows, cols : ndarray
        Read-only index arrays of length N(N-1)/2.

    Examples
    --------
    >>> rows, cols = triu_indices(4)
    >>> list(zip(rows.tolist(), cols.tolist()))
    [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    """
    rows, cols = np.triu_indices(n_joints, 1)
    rows.setflags(write=False)
    cols.setflags(write=False)
    return rows, cols


def num_joints_from_dim(n_features: int) -> int:
    """N such that N(N-1)/2 == n_features (clear error otherwise).

    Parameters
    ----------
    n_features : int
        Length of an EDM vector.

    Returns
    -------
    int
        The joint count N.

    Examples
    --------
    >>> num_joints_from_dim(91)
    14
    """
    n = int(round((1 + np.sqrt(1 + 8 * n_features)) / 2))
    if n * (n - 1) // 2 != n_features or n < 2:
        raise PoseError(
            f"{n_features} is not N(N-1)/2 for any joint count N; an EDM "
            "vector must have 3, 6, 10, ..., 91 (N=14), ... entries"
        )
    return n


def _check_poses(poses, name="poses") -> np.ndarray:
    poses = np.asarray(poses, dtype=float)
    if poses.ndim < 2 or poses.shape[-1] not in (2, 3):
        raise PoseError(
            f"{name} must have shape (..., N, 2) or (..., N, 3), got {poses.shape}"
        )
    if poses.shape[-2] < 3:
        raise PoseError(f"{name} must have at least 3 joints, got {poses.shape[-2]}")
    return poses


def pose_to_edm(poses) -> np.ndarray:
    """EDM of each pose.

    Parameters
    ----------
    poses : array_like, shape (..., N, d)
        Joint coordinates, d = 2 or 3, N >= 3.

    Returns
    -------
    edm : ndarray, shape (..., N, N)
        ``edm[..., i, j] = ||poses[..., i, :] - poses[..., j, :]||``; symmetric
        with an exact zero diagonal.

    Examples
    --------
    >>> pose_to_edm([[0, 0], [3, 0], [3, 4]])
    array([[0., 3., 5.],
           [3., 0., 4.],
           [5., 4., 0.]])
    """
    poses = _check_poses(poses)
    diff = poses[..., :, None, :] - poses[..., None, :, :]
    return np.sqrt(np.einsum("...ijk,...ijk->...ij", diff, diff))


def edm_to_vector(edm) -> np.ndarray:
    """Upper-triangle vector T of each EDM (row-major over i < j).

    Parameters
    ----------
    edm : array_like, shape (..., N, N)
        Euclidean distance matrices.

    Returns
    -------
    ndarray, shape (..., N(N-1)/2)
        Their upper triangles, row by row.

    Examples
    --------
    >>> edm_to_vector(pose_to_edm([[0, 0], [3, 0], [3, 4]]))
    array([3., 5., 4.])
    """
    edm = np.asarray(edm, dtype=float)
    if edm.ndim < 2 or edm.shape[-1] != edm.shape[-2]:
        raise PoseError(f"an EDM must have shape (..., N, N), got {edm.shape}")
    rows, cols = triu_indices(edm.shape[-1])
    return edm[..., rows, cols]


def vector_to_edm(vectors) -> np.ndarray:
    """Symmetric EDM with zero diagonal from upper-triangle vectors.

    Parameters
    ----------
    vectors : array_like, shape (..., N(N-1)/2)
        Upper-triangle vectors.

    Returns
    -------
    ndarray, shape (..., N, N)
        The matrices.

    Examples
    --------
    >>> vector_to_edm([3.0, 5.0, 4.0])
    array([[0., 3., 5.],
           [3., 0., 4.],
           [5., 4., 0.]])
    """
    vectors = np.asarray(vectors, dtype=float)
    if vectors.ndim < 1:
        raise PoseError("an EDM vector needs at least one axis")
    n = num_joints_from_dim(vectors.shape[-1])
    rows, cols = triu_indices(n)
    edm = np.zeros(vectors.shape[:-1] + (n, n))
    edm[..., rows, cols] = vectors
    edm[..., cols, rows] = vectors
    return edm


def pose_to_vector(poses) -> np.ndarray:
    """Shortcut for ``edm_to_vector(pose_to_edm(poses))`` without the full EDM.

    Parameters
    ----------
    poses : array_like, shape (..., N, dim)
        Joint coordinates.

    Returns
    -------
    ndarray, shape (..., N(N-1)/2)
        Each pose's pairwise joint distances, row-major over i < j.

    Examples
    --------
    >>> pose_to_vector([[0, 0], [3, 0], [3, 4]])
    array([3., 5., 4.])
    """
    poses = _check_poses(poses)
    rows, cols = triu_indices(poses.shape[-2])
    diff = poses[..., rows, :] - poses[..., cols, :]
    return np.sqrt(np.einsum("...k,...k->...", diff, diff))


def observed_entries(missing) -> np.ndarray:
    """Which EDM-vector entries touch no missing joint.

    Parameters
    ----------
    missing : array_like of bool, shape (..., N)
        True where a joint is occluded.

    Returns
    -------
    observed : ndarray of bool, shape (..., N(N-1)/2)
        True for entry (i, j) when neither joint i nor joint j is missing.

    Examples
    --------
    >>> observed_entries([False, False, True]).tolist()
    [True, False, False]
    """
    missing = np.asarray(missing, dtype=bool)
    rows, cols = triu_indices(missing.shape[-1])
    return ~(missing[..., rows] | missing[..., cols])
