"""A 3D radius per lifted joint: how far the true joint may be from the lifted one.

The radius (metres, the units of :attr:`LiftResult.poses3d`) of a sphere
centred on the lifted joint (pelvis at the origin, the pose at the lifter's
size prior) meant to hold the true joint 9 times in 10. It has two parts:

* the lifter's own error: a per-joint 90 % quantile of the 3D error on CMU
  validation clips (a lifter fitted on the other clips, virtual cameras),
  relative to the lifter's size prior: :data:`BASE_OBSERVED` for a joint seen
  in 2D or filled across time, :data:`BASE_MISSING` for a joint still missing
  in 2D (the lifter places it from the others). It covers depth ambiguity and
  the difference between the person's size and the size prior: an observed
  joint's radius is never 0;
* where 2D joints were filled across time (a video), their 2D uncertainty
  carried through the lift: the pose is lifted again with each filled joint
  moved at random inside its 2D 90 % circle (:data:`N_PERTURBATIONS` seeded
  draws), and each joint's root-mean-square 3D displacement, times
  :data:`SPREAD_FACTOR`, is added in quadrature to the first part.

The numbers were chosen for the shipped dictionary lifter
(``studies/uncertainty/lift3d.py`` writes them and their coverage to
``studies/uncertainty/lift3d.json``); other lifters get the same table
relative to their size prior, not calibrated for them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BASE_OBSERVED", "BASE_MISSING", "SPREAD_FACTOR", "N_PERTURBATIONS",
           "FILLED_WEIGHT_SCALE", "base_radius", "perturb_filled", "spread3d",
           "combine_radius", "filled_weights"]

#: per joint (SKELETON_14 order), the 90 % quantile of the 3D error of a joint
#: seen in 2D, as a fraction of the lifter's size prior (CMU validation clips)
BASE_OBSERVED = np.array([0.1784, 0.1309, 0.1423, 0.1699, 0.2246, 0.1357, 0.1777,
                          0.1982, 0.0281, 0.1464, 0.2393, 0.0280, 0.1420, 0.2224])
#: the same for a joint missing in 2D (Mix occlusion, 1-3 joints)
BASE_MISSING = np.array([0.2430, 0.1634, 0.1306, 0.2202, 0.3537, 0.1723, 0.1682,
                         0.2730, 0.0287, 0.2364, 0.3492, 0.0287, 0.2227, 0.3492])
#: times the RMS 3D displacement under perturbed filled joints (CMU validation)
SPREAD_FACTOR = 2.0
#: seeded re-lifts per pose holding filled joints
N_PERTURBATIONS = 4
#: s of :func:`filled_weights`, relative to the pose's 2D size (chosen on CMU
#: validation clips: studies/lifting/selection_weight.json)
FILLED_WEIGHT_SCALE = 0.01
#: a 2D Gaussian's 90 % radius in standard deviations, sqrt(2 ln 10)
_R90_2D = float(np.sqrt(2 * np.log(10)))


def base_radius(size_prior, missing, ok):
    """The lifter's own 90 % radius per joint (n, N) metres; NaN where not ``ok``.

    Parameters
    ----------
    size_prior : float
        The lifter's metric size prior (metres per normalised unit).
    missing : ndarray of bool (n, N)
        Joints still missing in 2D when lifted.
    ok : ndarray of bool (n,)
        Rows lifted.

    Returns
    -------
    ndarray (n, N)
        :data:`BASE_MISSING` or :data:`BASE_OBSERVED` times `size_prior`.
    """
    r = np.where(missing, BASE_MISSING, BASE_OBSERVED) * float(size_prior)
    return np.where(ok[:, None], r, np.nan)


def perturb_filled(poses, filled, radius2d, n_draws, seed=0):
    """Copies of the poses with each filled joint moved at random inside its 2D radius.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
    filled : ndarray of bool (n, N)
    radius2d : ndarray (n, N)
        The filled joints' 2D 90 % radius (pixels; ignored elsewhere).
    n_draws : int
    seed : int

    Returns
    -------
    ndarray (n_draws, n, N, 2)
        Each filled joint moved by a 2D Gaussian whose 90 % circle is its
        radius; the other joints unchanged.
    """
    rng = np.random.default_rng(seed)
    sigma = np.where(filled, np.nan_to_num(radius2d), 0.0) / _R90_2D
    noise = rng.standard_normal((n_draws,) + poses.shape) * sigma[None, ..., None]
    return poses[None] + noise


def spread3d(relift, poses, filled, radius2d, *, n_draws=None, seed=0):
    """Each joint's RMS 3D displacement (n, N) when the filled 2D joints move.

    Parameters
    ----------
    relift : callable
        ``relift(poses) -> (front, back)``: both metric reflections (n, N, 3) of
        the rows lifted from `poses` alone (no time), NaN where refused.
    poses : ndarray (n, N, 2)
        The 2D poses lifted, filled joints included.
    filled : ndarray of bool (n, N)
    radius2d : ndarray (n, N)
        The filled joints' 2D 90 % radius (pixels).
    n_draws : int, optional
        Default :data:`N_PERTURBATIONS`.
    seed : int

    Returns
    -------
    ndarray (n, N)
        0 where no joint of the row was filled or a draw was refused.
    """
    n_draws = N_PERTURBATIONS if n_draws is None else int(n_draws)
    front, back = relift(poses)
    ref = front
    sq = np.zeros(filled.shape)
    for draw in perturb_filled(poses, filled, radius2d, n_draws, seed):
        f, b = relift(draw)
        # the reflection closer to the reference: a flip is not a 2D uncertainty
        df, db = (np.linalg.norm(p - ref, axis=-1) for p in (f, b))
        d = np.where((df.mean(axis=1) <= db.mean(axis=1))[:, None], df, db)
        sq += np.nan_to_num(d) ** 2
    return np.where(filled.any(axis=1)[:, None], np.sqrt(sq / n_draws), 0.0)


def combine_radius(base, spread):
    """The 3D radius from its two parts, in quadrature.

    Parameters
    ----------
    base : ndarray (n, N)
        :func:`base_radius`.
    spread : ndarray (n, N)
        :func:`spread3d`, same units.

    Returns
    -------
    ndarray (n, N)
        ``sqrt(base^2 + (SPREAD_FACTOR * spread)^2)`` (NaN stays NaN).
    """
    return np.sqrt(base ** 2 + (SPREAD_FACTOR * spread) ** 2)


def filled_weights(poses, missing, filled, radius2d, scale=None):
    """Per-joint weights of the dictionary lifter's lasso for joints filled across time.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        The 2D poses, filled joints included.
    missing : ndarray of bool (n, N)
        Joints still missing (not filled).
    filled : ndarray of bool (n, N)
    radius2d : ndarray (n, N)
        The filled joints' 2D 90 % radius (pixels).
    scale : float, optional
        s; default :data:`FILLED_WEIGHT_SCALE`.

    Returns
    -------
    ndarray (n, N)
        ``1 / (1 + (r / (s h))^2)`` for a filled joint (r its 2D radius, h the
        diagonal of the 2D bounding box of the pose's joints not missing), 1
        elsewhere (an observed joint, or one still missing: the lasso ignores it).
        A row with no observed joint (every one filled) has its weights divided
        by their largest: only how the joints compare is known, and weights
        all far below 1 would let the lasso's penalty code no pose at all.
    """
    scale = FILLED_WEIGHT_SCALE if scale is None else float(scale)
    weights = np.ones(filled.shape)
    rows = np.flatnonzero(filled.any(axis=1))  # each holds a joint not missing
    pts = np.where(missing[rows, :, None], np.nan, poses[rows])
    with np.errstate(all="ignore"):  # a row with a bad coordinate keeps weight 1
        extent = np.nanmax(pts, axis=1) - np.nanmin(pts, axis=1)
        ratio = np.nan_to_num(radius2d[rows]) / (scale * np.hypot(*extent.T)[:, None])
        w = 1.0 / (1.0 + ratio ** 2)
    weights[rows] = np.where(filled[rows] & np.isfinite(w), w, 1.0)
    only_filled = rows[(filled[rows] | missing[rows]).all(axis=1)]
    weights[only_filled] /= weights[only_filled].max(axis=1, keepdims=True)
    return weights
