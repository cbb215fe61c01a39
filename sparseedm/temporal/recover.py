"""Temporal recovery: poses with tracks and frames, filled across time.

:func:`recover_temporal` is what ``sparseedm.recover(poses, frames=...)``
runs. It screens every row as the per-frame path does, cuts the rows into
segments (:mod:`sparseedm.temporal.tracks`), asks the per-frame sparse model
only for the frames whose answer carries weight, every
``settings.prior_stride``-th of them
(:func:`sparseedm.temporal.model.prior_frames`), asks it once more for the
frames of each segment's probes (observed joints hidden to test how far the
per-frame prior is to be trusted in that segment, and on noisy keypoints
whether the joints carried from their own frames beat it,
:func:`sparseedm.temporal.model.clip_trust`), fills every segment with the
temporal model (:func:`sparseedm.temporal.model.fill_segment`) and returns a
:class:`TemporalResult` in the caller's row order. Rows that cannot be placed
in time (see :mod:`~sparseedm.temporal.tracks`) are recovered frame by frame
and say why.

:func:`recover_track` is the same model as a gap filler of one track,
``fill(poses, missing, frames) -> filled``, the shape the video evaluation
compares every gap filler in.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from types import SimpleNamespace

import numpy as np

from .._recovery_base import (RecoveryResult, bad_coordinates, mirror_weights, screen_poses,
                              validate_poses)
from .._recovery_kernel import compiled_solver, recover_members
from .._validation import check_frames
from ..dictionary import Dictionary, load_dictionary
from ..edm import pose_to_vector
from ..ensemble import adapt_members
from ..normalize import normalize
from ..skeleton import JOINT_NAMES, SKELETON_14
from .linking import link_tracks, needs_linking, split_at_jumps
from .model import (DEFAULT_SETTINGS, choose_carry, choose_trust, fill_segment, prior_frames,
                    prior_scale, probe_errors, probe_mask, probe_settings, segment_settings,
                    time_filled)
from .tracks import split_tracks

__all__ = ["recover_temporal", "recover_track", "adapt_in_time", "adapts", "offered_poses",
           "linked_tracks", "time_layout",
           "TemporalResult", "SOURCES",
           "CLIP_NEAR", "CLIP_MIN_POSES", "ADAPT_MIN_FRAMES", "SELF_TRAINING_MIN_FRAMES",
           "OFFER_MAX"]

#: Per-joint sources of :attr:`TemporalResult.source`.
SOURCES = {
    "observed": "given by the caller, returned exactly",
    "temporal": "filled by the temporal model (time and the per-frame pose model)",
    "per_frame": "filled by the per-frame pose model alone (the row is outside any track)",
    "outlier": "given with a low score, contradicted by the pose model and the track, "
               "treated as missing and filled (sparseedm.outliers)",
    "": "not filled (the row was refused)",
}
#: a per-frame answer that places a joint further than this many times the
#: observed joints' extent from their centre gets no weight (a runaway
#: placement: the per-frame path's rare silent outliers)
RUNAWAY_EXTENTS = 3.0
#: relative residual of a trajectory's banded solve above which its rows are
#: 'inaccurate' instead of 'recovered'
RESIDUAL_TOL = 1e-8
#: one clip adapts: under ``adapt="auto"`` the dictionary is
#: adapted on the complete rows and on the rows whose missing joints all lie
#: within CLIP_NEAR frames of an observation, filled by time alone, once
#: CLIP_MIN_POSES of them pass the filters (the per-frame path needs 250
#: complete poses), then self-trained and guarded as everywhere. Chosen on
#: validation sequences across sources (``studies/temporal/select_temporal.py
#: --adapt``, ``studies/temporal/selection_temporal_adapt.json``)
CLIP_NEAR = 3
CLIP_MIN_POSES = 30
#: under ``adapt="auto"`` a call adapts only when some row asks the per-frame
#: model (a prior frame, a probe, a row answered alone: else no adapted
#: dictionary would be used) and it holds at least ADAPT_MIN_FRAMES rows; the
#: self-training rounds (``self_training=None``) run from
#: SELF_TRAINING_MIN_FRAMES rows on. Chosen on validation clips given one per
#: call (``studies/temporal/select_one_clip_cost.py``,
#: ``studies/temporal/selection_one_clip_cost.json``): under 60 frames (every
#: Bonn PoseTrack clip of real people, the shortest mocap ones) adapting
#: changed no error by more than 0.1 %; from 60 frames on it cut the error on
#: another lab's mocap by 10-40 %. Self-training rounds on mocap clips of
#: 60-300 frames moved the mean error by 0.4 % (by 2.8 % on another lab's
#: self-occlusions, all of it on two clips) at three times the call's time,
#: while on whole files (1,600-15,000 frames) they cut it by 1-9 %.
ADAPT_MIN_FRAMES = 60
SELF_TRAINING_MIN_FRAMES = 1000
#: at most this many offered poses are adapted on, a longer call's taken at an
#: even stride in track and frame order (neighbouring frames are near copies);
#: None: all of them (the adaptation then learns from its own seeded sample of
#: 5,000). On the whole validation file of another lab's mocap (15,000 frames,
#: 7,500-11,600 offered) 3,000 halved the adaptation's filter and learning and
#: moved the error by +3.0 % (gaps) and -5.2 % (self-occlusion); 2,000 by +4.0 %
#: and -2.5 %, 1,000 by +7.2 % and -0.2 %; a CMU file of 1,600 frames offers
#: fewer (same study, ``--files``). Clips of a few hundred frames never reach it.
OFFER_MAX = 3000


@dataclass
class TemporalResult(RecoveryResult):
    """A :class:`~sparseedm.recovery.RecoveryResult` with what time did.

    For rows filled by the temporal model, ``vectors``, ``center`` and
    ``scale`` describe the filled pose itself (normalised as
    :func:`sparseedm.normalize.normalize` does); ``objective``, ``gap`` and
    ``n_active`` are the per-frame answer's where one was computed.

    Parameters
    ----------
    poses, vectors, missing, center, scale, objective, gap, n_active : ndarray
        As :class:`~sparseedm.recovery.RecoveryResult` (see above for the rows
        filled by the temporal model).
    status, reason, fallback, alpha, seconds, adaptation, dictionary, members : object
        As :class:`~sparseedm.recovery.RecoveryResult`.
    uncertainty : ndarray (n, N) or None
        As :class:`~sparseedm.recovery.RecoveryResult`: the calibrated 90 %
        radius of each joint, here from the features of time as well.
    outliers : ndarray of bool (n, N) or None
        As :class:`~sparseedm.recovery.RecoveryResult`: low-scored points
        treated as missing (their ``source`` is ``"outlier"``).
    averaged, spread : ndarray or None
        As :class:`~sparseedm.recovery.RecoveryResult`: None (the photo path's
        averages do not run in time).
    source : ndarray of str (n, N)
        Where each joint comes from, one of :data:`SOURCES`.
    prior_weight : ndarray (n, N)
        Weight the per-frame pose model had at each filled joint (0: time
        alone, a spline; 1: full).
    residual : ndarray (n,)
        Largest relative residual of the row's trajectories' exact solves (the
        temporal model's certificate); NaN for rows outside any track.
    per_frame_poses : int
        Rows the per-frame model was asked for.
    probe_poses : int
        Rows it was asked for again with some observed joints hidden, to test
        the per-frame prior against time (:func:`~sparseedm.temporal.model.clip_trust`).
    prior_trust : ndarray (n,)
        The scale of the per-frame prior's weight the row's segment chose from
        those probes (1: as designed; 0: time alone at the joints observed in
        the segment); NaN for rows outside any segment.
    segments : int
        Segments (one track, consecutive frames) solved.
    linked_tracks : ndarray of int (n,) or None
        Track ids linked by :func:`~sparseedm.temporal.linking.link_tracks`
        when the caller gave frames without tracks and some frame holds
        several poses; None otherwise.
    alone_reason : ndarray of str (n,)
        Why a row was answered frame by frame instead of across time (a bad
        frame number, the only frame of its stretch, a jump); ``""`` for the
        rows of a segment.
    frames : ndarray of float (n,)
        Each row's frame number as read (NaN where refused), once: what the
        uncertainty's time features use.
    """

    source: np.ndarray = field(default=None)
    prior_weight: np.ndarray = field(default=None)
    residual: np.ndarray = field(default=None)
    per_frame_poses: int = 0
    probe_poses: int = 0
    prior_trust: np.ndarray = field(default=None)
    segments: int = 0
    linked_tracks: np.ndarray = field(default=None)
    alone_reason: np.ndarray = field(default=None)
    frames: np.ndarray = field(default=None)

    def summary(self) -> dict:
        """:meth:`RecoveryResult.summary` plus the temporal model's counts.

        Returns
        -------
        dict
            The per-frame summary with a ``"temporal"`` entry: segments solved,
            per-frame poses asked for, filled joints by source, linked tracks and
            why rows were answered alone (when any).
        """
        out = super().summary()
        out["temporal"] = {
            "segments": self.segments,
            "per_frame_poses": self.per_frame_poses,
            "joints": {s: int((self.source == s).sum()) for s in SOURCES if s
                       and s != "observed"},
        }
        if self.linked_tracks is not None:
            out["temporal"]["linked_tracks"] = int(len(np.unique(self.linked_tracks)))
        if self.alone_reason is not None and (self.alone_reason != "").any():
            why, count = np.unique(self.alone_reason[self.alone_reason != ""],
                                   return_counts=True)
            out["temporal"]["alone"] = dict(zip(why.tolist(), count.tolist()))
        return out


def _confidence(status, settings):
    return np.select([status == "recovered", status == "inaccurate"],
                     [1.0, settings.inaccurate], 0.0)


def _dense(rows, offsets, poses, mask, usable):
    """A segment's rows on its full frame range: values, free joints."""
    T, N = int(offsets[-1]) + 1, mask.shape[1]
    values = np.zeros((T, N, 2))
    free = np.ones((T, N), dtype=bool)
    keep = usable[rows]
    values[offsets[keep]] = np.where(mask[rows[keep], :, None], 0.0, poses[rows[keep]])
    free[offsets[keep]] = mask[rows[keep]]
    return values, free


def _plan(layout, poses, mask, usable, settings):
    """Rows that need a per-frame answer: alone rows and prior frames."""
    need = layout.alone & usable
    for rows, off in zip(layout.segments, layout.offsets):
        values, free = _dense(rows, off, poses, mask, usable)
        asked = prior_frames(free, segment_settings(values, free, settings))
        need[rows] |= asked[off] & mask[rows].any(axis=1)
    return need & usable


def _offered(layout, poses, mask, usable, settings):
    """What the poses offer adaptation (:data:`CLIP_NEAR`): complete rows and
    rows whose missing joints time alone fills from close by, filled; in an
    order that does not depend on the rows' (``layout.order``)."""
    alone = layout.order[(layout.alone & usable & ~mask.any(axis=1))[layout.order]]
    parts = [poses[alone]]
    for rows, off in zip(layout.segments, layout.offsets):
        values, free = _dense(rows, off, poses, mask, usable)
        near, filled = time_filled(values, free, CLIP_NEAR, settings)
        parts.append(filled[off][near[off] & usable[rows]])
    offered = np.concatenate(parts)
    if OFFER_MAX is None or len(offered) <= OFFER_MAX:
        return offered
    return offered[::-(-len(offered) // OFFER_MAX)]


def adapts(n_rows, asks_per_frame):
    """Whether ``adapt="auto"`` adapts a call in time, and whether it self-trains
    (when ``self_training`` is left to its default): only when some row asks
    the per-frame model, from :data:`ADAPT_MIN_FRAMES` and
    :data:`SELF_TRAINING_MIN_FRAMES` rows on.

    Parameters
    ----------
    n_rows : int
        Poses in the call.
    asks_per_frame : bool
        Whether any row's answer comes from, or is tested against, the
        per-frame model.

    Returns
    -------
    adapt : bool
    self_train : bool

    Examples
    --------
    >>> adapts(1000, False)
    (False, False)
    """
    adapt = bool(asks_per_frame) and n_rows >= ADAPT_MIN_FRAMES
    return adapt, adapt and n_rows >= SELF_TRAINING_MIN_FRAMES


def _adapt(dictionary, poses, mask, layout, usable, adapt, ensemble, settings, kw,
           asks_per_frame=True):
    """Members and adaptations: under "auto" on what the poses offer
    (:func:`_offered`, at least :data:`CLIP_MIN_POSES`) where :func:`adapts`
    says so, else as asked."""
    auto = isinstance(adapt, str) and adapt == "auto"
    if auto:
        adapt_now, self_train = adapts(len(poses), asks_per_frame)
        if not adapt_now:
            adapt = False
            if int(ensemble) > 1:  # as adapt_members says when it fits fewer members
                why = (f"{len(poses)} poses, fewer than the {ADAPT_MIN_FRAMES} a call in "
                       "time adapts from" if asks_per_frame else
                       "no pose asks the per-frame model")
                warnings.warn(f"ensemble={int(ensemble)}: no dictionary is adapted ({why}); "
                              f"1 dictionary recovers, not {int(ensemble)} members",
                              UserWarning, stacklevel=6)  # recover()'s caller
        elif not self_train and kw.get("self_training") is None:
            kw = dict(kw, self_training=0)
    if adapt is False or adapt is None:
        return adapt_members(dictionary, poses, mask, adapt, ensemble, **kw)
    # self-training samples the rows: in track and frame order, whatever theirs
    ordered = poses[layout.order], mask[layout.order]
    if auto:
        offered = _offered(layout, poses, mask, usable, settings)
        return adapt_members(dictionary, *ordered, offered, ensemble, warn=False,
                             min_poses=CLIP_MIN_POSES, check_input=False, **kw)
    return adapt_members(dictionary, *ordered, adapt, ensemble, **kw)


def _screened(poses, missing, n_joints, check_input=True):
    """Validated poses, mask, screening (:func:`screen_poses`) and the rows time
    can use (`check_input` False: `poses` and the mask `missing` were validated
    by the caller)."""
    poses, mask, bad_coord = (validate_poses(poses, missing, n_joints) if check_input
                              else (poses, missing, bad_coordinates(poses, missing)))
    screening = screen_poses(poses, mask, bad_coord)
    # rows whose observed coordinates cannot be used are absent from time too
    usable = ~np.isin(screening.status, ("invalid_coordinates", "out_of_range"))
    return poses, mask, screening, usable


def _linked(poses, mask, usable, tracks, frames):
    """The usable rows linked into tracks, or None (see :func:`linked_tracks`)."""
    if not needs_linking(tracks, frames):
        return None
    return link_tracks(np.where(usable[:, None, None], poses, np.nan), mask, frames=frames)


def linked_tracks(poses, missing, tracks, frames, n_joints=SKELETON_14.num_joints):
    """The tracks :func:`recover_temporal` links the poses into, or None.

    None when `tracks` are given or no frame holds several poses; otherwise
    :func:`~sparseedm.temporal.linking.link_tracks` of the rows time can use
    (what ``sparseedm recover`` links a file by, once, before its chunks).

    Parameters
    ----------
    poses : array_like (n, N, 2)
        The poses, NaN (or `missing`) at the unknown joints.
    missing : array_like of bool (n, N) or None
        The unknown joints; None: the NaN ones.
    tracks : array_like (n,) or None
        The caller's track ids, if any.
    frames : array_like of int (n,)
        Frame number of each pose.
    n_joints : int, default 14
        Joints per pose.

    Returns
    -------
    ndarray of int (n,) or None
        The linked track id of each row, or None.
    """
    if not needs_linking(tracks, frames):
        return None
    poses, mask, _, usable = _screened(poses, missing, n_joints)
    return _linked(poses, mask, usable, tracks, frames)


def _in_time(poses, missing, tracks, frames, n_joints, check_input=True):
    """Validated poses, mask, screening, usable rows and the track layout (tracks
    linked by :func:`~sparseedm.temporal.linking.link_tracks` when none are
    given and a frame holds several poses)."""
    poses, mask, screening, usable = _screened(poses, missing, n_joints, check_input)
    linked = _linked(poses, mask, usable, tracks, frames)
    layout = split_at_jumps(split_tracks(len(poses), tracks if linked is None else linked,
                                         frames),
                            np.where(usable[:, None, None], poses, np.nan), mask)
    layout.linked = linked
    return poses, mask, screening, usable, layout


def time_layout(poses, missing=None, *, tracks=None, frames,
                n_joints=SKELETON_14.num_joints, check_input=True):
    """The segments :func:`recover_temporal` fills the poses in: each track's
    rows in frame order (:func:`~sparseedm.temporal.tracks.split_tracks`; the
    tracks linked when none are given and a frame holds several poses), cut
    where the pose jumps (:func:`~sparseedm.temporal.linking.split_at_jumps`).

    Parameters
    ----------
    poses : array_like (n, N, 2)
        The poses, NaN (or `missing`) at the unknown joints.
    missing : array_like of bool (n, N), optional
        The unknown joints; default the NaN ones.
    tracks : array_like (n,), optional
        Track id of each pose; default linked from the poses when a frame
        holds several, else one track.
    frames : array_like of int (n,)
        Frame number of each pose.
    n_joints : int, default 14
        Joints per pose.
    check_input : bool, default True
        As :func:`recover_temporal`'s.

    Returns
    -------
    TrackLayout
        The segments, the rows answered alone and why, and the linked tracks.
    """
    return _in_time(poses, missing, tracks, frames, n_joints, check_input)[-1]


def offered_poses(poses, missing=None, *, tracks=None, frames, settings=None):
    """What poses with frames offer adaptation: their complete rows and the rows
    whose missing joints time fills from within :data:`CLIP_NEAR` frames,
    filled (what ``adapt="auto"`` adapts on; the rule wants
    :data:`CLIP_MIN_POSES` of them). ``sparseedm recover --adapt-from`` a
    video adapts on these.

    Parameters
    ----------
    poses : array_like (n, N, 2)
        The poses, NaN (or `missing`) at the unknown joints.
    missing : array_like of bool (n, N), optional
        The unknown joints; default the NaN ones.
    tracks : array_like (n,), optional
        Track id of each pose; default linked from the poses when a frame
        holds several, else one track.
    frames : array_like of int (n,)
        Frame number of each pose.
    settings : TemporalSettings, optional
        The temporal model's constants; default :class:`TemporalSettings`'s.

    Returns
    -------
    ndarray (m, N, 2)
        The offered poses, filled, in an order independent of the rows' (0 rows
        when none).
    """
    settings = DEFAULT_SETTINGS if settings is None else settings
    poses, mask, _, usable, layout = _in_time(poses, missing, tracks, frames,
                                              SKELETON_14.num_joints)
    return _offered(layout, poses, mask, usable, settings)


def adapt_in_time(dictionary, poses, missing=None, *, tracks=None, frames, ensemble=1,
                  n_jobs=1, self_training=None, settings=None, check_input=True):
    """The dictionaries ``adapt="auto"`` gives poses in time, and what was done.

    What :func:`recover_temporal` does first, for callers that adapt once and
    recover later (``sparseedm recover`` on a file with frames).

    Parameters
    ----------
    dictionary : Dictionary
    poses, missing, tracks, frames, settings, check_input
        As :func:`recover_temporal` (``sparseedm recover`` passes a file's
        poses as its reader checked them, with ``check_input=False``).
    ensemble, n_jobs, self_training
        As :func:`sparseedm.ensemble.adapt_members`.

    Returns
    -------
    members : list of Dictionary
    adaptations : list of AdaptationResult
        Empty when :func:`adapts` says the call does not adapt.
    """
    settings = DEFAULT_SETTINGS if settings is None else settings
    poses, mask, _, usable, layout = _in_time(poses, missing, tracks, frames,
                                              dictionary.n_joints, check_input)
    asks = _plan(layout, poses, mask, usable, settings).any() or _probes(
        layout, poses, mask, usable, settings)[2].any()
    return _adapt(dictionary, poses, mask, layout, usable, "auto", ensemble, settings,
                  dict(n_jobs=n_jobs, self_training=self_training), asks_per_frame=asks)


def _segment_prior(per, rows, off, T):
    """A segment's per-frame answers and confidences on its frame range."""
    prior = np.full((T,) + per.poses.shape[1:], np.nan)
    confidence = np.zeros(T)
    prior[off] = per.poses[rows]
    confidence[off] = per.confidence[rows]
    return prior, confidence


def _probes(layout, poses, mask, usable, settings):
    """Every segment's :func:`~sparseedm.temporal.model.probe_mask`, the rows'
    mask with the probes added, and the rows whose answer changes with them."""
    probes, probed, need = [], mask.copy(), np.zeros(len(mask), bool)
    for rows, off in zip(layout.segments, layout.offsets):
        values, free = _dense(rows, off, poses, mask, usable)
        probe = probe_mask(values, free, settings)
        probes.append(probe)
        probed[rows] |= probe[off]
        asked = prior_frames(free | probe,
                             probe_settings(segment_settings(values, free, settings)))
        need[rows] |= (asked & probe.any(axis=1))[off]
    return probes, probed, need & usable


def _trusts(layout, poses, mask, usable, per, settings, members, kwargs, track_of, planned,
            never=None):
    """Each segment's trust in the per-frame prior: the probes' errors
    (:func:`~sparseedm.temporal.model.probe_errors`, one batch of per-frame
    answers with the probes hidden; `planned`: :func:`_probes`) pooled over
    the segments of one track (`track_of`: a track key per row), so that a
    cut in a track does not change what its other rows are filled with: the
    trust level, the fused prior's scale
    (:func:`~sparseedm.temporal.model.prior_scale`) and whether the carried
    prior is kept (:func:`~sparseedm.temporal.model.choose_carry`; None: not
    tried), per segment; and the rows asked."""
    probes, probed, need = planned
    if not need.any():
        return [(1.0, 1.0, None)] * len(probes), 0
    test = _per_frame(poses, probed, need, members, settings, kwargs, never)
    pooled = {}
    for rows, off, probe in zip(layout.segments, layout.offsets, probes):
        if probe.any():
            score = probe_errors(*_probed_segment(rows, off, probe, poses, mask, usable, per,
                                                  test), settings)
            sums = pooled.setdefault(track_of[rows[0]], [0.0, 0, 0.0, 0, 0.0, 0.0])
            sums[:] = [a + b for a, b in zip(sums, score)]
    trust = {}
    for key, (errors, count, square, answered, *distances) in pooled.items():
        keep = choose_carry(*distances)  # kept: the carried prior at full weight
        trust[key] = (1.0 if keep else choose_trust(errors, count),
                      prior_scale(square, answered, settings), keep)
    return [trust.get(track_of[rows[0]], (1.0, 1.0, None)) for rows in layout.segments], \
        int(need.sum())


def _probed_segment(rows, off, probe, poses, mask, usable, per, test):
    """values, free, probe, prior, confidence of a probed segment: its
    per-frame answers, those of the probed frames from `test`."""
    values, free = _dense(rows, off, poses, mask, usable)
    prior, confidence = _segment_prior(per, rows, off, len(values))
    changed = probe.any(axis=1)
    test_prior, test_confidence = _segment_prior(test, rows, off, len(values))
    prior[changed], confidence[changed] = test_prior[changed], test_confidence[changed]
    return values, free, probe, prior, confidence


def _fill_segments(layout, poses, mask, usable, per, settings, trusts):
    """The temporal model on every segment: filled poses, weights, residuals."""
    n, N = mask.shape
    filled = np.full_like(poses, np.nan)
    weight = np.zeros((n, N))
    residual = np.full(n, np.nan)
    for rows, off, (trust, scale, carry) in zip(layout.segments, layout.offsets, trusts):
        values, free = _dense(rows, off, poses, mask, usable)
        prior, confidence = _segment_prior(per, rows, off, len(values))
        fused = segment_settings(values, free, settings)
        if fused is not settings:
            fused = replace(fused, ramp_floor=scale)
        if carry is False:  # the probes preferred the per-frame answers
            fused = replace(fused, carry=0.0)
        out, w, r = fill_segment(values, free, prior, confidence, fused, trust=trust)
        filled[rows], weight[rows] = out[off], w[off]
        residual[rows] = np.max(np.where(free[off], r[None, :], 0.0), axis=1)
    return filled, weight, residual


_PER_FRAME_KEYS = ("vectors", "center", "scale", "objective", "gap", "n_active", "fallback",
                   "status", "reason")


@dataclass
class _PerFrame:
    """Per-frame answers spread over all n rows (NaN / "" where not asked)."""

    poses: np.ndarray
    confidence: np.ndarray
    fields: dict
    rows: np.ndarray
    alpha: float


def _never_seen(layout, mask, track_of):
    """(n, N) bool: the hidden joints of the segments' rows that no segment of
    their track (`track_of`: a track key per row) shows."""
    seen = {}
    for rows in layout.segments:
        key = track_of[rows[0]]
        seen[key] = seen.get(key, False) | (~mask[rows]).any(axis=0)
    never = np.zeros_like(mask)
    for rows in layout.segments:
        never[rows] = mask[rows] & ~seen[track_of[rows[0]]]
    return never


def _mirror_never(poses, mask, rows, res, never, members, kwargs):
    """`res` (the answers of `rows`) with the mirror image's answers weighed in
    (:func:`~sparseedm._recovery_base.mirror_weights`) at the `never` joints."""
    moved = never[rows].any(axis=1)
    if not moved.any():
        return res.poses
    sub = rows[moved]
    mirror = recover_members(poses[sub], mask[sub], [m.mirrored() for m in members], [],
                             **kwargs)
    w = mirror_weights([SimpleNamespace(objective=res.objective[moved]), mirror])
    mixed = w[0][:, None, None] * res.poses[moved] + w[1][:, None, None] * mirror.poses
    out = res.poses.copy()
    keep = never[sub] & np.isfinite(mixed).all(axis=-1)
    out[moved] = np.where(keep[..., None], mixed, out[moved])
    return out


def _per_frame(poses, mask, need, members, settings, kwargs, never=None, screening=None):
    """The per-frame model on the `need` rows only (`never`: the joints whose
    answers take their mirror image's in, ``settings.never_mirror``;
    `screening`: the poses' and mask's, when at hand: not screened again)."""
    n, N = mask.shape
    m = N * (N - 1) // 2
    fields = dict(vectors=np.full((n, m), np.nan), center=np.full((n, 2), np.nan),
                  scale=np.full(n, np.nan), objective=np.full(n, np.nan),
                  gap=np.full(n, np.nan), n_active=np.zeros(n, dtype=int),
                  fallback=np.zeros(n, dtype=bool), status=np.full(n, "", dtype=object),
                  reason=np.full(n, "", dtype=object))
    full = np.full_like(poses, np.nan)
    confidence = np.zeros(n)
    rows = np.flatnonzero(need)
    alpha = kwargs.get("alpha")
    if len(rows):
        res = recover_members(poses[rows], mask[rows], members, [],
                              screening=None if screening is None else screening.take(rows),
                              **kwargs)
        for key in _PER_FRAME_KEYS:
            fields[key][rows] = getattr(res, key)
        full[rows] = (res.poses if never is None or not settings.never_mirror
                      else _mirror_never(poses, mask, rows, res, never, members, kwargs))
        confidence[rows] = _confidence(res.status, settings) * ~_runaway(
            res.poses, mask[rows])
        alpha = res.alpha
    if alpha is None:
        alpha = members[0].alpha_recover
    return _PerFrame(full, confidence, fields, rows, float(alpha))


def _runaway(filled, mask):
    """Rows (n,) whose filled joints lie further than :data:`RUNAWAY_EXTENTS`
    extents of the observed joints from their centre (a refused row, all NaN:
    never; numpy's all-NaN warnings silenced)."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        obs = np.where(mask[..., None], np.nan, filled)
        center = np.nanmean(obs, axis=1)
        extent = np.nanmax(np.nanmax(obs, axis=1) - np.nanmin(obs, axis=1), axis=1)
        dist = np.linalg.norm(filled - center[:, None, :], axis=-1)
        far = np.where(mask, dist, 0.0) > RUNAWAY_EXTENTS * extent[:, None]
    return far.any(axis=1)


def recover_temporal(poses, missing=None, *, tracks=None, frames, dictionary=None,
                     adapt="auto", self_training=None, ensemble=1, settings=None,
                     check_input=True, **kwargs):
    """Recover occluded joints across time: one call, every track.

    Parameters
    ----------
    poses, missing
        As :func:`sparseedm.recover`.
    tracks : array_like (n,), optional
        Person of each pose; None: all one track, or, when some frame holds
        several poses, the tracks :func:`~sparseedm.temporal.linking.link_tracks`
        links them into (``TemporalResult.linked_tracks``).
    frames : array_like (n,)
        Frame number of each pose (integers; any order; skipped numbers are
        frames where the person was not seen).
    dictionary, adapt, self_training, ensemble
        As :func:`sparseedm.recover`; ``adapt="auto"`` adapts on the complete
        frames and the frames whose missing joints time fills from within
        :data:`CLIP_NEAR` frames, from :data:`CLIP_MIN_POSES` of them on (one
        clip of a few hundred frames adapts), guarded as per frame; only when
        some row asks the per-frame model and the call has
        :data:`ADAPT_MIN_FRAMES` rows, and ``self_training=None`` runs its
        rounds from :data:`SELF_TRAINING_MIN_FRAMES` rows on (:func:`adapts`).
    settings : TemporalSettings, optional
        The temporal model's constants; default the validated ones.
    check_input : bool, default True
        Validate `poses`, `missing` and `frames`. False: the caller did
        (:func:`sparseedm.recover`: poses a float array (n, N, 2), `missing`
        a bool array (n, N)), as scikit-learn's ``check_input=False``.
    **kwargs
        The per-frame recovery's settings (alpha, representation, solver,
        n_jobs, chunk_size, positive, progress, backend, scheduler).

    Returns
    -------
    TemporalResult
        Rows in the order given.
    """
    t0 = time.perf_counter()
    settings = DEFAULT_SETTINGS if settings is None else settings
    if check_input:
        check_frames(frames, "recover_temporal")
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    poses, mask, screening, usable, layout = _in_time(poses, missing, tracks, frames,
                                                      dictionary.n_joints, check_input)
    need = _plan(layout, poses, mask, usable, settings)
    planned = _probes(layout, poses, mask, usable, settings)
    members, adaptations = _adapt(dictionary, poses, mask, layout, usable, adapt, ensemble,
                                  settings, dict(n_jobs=kwargs.get("n_jobs", 1),
                                                 self_training=self_training),
                                  asks_per_frame=bool(need.any() or planned[2].any()))
    # the compiled kernel at any size: its answers equal the numpy homotopy's to
    # round-off, 2-4x faster a row; a process's first call loads it once
    kwargs["solver"] = compiled_solver(kwargs.get("solver", "fast"))
    kwargs["check_input"] = False  # rows of the poses validated above
    track_of = layout.linked if layout.linked is not None else (
        np.zeros(len(poses), int) if tracks is None else np.asarray(tracks))
    # mirror images need the 14-joint layout's left and right (Dictionary.mirrored)
    never = (_never_seen(layout, mask, track_of) if dictionary.joint_names == JOINT_NAMES
             else None)
    per = _per_frame(poses, mask, need, members, settings, kwargs, never, screening)
    trusts, probe_poses = _trusts(layout, poses, mask, usable, per, settings, members, kwargs,
                                  track_of, planned, never)
    filled, weight, residual = _fill_segments(layout, poses, mask, usable, per, settings,
                                              trusts)
    res = _assemble(poses, mask, screening.status, screening.reason, layout, per, filled,
                    weight, residual, len(members))
    res.probe_poses, res.frames = probe_poses, layout.frames
    res.prior_trust = np.full(len(poses), np.nan)
    for rows, (trust, _, _) in zip(layout.segments, trusts):
        res.prior_trust[rows] = trust
    res.dictionary = members[0] if members else dictionary
    if adaptations:
        res.adaptation = adaptations[0]
    res.seconds = time.perf_counter() - t0
    return res


def _assemble(poses, mask, refusal, why, layout, per, filled, weight, residual, members):
    """The TemporalResult: per-frame rows as the per-frame path returns them,
    temporal rows from the segments, statuses and sources per row."""
    out = dict(per.fields)
    status, reason = out.pop("status"), out.pop("reason")
    result = filled.copy()
    alone = layout.alone
    result[alone] = per.poses[alone]
    source = np.where(mask, "", "observed").astype(object)
    in_time = ~alone
    ok = in_time & np.isfinite(filled).all(axis=(1, 2)) & ~np.isin(
        refusal, ("invalid_coordinates", "out_of_range"))
    complete = in_time & ~mask.any(axis=1) & (refusal == "")
    temporal = ok & ~complete
    exact = residual <= RESIDUAL_TOL
    status[temporal] = np.where(exact[temporal], "recovered", "inaccurate")
    reason[temporal] = np.where(exact[temporal], "filled across time by the temporal model",
                                "the temporal model's solve left a residual above 1e-8")
    status[complete], reason[complete] = "complete", "no joint missing"
    refused = in_time & ~ok & ~complete
    status[refused] = np.where(refusal[refused] == "", "solver_failed", refusal[refused])
    reason[refused] = np.where(
        why[refused] == "", "a joint is anchored neither by an observation in its track "
        "nor by a per-frame answer", why[refused])
    result[refused] = np.nan
    source[temporal[:, None] & mask] = "temporal"
    per_ok = alone & np.isin(status, ("recovered", "inaccurate"))
    source[per_ok[:, None] & mask] = "per_frame"
    said = alone & (status != "")  # a recovered row's own reason is blank
    reason[said] = [f"{r}; per frame because {a}" if r else f"per frame because {a}"
                    for r, a in zip(reason[said], layout.reason[said])]
    still = status == ""  # alone rows the per-frame model did not see: refused by screening
    status[still], reason[still] = refusal[still], why[still]
    _describe_filled(result, temporal | complete, out)
    return TemporalResult(
        poses=result, missing=mask, status=status.astype(str), reason=reason.astype(str),
        alpha=per.alpha, members=members, source=source.astype(str),
        prior_weight=np.where(temporal[:, None], weight, 0.0), residual=residual,
        per_frame_poses=len(per.rows), segments=len(layout.segments),
        linked_tracks=layout.linked, alone_reason=layout.reason, **out)


def _describe_filled(result, rows, out):
    """vectors, center and scale of the filled poses of `rows` (in place in `out`)."""
    rows = np.flatnonzero(rows)
    if len(rows):
        normed, center, scale = normalize(result[rows])
        out["vectors"][rows] = pose_to_vector(normed)
        out["center"][rows], out["scale"][rows] = center, scale


def recover_track(poses, missing, frames, **kwargs):
    """The temporal model as a gap filler of one track.

    Parameters
    ----------
    poses : ndarray (T, N, 2)
    missing : ndarray of bool (T, N)
    frames : ndarray of int (T,)
        Sorted, unique.
    **kwargs
        As :func:`recover_temporal` (e.g. ``adapt=False``).

    Returns
    -------
    ndarray (T, N, 2)
        Observed joints unchanged; NaN where a row was refused.
    """
    return recover_temporal(poses, missing, frames=frames, **kwargs).poses
