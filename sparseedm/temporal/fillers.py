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
* :func:`fill_kalman` -- a constant-velocity Kalman filter and
  Rauch-Tung-Striebel smoother per joint coordinate, its noise fitted to the
  track by maximum likelihood (:func:`fit_kalman_noise`); past a joint's
  last observation it carries the joint on at a decaying velocity;
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
  joint-frames as unfilled). :func:`fill_pca` and :func:`fill_kalman`
  follow the same rule;
  :func:`sparse_filler` fills them from the other joints of each frame.

References
----------
Gløersen, Ø., Federolf, P. (2016). Predicting missing marker trajectories in
human motion data using marker intercorrelations. PLoS ONE 11(3): e0152616.

Rauch, H. E., Tung, F., Striebel, C. T. (1965). Maximum likelihood estimates of
linear dynamic systems. AIAA Journal 3(8): 1445-1450.

Examples
--------
>>> import numpy as np
>>> poses = np.zeros((5, 14, 2)); poses[:, 4, 0] = [0, 1, 2, 3, 4]
>>> missing = np.zeros((5, 14), bool); missing[1:4, 4] = True
>>> fill_linear(poses, missing, np.arange(5))[:, 4, 0]
array([0., 1., 2., 3., 4.])
"""

from __future__ import annotations

from numbers import Real
from typing import NamedTuple

import numpy as np
from scipy.interpolate import Akima1DInterpolator, CubicSpline

from .._validation import Interval, Options, validate_params
from ..exceptions import ParameterError, PoseError

__all__ = ["check_track", "fill_linear", "fill_cubic", "fill_akima", "fill_pca",
           "fill_kalman", "fit_kalman_noise", "KalmanNoise", "sparse_filler", "FILLERS"]


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

    Parameters
    ----------
    poses : array_like, shape (T, N, 2)
        One track's poses, in frame order.
    missing : array_like of bool, shape (T, N)
        The joints to fill.
    frames : array_like of int, shape (T,)
        The poses' frame numbers, sorted and unique.

    Returns
    -------
    ndarray (T, N, 2)
        Observed joints as given; a joint never observed is NaN.

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

    Parameters
    ----------
    poses : array_like, shape (T, N, 2)
        One track's poses, in frame order.
    missing : array_like of bool, shape (T, N)
        The joints to fill.
    frames : array_like of int, shape (T,)
        The poses' frame numbers, sorted and unique.

    Returns
    -------
    ndarray (T, N, 2)
        Observed joints as given; a joint never observed is NaN.

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
        0.999, 0.9999, 0.99999 tried: ``benchmarks/video_select_pca.py``,
        ``benchmarks/results-video-pca.json``).
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
        coef = np.linalg.lstsq(V[obs], (M[i, obs] - mean[obs]) / scale, rcond=PCA_RCOND)[0]
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


#: a frame's coefficients ignore the directions its observed coordinates see less than
#: this fraction of (relative singular values of the kept components restricted to
#: them): a component that lives on the hidden coordinates alone is not guessed from
#: noise, which sent short real clips' fills 10^9 body heights away
PCA_RCOND = 0.05

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


# --- the constant-velocity Kalman smoother -------------------------------------------

#: how fill_kalman / fit_kalman_noise share the noise across a track's 28 series
KALMAN_POOLING = ("clip", "joint", "coordinate")
#: the ratio q / r is searched over 10 ** LOG_RATIO_RANGE (frames^-3)
LOG_RATIO_RANGE = (-6.0, 6.0)
#: fill_kalman's default persistence of the velocity past a joint's last observation
KALMAN_PERSISTENCE = 20.0


class KalmanNoise(NamedTuple):
    """The noise of :func:`fill_kalman`'s model, per joint and coordinate.

    Parameters
    ----------
    q : ndarray (N, 2)
        Process noise: the white acceleration's intensity, px² / frame³.
    r : ndarray (N, 2)
        Observation noise variance, px².
    log_likelihood : float
        The innovations log-likelihood at (q, r), summed over the series
        (the first two observations of each series set its diffuse start and
        are not counted).
    """

    q: np.ndarray
    r: np.ndarray
    log_likelihood: float


def fit_kalman_noise(poses, missing, frames, *, pooling="clip"):
    """Fit :func:`fill_kalman`'s noise (q, r) to a track by maximum likelihood.

    Each joint coordinate is a constant-velocity series (the model of
    :func:`fill_kalman`). For a given ratio ``q / r`` the observation noise
    ``r`` that maximises the innovations likelihood is the mean squared
    standardised innovation, so the search is over the ratio alone: every
    quarter decade over :data:`LOG_RATIO_RANGE`, all filtered in one pass
    (vectorised over the candidates and the series), then a parabola through
    the best three.

    Parameters
    ----------
    poses, missing, frames
        One track (see the module docstring).
    pooling : {"clip", "joint", "coordinate"}, default "clip"
        What shares one (q, r): the whole track (every joint and coordinate),
        each joint (its x and y), or each joint coordinate. A joint observed
        fewer than three times (in a unit with no other) gets NaN: there is
        nothing to fit, and a line through two points does not depend on it.

    Returns
    -------
    KalmanNoise

    Examples
    --------
    Constant-velocity motion with white acceleration of intensity 0.5 seen
    with noise of variance 4:

    >>> rng = np.random.default_rng(0)
    >>> T = 3000
    >>> acc = rng.normal(scale=np.sqrt(0.5), size=(T, 14, 2))
    >>> truth = np.cumsum(np.cumsum(acc, axis=0), axis=0)
    >>> seen = truth + rng.normal(scale=2.0, size=truth.shape)
    >>> noise = fit_kalman_noise(seen, np.zeros((T, 14), bool), np.arange(T))
    >>> round(float(noise.q[0, 0]), 1), round(float(noise.r[0, 0]), 1)
    (0.5, 4.1)
    """
    validate_params("fit_kalman_noise", dict(pooling=pooling),
                    {"pooling": [Options(KALMAN_POOLING)]})
    poses, missing, t = check_track(poses, missing, frames)
    return _fit_noise(_series(poses), ~_series(missing), t, pooling)


def fill_kalman(poses, missing, frames, *, q=None, r=None, pooling="clip",
                persistence=KALMAN_PERSISTENCE):
    """Constant-velocity Kalman filter and Rauch-Tung-Striebel smoother, per joint coordinate.

    Each joint coordinate is a position and a velocity over time: from frame
    to frame (``dt`` frames apart: frames may skip) the position moves by
    ``dt`` times the velocity, both disturbed by white acceleration noise of
    intensity ``q`` (covariance ``q [[dt³/3, dt²/2], [dt²/2, dt]]``), and the
    position is observed with noise of variance ``r``; a missing frame is a
    prediction only. Each series starts at its first observation (the
    position there observed, the velocity diffuse). The forward filter and
    the backward RTS pass give each missing joint-frame the mean of its
    position given every observed frame of the track: between observations
    a cubic smoothing spline whose stiffness is ``q / r``.

    With `q` and `r` not given, they are fitted on the track by maximum
    likelihood (:func:`fit_kalman_noise`); only their ratio matters for the
    filled values.

    Parameters
    ----------
    poses, missing, frames
        One track (see the module docstring).
    q, r : float, optional
        Process and observation noise (px² / frame³, px²), both or neither.
    pooling : {"clip", "joint", "coordinate"}, default "clip"
        As :func:`fit_kalman_noise`, when q and r are fitted.
    persistence : float, default 20
        Before a joint's first and after its last observation, frames: the
        smoothed velocity there carries the joint on, decaying with this
        time constant, so that ``d`` frames out it has moved
        ``v persistence (1 - exp(-d / persistence))`` (at most ``v``
        times `persistence`). 0 holds the first / last smoothed position, as
        the splines hold theirs; ``inf`` extrapolates at constant velocity
        (the model's own prediction, far off over long gaps). 20 was chosen
        on validation data: the mocap clips of
        ``benchmarks/video_protocols.py`` and Bonn PoseTrack's validation
        videos (``benchmarks/video_kalman.py``), where it beats holding at
        every gap length and constant velocity on real video's 30-frame gaps.

    Returns
    -------
    ndarray (T, N, 2)
        Observed joints as given (not smoothed); a joint never observed is NaN.

    Examples
    --------
    A gap in a straight line at constant speed is filled exactly:

    >>> poses = np.zeros((8, 14, 2)); poses[:, 3, 0] = 5.0 * np.arange(8)
    >>> missing = np.zeros((8, 14), bool); missing[2:6, 3] = True
    >>> fill_kalman(poses, missing, np.arange(8), q=1.0, r=1.0)[:, 3, 0]
    array([ 0.,  5., 10., 15., 20., 25., 30., 35.])
    """
    params = dict(q=q, r=r, pooling=pooling, persistence=persistence)
    validate_params("fill_kalman", params, {
        "q": [Interval(Real, 0, None, closed="neither"), None],
        "r": [Interval(Real, 0, None, closed="neither"), None],
        "pooling": [Options(KALMAN_POOLING)],
        "persistence": [Interval(Real, 0, None), Options((np.inf,))]})
    if (q is None) != (r is None):
        raise ParameterError("fill_kalman: give both q and r, or neither (fitted)")
    poses, missing, t = check_track(poses, missing, frames)
    y, observed = _series(poses), ~_series(missing)
    ratio = np.full(y.shape[1], q / r) if q is not None else \
        _fit_ratio(y, observed, t, pooling)
    smooth = _smooth(y, observed, t, ratio, float(persistence))
    filled = poses.reshape(len(t), -1)
    hidden = ~observed
    filled[hidden] = smooth[hidden]
    return filled.reshape(poses.shape)


def _series(a):
    """(T, N, 2) -> (T, 2N) series; a (T, N) mask -> the same per coordinate."""
    return a.reshape(len(a), -1) if a.ndim == 3 else np.repeat(a, 2, axis=1)


def _units(n_series, pooling):
    """(S, U) one-hot: which pooling unit each series belongs to."""
    unit = {"clip": np.zeros(n_series, int), "joint": np.arange(n_series) // 2,
            "coordinate": np.arange(n_series)}[pooling]
    return np.eye(unit.max() + 1)[unit]


def _diffuse(ratio, t):
    """The initial velocity variance, in units of r: far above what two observations
    leave (r / dt² + q dt / 3), far below where rounding would swamp the update."""
    return 1e6 * (1.0 + ratio * (t[-1] - t[0] + 1.0))


def _forward(y, observed, t, ratio, store=False):
    """The Kalman filter over time, every series (and candidate ratio) at once.

    In units of r (r = 1, q = `ratio`); `ratio` is (S,) or (G, S). A series
    starts at its first observation (position observed, velocity diffuse)
    and is exact from its second on (:func:`_start`). Without `store`, returns
    the likelihood's terms: sums of e² / F and log F, and counts, over each
    series' third and later observations. With `store`, returns the
    predicted and filtered states (p, v and the covariance a, b, c), each
    (5, T, *ratio.shape).
    """
    T, shape = len(t), ratio.shape
    K = _diffuse(ratio, t)
    p, v, b = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    a, c = np.ones(shape), np.ones(shape)
    square, logdet = np.zeros(shape), np.zeros(shape)
    before = np.cumsum(observed, axis=0) - observed      # observations before each frame
    first, second = observed & (before == 0), observed & (before == 1)
    update = (observed & (before > 1)).astype(float)
    starting, updating = (first | second).any(axis=1), update.any(axis=1)
    cols = np.arange(y.shape[1])
    start_row = np.argmax(observed, axis=0)
    y0 = np.where(observed, y, 0.0)
    y_first, t_first = y0[start_row, cols], t[start_row]
    states = (np.empty((5, T) + shape), np.empty((5, T) + shape)) if store else None
    for k in range(T):
        if k:
            dt = t[k] - t[k - 1]
            qdt = ratio * dt
            a = a + dt * (2.0 * b + dt * c) + qdt * (dt * dt / 3.0)
            b = b + dt * c + qdt * (dt / 2.0)
            c = c + qdt
            p = p + dt * v
        if store:
            states[0][:, k] = p, v, a, b, c
        if starting[k]:
            p, v, a, b, c = _start(first[k], second[k], y0[k], t[k] - t_first, y_first,
                                   (p, v, a, b, c), ratio, K)
        if updating[k]:
            F = a + 1.0
            e = y0[k] - p
            g = update[k] / F
            if not store:
                square += g * e * e
                logdet += update[k] * np.log(F)
            ag, ge = a * g, g * e
            p, v = p + a * ge, v + b * ge
            a, b, c = a * (1.0 - ag), b * (1.0 - ag), c - b * b * g
        if store:
            states[1][:, k] = p, v, a, b, c
    return states if store else (square, logdet, update.sum(axis=0))


def _start(first, second, y, h, y_first, state, ratio, K):
    """The state where a series starts: at its first observation the position
    observed, the velocity diffuse (variance `K`); at its second, the exact
    diffuse posterior of the two (a line through them), `h` frames apart."""
    p, v, a, b, c = state
    with np.errstate(divide="ignore", invalid="ignore"):
        exact = (y, (y - y_first) / h, 1.0, 1.0 / h, (2.0 + ratio * h ** 3 / 3.0) / h ** 2)
    start = (y, 0.0, 1.0, 0.0, K)
    return tuple(np.where(second, e, np.where(first, s, x))
                 for x, s, e in zip((p, v, a, b, c), start, exact))


def _backward(predicted, filtered, t):
    """The RTS pass: smoothed positions and velocities (T, S) from the stored states."""
    ps, vs = filtered[0].copy(), filtered[1].copy()
    for k in range(len(t) - 2, -1, -1):
        dt = t[k + 1] - t[k]
        pp, vp, ap, bp, cp = predicted[:, k + 1]
        _, _, af, bf, cf = filtered[:, k]
        dp, dv = ps[k + 1] - pp, vs[k + 1] - vp
        det = ap * cp - bp * bp
        w0, w1 = (cp * dp - bp * dv) / det, (ap * dv - bp * dp) / det  # P_pred^-1 d
        ps[k] += (af + dt * bf) * w0 + bf * w1  # + P_filt F' P_pred^-1 d
        vs[k] += (bf + dt * cf) * w0 + cf * w1
    return ps, vs


def _smooth(y, observed, t, ratio, persistence):
    """Smoothed positions (T, S); before a series' first and after its last
    observation carried on by its velocity there (fill_kalman's `persistence`);
    NaN for a series never observed."""
    predicted, filtered = _forward(y, observed, t, ratio, store=True)
    ps, vs = _backward(predicted, filtered, t)
    cols = np.arange(y.shape[1])
    first = np.argmax(observed, axis=0)
    last = len(t) - 1 - np.argmax(observed[::-1], axis=0)
    for edge, outside in ((first, t[:, None] < t[first]), (last, t[:, None] > t[last])):
        ps = np.where(outside, ps[edge, cols] + _drift(t[:, None] - t[edge], persistence)
                      * vs[edge, cols], ps)
    ps[:, ~observed.any(axis=0)] = np.nan
    return ps


def _drift(d, persistence):
    """How far a unit velocity decaying with time constant `persistence` carries
    in `d` frames (signed): d for inf, 0 for 0."""
    if persistence == 0 or np.isinf(persistence):
        return d * float(persistence != 0)
    return -persistence * np.expm1(-np.abs(d) / persistence) * np.sign(d)


def _fit_ratio(y, observed, t, pooling):
    """Each series' maximum-likelihood q / r, (S,): every quarter decade over
    :data:`LOG_RATIO_RANGE` in one pass, then a parabola through the best three.
    A unit with fewer than three observations per series gets any ratio: one or
    two points are held or joined by a line whatever it is."""
    units = _units(y.shape[1], pooling)
    lo, hi = LOG_RATIO_RANGE
    step = 0.25
    grid = np.arange(lo, hi + step / 2, step)
    ll = _grid_loglik(y, observed, t, grid[:, None] * np.ones(units.shape[1]), units)
    i = np.argmax(ll, axis=0)
    j = np.clip(i, 1, len(grid) - 2)
    cols = np.arange(units.shape[1])
    left, mid, right = ll[j - 1, cols], ll[j, cols], ll[j + 1, cols]
    curvature = left - 2.0 * mid + right
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where((i == j) & (curvature < 0),
                         0.5 * step * (left - right) / curvature, 0.0)
    return 10.0 ** (units @ (grid[i] + np.clip(shift, -step, step)))


def _grid_loglik(y, observed, t, logs, units):
    """The profile log-likelihood (G, U) of each unit at each candidate log10 ratio (G, U)."""
    terms = _forward(y, observed, t, 10.0 ** (logs @ units.T))
    return _pooled(terms, units).loglik


class _Pooled(NamedTuple):
    loglik: np.ndarray  # profile log-likelihood per unit (r at its best), 0 without counts
    r: np.ndarray       # the best r per unit (units of the data), NaN without counts
    count: np.ndarray   # innovations counted per unit


def _pooled(terms, units):
    """The likelihood's terms summed per pooling unit, r profiled out."""
    square, logdet, count = (x @ units for x in terms)
    has = count > 0
    r = np.where(has, np.maximum(square, np.finfo(float).tiny) / np.maximum(count, 1), np.nan)
    loglik = np.where(has, -0.5 * (count * (np.log(2 * np.pi * np.where(has, r, 1.0)) + 1.0)
                                   + logdet), 0.0)
    return _Pooled(loglik, r, count)


def _fit_noise(y, observed, t, pooling):
    """KalmanNoise of the series (T, S), fitted."""
    ratio = _fit_ratio(y, observed, t, pooling)
    units = _units(y.shape[1], pooling)
    pooled = _pooled(_forward(y, observed, t, ratio), units)
    r = pooled.r[np.argmax(units, axis=1)]  # NaN for a unit with nothing counted
    n_joints = y.shape[1] // 2
    return KalmanNoise((ratio * r).reshape(n_joints, 2), r.reshape(n_joints, 2),
                       float(pooled.loglik[pooled.count > 0].sum()))


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
           "pca": fill_pca, "kalman": fill_kalman, "sparse": sparse_filler()}
