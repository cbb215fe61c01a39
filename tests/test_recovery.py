"""recover(): agreement with an independent solve, exactness, the Eq. 10 merge,
per-pose statuses, and accuracy on real CMU poses (small learned dictionary)."""

import importlib.util
import warnings

import numpy as np
import pytest

import sparseedm
from sparseedm import recovery
from sparseedm.edm import observed_entries
from sparseedm.exceptions import PoseError, SparseEDMError
from sparseedm.metrics import joint_error, random_occlusion
from sparseedm.normalize import represent
from sparseedm.solvers import get_solver
from sparseedm.solvers.base import FAILED, BaseSolver
from sparseedm.solvers.fast import FastSolver

N_AGREE = 200      # poses checked by certificate (and by the Clarabel backend)
N_NAIVE = 24       # poses also solved by a naive per-pose cvxpy problem
M = 91
ALPHA_TINY = 1e-8  # small enough for 1e-6 exactness, large enough to certify


@pytest.fixture(scope="module")
def mix(cmu_poses):
    """All fixture poses with the paper's seeded Mix occlusion (1-3 joints)."""
    missing = random_occlusion(len(cmu_poses), 14, "mix", random_state=7)
    return cmu_poses, missing


@pytest.fixture(scope="module")
def mix_result(mix, small_dictionary):
    poses, missing = mix
    return sparseedm.recover(poses, missing, dictionary=small_dictionary)


def _sub_problem(dictionary, T, mask, alpha):
    """The lasso recovery.py solves: D_sub, x_sub and alpha_eff (entries scaling)."""
    idx = np.flatnonzero(observed_entries(mask))
    D_sub = dictionary.components[:, idx].T
    return D_sub, T[idx], alpha * len(idx) / M


def _objective(D, x, c, alpha):
    return 0.5 * np.sum((x - D @ c) ** 2) + alpha * np.abs(c).sum()


# ---------------------------------------------------------------- agreement


def test_fast_objective_matches_naive_cvxpy(mix, mix_result, small_dictionary):
    """Fast (LARS) objective == naive cvxpy + Clarabel objective within 1e-6 relative.

    A naive cvxpy problem costs ~0.15 s per pose (compile + interior point), so
    the naive solve covers the first N_NAIVE = 24 poses; all N_AGREE = 200 poses
    are checked against the Clarabel backend in the next test (skipped until
    `sparseedm.solvers.clarabel` exists) and here by an independent dual
    certificate: for any dual-feasible theta, P(c) - D(theta) >= P(c) - P*, so
    a certificate below 1e-6 * P(c) proves the objective within 1e-6 of the optimum.
    """
    cp = pytest.importorskip("cvxpy")
    poses, missing = mix
    res = mix_result
    assert (res.status[:N_AGREE] == "recovered").all()
    T, _, _ = represent(np.where(missing[..., None], np.nan, poses), missing, "average",
                        rule=res.dictionary.recovery_scale)
    tol = FastSolver().tol
    alpha = small_dictionary.alpha_recover
    for i in range(N_AGREE):
        D, x, a = _sub_problem(small_dictionary, T[i], missing[i], alpha)
        # independent certificate (written out here, not base.duality_gap)
        fast = get_solver("fast").solve(D, x[None], a)
        c = fast.coef[0]
        r = x - D @ c
        theta = r / max(1.0, np.abs(D.T @ r).max() / a)
        dual = 0.5 * x @ x - 0.5 * (x - theta) @ (x - theta)
        primal = _objective(D, x, c, a)
        assert primal == pytest.approx(res.objective[i], rel=1e-12)
        assert primal - dual <= tol * primal
        assert res.gap[i] <= tol * res.objective[i]
        if i < N_NAIVE:
            cv = cp.Variable(D.shape[1])
            prob = cp.Problem(cp.Minimize(0.5 * cp.sum_squares(x - D @ cv) + a * cp.norm1(cv)))
            prob.solve(solver="CLARABEL", tol_gap_abs=1e-12, tol_gap_rel=1e-12,
                       tol_feas=1e-12)
            assert prob.status == "optimal"
            assert res.objective[i] == pytest.approx(prob.value, rel=1e-6)
            assert res.objective[i] <= prob.value * (1 + 1e-9)  # never worse than Clarabel


@pytest.mark.skipif(importlib.util.find_spec("sparseedm.solvers.clarabel") is None,
                    reason="sparseedm.solvers.clarabel not written yet")
def test_fast_objective_matches_clarabel_backend(mix, mix_result, small_dictionary):
    """The same 200 poses recovered with solver='clarabel': same objectives."""
    poses, missing = mix
    ref = sparseedm.recover(poses[:N_AGREE], missing[:N_AGREE], dictionary=small_dictionary,
                            solver="clarabel")
    fast = mix_result.objective[:N_AGREE]
    np.testing.assert_allclose(fast, ref.objective, rtol=1e-6)
    assert (mix_result.gap[:N_AGREE] <= FastSolver().tol * fast).all()


# ---------------------------------------------------------------- exactness


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sparse_combination_recovered_exactly(small_dictionary, seed):
    """T = 0.7 atom_a + 0.3 atom_b with two joints occluded: the observed-entry
    lasso (tiny alpha) on D_sub, then the Eq. 10 merge, gives back T exactly."""
    comp = small_dictionary.components
    rng = np.random.default_rng(seed)
    a, b = rng.choice(len(comp), 2, replace=False)
    T = 0.7 * comp[a] + 0.3 * comp[b]
    mask = random_occlusion(1, 14, 2, random_state=seed)[0]
    observed = observed_entries(mask)
    idx = np.flatnonzero(observed)
    merged, obj, gap, status, n_active, _ = recovery._solve_chunk(
        get_solver("fast"), comp, T[None], observed[None], np.array([ALPHA_TINY]), False,
        ("exact", seed))
    assert status[0] == "optimal"
    np.testing.assert_array_equal(merged[0, idx], T[idx])  # Eq. 10 keeps the observed
    occluded = np.setdiff1d(np.arange(M), idx)
    np.testing.assert_allclose(merged[0, occluded], T[occluded], atol=1e-6)
    assert n_active[0] >= 2


# ---------------------------------------------------------------- merge, placement, jobs


def test_observed_entries_and_joints_untouched(mix, mix_result):
    poses, missing = mix
    res = mix_result
    T, _, _ = represent(np.where(missing[..., None], np.nan, poses), missing, "average",
                        rule=res.dictionary.recovery_scale)
    obs = observed_entries(missing)
    # Eq. 10: the completed vector keeps the observed entries bit for bit
    assert (res.vectors[obs] == T[obs]).all()
    assert not np.allclose(res.vectors[~obs], T[~obs])  # and the others were replaced
    # observed joints come back exactly as given; occluded ones are filled
    assert (res.poses[~missing] == poses[~missing]).all()
    assert np.isfinite(res.poses).all()
    assert res.missing.tolist() == missing.tolist()


def test_n_jobs_gives_identical_results(mix, small_dictionary):
    poses, missing = mix
    kw = dict(dictionary=small_dictionary, chunk_size=40)
    one = sparseedm.recover(poses[:160], missing[:160], n_jobs=1, **kw)
    two = sparseedm.recover(poses[:160], missing[:160], n_jobs=2, **kw)
    np.testing.assert_array_equal(one.poses, two.poses)
    np.testing.assert_array_equal(one.vectors, two.vectors)
    np.testing.assert_array_equal(one.objective, two.objective)
    assert one.status.tolist() == two.status.tolist()


def test_parallel_chunks_stay_on_the_compiled_kernel(mix, small_dictionary, monkeypatch):
    """n_jobs=2 must not cut a few hundred poses into chunks small enough for the
    numpy path (meant for a handful of poses: it made 2 jobs ~15x slower than 1)."""
    from sparseedm.solvers import fast

    calls = []
    numpy_path = fast._lars_masked_numpy
    monkeypatch.setattr(fast, "_lars_masked_numpy",
                        lambda *a, **k: calls.append(1) or numpy_path(*a, **k))
    poses, missing = mix
    res = sparseedm.recover(poses, missing, dictionary=small_dictionary, n_jobs=2)
    assert res.ok.all() and len(poses) > 4 * fast.NUMPY_MAX and calls == []
    sparseedm.recover(poses[:20], missing[:20], dictionary=small_dictionary, n_jobs=2)
    assert len(calls) == 20  # a small batch still answers without compiling


def test_workers_share_out_numba_threads_and_leave_no_core_idle():
    """The arithmetic of n_jobs against numba's threads (say four cores): process
    workers get cores // workers threads each; thread workers one each (numba's
    parallel regions from several threads serialise), so the fast solver's rows
    stay one task in-process (every core) while the workers are fewer than the cores."""
    from sparseedm._parallel import leaves_cores_idle, min_tasks, worker_threads

    assert [worker_threads(n, "loky", 4) for n in (1, 2, 3, 4, 8)] == [4, 2, 1, 1, 1]
    assert worker_threads(2, "multiprocessing", 6) == 3
    assert worker_threads(2, "threading", 4) == worker_threads(2, "dask", 4) == 1
    assert leaves_cores_idle(2, 4) and not leaves_cores_idle(4, 4)
    assert min_tasks(2, None, 6000, shared=True, threads=4) == 1  # in-process, 4 cores
    assert min_tasks(4, None, 6000, shared=True, threads=4) == 16  # 4 workers, 4 cores
    assert min_tasks(2, None, 6000, shared=True, threads=2) == 8
    assert min_tasks(2, None, 6000, threads=4) == 8  # one core a task anyway: cut


def test_process_workers_get_their_share_of_numba_threads(mix, small_dictionary,
                                                          monkeypatch):
    """recover(n_jobs=2, backend="loky") on four cores: each task set to two numba
    threads (it was one: two cores idle). joblib is replaced by a loop here."""
    import numba

    from sparseedm import _recovery_kernel

    seen = []

    class Inline:  # joblib.Parallel's interface, the calls run here in turn
        def __init__(self, n_jobs=None, return_as=None, backend=None):
            assert n_jobs == 2 and backend == "loky"

        def __call__(self, calls):
            for f, args, kwargs in calls:
                seen.append(args[-1])
                yield f(*args[:-1], None, **kwargs)  # numba's threads left as they are

    monkeypatch.setattr(_recovery_kernel, "Parallel", Inline)
    monkeypatch.setattr(_recovery_kernel, "usable_jobs", lambda n_jobs, n_tasks=None: 2)
    monkeypatch.setattr(numba, "get_num_threads", lambda: 4)  # four cores
    poses, missing = mix
    sparseedm.recover(poses, missing, dictionary=small_dictionary, adapt=False, n_jobs=2,
                      backend="loky")
    assert len(seen) > 1 and set(seen) == {2}


def test_a_small_file_is_one_task_in_process(mix, small_dictionary, monkeypatch):
    """n_jobs=2 cuts the fast solver's rows into tasks only when each worker gets
    two or more of TASK_MIN_ROWS rows (three tasks for two workers had left one
    worker a third of the rows alone): fewer stay one task in this process, on
    numba's threads."""
    from sparseedm import _recovery_kernel
    from sparseedm._parallel import TASK_MIN_ROWS, chunk_tasks
    from sparseedm.solvers.fast import NUMPY_MAX

    calls = []
    solve = _recovery_kernel.solve_chunk

    def spy(solver, components, X, *args):
        calls.append((len(X), args[-1]))
        return solve(solver, components, X, *args)

    monkeypatch.setattr(_recovery_kernel, "solve_chunk", spy)
    poses, missing = mix
    small = 4 * TASK_MIN_ROWS - 1  # poses (the occluded ones fewer): under two tasks a worker
    res = sparseedm.recover(poses[:small], missing[:small], dictionary=small_dictionary,
                            adapt=False, n_jobs=2)
    solved = int((res.status != "complete").sum())
    assert solved > 4 * NUMPY_MAX  # what the rule before cut into tasks
    assert calls == [(solved, None)]  # one task, numba's threads unchanged
    two = dict(shared=True, threads=2)  # two cores: two workers leave none idle
    assert [len(t) for t in chunk_tasks(np.arange(199), 2048, 2, **two)] == [199]
    big = [len(t) for t in chunk_tasks(np.arange(4 * TASK_MIN_ROWS), 2048, 2, **two)]
    assert len(big) == 4 and min(big) >= TASK_MIN_ROWS  # two a worker
    assert len(chunk_tasks(np.arange(6000), 2048, 2, **two)) == 8  # at most four
    # a solver whose one task would run on one core (Clarabel) is still cut
    assert len(chunk_tasks(np.arange(199), 2048, 2)) == 3


# ---------------------------------------------------------------- statuses


def test_bad_poses_get_their_status_and_the_rest_complete(cmu_poses, small_dictionary):
    poses = cmu_poses[:8].copy()
    missing = np.zeros((8, 14), bool)
    missing[0, 3:] = True                    # 3 observed: enough
    missing[1, 2:] = True                    # 2 observed
    missing[2, 5] = True
    poses[2, 7, 0] = np.inf                  # observed joint infinite
    missing[3, 4] = True
    poses[3, 0, 1] = np.nan                  # NaN where the mask says observed
    # row 4: nothing missing
    missing[5, 6] = True
    poses[5] = poses[5, 0]                   # all observed joints coincide
    missing[6, [4, 9]] = True
    missing[7, 12] = True
    poses[6, missing[6]] = np.nan            # occluded coordinates may be anything
    poses[7, 12] = 1e9
    res = sparseedm.recover(poses, missing, dictionary=small_dictionary)
    assert res.status.tolist() == [
        "recovered", "too_few_observed", "invalid_coordinates", "invalid_coordinates",
        "complete", "degenerate", "recovered", "recovered",
    ]
    assert set(res.status) <= set(recovery.STATUSES)
    refused = ~res.ok
    assert refused.tolist() == [False, True, True, True, False, True, False, False]
    assert all(res.reason[refused])
    assert np.isnan(res.poses[refused]).all()
    assert np.isnan(res.objective[refused]).all()
    np.testing.assert_array_equal(res.poses[4], poses[4])       # complete: unchanged
    assert np.isnan(res.objective[4])
    assert np.isfinite(res.poses[[0, 6, 7]]).all()
    assert (res.poses[7][~missing[7]] == poses[7][~missing[7]]).all()
    # NaN coordinates alone mark the missing joints when no mask is given
    nan_poses = np.where(missing[6:7, :, None], np.nan, poses[6:7])
    alone = sparseedm.recover(nan_poses, dictionary=small_dictionary)
    np.testing.assert_array_equal(alone.poses, res.poses[6:7])
    s = res.summary()
    assert s["poses"] == 8 and s["refused"] == 4
    assert s["recovered_joints"] == int(missing[[0, 6, 7]].sum())


def test_joint_count_must_match_the_dictionary(cmu_poses, small_dictionary):
    with pytest.raises(PoseError, match="13 joints"):
        sparseedm.recover(cmu_poses[:2, :13], dictionary=small_dictionary)
    with pytest.raises(PoseError):
        sparseedm.recover(cmu_poses[:2, :, :1], dictionary=small_dictionary)


@pytest.mark.parametrize("alpha", [0.0, -1.0, np.nan, np.inf])
def test_alpha_must_be_positive(cmu_poses, small_dictionary, alpha):
    with pytest.raises(SparseEDMError, match="alpha"):
        sparseedm.recover(cmu_poses[:2], dictionary=small_dictionary, alpha=alpha)


def test_unknown_representation(cmu_poses, small_dictionary):
    with pytest.raises(SparseEDMError, match="representation"):
        sparseedm.recover(cmu_poses[:1], dictionary=small_dictionary, representation="mean")


class FailingSolver(BaseSolver):
    """The fast solver, except that it gives up on every sub-problem with fewer
    than 78 observed entries (i.e. poses with 2+ occluded joints)."""

    name = "failing"

    def _solve(self, D, X, alpha, positive, key):
        coef, status, n_iter = FastSolver()._solve(D, X, alpha, positive, key)[:3]
        if D.shape[0] < 78:
            status = np.full(len(X), FAILED, dtype=object)
            coef = np.zeros_like(coef)
        return coef, status, n_iter


def test_solver_failure_is_flagged_per_pose(mix, small_dictionary):
    poses, missing = mix
    poses, missing = poses[:40], missing[:40]
    res = sparseedm.recover(poses, missing, dictionary=small_dictionary,
                            solver=FailingSolver())
    one = missing.sum(axis=1) == 1
    assert one.any() and (~one).any()
    assert (res.status[one] == "recovered").all()
    assert (res.status[~one] == "solver_failed").all()
    assert all(res.reason[~one])
    assert np.isnan(res.poses[~one]).all() and np.isnan(res.vectors[~one]).all()
    assert np.isfinite(res.poses[one]).all()


# ---------------------------------------------------------------- accuracy


def test_recovered_joints_beat_the_average_fill(mix, mix_result):
    """On real poses the recovered joints are far closer to the truth than the
    'average' representation's guess (the mean of the observed joints)."""
    poses, missing = mix
    mean = np.where(missing[..., None], 0, poses).sum(axis=1) / (~missing).sum(axis=1)[:, None]
    average_fill = np.where(missing[..., None], mean[:, None, :], poses)
    err = np.nanmean(joint_error(mix_result.poses, poses, missing))
    err_avg = np.nanmean(joint_error(average_fill, poses, missing))
    assert err < 0.25 * err_avg, (err, err_avg)
    # and small against the pose size (~215 px bounding boxes)
    assert err < 15.0


def test_a_batch_with_nothing_to_recover(cmu_poses, small_dictionary):
    """Complete poses only: no solver task, every pose comes back as given."""
    res = sparseedm.recover(cmu_poses[:5], dictionary=small_dictionary, adapt=False)
    assert res.status.tolist() == ["complete"] * 5
    np.testing.assert_array_equal(res.poses, cmu_poses[:5])


def test_recover_warns_of_joints_at_the_origin_of_pixel_poses(cmu_poses):
    """Zeros for missing joints in arrays passed to recover(): a warning names
    them and how to mark them; marked missing, the same poses are filled."""
    from sparseedm.keypoints import origin_joints

    poses = cmu_poses[:6].copy()
    hidden = np.zeros(poses.shape[:2], bool)
    hidden[:, 4] = True
    zeros = np.where(hidden[..., None], 0.0, poses)
    with pytest.warns(UserWarning, match=r"6 joint\(s\) of 6 pose\(s\) .* exactly \(0, 0\)"):
        sparseedm.recover(zeros, adapt=False)
    missing = origin_joints(zeros, np.zeros_like(hidden))
    np.testing.assert_array_equal(missing, hidden)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = sparseedm.recover(zeros, missing, adapt=False)
    assert res.status.tolist() == ["recovered"] * 6
    # the warning's recipe without a mask (it used to need one: origin_joints(poses,
    # None) raised TypeError): the NaN joints are the missing ones
    nan = zeros.copy()
    nan[0, 9] = np.nan
    nan[origin_joints(nan.tolist())] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = sparseedm.recover(nan, adapt=False)
    assert again.status.tolist() == ["recovered"] * 6
    # to rounding: the pose bank's Gaussian (adapt=False) solves the rows of a
    # missing pattern together, and pose 0's extra NaN moves it to its own pattern
    np.testing.assert_allclose(again.poses[1:], res.poses[1:], rtol=0, atol=1e-9)
