"""Normalisation of 2D poses into [-1, 1] and the paper's occlusion representations.

Normalisation (one scale for both axes)
---------------------------------------
For the joints used, take the bounding box; its centre goes to the origin and
its longer side is scaled to length 2::

    center = (min + max) / 2           (per axis)
    scale  = max(max - min) / 2        (one number for both axes)
    p_norm = (p - center) / scale

so the longer axis spans exactly [-1, 1] and the other lies inside it, and
the aspect ratio of the pose is kept. A pose whose used joints all coincide
(scale 0) cannot be normalised and is refused.

This box rule (``rule="box"``) is how training poses are normalised. A box
changes with the body's rotation in the image plane, so recovery scales a
pose by a measure that does not (``rule="radius"``, the rule a dictionary's
``recovery_scale`` names)::

    center = mean of the used joints
    scale  = RADIUS_FACTOR * sqrt(mean ||p - center||^2)

the root-mean-square distance of the used joints to their centroid, times
:data:`RADIUS_FACTOR` (the median ratio of the box scale to that distance over
complete mocap training poses), so a typical pose gets about the scale the
box gives it and a dictionary's alpha keeps its meaning. Rotating, shifting or
uniformly scaling the used joints rotates, shifts or scales ``center`` with
them and scales ``scale`` alone: the normalised EDM vector does not change.
The one exception: a pose whose coordinates lie within a factor of a few of
float64's limits, where that radius overflows or is subnormal while the box
is not, falls back to the box.

Occlusion representations (Guo & Dai)
-------------------------------------
``"zero"``
    Normalise using the observed joints only; the EDM rows and columns of the
    occluded joints are 0 (their coordinates are set to the origin only as a
    placeholder, and their distances are then zeroed).
``"average"``
    Set each occluded joint to the mean of the observed joints, then normalise
    all joints. The mean lies inside the observed bounding box, so the
    normalisation is the same as in ``"zero"``; only the occluded EDM entries
    differ (distances to that mean point instead of 0).

Both keep the observed EDM entries identical, which is all the sparse-coding
recovery uses; they differ in what a model that reads the whole EDM sees.

Occlusion may be given as a boolean mask, as NaN coordinates, or as detector
confidences below a threshold: :func:`missing_mask` turns each into a mask.
"""

from __future__ import annotations

import numpy as np

from .edm import pose_to_vector, observed_entries
from .exceptions import ParameterError, PoseError

__all__ = [
    "REPRESENTATIONS",
    "MIN_OBSERVED_JOINTS",
    "missing_mask",
    "usable_rows",
    "far_joint",
    "FAR_JOINT_RATIO",
    "normalize",
    "rms_radius",
    "denormalize",
    "represent",
    "representation_for",
    "DEFAULT_REPRESENTATION",
    "SCALE_RULES",
    "RADIUS_FACTOR",
]

REPRESENTATIONS = ("average", "zero")
#: how a pose's centre and scale are measured: its used joints' bounding box, or
#: their centroid and root-mean-square distance to it (invariant to rotation)
SCALE_RULES = ("box", "radius")
#: the "radius" rule's scale is this times the RMS distance to the centroid: the
#: median ratio of the box scale to that distance over complete CMU training poses
RADIUS_FACTOR = 1.59
#: the representation used when neither the caller nor a model or lifter file names one
DEFAULT_REPRESENTATION = "average"


def representation_for(given, recorded=None, where="the model"):
    """The occlusion representation to use: the one a model or lifter file
    `recorded` (it was trained on it), else `given`, else
    :data:`DEFAULT_REPRESENTATION`; a `given` one other than the recorded one
    is refused (the one rule for ``representation=None`` of recover, lift and
    their commands).

    Parameters
    ----------
    given : {"average", "zero"} or None
        The representation the caller asked for; None: unset.
    recorded : {"average", "zero"} or None, optional
        The representation the model or lifter file was trained on, if it
        records one.
    where : str, default "the model"
        What the error message calls the file.

    Returns
    -------
    str
        The representation to use.

    Raises
    ------
    ParameterError
        If `given` is set and differs from `recorded`.

    Examples
    --------
    >>> representation_for(None), representation_for(None, "zero")
    ('average', 'zero')
    >>> representation_for("zero", "average", "m.npz")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: m.npz was trained on 'average' inputs, not 'zero': leave representation (--representation) unset to use the file's own, or pass 'average'
    """
    if recorded is None:
        return DEFAULT_REPRESENTATION if given is None else given
    if given is not None and given != recorded:
        raise ParameterError(f"{where} was trained on {recorded!r} inputs, not {given!r}: "
                             "leave representation (--representation) unset to use the "
                             f"file's own, or pass {recorded!r}")
    return recorded
#: Fewer observed joints than this leave too little of the EDM to code.
MIN_OBSERVED_JOINTS = 3


def usable_rows(poses):
    """True for poses with every coordinate finite and a non-zero extent: the one rule
    for a usable complete pose (adaptation, learning, evaluation and the lifter
    adaptation all keep these rows; the extents it refuses are those recover() refuses).

    Parameters
    ----------
    poses : array_like, shape (n, N, 2)
        Complete poses.

    Returns
    -------
    ndarray of bool (n,)
        True for the usable rows.

    Examples
    --------
    >>> import numpy as np
    >>> p = np.ones((3, 14, 2)); p[:, 0] = 0; p[1, 3, 0] = np.nan; p[2] = 5.0
    >>> usable_rows(p).tolist()
    [True, False, False]
    """
    poses = np.asarray(poses, dtype=float)
    ok = np.isfinite(poses).all(axis=(-1, -2))
    finite = np.where(np.isfinite(poses), poses, 0.0)
    with np.errstate(over="ignore", invalid="ignore"):  # the extents recover() refuses
        span = np.ptp(finite, axis=-2).max(axis=-1)
        total = np.abs(finite).sum(axis=-2).max(axis=-1)
    ok &= np.isfinite(span) & np.isfinite(total) & (span / 2 >= np.finfo(float).tiny)
    ok[ok] = far_joint(poses[ok], np.zeros(poses[ok].shape[:-1], dtype=bool))[0] < 0
    return ok


#: a joint whose removal shrinks the observed extent by more than this factor
#: (float64's 1 / epsilon) leaves the other joints' distances below the rounding
#: of the normalised pose: every recovery would read them as one point
FAR_JOINT_RATIO = 1 / np.finfo(float).eps


def far_joint(poses, missing):
    """Each pose's observed joint so far from the others that the pose is no body.

    A joint without which the observed joints' extent shrinks by more than
    :data:`FAR_JOINT_RATIO`: beside it, the other joints' distances vanish in
    the rounding of the normalised pose (a joint at 1e300 next to a body of
    100 pixels). The other joints all coinciding is not such a case (a
    two-point pose loses nothing to rounding).

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Poses whose observed joints are finite with a finite, non-zero extent.
    missing : ndarray of bool (n, N)
        Joints left out.

    Returns
    -------
    joint : ndarray of int (n,)
        The far joint's index; -1 where there is none.
    ratio : ndarray (n,)
        The extent with the joint over the extent without it; NaN where none.

    Examples
    --------
    >>> import numpy as np
    >>> p = np.array([[[0.0, 0.0], [3.0, 4.0], [1.0, 2.0]]] * 2)
    >>> p[1, 1] = [1e300, 0.0]
    >>> joint, ratio = far_joint(p, np.zeros((2, 3), bool))
    >>> joint.tolist(), float(ratio[1])
    ([-1, 1], 5e+299)
    """
    lo = np.where(missing[..., None], np.inf, poses)
    hi = np.where(missing[..., None], -np.inf, poses)
    if poses.shape[1] < 2:
        return np.full(len(poses), -1), np.full(len(poses), np.nan)
    lo2 = np.partition(lo, 1, axis=1)[:, :2]  # the two lowest per axis
    hi2 = -np.partition(-hi, 1, axis=1)[:, :2]
    with np.errstate(invalid="ignore", over="ignore"):
        widest = (hi2[:, 0] - lo2[:, 0]).max(axis=-1)
        # each joint's extent without it: the second extreme where it is the extreme
        lo_wo = np.where(poses == lo2[:, :1], lo2[:, 1:], lo2[:, :1])
        hi_wo = np.where(poses == hi2[:, :1], hi2[:, 1:], hi2[:, :1])
        rest = (hi_wo - lo_wo).max(axis=-1)
        ratio = widest[:, None] / np.where(rest > 0, rest, np.nan)
    far = ~missing & (rest > 0) & (ratio > FAR_JOINT_RATIO)
    joint = np.where(far.any(axis=1), np.where(far, ratio, -np.inf).argmax(axis=1), -1)
    return joint, np.where(joint >= 0, np.where(far, ratio, 0.0).max(axis=1), np.nan)


def missing_mask(poses, missing=None, *, confidence=None, threshold=0.0):
    """Boolean (..., N) mask of missing joints from any of the accepted forms.

    A joint is missing when `missing` says so, when any of its coordinates is
    NaN, or when its `confidence` is below `threshold`. The three sources are
    combined with "or".

    Parameters
    ----------
    poses : array_like, shape (..., N, 2)
        The poses' coordinates; NaN marks a missing joint.
    missing : array_like of bool, shape (..., N), optional
        Joints known to be missing.
    confidence : array_like, shape (..., N), optional
        Detector scores; joints with ``confidence < threshold`` are missing.
    threshold : float, default 0.0
        The confidence below which a joint is missing.

    Returns
    -------
    missing : ndarray of bool, shape (..., N)
        True at the missing joints.

    Examples
    --------
    >>> import numpy as np
    >>> poses = np.array([[[0., 0.], [np.nan, np.nan], [1., 2.]]])
    >>> missing_mask(poses).tolist()
    [[False, True, False]]
    >>> missing_mask(poses[:, [0, 2, 2]], confidence=[[0.9, 0.1, 0.8]],
    ...              threshold=0.3).tolist()
    [[False, True, False]]
    """
    poses = np.asarray(poses, dtype=float)
    if poses.ndim < 2:
        raise PoseError(f"poses must have shape (..., N, 2), got {poses.shape}")
    mask = np.isnan(poses).any(axis=-1)
    for name, extra in (("missing", missing), ("confidence", confidence)):
        if extra is None:
            continue
        extra = np.asarray(extra)
        if extra.shape != mask.shape:
            raise PoseError(
                f"{name} must have shape {mask.shape} (one entry per joint), "
                f"got {extra.shape}"
            )
        if name == "missing":
            mask = mask | extra.astype(bool)
        else:
            mask = mask | ~(extra.astype(float) >= threshold)
    return mask


def _check_observed(poses, missing):
    """Validate observed coordinates; return the per-pose count of observed."""
    n_obs = (~missing).sum(axis=-1)
    bad_values = (~np.isfinite(poses)).any(axis=-1) & ~missing
    if bad_values.any():
        idx = np.argwhere(bad_values)[0]
        raise PoseError(
            f"observed joint {int(idx[-1])} of pose {tuple(int(i) for i in idx[:-1])} "
            "has a NaN or infinite coordinate; mark it missing or fix it"
        )
    too_few = n_obs < MIN_OBSERVED_JOINTS
    if too_few.any():
        idx = tuple(int(i) for i in np.argwhere(too_few)[0])
        raise PoseError(
            f"pose {idx} has {int(n_obs[idx])} observed joints; at least "
            f"{MIN_OBSERVED_JOINTS} are needed"
        )
    return n_obs


def normalize(poses, missing=None, rule="box"):
    """Map each pose's used joints into [-1, 1] with one scale for both axes.

    Parameters
    ----------
    poses : array_like, shape (..., N, 2)
        The poses' coordinates.
    missing : array_like of bool, shape (..., N), optional
        Joints left out of the measure (they are normalised with the
        same transform; NaN stays NaN).
    rule : {"box", "radius"}, default "box"
        The used joints' bounding box (the longer side spans [-1, 1]), or
        their centroid and :data:`RADIUS_FACTOR` times their RMS distance to
        it (the same for the pose rotated in the image plane); see the
        module docstring.

    Returns
    -------
    normalized : ndarray, shape (..., N, 2)
        The normalised poses.
    center : ndarray, shape (..., 2)
        Centre of each pose's bounding box (``"radius"``: the centroid).
    scale : ndarray, shape (...)
        Half the longer side of each bounding box (``"radius"``: the scaled
        RMS distance):
        ``poses == normalized * scale[..., None, None] + center[..., None, :]``.

    Examples
    --------
    >>> out, center, scale = normalize([[0., 0.], [4., 0.], [4., 2.]])
    >>> out.tolist(), center.tolist(), float(scale)
    ([[-1.0, -0.5], [1.0, -0.5], [1.0, 0.5]], [2.0, 1.0], 2.0)
    >>> square = [[0., 0.], [2., 0.], [2., 2.], [0., 2.]]
    >>> out, center, scale = normalize(square, rule="radius")
    >>> center.tolist(), round(float(scale) / RADIUS_FACTOR, 6)
    ([1.0, 1.0], 1.414214)
    """
    poses = np.asarray(poses, dtype=float)
    if poses.ndim < 2 or poses.shape[-1] != 2:
        raise PoseError(f"poses must have shape (..., N, 2), got {poses.shape}")
    if missing is None:
        missing = np.zeros(poses.shape[:-1], dtype=bool)
    missing = np.asarray(missing, dtype=bool)
    _check_observed(poses, missing)
    if rule not in SCALE_RULES:
        raise ParameterError(f"unknown normalisation rule {rule!r}; use one of {SCALE_RULES}")
    center, scale = (_radius if rule == "radius" else _box)(poses, missing)
    if (scale <= 0).any():
        idx = tuple(int(i) for i in np.argwhere(scale <= 0)[0])
        raise PoseError(f"pose {idx}: all observed joints coincide (zero extent)")
    bad = ~np.isfinite(scale) | (scale < np.finfo(float).tiny)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise PoseError(f"pose {idx}: the extent of its observed joints ({2 * scale[idx]:.3g}) "
                        "overflows float64 or is subnormal; rescale the coordinates")
    normalized = (poses - center[..., None, :]) / scale[..., None, None]
    return normalized, center, scale


def _box(poses, missing):
    used = np.where(missing[..., None], np.nan, poses)
    lo = np.nanmin(used, axis=-2)
    hi = np.nanmax(used, axis=-2)
    with np.errstate(over="ignore", invalid="ignore"):
        return lo / 2 + hi / 2, (hi - lo).max(axis=-1) / 2


def rms_radius(poses, missing):
    """The observed joints' centroid and root-mean-square distance to it.

    Computed relative to the largest offset, so coordinates near float64's
    limits neither overflow nor underflow (a pose beyond them gets a non-finite
    or zero distance).

    Parameters
    ----------
    poses : ndarray (..., N, 2)
    missing : ndarray of bool (..., N)
        Joints left out.

    Returns
    -------
    center : ndarray (..., 2)
    radius : ndarray (...)

    Examples
    --------
    >>> square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    >>> center, radius = rms_radius(square, np.zeros(4, bool))
    >>> center.tolist(), round(float(radius), 6)
    ([1.0, 1.0], 1.414214)
    """
    used = ~missing[..., None]
    count = used.sum(axis=-2)  # (..., 1)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        center = np.where(used, poses, 0.0).sum(axis=-2) / count
        # halved, then squared relative to the largest offset
        off = np.where(used, poses / 2 - center[..., None, :] / 2, 0.0)
        top = np.abs(off).max(axis=(-1, -2))
        ratio = off / np.where(top > 0, top, 1.0)[..., None, None]
        mean_sq = (ratio**2).sum(axis=(-1, -2)) / count[..., 0]
        return center, top * (2 * np.sqrt(mean_sq))


def _radius(poses, missing):
    center, radius = rms_radius(poses, missing)
    with np.errstate(over="ignore"):
        scale = RADIUS_FACTOR * radius
    # the one place the rule is not rotation-invariant: a pose within a factor of
    # a few of float64's limits, whose radius overflows or is subnormal where its
    # box is not, falls back to the box (recover() refuses what the box refuses)
    off_limits = ~np.isfinite(scale) | (scale < np.finfo(float).tiny)
    if off_limits.any():
        box_center, box_scale = _box(poses, missing)
        center = np.where(off_limits[..., None], box_center, center)
        scale = np.where(off_limits, box_scale, scale)
    return center, scale


def denormalize(normalized, center, scale):
    """Undo :func:`normalize`: back to the caller's own frame.

    Parameters
    ----------
    normalized : array_like, shape (..., N, 2)
        Normalised poses.
    center : array_like, shape (..., 2)
        Bounding-box centres, as returned by :func:`normalize`.
    scale : array_like, shape (...)
        Scales, as returned by :func:`normalize`.

    Returns
    -------
    ndarray, shape (..., N, 2)
        ``normalized * scale + center``, in the caller's units.
    """
    normalized = np.asarray(normalized, dtype=float)
    return normalized * np.asarray(scale)[..., None, None] + np.asarray(center)[
        ..., None, :
    ]


def represent(poses, missing=None, representation="average", rule="box"):
    """Normalised EDM vector of each pose under one occlusion representation.

    Parameters
    ----------
    poses : array_like, shape (..., N, 2)
        Coordinates of occluded joints are ignored (may be NaN).
    missing : array_like of bool, shape (..., N), optional
        Default: NaN coordinates mark missing joints.
    representation : {"average", "zero"}, default "average"
        How the occluded joints enter the EDM (see the module docstring).
    rule : {"box", "radius"}, default "box"
        How the observed joints set the normalisation (:func:`normalize`).

    Returns
    -------
    vectors : ndarray, shape (..., N(N-1)/2)
        Upper-triangle EDM vectors of the normalised poses (the paper's T).
    center, scale : ndarray
        The normalisation, as returned by :func:`normalize`.

    Examples
    --------
    A right triangle with its third joint occluded:

    >>> import numpy as np
    >>> pose = np.array([[0., 0.], [4., 0.], [0., 2.], [4., 2.]])
    >>> T, c, s = represent(pose, [False, False, False, True], "zero")
    >>> T.round(4).tolist()
    [2.0, 1.0, 0.0, 2.2361, 0.0, 0.0]
    >>> T, c, s = represent(pose, [False, False, False, True], "average")
    >>> T.round(4).tolist()
    [2.0, 1.0, 0.7454, 2.2361, 1.3744, 0.9428]
    """
    if representation not in REPRESENTATIONS:
        raise PoseError(
            f"unknown representation {representation!r}; use one of {REPRESENTATIONS}"
        )
    poses = np.asarray(poses, dtype=float)
    mask = missing_mask(poses, missing)
    if representation == "average":
        _check_observed(poses, mask)
        n_obs = (~mask).sum(axis=-1)
        filled = np.where(mask[..., None], 0.0, poses)
        with np.errstate(over="ignore", invalid="ignore"):
            mean = filled.sum(axis=-2) / n_obs[..., None]
        if not np.isfinite(mean).all():
            idx = tuple(int(i) for i in np.argwhere(~np.isfinite(mean).all(axis=-1))[0])
            raise PoseError(
                f"pose {idx}: the mean of its observed joints overflows float64; "
                "rescale the coordinates"
            )
        poses = np.where(mask[..., None], mean[..., None, :], poses)
        # the fills sit at the observed joints' mean: inside their box, but they
        # would shrink their RMS radius, so the measure is the observed joints'
        normalized, center, scale = normalize(poses, mask, rule)
        return pose_to_vector(normalized), center, scale
    normalized, center, scale = normalize(poses, mask, rule)
    normalized = np.where(mask[..., None], 0.0, normalized)
    vectors = pose_to_vector(normalized)
    return np.where(observed_entries(mask), vectors, 0.0), center, scale
