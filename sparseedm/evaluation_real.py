"""Recovery judged on real annotated people: photos and video, against peers.

Two protocols over a user's own keypoints (or a hand-annotated set), each
method measured in the same run on the same hidden joints:

**Photos** (:func:`evaluate_photos`). The complete poses are split (seeded)
into C that stay complete and M whose joints are hidden; the C + M poses are
ONE file given to each method in one call, as a user would (sparseedm adapts
on the file's complete poses). Conditions: ``"mix"`` (1, 2 or 3 random joints
per pose, :func:`sparseedm.metrics.occlusion_masks`), ``1``, ``2``, ``3``, and
``"transplanted"`` (each pose gets the missing pattern of a real incomplete
pose, :func:`sparseedm.real_protocol.transplant_masks`). Methods
(:data:`PHOTO_METHODS`): ``sparseedm`` (:func:`sparseedm.recover` defaults),
``sparseedm-no-adapt`` (``recover(adapt=False)``: with no `dictionary`, the
CMU + COCO prior with the mirror image and the shipped pose bank, a
dictionary given coded alone; also, when asked for,
``sparseedm-no-adapt-mirror``: the same with ``mirror=True``, and
``sparseedm-no-adapt-mirror-auto``: with ``mirror="auto"``), scikit-learn's
``iterative`` (``IterativeImputer(max_iter=10, tol=0)``) and ``knn``
(``KNNImputer()``) run by ``fit_transform`` on the file's 28 pixel
coordinates, ``mean-fill`` and ``nearest`` (:mod:`sparseedm.baselines`, the
nearest of the file's complete poses).

**Video** (:func:`evaluate_tracks`). Clips are runs of at least `min_frames`
consecutive frames of one track with every joint present; each clip is
given ALONE to each gap filler. Conditions: contiguous gaps of each gap
length on 1-3 joints (:func:`sparseedm.temporal.protocols.gap_mask`), and
``"transplanted"``: the missing runs of another real track of the file moved
onto the clip (:func:`sparseedm.real_protocol.transplant_track_mask`), scored
per run-length bin (:data:`sparseedm.temporal.protocols.RUN_BINS`). Methods
(:func:`video_methods`): ``sparseedm`` (:func:`sparseedm.recover` with
``tracks`` and ``frames``), ``per-frame`` (recover without them), the
fillers of :mod:`sparseedm.temporal.fillers` by name (``kalman`` among the
defaults when that module has ``fill_kalman``), or ``module:function``.

Scores (:mod:`sparseedm.real_protocol`): each hidden joint's distance to its
annotation in % of the body size (head top to the ankles' midpoint: the
pose's own for photos, the clip's median for video), the mean and median,
and PCKh@0.5 where head sizes are given. A method may leave a joint NaN
(``unfilled``); ``mean``/``median``/``pckh`` pool the hidden joints that every
method filled, so the rows compare the same joints.
"""

from __future__ import annotations

import csv
import io
import time
import warnings
import zlib
from dataclasses import dataclass, field
from numbers import Integral
from typing import NamedTuple
from pathlib import Path

import numpy as np

from . import _progress
from ._atomic import atomic_path, json_text
from ._validation import Interval, check_mask, check_pose_shape, check_poses, validate_params
from .baselines import NearestNeighbourBaseline, mean_fill
from .dictionary import Dictionary, load_dictionary
from .exceptions import ParameterError, PoseError
from .metrics import check_counts, occlusion_masks
from .real_protocol import (body_size, error_summary, group_summaries, hidden_errors,
                            transplant_masks, transplant_track_mask, usable_patterns)
from .recovery import recover
from .temporal import fillers
from .temporal.evaluation import edge_jumps, resolve_methods
from .temporal.protocols import GAP_LENGTHS, RUN_BINS, gap_mask, run_bin, run_lengths

__all__ = ["evaluate_photos", "evaluate_tracks", "track_clips", "clip_cases", "ClipCase",
           "video_methods",
           "RealReport", "PHOTO_METHODS", "PHOTO_CONDITIONS", "MIN_CLIP_FRAMES"]

#: evaluate_photos' methods, in table order
PHOTO_METHODS = ("sparseedm", "sparseedm-no-adapt", "iterative", "knn", "mean-fill", "nearest")
#: evaluate_photos' default conditions
PHOTO_CONDITIONS = ("mix", "transplanted")
#: a clip of evaluate_tracks has at least this many consecutive complete frames
MIN_CLIP_FRAMES = 30
_STAT_KEYS = ("n", "scored", "mean", "median", "pckh", "pckh_n", "unfilled", "mean_own")
_EDGE_KEYS = ("edges", "edge_jump")


def video_methods():
    """evaluate_tracks' default methods: sparseedm in time and per frame, then the
    gap fillers of :mod:`sparseedm.temporal.fillers` (``kalman`` when it has
    ``fill_kalman``).

    Examples
    --------
    >>> video_methods()[:3]
    ('sparseedm', 'per-frame', 'linear')
    """
    peers = ("linear", "cubic", "akima", "pca")
    if hasattr(fillers, "fill_kalman"):
        peers += ("kalman",)
    return ("sparseedm", "per-frame") + peers


@dataclass
class RealReport:
    """What :func:`evaluate_photos` and :func:`evaluate_tracks` return.

    Attributes
    ----------
    protocol : str
        ``"photos"`` or ``"video"``.
    rows : list of dict
        One per (method, condition, group): ``method``, ``condition`` (``"mix"``,
        ``"transplanted"``, ``"gaps"``...), ``group`` (a joint group of
        :data:`~sparseedm.real_protocol.JOINT_GROUPS`, a gap length ``"gap 10"``
        or a run-length bin, and ``"overall"``), ``n`` (hidden joints),
        ``scored``, ``mean``, ``median`` (% of body size), ``pckh``
        (PCKh@0.5, NaN without head sizes), ``pckh_n``, ``unfilled``,
        ``mean_own`` (see :func:`sparseedm.real_protocol.error_summary`); for
        video also ``edges`` and ``edge_jump``: the gap edges in the group
        (a hidden joint-frame next to an observed one) that every method
        filled, and the fill's mean excess jump there: how much farther the
        filled joint moves than the truth did, 0 where it moves less (the
        positive part of :func:`sparseedm.temporal.evaluation.edge_jumps`, so
        a fill that lags at one edge cannot make up for a jump at another; %
        of body size; NaN where there is none).
    seconds : dict
        ``{condition: {method: seconds}}``.
    settings : dict
        Sizes, seed, conditions, and ``notes`` (what was skipped or adapted).
    """

    protocol: str
    rows: list
    seconds: dict
    settings: dict = field(default_factory=dict)

    @property
    def methods(self):
        return list(dict.fromkeys(r["method"] for r in self.rows))

    @property
    def conditions(self):
        return list(dict.fromkeys(r["condition"] for r in self.rows))

    def row(self, method, condition, group="overall"):
        """The row of `method`, `condition` and `group` (KeyError if absent)."""
        for r in self.rows:
            if (r["method"], r["condition"], r["group"]) == (method, condition, group):
                return r
        raise KeyError((method, condition, group))

    def table(self, condition):
        """A Markdown table of one condition: a row per method, a column per group.

        Cells are ``mean (median)`` in % of body size, then PCKh@0.5 where
        known; a method that filled joints others left unfilled also shows
        its mean over all the hidden joints (``[all n: mean]``). Video
        tables add the mean excess jump at the gap edges (``edge jump``, %
        of body size, all groups).
        """
        rows = [r for r in self.rows if r["condition"] == condition]
        groups = list(dict.fromkeys(r["group"] for r in rows))
        jumps = self.protocol == "video"
        extra = ["edge jump"] if jumps else []
        lines = ["| method | " + " | ".join(groups + extra) + " | seconds |",
                 "|---|" + "---|" * (len(groups) + len(extra) + 1)]
        for m in self.methods:
            cells = [_cell(self.row(m, condition, g)) for g in groups]
            if jumps:  # blank without an edge, as an error cell without a joint
                r = self.row(m, condition)
                cells.append(f"{r['edge_jump']:.2f}" if r["edges"] else "")
            lines.append(f"| {m} | " + " | ".join(cells)
                         + f" | {self.seconds.get(condition, {}).get(m, float('nan')):.1f} |")
        first = [self.row(self.methods[0], condition, g) for g in groups]
        lines.append("| hidden (scored) joints | " + " | ".join(
            f"{r['n']}" + (f" ({r['scored']})" if r["scored"] < r["n"] else "")
            + (f", PCKh on {r['pckh_n']}" if 0 < r["pckh_n"] < r["scored"] else "")
            for r in first) + (f" | {first[-1]['edges']} edges" if jumps else "") + " | |")
        return "\n".join(lines)

    def to_json(self):
        """The report as strict JSON text: protocol, settings, seconds and rows,
        a value that is not a number (NaN: no head sizes, no edge) as ``null``."""
        return json_text({"protocol": self.protocol, "settings": self.settings,
                          "seconds": self.seconds, "rows": self.rows}, indent=1)

    def to_csv(self):
        buf = io.StringIO()
        keys = _STAT_KEYS + (_EDGE_KEYS if self.protocol == "video" else ())
        writer = csv.DictWriter(buf, fieldnames=("method", "condition", "group") + keys,
                                lineterminator="\n")
        writer.writeheader()
        writer.writerows(self.rows)
        return buf.getvalue()

    def write(self, json_path=None, csv_path=None):
        """Write the report as JSON and/or CSV, atomically."""
        for path, text in ((json_path, self.to_json), (csv_path, self.to_csv)):
            if path is not None:
                with atomic_path(path) as tmp:
                    Path(tmp).write_text(text(), encoding="utf-8")


def _cell(r):
    if r["scored"] == 0:
        return ""
    text = f"{r['mean']:.2f} ({r['median']:.2f})"
    if r["pckh_n"]:
        text += f" {r['pckh']:.0%}"
    if r["unfilled"]:
        text += f" [{r['unfilled']} unfilled]"
    elif r["scored"] < r["n"]:
        text += f" [all {r['n']}: {r['mean_own']:.2f}]"
    return text


def _rows(condition, errors, labels, order):
    """Rows of one condition: `errors` {method: HiddenErrors} of the same hidden joints,
    pooled where every method filled; per joint group (`labels` None) or per label
    of `labels` in `order`, then overall."""
    common = np.logical_and.reduce([np.isfinite(e.error) for e in errors.values()])
    rows = []
    for method, e in errors.items():
        if labels is None:
            summaries = group_summaries(e, common)
        else:
            summaries = [{"group": g, **error_summary(
                e.error[sel], e.hit[sel], common[sel])} for g, sel in
                [(g, labels == g) for g in order] + [("overall", np.ones(labels.shape, bool))]]
        rows += [{"method": method, "condition": condition, **s} for s in summaries]
    return rows

# --------------------------------------------------------------------------
# photos


_PHOTO_PARAMS = {
    "n_complete": [Interval(Integral, 0, None), None],
    "n_occluded": [Interval(Integral, 1, None), None],
    "random_state": [Interval(Integral, 0, None)],
    "dictionary": [Dictionary, "path", None],
}


def _photo_sizes(n, n_complete, n_occluded):
    """(C, M) within n poses: as asked when they fit, else scaled down in proportion."""
    c = n - n // 2 if n_complete is None else int(n_complete)
    m = n // 2 if n_occluded is None else int(n_occluded)
    if c + m > n:
        c, m = int(round(n * c / (c + m))), n - int(round(n * c / (c + m)))
    return c, m


def _photo_file(poses, complete, n_complete, n_occluded, random_state):
    """(the file's complete poses, the rows of `poses` to occlude): a seeded draw,
    the complete ones from `complete` when given, else from `poses`."""
    rng = np.random.default_rng([int(random_state), 3])
    if complete is None:
        c, m = _photo_sizes(len(poses), n_complete, n_occluded)
        order = rng.permutation(len(poses))
        return poses[order[:c]], order[c:c + m]
    c = len(complete) if n_complete is None else min(int(n_complete), len(complete))
    m = len(poses) if n_occluded is None else min(int(n_occluded), len(poses))
    return complete[rng.permutation(len(complete))[:c]], rng.permutation(len(poses))[:m]


def _fill_sparse(given, missing, context, **options):
    res = recover(given, missing, dictionary=context["dictionary"], **options)
    if res.adaptation is not None:
        context["adaptation"] = f"{'adapted' if res.adaptation.adapted else 'not adapted'}: " \
                                f"{res.adaptation.reason}"
    return res.poses


def _fill_imputer(given, missing, context, kind):
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer, KNNImputer

    imputer = KNNImputer() if kind == "knn" else IterativeImputer(
        max_iter=10, tol=0, random_state=context["random_state"])
    X = np.where(missing[..., None], np.nan, given).reshape(len(given), -1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # tol=0: "early stopping criterion not reached"
        return imputer.fit_transform(X).reshape(given.shape)


def _fill_nearest(given, missing, context):
    complete = given[~missing.any(axis=1)]
    if not len(complete):
        return np.full(given.shape, np.nan)
    nn = NearestNeighbourBaseline(max_train=len(complete), random_state=context["random_state"])
    return nn.fit(complete).complete(given, missing).poses


_PHOTO_FILLERS = {
    "sparseedm": _fill_sparse,
    "sparseedm-no-adapt": lambda g, m, c: _fill_sparse(g, m, c, adapt=False),
    "sparseedm-no-adapt-mirror": lambda g, m, c: _fill_sparse(g, m, c, adapt=False, mirror=True),
    "sparseedm-no-adapt-mirror-auto": lambda g, m, c: _fill_sparse(g, m, c, adapt=False,
                                                                   mirror="auto"),
    "iterative": lambda g, m, c: _fill_imputer(g, m, c, "iterative"),
    "knn": lambda g, m, c: _fill_imputer(g, m, c, "knn"),
    "mean-fill": lambda g, m, c: mean_fill(g, m).poses,
    "nearest": _fill_nearest,
}


def _photo_conditions(conditions, pool, n_occluded, random_state, notes):
    """{condition: (M, 14) mask}; "transplanted" skipped with a note without a usable pool."""
    masks = {}
    for c in conditions:
        if c == "transplanted":
            if pool is None or not usable_patterns(pool).size:
                notes.append("transplanted: skipped, no incomplete pose keeps 3 observed joints")
                continue
            rng = np.random.default_rng([int(random_state), 7])
            masks[c] = transplant_masks(n_occluded, pool, random_state=rng)[0]
        else:
            count = check_counts([c])[0]
            masks[str(count)] = occlusion_masks(n_occluded, 14, (count,), random_state)[count]
    return masks


def evaluate_photos(poses, pool=None, *, complete=None, n_complete=None, n_occluded=None,
                    conditions=PHOTO_CONDITIONS, methods=PHOTO_METHODS, head_size=None,
                    dictionary=None, random_state=0):
    """Real photos: hide joints of complete poses in one file; score every method.

    Parameters
    ----------
    poses : array_like (n, 14, 2)
        Complete poses (every joint present), pixels: the truth.
    pool : array_like of bool (k, 14), optional
        Real missing patterns (True = missing) for ``"transplanted"``, e.g.
        the file's incomplete poses; without one that keeps 3 observed
        joints, that condition is skipped (noted in ``settings["notes"]``).
    complete : array_like (k, 14, 2), optional
        The file's complete poses from elsewhere (other images of the same
        source); default: drawn from `poses`.
    n_complete, n_occluded : int, optional
        Poses kept complete (C) and poses occluded (M); default half of
        `poses` each (with `complete`: all of both). Scaled down in
        proportion when C + M exceeds n (with `complete`: each to what there
        is); the sizes used are in ``settings``.
    conditions : sequence, default ("mix", "transplanted")
        Among 1, 2, 3, "mix", "transplanted".
    methods : sequence of str, default PHOTO_METHODS
        Among PHOTO_METHODS, ``"sparseedm-no-adapt-mirror"`` and
        ``"sparseedm-no-adapt-mirror-auto"``.
    head_size : array_like (n,), optional
        PCKh's normaliser per pose (MPII's head size); None: no PCKh.
    dictionary : Dictionary, str or path, optional
        sparseedm's (None: :func:`~sparseedm.recover`'s own: the shipped default,
        and without adaptation ``cmu-coco-k2932`` with ``mirror="auto"`` and the
        shipped pose bank).
    random_state : int, default 0
        Seeds the split and the masks.

    Returns
    -------
    RealReport
        Rows per condition and joint group.

    Examples
    --------
    Twenty complete poses stay complete, two joints are hidden in each of the
    other twenty:

    >>> poses = np.random.default_rng(0).normal(100.0, 20.0, size=(40, 14, 2))
    >>> rep = evaluate_photos(poses, conditions=[2], methods=["mean-fill", "nearest"])
    >>> rep.settings["n_complete"], rep.row("nearest", "2")["n"]
    (20, 40)
    """
    validate_params("evaluate_photos", dict(n_complete=n_complete, n_occluded=n_occluded,
                                            random_state=random_state, dictionary=dictionary),
                    _PHOTO_PARAMS)
    poses = check_poses(poses, "evaluate_photos")
    check_pose_shape(poses, n_joints=14, model="protocol")
    if not np.isfinite(poses).all():
        raise PoseError("evaluate_photos: poses must be complete (the truth); a joint is NaN")
    unknown = [m for m in methods if m not in _PHOTO_FILLERS]
    if unknown or not methods:
        raise ParameterError(f"evaluate_photos: unknown method(s) {unknown}; known: "
                             f"{', '.join(_PHOTO_FILLERS)}")
    pool = None if pool is None else check_mask(pool, "evaluate_photos", "pool")
    head = None if head_size is None else np.asarray(head_size, float)
    if complete is not None:
        complete = check_poses(complete, "evaluate_photos", "complete")
        check_pose_shape(complete, "complete", n_joints=14, model="protocol")
        if not np.isfinite(complete).all():
            raise PoseError("evaluate_photos: complete poses must have every joint")
    kept, occ = _photo_file(poses, complete, n_complete, n_occluded, random_state)
    c, m = len(kept), len(occ)
    if m < 1:
        raise PoseError(f"evaluate_photos: {len(poses)} complete poses: none left to occlude")
    notes = []
    masks = _photo_conditions(conditions, pool, m, random_state, notes)
    if dictionary is not None and not isinstance(dictionary, Dictionary) and \
            any(m.startswith("sparseedm") for m in methods):
        dictionary = load_dictionary(dictionary)  # None stays: recover()'s own default
    truth = poses[occ]
    rows, seconds = [], {}
    for cond, mask in masks.items():
        given = np.concatenate([kept, np.where(mask[..., None], np.nan, truth)])
        missing = np.concatenate([np.zeros((c, 14), bool), mask])
        context = {"dictionary": dictionary, "random_state": int(random_state)}
        errors, seconds[cond] = {}, {}
        for name in methods:
            _progress.say(f"evaluating {name} on {len(given):,} poses ({cond})")
            start = time.perf_counter()
            filled = _PHOTO_FILLERS[name](given, missing, context)
            seconds[cond][name] = time.perf_counter() - start
            errors[name] = hidden_errors(filled[c:], truth, mask, body_size(truth),
                                         None if head is None else head[occ])
        if "adaptation" in context:
            notes.append(f"{cond}: sparseedm {context['adaptation']}")
        rows += _rows(cond, errors, None, ())
    settings = {"poses": len(poses), "n_complete": c, "n_occluded": m,
                "complete_given": complete is not None,
                "conditions": list(masks), "random_state": int(random_state),
                "pool": 0 if pool is None else int(usable_patterns(pool).size),
                "pckh": head is not None, "notes": notes}
    return RealReport("photos", rows, seconds, settings)


# --------------------------------------------------------------------------
# video


def _track_rows(tracks, frames):
    """{track: its rows in frame order}; a repeated frame in a track is refused."""
    out = {}
    for t in np.unique(tracks):
        rows = np.flatnonzero(tracks == t)
        rows = rows[np.argsort(frames[rows], kind="stable")]
        same = np.flatnonzero(np.diff(frames[rows]) == 0)
        if len(same):
            twice = rows[same[0]:same[0] + 2]
            raise PoseError(f"evaluate_tracks: track {t}: frame {frames[twice[0]]} is given "
                            f"twice (rows {twice[0]} and {twice[1]}): one pose per track "
                            "and frame")
        out[t] = rows
    return out


def track_clips(poses, tracks, frames, *, min_frames=MIN_CLIP_FRAMES):
    """The clips of a file: runs of consecutive frames of one track, all joints present.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        NaN where a joint is missing.
    tracks, frames : ndarray (n,)
    min_frames : int, default 30

    Returns
    -------
    list of (track, ndarray of int)
        Each clip's track and rows, in frame order; maximal runs only.

    Examples
    --------
    >>> p = np.zeros((6, 14, 2)); p[3, 0] = np.nan
    >>> [(int(t), r.tolist()) for t, r in track_clips(p, np.zeros(6), np.arange(6), min_frames=2)]
    [(0, [0, 1, 2]), (0, [4, 5])]
    """
    complete = np.isfinite(poses).all(axis=(1, 2))
    clips = []
    for track, rows in _track_rows(tracks, frames).items():
        ok = complete[rows]
        step = np.diff(frames[rows]) == 1
        start = 0
        for i in range(1, len(rows) + 1):
            if i == len(rows) or not (ok[i] and ok[i - 1] and step[i - 1]):
                run = rows[start:i][ok[start:i]]
                if len(run) >= min_frames:
                    clips.append((track, run))
                start = i
    return clips


def _video_fillers(methods, dictionary):
    """{name: fill(poses, missing, frames)} for evaluate_tracks' method names."""
    own = ("sparseedm", "per-frame", "kalman")
    unknown = [m for m in methods if m not in own and m not in fillers.FILLERS and ":" not in m]
    if unknown or not methods:
        known = ", ".join(dict.fromkeys(own + tuple(fillers.FILLERS)))
        raise ParameterError(f"evaluate_tracks: unknown method(s) {unknown}; known: {known}, "
                             "module:function" if unknown else
                             f"evaluate_tracks: no method given; give one or more of {known}")
    if {"sparseedm", "per-frame", "sparse"} & set(methods) and \
            not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    out = {}
    for name in methods:
        if name == "sparseedm":
            def fill(poses, missing, frames):
                return recover(poses, missing, dictionary=dictionary,
                               tracks=np.zeros(len(frames), int), frames=frames).poses
            out[name] = fill
        elif name == "per-frame":
            out[name] = fillers.sparse_filler(dictionary)
        elif name == "kalman":
            if not hasattr(fillers, "fill_kalman"):
                raise ParameterError("evaluate_tracks: method 'kalman' needs "
                                     "sparseedm.temporal.fillers.fill_kalman")
            out[name] = fillers.fill_kalman
        else:
            out.update(resolve_methods([name], dictionary))
    return out


_VIDEO_PARAMS = {
    "min_frames": [Interval(Integral, 2, None)],
    "max_clips": [Interval(Integral, 1, None), None],
    "random_state": [Interval(Integral, 0, None)],
    "dictionary": [Dictionary, "path", None],
    "transplanted": ["boolean"],
}


def _clip_masks(n_frames, gap_lengths, donors, transplanted, rng_for):
    """{condition label: (T, 14) mask} of one clip; empty masks dropped."""
    masks = {f"gap {L}": gap_mask(n_frames, L, random_state=rng_for(L)) for L in gap_lengths}
    if transplanted and donors:
        masks["transplanted"] = transplant_track_mask(n_frames, donors,
                                                      random_state=rng_for(0))[0]
    return {k: v for k, v in masks.items() if v.any()}


class ClipCase(NamedTuple):
    """One clip of the real-video protocol and the masks hidden on it."""

    #: the clip's track and its first frame, ``"track:frame"`` (seeds its masks)
    clip_id: str
    #: the clip's rows, in frame order
    rows: np.ndarray
    #: {condition label ("gap L" or "transplanted"): (T, 14) mask}, none empty
    masks: dict


def clip_cases(poses, tracks, frames, hidden, *, gap_lengths=GAP_LENGTHS, transplanted=True,
               min_frames=MIN_CLIP_FRAMES, max_clips=None, random_state=0, notes=None):
    """The clips of :func:`evaluate_tracks` and their masks, drawn as it draws them.

    Parameters
    ----------
    poses : ndarray (n, 14, 2)
        Pixels, NaN where a joint is missing.
    tracks, frames : ndarray (n,)
        Person and frame number of each pose.
    hidden : ndarray of bool (n, 14)
        The real missing joints the transplanted runs come from.
    gap_lengths, transplanted, min_frames, max_clips, random_state
        As :func:`evaluate_tracks`.
    notes : list, optional
        Receives what was left out (no clip, a sample of the clips).

    Yields
    ------
    ClipCase
        One per clip, in :func:`track_clips`' order.
    """
    clips = track_clips(poses, tracks, frames, min_frames=min_frames)
    notes = [] if notes is None else notes
    if not clips:
        notes.append(f"no clip of {min_frames} consecutive complete frames")
    if max_clips is not None and len(clips) > max_clips:
        pick = np.sort(np.random.default_rng([int(random_state), 5]).choice(
            len(clips), max_clips, replace=False))
        notes.append(f"a seeded sample of {max_clips} of {len(clips)} clips")
        clips = [clips[i] for i in pick]
    longest = max((len(rows) for _, rows in clips), default=0)
    notes += [f"gap {L}: no clip longer than {L} frames (the longest has {longest}), so no "
              f"gap of {L} frames" for L in gap_lengths if clips and L >= longest]
    by_track = _track_rows(tracks, frames)
    for track, rows in clips:
        donors = [hidden[r] for t, r in by_track.items() if t != track and hidden[r].any()]
        clip_id = f"{track}:{frames[rows[0]]}"

        def rng_for(extra, clip_id=clip_id):
            return np.random.default_rng([int(random_state), zlib.crc32(clip_id.encode()), extra])

        yield ClipCase(clip_id, rows,
                       _clip_masks(len(rows), gap_lengths, donors, transplanted, rng_for))


def evaluate_tracks(poses, tracks, frames, *, occluded=None, gap_lengths=GAP_LENGTHS,
                    transplanted=True, methods=None, head_size=None,
                    min_frames=MIN_CLIP_FRAMES, max_clips=None, dictionary=None,
                    random_state=0):
    """Real video: hide joints of complete clips, each clip given alone to each filler.

    Parameters
    ----------
    poses : array_like (n, 14, 2)
        Pixels, NaN where a joint is missing (not annotated).
    tracks, frames : array_like (n,)
        Person and frame number of each pose.
    occluded : array_like of bool (n, 14), optional
        Real missing joints the transplanted runs come from (True = missing:
        not annotated, or flagged invisible); default the NaN joints.
    gap_lengths : tuple of int, default (3, 10, 30, 90)
        Gaps on 1-3 joints (17 % of joint-frames) per length; a clip no
        longer than a gap gets none of that length.
    transplanted : bool, default True
        Also the missing runs of another track (scored per run-length bin).
    methods : sequence of str, optional
        Default :func:`video_methods`.
    head_size : array_like (n,), optional
        PCKh's normaliser per pose; None: no PCKh.
    min_frames : int, default 30
        Clips: at least this many consecutive complete frames of a track.
    max_clips : int, optional
        A seeded sample of this many clips (noted in ``settings``).
    dictionary : Dictionary, str or path, optional
    random_state : int, default 0
        Seeds the masks (with each clip's id) and the clip sample.

    Returns
    -------
    RealReport
        Conditions ``"gaps"`` (groups ``"gap L"``) and ``"transplanted"``
        (groups: run-length bins), each with ``"overall"``.
    """
    validate_params("evaluate_tracks", dict(min_frames=min_frames, max_clips=max_clips,
                                            random_state=random_state, dictionary=dictionary,
                                            transplanted=transplanted), _VIDEO_PARAMS)
    poses = check_poses(poses, "evaluate_tracks")
    check_pose_shape(poses, n_joints=14, model="protocol")
    tracks, frames = np.asarray(tracks), np.asarray(frames)
    if tracks.shape != poses.shape[:1] or frames.shape != poses.shape[:1]:
        raise PoseError(f"evaluate_tracks: tracks and frames must have shape ({len(poses)},)")
    hidden = ~np.isfinite(poses).all(axis=-1)
    if occluded is not None:
        hidden |= check_mask(occluded, "evaluate_tracks", "occluded")
    fills = _video_fillers(video_methods() if methods is None else tuple(methods), dictionary)
    notes, n_clips, n_frames = [], 0, 0
    scores = {}
    for _, rows, masks in _progress.steps(clip_cases(
            poses, tracks, frames, hidden, gap_lengths=gap_lengths, transplanted=transplanted,
            min_frames=min_frames, max_clips=max_clips, random_state=random_state,
            notes=notes), f"evaluating {', '.join(fills)} clip by clip", unit="clip"):
        n_clips, n_frames = n_clips + 1, n_frames + len(rows)
        heads = None if head_size is None else np.asarray(head_size, float)[rows]
        for label, mask in masks.items():
            _score_case(scores, fills, poses[rows], frames[rows], heads, label, mask)
    rows_out = []
    for cond, sc in scores.items():
        order = [f"gap {L}" for L in gap_lengths] if cond == "gaps" else \
            [label for _, _, label in RUN_BINS]
        joined = {m: _concat(parts) for m, parts in sc["errors"].items()}
        cond_rows = _rows(cond, joined, np.concatenate(sc["labels"]), order)
        _edge_rows(cond_rows, {m: np.concatenate(j) for m, j in sc["jumps"].items()},
                   np.concatenate(sc["edge_labels"]))
        rows_out += cond_rows
    seconds = {cond: sc["seconds"] for cond, sc in scores.items()}
    settings = {"clips": n_clips, "frames": int(n_frames),
                "tracks": int(len(np.unique(tracks))), "min_frames": int(min_frames),
                "gap_lengths": [int(L) for L in gap_lengths], "transplanted": transplanted,
                "random_state": int(random_state), "pckh": head_size is not None,
                "notes": notes}
    return RealReport("video", rows_out, seconds, settings)


def _score_case(scores, fills, truth, frames, heads, label, mask):
    """Hide `mask` on one clip, fill it with each of `fills`, and add the hidden
    joints' errors, their edges' excess jumps and the seconds to `scores`."""
    cond = "transplanted" if label == "transplanted" else "gaps"
    sc = scores.setdefault(cond, {"errors": {}, "jumps": {}, "seconds": {}, "labels": [],
                                  "edge_labels": []})
    size = np.full(len(truth), np.nanmedian(body_size(truth)))
    bins = run_bin(run_lengths(mask)[0]) if cond == "transplanted" \
        else np.full(mask.shape, label)
    edges = np.isfinite(edge_jumps(truth, truth, mask, frames))    # (T, 14, 2)
    sc["labels"].append(bins[mask])
    sc["edge_labels"].append(np.broadcast_to(bins[..., None], edges.shape)[edges])
    given = np.where(mask[..., None], np.nan, truth)
    for name, fill in fills.items():
        start = time.perf_counter()
        filled = fill(given, mask, frames)
        sc["seconds"][name] = sc["seconds"].get(name, 0.0) + time.perf_counter() - start
        sc["errors"].setdefault(name, []).append(hidden_errors(filled, truth, mask, size, heads))
        jump = edge_jumps(truth, filled, mask, frames) / size[:, None, None] * 100.0
        with np.errstate(invalid="ignore"):   # NaN (unfilled) stays NaN
            sc["jumps"].setdefault(name, []).append(np.where(jump > 0, jump, 0.0 * jump)[edges])


def _edge_rows(rows, jumps, labels):
    """Add ``edges`` and ``edge_jump`` to each of one condition's `rows`: the mean
    excess jump over the group's edges (all of them for ``"overall"``) that
    every method filled."""
    common = np.logical_and.reduce([np.isfinite(j) for j in jumps.values()])
    for r in rows:
        sel = common & ((labels == r["group"]) if r["group"] != "overall" else True)
        j = jumps[r["method"]][sel]
        r["edges"] = int(j.size)
        r["edge_jump"] = float(j.mean()) if j.size else float("nan")


def _concat(parts):
    return type(parts[0])(*(np.concatenate(a) for a in zip(*parts)))
