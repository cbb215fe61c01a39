"""Recovery: the lasso on the observed sub-dictionary, the Eq. 10 merge, joint placement.

For a pose with occluded joints (Guo & Dai, sec. 3):

1. normalise it and form its EDM vector T under the chosen representation;
2. keep the entries of T that touch no occluded joint, T_sub, and the same
   rows of the dictionary, D_sub;
3. solve ``min_c 0.5 ||T_sub - D_sub c||^2 + alpha_eff ||c||_1``;
4. ``T_re = D c``; the completed vector keeps the observed entries of T and
   takes the occluded ones from T_re (the paper's Eq. 10);
5. beyond the paper: place each occluded joint from its recovered distances
   (:mod:`sparseedm.placement`) and undo the normalisation, so the filled
   poses are in the caller's own pixel frame; observed joints stay exactly as
   given.

Alpha scaling: with ``alpha_scaling="entries"`` (the shipped dictionaries'
choice) ``alpha_eff = alpha * m_obs / m``, where m_obs of the m entries are
observed: the penalty keeps its weight per observed distance, as the data term
shrinks with the entries left. The recommended alpha of a dictionary was chosen
with the same rule on a validation split.

Poses are sorted by missing pattern (at most 469 patterns for up to 3 of 14
joints) and cut into chunks that joblib spreads over CPU cores; each chunk
goes to the solver's ``solve_masked``, which solves every row on its observed
entries (the fast solver in one kernel call from one cached Gram matrix of the
whole dictionary; the others per pattern group).
"""

from __future__ import annotations

import hashlib
import time
from numbers import Integral
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed, parallel_config
from threadpoolctl import threadpool_limits

from ._validation import (ALPHA, BOOLEAN, CHUNK_SIZE, ENSEMBLE, N_JOBS, Interval, Options,
                          check_mask, check_poses, unmask, usable_jobs, validate_params)
from .dictionary import Dictionary, check_gram_memory, check_layout, load_dictionary
from .edm import observed_entries, vector_to_edm
from .exceptions import ParameterError, PoseError, SparseEDMError
from .normalize import MIN_OBSERVED_JOINTS, REPRESENTATIONS, represent
from .placement import WEIGHT_POWER, place_missing_joints
from .skeleton import SKELETON_14
from .solvers import SOLVERS, BaseSolver, get_solver
from .solvers.fast import FastSolver

__all__ = ["recover", "RecoveryResult", "OcclusionRecoverer", "STATUSES"]

#: Per-pose statuses and what they mean.
STATUSES = {
    "recovered": "occluded joints recovered; the lasso optimum is certified by its duality gap",
    "inaccurate": "recovered, but the solver could not certify optimality (gap above tolerance)",
    "complete": "no joint was missing: returned unchanged",
    "solver_failed": "the solver failed on this pose; nothing recovered",
    "too_few_observed": f"fewer than {MIN_OBSERVED_JOINTS} observed joints",
    "invalid_coordinates": "an observed coordinate is infinite, or NaN where the mask says observed",
    "degenerate": "all observed joints coincide: the pose cannot be normalised",
    "out_of_range": "the observed joints' extent overflows float64 or is subnormal: rescale them",
    "empty_code": "the lasso chose no atom (alpha too large for this pose): nothing recovered",
}
_OK = ("recovered", "inaccurate", "complete")


@dataclass
class RecoveryResult:
    """What :func:`recover` returns; every array has the poses' leading axis n.

    Attributes
    ----------
    poses : ndarray (n, N, 2)
        Filled poses in the caller's frame: observed joints exactly as given,
        occluded ones placed from the recovered distances (NaN where the pose
        was refused).
    vectors : ndarray (n, N(N-1)/2)
        Completed EDM vectors after the Eq. 10 merge, in normalised units.
    missing : ndarray of bool (n, N)
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
        """True for poses that came back usable (recovered or complete)."""
        return np.isin(self.status, _OK)

    @property
    def adapted(self) -> bool:
        """True when the poses were recovered with a dictionary adapted to them."""
        return bool(self.adaptation is not None and self.adaptation.adapted)

    def summary(self) -> dict:
        """Counts a person reads at the end of a batch."""
        counts = {s: int((self.status == s).sum()) for s in STATUSES}
        out = {
            "poses": int(len(self.status)),
            "recovered_joints": int(self.missing[np.isin(self.status, ("recovered", "inaccurate"))].sum()),
            "refused": int((~self.ok).sum()),
            "fallbacks": int(self.fallback.sum()),
            "seconds": round(self.seconds, 3),
            "poses_per_second": round(len(self.status) / self.seconds, 1) if self.seconds else None,
            "status": {k: v for k, v in counts.items() if v},
        }
        if self.adaptation is not None:
            out["adaptation"] = self.adaptation.summary()
        if self.members > 1:
            out["ensemble"] = self.members
        return out


def _solve_chunk(solver, components, X, observed, alpha_eff, positive, key, threads=None):
    """One task: the lasso of every row on its observed entries, merged (Eq. 10)."""
    if threads is not None:  # one thread per joblib worker: no oversubscription
        import numba

        numba.set_num_threads(threads)
    res = solver.solve_masked(components.T, X, observed, alpha_eff, positive=positive,
                              key=key)
    # T_re = c D row by row over the few atoms used: a row's answer must not
    # depend on which rows share its chunk (a batched product rounds differently)
    T_re = np.empty_like(X)
    n_active = np.empty(len(X), dtype=int)
    for i, c in enumerate(res.coef):
        nz = np.flatnonzero(c)
        T_re[i] = c[nz] @ components[nz]
        n_active[i] = len(nz)
    merged = np.where(observed, X, T_re)  # Eq. 10
    return merged, res.objective, res.gap, res.status, n_active, res.fallback


#: constraints of recover()'s arguments (see sparseedm._validation)
_PARAMS = {
    "dictionary": [Dictionary, "path", None],
    "alpha": ALPHA + [None],
    "representation": [Options(REPRESENTATIONS)],
    "solver": [Options(SOLVERS), BaseSolver],
    "n_jobs": N_JOBS,
    "chunk_size": CHUNK_SIZE,
    "positive": ["boolean", None],
    "progress": BOOLEAN,
    "backend": [Options(("loky", "threading", "multiprocessing", "dask")), None],
    "scheduler": ["path", None],
    "method": [Options(("sparse", "fconv"))],
    "self_training": [Interval(Integral, 0, None), None],
    "ensemble": ENSEMBLE,
    "temporal": BOOLEAN,
}
#: the smallest extent a pose may have: below it 1/extent overflows or loses bits
_TINY = np.finfo(float).tiny


def check_options_apply(caller, *, method, model, backend, scheduler, adapt, ensemble):
    """Refuse options that would be silently ignored (a ParameterError naming them)."""
    if method == "sparse" and model is not None:
        raise ParameterError(f"{caller}: model is the FConv network of method='fconv'; "
                             "method='sparse' codes with dictionary=")
    if scheduler is not None and backend != "dask":
        raise ParameterError(f"{caller}: scheduler is a Dask address: it needs "
                             "backend='dask' (--backend dask)")
    if ensemble > 1 and (adapt is False or adapt is None):
        raise ParameterError(f"{caller}: ensemble={ensemble} averages adapted "
                             "dictionaries: it needs adaptation (drop adapt=False / "
                             "--no-adapt)")


def _validate(poses, missing, n_joints, caller="recover", model="dictionary"):
    """Poses (n, N, 2) as floats, the missing mask and the rows with a bad
    observed coordinate; whole-input problems raise, naming `caller`/`model`.
    A masked array's masked joints are missing."""
    poses, missing = unmask(poses, missing, caller)
    poses = check_poses(poses, caller)
    if poses.ndim == 2:
        poses = poses[None]
    if poses.ndim != 3 or poses.shape[-1] != 2:
        raise PoseError(f"poses must have shape (n, N, 2), got {np.shape(poses)}")
    if poses.shape[1] != n_joints:
        raise PoseError(
            f"poses have {poses.shape[1]} joints but the {model} is for {n_joints}"
        )
    nan = np.isnan(poses).any(axis=-1)
    if missing is None:
        mask = nan
        bad_coord = np.isinf(poses).any(axis=-1).any(axis=-1)
    else:
        mask = check_mask(missing, caller)
        if mask.ndim == 1:
            mask = mask[None]
        if mask.shape != poses.shape[:2]:
            raise PoseError(f"missing must have shape {poses.shape[:2]}, got {mask.shape}")
        bad_coord = ((~np.isfinite(poses)).any(axis=-1) & ~mask).any(axis=-1)
    return poses, mask, bad_coord


def screen_poses(poses, mask, bad_coord):
    """Why each pose cannot be used, before any solving: shared by every path.

    Returns ``(status, reason, n_obs, clean)``: `status` is ``""`` for a usable
    pose and a refusal of :data:`STATUSES` otherwise (``invalid_coordinates``,
    ``too_few_observed``, ``degenerate``, ``out_of_range``); `clean` is the poses
    with missing joints at 0. Used by :func:`recover`, the FConv path and
    :func:`sparseedm.lift`.
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
    return status, reason, n_obs, clean


def _screen(poses, mask, bad_coord, representation):
    """Statuses of every pose, and the usable ones' vectors under `representation`.

    Shared by the sparse path and the FConv path (:mod:`sparseedm.fconv`).
    """
    n, N = mask.shape
    status, reason, n_obs, clean = screen_poses(poses, mask, bad_coord)
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
        T, c, s = represent(clean[usable], mask[usable], representation)
        vectors[usable], center[usable], scale[usable] = T, c, s
        filled[complete] = poses[complete]
    return status, reason, n_obs, clean, vectors, center, scale, filled


def _place(poses, clean, mask, vectors, center, scale, status, reason, filled, certified=None,
           weight_power=WEIGHT_POWER):
    """Place the occluded joints of recovered poses into `filled`, batched by count.

    `weight_power`: the placement's residual weights (chosen on the sparse
    method's answers; the FConv path keeps unweighted placement).

    No row stays recovered unless what it returns (its joints, its distances
    and, where given, ``certified``: a finite objective and gap) is finite:
    such rows become ``solver_failed``.
    """
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


def recover(poses, missing=None, *, dictionary=None, alpha=None,
            representation="average", solver="fast", n_jobs=1, chunk_size=2048,
            positive=None, progress=False, backend=None, scheduler=None,
            method="sparse", model=None, adapt="auto", self_training=None, ensemble=1,
            tracks=None, frames=None, temporal=True):
    """Recover the occluded joints of 2D poses.

    Parameters
    ----------
    poses : array_like, shape (n, N, 2) or (N, 2)
        Keypoints in the caller's own pixel frame.
    missing : array_like of bool, shape (n, N), optional
        True where a joint is occluded; by default NaN coordinates mark them.
    dictionary : Dictionary, str or path, optional
        None means the shipped default.
    alpha : float, optional
        Lasso penalty; default the dictionary's recommended ``alpha_recover``.
        Scaled per pose by the dictionary's ``alpha_scaling`` rule.
    representation : {"average", "zero"}
    solver : {"fast", "clarabel", "cvxpy-naive"} or a BaseSolver
        "fast" (default) is the certified LARS path, which hands any pose it
        cannot certify to Clarabel; "clarabel" is cvxpy + Clarabel throughout.
    n_jobs : int, default 1
        joblib workers over chunks of poses; -1 for all cores.
    chunk_size : int, default 2048
        Poses per task.
    positive : bool, optional
        Non-negative codes; default the dictionary's ``positive_code``.
    progress : bool, default False
        Show a progress bar over chunks.
    backend : {None, "loky", "threading", "dask"}, optional
        joblib backend for the chunks when ``n_jobs != 1``; None means
        threads for the "fast" solver (its compiled kernels release the GIL)
        and loky processes for the others. ``"dask"`` sends the chunks to a Dask
        cluster (``pip install sparseedm[dask]``), all its workers being used.
    scheduler : str, optional
        With ``backend="dask"``: the scheduler address (``tcp://host:8786``);
        None uses the Dask client already created in this process.
    method : {"sparse", "fconv"}, default "sparse"
        "fconv" completes the EDM with a trained FConv network instead
        (:mod:`sparseedm.fconv`, needs ``sparseedm[torch]``); the dictionary,
        alpha, solver, n_jobs, backend and positive arguments are then unused.
    model : FConvModel, str or path, optional
        The network for ``method="fconv"`` (``sparseedm fit-cnn``); its
        representation must be `representation`.
    adapt : "auto", False or array_like (n_adapt, N, 2)
        (sparse method only)
        ``"auto"`` (default): when the poses hold at least
        :data:`sparseedm.adaptation.MIN_COMPLETE_POSES` complete plausible
        poses, the dictionary is first adapted on them (guarded: kept only if
        better on a held-back slice, see :mod:`sparseedm.adaptation`).
        ``False``: recover with the dictionary as given. An array: adapt on
        those (complete) poses instead, e.g. other files of the same source.
        ``res.adaptation`` says what was done.
    self_training : int, optional
        After an adopted adaptation, this many rounds of transductive
        self-training on the incomplete poses (recover a seeded sample of
        them, adapt again on the complete plus the filled poses, guarded each
        round: :func:`sparseedm.adaptation.self_train`); default
        :data:`sparseedm.adaptation.SELF_TRAINING_ROUNDS`, 0 turns it off.
    ensemble : int, default 1
        (with adaptation) Adapt this many times (seeds 0, 1, ...), recover
        with each adapted dictionary and return the mean of the filled poses
        and EDM vectors (:mod:`sparseedm.ensemble`): lower error, K times the
        work. Stays at one member when the adaptation is not adopted.
    tracks : array_like (n,), optional
        With `frames`: the person of each pose (any values); None means all
        poses are one person.
    frames : array_like of int (n,), optional
        Frame number of each pose: turns on temporal recovery
        (:mod:`sparseedm.temporal`), which fills each track's occluded joints
        from the frames around them and the per-frame answer. Any order;
        skipped numbers are frames where the person was not seen.
    temporal : bool, default True
        False ignores `tracks` and `frames`: every pose on its own, exactly as
        without them.

    Returns
    -------
    RecoveryResult
        A :class:`~sparseedm.temporal.recover.TemporalResult` (per-joint
        ``source``) when `frames` turned temporal recovery on.

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> pose[4] = np.nan                      # right wrist occluded
    >>> res = sparseedm.recover(pose)
    >>> res.status.tolist()
    ['recovered']
    >>> bool(np.isfinite(res.poses).all()), bool((res.poses[0, :4] == pose[:4]).all())
    (True, True)
    """
    validate_params("recover", dict(
        dictionary=dictionary, alpha=alpha, representation=representation, solver=solver,
        n_jobs=n_jobs, chunk_size=chunk_size, positive=positive, progress=progress,
        backend=backend, scheduler=scheduler, method=method, self_training=self_training,
        ensemble=ensemble, temporal=temporal), _PARAMS)
    check_options_apply("recover", method=method, model=model, backend=backend,
                        scheduler=scheduler, adapt=adapt, ensemble=ensemble)
    if frames is not None and temporal:
        return _recover_in_time(poses, missing, tracks, frames, method, dict(
            dictionary=dictionary, alpha=alpha, representation=representation, solver=solver,
            n_jobs=n_jobs, chunk_size=chunk_size, positive=positive, progress=progress,
            backend=backend, scheduler=scheduler, adapt=adapt, self_training=self_training,
            ensemble=ensemble))
    if method == "fconv":  # torch is imported only on this path
        from .fconv.recover import recover_fconv

        if ensemble > 1:
            raise SparseEDMError("ensemble averages adapted dictionaries: it needs "
                                 "method='sparse'")

        return recover_fconv(poses, missing, model=model, representation=representation,
                             chunk_size=chunk_size, progress=progress)
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    check_gram_memory(dictionary)
    adaptations, members = [], [dictionary]
    if adapt is not False:
        from .ensemble import adapt_members

        if not isinstance(dictionary, Dictionary):
            dictionary = load_dictionary(dictionary)
        poses, missing, _ = _validate(poses, missing, dictionary.n_joints)
        # one member unless an ensemble was asked for (seed 0 is the default's)
        members, adaptations = adapt_members(dictionary, poses, missing, adapt, ensemble,
                                             n_jobs=n_jobs, self_training=self_training)
    return _recover_members(poses, missing, members, adaptations, alpha=alpha,
                           representation=representation, solver=solver, n_jobs=n_jobs,
                           chunk_size=chunk_size, positive=positive, progress=progress,
                           backend=backend, scheduler=scheduler)


def _recover_in_time(poses, missing, tracks, frames, method, kwargs):
    """recover(frames=...): the temporal model (:mod:`sparseedm.temporal`)."""
    from .temporal.recover import recover_temporal

    if method != "sparse":
        raise SparseEDMError("temporal recovery uses the sparse method: pass "
                             "method='sparse', or temporal=False")
    return recover_temporal(poses, missing, tracks=tracks, frames=frames, **kwargs)


def _recover_members(poses, missing, members, adaptations, **kwargs):
    """The poses recovered with each of `members` (dictionaries), combined
    (:func:`sparseedm.ensemble.combine`: one member's result as it is), with
    what `adaptations` (:func:`sparseedm.ensemble.adapt_members`'s, or empty)
    did and took; `kwargs` as :func:`recover`'s recovery settings."""
    from .ensemble import combine

    # the work is many small BLAS calls beside numba's threads: BLAS threads
    # would only spin against them (measured 2x slower), so BLAS gets one.
    with threadpool_limits(1, user_api="blas"):
        res = combine([_recover(poses, missing, dictionary=d, **kwargs) for d in members])
    if adaptations:
        res.adaptation = adaptations[0]
        res.seconds += sum(a.seconds for a in adaptations)
    return res


def _recover(poses, missing=None, *, dictionary=None, alpha=None,
             representation="average", solver="fast", n_jobs=1, chunk_size=2048,
             positive=None, progress=False, backend=None, scheduler=None):
    t0 = time.perf_counter()
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    if dictionary.n_joints == SKELETON_14.num_joints:  # 14-joint poses come in SKELETON_14 order
        check_layout(dictionary)
    alpha = dictionary.alpha_recover if alpha is None else alpha
    positive = dictionary.positive_code if positive is None else bool(positive)
    solver = get_solver(solver)
    N = dictionary.n_joints
    poses, mask, bad_coord = _validate(poses, missing, N)
    n = len(poses)
    m = dictionary.n_features
    components = dictionary.components
    status, reason, n_obs, clean, vectors, center, scale, filled = _screen(
        poses, mask, bad_coord, representation)
    objective = np.full(n, np.nan)
    gap = np.full(n, np.nan)
    n_active = np.zeros(n, dtype=int)
    fallback = np.zeros(n, dtype=bool)

    todo = np.flatnonzero(status == "recovered")
    dict_key = hashlib.sha1(np.ascontiguousarray(components).tobytes()).hexdigest()
    # rows sorted by missing pattern (a backend that works per pattern sees
    # whole groups), cut into chunks; each row is solved on its observed entries
    order = np.lexsort(mask[todo].T[::-1])
    todo = todo[order]
    observed = observed_entries(mask[todo])
    m_obs = observed.sum(axis=1)
    alpha_eff = alpha * (m_obs / m if dictionary.alpha_scaling == "entries"
                         else np.ones(len(m_obs)))
    tasks = _chunk_tasks(np.arange(len(todo)), chunk_size, n_jobs, backend)
    results = _run_tasks(solver, components, vectors[todo], observed, alpha_eff, tasks,
                         positive, dict_key, n_jobs, progress, backend, scheduler)
    for t, (merged, obj, g, st, act, fb) in zip(tasks, results):
        chunk = todo[t]
        vectors[chunk] = merged
        objective[chunk], gap[chunk], n_active[chunk], fallback[chunk] = obj, g, act, fb
        status[chunk] = np.where(st == "optimal", "recovered",
                                 np.where(st == "failed", "solver_failed", "inaccurate"))
    empty = np.zeros(n, dtype=bool)
    empty[todo] = n_active[todo] == 0
    empty &= np.isin(status, ("recovered", "inaccurate"))
    status[empty] = "empty_code"  # every distance would come back 0: not an answer
    reason[empty] = (f"the lasso chose no atom at alpha {alpha:g}: lower alpha (the "
                     f"dictionary recommends {dictionary.alpha_recover:g})")
    failed = (status == "solver_failed") | empty
    reason[status == "solver_failed"] = "solver status not optimal"
    vectors[failed] = np.nan
    reason[status == "inaccurate"] = "duality gap above tolerance"

    _place(poses, clean, mask, vectors, center, scale, status, reason, filled,
           certified=np.isfinite(objective) & np.isfinite(gap))
    return RecoveryResult(
        poses=filled, vectors=vectors, missing=mask, center=center, scale=scale,
        objective=objective, gap=gap, n_active=n_active,
        status=status.astype(str), reason=reason.astype(str), fallback=fallback,
        alpha=float(alpha), seconds=time.perf_counter() - t0, dictionary=dictionary,
    )


def _chunk_tasks(rows, chunk_size, n_jobs, backend=None):
    """`rows` cut into consecutive tasks: at most `chunk_size` each, and enough
    of them to keep every worker busy (:func:`_min_tasks`); none when `rows` is
    empty. Shared by recover() and the dictionary lifter."""
    n, chunk_size = len(rows), int(chunk_size)  # np.uint64(7): -n // it overflows
    n_tasks = max(-(-n // chunk_size), _min_tasks(n_jobs, backend, n))
    return [t for t in np.array_split(rows, max(1, min(n_tasks, n))) if len(t)]


def _min_tasks(n_jobs, backend, n_rows):
    """Tasks enough to keep every worker busy (1 when the work runs in-process).

    Never so many that a task falls under the fast solver's compiled-kernel
    size (:data:`sparseedm.solvers.fast.NUMPY_MAX` rows): smaller batches take
    its numpy path, which is meant for a handful of poses and ran 2 jobs on
    300 poses at 42 poses/s against 600 for one job.
    """
    if n_jobs in (None, 1) and backend is None:
        return 1
    from joblib import effective_n_jobs

    from .solvers.fast import NUMPY_MAX

    return max(min(4 * max(effective_n_jobs(n_jobs), 1), n_rows // NUMPY_MAX), 1)


def _run_tasks(solver, components, X, observed, alpha_eff, tasks, positive, key, n_jobs,
               progress, backend=None, scheduler=None):
    if not tasks:
        return []
    from tqdm.auto import tqdm

    distributed = backend == "dask"
    if not distributed and n_jobs is not None:
        n_jobs = usable_jobs(n_jobs, len(tasks))  # --jobs 100000 runs what can run
    threads = None if (n_jobs in (None, 1) and not distributed) else 1
    calls = (
        delayed(_solve_chunk)(solver, components, X[t], observed[t], alpha_eff[t], positive,
                              key, threads)
        for t in tasks
    )
    bar = dict(total=len(tasks), disable=not progress, unit="chunk", desc="recover")
    if distributed:
        with _dask_client(scheduler):
            with parallel_config(backend="dask"):
                return list(tqdm(Parallel(n_jobs=-1, return_as="generator")(calls), **bar))
    if n_jobs in (None, 1) and backend is None:
        return [f(*args, **kw) for f, args, kw in tqdm(calls, **bar)]
    if backend is None and isinstance(solver, FastSolver):
        # its kernels release the GIL: threads share one Gram cache and skip
        # process start-up (measured 1.2x the throughput of loky processes)
        backend = "threading"
    parallel = Parallel(n_jobs=n_jobs, return_as="generator", backend=backend)
    return list(tqdm(parallel(calls), **bar))


class _dask_client:
    """Connect to `scheduler` (closed afterwards), or use this process's client."""

    def __init__(self, scheduler):
        self.scheduler = scheduler
        self.client = None

    def __enter__(self):
        try:
            from distributed import Client, get_client
        except ImportError:
            raise SparseEDMError(
                "backend='dask' needs dask.distributed: pip install 'sparseedm[dask]'"
            ) from None
        if self.scheduler:
            try:
                self.client = Client(self.scheduler, timeout="10s")
            except OSError as exc:
                raise SparseEDMError(
                    f"cannot reach the Dask scheduler at {self.scheduler}: {exc}"
                ) from None
        else:
            try:
                get_client()
            except ValueError:
                raise SparseEDMError(
                    "backend='dask' needs a scheduler address or a Client created "
                    "in this process"
                ) from None
        return self

    def __exit__(self, *exc):
        if self.client is not None:
            self.client.close()


class OcclusionRecoverer:
    """scikit-learn-style shell around :func:`recover`.

    ``__init__`` only stores the arguments; :meth:`fit` loads the dictionary
    (``dictionary_``); :meth:`transform` returns filled poses and keeps the
    last :class:`RecoveryResult` in ``result_``.

    Examples
    --------
    >>> import numpy as np
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)[None]
    >>> pose[0, 12] = np.nan                   # left knee occluded
    >>> filled = OcclusionRecoverer().fit().transform(pose)
    >>> filled.shape, bool(np.isfinite(filled).all())
    ((1, 14, 2), True)
    """

    def __init__(self, dictionary=None, *, alpha=None, representation="average",
                 solver="fast", n_jobs=1, adapt="auto"):
        self.dictionary = dictionary
        self.alpha = alpha
        self.adapt = adapt
        self.representation = representation
        self.solver = solver
        self.n_jobs = n_jobs

    def fit(self, X=None, y=None):
        """Load the dictionary (nothing is learned from X)."""
        validate_params("OcclusionRecoverer", dict(
            dictionary=self.dictionary, alpha=self.alpha, representation=self.representation,
            solver=self.solver, n_jobs=self.n_jobs),
            {k: _PARAMS[k] for k in ("dictionary", "alpha", "representation", "solver",
                                     "n_jobs")})
        d = self.dictionary
        self.dictionary_ = d if isinstance(d, Dictionary) else load_dictionary(d)
        return self

    def transform(self, X, missing=None):
        """Filled poses (n, N, 2); NaN coordinates (or `missing`) mark occlusions."""
        if not hasattr(self, "dictionary_"):
            self.fit()
        self.result_ = recover(X, missing, dictionary=self.dictionary_, alpha=self.alpha,
                               representation=self.representation, solver=self.solver,
                               n_jobs=self.n_jobs, adapt=self.adapt)
        return self.result_.poses
