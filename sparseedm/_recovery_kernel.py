"""The sparse recovery kernel: the lasso on each pose's observed entries, merged (Eq. 10).

:func:`recover_sparse` runs one dictionary over a batch of poses (screening
and placement from :mod:`sparseedm._recovery_base`; rows sorted by missing
pattern, chunked over joblib workers by :mod:`sparseedm._parallel`);
:func:`recover_members` runs it once per dictionary of an ensemble and
combines the answers. Below adaptation (whose guard and self-training call
it) and below the :func:`sparseedm.recover` dispatcher.
"""

from __future__ import annotations

import time
from numbers import Integral

import numpy as np
from joblib import Parallel, delayed, parallel_config
from threadpoolctl import threadpool_limits

from ._coding import atoms_key, pattern_order
from ._parallel import chunk_tasks, dask_client, worker_threads
from ._recovery_base import (RecoveryResult, bad_coordinates, combine, mirror_weights,
                             place_occluded_inplace, screen, screen_poses, validate_poses)
from ._validation import (ALPHA, BOOLEAN, CHUNK_SIZE, ENSEMBLE, N_JOBS, Interval, Options,
                          usable_jobs)
from .dictionary import Dictionary, check_layout, load_dictionary
from .edm import observed_entries
from .normalize import REPRESENTATIONS
from .skeleton import SKELETON_14
from .solvers import SOLVERS, BaseSolver, get_solver
from .solvers.fast import FastSolver
from .solvers.local_ridge import LocalRidgeSolver

__all__ = ["recover_sparse", "recover_members", "solve_chunk", "compiled_solver",
           "preset_solver", "RECOVER_PARAMS", "PRESETS", "FAST_RIDGE", "FAST_MAX_ATOMS"]

#: recover()'s presets: "default" (adaptation and self-training) and "fast"
#: (the file's complete poses as the atoms, nothing learned: sparseedm.file_atoms)
PRESETS = ("default", "fast")

#: constraints of recover()'s arguments (see sparseedm._validation)
RECOVER_PARAMS = {
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
    "preset": [Options(PRESETS)],
}

#: ``recover(preset="fast")``'s coder: K atoms per pose, the relative ridge
#: weight, the penalty's power and the first pass's atoms of
#: :class:`~sparseedm.solvers.local_ridge.LocalRidgeSolver`, and the most
#: complete poses that become atoms (None: every one), chosen on CMU validation
#: files (``studies/fast/select_fast.py --local``)
FAST_RIDGE = {"n_atoms": 48, "lam": 3e-4, "power": 3.0, "first_atoms": 16}
FAST_MAX_ATOMS = None


def solve_chunk(solver, components, X, observed, alpha_eff, positive, key, threads=None):
    """One task: the lasso of every row on its observed entries, merged (Eq. 10).

    Parameters
    ----------
    solver : BaseSolver
        The lasso backend (:func:`sparseedm.solvers.get_solver`).
    components : ndarray (K, m)
        The dictionary's atoms, one per row.
    X : ndarray (n, m)
        The chunk's normalised EDM vectors (read at the observed entries).
    observed : ndarray of bool (n, m)
        Each row's observed EDM entries.
    alpha_eff : ndarray (n,)
        Each row's lasso penalty, already scaled.
    positive : bool
        Non-negative codes.
    key : object
        The dictionary's cache key (:func:`sparseedm._coding.atoms_key`).
    threads : int, optional
        Numba threads for this task (1 inside a joblib worker); None: unchanged.

    Returns
    -------
    merged : ndarray (n, m)
        The observed entries as given, the others from the code (Eq. 10).
    objective : ndarray (n,)
        Each row's lasso objective.
    gap : ndarray (n,)
        Each row's duality gap.
    status : ndarray of str (n,)
        The solver's status per row (``"optimal"``, ``"failed"``, ...).
    n_active : ndarray of int (n,)
        Non-zero atoms in each row's code.
    fallback : ndarray of bool (n,)
        Rows the fast solver handed to Clarabel.
    """
    if threads is not None:  # one thread per joblib worker: no oversubscription
        import numba

        numba.set_num_threads(threads)
    res = solver.solve_masked(components.T, X, observed, alpha_eff, positive=positive,
                              key=key)
    T_re, n_active = _reconstruct(res, components)
    merged = np.where(observed, X, T_re)  # Eq. 10
    return merged, res.objective, res.gap, res.status, n_active, res.fallback


def _reconstruct(res, components):
    """T_re = c D row by row over the few atoms used, and their number: a row's
    answer must not depend on which rows share its chunk (a batched product
    rounds differently). Rows whose support the solver gives are gathered
    there (no scan of a wide `coef`), one small product per row."""
    coef = res.coef
    T_re = np.empty((len(coef), components.shape[1]))
    n_active = np.empty(len(coef), dtype=int)
    scan = np.ones(len(coef), bool) if res.support is None else res.fallback
    known = np.flatnonzero(~scan)
    for start in range(0, len(known), 256):  # blocks: the gathered atoms stay in cache
        rows = known[start:start + 256]
        cols = np.sort(res.support[rows], axis=1)
        c = coef[rows[:, None], cols]
        T_re[rows] = np.matmul(c[:, None, :], components[cols])[:, 0]
        n_active[rows] = np.count_nonzero(c, axis=1)
    for i in np.flatnonzero(scan):
        nz = np.flatnonzero(coef[i])
        T_re[i] = coef[i, nz] @ components[nz]
        n_active[i] = len(nz)
    return T_re, n_active


def compiled_solver(solver="fast", adaptations=None):
    """`solver` for a call that compiles numba anyway: the fast backend with
    its compiled kernel at any batch size (``FastSolver(numpy_max=0)``) when
    `solver` is ``"fast"`` and the call adapts, else `solver` as given.

    `adaptations`: what the call's adaptations did (it adapts when one of
    them learned a candidate: the learning is compiled); None: the caller is
    the adaptation itself (its guard, its self-training rounds).

    Small batches otherwise take the numpy homotopy so that they never wait
    for a compilation; in a call that adapts the wait is paid already, and the
    compiled kernel is 2.5-4x faster per row (one clip of another lab's video
    with defaults: 53 -> 87 frames/s, answers within 2e-8 px).

    Parameters
    ----------
    solver : str or BaseSolver, default "fast"
        The solver the caller asked for.
    adaptations : sequence of AdaptationResult, optional
        What the call's adaptations did; None: the caller is the adaptation.

    Returns
    -------
    str or BaseSolver
        ``FastSolver(numpy_max=0)`` or `solver` unchanged.

    Examples
    --------
    >>> compiled_solver("fast").numpy_max, compiled_solver("clarabel")
    (0, 'clarabel')
    >>> compiled_solver("fast", adaptations=[])
    'fast'
    """
    learned = adaptations is None or any(getattr(a, "candidate", None) is not None
                                         for a in adaptations)
    if isinstance(solver, str) and solver == "fast" and learned:
        return FastSolver(numpy_max=0)
    return solver


def preset_solver(solver="fast", preset="default", adaptation=None, positive=None):
    """The backend `preset` codes with: ``"fast"`` codes each pose by a local ridge
    over its most correlated atoms (:class:`~sparseedm.solvers.local_ridge.LocalRidgeSolver`
    with :data:`FAST_RIDGE`: not the lasso) when the file's own complete poses are
    the only atoms (`adaptation`, what :func:`~sparseedm.file_atoms.resolve_fast`
    did); with fewer complete poses than a dictionary of their own needs they
    join the base dictionary's learned atoms, where the local ridge is worse
    than the lasso (MPII validation photos, 50-240 complete poses: 9.7-10.8 %
    of the body's size against 7.9-8.9), and `solver` codes as given, as does
    any other preset or solver. The local ridge's codes are signed: when the
    codes must be non-negative (`positive`, or the dictionary's
    ``positive_code``) the preset codes by the lasso on working sets, as the
    defaults do over the file's own poses.

    Parameters
    ----------
    solver : str or BaseSolver, default "fast"
        The solver the caller asked for.
    preset : {"default", "fast"}, default "default"
    adaptation : AdaptationResult, optional
        What the preset did with the file's poses; None: nothing.
    positive : bool, optional
        Non-negative codes asked for; None: the adapted dictionary's
        ``positive_code``.

    With the default preset and the file's own poses as the only atoms (the
    default path's exemplar rule, :mod:`sparseedm.exemplars`), the lasso runs
    on working sets of atoms checked on all of them
    (``FastSolver(working_set=True)``): the same lasso and certificate,
    fewer atoms touched per pose. (``FastSolver()`` itself codes on working
    sets from :data:`~sparseedm.solvers.fast.WS_MIN_ATOMS` atoms, as
    ``adapt=False``'s prior of 2,932 atoms and its mirror image.)

    Returns
    -------
    str or BaseSolver

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> from sparseedm.file_atoms import resolve_fast
    >>> poses = np.random.default_rng(0).normal(size=(300, 14, 2))
    >>> _, own = resolve_fast(load_dictionary(), poses, None, "auto")
    >>> fast = preset_solver("fast", "fast", own)
    >>> fast.name, fast.n_atoms == FAST_RIDGE["n_atoms"], preset_solver("fast")
    ('local-ridge', True, 'fast')
    >>> _, few = resolve_fast(load_dictionary(), poses[:40], None, "auto")
    >>> preset_solver("fast", "fast", few), preset_solver("clarabel")
    ('fast', 'clarabel')
    >>> preset_solver("fast", "default", own).working_set
    True
    >>> preset_solver("fast", "fast", own, positive=True).working_set  # signed ridge: the lasso
    True
    """
    if not (isinstance(solver, str) and solver == "fast"):
        return solver
    if adaptation is None or not (adaptation.file_atoms > 0
            and adaptation.file_atoms == adaptation.dictionary.n_components):
        return solver
    if positive is None:
        positive = adaptation.dictionary.positive_code
    if preset == "fast" and not positive:
        return LocalRidgeSolver(**FAST_RIDGE)
    # the defaults over the file's own poses (or the preset's with non-negative
    # codes): the same lasso on working sets of atoms, checked on all of them
    # (the same answers, fewer atoms touched)
    return FastSolver(working_set=True, numpy_max=0)


def recover_members(poses, missing, members, adaptations, mirror_gate=False, screening=None,
                    **kwargs):
    """The poses recovered with each of `members` (dictionaries), combined
    (:func:`~sparseedm._recovery_base.combine`: one member's result as it is), with
    what `adaptations` (:func:`sparseedm.ensemble.adapt_members`'s, or empty)
    did and took; `kwargs` as :func:`recover`'s recovery settings (the fast
    solver on its compiled kernel when an adaptation learned:
    :func:`compiled_solver`).

    Parameters
    ----------
    poses : array_like (n, N, 2)
        The poses, NaN (or `missing`) at the occluded joints.
    missing : array_like of bool (n, N) or None
        The occluded joints; None: the NaN ones.
    members : sequence of Dictionary
        The dictionaries (one unless an ensemble).
    adaptations : sequence of AdaptationResult
        What adapting each member did (empty: no adaptation).
    mirror_gate : bool, default False
        `members` are K dictionaries followed by their mirrored ones: weigh
        each pose's answers by :func:`~sparseedm._recovery_base.mirror_weights`
        (``recover(mirror="auto")``) instead of the plain mean.
    screening : Screening, optional
        With ``check_input=False``: the poses' screening, when the caller has
        it (:func:`recover_sparse`'s); else, trusted poses are screened here
        once for every member.
    **kwargs
        The recovery settings of :func:`recover_sparse` (alpha, solver, n_jobs...).

    Returns
    -------
    RecoveryResult
        The combined result, with the first adaptation and every adaptation's
        time.
    """
    kwargs["solver"] = compiled_solver(kwargs.get("solver", "fast"), adaptations)
    if not kwargs.get("check_input", True) and screening is None:
        screening = screen_poses(poses, missing, bad_coordinates(poses, missing))
    # the work is many small BLAS calls beside numba's threads: BLAS threads
    # would only spin against them (measured 2x slower), so BLAS gets one.
    with threadpool_limits(1, user_api="blas"):
        results = [recover_sparse(poses, missing, dictionary=d, screening=screening, **kwargs)
                   for d in members]
        res = combine(results, mirror_weights(results) if mirror_gate else None)
    if adaptations:
        res.adaptation = adaptations[0]
        res.seconds += sum(a.seconds for a in adaptations)
    return res


def recover_sparse(poses, missing=None, *, dictionary=None, alpha=None,
             representation="average", solver="fast", n_jobs=1, chunk_size=2048,
             positive=None, progress=False, backend=None, scheduler=None, check_input=True,
             screening=None):
    """One dictionary's sparse recovery of a batch of poses.

    The kernel of :func:`sparseedm.recover`, its arguments already validated.

    Each pose is screened and normalised, its lasso solved on the observed EDM
    entries (rows sorted by missing pattern, chunked over workers), the code's
    entries merged into the unobserved ones (Eq. 10) and the occluded joints
    placed from the completed distances.

    Parameters
    ----------
    poses : array_like (n, N, 2)
        Keypoints in the caller's own frame.
    missing : array_like of bool (n, N), optional
        The occluded joints; default the NaN ones.
    dictionary : Dictionary, str or path, optional
        The dictionary; None: the shipped default.
    alpha : float, optional
        Lasso penalty; default the dictionary's ``alpha_recover``.
    representation : {"average", "zero"}, default "average"
        How occluded joints enter the EDM vector.
    solver : str or BaseSolver, default "fast"
        The lasso backend.
    n_jobs : int, default 1
        joblib workers over chunks; -1 for all cores.
    chunk_size : int, default 2048
        Poses per task.
    positive : bool, optional
        Non-negative codes; default the dictionary's ``positive_code``.
    progress : bool, default False
        Show a progress bar over chunks.
    backend : {None, "loky", "threading", "multiprocessing", "dask"}, optional
        joblib backend when ``n_jobs != 1``; None: threads for the fast solver,
        loky processes for the others.
    scheduler : str, optional
        With ``backend="dask"``: the scheduler's address; None: the client
        already created in this process.
    check_input : bool, default True
        Validate `poses` and `missing` (:func:`validate_poses`). False: the
        caller did (poses a float array (n, N, 2), `missing` a bool array
        (n, N)), as scikit-learn's ``check_input=False``.
    screening : Screening, optional
        With ``check_input=False``: the poses'
        :func:`~sparseedm._recovery_base.screen_poses`, when the caller has it
        (trusted: the poses are not screened again).

    Returns
    -------
    RecoveryResult
        The filled poses, completed EDM vectors and each pose's status.
    """
    t0 = time.perf_counter()
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    if dictionary.n_joints == SKELETON_14.num_joints:  # 14-joint poses come in SKELETON_14 order
        check_layout(dictionary)
    alpha = dictionary.alpha_recover if alpha is None else alpha
    positive = dictionary.positive_code if positive is None else bool(positive)
    solver = get_solver(solver)
    N = dictionary.n_joints
    if check_input:
        poses, mask, bad_coord = validate_poses(poses, missing, N)
        screening = None
    else:  # trusted: screened by the caller, or here
        mask = missing
        bad_coord = bad_coordinates(poses, missing) if screening is None else None
    n = len(poses)
    m = dictionary.n_features
    components = dictionary.components
    screened = screen(poses, mask, bad_coord, representation, dictionary.recovery_scale,
                      screening)
    status, reason, n_obs, clean, vectors, center, scale, filled = screened
    objective = np.full(n, np.nan)
    gap = np.full(n, np.nan)
    n_active = np.zeros(n, dtype=int)
    fallback = np.zeros(n, dtype=bool)

    todo = np.flatnonzero(status == "recovered")
    dict_key = atoms_key(components)
    # rows sorted by missing pattern (a backend that works per pattern sees
    # whole groups), cut into chunks; each row is solved on its observed entries
    order = pattern_order(mask[todo])
    todo = todo[order]
    observed = observed_entries(mask[todo])
    m_obs = observed.sum(axis=1)
    alpha_eff = alpha * (m_obs / m if dictionary.alpha_scaling == "entries"
                         else np.ones(len(m_obs)))
    # the fast solver's kernels run on numba's threads in-process: tasks only
    # when each worker gets a few large ones (the rows are the same either way)
    tasks = chunk_tasks(np.arange(len(todo)), chunk_size, n_jobs, backend,
                        shared=backend is None and isinstance(solver, FastSolver))
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

    place_occluded_inplace(poses, mask, screened,
                           certified=np.isfinite(objective) & np.isfinite(gap))
    return RecoveryResult(
        poses=filled, vectors=vectors, missing=mask, center=center, scale=scale,
        objective=objective, gap=gap, n_active=n_active,
        status=status.astype(str), reason=reason.astype(str), fallback=fallback,
        alpha=float(alpha), seconds=time.perf_counter() - t0, dictionary=dictionary,
    )


def _run_tasks(solver, components, X, observed, alpha_eff, tasks, positive, key, n_jobs,
               progress, backend=None, scheduler=None):
    if not tasks:
        return []
    from tqdm.auto import tqdm

    distributed = backend == "dask"
    if not distributed and n_jobs is not None:
        n_jobs = usable_jobs(n_jobs, len(tasks))  # --jobs 100000 runs what can run
    if backend is None and isinstance(solver, (FastSolver, LocalRidgeSolver)):
        # its kernels release the GIL: threads share one Gram cache and skip
        # process start-up (measured 1.2x the throughput of loky processes)
        backend = "threading"
    threads = (None if (n_jobs in (None, 1) and not distributed) else
               worker_threads(usable_jobs(n_jobs), "dask" if distributed else backend or "loky"))
    calls = (
        delayed(solve_chunk)(solver, components, X[t], observed[t], alpha_eff[t], positive,
                              key, threads)
        for t in tasks
    )
    bar = dict(total=len(tasks), disable=not progress, unit="chunk", desc="recover")
    if distributed:
        with dask_client(scheduler):
            with parallel_config(backend="dask"):
                return list(tqdm(Parallel(n_jobs=-1, return_as="generator")(calls), **bar))
    if n_jobs in (None, 1) and backend in (None, "threading"):
        return [f(*args, **kw) for f, args, kw in tqdm(calls, **bar)]
    parallel = Parallel(n_jobs=n_jobs, return_as="generator", backend=backend)
    return list(tqdm(parallel(calls), **bar))
