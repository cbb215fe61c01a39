"""Seeded virtual pinhole cameras: 3D world poses -> 2D image poses.

Camera model (OpenCV convention): a world point ``X`` goes to camera
coordinates ``x = R @ X + t`` (x right, y down, z forward, ``det R = +1`` so
images are never mirrored and left stays left), then to pixels
``u = f * x / z + c_u``, ``v = f * y / z + c_v``.

:func:`sample_cameras` places each camera around a target point (the pose's
centre): the azimuth is uniform all round, the camera's horizontal distance
from the target and its height above the ground (world up coordinate 0) are
uniform in ranges, and it looks straight at the target with no roll. The
world up axis is given explicitly: ``up="y"`` for BVH and ASF/AMC data
(Y-up), ``up="z"`` for Z-up data.

Defaults: horizontal distance 3-6 m, height 0.5-2 m, focal length 1000 px,
principal point (500, 500) -- a 1000 x 1000 image.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validation import check_pose_shape
from .exceptions import PoseError

__all__ = ["Cameras", "sample_cameras", "project", "look_at"]

_UP = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class Cameras:
    """A batch of n pinhole cameras, as arrays (ready for an .npz).

    Attributes
    ----------
    R : ndarray, shape (n, 3, 3)
        World -> camera rotations.
    t : ndarray, shape (n, 3)
        World -> camera translations (``x_cam = R @ X + t``).
    f : ndarray, shape (n,)
        Focal lengths in pixels.
    c : ndarray, shape (n, 2)
        Principal points in pixels.
    """

    R: np.ndarray
    t: np.ndarray
    f: np.ndarray
    c: np.ndarray

    def __len__(self) -> int:
        return self.R.shape[0]

    @property
    def centers(self) -> np.ndarray:
        """Camera centres in world coordinates, (n, 3): ``-R^T t``."""
        return -np.einsum("nji,nj->ni", self.R, self.t)

    def __getitem__(self, index) -> "Cameras":
        index = np.atleast_1d(np.arange(len(self))[index])
        return Cameras(self.R[index], self.t[index], self.f[index], self.c[index])

    def as_dict(self, prefix="camera_") -> dict:
        """``{prefix + "R": R, ...}`` for saving in an .npz."""
        return {f"{prefix}R": self.R, f"{prefix}t": self.t,
                f"{prefix}f": self.f, f"{prefix}c": self.c}


def look_at(eye, target, up="y") -> np.ndarray:
    """World -> camera rotations of cameras at `eye` looking at `target`.

    Parameters
    ----------
    eye, target : array_like, shape (n, 3) or (3,)
    up : {"y", "z", "x"}
        The world up axis; the image's y axis points to world down.

    Returns
    -------
    R : ndarray, shape (n, 3, 3)
        Rows are the camera's x (right), y (down), z (forward) axes.

    Examples
    --------
    >>> R = look_at([0, 1, 5], [0, 1, 0], up="y")
    >>> R[0] @ [0, 1, 0]  # world up is image up (negative y)
    array([ 0., -1.,  0.])
    """
    eye = np.atleast_2d(np.asarray(eye, dtype=float))
    target = np.atleast_2d(np.asarray(target, dtype=float))
    up_vec = np.zeros(3)
    up_vec[_axis(up)] = 1.0
    fwd = target - eye
    norm = np.linalg.norm(fwd, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise ValueError("a camera sits on its target")
    fwd = fwd / norm
    right = np.cross(fwd, up_vec)
    rnorm = np.linalg.norm(right, axis=-1, keepdims=True)
    if np.any(rnorm < 1e-9):
        raise ValueError("a camera looks straight along the up axis")
    right = right / rnorm
    down = np.cross(fwd, right)
    return np.stack([right, down, fwd], axis=-2)


def _axis(up):
    try:
        return _UP[str(up).lower()]
    except KeyError:
        raise ValueError(f"up must be 'x', 'y' or 'z', got {up!r}") from None


def _uniform(rng, value, n, name):
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (2,) or arr[0] > arr[1]:
        raise ValueError(f"{name} must be a number or a (low, high) range, got {value!r}")
    return rng.uniform(arr[0], arr[1], size=n)


def sample_cameras(
    n=None,
    *,
    targets=None,
    distance=(3.0, 6.0),
    height=(0.5, 2.0),
    focal=1000.0,
    principal_point=(500.0, 500.0),
    up="y",
    random_state=None,
) -> Cameras:
    """Draw n seeded virtual cameras looking at `targets`.

    Parameters
    ----------
    n : int, optional
        Number of cameras; defaults to the number of targets.
    targets : array_like, shape (n, 3) or (3,), optional
        Points the cameras look at (e.g. each pose's mean joint); the origin
        (at the mean height of ``height``) by default.
    distance : float or (low, high)
        Horizontal distance from the target, metres (uniform in the range).
    height : float or (low, high)
        Camera height: its world up coordinate, metres (ground at 0).
    focal : float or (low, high)
        Focal length in pixels.
    principal_point : (cu, cv)
        Principal point in pixels, the same for every camera.
    up : {"y", "z", "x"}
        World up axis (``"y"`` for BVH and ASF/AMC).
    random_state : int or numpy.random.Generator, optional
        Seed; the same seed gives the same cameras.

    Returns
    -------
    Cameras

    Examples
    --------
    >>> cams = sample_cameras(4, random_state=0)
    >>> cams.R.shape, cams.t.shape, cams.f.shape, cams.c.shape
    ((4, 3, 3), (4, 3), (4,), (4, 2))
    >>> bool(np.allclose(cams.R @ cams.R.transpose(0, 2, 1), np.eye(3)))
    True
    """
    rng = np.random.default_rng(random_state)
    ax = _axis(up)
    if targets is not None:
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        if targets.shape[-1] != 3 or targets.ndim != 2:
            raise PoseError(f"targets must have shape (n, 3), got {targets.shape}")
        if n is None:
            n = targets.shape[0]
        elif targets.shape[0] == 1:
            targets = np.repeat(targets, n, axis=0)
        elif targets.shape[0] != n:
            raise PoseError(f"{targets.shape[0]} targets for {n} cameras")
    else:
        if n is None:
            raise ValueError("give n or targets")
        targets = np.zeros((n, 3))
        targets[:, ax] = np.mean(np.atleast_1d(height))
    azimuth = rng.uniform(0.0, 2.0 * np.pi, size=n)
    dist = _uniform(rng, distance, n, "distance")
    ht = _uniform(rng, height, n, "height")
    f = _uniform(rng, focal, n, "focal")
    h1, h2 = [a for a in range(3) if a != ax]
    eye = targets.copy()
    eye[:, h1] += dist * np.cos(azimuth)
    eye[:, h2] += dist * np.sin(azimuth)
    eye[:, ax] = ht
    R = look_at(eye, targets, up=up)
    t = -np.einsum("nij,nj->ni", R, eye)
    c = np.broadcast_to(np.asarray(principal_point, dtype=float), (n, 2)).copy()
    return Cameras(R=R, t=t, f=f, c=c)


def project(points3d, cameras: Cameras) -> np.ndarray:
    """Project world points through each pose's camera to pixels.

    Parameters
    ----------
    points3d : array_like, shape (n, N, 3)
        One pose (N points) per camera.
    cameras : Cameras
        n cameras.

    Returns
    -------
    ndarray, shape (n, N, 2)
        Pixel coordinates (u right, v down).

    Raises
    ------
    PoseError
        For mismatched shapes or a point at or behind a camera.

    Examples
    --------
    >>> cams = Cameras(R=np.eye(3)[None], t=np.array([[0.0, 0.0, 4.0]]),
    ...                f=np.array([1000.0]), c=np.array([[500.0, 500.0]]))
    >>> project([[[0.0, 0.0, 0.0], [0.4, -0.2, 0.0]]], cams)
    array([[[500., 500.],
            [600., 450.]]])
    """
    pts = np.asarray(points3d, dtype=float)
    check_pose_shape(pts, "points3d", dim=3)
    if pts.shape[0] != len(cameras):
        raise PoseError(f"{pts.shape[0]} poses for {len(cameras)} cameras")
    cam = np.einsum("nij,nkj->nki", cameras.R, pts) + cameras.t[:, None, :]
    z = cam[..., 2]
    if np.any(z <= 1e-9):
        bad = int(np.flatnonzero((z <= 1e-9).any(axis=1))[0])
        raise PoseError(f"pose {bad} has a point at or behind its camera")
    uv = cam[..., :2] / z[..., None] * cameras.f[:, None, None] + cameras.c[:, None, :]
    return uv
