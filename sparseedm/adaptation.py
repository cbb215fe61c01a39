"""Adapt a dictionary to the user's own poses before recovering their occluded joints.

A keypoint file is mostly complete poses with some occluded joints; the
complete ones are in-domain training data. :func:`adapt` continues the online
dictionary learning of :mod:`sparseedm.learning` from the given atoms (a warm
start) on the normalised EDM vectors of those poses, and returns the adapted
:class:`~sparseedm.dictionary.Dictionary`. :func:`run_adaptation` does the same
and returns an :class:`AdaptationResult` saying what happened; it is what
``recover(..., adapt="auto")`` and ``sparseedm recover`` run.

Steps of :func:`run_adaptation`
-------------------------------
1. **Bound** the work: at most ``max_poses`` of the complete poses, a seeded
   sample (before the filters, which code every pose they check).
2. **Filter** implausible poses, each by a small pure function:
   :func:`usable_rows` (NaN/inf, zero extent), :func:`repeat_rows` (repeats,
   exact or within :data:`REPEAT_TOLERANCE` of the pose's size: a frozen
   detector, a still person), :func:`reconstruction_error` +
   :func:`outlier_rows` (far-out relative residual under the base dictionary:
   detector garbage) and :func:`swapped_rows` (the arms' or the legs'
   left/right labels exchanged: the exchanged pose is explained much better;
   checked on the worst-explained quarter of the poses only, to save time).
3. **Hold back** a validation slice (``validation_fraction``, whole
   contiguous blocks of rows, so neighbouring video frames do not leak
   across; at most 300 poses), adapt on the rest.
4. **Guard**: occlude the held-back poses with the evaluation protocol's
   Mix of 1-3 joints (:func:`guard_masks`: the protocol's masks of a few
   patterns, each shared by ``GUARD_POSES_PER_PATTERN`` poses so that the
   fast solver recovers them in batches), recover them with the base and
   with the adapted dictionary and compare the mean Err_ave; the base
   dictionary is kept unless the adapted one is better. Both figures are
   reported. The base's figure is worked out in a side thread while the
   adapted dictionary is learned (:class:`_BaseGuard`: the learning leaves a
   core mostly idle; the same figure, measured 0.5-1 s sooner on a
   10,000-frame video file).

Self-training (:func:`self_train`)
----------------------------------
The incomplete poses to be recovered are in-domain data too: their observed
joints show the very poses (and clips) that are scored. After adapting,
``recover`` recovers a bounded seeded sample of them, adapts the *base*
dictionary again on the complete poses plus those filled poses, recovers
again, and so on for ``SELF_TRAINING_ROUNDS`` rounds (transductive
self-training; only the observed joints of the incomplete poses carry new
information, the filled ones are the model's own). The rounds before the last
learn on every complete pose, the guard's held-back ones included, unchecked:
they only fill the next round's poses. The last round holds the guard's poses
back and is judged on them (the filled poses are never held back); when the
guard rejects it, the first adaptation is used. On the validation files
(``studies/adaptation/probe_self_training_cost.py``) this was 1-2 % more accurate
than judging every round, and two guards cheaper.

The learning (:func:`adapt_vectors`)
------------------------------------
``stats="fresh"`` starts Mairal's inner statistics A, B at zero, as a new fit
does (atoms no adaptation pose uses are re-drawn from the poses).
``stats="carried"`` starts them as if each base atom had been seen
``memory`` times on its own (``A = memory I``, ``B = memory D^T``), without
the early-batch forgetting: atoms move towards the new poses in proportion to
how much the new poses use them, unused atoms stay as they were. ``replay``
mixes base atoms, scaled to the poses' typical norm, into every mini-batch
against forgetting. The defaults were chosen on cross-source validation splits
by ``studies/adaptation/select_adaptation.py`` (results in
``studies/adaptation/selection_adaptation.json``, summary in
``docs/explanation/settings.md``, "Adaptation and self-training").
"""

from __future__ import annotations

import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from . import _progress
from ._atomic import check_paths
from ._parallel import numba_threads
from ._recovery_kernel import RECOVER_PARAMS, compiled_solver, recover_members, recover_sparse
from ._validation import check_mask, check_pose_shape, check_poses, unmask, validate_params
from .dictionary import Dictionary, load_dictionary
from .edm import pose_to_vector
from .keypoints import default_errors_path
from .exceptions import DictionaryError, PoseError, SparseEDMError
from .learning import (OnlineDictionaryLearning, complete_pose_vectors, iter_batches,
                       load_training_poses, poses_sha256, sparse_code, training_errors)
from .metrics import err_ave, occlusion_masks
from .normalize import normalize, usable_rows
from .skeleton import SKELETON_14
from .solvers.gram import gram_matrix

__all__ = ["adapt", "run_adaptation", "adapt_vectors", "AdaptationResult",
           "usable_rows", "duplicate_rows", "repeat_rows", "REPEAT_TOLERANCE",
           "reconstruction_error", "outlier_rows",
           "swapped_rows", "filter_poses", "holdout_blocks", "resolve_adaptation",
           "masked_error", "guard_masks", "sample_complete", "sample_stream", "fine_tune_file",
           "self_train", "MIN_COMPLETE_POSES", "ADAPTED_ALPHA_TRAIN",
           "adaptation_alpha", "STATS", "SELF_TRAINING_ROUNDS", "AVERAGED_PATH",
           "MIRRORED_ATOMS_PATH", "FILE_ATOMS_PATHS"]

#: Fewest complete poses (after filtering) that ``adapt="auto"`` adapts on;
#: chosen on the validation splits (docs/explanation/settings.md).
MIN_COMPLETE_POSES = 250
#: AdaptationResult.path when the default path averages the answers of the file's
#: own complete poses as the only atoms, of those with their mirror images, and of
#: the base with them as extra atoms (:mod:`sparseedm.exemplars`)
AVERAGED_PATH = "file atoms and their mirror images averaged with base + file atoms"
#: AdaptationResult.path when, below MIN_COMPLETE_POSES, the default path averages
#: the answers of the base with the file's complete poses as extra atoms and of
#: the base with them and their mirror images as extra atoms (:mod:`sparseedm.exemplars`)
MIRRORED_ATOMS_PATH = "base + file atoms averaged with base + file atoms and mirror images"
#: AdaptationResult.path values where the file's own complete poses are the only
#: atoms (their answers alone, or averaged with others': :data:`AVERAGED_PATH`)
FILE_ATOMS_PATHS = ("file atoms", AVERAGED_PATH)
#: the answers each averaging path averages (AdaptationResult.averaged_answers)
_AVERAGED_ANSWERS = {
    AVERAGED_PATH: ("file atoms", "file atoms and their mirror images", "base + file atoms"),
    MIRRORED_ATOMS_PATH: ("base + file atoms", "base + file atoms and their mirror images")}
#: Inner-statistics modes of :func:`adapt_vectors`.
STATS = ("fresh", "carried")
# defaults chosen by studies/adaptation/select_adaptation.py (see docs/explanation/settings.md)
DEFAULT_PASSES = 2
#: The adapted dictionary's recommended recovery alpha is the base's times this
#: (0.0005 -> 0.00025 for the shipped default; chosen on the validation splits,
#: grid 6 of studies/adaptation/select_adaptation.py).
ADAPTED_ALPHA_RECOVER_FACTOR = 0.5
#: Lasso penalty of the adaptation's coding step (``alpha=None``):
#: ``min(ADAPTED_ALPHA_TRAIN_FACTOR * base alpha_train, ADAPTED_ALPHA_TRAIN)``,
#: sparser codes than the base's own (0.8 for the all-CMU default -> 3.2; 1.6
#: for the k = 2000 ones -> 3.2). Chosen on the validation splits (grid 6 of
#: studies/adaptation/select_adaptation.py): 2-5 % lower error than the base's alpha
#: for k = 2000 dictionaries, and a faster learning (shorter LARS paths). The
#: factor keeps small dictionaries (trained with small alphas: denser codes)
#: away from a penalty that would leave their codes empty.
ADAPTED_ALPHA_TRAIN = 3.2
ADAPTED_ALPHA_TRAIN_FACTOR = 4.0


def adaptation_alpha(dictionary):
    """The default training alpha of adapting `dictionary` (see ADAPTED_ALPHA_TRAIN).

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary (its ``alpha_train`` is used).

    Returns
    -------
    float
        ``min(ADAPTED_ALPHA_TRAIN_FACTOR * alpha_train, ADAPTED_ALPHA_TRAIN)``.

    Examples
    --------
    >>> import sparseedm
    >>> adaptation_alpha(sparseedm.load_dictionary())   # the default's 0.8, times 4
    3.2
    """
    return float(min(ADAPTED_ALPHA_TRAIN_FACTOR * dictionary.alpha_train, ADAPTED_ALPHA_TRAIN))
DEFAULT_STATS = "fresh"
DEFAULT_REPLAY = 0.0
DEFAULT_MEMORY = 1.0
DEFAULT_BATCH_SIZE = 256
DEFAULT_REINIT = False
DEFAULT_MAX_POSES = 5000
DEFAULT_VALIDATION_FRACTION = 0.2
MAX_VALIDATION = 300
#: Rounds of :func:`self_train` that ``recover`` runs after adapting (0: none);
#: chosen on the validation splits (grid 8 of studies/adaptation/select_adaptation.py).
SELF_TRAINING_ROUNDS = 3
#: Fewest incomplete poses (recovered) a self-training round learns from.
MIN_SELF_TRAINING_POSES = 50
#: Most incomplete poses (a seeded sample) a self-training round recovers and
#: learns from: bounds its cost (3 rounds on 5,000 poses took ~30 s on 2 cores,
#: benchmarks/README.md); the validation and test runs used 600 and 1,200.
SELF_TRAINING_MAX_POSES = 2000
#: Most complete poses (a seeded sample of the first adaptation's training
#: rows) a self-training round learns from beside its filled ones; None: all.
SELF_TRAINING_MAX_COMPLETE = None
#: Recovery alpha of a self-training round's sample, times the current
#: dictionary's ``alpha_recover``. A larger factor means shorter LARS paths
#: (fewer atoms per pose) and cheaper rounds, but the filled poses feed the next
#: round: on the validation splits (studies/adaptation/probe_self_training_cost.py)
#: x 2 moved the error by -0.7 / +0.3 / +3.1 % for about a fifth less
#: time in the rounds' recoveries, so the default stays 1 (exact as before).
SELF_TRAINING_ALPHA_FACTOR = 1.0
#: Held-back poses per occlusion pattern of the guard (:func:`guard_masks`):
#: the fast solver codes a pattern's poses together through one Gram matrix
#: once they are at least its ``gram_min`` (12).
GUARD_POSES_PER_PATTERN = 12


# --------------------------------------------------------------------------
# filters: small pure functions over poses / vectors

def duplicate_rows(X, decimals=9):
    """True for rows that repeat an earlier row (after rounding to `decimals`).

    Parameters
    ----------
    X : array_like (n, m)
        The rows (EDM vectors or any other).
    decimals : int, default 9
        Rows equal after rounding to this many decimals are repeats.

    Returns
    -------
    ndarray of bool (n,)
        True for every repeat after its first occurrence.

    Examples
    --------
    >>> duplicate_rows([[1., 2.], [3., 4.], [1., 2.]]).tolist()
    [False, False, True]
    """
    X = np.round(np.asarray(X, dtype=float), decimals)
    if len(X) == 0:
        return np.zeros(0, dtype=bool)
    _, first = np.unique(X, axis=0, return_index=True)
    out = np.ones(len(X), dtype=bool)
    out[first] = False
    return out


#: Two complete poses are one when their EDM vectors, each scaled to unit norm,
#: are closer than this (:func:`repeat_rows`). Relative to the pose's own size:
#: about 1e-4 of it moved at every joint, 0.01 px on a person 100 px across, far
#: below annotation or detector precision (1 px there is 1e-2) and below the
#: closest distinct poses of the validation files (CMU frames 6.5e-3, MPII and
#: COCO photos 4e-2); a still person with 1e-4 px of noise is 1e-6 apart.
REPEAT_TOLERANCE = 1e-4


def repeat_rows(X, tolerance=REPEAT_TOLERANCE, neighbours=16):
    """True for rows that repeat an earlier row up to `tolerance`, relative to the rows' size.

    Rows are scaled to unit norm and joined when closer than `tolerance`
    (each to at most its `neighbours` nearest); every row of a group so
    joined after its first is a repeat. Exact repeats (:func:`duplicate_rows`)
    are repeats too. A group can chain: rows each within `tolerance` of the
    next are one, however far its ends drift (at 1e-4, only a pose held still
    to a hundredth of a pixel).

    Parameters
    ----------
    X : array_like (n, m)
        Rows with a nonzero norm (the EDM vectors of usable poses).
    tolerance : float, default REPEAT_TOLERANCE
        Largest distance between two unit-norm rows that are one; 0: exact
        repeats only.
    neighbours : int, default 16
        Nearest rows each row is compared with (a bound on the work: a
        group of near-copies is joined through its members' neighbours).

    Returns
    -------
    ndarray of bool (n,)
        True for every repeat after its group's first row.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.array([[1.0, 2.0], [3.0, 4.0], [1.0, 2.0 + 1e-7], [10.0, 20.0]])
    >>> repeat_rows(X).tolist()                  # a near-copy, and a scaled copy
    [False, False, True, True]
    >>> repeat_rows(X, tolerance=0).tolist()     # exact repeats only
    [False, False, False, False]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    X = np.asarray(X, dtype=float)
    out = duplicate_rows(X)
    rows = np.flatnonzero(~out)
    if tolerance <= 0 or len(rows) < 2:
        return out
    U = X[rows] / np.linalg.norm(X[rows], axis=1, keepdims=True)
    dist, near = cKDTree(U).query(U, k=min(int(neighbours), len(rows)),
                                  distance_upper_bound=float(tolerance))
    joined = np.isfinite(dist)  # a missing neighbour has an infinite distance
    own = np.broadcast_to(np.arange(len(rows))[:, None], near.shape)
    graph = coo_matrix((np.ones(joined.sum()), (own[joined], near[joined])),
                       shape=(len(rows), len(rows)))
    _, group = connected_components(graph, directed=False)
    first = np.zeros(len(rows), bool)
    first[np.unique(group, return_index=True)[1]] = True
    out[rows[~first]] = True
    return out


def reconstruction_error(X, components, alpha):
    """Relative residual ``||x - D c|| / ||x||`` of each row's lasso code.

    Parameters
    ----------
    X : ndarray (n, m)
        Normalised EDM vectors.
    components : ndarray (k, m)
        The dictionary's atoms.
    alpha : float
        Lasso penalty of the code (a dictionary's ``alpha_train``).

    Returns
    -------
    ndarray (n,)
        Each row's residual relative to its norm (0 <= e, 1 for an empty code).
    """
    X = np.asarray(X, dtype=float)
    if len(X) == 0:
        return np.zeros(0)
    code = sparse_code(X, components, alpha)
    R = X - code @ components
    return np.linalg.norm(R, axis=1) / np.maximum(np.linalg.norm(X, axis=1), 1e-12)


def outlier_rows(errors, factor=3.0):
    """True for far-out errors: above ``Q3 + factor * (Q3 - Q1)`` (Tukey's fence).

    Parameters
    ----------
    errors : array_like (n,)
        Per-row errors (:func:`reconstruction_error`).
    factor : float, default 3.0
        Interquartile ranges above the third quartile that make an outlier.

    Returns
    -------
    ndarray of bool (n,)
        True for the outliers; none when fewer than 4 errors are given.

    Examples
    --------
    >>> outlier_rows([1.0, 1.1, 0.9, 1.0, 1.05, 9.0]).tolist()
    [False, False, False, False, False, True]
    """
    e = np.asarray(errors, dtype=float)
    if len(e) < 4:
        return np.zeros(len(e), dtype=bool)
    q1, q3 = np.percentile(e, [25, 75])
    return e > q3 + factor * (q3 - q1)


def _swap(poses, pairs):
    out = poses.copy()
    for a, b in pairs:
        out[:, [a, b]] = poses[:, [b, a]]
    return out


def swapped_rows(poses, components, alpha, *, skeleton=SKELETON_14, ratio=0.5, errors=None):
    """True where the arms' or the legs' left/right labels look exchanged.

    A pose whose arm (or leg) joints have their left and right labels
    exchanged -- a detector's common mistake -- is explained by the
    dictionary much better after exchanging them back. A pose is flagged when
    exchanging the arms or the legs lowers its relative reconstruction error
    below ``ratio`` times its own. (Exchanging every left/right label at once
    gives the pose seen from behind, a plausible pose: that is not tested.)

    Parameters
    ----------
    poses : ndarray (n, N, 2), complete
        The poses to check, in pixels.
    components : ndarray (k, m)
        The dictionary's atoms.
    alpha : float
        Lasso penalty of the codes (a dictionary's ``alpha_train``).
    skeleton : Skeleton, default SKELETON_14
        Names the left/right joint pairs; arms are the shoulder, elbow and
        wrist pairs, legs the others.
    ratio : float, default 0.5
        Flag a pose when an exchange brings its error below this times its own.
    errors : ndarray (n,), optional
        The poses' own :func:`reconstruction_error`, if already known.

    Returns
    -------
    ndarray of bool (n,)
        True for the poses whose arms or legs look exchanged.
    """
    poses = np.asarray(poses, dtype=float)
    if len(poses) == 0:
        return np.zeros(0, dtype=bool)
    pairs = list(zip(skeleton.joints_left, skeleton.joints_right))
    # arms: the pairs whose joints hang from the shoulders; legs: the rest
    names = skeleton.joint_names
    arms = [(a, b) for a, b in pairs if any(k in names[a] for k in ("shoulder", "elbow", "wrist"))]
    legs = [p for p in pairs if p not in arms]
    base = reconstruction_error(pose_vectors(poses), components, alpha) if errors is None \
        else np.asarray(errors, dtype=float)
    groups = [g for g in (arms, legs) if g]
    if not groups:
        return np.zeros(len(poses), dtype=bool)
    # the arms- and the legs-exchanged poses coded in one batch
    err = reconstruction_error(np.vstack([pose_vectors(_swap(poses, g)) for g in groups]),
                               components, alpha).reshape(len(groups), len(poses))
    return (err < ratio * base).any(axis=0)


def pose_vectors(poses):
    normed, _, _ = normalize(poses)
    return pose_to_vector(normed)


@dataclass
class FilterReport:
    """Which complete poses survived :func:`filter_poses`, and why others did not."""

    keep: np.ndarray
    counts: dict


def filter_poses(poses, dictionary, *, outlier_factor=3.0, swap_ratio=0.5):
    """Drop implausible poses before adapting (see the module docstring).

    Parameters
    ----------
    poses : array_like (n, N, 2)
        Poses in pixels; rows that are not complete and usable are dropped
        as ``incomplete``.
    dictionary : Dictionary
        Codes the poses (with its ``alpha_train``) for the outlier and
        swapped-label tests.
    outlier_factor : float, default 3.0
        Tukey factor of :func:`outlier_rows` on the reconstruction errors.
    swap_ratio : float, default 0.5
        The `ratio` of :func:`swapped_rows` (checked on the worst quarter of
        the errors only).

    Returns
    -------
    FilterReport
        ``keep`` (n,) bool and ``counts`` of dropped poses per reason
        (``incomplete``, ``duplicate``, ``outlier``, ``swapped``).
    """
    poses = np.asarray(poses, dtype=float)
    keep = usable_rows(poses)
    counts = {"incomplete": int((~keep).sum())}
    idx = np.flatnonzero(keep)
    X = pose_vectors(poses[idx])
    dup = repeat_rows(X)
    counts["duplicate"] = int(dup.sum())
    idx, X = idx[~dup], X[~dup]
    alpha = dictionary.alpha_train
    err = reconstruction_error(X, dictionary.components, alpha)
    out = outlier_rows(err, outlier_factor)
    counts["outlier"] = int(out.sum())
    idx = idx[~out]
    # a pose with exchanged labels is explained badly: only the worst quarter is
    # checked, in the 14-joint layout (whose left and right joints are known)
    err = err[~out]
    check = (err > np.percentile(err, 75)
             if len(err) and dictionary.n_joints == SKELETON_14.num_joints
             else np.zeros(len(err), dtype=bool))
    sw = np.zeros(len(idx), dtype=bool)
    sw[check] = swapped_rows(poses[idx[check]], dictionary.components, alpha, ratio=swap_ratio,
                             errors=err[check])
    counts["swapped"] = int(sw.sum())
    idx = idx[~sw]
    keep = np.zeros(len(poses), dtype=bool)
    keep[idx] = True
    return FilterReport(keep=keep, counts=counts)


def holdout_blocks(n, fraction, random_state=0, n_blocks=20, max_rows=MAX_VALIDATION):
    """Seeded held-back rows made of whole contiguous blocks (rows in file order).

    Neighbouring frames of a video are near-copies: a random row split would
    leak them across. The rows are cut into `n_blocks` contiguous blocks and
    whole blocks are held back until `fraction` of the rows (at most
    `max_rows`) are.

    Parameters
    ----------
    n : int
        Rows in all.
    fraction : float
        Share of the rows to hold back.
    random_state : int, default 0
        Seed of the blocks' order.
    n_blocks : int, default 20
        Contiguous blocks the rows are cut into (at most `n`).
    max_rows : int, default MAX_VALIDATION
        Held-back rows at most (the last block taken is cut short to fit).

    Returns
    -------
    ndarray of bool (n,)
        True for the held-back rows; none when ``n < 2`` or the share rounds
        to 0.

    Examples
    --------
    >>> v = holdout_blocks(100, 0.2, random_state=0)
    >>> int(v.sum())
    20
    """
    out = np.zeros(n, dtype=bool)
    want = min(int(round(fraction * n)), max_rows)
    if want <= 0 or n < 2:
        return out
    edges = np.linspace(0, n, min(n_blocks, n) + 1).astype(int)
    order = np.random.default_rng([int(random_state or 0), 11]).permutation(len(edges) - 1)
    for b in order:
        if out.sum() >= want:
            break
        lo, hi = edges[b], edges[b + 1]
        out[lo:min(hi, lo + want - int(out.sum()))] = True
    return out


# --------------------------------------------------------------------------
# the learning

def adapt_vectors(components, X, alpha, *, passes=DEFAULT_PASSES, stats=DEFAULT_STATS,
                  memory=DEFAULT_MEMORY, replay=DEFAULT_REPLAY, replay_vectors=None,
                  batch_size=DEFAULT_BATCH_SIZE, reinit=DEFAULT_REINIT, forget=None,
                  random_state=0, n_jobs=1):
    """Continue online dictionary learning from `components` on the vectors X.

    Parameters
    ----------
    components : ndarray (k, m)
        Base atoms (rows, unit norm); not modified.
    X : ndarray (n, m)
        Normalised EDM vectors of complete poses.
    alpha : float
        Lasso penalty of the coding step.
    passes : float, default 2
        Passes over X (a fraction: part of a pass).
    stats : {"fresh", "carried"}
        Inner statistics A, B start at zero ("fresh") or as ``memory``
        pseudo-observations of each base atom ("carried").
    memory : float
        Weight of the carried statistics.
    replay : float in [0, 1)
        Fraction of each mini-batch made of replayed vectors.
    replay_vectors : ndarray (r, m), optional
        What is replayed; default the base atoms scaled to X's median norm.
    reinit : bool
        Start with one step over all of X (every vector coded once): the
        atoms no adaptation vector uses are re-drawn from the rows of all of
        X, and the inner statistics start from the whole set, instead of from
        the first mini-batch alone (whose few rows would otherwise re-seed
        every atom it does not use). Only with ``stats="fresh"``.
    forget : float in (0, 1], optional
        A constant forgetting factor of the inner statistics per mini-batch
        (new poses dominate); default Mairal's schedule.
    batch_size, random_state, n_jobs
        As :class:`sparseedm.learning.OnlineDictionaryLearning`.

    Returns
    -------
    components : ndarray (k, m)
        The adapted atoms, rows scaled to unit norm.

    Raises
    ------
    SparseEDMError
        `stats`, `replay` or `forget` is out of its range.
    """
    if stats not in STATS:
        raise SparseEDMError(f"stats must be one of {STATS}, got {stats!r}")
    if not 0 <= replay < 1:
        raise SparseEDMError(f"replay must be in [0, 1), got {replay!r}")
    components = np.array(components, dtype=float)
    X = np.asarray(X, dtype=float)
    k, m = components.shape
    est = OnlineDictionaryLearning(k, alpha=alpha, batch_size=batch_size, n_passes=passes,
                                   random_state=random_state, n_jobs=n_jobs)
    est._init_state(components=components)
    if stats == "carried":
        est.inner_stats_ = (memory * np.eye(k), memory * components.T.copy())
        # a continued learner: no early-batch forgetting of the carried statistics
        est.n_steps_ = batch_size
    if forget is not None:
        if not 0 < forget <= 1:
            raise SparseEDMError(f"forget must be in (0, 1], got {forget!r}")
        est._beta = lambda: float(forget)
    # the first step codes on the base atoms: their Gram is the process's
    # (the filter, the guard and earlier learnings from this base formed it)
    gram = gram_matrix(est.components_.T)
    if reinit and stats == "fresh":
        # every atom's statistics from all of X; unused atoms re-drawn from X
        est._step(X, gram=gram)
        gram = None
    n_replay = int(round(replay * batch_size))
    if n_replay:
        if replay_vectors is None:
            replay_vectors = components * np.median(np.linalg.norm(X, axis=1))
        replay_vectors = np.asarray(replay_vectors, dtype=float)
        rng = np.random.default_rng([int(random_state or 0), 13])
    for batch in iter_batches(len(X), batch_size, passes, random_state):
        Xb = X[np.sort(batch)]
        if n_replay:
            Xb = np.vstack([Xb, replay_vectors[rng.integers(0, len(replay_vectors), n_replay)]])
        est._step(Xb, gram=gram)
        gram = None  # the atoms have moved
    out = est.components_
    return out / np.linalg.norm(out, axis=1, keepdims=True)


# --------------------------------------------------------------------------
# the guard

def guard_masks(n_poses, n_joints, n_patterns=None, random_state=0):
    """Seeded Mix masks (1-3 joints) for `n_poses` poses, from at most `n_patterns` patterns.

    ``n_patterns=None``: the evaluation protocol's masks
    (:func:`sparseedm.evaluation.occlusion_masks`), nearly one pattern per
    pose. With ``n_patterns`` the protocol's masks of the first
    ``n_patterns`` poses are dealt round the poses in a seeded order: every
    pattern is then shared by ``n_poses / n_patterns`` poses, which the fast
    solver recovers together through one Gram matrix (the guard's speed;
    both dictionaries it compares see the same masks).

    Parameters
    ----------
    n_poses : int
        Poses to mask.
    n_joints : int
        Joints per pose.
    n_patterns : int, optional
        Distinct patterns at most; None (or at least `n_poses`): one drawn
        per pose.
    random_state : int, default 0
        Seed of the masks and of their order.

    Returns
    -------
    ndarray of bool (n_poses, n_joints)
        True for the joints to hide, 1 to 3 per pose.

    Examples
    --------
    >>> m = guard_masks(100, 14, n_patterns=10)
    >>> len(np.unique(m, axis=0)) <= 10, sorted(set(m.sum(axis=1).tolist())) <= [1, 2, 3]
    (True, True)
    """
    if n_patterns is None or n_patterns >= n_poses:
        return occlusion_masks(n_poses, n_joints, ("mix",), random_state)["mix"]
    patterns = occlusion_masks(n_patterns, n_joints, ("mix",), random_state)["mix"]
    order = np.random.default_rng([int(random_state or 0), 23]).permutation(n_poses)
    return patterns[order % n_patterns]


def masked_error(dictionary, poses, *, random_state=0, alpha=None, n_jobs=1, n_patterns=None,
                 solver="fast", backend=None, scheduler=None, check_input=True):
    """Mean Mix Err_ave (%) of recovering `poses` with seeded masks.

    The masks are :func:`guard_masks`: by default the evaluation protocol's
    (:func:`sparseedm.evaluation.occlusion_masks`, the Mix of 1-3 joints);
    with `n_patterns`, that many patterns shared round the poses (faster).
    Every dictionary compared on the same poses sees the same occlusions.
    `solver` as :func:`sparseedm.recover`'s (the guard passes the fast one on
    its compiled kernel at any size, :func:`~sparseedm._recovery_kernel.compiled_solver`).

    Parameters
    ----------
    dictionary : Dictionary
        The dictionary to score (recovered with as given: no adaptation).
    poses : array_like (n, N, 2)
        Complete poses in pixels, the truth of the hidden joints.
    random_state : int, default 0
        Seed of the masks.
    alpha : float, optional
        Recovery alpha; default the dictionary's ``alpha_recover``.
    n_jobs : int, default 1
        joblib workers of the recovery.
    n_patterns : int, optional
        Distinct occlusion patterns (:func:`guard_masks`); None: one per pose.
    solver : str or BaseSolver, default "fast"
        The recovery's solver.
    backend, scheduler : optional
        As :func:`sparseedm.recover`'s: ``backend="dask"`` recovers the
        poses' chunks on the cluster (the same numbers).
    check_input : bool, default True
        Validate `poses`; False: the caller did (the guard's held-back poses,
        a float array (n, N, 2)).

    Returns
    -------
    float
        The mean Err_ave (%) over the poses recovered usably; NaN when none was.

    Raises
    ------
    ParameterError
        `dictionary`, `alpha` or `n_jobs` is not one :func:`sparseedm.recover`
        accepts.
    """
    validate_params("recover", dict(dictionary=dictionary, alpha=alpha, n_jobs=n_jobs,
                                    backend=backend, scheduler=scheduler), RECOVER_PARAMS)
    poses = np.asarray(poses, dtype=float)
    mask = guard_masks(len(poses), poses.shape[1], n_patterns, random_state)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = recover_members(np.where(mask[..., None], np.nan, poses), mask, [dictionary], [],
                              alpha=alpha, n_jobs=n_jobs, solver=solver, backend=backend,
                              scheduler=scheduler, check_input=check_input)
    e = err_ave(res.vectors * res.scale[:, None], pose_to_vector(poses))
    e = e[res.ok & np.isfinite(e)]
    return float(e.mean()) if len(e) else float("nan")


# --------------------------------------------------------------------------
# the whole: filter, bound, hold back, adapt, guard

@dataclass
class AdaptationResult:
    """What :func:`run_adaptation` did.

    Parameters
    ----------
    dictionary : Dictionary
        The dictionary to recover with: the adapted one if it was used, else
        the base.
    adapted : bool
        True when the adapted dictionary passed the guard and is used.
    reason : str
        Why not, or what was done, in words.
    n_given, n_complete, n_used, n_validation : int
        Poses given; complete and plausible after filtering (complete poses
        beyond the ``max_poses`` sample are not checked and are counted in);
        adapted on; held back for the guard.
    dropped : dict
        Poses dropped per filter reason.
    err_base, err_adapted : float
        Mean Mix Err_ave (%) on the held-back poses (NaN when not measured).
    seconds : float
        Wall time of the whole adaptation (self-training rounds included).
    step_seconds : dict
        Seconds of each step: ``filter``, ``learning``, ``guard``; after
        self-training, the first adaptation's as ``first filter``, ... and each
        round's as ``round r recovery``, ``round r learning``, ``round r
        guard``, with the totals ``first_adaptation`` and ``self_training``.
    candidate : Dictionary or None
        The adapted dictionary even when the guard rejected it.
    settings : dict
        The learning and guard settings used (:func:`run_adaptation`'s
        arguments by name).
    n_extra : int
        Filled (recovered) poses learned from besides the complete ones
        (self-training; 0 otherwise).
    self_training : list of dict
        One entry per self-training round: ``poses`` learned from, whether
        the guard ``checked`` it (the last round only), its ``validation_err``
        (NaN unchecked) and whether the round is ``adopted`` (used).
    pool : ndarray or None
        The complete poses after filtering and bounding (learning and
        held-back slice come from them); reused by self-training rounds.
    file_atoms : int
        When not adapted: the complete poses appended to the base dictionary
        as atoms instead (:mod:`sparseedm.file_atoms`; 0: none).
    """

    dictionary: Dictionary
    adapted: bool
    reason: str
    n_given: int = 0
    n_complete: int = 0
    n_used: int = 0
    n_validation: int = 0
    dropped: dict = field(default_factory=dict)
    err_base: float = float("nan")
    err_adapted: float = float("nan")
    seconds: float = 0.0
    step_seconds: dict = field(default_factory=dict)
    candidate: Dictionary | None = None
    settings: dict = field(default_factory=dict)
    n_extra: int = 0
    self_training: list = field(default_factory=list)
    pool: np.ndarray | None = field(default=None, repr=False)
    file_atoms: int = 0

    def summary(self) -> dict:
        """JSON-able summary (what ``RecoveryResult.summary()`` reports).

        Returns
        -------
        dict
            ``path`` (:attr:`path`), ``adapted``, ``reason``, the pose counts (``poses_given``,
            ``complete_poses``, ``poses_used``, ``validation_poses``),
            ``dropped``, the guard's ``validation_err_base`` and
            ``validation_err_adapted`` (None when not measured),
            ``file_atoms``, ``seconds``, ``step_seconds`` and the
            ``self_training`` rounds; when an ensemble was asked for
            (``recover(ensemble=K)``, K > 1), ``ensemble``: the members
            ``asked`` and the dictionaries whose answers were averaged
            (``members``; fewer when the path fits one, or its own:
            :mod:`sparseedm.ensemble`); when the donor step chose
            (:mod:`sparseedm.donors`), ``donors``: its weight, gate (None: no
            gate), probes and their errors; when the bank step ran
            (:func:`sparseedm.cold_bank.bank_step`), ``bank``: its weight,
            probes and their errors, or why it was skipped.
        """
        def num(v):
            return None if not np.isfinite(v) else round(float(v), 4)
        out = {
            "path": self.path, "adapted": bool(self.adapted), "reason": self.reason,
            "poses_given": self.n_given, "complete_poses": self.n_complete,
            "poses_used": self.n_used, "validation_poses": self.n_validation,
            "dropped": dict(self.dropped),
            "validation_err_base": num(self.err_base),
            "validation_err_adapted": num(self.err_adapted),
            "file_atoms": int(self.file_atoms),
            "seconds": round(self.seconds, 3),
            "step_seconds": {k: round(v, 3) for k, v in self.step_seconds.items()},
            "self_training": [{k: (num(v) if isinstance(v, float) else v)
                               for k, v in r.items()} for r in self.self_training],
        }
        if "ensemble" in self.settings:
            out["ensemble"] = dict(self.settings["ensemble"])
        for step in ("bank", "donors"):  # cold_bank.bank_step's and sparseedm.donors' choices
            if step in self.settings:
                out[step] = dict(self.settings[step])
        return out

    @property
    def path(self) -> str:
        """Which dictionary recovered: ``"file atoms"`` (the poses' own complete
        poses as the only atoms: :mod:`sparseedm.exemplars`, ``preset="fast"``),
        ``"adapted"``, ``"base + file atoms"``, ``"base"``, :data:`AVERAGED_PATH`
        (the mean of the answers of the file atoms, with and without their mirror
        images, and of the base with file atoms) or :data:`MIRRORED_ATOMS_PATH`."""
        if self.settings.get("path") in (AVERAGED_PATH, MIRRORED_ATOMS_PATH):
            return self.settings["path"]  # sparseedm.exemplars averages
        if "file_dictionary" in (self.dictionary.provenance or {}):
            return "file atoms"
        if self.adapted:
            return "adapted"
        return "base + file atoms" if self.file_atoms else "base"

    @property
    def averaged_answers(self) -> tuple:
        """The codes whose answers the path averages for every occluded pose
        (:data:`AVERAGED_PATH`, :data:`MIRRORED_ATOMS_PATH`: nothing learned, no
        ensemble asked for); empty: one answer per dictionary recovered with."""
        return _AVERAGED_ANSWERS.get(self.settings.get("path"), ())

    @property
    def over_file_atoms(self) -> bool:
        """Whether the file's own complete poses were the only atoms (:attr:`path`
        in :data:`FILE_ATOMS_PATHS`)."""
        return self.path in FILE_ATOMS_PATHS

    def line(self) -> str:
        """One line a person reads (what ``sparseedm recover`` prints).

        Returns
        -------
        str
            ``"adaptation: "`` then what was done and why, the poses used, the
            guard's errors, the self-training rounds and the time.
        """
        if self.settings.get("preset") == "fast":  # nothing adapted, nothing to compare
            return f"adaptation: none ({self.reason}); {self.seconds:.1f} s"
        if self.over_file_atoms:  # sparseedm.exemplars
            return (f"adaptation: none, the file's own poses are the atoms ({self.reason}); "
                    f"{self.seconds:.1f} s")
        if np.isfinite(self.err_base) and np.isfinite(self.err_adapted):
            errs = (f"validation Mix Err_ave {self.err_base:.2f}% -> {self.err_adapted:.2f}% "
                    f"on {self.n_validation} held-back poses")
        else:
            errs = ""
        head = ("adapted the dictionary" if self.adapted else "kept the base dictionary")
        parts = [f"{head} ({self.reason})"]
        if self.n_used:
            parts.append(f"{self.n_used} poses used")
        if self.file_atoms:
            parts.append(f"{self.file_atoms} complete poses added as atoms")
        if errs:
            parts.append(errs)
        if self.self_training:
            used = [r for r in self.self_training if r["adopted"]]
            txt = (f"self-training: {len(used)} of {len(self.self_training)} rounds adopted, "
                   f"{self.self_training[0]['poses']} recovered poses")
            if used:
                txt += f", held-back Mix Err_ave {used[-1]['validation_err']:.2f}%"
            parts.append(txt)
        parts.append(f"{self.seconds:.1f} s")
        return "adaptation: " + "; ".join(parts)


def _complete_input(poses, missing, check_input=True):
    """The complete rows of user poses (NaN, `missing` or a masked array's mask mark
    occlusions); refused as recover() refuses them (strings, complex, objects...);
    `check_input` False: validated by the caller (recover()'s poses and mask)."""
    if not check_input:
        ok = np.isfinite(poses).all(axis=(-1, -2))
        return poses[ok if missing is None else ok & ~missing.any(axis=1)], len(poses)
    poses, missing = unmask(poses, missing, "adapt")
    poses = check_poses(poses, "adapt")
    if poses.ndim == 2:
        poses = poses[None]
    check_pose_shape(poses, "adaptation poses")
    ok = np.isfinite(poses).all(axis=(-1, -2))
    if missing is not None:
        mask = check_mask(missing, "adapt")
        if mask.ndim == 1:
            mask = mask[None]
        if mask.shape != poses.shape[:2]:
            raise PoseError(f"missing must have shape {poses.shape[:2]}, got {mask.shape}")
        ok &= ~mask.any(axis=1)
    return poses[ok], len(poses)


def run_adaptation(dictionary, poses, missing=None, *, passes=DEFAULT_PASSES, alpha=None,
                   stats=DEFAULT_STATS, memory=DEFAULT_MEMORY, replay=DEFAULT_REPLAY,
                   batch_size=DEFAULT_BATCH_SIZE, min_poses=MIN_COMPLETE_POSES,
                   max_poses=DEFAULT_MAX_POSES,
                   validation_fraction=DEFAULT_VALIDATION_FRACTION, guard=True,
                   filter=True, random_state=0, n_jobs=1, extra=None, reuse=None,
                   max_train=None, backend=None, scheduler=None, check_input=True):
    """Adapt `dictionary` on the complete rows of `poses`, guarded; see the module docstring.

    Parameters
    ----------
    dictionary : Dictionary, str or path
        The base dictionary (a name or path is loaded).
    poses : array_like (n, N, 2)
        Poses in pixels; rows with a missing joint (NaN or `missing`) are
        not used.
    missing : array_like of bool (n, N), optional
        True where a joint is missing; by default NaN coordinates mark them.
    passes, alpha, stats, memory, replay, batch_size
        The learning (:func:`adapt_vectors`); ``alpha`` defaults to the
        :func:`adaptation_alpha` (3.2 for the default). The adapted dictionary recommends
        ``ADAPTED_ALPHA_RECOVER_FACTOR`` times the base's recovery alpha.
    min_poses : int
        Fewer complete plausible poses than this: no adaptation.
    max_poses : int
        At most this many poses (a seeded sample) are used, bounding the time.
    validation_fraction : float
        Share of the poses held back for the guard (at most ``MAX_VALIDATION``).
    guard : bool
        Compare base and adapted on the held-back poses and keep the better.
        ``False`` uses the adapted dictionary unchecked (and holds nothing back).
    filter : bool
        Drop duplicates, outliers and left/right swaps first.
    random_state : int
        Seed of the sample, the held-back blocks, the guard's masks and the
        learning's mini-batches.
    n_jobs : int or None
        Threads for the coding step and the guard's recovery; None: numba's
        (every core unless ``NUMBA_NUM_THREADS`` says otherwise), which is what
        ``recover(n_jobs=1)`` passes, as its own compiled recovery uses them.
    extra : array_like (m, N, 2), optional
        Filled poses (e.g. recovered ones, :func:`self_train`) learned from
        besides the complete ones: never held back for the guard, not
        counted towards `min_poses`, at most `max_poses` of them (seeded).
    reuse : AdaptationResult, optional
        An earlier result on the same poses and settings (what
        :func:`self_train` passes): its filtered, bounded poses and the base
        dictionary's guard error are taken from it instead of recomputed.
    max_train : int, optional
        At most this many of the complete poses not held back are learned
        from (a seeded sample, order kept); None: all of them.
    backend, scheduler : optional
        As :func:`sparseedm.recover`'s: ``backend="dask"`` runs the guard's
        recoveries on the cluster; the learning stays in this process.
    check_input : bool, default True
        Validate `poses` and `missing`; False: the caller did (a float array
        (n, N, 2) and a bool array (n, N) or None).

    Returns
    -------
    AdaptationResult
        The dictionary to recover with (adapted or the base), the guard's
        errors, the pose counts and the reason in words.
    """
    t0 = time.perf_counter()
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    settings = dict(passes=passes, alpha=alpha, stats=stats, memory=memory, replay=replay,
                    batch_size=batch_size, min_poses=min_poses, max_poses=max_poses,
                    validation_fraction=validation_fraction, guard=guard, filter=filter,
                    random_state=random_state)
    steps = {}
    pool = (_Pool(reuse.pool, reuse.n_complete, dict(reuse.dropped), reuse.n_given)
            if reuse is not None  # the same poses, filtered and bounded once
            else _filtered_pool(dictionary, poses, missing, filter=filter,
                                min_poses=min_poses, max_poses=max_poses,
                                random_state=random_state, steps=steps,
                                check_input=check_input))

    def done(reason, **kw):
        return AdaptationResult(dictionary=kw.pop("use", dictionary), reason=reason,
                                n_given=pool.n_given, seconds=time.perf_counter() - t0,
                                settings=settings, step_seconds=steps, **kw)

    if pool.poses is None:
        return done(f"{pool.n_complete} complete plausible poses, fewer than the {min_poses} "
                    "needed", adapted=False, n_complete=pool.n_complete, dropped=pool.dropped)
    val = holdout_blocks(len(pool.poses), validation_fraction if guard else 0.0, random_state)
    held = pool.poses[val]
    train = pool.poses[~val]
    train, n_extra = _with_extra(train[_sample_rows(len(train), max_train, random_state, 37)],
                                 extra, max_poses, random_state)
    alpha_train = adaptation_alpha(dictionary) if alpha is None else alpha
    if reuse is None:  # self_train's rounds say their own line
        _progress.say(f"adapting the dictionary on {len(train):,} complete poses, "
                      f"{len(held):,} held back to check it (seed {random_state})")
    t_step = time.perf_counter()
    dist = dict(backend=backend, scheduler=scheduler)
    with _BaseGuard(dictionary, held if guard else held[:0], reuse, random_state,
                    dist) as base:
        comps = adapt_vectors(dictionary.components, pose_vectors(train), alpha_train,
                              passes=passes, stats=stats, memory=memory, replay=replay,
                              batch_size=batch_size, random_state=random_state,
                              n_jobs=n_jobs)
        steps["learning"] = time.perf_counter() - t_step
        e0 = base.error()
    candidate = _adapted_dictionary(dictionary, comps, alpha_train, dict(
        poses=int(len(train)), filled_poses=int(n_extra), passes=passes, stats=stats,
        replay=replay, alpha=alpha_train, seed=random_state))
    kw = dict(n_complete=pool.n_complete, n_used=len(train) - n_extra,
              n_validation=len(held), dropped=pool.dropped, candidate=candidate,
              n_extra=n_extra, pool=pool.poses)
    if not guard or len(held) == 0:
        return done("unchecked: no held-back poses", adapted=True, use=candidate, **kw)
    t_step = time.perf_counter()
    e1 = _guard_error(candidate, held, random_state, n_jobs, dist)
    steps["guard"] = time.perf_counter() - t_step + base.seconds_waited
    candidate.provenance["adaptation"].update(validation_err_base=e0, validation_err_adapted=e1)
    if e1 < e0:
        return done("better on the held-back poses", adapted=True, use=candidate,
                    err_base=e0, err_adapted=e1, **kw)
    return done("the adapted dictionary was not better on the held-back poses",
                adapted=False, err_base=e0, err_adapted=e1, **kw)


@dataclass
class _Pool:
    """The complete poses an adaptation draws from: filtered and bounded (``poses``,
    None when fewer than needed), how many were complete and plausible, dropped
    per reason, and how many were given."""

    poses: np.ndarray | None
    n_complete: int
    dropped: dict
    n_given: int


def _filtered_pool(dictionary, poses, missing, *, filter, min_poses, max_poses, random_state,
                   steps, check_input=True):
    """Step 1-2 of :func:`run_adaptation`: the complete rows bounded to a seeded
    sample of `max_poses` and filtered (its time recorded in ``steps["filter"]``;
    no poses when fewer than `min_poses` are left). The bound comes first: the
    filters code every pose they check with the lasso, and a sample's outliers
    are as far out as the file's (15,000 complete poses: 4.9 s -> 1.6 s)."""
    complete, n_given = _complete_input(poses, missing, check_input)
    if complete.shape[1] != dictionary.n_joints:
        raise PoseError(f"adaptation poses have {complete.shape[1]} joints but the "
                        f"dictionary is for {dictionary.n_joints}")
    n_unchecked = max(len(complete) - max_poses, 0)
    complete = complete[_sample_rows(len(complete), max_poses, random_state, 17)]
    t_step = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        if filter:
            rep = filter_poses(complete, dictionary)
            keep, dropped = rep.keep, rep.counts
        else:
            keep = usable_rows(complete)
            dropped = {"incomplete": int((~keep).sum())}
    dropped["incomplete"] += n_given - len(complete) - n_unchecked
    steps["filter"] = time.perf_counter() - t_step
    good = complete[keep]
    if len(good) < min_poses:
        return _Pool(None, len(good), dropped, n_given)
    return _Pool(good, len(good) + n_unchecked, dropped, n_given)


def _sample_rows(n, max_rows, random_state, stream):
    """Row indices of a seeded sample of at most `max_rows` of n rows, in their
    order (all of them when they fit or `max_rows` is None); `stream` keeps
    each caller's draw its own."""
    if max_rows is None or n <= max_rows:
        return np.arange(n)
    rng = np.random.default_rng([int(random_state or 0), stream])
    return np.sort(rng.choice(n, int(max_rows), replace=False))


def _with_extra(train, extra, max_poses, random_state):
    """`train` with the usable rows of `extra` (filled poses; a seeded sample of
    at most `max_poses`) appended, and how many were."""
    if extra is None or not len(extra):
        return train, 0
    extra = np.asarray(extra, dtype=float)
    extra = extra[usable_rows(extra)]
    extra = extra[_sample_rows(len(extra), max_poses, random_state, 23)]
    return np.concatenate([train, extra]), len(extra)


def _adapted_dictionary(dictionary, components, alpha_train, record):
    """The candidate: `dictionary`'s settings with the adapted atoms, the
    adapted recovery alpha, and `record` under ``provenance["adaptation"]``."""
    prov = dict(dictionary.provenance or {})
    prov["adaptation"] = dict(record, base_sha256=prov.get("sha256", ""))
    return Dictionary(
        components=components, joint_names=dictionary.joint_names,
        alpha_recover=dictionary.alpha_recover * ADAPTED_ALPHA_RECOVER_FACTOR,
        alpha_train=alpha_train,
        alpha_scaling=dictionary.alpha_scaling, positive_code=dictionary.positive_code,
        representation=dictionary.representation, normalization=dictionary.normalization,
        recovery_scale=dictionary.recovery_scale, provenance=prov,
    )


def _guard_kw(held, random_state, n_jobs, dist=None):
    """:func:`masked_error`'s settings in the guard: a pattern per 12 poses, the
    compiled kernel at any size (the learning has compiled numba already);
    `dist` the recovery's ``backend`` and ``scheduler``, if any."""
    return dict(random_state=random_state, n_jobs=n_jobs, solver=compiled_solver(),
                n_patterns=max(1, len(held) // GUARD_POSES_PER_PATTERN), check_input=False,
                **(dist or {}))


def _guard_error(dictionary, held, random_state, n_jobs, dist=None):
    """Mix Err_ave of `dictionary` on the held-back poses (the guard's masks)."""
    with numba_threads(n_jobs):
        return masked_error(dictionary, held, **_guard_kw(held, random_state, n_jobs, dist))


class _BaseGuard:
    """The base dictionary's guard error, worked out in a side thread while the
    candidate is learned (taken from `reuse` when it has it; NaN without
    held-back poses).

    The learning keeps one core busy most of the time (the Gram matrix, the
    atoms' block-coordinate pass and the inner statistics are serial; only
    the batch's coding is parallel), so the base's recovery runs on one numba
    thread beside it. Every row is solved alone, so the error is the same
    number as in the main thread. Held in a ``with`` block: BLAS is held to
    one thread and the warning filters restored around both threads (the
    recovery sets and restores both, which would otherwise interleave with the
    main thread's).
    """

    def __init__(self, dictionary, held, reuse, random_state, dist=None):
        self.args = (dictionary, held, random_state, 1, dist)
        self.known = reuse.err_base if reuse is not None else float("nan")
        self.seconds_waited = 0.0

    def __enter__(self):
        self.stack, self.future = [], None
        if len(self.args[1]) and not np.isfinite(self.known):
            self.stack = [threadpool_limits(1, user_api="blas"), warnings.catch_warnings()]
            for ctx in self.stack:
                ctx.__enter__()
            self.pool = ThreadPoolExecutor(1, thread_name_prefix="sparseedm-guard")
            self.future = self.pool.submit(_guard_error, *self.args)
        return self

    def error(self):
        """The base's error (waits for the side thread; its wait is timed)."""
        if self.future is None:
            return self.known
        t0 = time.perf_counter()
        self.known = self.future.result()
        self.seconds_waited = time.perf_counter() - t0
        self.future = None
        self.pool.shutdown()
        return self.known

    def __exit__(self, *exc):
        if self.future is not None:  # an error in the learning: let the thread end first
            self.future.cancel()
            self.pool.shutdown(wait=True)
        for ctx in reversed(self.stack):
            ctx.__exit__(None, None, None)


def adapt(dictionary, complete_poses, *, passes=DEFAULT_PASSES, alpha=None, **kwargs):
    """A new Dictionary warm-started from `dictionary` and adapted on `complete_poses`.

    :func:`run_adaptation` with its guard and filters; returns the dictionary
    it decided on (the base one when adaptation was refused or not better),
    whose ``provenance["adaptation"]`` records what was done. Use
    :func:`run_adaptation` to see why.

    Parameters
    ----------
    dictionary : Dictionary, str or path
        The base dictionary (a name or path is loaded).
    complete_poses : array_like (n, N, 2)
        Poses in pixels; rows with NaN are ignored.
    passes : float, default 2
        Passes of the online learning over the poses.
    alpha : float, optional
        Lasso penalty of the learning's coding step; default
        :func:`adaptation_alpha` of `dictionary`.
    **kwargs
        Any other argument of :func:`run_adaptation`.

    Returns
    -------
    Dictionary
        The adapted dictionary, or `dictionary` itself when the adaptation was
        refused or not better on the held-back poses.

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> d = sparseedm.load_dictionary()
    >>> few = np.random.default_rng(0).uniform(0, 100, (3, 14, 2))
    >>> sparseedm.adapt(d, few) is d        # 3 poses are too few: the base comes back
    True
    """
    return run_adaptation(dictionary, complete_poses, passes=passes, alpha=alpha,
                          **kwargs).dictionary


def _occluded(poses, missing):
    """Joints missing by `missing` or by a non-finite coordinate, and which rows
    are incomplete (some joints missing, not all)."""
    mask = ~np.isfinite(poses).all(axis=-1)
    if missing is not None:
        mask |= np.asarray(missing, dtype=bool)
    return mask, mask.any(axis=1) & ~mask.all(axis=1)


def _incomplete_rows(poses, missing, max_poses, random_state):
    """A seeded sample (file order kept) of the rows of `poses` with a missing joint."""
    poses = np.asarray(poses, dtype=float)
    mask, incomplete = _occluded(poses, missing)
    rows = np.flatnonzero(incomplete)
    rows = rows[_sample_rows(len(rows), max_poses, random_state, 29)]
    return poses[rows], mask[rows]


def self_train(dictionary, result, adapt_poses, adapt_missing, poses, missing, *,
               rounds=SELF_TRAINING_ROUNDS, max_poses=None, max_complete=None,
               alpha_factor=SELF_TRAINING_ALPHA_FACTOR, random_state=0, n_jobs=1,
               backend=None, scheduler=None):
    """Transductive self-training after :func:`run_adaptation` (module docstring).

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary (every round adapts it afresh).
    result : AdaptationResult
        The first adaptation (on `adapt_poses`); nothing is done unless it
        was adopted.
    adapt_poses, adapt_missing
        What `result` was adapted on (as given to :func:`run_adaptation`).
    poses, missing
        The poses to be recovered: their incomplete rows (a seeded sample of
        at most `max_poses`) are recovered, and the filled poses learned from.
    rounds : int, default SELF_TRAINING_ROUNDS
        Rounds to run; 0 or fewer: none (`result` comes back).
    max_poses : int, optional
        Default :data:`SELF_TRAINING_MAX_POSES`.
    max_complete : int, optional
        Default :data:`SELF_TRAINING_MAX_COMPLETE`: the complete poses a
        round learns from (``max_train`` of :func:`run_adaptation`).
    alpha_factor : float
        The sample is recovered at this times the current dictionary's
        ``alpha_recover`` (:data:`SELF_TRAINING_ALPHA_FACTOR`).
    random_state : int, default 0
        Seed of the sample and of every round's adaptation.
    n_jobs : int or None, default 1
        Threads of the rounds' recoveries and adaptations (as
        :func:`run_adaptation`'s).
    backend, scheduler : optional
        As :func:`sparseedm.recover`'s: ``backend="dask"`` runs the rounds'
        recoveries and guard on the cluster; the learning stays here.

    Returns
    -------
    AdaptationResult
        The last round's when the guard adopted it, else `result` itself
        (``self_training`` lists every round: ``poses`` learned from, whether
        it was ``checked`` by the guard, only the last is, its
        ``validation_err`` and whether it is ``adopted``, i.e. used).

    Examples
    --------
    >>> import numpy as np, sparseedm
    >>> from sparseedm.adaptation import run_adaptation, self_train
    >>> d = sparseedm.load_dictionary()
    >>> res = run_adaptation(d, np.zeros((3, 14, 2)))      # too few poses: not adopted
    >>> self_train(d, res, None, None, np.zeros((3, 14, 2)), None) is res
    True
    """
    if rounds <= 0 or not result.adapted or poses is None:
        return result
    t0 = time.perf_counter()
    max_poses = SELF_TRAINING_MAX_POSES if max_poses is None else max_poses
    max_complete = SELF_TRAINING_MAX_COMPLETE if max_complete is None else max_complete
    inc, mask = _incomplete_rows(poses, missing, max_poses, random_state)
    if len(inc) < MIN_SELF_TRAINING_POSES:
        return result
    current, history, spent, rounds = result, [], {}, int(rounds)
    for r in _progress.steps(range(rounds), f"self-training on {len(inc):,} incomplete "
                             f"poses, {rounds} rounds (seed {random_state})",
                             total=rounds, unit="round"):
        t_rec = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rec = recover_sparse(inc, mask, dictionary=current.dictionary, n_jobs=n_jobs,
                                 solver=compiled_solver(), backend=backend,
                                 scheduler=scheduler,
                                 alpha=current.dictionary.alpha_recover * alpha_factor)
        spent[f"round {r + 1} recovery"] = time.perf_counter() - t_rec
        filled = rec.poses[rec.status == "recovered"]
        last = r == rounds - 1  # only the last round is judged (module docstring)
        current = run_adaptation(dictionary, adapt_poses, adapt_missing, extra=filled,
                                 random_state=random_state, n_jobs=n_jobs, reuse=result,
                                 guard=last, max_train=max_complete, backend=backend,
                                 scheduler=scheduler)
        for step, secs in current.step_seconds.items():
            spent[f"round {r + 1} {step}"] = secs
        history.append({"round": r + 1, "poses": int(len(filled)), "checked": last,
                        "validation_err": float(current.err_adapted),
                        "adopted": bool(current.adapted)})
    if not current.adapted:  # the guard rejected the last round: none of them is used
        current = result
        for entry in history:
            entry["adopted"] = False
    current.self_training = history
    first = {f"first {k}": v for k, v in result.step_seconds.items()}
    current.step_seconds = dict(first, **spent, first_adaptation=result.seconds,
                                self_training=time.perf_counter() - t0)
    current.seconds = result.seconds + time.perf_counter() - t0
    return current


def resolve_adaptation(dictionary, poses, missing, adapt, *, n_jobs=1, random_state=0,
                       warn=True, self_training=None, min_poses=MIN_COMPLETE_POSES,
                       backend=None, scheduler=None, check_input=True):
    """The dictionary :func:`sparseedm.recover` should use, and what was done.

    `adapt` is ``"auto"`` (adapt on the complete rows of `poses`), ``False``
    (nothing) or an array of separate poses to adapt on; then, when adopted,
    `self_training` rounds of :func:`self_train` on the incomplete rows of
    `poses` (0: none; None: ``SELF_TRAINING_ROUNDS``). A refusal is warned about
    (``UserWarning``) when adaptation poses were given explicitly (unless
    ``warn=False``); under ``"auto"`` it is said in the result's summary only
    (small batches of incomplete poses are the common case, not a problem),
    and ``sparseedm recover`` says it on stderr.

    Parameters
    ----------
    dictionary : Dictionary, str or path
        The base dictionary (a name or path is loaded).
    poses : ndarray (n, N, 2)
        The poses to be recovered, in pixels, as
        :func:`~sparseedm._recovery_base.validate_poses` gives them (trusted).
    missing : ndarray of bool (n, N) or None
        True where a joint of `poses` is missing; None: NaN coordinates mark them.
    adapt : "auto", False, None or array_like (n_adapt, N, 2)
        ``"auto"``: adapt on the complete rows of `poses`; False or None: no
        adaptation; an array: adapt on those poses instead.
    n_jobs : int or None, default 1
        Threads of the adaptation and of the self-training rounds.
    random_state : int, default 0
        Seed of the adaptation and the rounds.
    warn : bool, default True
        Warn when explicitly given adaptation poses are refused.
    self_training : int, optional
        Rounds of :func:`self_train` after an adopted adaptation; default
        :data:`SELF_TRAINING_ROUNDS`.
    min_poses : int, default MIN_COMPLETE_POSES
        As :func:`run_adaptation`'s (the temporal path lowers it for one clip).
    backend, scheduler : optional
        As :func:`sparseedm.recover`'s: ``backend="dask"`` runs the guard's and
        the self-training rounds' recoveries on the cluster.
    check_input : bool, default True
        Validate an `adapt` array; False: it was made from validated poses
        (the temporal path's offered poses). `poses` are never checked again.

    Returns
    -------
    dictionary : Dictionary
        The dictionary to recover with: the adapted one when adopted, else
        the base (as given when `adapt` is False or None).
    adaptation : AdaptationResult or None
        What was done; None when `adapt` is False or None.

    Raises
    ------
    SparseEDMError
        `adapt` is a string other than ``"auto"``.
    """
    if adapt is False or adapt is None:
        return dictionary, None
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    if isinstance(adapt, str):
        if adapt != "auto":
            raise SparseEDMError(f"adapt must be 'auto', False or an array of poses, "
                                 f"got {adapt!r}")
        source = (poses, missing)
        explicit = False
    else:
        source = (adapt, None)
        explicit = True
    dist = dict(backend=backend, scheduler=scheduler)
    # the poses to be recovered come validated (recover()); separate ones are checked here
    res = run_adaptation(dictionary, *source, n_jobs=n_jobs, random_state=random_state,
                         min_poses=min_poses, check_input=explicit and check_input, **dist)
    if warn and explicit and not res.adapted and res.candidate is None:
        warnings.warn(f"no adaptation: {res.reason}", UserWarning, stacklevel=3)
    rounds = SELF_TRAINING_ROUNDS if self_training is None else self_training
    res = self_train(dictionary, res, *source, poses, missing, rounds=rounds,
                     random_state=random_state, n_jobs=n_jobs, **dist)
    return res.dictionary, res


class _Reservoir:
    """The rows with the `max_poses` smallest seeded keys seen so far (stream order kept)."""

    def __init__(self, max_poses):
        self.max_poses = max_poses
        self.keys = np.zeros(0)
        self.rows = np.zeros(0, dtype=np.int64)
        self.poses = self.missing = None

    def add(self, keys, rows, poses, missing):
        if self.poses is not None:
            keys, rows = np.concatenate([self.keys, keys]), np.concatenate([self.rows, rows])
            poses = np.concatenate([self.poses, poses])
            missing = np.concatenate([self.missing, missing])
        top = np.argsort(keys, kind="stable")[:self.max_poses]
        self.keys, self.rows = keys[top], rows[top]
        self.poses, self.missing = poses[top], missing[top]

    def result(self, n_joints):
        if self.poses is None:
            return np.zeros((0, n_joints, 2)), np.zeros((0, n_joints), bool)
        order = np.argsort(self.rows)
        return self.poses[order], self.missing[order]


def sample_stream(chunks, max_poses=DEFAULT_MAX_POSES, random_state=0):
    """Bounded, seeded samples of the complete and of the incomplete poses of a stream.

    One pass over `chunks` (iterable of ``(poses (n, N, 2), missing (n, N))``,
    e.g. a memory-mapped .npy file's rows). Each row gets a seeded random key
    and each sample keeps the `max_poses` smallest keys of its kind (the
    same sample whatever the chunk size), in stream order, so memory stays
    at ``2 * max_poses`` poses however long the stream.

    Parameters
    ----------
    chunks : iterable of (ndarray (n, N, 2), ndarray of bool (n, N) or None)
        The stream's poses in pixels with their missing masks (None: NaN
        coordinates mark the missing joints).
    max_poses : int, default 5000
        Poses at most in each sample.
    random_state : int, default 0
        Seed of the rows' keys.

    Returns
    -------
    complete : ndarray (<= max_poses, N, 2)
        Complete, finite poses (what adaptation learns from).
    incomplete, incomplete_missing : ndarray (<= max_poses, N, 2), (<= max_poses, N)
        Poses with some but not all joints missing (NaN or `missing`), and
        their masks (what self-training recovers, :func:`self_train`).

    Examples
    --------
    >>> import numpy as np
    >>> p = np.arange(10 * 14 * 2, dtype=float).reshape(10, 14, 2)
    >>> m = np.zeros((10, 14), bool); m[3, 0] = True
    >>> c, i, im = sample_stream([(p[:5], m[:5]), (p[5:], m[5:])], max_poses=4)
    >>> c.shape, i.shape, int(im.sum())
    ((4, 14, 2), (1, 14, 2), 1)
    """
    rng = np.random.default_rng([int(random_state or 0), 19])
    full, part = _Reservoir(max_poses), _Reservoir(max_poses)
    offset, n_joints = 0, 0
    for poses, missing in chunks:
        poses = np.asarray(poses, dtype=float)
        n, n_joints = len(poses), poses.shape[1]
        keys = rng.random(n)  # one key per row, drawn whatever the row holds
        mask, incomplete = _occluded(poses, missing)
        for res, ok in ((full, ~mask.any(axis=1)), (part, incomplete)):
            rows = np.flatnonzero(ok)
            res.add(keys[rows], rows + offset, poses[rows], mask[rows])
        offset += n
    return (full.result(n_joints)[0],) + part.result(n_joints)


def sample_complete(chunks, max_poses=DEFAULT_MAX_POSES, random_state=0):
    """A bounded, seeded sample of the complete poses of a stream, in stream order.

    The first sample of :func:`sample_stream` (the same rows).

    Parameters
    ----------
    chunks : iterable of (ndarray (n, N, 2), ndarray of bool (n, N) or None)
        The stream's poses in pixels with their missing masks.
    max_poses : int, default 5000
        Poses at most in the sample.
    random_state : int, default 0
        Seed of the rows' keys.

    Returns
    -------
    ndarray (<= max_poses, N, 2)
        Complete, finite poses of the stream.

    Examples
    --------
    >>> import numpy as np
    >>> p = np.arange(10 * 14 * 2, dtype=float).reshape(10, 14, 2)
    >>> m = np.zeros((10, 14), bool); m[3, 0] = True
    >>> s = sample_complete([(p[:5], m[:5]), (p[5:], m[5:])], max_poses=4)
    >>> s.shape
    (4, 14, 2)
    """
    return sample_stream(chunks, max_poses, random_state)[0]


def fine_tune_file(train_path, output, init="default", *, passes=DEFAULT_PASSES, alpha=None,
                   alpha_recover=None, stats=DEFAULT_STATS, replay=DEFAULT_REPLAY,
                   batch_size=DEFAULT_BATCH_SIZE, random_state=0, n_jobs=None,
                   input_format=None, joint_map=None, errors_path=None):
    """Fine-tune an existing dictionary on the complete poses of a training .npz or keypoint
    file; save it.

    What ``sparseedm fit TRAIN.npz --init default|PATH`` runs: the learning
    of :func:`adapt_vectors` over every complete pose of TRAIN (no sample, no
    guard: the caller validates, e.g. with ``sparseedm evaluate``).

    Parameters
    ----------
    train_path : str or path
        A training ``.npz`` (``poses2d``) or a keypoint file, as ``sparseedm
        fit`` reads it (:func:`sparseedm.learning.load_training_poses`).
    output : str or path
        Where the fine-tuned dictionary is saved (``.npz``).
    init : Dictionary, str or path, default "default"
        The dictionary to start from (a name or path is loaded).
    passes : float, default 2
        Passes of the online learning over the poses.
    alpha : float, optional
        Lasso penalty of the learning; default the base's ``alpha_train``.
    alpha_recover : float, optional
        The recovery alpha the new dictionary recommends; default the base's.
    stats : {"fresh", "carried"}, default "fresh"
        How the learning's inner statistics start (:func:`adapt_vectors`).
    replay : float, default 0.0
        Base atoms mixed into each mini-batch, as a share of its size
        (:func:`adapt_vectors`).
    batch_size : int, default 256
        Poses per mini-batch.
    random_state : int, default 0
        Seed of the mini-batches.
    n_jobs : int, optional
        Threads of the coding step; None: numba's.
    input_format, joint_map : str, optional
        How a keypoint file is read (:func:`sparseedm.keypoints.read_keypoints`).
    errors_path : str or path, optional
        The errors file of TRAIN's refused rows and unreadable frame files
        (:func:`sparseedm.learning.training_errors`, as ``sparseedm recover``'s);
        default ``<output stem>.errors.csv``, written only when there is
        something to list.

    Returns
    -------
    Dictionary
        The fine-tuned dictionary (also saved to `output`), its provenance
        naming the training file and the base's (and counting TRAIN's refused
        rows and unreadable files).

    Raises
    ------
    FileFormatError
        TRAIN is neither a training file (a ``poses2d`` array of shape (n, N, 2))
        nor a readable keypoint file.
    SparseEDMError
        TRAIN holds no complete pose.
    PoseError
        TRAIN's poses have another number of joints than the dictionary.
    """
    if Path(output).suffix != ".npz":
        raise DictionaryError(f"{output}: a dictionary file must end in .npz")
    # before any work: the output is neither the training file nor the base's file
    errors_path = default_errors_path(output) if errors_path is None else Path(errors_path)
    check_paths([("training file", train_path),
                 ("initial dictionary", None if isinstance(init, Dictionary) else init)],
                [("output", output), ("errors file", errors_path)])
    base = init if isinstance(init, Dictionary) else load_dictionary(init)
    train = load_training_poses(train_path, input_format, joint_map)
    poses = train.poses
    X, ok = complete_pose_vectors(poses)
    if len(X) == 0:
        raise SparseEDMError(f"{train_path}: no complete poses to fine-tune on")
    if poses.shape[1] != base.n_joints:
        raise PoseError(f"{train_path}: poses have {poses.shape[1]} joints, the dictionary "
                        f"{base.n_joints}")
    alpha = base.alpha_train if alpha is None else alpha
    _progress.say(f"fine-tuning {base.n_components:,} atoms on {len(X):,} complete poses "
                  f"({passes:g} passes)")
    comps = adapt_vectors(base.components, X, alpha, passes=passes, stats=stats,
                          replay=replay, batch_size=batch_size, random_state=random_state,
                          n_jobs=n_jobs)
    prov = {
        "files": [Path(train_path).name], "n_poses": int(len(X)), "sha256": poses_sha256(poses),
        "sha256_of": "poses2d float64 values", "seed": random_state, "passes": passes,
        "batch_size": batch_size, "fine_tuned_from": dict(base.provenance or {}),
        "stats": stats, **training_errors(train, errors_path),
    }
    d = Dictionary(components=comps, joint_names=base.joint_names,
                   alpha_recover=base.alpha_recover if alpha_recover is None else alpha_recover,
                   alpha_train=alpha, alpha_scaling=base.alpha_scaling,
                   positive_code=base.positive_code, recovery_scale=base.recovery_scale,
                   provenance=prov)
    d.save(output)
    return d
