"""The low pieces every recovery path shares: statuses, the result, screening, placement.

One step below the recovery methods (scikit-learn's ``_base`` habit): the
sparse kernel (:mod:`sparseedm._recovery_kernel`), the FConv path
(:mod:`sparseedm.fconv.recover`), ensembles (:func:`combine`) and lifting
(:func:`screen_poses`, :data:`STATUSES`) all import from here, and this module
imports nothing above the geometry, the dictionary format and validation.

- :data:`STATUSES`, :data:`OK_STATUSES`  the per-pose statuses and the usable ones
- :class:`RecoveryResult`                what every recovery path returns
- :func:`validate_poses`                 poses and mask checked, bad rows flagged
- :func:`bad_coordinates`                those rows, for inner callers that trust their input
- :func:`screen_poses`, :func:`screen`   why a pose cannot be used; the usable ones represented
- :func:`place_occluded_inplace`         occluded joints placed from recovered distances
- :func:`combine`                        one result from several members' results
- :func:`mirror_weights`                 recover(mirror="auto")'s weights per pose
- :func:`cold_prior`                     the dictionary and mirror rule of a call given neither
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import NamedTuple

import numpy as np

from ._validation import check_mask, check_pose_shape, check_poses, unmask
from .dictionary import Dictionary
from .edm import observed_entries, vector_to_edm
from .exceptions import PoseError
from .normalize import MIN_OBSERVED_JOINTS, far_joint, represent
from .placement import WEIGHT_POWER, place_missing_joints

__all__ = ["STATUSES", "OK_STATUSES", "RecoveryResult", "Screened", "Screening",
           "validate_poses", "bad_coordinates", "screen_poses", "screen",
           "place_occluded_inplace", "combine", "mirror_weights", "MIRROR_TEMPERATURE",
           "COLD_DICTIONARY", "cold_prior",
           "SCREENING_REFUSALS", "status_counts", "poses_per_second", "recovery_summary",
           "take_rows", "put_rows", "averaged_summary"]

#: Per-pose statuses and what they mean.
STATUSES = {
    "recovered": ("occluded joints recovered; the code is certified optimal (the lasso's duality "
                  "gap; the fast preset's local ridge: its normal equations' residual)"),
    "inaccurate": "recovered, but the solver could not certify optimality (gap above tolerance)",
    "complete": "no joint was missing: returned unchanged",
    "solver_failed": "the solver failed on this pose; nothing recovered",
    "too_few_observed": f"fewer than {MIN_OBSERVED_JOINTS} observed joints",
    "invalid_coordinates": "an observed coordinate is infinite, or NaN where the mask says observed",
    "degenerate": "all observed joints coincide: the pose cannot be normalised",
    "out_of_range": ("the observed joints' extent overflows float64 or is subnormal (rescale "
                     "them), or one joint lies so far from the others that, beside it, their "
                     "distances vanish in float64 rounding (not a body)"),
    "empty_code": "the lasso chose no atom (alpha too large for this pose): nothing recovered",
}
#: statuses of the poses that came back usable
OK_STATUSES = ("recovered", "inaccurate", "complete")
#: the refusals :func:`screen_poses` gives, before any solving (every path shares them)
SCREENING_REFUSALS = ("too_few_observed", "invalid_coordinates", "degenerate", "out_of_range")


def status_counts(status, statuses):
    """How many rows have each of `statuses`, in its order, those present only: the
    one count behind :meth:`RecoveryResult.summary` and ``LiftResult.summary``.

    Examples
    --------
    >>> status_counts(np.array(["complete", "degenerate", "complete"]), STATUSES)
    {'complete': 2, 'degenerate': 1}
    """
    counts = {s: int((status == s).sum()) for s in statuses}
    return {k: v for k, v in counts.items() if v}


def poses_per_second(n, seconds):
    """The rate a summary reports (None when no time was measured)."""
    return round(n / seconds, 1) if seconds else None


def recovery_summary(status, recovered_joints, fallback, seconds):
    """The counts a person reads at the end of a recovery: one home for
    :meth:`RecoveryResult.summary` and :func:`sparseedm.batch.recover_file`.

    Examples
    --------
    >>> recovery_summary(np.array(["recovered", "degenerate"]), 3, np.zeros(2, bool), 0.5)
    {'poses': 2, 'recovered_joints': 3, 'refused': 1, 'fallbacks': 0, 'seconds': 0.5, \
'poses_per_second': 4.0, 'status': {'recovered': 1, 'degenerate': 1}}
    """
    return {
        "poses": int(len(status)),
        "recovered_joints": int(recovered_joints),
        "refused": int((~np.isin(status, OK_STATUSES)).sum()),
        "fallbacks": int(np.sum(fallback)),
        "seconds": round(seconds, 3),
        "poses_per_second": poses_per_second(len(status), seconds),
        "status": status_counts(status, STATUSES),
    }


@dataclass
class RecoveryResult:
    """What :func:`sparseedm.recover` returns; every array has the poses' leading axis n.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Filled poses in the caller's frame: observed joints exactly as given,
        occluded ones placed from the recovered distances (NaN where the pose
        was refused).
    vectors : ndarray (n, N(N-1)/2)
        Completed EDM vectors after the Eq. 10 merge, in normalised units.
    missing : ndarray of bool (n, N)
        True where a joint was occluded in the input (from the mask given, or
        its NaN coordinates): the joints the recovery filled.
    center, scale : ndarray (n, 2), (n,)
        The normalisation: pixel distances are ``vectors * scale``.
    objective, gap : ndarray (n,)
        Lasso objective and duality gap of the full observed sub-problem
        (NaN where no lasso was solved).
    n_active : ndarray of int (n,)
        Non-zero atoms in the code.
    status : ndarray of str (n,)
        One of :data:`STATUSES`; ``reason`` says more for refused poses.
    reason : ndarray of str (n,)
        The status in words: why a pose was refused, or how it was filled
        (an uncertified gap, the FConv network, the temporal model); may be
        empty for a pose recovered as expected.
    fallback : ndarray of bool (n,)
        The fast solver handed this pose to Clarabel.
    alpha : float
        The unscaled alpha used.
    seconds : float
        Wall time of the call.
    adaptation : AdaptationResult or None
        What ``adapt`` did (:mod:`sparseedm.adaptation`); None with ``adapt=False``.
    dictionary : Dictionary
        The dictionary the poses were recovered with (the adapted one when
        adaptation was used): ``res.dictionary.save(path)`` keeps it. For an
        ensemble, the first member's.
    members : int
        Dictionaries averaged (``recover(ensemble=K)``, :mod:`sparseedm.ensemble`).
    uncertainty : ndarray (n, N) or None
        How sure each joint is: the radius (the input's units) of a circle
        around the joint that holds the true joint 9 times in 10; 0 for an
        observed joint, NaN on a refused pose (:mod:`sparseedm.uncertainty`).
        Set by :func:`sparseedm.recover` for the 14-joint layout; None from the
        lower layers and for other layouts.
    outliers : ndarray of bool (n, N) or None
        Points given with a low confidence that the pose model and the track
        both contradicted, treated as missing and filled
        (:mod:`sparseedm.outliers`); None when no confidence was given or the
        check was off.
    averaged : ndarray of str (n,) or None
        What each pose's answer was averaged with after its path's own answer,
        ``""``: nothing (:func:`sparseedm.exemplars.blend_many_hidden`: the
        local ridge's answer over the file's complete poses,
        :data:`~sparseedm.exemplars.AVERAGED_MANY_HIDDEN`, and over the base
        with them as extra atoms, :data:`~sparseedm.exemplars.AVERAGED_RIDGE_MEAN`,
        and one Gaussian's of the file's poses at the check's weight,
        :data:`~sparseedm.exemplars.AVERAGED_GAUSSIAN`, joined by ``"; "``;
        the shipped pose bank's local Gaussian,
        :data:`~sparseedm.cold_bank.AVERAGED_BANK`, with ``adapt=False``
        without a dictionary, and on the default path where probes gave it a
        weight, :func:`sparseedm.cold_bank.bank_step`; the donor step's moves
        are not named here); None: the path averaged nothing so.
    spread : ndarray (n, N) or None
        With ``averaged``: the distance (the input's units) between the two
        answers averaged at each filled joint (the largest when averaged
        twice), 0 where nothing was averaged.

    Examples
    --------
    >>> import numpy as np, sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> poses = np.stack([pose, pose, np.full_like(pose, np.nan)])
    >>> poses[0, 4] = np.nan                        # a hidden right wrist
    >>> res = sparseedm.recover(poses)
    >>> res.status.tolist()
    ['recovered', 'complete', 'too_few_observed']
    >>> res.summary()["status"], res.ok.tolist()
    ({'recovered': 1, 'complete': 1, 'too_few_observed': 1}, [True, True, False])
    >>> filled = res.missing & res.ok[:, None]       # the joints filled
    >>> bool((res.uncertainty[filled] > 0).all()), res.take([0]).poses.shape
    (True, (1, 14, 2))
    """

    poses: np.ndarray
    vectors: np.ndarray
    missing: np.ndarray
    center: np.ndarray
    scale: np.ndarray
    objective: np.ndarray
    gap: np.ndarray
    n_active: np.ndarray
    status: np.ndarray
    reason: np.ndarray
    fallback: np.ndarray
    alpha: float
    seconds: float = 0.0
    adaptation: object = None
    dictionary: Dictionary | None = None
    members: int = 1
    uncertainty: np.ndarray | None = None
    outliers: np.ndarray | None = None
    averaged: np.ndarray | None = None
    spread: np.ndarray | None = None

    @property
    def edms(self) -> np.ndarray:
        """Completed EDMs (n, N, N), normalised units."""
        return vector_to_edm(self.vectors)

    @property
    def edms_pixels(self) -> np.ndarray:
        """Completed EDMs (n, N, N) in the caller's units."""
        return vector_to_edm(self.vectors * self.scale[:, None])

    @property
    def ok(self) -> np.ndarray:
        """True for poses that came back usable (recovered, inaccurate or complete)."""
        return np.isin(self.status, OK_STATUSES)

    @property
    def adapted(self) -> bool:
        """True when the poses were recovered with a dictionary adapted to them."""
        return bool(self.adaptation is not None and self.adaptation.adapted)

    def take(self, rows):
        """The result of the poses `rows` only (:func:`take_rows`).

        Parameters
        ----------
        rows : array_like of int, slice or array_like of bool (n,)
            The poses to keep: indices, a slice or a mask.

        Returns
        -------
        RecoveryResult
            Every per-pose array indexed by `rows`; ``alpha``, ``seconds``,
            ``adaptation``, ``dictionary`` and ``members`` as they are.
        """
        return take_rows(self, rows)

    def summary(self) -> dict:
        """Counts a person reads at the end of a batch.

        Returns
        -------
        dict
            ``poses``, ``recovered_joints``, ``refused``, ``fallbacks``,
            ``seconds``, ``poses_per_second`` and ``status`` (the count of
            each status present), as :func:`recovery_summary` gives them; also
            ``adaptation`` (:meth:`AdaptationResult.summary
            <sparseedm.adaptation.AdaptationResult.summary>`) when adaptation
            ran; ``averaged`` (:func:`averaged_summary`: counts, and the first
            few rows, :attr:`averaged` says it per pose) when the path averaged
            answers of its own (``answers``) or some poses' answers with
            another's (``with``); and ``ensemble`` (the members) when more
            than one and not the path's own averaged answers.
        """
        recovered = self.missing[np.isin(self.status, ("recovered", "inaccurate"))].sum()
        out = recovery_summary(self.status, recovered, self.fallback, self.seconds)
        if self.adaptation is not None:
            out["adaptation"] = self.adaptation.summary()
        averaged = averaged_summary(self.averaged, getattr(
            self.adaptation, "averaged_answers", ()) if self.members > 1 else ())
        if averaged:
            out["averaged"] = averaged
        if self.members > 1 and not (averaged.get("answers") and
                                     "ensemble" not in out.get("adaptation", {})):
            out["ensemble"] = self.members
        return out


#: rows of each kind :func:`averaged_summary` names (the counts are whole)
FIRST_ROWS = 5


def averaged_summary(averaged, answers=(), rows=True):
    """What a result's answers average, said for a person: ``answers`` (the
    codes the path itself averages for every occluded pose, :attr:`AdaptationResult.averaged_answers
    <sparseedm.adaptation.AdaptationResult.averaged_answers>`) and ``with``
    (per kind of :attr:`RecoveryResult.averaged`, the count of ``poses`` whose
    answer was averaged with it and, with `rows`, the first few of them,
    ``first_rows``: :attr:`RecoveryResult.averaged` says it for every pose);
    {} when nothing was averaged (an ensemble asked for is
    ``summary()["ensemble"]``).

    Parameters
    ----------
    averaged : array_like of str (n,) or None
        :attr:`RecoveryResult.averaged`.
    answers : sequence of str, default ()
        The path's own averaged answers.
    rows : bool, default True
        Name the first :data:`FIRST_ROWS` rows of each kind.

    Returns
    -------
    dict
        ``answers`` and ``with`` as above, each only when there is one.

    Examples
    --------
    >>> averaged_summary(np.array(["", "a", "a; b"]))
    {'with': {'a': {'poses': 2, 'first_rows': [1, 2]}, 'b': {'poses': 1, 'first_rows': [2]}}}
    >>> averaged_summary(np.array(["a"] * 1000), rows=False)
    {'with': {'a': {'poses': 1000}}}
    >>> averaged_summary(None, ("x", "y"))
    {'answers': ['x', 'y']}
    """
    out = {"answers": list(answers)} if len(answers) else {}
    if averaged is None:
        return out
    kinds = {}
    texts, which = np.unique(np.asarray(averaged, str), return_inverse=True)
    for i, text in enumerate(texts):
        for kind in filter(None, str(text).split("; ")):
            kinds.setdefault(kind, []).append(np.flatnonzero(which == i))
    if kinds:
        out["with"] = {}
        for kind, parts in kinds.items():
            at = np.sort(np.concatenate(parts))
            out["with"][kind] = dict(poses=len(at), **(
                {"first_rows": at[:FIRST_ROWS].tolist()} if rows else {}))
    return out


#: the smallest extent a pose may have: below it 1/extent overflows or loses bits
_TINY = np.finfo(float).tiny



def take_rows(result, rows):
    """A per-pose result dataclass (its arrays' leading axis the poses) of the
    poses `rows` only (an index array, a slice or a bool mask): every array
    field indexed, the other fields as they are."""
    return replace(result, **{f.name: getattr(result, f.name)[rows] for f in fields(result)
                              if isinstance(getattr(result, f.name), np.ndarray)})


def put_rows(result, rows, part):
    """`result` with the poses `rows` (an index array) replaced by those of `part`
    (a result of the same class over ``len(rows)`` poses): every per-pose array of
    `result` copied with those rows from `part`'s (strings widened to fit), the
    other fields as they are.

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> two = sparseedm.recover(np.stack([pose, pose + 1]), adapt=False)
    >>> back = put_rows(two, np.array([1]), two.take([0]))
    >>> bool(np.array_equal(back.poses[1], two.poses[0]))
    True
    """
    out = {}
    for f in fields(result):
        mine, theirs = getattr(result, f.name), getattr(part, f.name)
        if isinstance(mine, np.ndarray) and isinstance(theirs, np.ndarray):
            new = mine.astype(np.result_type(mine, theirs))  # a copy
            new[rows] = theirs
            out[f.name] = new
    return replace(result, **out)


def validate_poses(poses, missing, n_joints, caller="recover", model="dictionary"):
    """Poses (n, N, 2) as floats, the missing mask and the rows with a bad
    observed coordinate; whole-input problems raise, naming `caller`/`model`.
    A masked array's masked joints are missing."""
    given = poses
    poses, missing = unmask(poses, missing, caller)
    poses = check_poses(poses, caller)
    if poses.ndim == 2:
        poses = poses[None]
    check_pose_shape(poses, n_joints=n_joints, model=model, given=given)
    if missing is None:  # a joint with NaN and inf coordinates is a bad one, not missing
        return poses, np.isnan(poses).any(axis=-1), np.isinf(poses).any(axis=-1).any(axis=-1)
    mask = check_mask(missing, caller)
    if mask.ndim == 1:
        mask = mask[None]
    if mask.shape != poses.shape[:2]:
        raise PoseError(f"missing must have shape {poses.shape[:2]}, got {mask.shape}")
    return poses, mask, bad_coordinates(poses, mask)


def bad_coordinates(poses, mask):
    """Rows (n,) with a NaN or infinite coordinate at an observed joint: what
    :func:`validate_poses` flags, for inner callers that trust their (already
    validated) poses and mask and check nothing again.

    Examples
    --------
    >>> poses = np.zeros((2, 3, 2)); poses[0, 1] = np.inf; poses[1, 2] = np.nan
    >>> bad_coordinates(poses, np.array([[0, 0, 0], [0, 0, 1]], bool)).tolist()
    [True, False]
    """
    return ((~np.isfinite(poses)).any(axis=-1) & ~mask).any(axis=-1)


class Screening(NamedTuple):
    """What :func:`screen_poses` returns (a tuple, so it unpacks as before)."""

    status: np.ndarray
    reason: np.ndarray
    n_obs: np.ndarray
    clean: np.ndarray

    def take(self, rows):
        """The screening of the poses `rows` only (each pose is screened alone)."""
        return Screening(*(a[rows] for a in self))


class Screened(NamedTuple):
    """What :func:`screen` returns (a tuple, so it unpacks as before): the
    statuses, and the usable poses' vectors and normalisation under one
    representation; `filled` holds the complete poses as given, NaN elsewhere."""

    status: np.ndarray
    reason: np.ndarray
    n_obs: np.ndarray
    clean: np.ndarray
    vectors: np.ndarray
    center: np.ndarray
    scale: np.ndarray
    filled: np.ndarray


def screen_poses(poses, mask, bad_coord):
    """Why each pose cannot be used, before any solving: shared by every path.

    Used by :func:`recover`, the FConv path and :func:`sparseedm.lift`; the
    inputs are trusted (as :func:`validate_poses` gives them).

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        The poses as floats (missing joints may hold anything).
    mask : ndarray of bool (n, N)
        True where a joint is missing.
    bad_coord : ndarray of bool (n,)
        Rows with a NaN or infinite observed coordinate.

    Returns
    -------
    Screening
        ``(status, reason, n_obs, clean)``: `status` is ``""`` for a usable
        pose and a refusal of :data:`STATUSES` otherwise
        (``invalid_coordinates``, ``too_few_observed``, ``degenerate``,
        ``out_of_range``), `reason` says why in words, `n_obs` counts each
        pose's observed joints and `clean` is the poses with missing joints
        at 0.

    Examples
    --------
    >>> pose = np.zeros((1, 14, 2))                 # every joint at one point
    >>> screen_poses(pose, np.zeros((1, 14), bool), np.zeros(1, bool)).status.tolist()
    ['degenerate']
    """
    n, N = mask.shape
    status = np.full(n, "", dtype=object)
    reason = np.full(n, "", dtype=object)
    n_obs = (~mask).sum(axis=1)
    status[bad_coord] = "invalid_coordinates"
    reason[bad_coord] = "an observed joint has a NaN or infinite coordinate"
    few = ~bad_coord & (n_obs < MIN_OBSERVED_JOINTS)
    status[few] = "too_few_observed"
    reason[few] = [f"{k} observed joints, at least {MIN_OBSERVED_JOINTS} needed" for k in n_obs[few]]
    clean = np.where(mask[..., None], 0.0, poses)
    with np.errstate(invalid="ignore", over="ignore"):  # inf - inf on refused rows
        lo = np.where(mask[..., None], np.inf, poses).min(axis=1)
        hi = np.where(mask[..., None], -np.inf, poses).max(axis=1)
        widest = (hi - lo).max(axis=1)  # -inf for a pose with no observed joint
        # the 'average' fill sums the observed coordinates: that must not overflow
        total = np.abs(clean).sum(axis=1).max(axis=1)
    degenerate = (status == "") & ~(widest > 0)
    status[degenerate] = "degenerate"
    reason[degenerate] = "all observed joints coincide"
    huge = (status == "") & ~(np.isfinite(widest) & np.isfinite(total))
    status[huge] = "out_of_range"
    reason[huge] = ("the observed joints span more than float64 can hold (extent or sum "
                    "overflows); rescale the coordinates")
    tiny = (status == "") & (widest / 2 < _TINY)
    status[tiny] = "out_of_range"
    reason[tiny] = [f"the observed joints span only {w:.3g} (a subnormal extent); rescale "
                    "the coordinates" for w in widest[tiny]]
    far = np.flatnonzero(status == "")
    joint, ratio = far_joint(poses[far], mask[far])
    far, joint, ratio = far[joint >= 0], joint[joint >= 0], ratio[joint >= 0]
    status[far] = "out_of_range"
    reason[far] = [f"joint {j} lies {q:.3g} times the other joints' extent away from them: "
                   "beside it their distances vanish in float64 rounding, not a body; check "
                   "its coordinates" for j, q in zip(joint, ratio)]
    return Screening(status, reason, n_obs, clean)



def screen(poses, mask, bad_coord, representation, rule="box", screening=None):
    """Statuses of every pose, and the usable ones' vectors under `representation`,
    normalised by `rule` (:func:`sparseedm.normalize.normalize`).

    Shared by the sparse path (its dictionary's ``recovery_scale``) and the
    FConv path (:mod:`sparseedm.fconv`, the box its models were trained on).
    `screening`: :func:`screen_poses` of these poses when the caller has it
    (trusted; `bad_coord` then unused), so that no pose is screened twice.
    """
    n, N = mask.shape
    if screening is None:
        screening = screen_poses(poses, mask, bad_coord)
    status, reason, n_obs, clean = screening
    status, reason = status.copy(), reason.copy()  # written below; the caller's kept
    status[status == ""] = "recovered"
    complete = (status == "recovered") & (n_obs == N)
    status[complete] = "complete"
    reason[complete] = "no joint missing"

    vectors = np.full((n, N * (N - 1) // 2), np.nan)
    center = np.full((n, 2), np.nan)
    scale = np.full(n, np.nan)
    filled = np.full_like(poses, np.nan)
    usable = np.isin(status, ("recovered", "complete"))
    if usable.any():
        T, c, s = represent(clean[usable], mask[usable], representation, rule)
        vectors[usable], center[usable], scale[usable] = T, c, s
        filled[complete] = poses[complete]
    return Screened(status, reason, n_obs, clean, vectors, center, scale, filled)


def place_occluded_inplace(poses, mask, screened, certified=None, weight_power=WEIGHT_POWER):
    """Place the occluded joints of recovered poses, writing into `screened`.

    `screened` is :func:`screen`'s record after the recovery wrote its
    completed ``vectors`` and ``status`` into it: the joints go into its
    ``filled`` array, batched by occluded count; its ``status``, ``reason``,
    ``vectors`` and ``filled`` are updated in place.

    `weight_power`: the placement's residual weights (chosen on the sparse
    method's answers; the FConv path keeps unweighted placement).

    No row stays recovered unless what it returns (its joints, its distances
    and, where given, ``certified``: a finite objective and gap) is finite:
    such rows become ``solver_failed``.
    """
    clean, vectors, center, scale = (screened.clean, screened.vectors, screened.center,
                                     screened.scale)
    status, reason, filled = screened.status, screened.reason, screened.filled
    N = mask.shape[1]
    n_obs = (~mask).sum(axis=1)
    placed_rows = np.flatnonzero(np.isin(status, ("recovered", "inaccurate")))
    for count in np.unique(N - n_obs[placed_rows]):
        rows = placed_rows[N - n_obs[placed_rows] == count]
        normed = (clean[rows] - center[rows, None, :]) / scale[rows, None, None]
        P = place_missing_joints(normed, vector_to_edm(vectors[rows]), mask[rows],
                                 weight_power=weight_power)
        out = poses[rows].copy()
        with np.errstate(over="ignore", invalid="ignore"):
            out[mask[rows]] = (P * scale[rows, None, None]
                               + center[rows, None, :]).reshape(-1, 2)
        filled[rows] = out
    placed = np.isin(status, ("recovered", "inaccurate"))
    finite = np.isfinite(filled).all(axis=(1, 2)) & np.isfinite(vectors).all(axis=1)
    if certified is not None:
        finite &= certified
    broken = placed & ~finite
    status[broken] = "solver_failed"
    reason[broken] = "the recovered distances or joints are not finite"
    filled[broken] = np.nan
    vectors[broken] = np.nan


#: a row's status in the ensemble: the first of these any member gave it
_PRECEDENCE = ("solver_failed", "inaccurate")


def combine(results, weights=None):
    """One :class:`RecoveryResult` from members' results on the same poses.

    Filled poses and EDM vectors are the means over the members (with
    `weights`, array (members, n) summing to 1 over the members: each row's
    weighted mean, :func:`mirror_weights`). A row's
    status is the members' common status; where they differ, a solver failure
    of any member fails the row (its joints and vectors NaN, as a failed row of
    one recovery), else an uncertified ("inaccurate") answer of any member is
    reported; the reason is that member's. Objective, gap and active atoms are the first
    member's (each member's certificate is of its own lasso); ``fallback`` is
    true if any member fell back to Clarabel. ``seconds`` is the members' sum.

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> pose[4] = np.nan
    >>> one = sparseedm.recover(pose, adapt=False)
    >>> both = combine([one, one])
    >>> bool(np.allclose(both.poses, one.poses, equal_nan=True)), both.status.tolist()
    (True, ['recovered'])
    """
    results = list(results)
    first = results[0]
    if len(results) == 1:
        return first
    ok = np.stack([r.ok for r in results])  # (members, n)
    with np.errstate(invalid="ignore"):  # rows not usable in every member are set below
        if weights is None:
            poses = np.mean([r.poses for r in results], axis=0)
            vectors = np.mean([r.vectors for r in results], axis=0)
        else:
            poses = np.einsum("mn,mnjd->njd", weights, [r.poses for r in results])
            vectors = np.einsum("mn,mne->ne", weights, [r.vectors for r in results])
    # what every member keeps as given stays bit for bit (a mean of equal floats
    # need not be that float): the observed joints and their distances
    observed = ~first.missing
    poses = np.where(observed[..., None], first.poses, poses)
    vectors = np.where(observed_entries(first.missing), first.vectors, vectors)
    # object arrays: a member's longer status or reason must not be cut to the
    # first member's string width
    status = first.status.astype(object)
    reason = first.reason.astype(object)
    for bad in _PRECEDENCE[::-1]:  # the first of _PRECEDENCE wins
        for r in results[::-1]:
            hit = r.status == bad
            status[hit] = r.status[hit]
            reason[hit] = r.reason[hit]
    unusable = ~ok.all(axis=0)  # refused by the screening (all members) or failed
    poses[unusable] = np.nan
    vectors[unusable] = np.nan
    refused = ~ok[0]  # refused rows come back as one recovery returns them
    poses[refused] = first.poses[refused]
    vectors[refused] = first.vectors[refused]
    return type(first)(
        poses=poses, vectors=vectors, missing=first.missing, center=first.center,
        scale=first.scale, objective=first.objective, gap=first.gap, n_active=first.n_active,
        status=status.astype(str), reason=reason.astype(str),
        fallback=np.any([r.fallback for r in results], axis=0), alpha=first.alpha,
        seconds=float(sum(r.seconds for r in results)), adaptation=first.adaptation,
        dictionary=first.dictionary, members=len(results),
        uncertainty=_mean_uncertainty(results, unusable))


#: ``recover(mirror="auto")``: the temperature of the mirror image's weight,
#: ``min(1/2, 1 / (1 + exp(r / T)))`` with r its lasso objective relative to
#: the pose's own (``obj_mirror / obj_own - 1``); chosen on validation photos and
#: mocap (``studies/real_prior/probe_mirror_gate.py``)
MIRROR_TEMPERATURE = 0.05


def mirror_weights(results):
    """Weights (members, n) for :func:`combine` of K members' results followed by
    their mirrored dictionaries' (``recover(mirror="auto")``): per pose, each
    mirror answer's weight falls from 1/2 as its lasso objective exceeds its
    member's (:data:`MIRROR_TEMPERATURE`); never above 1/2 (a lower mirror
    objective gives the plain mean). Rows without a lasso (complete, refused)
    get the mean.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace as R
    >>> w = mirror_weights([R(objective=np.array([1.0, 1.0, np.nan])),
    ...                     R(objective=np.array([1.0, 1.5, np.nan]))])
    >>> np.round(w, 3).tolist()
    [[0.5, 1.0, 0.5], [0.5, 0.0, 0.5]]
    """
    k = len(results) // 2
    own = np.stack([r.objective for r in results[:k]])
    mirror = np.stack([r.objective for r in results[k:]])
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        r = mirror / own - 1
        w = np.minimum(0.5, 1 / (1 + np.exp(np.clip(r / MIRROR_TEMPERATURE, -50, 50))))
    w = np.where(np.isfinite(w), w, 0.5)
    return np.concatenate([1 - w, w]) / k


#: what ``adapt=False`` codes poses one by one over when no dictionary is given: the
#: default's CMU atoms plus COCO's people (``dictionaries/README.md``)
COLD_DICTIONARY = "cmu-coco-k2932"


def cold_prior(dictionary, adapt, mirror, per_pose=True):
    """(dictionary, mirror) a recovery uses when it was given `dictionary` and
    `mirror` (None: unset).

    With ``adapt=False`` (or None, taken as False) and no dictionary, poses coded one by one
    (`per_pose`: the sparse method, no frames) are coded over
    :data:`COLD_DICTIONARY` with ``mirror="auto"`` unless `mirror` says
    otherwise; anywhere else no dictionary is the shipped default
    (``None``, ``cmu-all-k2000``) and no `mirror` is False.

    Examples
    --------
    >>> cold_prior(None, False, None)
    ('cmu-coco-k2932', 'auto')
    >>> cold_prior(None, False, False), cold_prior(None, "auto", None)
    (('cmu-coco-k2932', False), (None, False))
    >>> cold_prior("default", False, None), cold_prior(None, False, None, per_pose=False)
    (('default', False), (None, False))
    """
    cold = dictionary is None and (adapt is False or adapt is None) and per_pose
    if mirror is None:
        mirror = "auto" if cold else False
    return (COLD_DICTIONARY if cold else dictionary), mirror


def _mean_uncertainty(results, unusable):
    """The members' mean radius (None unless every member has one), NaN on
    the rows not usable in every member."""
    if any(r.uncertainty is None for r in results):
        return None
    out = np.mean([r.uncertainty for r in results], axis=0)
    out[unusable] = np.nan
    return out
