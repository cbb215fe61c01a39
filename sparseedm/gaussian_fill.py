"""Gaussians over a file's poses: the conditional mean of the hidden joints.

A linear estimate to set beside the sparse codes: the file's poses
are taken as draws of one Gaussian over the 28 coordinates, each pose in the
frame of the joints observed in the pose being filled (their centroid and RMS
radius: :func:`sparseedm.normalize.rms_radius`, rotation-invariant), and the
hidden joints get their conditional mean given the observed ones,

    mu_h + S_ho (S_oo + r I_o)^-1 (x_o - mu_o),

with the covariance shrunk by a ridge ``r`` (:data:`GAUSSIAN_RIDGE` times its
mean variance). The closed form is solved once per missing pattern.
:func:`gaussian_fill` fits the Gaussian to given training poses;
:func:`file_gaussian` refits it on the whole file, the incomplete poses as
last filled (:data:`GAUSSIAN_ROUNDS` rounds, as an iterative imputer does),
so that the file's incomplete poses shape it too (``augment``: over the
draws and, say, their mirror images). :func:`local_gaussian_fill` gives
each pose its own Gaussian: that of the :data:`LOCAL_NEIGHBOURS` draws
nearest it on its observed joints, shrunk toward the Gaussian of every draw
(:data:`LOCAL_PRIOR` pseudo-draws), so a file of several kinds of pose is
not forced into one; the neighbours are then chosen again on the whole pose
as filled (its hidden joints weighted :data:`LOCAL_RESELECT`) and the
Gaussian refitted. The default path weighs the local answer over the
file's poses and their mirror images against its own by a held-back check
(:func:`sparseedm.exemplars.linear_weight`).
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import numpy as np
from threadpoolctl import threadpool_limits

__all__ = ["GAUSSIAN_RIDGE", "GAUSSIAN_ROUNDS", "LOCAL_NEIGHBOURS", "LOCAL_PRIOR", "LOCAL_RESELECT",
           "conditional_mean", "gaussian_fill", "local_gaussian_fill", "file_gaussian",
           "nearest_distances", "gated_local_fill"]

#: The covariance's ridge, relative to its mean variance (chosen on validation
#: photo files: studies/fast/README.md)
GAUSSIAN_RIDGE = 0.01

#: Refits of :func:`file_gaussian` on the file's poses as last filled
GAUSSIAN_ROUNDS = 3

#: :func:`local_gaussian_fill`: the draws nearest a pose on its observed joints
#: that set its Gaussian, and the weight (in draws) of the Gaussian of every
#: draw they are shrunk to (chosen on validation photo files: studies/fast/README.md)
LOCAL_NEIGHBOURS, LOCAL_PRIOR = 100, 50

#: :func:`local_gaussian_fill`: the hidden joints' weight in the distance by which
#: the neighbours are chosen again on the pose as first filled (chosen on
#: validation photo files: studies/fast/README.md)
LOCAL_RESELECT = 0.5

# query rows per block of local_gaussian_fill (its distances and covariances)
_LOCAL_BLOCK = 256


def conditional_mean(train, query, observed, ridge=GAUSSIAN_RIDGE):
    """The conditional mean of the unobserved columns under one Gaussian of `train`.

    Parameters
    ----------
    train : ndarray (n, d)
        Rows the Gaussian is fitted to (mean and covariance), n >= 2.
    query : ndarray (m, d)
        Rows whose `observed` columns are given (the others are ignored).
    observed : ndarray of bool (d,)
    ridge : float, default GAUSSIAN_RIDGE
        Added to the covariance's diagonal, times its mean variance.

    Returns
    -------
    ndarray (m, d)
        `query` with its unobserved columns replaced by their conditional mean.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.random.default_rng(0).normal(size=(500, 1))
    >>> train = np.hstack([x, 2 * x + 1])
    >>> q = np.array([[1.5, np.nan]])
    >>> out = conditional_mean(train, q, np.array([True, False]), ridge=0.0)
    >>> round(float(out[0, 1]), 6)
    4.0
    """
    mu = np.ones(len(train)) @ train / len(train)
    centred = train - mu
    cov = centred.T @ centred / (len(train) - 1)
    cov = cov + ridge * np.trace(cov) / len(cov) * np.eye(len(cov))
    obs, hid = np.flatnonzero(observed), np.flatnonzero(~observed)
    coef = np.linalg.solve(cov[np.ix_(obs, obs)], cov[np.ix_(obs, hid)])
    out = np.array(query, dtype=float)
    out[:, hid] = mu[hid] + (out[:, obs] - mu[obs]) @ coef
    return out


def _sums(poses):
    """The per-joint terms :func:`_frame` weighs: x, y and x² + y² (n, N) each."""
    x, y = np.ascontiguousarray(poses[..., 0]), np.ascontiguousarray(poses[..., 1])
    with np.errstate(over="ignore"):
        return x, y, x * x + y * y


def _frame(poses, observed, sums=None):
    """Each pose shifted to the centroid of its `observed` joints and divided by
    their RMS radius (:func:`~sparseedm.normalize.rms_radius`'s, computed as
    weighted sums of validated coordinates; `sums` :func:`_sums` of `poses`):
    (normalised poses, centre, radius)."""
    x, y, squares = _sums(poses) if sums is None else sums
    weights = observed / observed.sum()
    centre = np.stack([x @ weights, y @ weights], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        radius = np.sqrt(np.maximum(squares @ weights - (centre * centre).sum(axis=-1), 0.0))
        return (poses - centre[:, None]) / radius[:, None, None], centre, radius


def gaussian_fill(train, poses, missing, *, ridge=GAUSSIAN_RIDGE):
    """Each pose's missing joints filled by their conditional mean given its observed
    ones under one Gaussian of `train`, in the frame of those joints.

    Parameters
    ----------
    train : ndarray (n, N, 2)
        Complete poses (n >= 2), the Gaussian's draws.
    poses : ndarray (m, N, 2)
        Poses to fill (values at missing joints ignored).
    missing : ndarray of bool (m, N)
    ridge : float, default GAUSSIAN_RIDGE
        The covariance's ridge, relative to its mean variance.

    Returns
    -------
    ndarray (m, N, 2)
        `poses` with the missing joints filled; NaN where a pose's observed
        joints have no spread (fewer than two distinct) to set its frame.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> train = rng.normal(size=(200, 14, 2))
    >>> missing = np.zeros((1, 14), bool); missing[0, 3] = True
    >>> out = gaussian_fill(train, train[:1], missing)
    >>> bool(np.array_equal(out[0, ~missing[0]], train[0, ~missing[0]]))
    True
    """
    return _fill_by_pattern(train, poses, missing, partial(conditional_mean, ridge=ridge))


def _patterns(missing):
    """(pattern, its rows) for each distinct row of `missing`."""
    patterns, which = np.unique(missing, axis=0, return_inverse=True)
    which = np.ravel(which)
    return [(pattern, np.flatnonzero(which == k)) for k, pattern in enumerate(patterns)]


def _square_distances(seen, q, squares=None):
    """Squared distances (m, n) of the rows of `q` to the rows of `seen`
    (`squares`: the rows of `seen`'s squared norms, when already at hand)."""
    squares = (seen * seen).sum(axis=1) if squares is None else squares
    with np.errstate(invalid="ignore", over="ignore"):
        return squares[None, :] - 2 * q @ seen.T + (q * q).sum(axis=1)[:, None]


def _fill_by_pattern(train, poses, missing, conditional):
    """`poses` with each missing pattern's joints filled in the frame of its
    observed ones: ``conditional(draws, query, observed)`` on the flat frames
    of `train` (the draws) and of the pattern's rows gives the rows filled
    (:func:`gaussian_fill`, :func:`local_gaussian_fill`)."""
    train = np.asarray(train, dtype=float)
    poses = np.asarray(poses, dtype=float)
    missing = np.asarray(missing, bool)
    out = poses.copy()
    sums = _sums(train)
    # products of at most (n, 28) by (28, 28): threaded BLAS only waits on a busy machine
    with threadpool_limits(1, user_api="blas"):
        for pattern, rows in _patterns(missing):
            _fill_pattern(train, sums, poses, out, rows, pattern, conditional)
    return out


def _fill_pattern(train, sums, poses, out, rows, pattern, conditional):
    """_fill_by_pattern of the `rows` of one missing `pattern`, written into `out`."""
    if not pattern.any():
        return
    if (~pattern).sum() < 2:  # no frame: left NaN
        out[rows] = np.where(pattern[:, None], np.nan, poses[rows])
        return
    z_train, _, spread = _frame(train, ~pattern, sums)
    z_train = z_train[spread > 0]  # a frame of no spread: left out
    z, centre, radius = _frame(np.where(pattern[:, None], 0.0, poses[rows]), ~pattern)
    filled = conditional(z_train.reshape(len(z_train), -1), z.reshape(len(rows), -1),
                         np.repeat(~pattern, 2))
    _put_back_into(out, rows, pattern, filled, (z, centre, radius), poses)


def _put_back_into(out, rows, pattern, filled, frame, poses):
    """The flat `filled` rows, in the frame ``(z, centre, radius)`` of their
    pattern's observed joints, back in the image: their hidden joints written
    into ``out[rows]`` (NaN where the frame has no spread)."""
    z, centre, radius = frame
    back = filled.reshape(z.shape) * radius[:, None, None] + centre[:, None]
    back[~(np.isfinite(radius) & (radius > 0))] = np.nan
    out[rows] = np.where(pattern[:, None], back, poses[rows])


def local_gaussian_fill(train, poses, missing, *, neighbours=LOCAL_NEIGHBOURS,
                        prior=LOCAL_PRIOR, ridge=GAUSSIAN_RIDGE, reselect=LOCAL_RESELECT):
    """:func:`gaussian_fill` with a Gaussian per pose: that of the draws nearest it on
    its observed joints, shrunk toward the Gaussian of every draw.

    In the frame of the pose's observed joints (as :func:`gaussian_fill`), the
    `neighbours` draws of `train` nearest the pose on those joints (Euclidean;
    a draw that matches them exactly, the pose itself when `train` holds it
    filled, is left out) give a mean ``m_k`` and scatter ``S_k``; the pose's
    Gaussian is their mean and covariance pooled with the global ones as
    `prior` pseudo-draws, ``(k m_k + prior mu) / (k + prior)`` and
    ``(S_k + prior C) / (k + prior)`` (``C`` with its ridge), and the hidden
    joints get its conditional mean. A file of several kinds of pose (standing,
    lying, seen from the side) is not one Gaussian: the neighbours' covariance
    follows the kind of the pose. Then (`reselect` > 0) the neighbours are
    chosen again by their distance to the whole pose as filled, the hidden
    joints' squared distances weighted `reselect`, and the Gaussian refitted:
    the first fill's hidden joints tell which kind of pose it is too.

    Parameters
    ----------
    train : ndarray (n, N, 2)
        Complete poses (n >= 2), the draws.
    poses : ndarray (m, N, 2)
        Poses to fill (values at missing joints ignored).
    missing : ndarray of bool (m, N)
    neighbours : int, default LOCAL_NEIGHBOURS
    prior : float, default LOCAL_PRIOR
        The global Gaussian's weight, in draws (0: the neighbours' alone).
    ridge : float, default GAUSSIAN_RIDGE
        The global covariance's ridge, relative to its mean variance.
    reselect : float, default LOCAL_RESELECT
        The hidden joints' weight when the neighbours are chosen again on the
        filled pose (0: chosen once, on the observed joints).

    Returns
    -------
    ndarray (m, N, 2)
        `poses` with the missing joints filled; NaN where a pose's observed
        joints have no spread (fewer than two distinct) to set its frame.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> train = rng.normal(size=(300, 14, 2))
    >>> missing = np.zeros((2, 14), bool); missing[:, 3] = True
    >>> out = local_gaussian_fill(train, train[:2], missing, neighbours=50)
    >>> out.shape, bool(np.isfinite(out).all())
    ((2, 14, 2), True)
    """
    return _fill_by_pattern(train, poses, missing, partial(
        _local_means, neighbours=neighbours, prior=prior, ridge=ridge, reselect=reselect))


def _local_means(train, query, observed, neighbours, prior, ridge, reselect, distances=None):
    """local_gaussian_fill of flat `query` rows over flat `train` draws in one
    frame: `query` with its unobserved columns replaced (`distances`: the rows'
    squared distances to the draws on the observed columns, when at hand)."""
    mu = np.ones(len(train)) @ train / len(train)
    centred = train - mu
    cov = centred.T @ centred / max(len(train) - 1, 1)
    cov = cov + ridge * np.trace(cov) / len(cov) * np.eye(len(cov))
    obs, hid = np.flatnonzero(observed), np.flatnonzero(~observed)
    out = np.array(query, dtype=float)
    seen = train[:, obs]
    squares = (seen * seen).sum(axis=1)
    weights = np.where(observed, 1.0, reselect)
    weighted = (train * train) @ weights if reselect > 0 else None
    for s in range(0, len(out), _LOCAL_BLOCK):
        q = out[s:s + _LOCAL_BLOCK, obs]
        d = (_square_distances(seen, q, squares) if distances is None
             else distances[s:s + _LOCAL_BLOCK])
        # the pose itself (filled) among the draws: left out
        d = np.where(d > 1e-12 * len(obs), d, np.inf)
        out[s:s + _LOCAL_BLOCK, hid] = _local_fit(train, q, d, obs, hid, (mu, cov),
                                                  neighbours, prior)
        if reselect > 0:  # chosen again on the whole pose as filled, hidden joints weighted
            full = out[s:s + _LOCAL_BLOCK] * weights
            with np.errstate(invalid="ignore", over="ignore"):
                again = weighted[None, :] - 2 * full @ train.T + (
                    full * out[s:s + _LOCAL_BLOCK]).sum(axis=1)[:, None]
            out[s:s + _LOCAL_BLOCK, hid] = _local_fit(
                train, q, np.where(np.isfinite(d), again, np.inf), obs, hid, (mu, cov),
                neighbours, prior)
    return out


def _local_fit(train, q, d, obs, hid, whole, neighbours, prior):
    """The hidden columns' conditional mean for each row of `q` (its observed
    columns) under the Gaussian of its `neighbours` draws nearest by `d` (rows:
    distances to every draw; inf: left out), pooled with the file's
    ``(mu, cov)`` as `prior` pseudo-draws."""
    mu, cov = whole
    k = min(int(neighbours), len(train))
    near = np.argpartition(d, k - 1, axis=1)[:, :k]
    w = np.isfinite(np.take_along_axis(d, near, axis=1))[..., None]   # (b, k, 1)
    counts = w.sum(axis=1)                                               # (b, 1)
    draws = train[near]                                                  # (b, k, d)
    local = (w * draws).sum(axis=1) / np.maximum(counts, 1)
    dev = w * (draws - local[:, None])
    scatter = np.matmul(dev.transpose(0, 2, 1), dev)
    mean = (counts * local + prior * mu) / (counts + prior)
    sigma = (scatter + prior * cov) / (counts + prior)[..., None]
    coef = np.linalg.solve(sigma[:, obs][:, :, obs], sigma[:, obs][:, :, hid])
    return mean[:, hid] + np.einsum("bo,boh->bh", q - mean[:, obs], coef)


def nearest_distances(train, poses, missing, neighbours, parts=None):
    """Each pose's mean distance to its `neighbours` nearest draws on its observed joints.

    In the frame of the pose's observed joints (their centroid and RMS radius,
    as :func:`local_gaussian_fill` compares them), the Euclidean distance over
    those joints' coordinates to each draw of `train`; the mean of the
    `neighbours` smallest (among the draws of each part with `parts`).

    Parameters
    ----------
    train : ndarray (n, N, 2)
        Complete poses, the draws.
    poses : ndarray (m, N, 2)
        Values at missing joints ignored.
    missing : ndarray of bool (m, N)
    neighbours : int
    parts : ndarray of bool (n,), optional
        Two parts of the draws (True, False), each with at least one draw.

    Returns
    -------
    ndarray (m,), or (m, 2) with `parts`: the True part's, then the False part's
        NaN where a pose's observed joints have no spread.

    Examples
    --------
    >>> import numpy as np
    >>> train = np.random.default_rng(0).normal(size=(50, 14, 2))
    >>> missing = np.zeros((2, 14), bool); missing[:, 3] = True
    >>> d = nearest_distances(train, train[:2] * 2 + 5, missing, 1)    # scaled, moved
    >>> bool(d[0] < 1e-6 and d[1] < 1e-6)
    True
    """
    train = np.asarray(train, dtype=float)
    poses = np.asarray(poses, dtype=float)
    missing = np.asarray(missing, bool)
    split = [np.ones(len(train), bool)] if parts is None else [parts, ~np.asarray(parts)]
    out = np.full((len(poses), len(split)), np.nan)
    sums = _sums(train)
    for pattern, rows in _patterns(missing):
        if (~pattern).sum() < 2:
            continue
        near = _PatternDistances.of(train, sums, poses[rows], pattern)
        out[rows] = near.part_means(split, neighbours)
    return out[:, 0] if parts is None else out


class _PatternDistances(NamedTuple):
    """One missing pattern's rows and the draws in the frame of its observed
    joints (:func:`_frame`), and the rows' squared distances to the draws on
    those joints (inf to a draw of no spread: never near)."""

    train: np.ndarray      # (n, 2N) the draws, flat
    spread: np.ndarray     # (n,) the draws' radius on the observed joints
    frame: tuple           # the rows' (z, centre, radius)
    distances: np.ndarray  # (m, n)

    @classmethod
    def of(cls, train, sums, poses, pattern):
        """Of `poses` (all of `pattern`, with two observed joints or more)."""
        z_train, _, spread = _frame(train, ~pattern, sums)
        seen = np.where((spread > 0)[:, None], z_train[:, ~pattern].reshape(len(train), -1),
                        0.0)
        frame = _frame(np.where(pattern[:, None], 0.0, poses), ~pattern)
        d = _square_distances(seen, frame[0][:, ~pattern].reshape(len(poses), -1))
        d[:, ~(spread > 0)] = np.inf
        return cls(z_train.reshape(len(train), -1), spread, frame, d)

    def part_means(self, parts, neighbours):
        """(m, len(parts)): each row's mean distance to its `neighbours` nearest
        draws of each part; NaN where the row's observed joints have no spread."""
        radius = self.frame[2]
        out = np.full((len(radius), len(parts)), np.nan)
        for j, part in enumerate(parts):
            dj = self.distances[:, part]
            n = min(int(neighbours), dj.shape[1])
            near = np.sqrt(np.maximum(np.partition(dj, n - 1, axis=1)[:, :n], 0.0)).mean(axis=1)
            out[:, j] = np.where(np.isfinite(radius) & (radius > 0), near, np.nan)
        return out


def gated_local_fill(train, poses, missing, parts, gate, gate_neighbours, *,
                     neighbours=LOCAL_NEIGHBOURS, prior=LOCAL_PRIOR, ridge=GAUSSIAN_RIDGE):
    """:func:`local_gaussian_fill` (neighbours chosen once) over one part of the
    draws for the poses near it, over every draw for the others.

    A pose whose mean distance to its `gate_neighbours` nearest draws of the
    True part (:func:`nearest_distances`) is below `gate` times that to the
    False part's takes its Gaussian from the True part alone. Each missing
    pattern's frames and distances are computed once, for the gate and the fill.

    Parameters
    ----------
    train : ndarray (n, N, 2)
        Complete poses, the draws.
    poses : ndarray (m, N, 2)
        Poses to fill (values at missing joints ignored).
    missing : ndarray of bool (m, N)
    parts : ndarray of bool (n,)
        The two parts, each with at least two draws.
    gate : float
        0: every draw for every pose; inf: the True part for every pose with a frame.
    gate_neighbours : int
    neighbours, prior, ridge
        As :func:`local_gaussian_fill`'s.

    Returns
    -------
    ndarray (m, N, 2)
        `poses` with the missing joints filled; NaN where a pose's observed
        joints have no spread.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> train = rng.normal(size=(300, 14, 2)); parts = np.arange(300) < 100
    >>> missing = np.zeros((2, 14), bool); missing[:, 3] = True
    >>> out = gated_local_fill(train, train[:2], missing, parts, np.inf, 20, neighbours=50)
    >>> ref = local_gaussian_fill(train[parts], train[:2], missing, neighbours=50, reselect=0)
    >>> bool(np.array_equal(out, ref))
    True
    """
    train = np.asarray(train, dtype=float)
    poses = np.asarray(poses, dtype=float)
    missing = np.asarray(missing, bool)
    parts = np.asarray(parts, bool)
    out = poses.copy()
    sums = _sums(train)
    local = partial(_local_means, neighbours=neighbours, prior=prior, ridge=ridge, reselect=0.0)
    with threadpool_limits(1, user_api="blas"):  # as _fill_by_pattern
        for pattern, rows in _patterns(missing):
            if not pattern.any():
                continue
            if (~pattern).sum() < 2:  # no frame: left NaN
                out[rows] = np.where(pattern[:, None], np.nan, poses[rows])
                continue
            near = _PatternDistances.of(train, sums, poses[rows], pattern)
            inside = np.zeros(len(rows), bool)
            if gate > 0:
                with np.errstate(invalid="ignore"):
                    means = near.part_means([parts, ~parts], gate_neighbours)
                    inside = means[:, 0] < gate * means[:, 1]
            for which, pool in ((inside, parts), (~inside, np.ones(len(train), bool))):
                pool = pool & (near.spread > 0)  # a frame of no spread: left out
                if which.any():
                    # the rows framed apart, as local_gaussian_fill frames them: BLAS's
                    # products over fewer rows may round otherwise
                    frame = _frame(np.where(pattern[:, None], 0.0, poses[rows[which]]),
                                   ~pattern)
                    filled = local(near.train[pool], frame[0].reshape(which.sum(), -1),
                                   np.repeat(~pattern, 2),
                                   distances=near.distances[which][:, pool])
                    _put_back_into(out, rows[which], pattern, filled, frame, poses)
    return out


def file_gaussian(complete, poses, missing, *, rounds=GAUSSIAN_ROUNDS, ridge=GAUSSIAN_RIDGE,
                  augment=None):
    """:func:`gaussian_fill` on a file: the Gaussian of its complete poses, then
    `rounds` times refitted on them and the incomplete poses as last filled.

    Parameters
    ----------
    complete : ndarray (n, N, 2)
        The file's complete poses (n >= 2).
    poses : ndarray (m, N, 2)
        Its incomplete poses (values at missing joints ignored).
    missing : ndarray of bool (m, N)
    rounds : int, default GAUSSIAN_ROUNDS
    ridge : float, default GAUSSIAN_RIDGE
    augment : callable, optional
        ``augment(draws)`` -> the Gaussian's draws (e.g. the draws and their
        mirror images, :func:`sparseedm.file_atoms.mirror_images`); default
        the draws themselves.

    Returns
    -------
    filled : ndarray (m, N, 2)
        `poses` filled by the last Gaussian.
    train : ndarray (n + m', N, 2)
        That Gaussian's draws before `augment`: `complete` and the filled poses
        with a frame (:func:`gaussian_fill` fills other poses with them, as a
        file's chunks are).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> complete = rng.normal(size=(100, 14, 2))
    >>> missing = np.zeros((20, 14), bool); missing[:, 5] = True
    >>> filled, train = file_gaussian(complete, rng.normal(size=(20, 14, 2)), missing)
    >>> filled.shape, train.shape
    ((20, 14, 2), (120, 14, 2))
    """
    complete = np.asarray(complete, dtype=float)
    augment = (lambda draws: draws) if augment is None else augment
    filled, train = gaussian_fill(augment(complete), poses, missing, ridge=ridge), complete
    for _ in range(rounds):
        train = np.concatenate([complete, filled[np.isfinite(filled).all(axis=(1, 2))]])
        filled = gaussian_fill(augment(train), poses, missing, ridge=ridge)
    return filled, train
