"""Gap fillers for one track: the interface, and the fillers users already apply.

A **gap filler** is any function ``fill(poses, missing, frames) -> filled`` on
ONE track (one person over time):

``poses`` (T, N, 2) float
    Keypoints in pixels; the values of missing joints are ignored (they may
    be NaN).
``missing`` (T, N) bool
    True where a joint is to be filled.
``frames`` (T,) int
    Frame numbers, sorted and unique; they may skip (a skipped frame is a
    gap in time, and time is measured in frame numbers).

It returns ``filled`` (T, N, 2): observed joints exactly as given, missing
ones filled, or NaN where the filler has nothing to go on (see below). The
video evaluation (:mod:`sparseedm.temporal.evaluation`) runs any such
function; :data:`FILLERS` names the ones here.

The fillers users already apply, each per joint and per coordinate over time:

* :func:`fill_linear` -- linear interpolation (FreeMoCap's, pandas'
  ``interpolate()``);
* :func:`fill_cubic` -- a cubic spline through the observed frames
  (``scipy.interpolate.CubicSpline``, not-a-knot: DeepLabCut's ``spline``
  filter, Vicon Nexus' spline fill);
* :func:`fill_akima` -- Akima's spline (``scipy.interpolate.Akima1DInterpolator``),
  less prone to overshoot;
* :func:`fill_pca` -- PCA gap filling after Gløersen & Federolf (2016): each
  frame's missing coordinates predicted from its observed ones through the
  leading principal components of the clip's trajectory matrix (the
  correlations between joints);
* :func:`sparse_filler` -- per-frame sparseedm (:func:`sparseedm.recover` on
  the track's poses, time unused), as a filler.

Rules shared by the splines and linear interpolation:

* **Clip ends.** Before the first and after the last observed frame of a
  joint, the nearest observed value is **held** (constant): no tool above
  extrapolates a spline past its data (DeepLabCut and Vicon leave such gaps
  unfilled; holding is what a user then does). With one observed frame the
  joint is held there throughout; with two, cubic and Akima are linear.
* **A joint never observed in the track** is returned as NaN: the filler has
  nothing to go on, and the caller decides (the evaluation counts such
  joint-frames as unfilled). :func:`fill_pca` follows the same rule;
  :func:`sparse_filler` fills them from the other joints of each frame.

References
----------
Gløersen, Ø., Federolf, P. (2016). Predicting missing marker trajectories in
human motion data using marker intercorrelations. PLoS ONE 11(3): e0152616.

Examples
--------
>>> import numpy as np
>>> poses = np.zeros((5, 14, 2)); poses[:, 4, 0] = [0, 1, 2, 3, 4]
>>> missing = np.zeros((5, 14), bool); missing[1:4, 4] = True
>>> fill_linear(poses, missing, np.arange(5))[:, 4, 0]
array([0., 1., 2., 3., 4.])
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import Akima1DInterpolator, CubicSpline

from ..exceptions import PoseError

__all__ = ["check_track", "fill_linear", "fill_cubic", "fill_akima", "fill_pca",
           "sparse_filler", "FILLERS"]


def check_track(poses, missing, frames):
    """The three arguments of a gap filler, checked and as arrays.

    Parameters
    ----------
    poses : array_like, shape (T, N, 2)
    missing : array_like of bool, shape (T, N)
    frames : array_like of int, shape (T,), sorted and unique

    Returns
    -------
    poses : ndarray (T, N, 2) float64
        A copy, with NaN written into the missing joints.
    missing : ndarray (T, N) bool
    frames : ndarray (T,) float64
        The frame numbers, as the interpolators' time axis.

    Raises
    ------
    PoseError
        Naming the argument: wrong shapes, non-integer or unsorted or repeated
        frames, a non-finite observed coordinate.

    Examples
    --------
    >>> check_track(np.zeros((2, 14, 2)), np.zeros((2, 14), bool), [3, 3])
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.PoseError: frames must be sorted and unique (a track has one pose per frame); frame 3 repeats or goes back at position 1
    """
    poses = np.array(poses, dtype=float)
    missing = np.asarray(missing, dtype=bool)
    frames = np.asarray(frames)
    if poses.ndim != 3 or poses.shape[-1] != 2:
        raise PoseError(f"poses must have shape (T, N, 2), got {poses.shape}")
    if missing.shape != poses.shape[:2]:
        raise PoseError(f"missing must have shape {poses.shape[:2]}, got {missing.shape}")
    if frames.shape != poses.shape[:1]:
        raise PoseError(f"frames must have shape ({poses.shape[0]},), got {frames.shape}")
    if frames.dtype.kind not in "iu":
        if frames.dtype.kind != "f" or not np.all(np.isfinite(frames)) \
                or np.any(frames != np.round(frames)):
            raise PoseError(f"frames must be integers, got {frames.dtype} values")
    bad = np.flatnonzero(np.diff(frames) <= 0)
    if bad.size:
        raise PoseError("frames must be sorted and unique (a track has one pose per "
                        f"frame); frame {frames[bad[0] + 1]} repeats or goes back at "
                        f"position {bad[0] + 1}")
    if not np.all(np.isfinite(poses[~missing])):
        raise PoseError("poses has a NaN or infinite coordinate on a joint not marked missing")
    poses[missing] = np.nan
    return poses, missing, frames.astype(float)


def _per_joint(poses, missing, frames, interpolate):
    """Fill each joint's gaps with ``interpolate(t_obs, xy_obs, t_gap)`` and hold at ends."""
    poses, missing, t = check_track(poses, missing, frames)
    for j in range(poses.shape[1]):
        gap = missing[:, j]
        if not gap.any() or gap.all():
            continue
        obs = ~gap
        t_obs, xy = t[obs], poses[obs, j]
        inside = gap & (t > t_obs[0]) & (t < t_obs[-1])
        if inside.any():
            poses[inside, j] = interpolate(t_obs, xy, t[inside]) if len(t_obs) > 2 else \
                _linear(t_obs, xy, t[inside])
        poses[gap & (t < t_obs[0]), j] = xy[0]
        poses[gap & (t > t_obs[-1]), j] = xy[-1]
    return poses


def _linear(t_obs, xy, t_new):
    return np.stack([np.interp(t_new, t_obs, xy[:, k]) for k in range(xy.shape[1])], axis=-1)


def _cubic(t_obs, xy, t_new):
    return CubicSpline(t_obs, xy, axis=0, bc_type="not-a-knot")(t_new)


def _akima(t_obs, xy, t_new):
    return Akima1DInterpolator(t_obs, xy, axis=0)(t_new)


def fill_linear(poses, missing, frames):
    """Linear interpolation over time, per joint; ends held.

    Parameters
    ----------
    poses, missing, frames
        One track (see the module docstring).

    Returns
    -------
    ndarray (T, N, 2)
        Observed joints as given; a joint never observed is NaN.

    Examples
    --------
    >>> poses = np.zeros((4, 14, 2)); poses[:, 0, 1] = [10, 0, 0, 40]
    >>> missing = np.zeros((4, 14), bool); missing[1:3, 0] = True
    >>> fill_linear(poses, missing, [0, 1, 2, 3])[:, 0, 1]
    array([10., 20., 30., 40.])
    """
    return _per_joint(poses, missing, frames, _linear)


def fill_cubic(poses, missing, frames):
    """Cubic spline (not-a-knot) through each joint's observed frames; ends held.

    As DeepLabCut's ``spline`` filter and Vicon's spline fill: the spline
    through all observed frames of the joint, evaluated in its gaps. Two
    observed frames give a straight line, one a constant.

    Examples
    --------
    >>> t = np.arange(8.0)
    >>> poses = np.zeros((8, 14, 2)); poses[:, 2, 0] = t ** 3 - 2 * t
    >>> missing = np.zeros((8, 14), bool); missing[3:5, 2] = True
    >>> np.allclose(fill_cubic(poses, missing, t.astype(int))[:, 2, 0], t ** 3 - 2 * t)
    True
    """
    return _per_joint(poses, missing, frames, _cubic)


def fill_akima(poses, missing, frames):
    """Akima spline through each joint's observed frames; ends held.

    Akima's local cubic follows the data without the overshoot a global
    cubic spline can show near sharp turns; it reproduces straight lines.

    Examples
    --------
    >>> poses = np.zeros((6, 14, 2)); poses[:, 7, 0] = np.arange(6) * 3.0
    >>> missing = np.zeros((6, 14), bool); missing[2:4, 7] = True
    >>> fill_akima(poses, missing, np.arange(6))[:, 7, 0]
    array([ 0.,  3.,  6.,  9., 12., 15.])
    """
    return _per_joint(poses, missing, frames, _akima)


def fill_pca(poses, missing, frames, *, variance=0.9999, max_iter=200, tol=1e-6):
    """PCA gap filling of the track's trajectory matrix (Gløersen & Federolf 2016).

    The track is a matrix with one row per frame and one column per joint
    coordinate (T x 2N), normalised: each column centred on its mean, all
    divided by one overall standard deviation (so that a joint is not
    weighted by how little it moves). Its principal components are kept up
    to the fewest that explain `variance` of the variance (at most one less
    than the columns), and each frame's missing coordinates are predicted
    from its observed ones through them:

    * with at least :data:`MIN_COMPLETE_FRAMES` complete frames (no joint
      missing), as Gløersen & Federolf: the components are those of the
      complete frames, and each incomplete frame's coefficients are the
      least-squares fit of its observed coordinates;
    * otherwise (EM-PCA): gaps start from :func:`fill_linear` and are
      replaced by their reconstruction from the components of the whole
      filled matrix until they change by less than `tol` (relative) or
      `max_iter` rounds.

    Observed entries never change; gaps at clip ends are filled as interior
    ones (no holding): the prediction comes from the other joints of the
    frame and the correlations across the clip, not from time.

    Parameters
    ----------
    poses, missing, frames
        One track (see the module docstring); `frames` only orders it.
    variance : float, default 0.9999
        Fraction of the variance the kept components explain; chosen on the
        validation sequences of ``benchmarks/video_protocols.py`` (0.99,
        0.999, 0.9999, 0.99999 tried; see benchmarks/README.md).
    max_iter : int, default 200
    tol : float, default 1e-6

    Returns
    -------
    ndarray (T, N, 2)
        Observed joints as given; a joint never observed in the track is NaN.

    Examples
    --------
    A joint that moves as a fixed combination of two others is recovered
    through a gap in it:

    >>> t = np.linspace(0, 6, 60)
    >>> poses = np.zeros((60, 14, 2))
    >>> poses[:, :, 0] = np.sin(t)[:, None] * np.arange(14)
    >>> poses[:, :, 1] = np.cos(t)[:, None] * np.arange(14)[::-1]
    >>> missing = np.zeros((60, 14), bool); missing[20:40, 5] = True
    >>> err = fill_pca(poses, missing, np.arange(60)) - poses
    >>> bool(np.abs(err).max() < 1e-3)
    True
    """
    filled = fill_linear(poses, missing, frames)
    missing = np.asarray(missing, dtype=bool)
    never = missing.all(axis=0)
    cols = np.repeat(~never, 2)  # joint-coordinate columns with data
    T, N = missing.shape
    M = filled.reshape(T, 2 * N)[:, cols]
    holes = np.repeat(missing, 2, axis=1)[:, cols]
    if not holes.any() or T < 2:
        return filled
    complete = ~holes.any(axis=1)
    if complete.sum() >= MIN_COMPLETE_FRAMES:
        _pca_project(M, holes, M[complete], variance)
    else:
        _pca_em(M, holes, _pca_rank(M, variance), max_iter, tol)
    out = filled.reshape(T, 2 * N)
    out[:, cols] = M
    return out.reshape(T, N, 2)


def _normalised_svd(C):
    mean = C.mean(axis=0)
    scale = np.std(C - mean) or 1.0
    U, s, Vt = np.linalg.svd((C - mean) / scale, full_matrices=False)
    return mean, scale, U, s, Vt


def _pca_project(M, holes, complete, variance):
    """Fill `M`'s holes in place from the components of its `complete` rows."""
    mean, scale, _, _, Vt = _normalised_svd(complete)
    V = Vt[:_pca_rank(complete, variance)].T
    for i in np.flatnonzero(holes.any(axis=1)):
        obs, gap = ~holes[i], holes[i]
        coef = np.linalg.lstsq(V[obs], (M[i, obs] - mean[obs]) / scale, rcond=None)[0]
        M[i, gap] = V[gap] @ coef * scale + mean[gap]


def _pca_em(M, holes, rank, max_iter, tol):
    """Fill `M`'s holes in place by rank-`rank` reconstruction until they settle."""
    for _ in range(int(max_iter)):
        mean, scale, U, s, Vt = _normalised_svd(M)
        recon = (U[:, :rank] * s[:rank]) @ Vt[:rank] * scale + mean
        change = np.linalg.norm(recon[holes] - M[holes])
        M[holes] = recon[holes]
        if change <= tol * max(np.linalg.norm(M[holes]), 1.0):
            break


#: fill_pca chooses its rank on the complete frames when the track has this many
MIN_COMPLETE_FRAMES = 10


def _pca_rank(M, variance):
    """The fewest principal components of the rows of `M` explaining `variance`,
    at most one less than the columns or the rows (a full rank would keep every
    initial fill as it is)."""
    Z = M - M.mean(axis=0)
    s = np.linalg.svd(Z, compute_uv=False)
    energy = np.cumsum(s ** 2) / max(np.sum(s ** 2), np.finfo(float).tiny)
    rank = int(np.searchsorted(energy, variance) + 1)
    return max(1, min(rank, M.shape[1] - 1, M.shape[0] - 1))


def sparse_filler(dictionary=None, **recover_options):
    """Per-frame sparseedm as a gap filler: :func:`sparseedm.recover` on the track.

    Each frame is recovered on its own from its observed joints (time is
    not used). A frame recover refuses (e.g. too few observed joints) comes
    back NaN in its missing joints.

    Parameters
    ----------
    dictionary : Dictionary, str or path, optional
        As :func:`sparseedm.recover`; None is the shipped default.
    **recover_options
        Passed to :func:`sparseedm.recover` (its defaults otherwise).

    Returns
    -------
    callable
        ``fill(poses, missing, frames) -> filled``.

    Examples
    --------
    >>> fill = sparse_filler()
    >>> callable(fill)
    True
    """
    def fill(poses, missing, frames):
        from ..recovery import recover

        poses, missing, _ = check_track(poses, missing, frames)
        filled = recover(poses, missing, dictionary=dictionary, **recover_options).poses
        filled[~missing] = poses[~missing]
        return filled

    fill.__name__ = "fill_sparse"
    fill.__doc__ = "Per-frame sparseedm (sparse_filler) on one track."
    return fill


#: the fillers above by name (``"sparse"`` is per-frame sparseedm with defaults)
FILLERS = {"linear": fill_linear, "cubic": fill_cubic, "akima": fill_akima,
           "pca": fill_pca, "sparse": sparse_filler()}
