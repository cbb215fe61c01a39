"""How sure: a calibrated 90 % radius for every filled joint.

:func:`joint_uncertainty` gives, for each joint of a recovery's result, the
radius (in the input's units, pixels) of a circle centred on the filled joint
that holds the true joint 9 times in 10: 0 for an observed joint, NaN for a
joint of a refused pose. :func:`sparseedm.recover` puts it in
``RecoveryResult.uncertainty``.

The radius is the pose's size times a log-linear function of what the model
knows about each filled joint (:func:`joint_features`)::

    radius = max(noise, size * exp(coef . features) * conformal)

with one set of coefficients per way of filling (:data:`CALIBRATION`):

* ``per_frame`` (a photo, or a pose outside any track, coded over the
  shipped dictionary, alone or with the file's complete poses as extra
  atoms): the number of hidden joints of the pose, the joint's hops along
  the skeleton to the nearest observed joint, the disagreement between the
  recovered distances and the placed joint, the lasso's residual on the
  observed distances, and the joint's depth in the skeleton (bones from the
  neck: a wrist 3, a hip 1);
* ``adapted``, ``file_atoms`` and ``local_ridge``: the same features for
  the other per-frame paths (``summary()["adaptation"]["path"]``,
  :func:`coding_way`): over a dictionary adapted (and self-trained) on the
  file, and over the file's own complete poses as the only atoms, by the
  lasso (the default path's exemplars, :mod:`sparseedm.exemplars`) or by
  ``preset="fast"``'s local ridge. ``file_atoms`` also reads the file's own
  measured error: when the default path's check recovered held-back complete
  poses of the file (hidden as its incomplete poses are) before taking that
  path, the log of their hidden joints' mean error over the pose's size
  (``checked`` 1, ``log_held_error``; ``settings["held_err_path"]`` of
  ``res.adaptation``); a file of such alike people as video frames errs far
  less than a file of strangers, which the joint's own features do not see;
  a file the check did not measure (from 2,000 complete poses) gets the
  way's ``"unchecked"`` rule, without that error (:data:`UNCHECKED_FEATURES`).
  ``adapted`` likewise reads the error the adaptation's guard measured for
  the adapted dictionary on held-back complete poses of the file
  (``guarded`` 1, ``log_guard_error``; ``res.adaptation.err_adapted``, the
  Mix Err_ave in %): without it the rule covered 0.98 of the hidden joints
  of Bonn frames (the same people's neighbouring frames among the file's
  poses) with circles 5-7 times their mean error; an adaptation without a
  guard gets the way's ``"unchecked"`` rule. Each path has its own
  coefficients: a
  dictionary adapted and self-trained on the file agrees with its own
  fills whatever their error, over the file's own poses the errors depend
  on how alike the file's people are, and a ridge's residual is not a
  lasso's, so one rule for every path covered them unevenly. ``adapted``
  leaves the residual out (a dictionary learned on the file's poses fits
  their observed distances however well it fills);
* ``temporal`` (a joint filled across time): the distance in frames to the
  nearest frame where the joint is observed in its track, whether it is
  observed on one side only (a clip's end) or never, the hops, the depth,
  the hidden joints of the frame and the track's noise level relative to
  its size (the per-frame prior's weight is left out: it is a function of
  the same distance, and with it the radius would not grow steadily into a
  gap).

``size`` is the pose's root-mean-square distance of its joints to their
centroid (per pose for ``per_frame``; the track's median for ``temporal``).
``noise`` is what the observed joints say of the data's own noise: in time,
the 90 % radius of the observed joints' frame-to-frame jitter (their second
differences); per frame, the lasso's root-mean-square misfit of the observed
distances; never less than :data:`MIN_RELATIVE` of the size. The
coefficients are a 0.9-quantile regression of ``log(error / size)`` on
validation data of real people and mocap, and ``conformal`` the factor that
brings each way's coverage to 90 % on those data
(``studies/uncertainty/calibrate.py`` re-fits the table in one command).

Another level than 90 %: :func:`radius_at` scales the radius by the factor
measured for it, per way of filling (``CALIBRATION[way]["levels"]``, at
:data:`LEVELS`): the real people's validation quantiles of a filled joint's
error over its 90 % radius. The errors have heavier tails than a 2D
Gaussian's, whose rule held 0.63-0.98 of the joints at 50 %. Given the
result the radii belong to (or :func:`joint_ways`), each joint gets its
way's factors; radii alone (read from a file) the factors pooled over every
way (``CALIBRATION["pooled"]``).
"""

from __future__ import annotations

from numbers import Real

import numpy as np

from ._validation import Interval, frame_numbers, validate_params
from .edm import vector_to_edm
from .exceptions import ParameterError
from .normalize import rms_radius
from .skeleton import SKELETON_14, skeleton_hops

__all__ = ["joint_uncertainty", "joint_features", "uncertainty_rule", "coding_way",
           "CALIBRATION", "FEATURES", "UNCHECKED_FEATURES", "CHECKED_FLAG", "MIN_RELATIVE", "NOISE_RADIUS",
           "UNSOLVED_LOG_RESIDUAL", "radius_at", "joint_ways", "LEVELS"]

#: the features each way of filling uses, in the order of its coefficients
FEATURES = {
    "per_frame": ("const", "log_missing", "hops", "depth", "log_disagreement",
                  "log_residual"),
    "adapted": ("const", "log_missing", "hops", "depth", "log_disagreement",
                "log_guard_error"),
    "file_atoms": ("const", "log_missing", "hops", "depth", "log_disagreement",
                   "log_residual", "log_held_error"),
    "local_ridge": ("const", "log_missing", "hops", "depth", "log_disagreement",
                    "log_residual"),
    "temporal": ("const", "log_frames", "one_sided", "never", "hops", "depth",
                 "log_missing", "log_noise"),
}

#: the features of a way's ``"unchecked"`` entry: its joints in files whose error
#: on held-back poses was not measured (:data:`CHECKED_FLAG` 0)
UNCHECKED_FEATURES = {"file_atoms": ("const", "log_missing", "hops", "depth",
                                     "log_disagreement", "log_residual"),
                      "adapted": ("const", "log_missing", "hops", "depth", "log_disagreement")}
#: the feature that says a way's file error was measured (1) or not (0): the
#: default path's check (``file_atoms``), the adaptation's guard (``adapted``)
CHECKED_FLAG = {"file_atoms": "checked", "adapted": "guarded"}

#: the coverage levels of the factors ``CALIBRATION[way]["levels"]`` (:func:`radius_at`)
LEVELS = (0.25, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99)

#: coefficients of log(radius / size) per way of filling, and the conformal
#: factor; fitted by ``studies/uncertainty/calibrate.py`` on validation data
#: (studies/uncertainty/calibration.json has the run's coverage per source);
#: ``"unchecked"``: the entry (features :data:`UNCHECKED_FEATURES`) of the way's
#: joints in files without a held-back error; ``"levels"``: the factors from the
#: 90 % radius to the radius at each of :data:`LEVELS` (:func:`radius_at`),
#: ``"pooled"`` those of every way together
CALIBRATION = {
    "per_frame": {"conformal": 1.1836,
        "coef": (2.8071, 0.4473, 0.2826, 0.2539, 0.3864, 0.9104),
        "levels": (0.2127, 0.37, 0.4462, 0.537, 0.6613, 1.0, 1.1336, 1.7477)},
    "adapted": {"conformal": 1.1187,
        "coef": (0.4341, 0.5787, 0.3197, 0.3363, -0.0129, 0.8181),
        "levels": (0.1418, 0.2818, 0.3586, 0.4555, 0.6099, 1.0, 1.2029, 2.0779),
        "unchecked": {"conformal": 1.3181,
                      "coef": (-1.7032, 0.3743, 0.4231, 0.2755, 0.0849)}},
    "file_atoms": {"conformal": 0.9998,
        "coef": (3.0178, 0.1843, 0.3024, 0.2605, 0.4772, 0.6809, 0.3898),
        "levels": (0.2059, 0.3687, 0.4493, 0.5518, 0.6981, 1.0, 1.2138, 1.9854),
        "unchecked": {"conformal": 1.0632,
                      "coef": (1.8037, 0.3945, 0.3829, 0.2546, 0.6612, 0.48)}},
    "local_ridge": {"conformal": 1.2582,
        "coef": (0.0552, 0.536, 0.5565, 0.3187, 0.3874, 0.3644),
        "levels": (0.1603, 0.2989, 0.3711, 0.4681, 0.5895, 1.0, 1.1154, 2.1188)},
    "temporal": {"conformal": 1.1385,
        "coef": (-3.5664, 0.72, 0.3725, 0.5261, 0.0021, 0.4354, 0.4058, 0.1828),
        "levels": (0.1492, 0.2825, 0.3656, 0.4716, 0.6388, 1.0, 1.2698, 2.3764)},
    "pooled": {"levels": (0.1636, 0.3116, 0.3914, 0.49, 0.6369, 1.0, 1.1916, 2.0469)},
}

#: log of the lasso residual a pose solved without a lasso (FConv) is given: the
#: median of the validation photos' (studies/uncertainty/calibrate.py); FConv's
#: own errors were not part of the calibration
UNSOLVED_LOG_RESIDUAL = -4.5
#: the radius never claims less than this fraction of the pose's size
MIN_RELATIVE = 0.01
#: a 2D isotropic Gaussian's 90 % radius in standard deviations, sqrt(2 ln 10)
NOISE_RADIUS = float(np.sqrt(2 * np.log(10)))
#: small numbers kept out of the logarithms
_EPS = 1e-4
_HUGE = np.finfo(float).max


def _hops(missing, parents=SKELETON_14.parents):
    """(n, N) hops along the skeleton from each joint to the nearest observed
    one (0 observed; N where nothing is observed)."""
    n, N = missing.shape
    bones = skeleton_hops(parents)
    hops = np.full((n, N), N)
    for k in range(N):  # observed joint k bounds every joint's hops
        hops = np.where(missing[:, k:k + 1], hops, np.minimum(hops, bones[:, k]))
    return hops


def _depth(parents=SKELETON_14.parents):
    """(N,) each joint's bones from the skeleton's root (the neck: 0; a wrist: 3)."""
    depth = np.zeros(len(parents), int)
    for j, p in enumerate(parents):
        k = p
        while k >= 0:
            depth[j] += 1
            k = parents[k]
    return depth


def _in_own_units(poses):
    """(poses centred and divided by their largest coordinate, that unit (n,)):
    what follows squares no huge number."""
    centred = poses - poses.mean(axis=1, keepdims=True)
    unit = np.abs(centred).max(axis=(1, 2))
    unit = np.where(np.isfinite(unit) & (unit > 0), unit, 1.0)
    return centred / unit[:, None, None], unit


def _pose_size(poses):
    """(n,) root-mean-square distance of a pose's joints to their centroid."""
    return rms_radius(poses, np.zeros(poses.shape[:2], bool))[1]


def _disagreement(missing, vectors, scale, poses):
    """(n, N) per filled joint of `poses` (finite): the root-mean-square
    difference between its placed distances to the observed joints and the
    recovered ones (EDM `vectors` times `scale`), in the poses' own units
    (:func:`_in_own_units`), and that unit (n,)."""
    own, unit = _in_own_units(poses)
    with np.errstate(invalid="ignore"):
        placed = np.linalg.norm(own[:, :, None] - own[:, None], axis=-1)
        wanted = vector_to_edm(np.nan_to_num(vectors) * (np.nan_to_num(scale) / unit)[:, None])
        diff = np.where(~missing[:, None, :], (placed - wanted) ** 2, 0.0)
        n_obs = np.maximum((~missing).sum(axis=1), 1)[:, None]
        return np.sqrt(diff.sum(axis=2) / n_obs), unit


def _time_layout(n, tracks, frames, read=None):
    """[(rows in frame order, their frames)] per track; rows whose frame is not
    a finite number are left out (`read`: the frames as the recovery read them)."""
    if read is None:
        values, reason = frame_numbers(frames, n)  # refused: NaN (its row is per frame)
        read = np.where(reason == "", values, np.nan)
    frames = read
    tracks = np.zeros(n, int) if tracks is None else np.asarray(tracks)
    try:
        _, tracks = np.unique(tracks, return_inverse=True)
    except TypeError:  # values numpy cannot order together: grouped by their text
        _, tracks = np.unique(tracks.astype(str), return_inverse=True)
    out = []
    finite = np.isfinite(frames)
    for t in np.unique(tracks[finite]):
        rows = np.flatnonzero((tracks == t) & finite)
        rows = rows[np.argsort(frames[rows], kind="stable")]
        out.append((rows, frames[rows]))
    return out


def _frames_to_observed(fr, observed):
    """(T, N) frames from each row to the nearest row where the joint is
    observed (inf: never) and (T, N) True where observations lie on one side only."""
    T, N = observed.shape
    dist = np.full((T, N), np.inf)
    one_sided = np.zeros((T, N), bool)
    for j in range(N):
        at = fr[observed[:, j]]
        if not len(at):
            continue
        k = np.searchsorted(at, fr)
        before = np.where(k > 0, fr - at[np.maximum(k - 1, 0)], np.inf)
        after = np.where(k < len(at), at[np.minimum(k, len(at) - 1)] - fr, np.inf)
        dist[:, j] = np.minimum(before, after)
        one_sided[:, j] = np.isinf(before) | np.isinf(after)
    return dist, one_sided


def _jitter(points, fr, observed):
    """A track's noise level (pixels, one number): the robust spread of the
    observed joints' second differences over consecutive frames, NaN if none."""
    steps = (np.diff(fr[:-1]) == 1) & (np.diff(fr[1:]) == 1)
    if not steps.any():
        return np.nan
    ok = observed[:-2] & observed[1:-1] & observed[2:] & steps[:, None]
    second = points[2:] - 2 * points[1:-1] + points[:-2]
    values = np.abs(second[ok]).ravel()
    if not len(values):
        return np.nan
    # a second difference of white noise has variance 6 sigma^2
    return float(np.median(values) / 0.6745 / np.sqrt(6))


def joint_features(result, tracks=None, frames=None):
    """The per-joint features the calibrated radius is computed from.

    Parameters
    ----------
    result : RecoveryResult
        What :func:`sparseedm.recover` returned (a ``TemporalResult`` when
        frames were given).
    tracks, frames : array_like (n,), optional
        The tracks and frames given to recover (the linked tracks when it
        linked them); None: poses on their own.

    Returns
    -------
    dict
        ``way`` (n, N) str: ``"temporal"``, the per-frame way
        (:func:`coding_way`) or ``""`` (observed or refused); ``size`` and
        ``noise`` (n, N) pixels; one (n, N) array per name of :data:`FEATURES`.
    """
    poses, missing = result.poses, result.missing
    n, N = missing.shape
    ok = np.asarray(result.ok) & np.isfinite(poses).all(axis=(1, 2))
    filled = missing & ok[:, None]
    way = joint_ways(result)
    safe = np.where(np.isfinite(poses), poses, 0.0)
    size = np.where(ok, _pose_size(safe), np.nan)
    n_missing = missing.sum(axis=1)
    residual = np.sqrt(2 * np.nan_to_num(result.objective) / np.maximum(
        N * (N - 1) / 2 - n_missing * (2 * N - n_missing - 1) / 2, 1))
    out = {"const": np.ones((n, N)), "log_missing": np.repeat(
        np.log(np.maximum(n_missing, 1))[:, None], N, axis=1).astype(float),
        "hops": _hops(missing).astype(float),
        "depth": np.repeat(_depth()[None].astype(float), n, axis=0)}
    noise = np.repeat((residual * np.nan_to_num(result.scale))[:, None], N, axis=1)
    rel = np.zeros((n, N))
    rows = np.flatnonzero(((way != "") & (way != "temporal")).any(axis=1))  # its users
    if len(rows):
        disagreement, unit = _disagreement(result.missing[rows], result.vectors[rows],
                                           result.scale[rows], safe[rows])
        rel[rows] = disagreement / np.where(size[rows] > 0, size[rows] / unit, 1.0)[:, None]
    out["log_disagreement"] = np.log(np.nan_to_num(rel) + _EPS)
    log_residual = np.where(np.isnan(result.objective), UNSOLVED_LOG_RESIDUAL,
                            np.log(residual + _EPS))
    out["log_residual"] = np.repeat(log_residual[:, None], N, axis=1)
    size = np.repeat(size[:, None], N, axis=1)
    out.update(_averaging_features(result, filled, size))
    time = _time_features(result, way, filled, safe, tracks, frames, size, noise)
    out.update(time)
    with np.errstate(invalid="ignore", divide="ignore"):
        out["log_noise"] = np.log(np.nan_to_num(noise / size) + _EPS)
    out.update(way=way, size=size, noise=noise)
    return out


def _averaging_features(result, filled, size):
    """What the result's record says was averaged (``RecoveryResult.averaged``
    and ``spread``, read as recorded, not re-derived): ``averaged`` (n, N) the
    answers averaged into the pose's after its path's own (0, 1, 2),
    ``rel_spread`` the distance between the answers averaged at the joint over
    the pose's size (0: none), ``log_complete`` the log of the file's complete
    poses (:attr:`~sparseedm.adaptation.AdaptationResult.n_complete`, 0 without),
    ``checked`` 1 when the default path's check measured the path's error on
    held-back complete poses and ``log_held_error`` the log of that error as a
    fraction of the pose's size (0 unchecked), ``guarded`` 1 when the file's
    poses were coded over a dictionary adapted on the file and its guard
    measured that dictionary's error on held-back complete poses
    (:attr:`~sparseedm.adaptation.AdaptationResult.err_adapted`, the Mix
    Err_ave in %) and ``log_guard_error`` the log of that error over 100
    (0 unguarded)."""
    n, N = filled.shape
    record = getattr(result, "averaged", None)
    count = np.zeros(n) if record is None else np.array(
        [len([k for k in str(t).split("; ") if k]) for t in record], float)
    spread = getattr(result, "spread", None)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.zeros((n, N)) if spread is None else np.nan_to_num(
            np.asarray(spread, float) / size, nan=0.0, posinf=0.0)
    adaptation = getattr(result, "adaptation", None)
    complete = getattr(adaptation, "n_complete", 0) or 0
    held = float(getattr(adaptation, "settings", {}).get("held_err_path", np.nan))
    checked = np.isfinite(held) and held > 0
    guard = float(getattr(adaptation, "err_adapted", np.nan)) \
        if getattr(adaptation, "adapted", False) else np.nan
    guarded = np.isfinite(guard) and guard > 0
    return {"averaged": np.repeat(count[:, None], N, axis=1),
            "rel_spread": np.where(filled, rel, 0.0),
            "log_complete": np.full((n, N), np.log1p(float(complete))),
            "checked": np.full((n, N), float(checked)),
            "log_held_error": np.full((n, N), np.log(held / 100) if checked else 0.0),
            "guarded": np.full((n, N), float(guarded)),
            "log_guard_error": np.full((n, N), np.log(guard / 100) if guarded else 0.0)}


def coding_way(result):
    """The way of filling of `result`'s poses coded one by one (outside time).

    Parameters
    ----------
    result : RecoveryResult

    Returns
    -------
    str
        ``"file_atoms"`` when the poses were coded over the file's own
        complete poses as the only atoms, or averaged over codes of them
        (:attr:`~sparseedm.adaptation.AdaptationResult.over_file_atoms`:
        :mod:`sparseedm.exemplars`), ``"local_ridge"`` when that
        was ``preset="fast"``'s path (its local ridge codes over them; another
        solver asked for with the preset is rated as the local ridge),
        ``"adapted"`` over a dictionary adapted to the file (path
        ``"adapted"``, an ensemble's members), else ``"per_frame"``.

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> pose = np.random.default_rng(0).normal(size=(14, 2))
    >>> pose[4] = np.nan
    >>> coding_way(sparseedm.recover(pose, adapt=False))
    'per_frame'
    """
    adaptation = getattr(result, "adaptation", None)
    if adaptation is None:
        return "per_frame"
    if adaptation.over_file_atoms:
        return "local_ridge" if adaptation.settings.get("preset") == "fast" else "file_atoms"
    return "adapted" if adaptation.path == "adapted" else "per_frame"


def _time_features(result, way, filled, safe, tracks, frames, size, noise):
    """The temporal features (and the track's size and noise written into
    `size` and `noise` for its time-filled joints)."""
    n, N = filled.shape
    log_frames = np.zeros((n, N))
    one_sided = np.zeros((n, N))
    never = np.zeros((n, N))
    weight = getattr(result, "prior_weight", None)
    prior = np.zeros((n, N)) if weight is None else np.nan_to_num(np.asarray(weight, float))
    temporal = way == "temporal"
    if frames is None or not temporal.any():
        return dict(log_frames=log_frames, one_sided=one_sided, never=never,
                    prior_weight=prior)
    observed = ~result.missing & np.isfinite(result.poses).all(axis=-1)
    for rows, fr in _time_layout(n, tracks, frames, getattr(result, "frames", None)):
        here = temporal[rows]
        if not here.any():
            continue
        dist, side = _frames_to_observed(fr, observed[rows])
        span = fr[-1] - fr[0] + 1
        log_frames[rows] = np.log1p(np.where(np.isinf(dist), span, dist))
        never[rows] = np.isinf(dist)
        one_sided[rows] = side & ~np.isinf(dist)
        ok = np.isfinite(size[rows, 0])
        track_size = np.median(size[rows, 0][ok]) if ok.any() else np.nan
        size[rows] = np.where(here, track_size, size[rows])
        sigma = _jitter(safe[rows], fr, observed[rows])
        if np.isfinite(sigma):
            noise[rows] = np.where(here, NOISE_RADIUS * sigma, noise[rows])
    return dict(log_frames=log_frames, one_sided=one_sided, never=never, prior_weight=prior)


def uncertainty_rule(features, calibration=None):
    """The radius (n, N) from :func:`joint_features`' output and a calibration.

    Parameters
    ----------
    features : dict
        :func:`joint_features`' output.
    calibration : dict, optional
        Shaped as :data:`CALIBRATION` (the default).

    Returns
    -------
    ndarray (n, N)
        The 90 % radius: 0 where no joint was filled, NaN on refused poses
        (where ``size`` is NaN).
    """
    calibration = CALIBRATION if calibration is None else calibration
    way, size = features["way"], features["size"]
    radius = np.where(np.isnan(size), np.nan, 0.0)
    for name, names in FEATURES.items():
        at = way == name
        if not at.any():
            continue
        entry = calibration[name]
        if "unchecked" in entry:  # files without a measured held-back error
            unchecked = at & (features[CHECKED_FLAG[name]] == 0)
            _radius_into(radius, features, unchecked, UNCHECKED_FEATURES[name],
                         entry["unchecked"])
            at &= ~unchecked
        _radius_into(radius, features, at, names, entry)
    return radius


def _radius_into(radius, features, at, names, entry):
    """`radius` at `at` by the rule `entry` over the features `names`."""
    if not at.any():
        return
    size = features["size"][at]
    x = np.stack([features[f][at] for f in names], axis=-1)
    relative = np.exp(x @ np.asarray(entry["coef"], float)) * entry["conformal"]
    floor = np.maximum(np.nan_to_num(features["noise"][at]), MIN_RELATIVE * size)
    with np.errstate(over="ignore"):  # a pose near float's limit: the largest radius
        radius[at] = np.minimum(np.maximum(floor, size * relative), _HUGE)


def joint_uncertainty(result, tracks=None, frames=None, calibration=None):
    """The calibrated 90 % radius of every joint of a recovery's result.

    Parameters
    ----------
    result : RecoveryResult
        What :func:`sparseedm.recover` returned.
    tracks, frames : array_like (n,), optional
        The tracks and frames the poses were recovered with.
    calibration : dict, optional
        Shaped as :data:`CALIBRATION` (the default).

    Returns
    -------
    ndarray (n, N) or None
        Pixels (the input's units): 0 for an observed joint, NaN for every
        joint of a refused pose, else the radius of the circle around the
        filled joint that holds the true joint with 90 % probability. None
        for poses of another layout than the 14 joints (no rule calibrated).

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> xs = [50, 50, 35, 30, 28, 65, 70, 72, 40, 40, 40, 60, 60, 60]
    >>> ys = [10, 30, 32, 55, 78, 32, 55, 78, 80, 115, 150, 80, 115, 150]
    >>> pose = np.column_stack([xs, ys]).astype(float)
    >>> pose[4] = np.nan                      # the right wrist, hidden
    >>> r = joint_uncertainty(sparseedm.recover(pose, adapt=False))
    >>> bool(r[0, 4] > 0), float(r[0, 0])
    (True, 0.0)
    """
    if np.shape(result.missing)[1] != SKELETON_14.num_joints:
        return None  # the rule's features and table are the 14-joint skeleton's
    with np.errstate(over="ignore", invalid="ignore"):  # poses near float's limits
        radius = uncertainty_rule(joint_features(result, tracks, frames), calibration)
    radius[~np.asarray(result.missing) & np.isfinite(radius)] = 0.0
    return radius


def joint_ways(result):
    """Each joint's way of filling: which rule of :data:`CALIBRATION` rated it.

    Parameters
    ----------
    result : RecoveryResult
        What :func:`sparseedm.recover` returned.

    Returns
    -------
    ndarray of str (n, N)
        ``"temporal"`` for a joint filled across time, else the poses' way
        (:func:`coding_way`) at a filled joint; ``""`` at an observed joint
        and on a refused pose.

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> pose = np.random.default_rng(0).normal(size=(14, 2))
    >>> pose[4] = np.nan
    >>> joint_ways(sparseedm.recover(pose, adapt=False))[0, 3:6].tolist()
    ['', 'per_frame', '']
    """
    poses, missing = result.poses, result.missing
    ok = np.asarray(result.ok) & np.isfinite(poses).all(axis=(1, 2))
    filled = missing & ok[:, None]
    way = np.where(filled, coding_way(result), "").astype(object)
    source = getattr(result, "source", None)
    if source is not None:
        way[filled & (source == "temporal")] = "temporal"
    return way.astype(str)


def _level_scale(level, table):
    """The factor from the 90 % radius to the `level` one by `table` (one factor per
    level of :data:`LEVELS`): log-linear in the Gaussian radius
    ``sqrt(-2 ln(1 - level))`` between the table's levels, that radius's shape
    beyond them."""
    z = np.log(np.sqrt(-2 * np.log1p(-np.asarray(LEVELS))))
    at = np.log(np.sqrt(-2 * np.log1p(-level)))
    logs = np.log(np.asarray(table, float))
    if at < z[0]:
        return float(np.exp(logs[0] + at - z[0]))
    if at > z[-1]:
        return float(np.exp(logs[-1] + at - z[-1]))
    return float(np.exp(np.interp(at, z, logs)))


def radius_at(uncertainty, level, way=None, calibration=None):
    """The radius at another coverage `level`, scaled from the 90 % one.

    The factor is the measured one: per way of filling, the quantiles of a
    filled joint's error over its 90 % radius on the validation data
    (``CALIBRATION[way]["levels"]`` at :data:`LEVELS`; the errors have
    heavier tails than a 2D Gaussian's), interpolated between those levels
    log-linearly in a 2D Gaussian's radius ``sqrt(-2 ln(1 - level))``, whose
    shape continues beyond them. 1 at 0.9, and growing with `level`.

    Parameters
    ----------
    uncertainty : array_like
        90 % radii (:attr:`RecoveryResult.uncertainty`, or read from a file).
    level : float
        In (0, 1).
    way : str, array_like of str or RecoveryResult, optional
        Whose factors: a way of filling (a name of :data:`FEATURES`), one per
        radius (shaped as `uncertainty`, as :func:`joint_ways` gives them;
        ``""``: the pooled factors), or the result the radii belong to (its
        :func:`joint_ways`). None: the factors pooled over every way
        (``CALIBRATION["pooled"]``), for radii whose way is not known.
    calibration : dict, optional
        Shaped as :data:`CALIBRATION` (the default).

    Returns
    -------
    ndarray
        Radii at `level` (0 stays 0, NaN stays NaN).

    Raises
    ------
    ParameterError
        `level` is not a number in (0, 1) or `way` names no way.

    Examples
    --------
    >>> float(radius_at(10.0, 0.9))
    10.0
    >>> bool(radius_at(10.0, 0.5) < radius_at(10.0, 0.8) < 10.0 < radius_at(10.0, 0.95))
    True
    """
    validate_params("radius_at", {"level": level},
                    {"level": [Interval(Real, 0, 1, closed="neither")]})
    calibration = CALIBRATION if calibration is None else calibration
    radii = np.asarray(uncertainty, float)
    if way is None or isinstance(way, str):
        return radii * _level_scale(level, _way_levels(way, calibration))
    if hasattr(way, "missing") and hasattr(way, "ok"):  # the RecoveryResult of the radii
        way = joint_ways(way)
    way = np.broadcast_to(np.asarray(way, str), radii.shape)
    scale = np.ones(radii.shape)
    for name in np.unique(way):
        scale[way == name] = _level_scale(level, _way_levels(name, calibration))
    return radii * scale


def _way_levels(name, calibration):
    """The level factors of way `name` in `calibration` (None or "": the pooled ones)."""
    if not name:
        name = "pooled"
    if name not in FEATURES and name != "pooled":
        raise ParameterError(f"radius_at: way must be one of {sorted(FEATURES)}, "
                             f"got {name!r}")
    return calibration[name]["levels"]
