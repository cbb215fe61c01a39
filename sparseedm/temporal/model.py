"""The temporal model of one segment: time and the pose model, blended by weight.

Every joint of a segment (one track, consecutive frames) is one trajectory of
:func:`sparseedm.temporal.smoothing.smooth_trajectory`: observed frames fixed,
penalties ``acceleration`` and ``jerk`` on its second and third differences,
and the per-frame sparse answer as a prior whose weight grows with the
distance ``d`` (frames) to the joint's nearest observation,

    w(d) = clip((d - ramp_start) / (ramp_full - ramp_start), 0, 1)

times a confidence (1 for a certified per-frame answer, ``inaccurate`` for
one whose duality gap stayed above tolerance, 0 where it was refused). Near
observations (short gaps) the answer is the smoothest curve through them, a
spline; deep inside long gaps and past a clip's ends it follows the pose
model. Why: time is the better evidence next to an observation, the pose model
far from one.

The rest of the module refines that blend: per-frame answers are computed
only where they carry weight, on every ``prior_stride``-th frame
(:func:`needs_prior`, :func:`prior_frames`, :func:`spread_prior`); each joint
is smoothed relative to its parent's trajectory, so a hidden wrist follows
its elbow (:func:`reference_trajectories`, :func:`coupling`); noisy
observations become data of a weight instead of exact anchors
(:func:`observation_weight`); still joints are filled by time alone
(:func:`still_runs`, on the line between their neighbours: :func:`held`),
filled runs are joined to their observed neighbours
(:func:`joined`; a run observed on one side only takes a damped first step,
:func:`damped_ends`), keypoints that repeat their previous frame's are expected
to have repeated in the runs too (:func:`repeat_rate`, :func:`repeated`)
and each segment tests how far to trust its prior
(:func:`probe_mask`, :func:`clip_trust`). :func:`fill_segment` runs it all.

The constants were chosen on validation sequences across sources; the
penalties and the prior are squared pixels, so the settings do not depend on
the image's scale (they do depend on the frame rate). How they were chosen,
and what each refinement changed, is in the documentation:
``docs/explanation/method.md`` ("Video: the temporal model") and
``docs/explanation/settings.md`` ("The temporal model").
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from ..exceptions import ParameterError
from ..skeleton import SKELETON_14
from .carried import carried_prior
from .smoothing import smooth_trajectory
from .tracks import distance_to_observed

__all__ = ["TemporalSettings", "prior_weights", "needs_prior", "prior_frames",
           "spread_prior", "reference_trajectories", "coupling", "observation_noise",
           "body_extent", "observation_weight", "segment_settings", "free_runs",
           "still_runs", "joined", "damped_ends", "held", "repeat_rate", "repeated",
           "fill_segment", "probe_settings", "probe_mask", "clip_trust", "probe_errors",
           "ProbeScore", "choose_trust", "prior_scale", "time_filled", "TRUST_LEVELS",
           "FUSED_POOL", "carries", "choose_carry"]


@dataclass(frozen=True)
class TemporalSettings:
    """The temporal model's constants (see the module docstring).

    Parameters
    ----------
    acceleration : float
        The acceleration penalty ``lam`` (the prior's full weight is 1).
    jerk : float
        The penalty on third differences.
    ramp_start, ramp_full : float
        Distances (frames) to the nearest observation where the prior's weight
        starts to grow and where it reaches 1.
    inaccurate : float
        Confidence of a per-frame answer whose duality gap is above tolerance.
    prior_stride : int
        Per-frame answers are computed on every ``prior_stride``-th frame of
        a stretch of frames that needs them (and its last frame); the frames
        between take the answers, and their confidences, interpolated linearly
        (:func:`prior_frames`, :func:`spread_prior`). 1: every frame. The
        default 4 asks the per-frame model for 3.5x fewer frames at 0.1 % of
        the error on the validation sequences
        (``studies/temporal/selection_temporal_stride.json``).
    relative : bool
        Smooth each joint relative to its parent's trajectory (see the
        module docstring); False: every trajectory on its own.
    denoise : bool
        Where the observed coordinates carry white noise (a detector's
        jitter) above ``noise_floor`` of the body's extent
        (:func:`observation_weight`), treat them as data of weight
        ``(prior_error * extent / noise)^2`` instead of exact anchors, so the
        gaps are not bent by the jitter of their neighbouring frames (the
        observed joints are still returned exactly as given). Clean input
        (motion capture, a smoothed track) stays exact.
    noise_floor : float
        Estimated noise, as a fraction of the body's extent, below which the
        observations are exact anchors.
    prior_error : float
        Typical error of a per-frame answer, as a fraction of the body's
        extent: the scale the observations' weight is set against.
    noisy_acceleration : float
        The acceleration penalty where the observations are data (noisy
        input, :func:`observation_weight`): a detector's or an annotator's
        keypoints want a stiffer curve than clean ones.
    noisy_jerk : float
        The penalty on third differences where the observations are data:
        0, the acceleration penalty alone. A jerk penalty keeps a spline
        through exact anchors from overshooting; a curve that passes beside
        noisy keypoints has no such overshoot, and the penalty only slows its
        turns (on Bonn PoseTrack's validation clips 0 instead of the clean
        ``jerk`` lowered the error by 2-3 % at 3-, 10- and 30-frame gaps and
        by up to 1.5 % on transplanted runs, and the excess jump at gap edges
        from 0.764 to 0.751 px; ``studies/real_video/select_join.py``).
    edge_decay : float
        Frames over which a filled run takes on the offset between an
        observed neighbour and the smoothed curve there (:func:`joined`):
        the first and last filled frames continue the observed ones.
        0: not joined.
    end_step, end_decay : float
        Where the observations are data (noisy input), a run with one
        observed side (it reaches the segment's first or last frame) keeps
        ``end_step`` of its displacement from that observation at the first
        filled frame, the share growing back to 1 as
        ``1 - (1 - end_step) exp(-(d - 1) / end_decay)`` at ``d`` frames from
        it (:func:`damped_ends`): the smoothed curve's velocity there is read
        from one side only, through noisy keypoints. 1: not damped. On Bonn
        PoseTrack's validation clips, one per call (8 mask seeds), 0.8 over 1
        frame lowered the excess jump at those runs' edges, and with it the
        mean over all edges by 10 % (gaps and transplanted runs), and the
        error at 3-frame gaps by 0.9 %, no bin rising by more than 0.1 %;
        clean keypoints are never damped
        (``studies/real_video/select_edges.py``).
    still : float
        A joint whose observed frames within :data:`STILL_FRAMES` of a run's
        both ends stay within this fraction of the body's extent is still
        there: time alone fills the run (:func:`still_runs`). 0: never.
    hold_still : bool
        Fill still runs on the straight line between their observed
        neighbours (:func:`held`); False: the smoothed curve without the prior.
    repeats : bool
        Where the keypoints repeat their previous frame's coordinates exactly
        (an annotator or a tracker holding a point), expect a hidden joint to
        have been held at its observed neighbour as often as its observed
        frames were (:func:`repeat_rate`, :func:`repeated`); input
        without repeats is unchanged. On Bonn PoseTrack's validation clips
        (19 % of steps repeat) it lowered the excess jump at gap edges from
        0.751 to 0.589 px and the error by up to 1.2 %, no bin rising by 0.2 %
        (``studies/real_video/select_join.py``).
    probe : bool
        Test the per-frame prior on each segment's own observed joints and
        scale its weight by what the test shows (:func:`probe_mask`,
        :func:`clip_trust`); False: full trust, no extra per-frame answers.
    fusion : bool
        Where the observations are noisy (data, not anchors:
        :func:`observation_weight`), time is uncertain from the first hidden
        frame on: there the prior weighs from the first free frame (no ramp,
        :func:`segment_settings`), and its weight is scaled per track by the
        error the probes measure in its per-frame answers
        (:func:`prior_scale`). Clean input (motion capture) keeps the ramp.
        Off by default: on Bonn PoseTrack's validation clips it moved the
        error by -3 % (3-frame gaps) to +3 % (transplanted runs of 6-15
        frames), no bin by 20 %, at 1.8 times the seconds
        (``studies/real_video/select_fusion.py``); with the carried prior
        (``carry``) and ``fusion_share`` 1 every bin fell by 1-7 %, but
        CMU's validation self-occlusions with 1 % jitter rose by 7 % (8
        sequences; 2 % on 16), and a per-frame prior 5 % off, not carried,
        then makes the fill step at gap edges beyond the truth's step and
        the noise (``studies/real_video/select_edges.py``).
    fusion_share : float
        Share of the measured variance ratio :func:`prior_scale` takes: a
        per-frame answer's error persists over neighbouring frames (lag-one
        correlation 0.83 on Bonn PoseTrack's validation clips), so the answers
        of a run are worth fewer independent measurements than frames.
    ramp_floor : float
        The prior's weight at free frames where the ramp is below it (before
        the confidence and the trust): 0 for clean input; a fused segment's
        is its track's :func:`prior_scale` (1 while it is being measured,
        :func:`segment_settings`).
    carry : float
        Where the observations are noisy (:func:`carries`: real keypoints),
        a joint observed somewhere in the segment takes as its prior, instead
        of the per-frame answer, its position carried from its nearest
        observed frames by its nearest observed neighbours in the skeleton
        (:func:`sparseedm.temporal.carried.carried_prior`), those frames
        weighted by ``exp(-distance / carry)`` (frames), at full trust, unless
        the track's probes find the per-frame answers nearer their hidden
        observations (:func:`choose_carry`); a joint never observed keeps the
        per-frame answer. 0: the per-frame answers alone. On Bonn PoseTrack's
        validation clips, one per call, it lowered the error over transplanted
        invisibility runs of joints seen elsewhere in the clip from 5.44 to
        4.29 % of the body size (runs of 16-45 frames 8.97 to 6.57) and at
        30-frame gaps from 6.03 to 5.72; clean motion capture is unchanged and
        with 1 % jitter moved by -0.5 % (gaps) and +1.0 % (self-occlusion)
        (``studies/real_video/select_prior.py``).
    carry_floor : float
        Where a joint is carried (``carry``), its carried placement weighs
        at least this much from the first hidden frame on (the ramp still
        takes it to 1 far from an observation): next to its observed
        neighbours the placement they carry is better evidence than time
        alone, and it needs no per-frame answer. 0: the ramp alone. Off by
        default: 1 lowered Bonn PoseTrack's validation 3-frame gaps by 7.9 %
        (other bins level or lower), but CMU's self-occlusions with 1 %
        jitter rose by 3 % (8 sequences) and 11 +- 8 % (16)
        (``studies/real_video/select_edges.py``).
    never_mirror : bool
        A joint hidden in every frame of its track (only the pose model
        places it) takes, in the per-frame answers, its mirror image's answer
        weighed in per pose as ``recover(mirror="auto")`` weighs it
        (:func:`sparseedm._recovery_base.mirror_weights`); the other joints
        keep the per-frame answer. On Bonn PoseTrack's validation clips, one
        per call, the error of those joints over transplanted invisibility
        runs fell from 13.48 to 12.92 % of the body size, the seen joints'
        4.290 to 4.286, at 1.08 times the seconds; motion capture, where no
        joint is hidden for a whole sequence, is unchanged
        (``studies/real_video/select_prior.py``). False: the per-frame
        answers alone.
    """

    acceleration: float = 30.0
    jerk: float = 300.0
    ramp_start: float = 6.0
    ramp_full: float = 30.0
    inaccurate: float = 0.25
    prior_stride: int = 4
    relative: bool = True
    denoise: bool = True
    noise_floor: float = 0.002
    prior_error: float = 0.03
    noisy_acceleration: float = 100.0
    noisy_jerk: float = 0.0
    edge_decay: float = 3.0
    end_step: float = 0.8
    end_decay: float = 1.0
    still: float = 0.04
    hold_still: bool = True
    repeats: bool = True
    probe: bool = True
    fusion: bool = False
    fusion_share: float = 0.25
    ramp_floor: float = 0.0
    carry: float = 3.0
    carry_floor: float = 0.0
    never_mirror: bool = True

    def __post_init__(self):
        check_settings(self)


#: TemporalSettings' fields that are switches; the others are numbers
_SWITCHES = ("relative", "denoise", "hold_still", "repeats", "probe", "fusion",
             "never_mirror")
#: fields that are fractions in [0, 1]
_FRACTIONS = ("inaccurate", "fusion_share", "ramp_floor", "end_step")


def check_settings(settings):
    """Refuse TemporalSettings a fill cannot use: a switch that is not a bool, a
    number that is not finite and >= 0, a fraction outside [0, 1], a
    ``prior_stride`` that is not an integer >= 1, a ramp that ends before it
    starts (:class:`~sparseedm.exceptions.ParameterError`, naming the field).

    Parameters
    ----------
    settings : TemporalSettings

    Examples
    --------
    >>> TemporalSettings(ramp_start=10, ramp_full=5)
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: TemporalSettings: ramp_full (5) must be at least ramp_start (10)
    """
    for name, value in vars(settings).items():
        if name in _SWITCHES:
            if not isinstance(value, (bool, np.bool_)):
                raise ParameterError(f"TemporalSettings: {name} must be True or False, "
                                     f"got {value!r}")
        elif name == "prior_stride":
            if isinstance(value, (bool, np.bool_)) or not isinstance(
                    value, (int, np.integer)) or value < 1:
                raise ParameterError(f"TemporalSettings: prior_stride must be an integer "
                                     f">= 1, got {value!r}")
        elif (isinstance(value, (bool, np.bool_)) or not isinstance(
                value, (int, float, np.integer, np.floating))
              or not np.isfinite(value) or value < 0):
            raise ParameterError(f"TemporalSettings: {name} must be a finite number >= 0, "
                                 f"got {value!r}")
        elif name in _FRACTIONS and value > 1:
            raise ParameterError(f"TemporalSettings: {name} must be at most 1, got {value!r}")
    if settings.ramp_full < settings.ramp_start:
        raise ParameterError(f"TemporalSettings: ramp_full ({settings.ramp_full}) must be at "
                             f"least ramp_start ({settings.ramp_start})")


DEFAULT_SETTINGS = TemporalSettings()


def _ramp(distance, settings):
    span = max(settings.ramp_full - settings.ramp_start, 1e-9)
    return np.clip((distance - settings.ramp_start) / span, settings.ramp_floor, 1.0)


def needs_prior(free, settings=DEFAULT_SETTINGS):
    """Frames (T,) where some unknown joint gives a per-frame answer weight.

    Parameters
    ----------
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray of bool (T,)
        True at the frames that need a per-frame answer.
    """
    w = _ramp(distance_to_observed(free), settings)
    return ((w > 0) & free).any(axis=1)


def _runs(need):
    """Indices of the True frames of `need` and the id of the run each is in."""
    idx = np.flatnonzero(need)
    run = np.concatenate([[0], np.cumsum(np.diff(idx) != 1)]) if len(idx) else idx
    return idx, run


def prior_frames(free, settings=DEFAULT_SETTINGS):
    """Frames (T,) whose per-frame answer is computed: every
    ``settings.prior_stride``-th frame of each run of :func:`needs_prior`
    frames, counted from the run's first, and the run's last frame.

    Parameters
    ----------
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray of bool (T,)
        True at the frames whose per-frame answer is computed.

    Examples
    --------
    >>> free = np.zeros((40, 1), bool); free[5:35] = True
    >>> s = TemporalSettings(ramp_start=6, prior_stride=4)
    >>> np.flatnonzero(prior_frames(free, s)).tolist()
    [11, 15, 19, 23, 27, 28]
    """
    return _strided(needs_prior(free, settings), int(settings.prior_stride))


def _strided(need, stride):
    """:func:`prior_frames` from the :func:`needs_prior` frames `need`."""
    if stride <= 1:
        return need
    idx, run = _runs(need)
    first = np.flatnonzero(np.diff(run, prepend=-1) != 0)
    last = np.append(first[1:] - 1, len(idx) - 1) if len(idx) else first
    keep = (idx - idx[first][run]) % stride == 0
    keep[last] = True
    out = np.zeros_like(need)
    out[idx[keep]] = True
    return out


def spread_prior(free, prior, confidence, settings=DEFAULT_SETTINGS):
    """Per-frame answers and confidences interpolated onto the frames that
    :func:`prior_frames` skipped (from the nearest answered frames of the
    same run on either side; NaN and 0 where either side has none).

    Returns new ``(prior, confidence)``; unchanged when ``prior_stride`` is 1.

    Parameters
    ----------
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    prior : ndarray (T, N, 2)
        Per-frame answers, NaN at the frames without one.
    confidence : ndarray (T,)
        Confidence of each frame's answer, 0 where there is none.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    prior : ndarray (T, N, 2)
        The answers, the skipped frames filled by interpolation.
    confidence : ndarray (T,)
        The confidences, interpolated the same way.
    """
    if int(settings.prior_stride) <= 1:
        return prior, confidence
    need = needs_prior(free, settings)  # once: prior_frames would compute it again
    idx, run = _runs(need)
    target = ~_strided(need, int(settings.prior_stride))[idx]
    have = ~target & np.isfinite(prior[idx]).all(axis=(1, 2))
    src, src_run = idx[have], run[have]
    t, t_run = idx[target], run[target]
    if not len(t) or not len(src):
        return prior, confidence
    k = np.clip(np.searchsorted(src, t), 1, len(src) - 1)
    lo, hi = src[k - 1], src[k]
    ok = (src_run[k - 1] == t_run) & (src_run[k] == t_run) & (lo < t) & (t < hi)
    frac = np.where(ok, (t - lo) / np.maximum(hi - lo, 1), 0.0)
    prior, confidence = prior.copy(), confidence.copy()
    prior[t] = np.where(ok[:, None, None], (1 - frac)[:, None, None] * prior[lo]
                        + frac[:, None, None] * prior[hi], np.nan)
    confidence[t] = np.where(ok, (1 - frac) * confidence[lo] + frac * confidence[hi], 0.0)
    return prior, confidence


def prior_weights(free, confidence, settings=DEFAULT_SETTINGS):
    """Weights (T, N) of the per-frame answers: ramp of the distance times confidence.

    Parameters
    ----------
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    confidence : ndarray (T,)
        Confidence of each frame's per-frame answer, 0 where there is none.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray (T, N)
        The prior's weight at each joint-frame, 0 at the observed ones.
    """
    return _ramp(distance_to_observed(free), settings) * confidence[:, None] * free


def reference_trajectories(filled, parents=None):
    """Each joint's reference for relative smoothing: its parent's trajectory.

    Parameters
    ----------
    filled : ndarray (T, N, 2)
        A segment's trajectories (the first pass of :func:`fill_segment`).
    parents : sequence of int, optional
        Parent of each joint, -1 at the root; default the 14-joint skeleton's.

    Returns
    -------
    ndarray (T, N, 2)
        The parent's trajectory; the root's reference is the mean of its
        children that have children (the shoulders and hips). A reference
        that is not finite in every frame is zero (the joint is smoothed on
        its own).

    Examples
    --------
    >>> filled = np.arange(14.0)[None, :, None] * np.ones((3, 14, 2))
    >>> ref = reference_trajectories(filled)
    >>> ref[0, :, 0].tolist()[:5]    # neck: mean of joints 2, 5, 8, 11
    [1.0, 6.5, 1.0, 2.0, 3.0]
    """
    parents = np.asarray(SKELETON_14.parents if parents is None else parents)
    children = [np.flatnonzero(parents == j) for j in range(len(parents))]
    ref = np.zeros_like(filled)
    for j, parent in enumerate(parents):
        if parent >= 0:
            ref[:, j] = filled[:, parent]
        else:
            trunk = [c for c in children[j] if len(children[c])] or list(children[j])
            if trunk:
                ref[:, j] = filled[:, trunk].mean(axis=1)
    ref[:, ~np.isfinite(ref).all(axis=(0, 2))] = 0.0
    return ref


def coupling(values, free, reference):
    """Share ``beta_j`` in [0, 1] of its reference's acceleration each joint
    follows: least squares of the joint's observed second differences on the
    reference's, over the frames where the joint is observed three in a row
    (0 for a joint with fewer than 3 such frames or nothing free).

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints.
    reference : ndarray (T, N, 2)
        Each joint's reference trajectory (:func:`reference_trajectories`).

    Returns
    -------
    ndarray (N,)
        Each joint's share ``beta_j``.

    Examples
    --------
    A joint moving with its parent plus a straight line shares all of it:

    >>> t = np.arange(10.0)
    >>> ref = np.zeros((10, 1, 2)); ref[:, 0, 0] = np.sin(t)
    >>> values = ref + 0.5 * t[:, None, None]
    >>> free = np.zeros((10, 1), bool); free[4:6] = True
    >>> coupling(values, free, ref).round(6).tolist()
    [1.0]
    """
    seen = _observed_runs(free, 3)
    with np.errstate(invalid="ignore"):  # free frames may hold anything, NaN too
        d2x = np.where(seen[..., None], np.diff(values, n=2, axis=0), 0.0)
        d2r = np.where(seen[..., None], np.diff(reference, n=2, axis=0), 0.0)
    cross = np.einsum("tnk,tnk->n", d2x, d2r)
    power = np.einsum("tnk,tnk->n", d2r, d2r)
    beta = np.divide(cross, power, out=np.zeros_like(power), where=power > 0)
    return np.where((seen.sum(axis=0) >= 3) & free.any(axis=0), np.clip(beta, 0.0, 1.0), 0.0)


def observation_noise(values, free):
    """Standard deviation (pixels) of white noise on the observed coordinates.

    For white noise of variance s^2 the third differences ``d_t`` have lag-1
    autocovariance ``-15 s^2``, while a smooth motion's are positively
    correlated: ``s^2 = max(0, -mean(d_t . d_{t+1}) / 30)`` over the frames
    where a joint is observed five in a row (both coordinates pooled), so
    motion is not mistaken for noise. NaN with fewer than 10 such products.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).

    Returns
    -------
    float
        The estimated standard deviation, NaN when fewer than 6 frames or 10
        usable third-difference pairs.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(400.0)
    >>> clean = np.stack([np.sin(t / 9), np.cos(t / 7)], -1)[:, None, :] * 50
    >>> free = np.zeros((400, 1), bool)
    >>> float(observation_noise(clean, free)) < 0.05
    True
    >>> noisy = clean + rng.normal(scale=2.0, size=clean.shape)
    >>> 1.8 < observation_noise(noisy, free) < 2.2
    True
    """
    T = len(values)
    if T < 6:
        return np.nan
    seen = _observed_runs(free, 5)
    with np.errstate(invalid="ignore"):
        d3 = np.diff(values, n=3, axis=0)
        prod = (d3[:-1] * d3[1:]).sum(axis=-1)[seen]
    if prod.size < 10:
        return np.nan
    return float(np.sqrt(max(0.0, -prod.mean() / 30.0)))


def _observed_runs(free, k):
    """(T - k + 1, N): True at frame t where the joint is observed in frames t .. t+k-1
    (where its (k-1)-th difference at t reads observations only)."""
    run = ~free[:len(free) - k + 1]
    for i in range(1, k):
        run = run & ~free[i:len(free) - k + 1 + i]
    return run


def body_extent(values, free):
    """Median over frames of the observed joints' vertical extent (pixels).

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).

    Returns
    -------
    float
        The median extent over the frames with at least two observed joints,
        NaN when there is none.
    """
    y = np.where(free, np.nan, values[..., 1])
    ok = (~free).sum(axis=1) >= 2
    if not ok.any():
        return np.nan
    return float(np.median(np.nanmax(y[ok], axis=1) - np.nanmin(y[ok], axis=1)))


def observation_weight(values, free, settings=DEFAULT_SETTINGS):
    """Weight of the observed coordinates as data, or None: exact anchors.

    None unless ``settings.denoise`` and the segment's
    :func:`observation_noise` exceeds ``settings.noise_floor`` times its
    :func:`body_extent`; then ``(settings.prior_error * extent / noise)^2``
    (the prior's weight is 1, so the weight is the ratio of the per-frame
    answers' variance to the observations').

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    float or None
        The observations' weight, or None when they are exact anchors.
    """
    if not settings.denoise:
        return None
    noise, extent = observation_noise(values, free), body_extent(values, free)
    if not (np.isfinite(noise) and np.isfinite(extent) and extent > 0) \
            or noise <= settings.noise_floor * extent:
        return None
    return (settings.prior_error * extent / noise) ** 2


def segment_settings(values, free, settings=DEFAULT_SETTINGS):
    """The settings one segment is filled with (``settings.fusion``).

    Where the observations are noisy (:func:`observation_weight` is not
    None) the smoothed curve passes beside them, and time's own error at a
    hidden frame is of the order of the noise from the first hidden frame
    on: the per-frame prior then weighs there too, at least
    ``ramp_floor`` (the ramp still takes it to 1 deep inside long runs).
    A segment whose ``ramp_floor`` is not set yet gets 1 (every free frame
    then asks for a per-frame answer and its probes measure the prior);
    :func:`sparseedm.temporal.recover.recover_temporal` fills it with its
    track's :func:`prior_scale`. Clean observations keep the ramp alone: next
    to an exact anchor the spline is nearly exact.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    TemporalSettings
        `settings`, or a copy with ``ramp_floor`` 1.

    Examples
    --------
    >>> t = np.arange(60.0)
    >>> clean = np.stack([np.sin(t / 9), np.cos(t / 7)], -1)[:, None, :] * 50
    >>> clean = np.repeat(clean, 3, axis=1) + [[0, 0], [10, 40], [0, 90]]
    >>> free = np.zeros((60, 3), bool)
    >>> fused = TemporalSettings(fusion=True)
    >>> segment_settings(clean, free, fused).ramp_floor
    0.0
    >>> noisy = clean + np.random.default_rng(0).normal(scale=2.0, size=clean.shape)
    >>> segment_settings(noisy, free, fused).ramp_floor, segment_settings(noisy, free).ramp_floor
    (1.0, 0.0)
    """
    if not settings.fusion or settings.ramp_floor > 0 \
            or observation_weight(values, free, settings) is None:
        return settings
    return replace(settings, ramp_floor=1.0)


#: observed frames on each side of a run that :func:`still_runs` reads
STILL_FRAMES = 5


def free_runs(free):
    """Each joint's runs of free frames: (joint, first, stop) rows, ``stop``
    one past the last frame.

    Parameters
    ----------
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).

    Returns
    -------
    ndarray of int (R, 3)
        One ``(joint, first, stop)`` row per run, by joint then frame.

    Examples
    --------
    >>> free = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], bool)
    >>> free_runs(free).tolist()
    [[0, 1, 3], [1, 0, 2]]
    """
    T, N = free.shape
    pad = np.zeros((1, N), np.int8)
    edges = np.diff(np.concatenate([pad, free.astype(np.int8), pad]), axis=0)
    starts, stops = np.nonzero(edges.T == 1), np.nonzero(edges.T == -1)
    return np.stack([starts[0], starts[1], stops[1]], axis=1) if len(starts[0]) \
        else np.zeros((0, 3), int)


def still_runs(values, free, settings=DEFAULT_SETTINGS):
    """(T, N) bool: the free frames of runs between two still stretches.

    A run inside the segment is still when the joint's observed positions in
    the :data:`STILL_FRAMES` frames before it and after it (the observed ones
    among them, at least two a side) all lie within ``settings.still`` times
    the :func:`body_extent` of their mean: a resting foot or hand. Such a run
    needs no pose model (which may drag it away); time alone keeps it still.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray of bool (T, N)
        True at the free frames that time alone fills.
    """
    out = np.zeros(free.shape, bool)
    extent = body_extent(values, free)
    if not settings.still or not np.isfinite(extent):
        return out
    T, k, tol = len(free), STILL_FRAMES, settings.still * extent
    for j, a, b in free_runs(free):
        if a == 0 or b == T:
            continue
        sides = [np.flatnonzero(~free[lo:hi, j]) + lo for lo, hi in
                 ((max(a - k, 0), a), (b, min(b + k, T)))]
        if min(len(i) for i in sides) < 2:
            continue
        pts = values[np.concatenate(sides), j]
        if np.linalg.norm(pts - pts.mean(axis=0), axis=1).max() <= tol:
            out[a:b, j] = True
    return out


def joined(filled, values, free, settings=DEFAULT_SETTINGS):
    """`filled` with every run of free frames joined to its observed ends.

    Where the observations are data rather than anchors (noisy input) the
    smoothed curve passes beside them; the run then takes on the offset
    ``values - filled`` of each observed neighbour, in full at the frame next
    to it and fading over ``settings.edge_decay`` frames (times the share of
    the run nearer that side), so the filled frames continue the observed
    motion instead of jumping to the smoothed curve.

    Parameters
    ----------
    filled : ndarray (T, N, 2)
        The smoothed segment (:func:`fill_segment`'s trajectories).
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray (T, N, 2)
        A copy of `filled` with the observed offsets spread into each run.
    """
    out = filled.copy()
    T = len(free)
    if settings.edge_decay <= 0:
        return out
    tau = float(settings.edge_decay)
    for j, a, b in free_runs(free):
        t = np.arange(a, b)
        share = ((b - t) / (b - a + 1), (t - a + 1) / (b - a + 1)) \
            if a > 0 and b < T else (1.0, 1.0)
        for edge, near, part in ((a - 1, t - a, share[0]), (b, b - 1 - t, share[1])):
            if 0 <= edge < T:
                offset = values[edge, j] - filled[edge, j]
                out[a:b, j] += (part * np.exp(-near / tau))[:, None] * offset
    return out


def damped_ends(filled, values, free, settings=DEFAULT_SETTINGS):
    """`filled` with every run that has one observed side (it reaches the
    segment's first or last frame) brought towards that observation: at ``d``
    frames from it the displacement keeps the share
    ``1 - (1 - settings.end_step) exp(-(d - 1) / settings.end_decay)``
    (``end_step`` at the first filled frame, back to 1 a few frames on).
    Past a segment's end the smoothed curve runs on with the velocity it read
    from one side only, through noisy keypoints; its first step is damped.

    Parameters
    ----------
    filled : ndarray (T, N, 2)
        The filled segment (joined to its observations, :func:`joined`).
    values : ndarray (T, N, 2)
        The segment's coordinates (read at the frame next to each such run).
    free : ndarray of bool (T, N)
        The segment's unknown joints.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray (T, N, 2)
        A copy of `filled`; runs with two observed sides or none unchanged.

    Examples
    --------
    >>> values = np.zeros((5, 1, 2)); free = np.zeros((5, 1), bool); free[2:] = True
    >>> filled = np.zeros((5, 1, 2)); filled[2:, 0, 0] = [1.0, 2.0, 3.0]
    >>> s = TemporalSettings(end_step=0.5, end_decay=0.0)
    >>> damped_ends(filled, values, free, s)[2:, 0, 0].tolist()
    [0.5, 2.0, 3.0]
    """
    out = filled.copy()
    keep = float(settings.end_step)
    if keep >= 1.0:
        return out
    T = len(free)
    for j, a, b in free_runs(free):
        if (a == 0) == (b == T):  # observed on both sides, or on neither
            continue
        edge = b if a == 0 else a - 1
        d = np.abs(np.arange(a, b) - edge) - 1.0
        fade = (np.exp(-d / settings.end_decay) if settings.end_decay > 0
                else (d == 0).astype(float))
        share = 1.0 - (1.0 - keep) * fade
        out[a:b, j] = values[edge, j] + share[:, None] * (filled[a:b, j] - values[edge, j])
    return out


def held(filled, values, still):
    """`filled` with every still run (:func:`still_runs`) on the straight line
    between its two observed neighbours: a joint at rest on both sides stays
    at rest, joined to both ends, instead of following the smoothed curve,
    whose velocity at the run's edges comes from the noise and the motion
    before and after the rest.

    Parameters
    ----------
    filled : ndarray (T, N, 2)
        The smoothed segment.
    values : ndarray (T, N, 2)
        The segment's coordinates (read at the frames next to each still run,
        which are observed).
    still : ndarray of bool (T, N)
        The still runs' frames (:func:`still_runs`; never at a segment's ends).

    Returns
    -------
    ndarray (T, N, 2)
        A copy of `filled`, the still runs replaced.

    Examples
    --------
    >>> values = np.zeros((6, 1, 2)); values[5, 0] = 4.0
    >>> still = np.zeros((6, 1), bool); still[1:5] = True
    >>> held(np.full((6, 1, 2), 9.0), values, still)[:, 0, 0].tolist()
    [9.0, 0.8, 1.6, 2.4, 3.2, 9.0]
    """
    out = filled.copy()
    for j, a, b in free_runs(still):
        share = ((np.arange(a, b) - a + 1) / (b - a + 1))[:, None]
        out[a:b, j] = (1 - share) * values[a - 1, j] + share * values[b, j]
    return out


#: fewest pairs of consecutive observed joint-frames :func:`repeat_rate` reads
REPEAT_MIN_PAIRS = 20
#: pairs of the segment's rate a joint's own pairs are pooled with (:func:`repeat_rate`)
REPEAT_POOL = 20


def repeat_rate(values, free):
    """How often each joint's keypoints repeat the previous frame's: its share
    of consecutive observed frame pairs with identical coordinates, pooled
    with the segment's share (all joints) as :data:`REPEAT_POOL` pairs, so a
    joint that moves while the others rest repeats less (0 everywhere with
    fewer than :data:`REPEAT_MIN_PAIRS` pairs in the segment).

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints.

    Returns
    -------
    ndarray (N,)
        Each joint's rate, in [0, 1].

    Examples
    --------
    >>> values = np.zeros((41, 2, 2)); values[:, 0, 0] = np.arange(41.0)
    >>> repeat_rate(values, np.zeros((41, 2), bool)).round(3).tolist()   # joint 1 rests
    [0.167, 0.833]
    """
    pairs = ~free[1:] & ~free[:-1]
    if pairs.sum() < REPEAT_MIN_PAIRS:
        return np.zeros(free.shape[1])
    with np.errstate(invalid="ignore"):
        same = (np.diff(values, axis=0) == 0).all(axis=-1) & pairs
    segment = same.sum() / pairs.sum()
    return (same.sum(axis=0) + REPEAT_POOL * segment) / (pairs.sum(axis=0) + REPEAT_POOL)


def repeated(filled, values, free, rate):
    """`filled` moved towards each run's observed neighbours by the chance that
    the keypoints held them: a frame ``d`` frames after (or before) an
    observation repeats it with probability ``rate ** d`` (:func:`repeat_rate`,
    each frame independently), so its expected position is the observation
    with that weight and `filled` with the rest (the two sides' weights
    scaled down together where they would sum above 1).

    Parameters
    ----------
    filled : ndarray (T, N, 2)
        The filled segment.
    values : ndarray (T, N, 2)
        The segment's coordinates (read at the frames next to each run).
    free : ndarray of bool (T, N)
        The segment's unknown joints.
    rate : float or ndarray (N,)
        Each joint's :func:`repeat_rate`.

    Returns
    -------
    ndarray (T, N, 2)
        A copy of `filled`; unchanged at joints whose rate is 0.

    Examples
    --------
    >>> values = np.zeros((5, 1, 2)); free = np.zeros((5, 1), bool); free[2:] = True
    >>> repeated(np.full((5, 1, 2), 8.0), values, free, 0.5)[2:, 0, 0].tolist()
    [4.0, 6.0, 7.0]
    """
    out = filled.copy()
    rate = np.broadcast_to(np.asarray(rate, float), free.shape[1:])
    if not (rate > 0).any():
        return out
    T = len(free)
    for j, a, b in free_runs(free):
        d = np.arange(a, b)
        sides = [(rate[j] ** (d - edge if edge < a else edge - d), values[edge, j])
                 for edge in (a - 1, b) if 0 <= edge < T]
        if not sides:
            continue
        scale = 1.0 / np.maximum(sum(w for w, _ in sides), 1.0)
        out[a:b, j] += sum((w * scale)[:, None] * (o - filled[a:b, j]) for w, o in sides)
    return out


def _smooth_joints(values, free, prior, weight, settings, joints=None):
    """Every joint with a free frame (of `joints`, default all) through
    :func:`smooth_trajectory`."""
    filled = values.copy()
    residual = np.zeros(values.shape[1])
    todo = free.any(axis=0) if joints is None else free.any(axis=0) & joints
    for j in np.flatnonzero(todo):
        filled[:, j], residual[j] = smooth_trajectory(
            values[:, j], free[:, j], prior[:, j], weight[:, j], settings.acceleration,
            settings.jerk)
    return filled, residual


def fill_segment(values, free, prior, confidence, settings=DEFAULT_SETTINGS, parents=None,
                 trust=1.0):
    """Every unknown joint of one segment from time and the per-frame prior.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        Coordinates over the segment's frame range (read where not free).
    free : ndarray of bool (T, N)
        Unknown joints (missing, or in a frame absent from the track).
    prior : ndarray (T, N, 2)
        Per-frame answers (NaN where none); frames that :func:`prior_frames`
        skipped take them interpolated (:func:`spread_prior`).
    confidence : ndarray (T,)
        Confidence of each frame's per-frame answer, 0 where there is none.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.
    parents : sequence of int, optional
        The skeleton's parents for ``settings.relative``; default the
        14-joint skeleton's (relative smoothing is skipped for other joint
        counts).
    trust : float, default 1
        Scale of the prior's weight at joints observed somewhere in the
        segment (a joint never observed keeps the full weight: only the pose
        model places it); see :func:`clip_trust` and :func:`prior_scale`.

    Returns
    -------
    filled : ndarray (T, N, 2)
        Observed joints as given; NaN where nothing anchors a joint.
    weight : ndarray (T, N)
        The prior's weight at each unknown joint (0: time alone).
    residual : ndarray (N,)
        Each trajectory's relative residual (the certificate; the larger of
        the two passes').

    Examples
    --------
    A joint that moves at constant speed, hidden for three frames, comes back
    on its line; the rest of the pose needs no prior:

    >>> import numpy as np
    >>> values = np.zeros((9, 2, 2)); values[:, 0, 0] = np.arange(9.0)
    >>> free = np.zeros((9, 2), bool); free[3:6, 0] = True
    >>> out, w, r = fill_segment(values, free, np.full_like(values, np.nan), np.zeros(9))
    >>> out[3:6, 0, 0].round(6).tolist(), float(w.max())
    ([3.0, 4.0, 5.0], 0.0)
    """
    settings = segment_settings(values, free, settings)
    prior, confidence = spread_prior(free, prior, confidence, settings)
    confidence = np.where(np.isfinite(prior).all(axis=(1, 2)), confidence, 0.0)
    weight = prior_weights(free, confidence, settings)
    if not free.any():
        return values.copy(), weight, np.zeros(values.shape[1])
    parents = _skeleton_parents(parents, values.shape[1])
    w_obs = observation_weight(values, free, settings)
    if settings.carry > 0 and w_obs is not None and parents is not None:
        prior, weight = _carried(values, free, prior, weight, parents, settings)
    weight[:, (~free).any(axis=0)] *= trust
    still = still_runs(values, free, settings)
    weight[still] = 0.0
    if not settings.hold_still:
        still = np.zeros_like(still)
    unknown, data, data_weight, settings = _data_terms(values, free, prior, weight, settings,
                                                       w_obs)
    filled, residual = _smooth_joints(values, unknown, data, data_weight, settings)
    if settings.relative and parents is not None:
        ref = reference_trajectories(filled, parents)
        ref *= coupling(values, free, ref)[None, :, None]
        # only joints with something to fill: the others were needed as references
        second, residual2 = _smooth_joints(values - ref, unknown, data - ref, data_weight,
                                           settings, joints=free.any(axis=0))
        filled, residual = second + ref, np.maximum(residual, residual2)
    if unknown is not free:  # observations as data: runs joined, still runs held, ends damped
        filled = damped_ends(held(joined(filled, values, free, settings), values, still),
                             values, free, settings)
    if settings.repeats:
        filled = repeated(filled, values, free, repeat_rate(values, free))
    return np.where(free[..., None], filled, values), weight, residual


def _skeleton_parents(parents, n_joints):
    """`parents`, or when None the 14-joint skeleton's for poses of its N joints
    (None for other layouts: no skeleton known, nothing carried or related)."""
    if parents is None and n_joints == SKELETON_14.num_joints:
        return SKELETON_14.parents
    return parents


def _carried(values, free, prior, weight, parents, settings):
    """`prior` with :func:`~sparseedm.temporal.carried.carried_prior` where the
    prior weighs and a joint could be carried, and `weight` raised to
    ``settings.carry_floor`` at every free frame of a joint that could be."""
    floor = float(settings.carry_floor)
    frames = (weight > 0).any(axis=1) | (free.any(axis=1) if floor > 0 else False)
    carried = carried_prior(values, free, parents, settings.carry, frames=frames)
    can = np.isfinite(carried).all(axis=-1) & free
    if floor > 0:
        weight = np.where(can, np.maximum(weight, floor), weight)
    return np.where((can & (weight > 0))[..., None], carried, prior), weight


def _data_terms(values, free, prior, weight, settings, w_obs):
    """Unknown frames, data, data weights and settings of the banded solves:
    the free frames against the prior, and, when :func:`observation_weight`
    found the observations noisy (`w_obs` not None), every frame, the observed
    ones against their values (with ``settings.noisy_acceleration``)."""
    if w_obs is None:
        return free, prior, weight, settings
    data = np.where(free[..., None], prior, values)
    stiff = replace(settings, acceleration=settings.noisy_acceleration,
                    jerk=settings.noisy_jerk)
    return np.ones_like(free), data, np.where(free, weight, w_obs), stiff


#: scales of the prior's weight a segment chooses among (:func:`clip_trust`)
TRUST_LEVELS = (0.0, 0.25, 1.0)
#: a lower trust is taken only when its probe error is below this share of
#: the full trust's: the probes are few, and the pose model is right on most
#: people, so only a clear loss moves a segment to time
TRUST_MARGIN = 0.5
#: joints hidden per probe window, and most windows per segment (:func:`probe_mask`)
PROBE_JOINTS = 2
PROBE_WINDOWS = 2


def probe_settings(settings=DEFAULT_SETTINGS):
    """The settings probes are filled with: per-frame answers twice as sparse
    (a probe only ranks the trust levels; its answers are extra cost).

    Parameters
    ----------
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    TemporalSettings
        `settings` with ``prior_stride`` doubled.
    """
    return replace(settings, prior_stride=2 * max(int(settings.prior_stride), 1))


def probe_mask(values, free, settings=DEFAULT_SETTINGS):
    """(T, N) bool: observed joint-frames to hide so a segment can test its prior.

    Only when some joint observed in the segment has a run of free frames
    where the prior carries weight: then up to :data:`PROBE_WINDOWS` windows
    side by side from the segment's start, as long as the longest such run
    (at least ``2 * ramp_start + 4`` frames, so the prior weighs inside them;
    at most half the segment), each with one observed frame on both sides,
    hide up to :data:`PROBE_JOINTS` joints observed throughout the window and
    its two neighbours and not still there (:func:`still_runs`: time alone
    fills those whatever the trust), chosen by a generator seeded by the
    segment's shape (the same segment is probed the same way). A probed frame loses few joints more
    than it has lost, so its per-frame answer is as good as the real ones.
    Else all False.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray of bool (T, N)
        The observed joint-frames to hide as a probe.
    """
    T, N = free.shape
    out = np.zeros_like(free)
    if not settings.probe:
        return out
    settings = segment_settings(values, free, settings)
    seen = (~free).any(axis=0)
    deep = free & seen & (_ramp(distance_to_observed(free), settings) > 0)
    if not deep.any():
        return out
    runs = free_runs(free)
    longest = max(b - a for j, a, b in runs if deep[a:b, j].any())
    L = int(min(max(longest, 2 * settings.ramp_start + 4), (T - 2) // 2))
    if L < 1:
        return out
    rng = np.random.default_rng([T, N])
    count = min(PROBE_WINDOWS, (T - 1) // (L + 1))
    for s in 1 + (L + 1) * np.arange(count):
        ok = ~free[s - 1:s + L + 1].any(axis=0)
        trial = free.copy()
        trial[s:s + L, ok] = True
        ok = np.flatnonzero(ok & ~still_runs(values, trial, settings)[s])
        pick = rng.choice(ok, min(PROBE_JOINTS, len(ok)), replace=False)
        out[s:s + L, pick] = True
    return out


def clip_trust(values, free, probe, prior, confidence, settings=DEFAULT_SETTINGS,
               parents=None):
    """The scale of the prior's weight (one of :data:`TRUST_LEVELS`) that fills
    a segment's probed joints best.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates, as :func:`fill_segment`.
    free : ndarray of bool (T, N)
        The segment's unknown joints, as :func:`fill_segment`.
    probe : ndarray of bool (T, N)
        Observed joint-frames hidden as a test (:func:`probe_mask`).
    prior : ndarray (T, N, 2)
        Per-frame answers with the probed joints hidden too, at the
        :func:`prior_frames` of ``free | probe`` under :func:`probe_settings`.
    confidence : ndarray (T,)
        Confidences of those answers, 0 where there is none.
    settings : TemporalSettings, optional
        The temporal model's constants, as :func:`fill_segment`.
    parents : sequence of int, optional
        The skeleton's parents, as :func:`fill_segment`.

    Returns
    -------
    float
        The full trust (the last level) when :func:`choose_carry` keeps the
        carried prior; else the level whose fill of ``free | probe`` lies
        nearest the hidden observations, over the probed joint-frames where the prior weighs
        and the joint is not still (ties to the smaller), when it beats the
        full trust's (the last level) by :data:`TRUST_MARGIN`; else, or with
        nothing to score, 1.0.
    """
    score = probe_errors(values, free, probe, prior, confidence, settings, parents)
    if choose_carry(score.answers_distance, score.carried_distance):
        return TRUST_LEVELS[-1]
    return choose_trust(score.errors, score.count)


class ProbeScore(NamedTuple):
    """What one segment's probes measured (:func:`probe_errors`), to be pooled
    over the segments of a track.

    Parameters
    ----------
    errors : ndarray (len(TRUST_LEVELS),)
        Summed distances (pixels) of the probed joint-frames per trust level
        (:data:`TRUST_LEVELS`; inf where a fill was not finite).
    count : int
        Joint-frames scored (0: nothing to score).
    prior_error : float
        Summed squared coordinate errors of the per-frame answers at the
        probed joint-frames that have one, over the squared body extent (0
        unless :func:`segment_settings` fuses the segment).
    prior_count : int
        Joint-frames summed in ``prior_error``.
    answers_distance, carried_distance : float
        Summed distances (pixels) of the per-frame answers and of the carried
        placements (``TemporalSettings.carry``) to the hidden observations,
        over the probed joint-frames that have both (0 when the carried prior
        was not tried: ``carry`` 0, clean observations, nothing to score).
    """

    errors: np.ndarray
    count: int
    prior_error: float
    prior_count: int
    answers_distance: float
    carried_distance: float


def probe_errors(values, free, probe, prior, confidence, settings=DEFAULT_SETTINGS,
                 parents=None):
    """What :func:`clip_trust` ranks the levels by and :func:`prior_scale`
    weighs the prior by, to be pooled over segments.

    The levels are ranked by fills without ``settings.fusion`` (over the
    probed joint-frames where the ramp weighs), so a track's trust level is
    the one it has without fusion; a fused segment's per-frame answers are
    scored at every probed joint-frame that has one.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints (missing, or in a frame absent from the track).
    probe : ndarray of bool (T, N)
        Observed joint-frames hidden as a test (:func:`probe_mask`).
    prior : ndarray (T, N, 2)
        Per-frame answers with the probed joints hidden too, NaN where none.
    confidence : ndarray (T,)
        Confidence of each frame's per-frame answer, 0 where there is none.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.
    parents : sequence of int, optional
        The skeleton's parents, as :func:`fill_segment`.

    Returns
    -------
    ProbeScore
        The fills' summed distances per trust level, the joint-frames scored,
        and the per-frame answers' own squared error there.
    """
    probed = free | probe
    fused = segment_settings(values, free, settings)
    settings = replace(settings, fusion=False)  # the levels are ranked as without fusion
    still = still_runs(values, probed, settings)
    distance = distance_to_observed(probed)
    scored = probe & (_ramp(distance, settings) > 0) & ~still
    errors = np.zeros(len(TRUST_LEVELS))
    distances = (0.0, 0.0)
    if scored.any():
        # the trust levels rank the per-frame answers: the carried prior, when
        # kept, has the full weight
        errors, probing = [], probe_settings(replace(settings, carry=0.0))
        for level in TRUST_LEVELS:
            out = fill_segment(values, probed, prior, confidence, probing, parents, level)[0]
            errors.append(np.linalg.norm(out[scored] - values[scored], axis=-1).sum())
        errors = np.nan_to_num(np.asarray(errors), nan=np.inf)
        if carries(values, free, settings):
            distances = _carried_distances(values, probed, probe, prior, parents,
                                           settings.carry)
    answered = probe & (_ramp(distance, fused) > 0) & ~still \
        & np.isfinite(prior).all(axis=-1) & (confidence[:, None] > 0)
    if fused.ramp_floor == settings.ramp_floor or not answered.any():
        return ProbeScore(errors, int(scored.sum()), 0.0, 0, *distances)
    square = float(((prior[answered] - values[answered]) ** 2).sum())
    return ProbeScore(errors, int(scored.sum()), square / body_extent(values, free) ** 2,
                      int(answered.sum()), *distances)


def _carried_distances(values, probed, probe, prior, parents, tau):
    """Summed distances of the per-frame answers and of the carried placements to
    the probed observations, where both exist."""
    parents = _skeleton_parents(parents, values.shape[1])
    if parents is None:  # nothing carried (as fill_segment): not tried
        return 0.0, 0.0
    carried = carried_prior(values, probed, parents, tau, frames=probe.any(axis=1))
    both = probe & np.isfinite(prior).all(axis=-1) & np.isfinite(carried).all(axis=-1)
    return (float(np.linalg.norm(prior[both] - values[both], axis=-1).sum()),
            float(np.linalg.norm(carried[both] - values[both], axis=-1).sum()))


def carries(values, free, settings=DEFAULT_SETTINGS):
    """Whether a segment may take the carried prior (``settings.carry``): only
    where its observations are noisy (:func:`observation_weight`: real
    keypoints; on clean ones the per-frame answers stay).

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    bool
    """
    return settings.carry > 0 and observation_weight(values, free, settings) is not None


def choose_carry(answers_distance, carried_distance):
    """Whether a track's probes keep the carried prior: its placements nearer
    the hidden observations than the per-frame answers (:class:`ProbeScore`,
    pooled).

    Parameters
    ----------
    answers_distance, carried_distance : float
        Pooled summed distances of the per-frame answers and of the carried
        placements at the probed joint-frames that have both.

    Returns
    -------
    bool or None
        None when the carried prior was not tried (the segment keeps what
        ``TemporalSettings.carry`` says).

    Examples
    --------
    >>> choose_carry(40.0, 25.0), choose_carry(20.0, 25.0), choose_carry(0.0, 0.0)
    (True, False, None)
    """
    if not carried_distance:
        return None
    return bool(carried_distance < answers_distance)


def choose_trust(errors, count):
    """The trust level of pooled :func:`probe_errors` (see :func:`clip_trust`).

    Parameters
    ----------
    errors : ndarray (len(TRUST_LEVELS),)
        Summed probe distances per trust level, pooled over segments.
    count : int
        Number of joint-frames scored.

    Returns
    -------
    float
        The chosen level of :data:`TRUST_LEVELS`; 1.0 without a clear win.

    Examples
    --------
    >>> choose_trust(np.array([1.0, 3.0, 4.0]), 2), choose_trust(np.zeros(3), 0)
    (0.0, 1.0)
    """
    if not count:
        return 1.0
    best = int(np.argmin(errors))
    return float(TRUST_LEVELS[best]) if errors[best] < TRUST_MARGIN * errors[-1] else 1.0


#: the probes' joint-frames are few and their errors run together over
#: frames: :func:`prior_scale` pools them with this many joint-frames of the
#: settings' ``prior_error``
FUSED_POOL = 10


def prior_scale(prior_error, prior_count, settings=DEFAULT_SETTINGS):
    """The scale of the prior's weight in a fused segment (``settings.fusion``).

    The prior's weight 1 stands for per-frame answers off by
    ``settings.prior_error`` of the body's extent (per coordinate, RMS); the
    probes measured ``prior_error / prior_count`` (squared, over the squared
    extent, :func:`probe_errors`). The weight is the ratio of the two
    variances, the measured one pooled with :data:`FUSED_POOL` joint-frames
    of the nominal one, times ``settings.fusion_share``, at most 1.

    Parameters
    ----------
    prior_error : float
        Summed squared coordinate errors over the squared extent (pooled
        :attr:`ProbeScore.prior_error`).
    prior_count : int
        Joint-frames summed (0: nothing measured).
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    float
        The scale, in (0, 1]: the fused segment's ``ramp_floor``.

    Examples
    --------
    Answers twice as far off as nominal, measured on many joint-frames:

    >>> round(prior_scale(2 * 1000 * (2 * 0.03) ** 2, 1000), 3)
    0.063
    >>> prior_scale(0.0, 0)    # nothing measured: the nominal error
    0.25
    """
    nominal = settings.prior_error ** 2
    measured = (FUSED_POOL * nominal + prior_error / 2) / (FUSED_POOL + prior_count)
    share = settings.fusion_share
    return float(min(1.0, share * nominal / max(measured, np.finfo(float).tiny)))


def time_filled(values, free, near, settings=DEFAULT_SETTINGS):
    """Frames whose every unknown joint is within `near` frames of an
    observation of it, filled by time alone (the prior-free spline of
    :func:`fill_segment`): near-complete poses a clip offers to adaptation.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        The segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        The segment's unknown joints.
    near : int
        Most frames between an unknown joint and an observation of it;
        0: the complete frames only.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    rows : ndarray of bool (T,)
        The frames offered.
    filled : ndarray (T, N, 2)
        The segment with every unknown joint filled by time (read at `rows`).

    Examples
    --------
    >>> values = np.zeros((9, 2, 2)); values[:, 0, 0] = np.arange(9.0)
    >>> free = np.zeros((9, 2), bool); free[3:6, 0] = True
    >>> rows, filled = time_filled(values, free, 1)
    >>> rows.astype(int).tolist(), filled[3, 0].round(6).tolist()
    ([1, 1, 1, 1, 0, 1, 1, 1, 1], [3.0, 0.0])
    """
    rows = (np.where(free, distance_to_observed(free), 0.0) <= near).all(axis=1)
    if not (rows & free.any(axis=1)).any():
        return rows, values
    nothing = np.full_like(values, np.nan)
    return rows, fill_segment(values, free, nothing, np.zeros(len(values)), settings)[0]
