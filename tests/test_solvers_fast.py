"""The certified fast path against Clarabel, its certificate and its fallback."""

import numpy as np
import pytest

from sparseedm.edm import observed_entries
from sparseedm.metrics import random_occlusion
from sparseedm.normalize import represent
from sparseedm.solvers import get_solver
from sparseedm.solvers.base import BaseSolver, duality_gap
from sparseedm.solvers.fast import FastSolver, lars_lasso_gram


def _subproblems(poses, components, alpha, n_occluded, seed):
    """(D_sub, X_sub, alpha_eff, key) per missing pattern, as recovery builds them."""
    mask = random_occlusion(len(poses), 14, n_occluded, random_state=seed)
    T, _, _ = represent(np.where(mask[..., None], np.nan, poses), mask)
    out = []
    for pattern in np.unique(mask, axis=0):
        rows = (mask == pattern).all(axis=1)
        obs = np.flatnonzero(observed_entries(pattern))
        out.append((components[:, obs].T, T[rows][:, obs], alpha * len(obs) / 91,
                    pattern.tobytes()))
    return out


@pytest.fixture(scope="module")
def problems(cmu_poses, small_dictionary):
    # 510 poses: the fixture's 334 and 176 of them stretched (another camera aspect)
    poses = np.concatenate([cmu_poses, cmu_poses[::2, :, :][:176] * [1.1, 0.9]])
    comps = small_dictionary.components
    probs = []
    for i, count in enumerate((1, 2, 3)):
        probs += _subproblems(poses[i::3], comps, 0.002, count, seed=i)
    return probs


def test_fast_equals_clarabel_on_500_real_poses(problems):
    """>= 500 real poses, patterns with 1-3 missing joints: objectives within 1e-6."""
    fast, clarabel = FastSolver(fallback=None), get_solver("clarabel")
    n = 0
    worst = 0.0
    for D, X, alpha, key in problems:
        a = fast.solve(D, X, alpha, key=key)
        b = clarabel.solve(D, X, alpha, key=key)
        assert (a.status == "optimal").all()
        worst = max(worst, np.max(np.abs(a.objective - b.objective) / b.objective))
        n += len(X)
    assert n >= 500
    assert worst <= 1e-6


def test_gap_is_a_true_upper_bound(problems):
    """gap >= objective - optimum, the optimum taken as the best of two backends."""
    fast, clarabel = FastSolver(fallback=None), get_solver("clarabel")
    for D, X, alpha, key in problems[:: max(1, len(problems) // 8)]:
        # a deliberately stopped path: not optimal, so the bound is tested where it matters
        early = FastSolver(fallback=None, max_steps=3).solve(D, X, alpha)
        best = np.minimum(fast.solve(D, X, alpha).objective,
                          clarabel.solve(D, X, alpha).objective)
        assert (early.gap >= early.objective - best - 1e-12).all()
        assert (early.objective >= best - 1e-12).all()


def test_positive_codes(problems):
    D, X, alpha, key = problems[0]
    res = FastSolver(fallback=None).solve(D, X, alpha, positive=True)
    assert (res.coef >= 0).all() and (res.status == "optimal").all()
    ref = get_solver("clarabel").solve(D, X, alpha, positive=True)
    np.testing.assert_allclose(res.objective, ref.objective, rtol=1e-6)


class _CountingClarabel(BaseSolver):
    name = "counting"

    def __init__(self):
        super().__init__()
        self.calls = 0
        self.inner = get_solver("clarabel")

    def _solve(self, D, X, alpha, positive, key):
        self.calls += len(X)
        res = self.inner.solve(D, X, alpha, positive=positive)
        return res.coef, res.status, res.n_iter


def test_fallback_answers_what_the_fast_path_cannot_certify():
    """Duplicate atoms and a path cut short: the certificate catches it, Clarabel answers."""
    rng = np.random.default_rng(0)
    D = np.abs(rng.standard_normal((30, 60)))
    D[:, 30:] = D[:, :30]  # every atom twice
    D /= np.linalg.norm(D, axis=0)
    X = D[:, :5] @ rng.uniform(0.5, 1, (5, 4)) + 0.01 * rng.standard_normal((30, 4))
    X = np.vstack([X.T, np.zeros(30)])  # and one all-zero observed vector
    backup = _CountingClarabel()
    res = FastSolver(max_steps=2, fallback=backup, refine=False).solve(D, X, 0.01)
    assert res.fallback[:4].all() and backup.calls >= 4
    assert (res.status == "optimal").all()
    ref = get_solver("clarabel").solve(D, X, 0.01)
    np.testing.assert_allclose(res.objective, ref.objective, rtol=1e-6)
    assert res.objective[4] == 0 and not res.fallback[4]  # zero vector: c = 0 is optimal
    # with enough steps the duplicates are handled by the path itself
    ok = FastSolver(fallback=None).solve(D, X, 0.01)
    assert (ok.status == "optimal").all()


def test_ill_conditioned_pattern_one_arm_missing(small_dictionary, cmu_poses):
    """All joints of one arm missing (shoulder, elbow, wrist): certified or fallen back."""
    mask = np.zeros((60, 14), bool)
    mask[:, [2, 3, 4]] = True
    T, _, _ = represent(np.where(mask[..., None], np.nan, cmu_poses[:60]), mask)
    obs = np.flatnonzero(observed_entries(mask[0]))
    D = small_dictionary.components[:, obs].T
    res = FastSolver().solve(D, T[:, obs], 1e-5)
    assert (res.status == "optimal").all()
    primal, gap = duality_gap(D, T[:, obs], res.coef, 1e-5)
    assert (gap <= 1e-6 * primal).all()


def test_lars_matches_soft_threshold_and_is_exact_on_orthonormal():
    rng = np.random.default_rng(1)
    Q, _ = np.linalg.qr(rng.standard_normal((8, 8)))
    x = rng.standard_normal((5, 8))
    coef, steps = lars_lasso_gram(Q.T @ Q, x @ Q, 0.3)
    z = x @ Q
    np.testing.assert_allclose(coef, np.sign(z) * np.maximum(np.abs(z) - 0.3, 0), atol=1e-12)
    assert (steps >= 0).all()


def test_solver_pickles_without_its_cache(problems):
    import pickle

    D, X, alpha, key = problems[0]
    s = FastSolver()
    s.solve(D, X, alpha, key=key)
    t = pickle.loads(pickle.dumps(s))
    assert len(t._grams) == 0
    np.testing.assert_array_equal(t.solve(D, X, alpha, key=key).coef,
                                  s.solve(D, X, alpha, key=key).coef)


def test_numpy_path_walks_the_same_homotopy_as_the_compiled_one(cmu_poses, small_dictionary):
    """Small batches run the numpy LARS (no compilation), large ones the numba
    kernel: same steps, same supports, same codes to round-off, on real poses."""
    from sparseedm.solvers.fast import NUMPY_MAX, lars_lasso_masked

    poses = cmu_poses[:2 * NUMPY_MAX]
    mask = random_occlusion(len(poses), 14, "mix", random_state=5)
    T, _, _ = represent(np.where(mask[..., None], np.nan, poses), mask)
    obs = observed_entries(mask)
    X0 = np.where(obs, T, 0.0)
    D = small_dictionary.components.T
    G = D.T @ D
    alpha = 0.002 * obs.sum(axis=1) / 91
    compiled, steps_c = lars_lasso_masked(G, D, X0, obs, alpha)
    parts = [lars_lasso_masked(G, D, X0[s], obs[s], alpha[s])
             for s in np.array_split(np.arange(len(X0)), 4)]  # < NUMPY_MAX rows each
    numpy_coef = np.concatenate([p[0] for p in parts])
    steps_n = np.concatenate([p[1] for p in parts])
    np.testing.assert_array_equal(steps_n, steps_c)
    np.testing.assert_array_equal(numpy_coef != 0, compiled != 0)
    np.testing.assert_allclose(numpy_coef, compiled, atol=1e-8)


def _coherent(seed, n_signals):
    """80 coherent non-negative unit atoms in 30 dimensions, and signals (rows) made
    of the first six plus a little noise."""
    rng = np.random.default_rng(seed)
    D = np.abs(rng.standard_normal((30, 80)))
    D /= np.linalg.norm(D, axis=0)
    X = D[:, :6] @ rng.uniform(0.5, 1, (6, n_signals)) + 0.01 * rng.standard_normal(
        (30, n_signals))
    return D, X.T


def test_refinement_finishes_a_path_cut_short_without_the_fallback():
    """Paths stopped after 2 steps are finished by feature-sign search: certified, no
    Clarabel call, the same optimum as Clarabel's; without it they fall back."""
    D, X = _coherent(3, 5)
    for positive in (False, True):
        backup = _CountingClarabel()
        res = FastSolver(max_steps=2, fallback=backup).solve(D, X, 0.01, positive=positive)
        assert backup.calls == 0 and not res.fallback.any()
        assert (res.status == "optimal").all()
        ref = get_solver("clarabel").solve(D, X, 0.01, positive=positive)
        np.testing.assert_allclose(res.objective, ref.objective, rtol=1e-6)
        cut = FastSolver(max_steps=2, fallback=None, refine=False).solve(D, X, 0.01,
                                                                          positive=positive)
        assert (cut.status == "inaccurate").all()  # what the refinement started from


def test_refinement_on_masked_rows_keeps_the_patterns():
    """solve_masked: rows cut short on two patterns are each finished on their own
    sub-dictionary (the certificate is judged per pattern), without the fallback."""
    D, X = _coherent(5, 8)
    obs = np.ones(X.shape, bool)
    obs[::2, :4] = False  # a second pattern: four entries unobserved
    backup = _CountingClarabel()
    res = FastSolver(max_steps=2, fallback=backup).solve_masked(D, X, obs, 0.01)
    assert (res.status == "optimal").all() and backup.calls == 0
    for rows in (slice(0, None, 2), slice(1, None, 2)):
        o = obs[rows][0]
        ref = get_solver("clarabel").solve(D[o], X[rows][:, o], 0.01)
        np.testing.assert_allclose(res.objective[rows], ref.objective, rtol=1e-6)


def _masked_problems(seed, n=96, m=60, k=600):
    """Coherent non-negative unit atoms (as EDM vectors are), rows of a few of
    them plus noise, each with its own random hidden entries, and alphas small
    enough for supports of tens of atoms."""
    rng = np.random.default_rng(seed)
    D = np.abs(rng.standard_normal((m, k))) + 0.5
    D /= np.linalg.norm(D, axis=0)
    X = (D[:, rng.integers(0, k, (n, 8))] * rng.uniform(0.2, 1, (1, n, 8))).sum(-1).T
    X += 0.01 * rng.standard_normal(X.shape)
    obs = rng.random((n, m)) > rng.uniform(0.1, 0.4, (n, 1))
    alpha = rng.uniform(5e-3, 2e-2, n) * obs.sum(axis=1) / m
    return D, np.where(obs, X, 0.0), obs, alpha


@pytest.mark.parametrize("positive", [False, True])
def test_working_set_answer_is_the_full_dictionary_lasso(positive):
    """The working-set solve ends at the full problem's optimum: objectives and codes
    of the full-dictionary homotopy to round-off, certified by the shared duality gap,
    and the check did have to add atoms beyond the first (for most rows' supports
    leave the 4 atoms it starts from)."""
    from sparseedm.solvers.fast import lars_lasso_masked, lars_lasso_working_set

    D, X, obs, alpha = _masked_problems(3)
    full, steps_f = lars_lasso_masked(D.T @ D, D, X, obs, alpha, positive=positive,
                                      numpy_max=0)
    ws, steps = lars_lasso_working_set(D, X, obs, alpha, positive=positive, n_init=4, add=3)
    assert (steps > 0).all() and (steps_f > 0).all()
    # most rows finish on their set (the others were solved again over all atoms)
    _, own = lars_lasso_working_set(D, X, obs, alpha, positive=positive, n_init=4, add=3,
                                    resolve=False)
    assert np.mean(own > 0) > 0.75
    obj_f, _ = duality_gap(D, X, full, alpha, positive, obs)
    obj, gap = duality_gap(D, X, ws, alpha, positive, obs)
    assert (gap <= 1e-9 * obj).all()
    np.testing.assert_allclose(obj, obj_f, rtol=1e-9)
    np.testing.assert_allclose(ws, full, atol=1e-6 * np.abs(full).max())
    first = np.argsort(-(X @ D if positive else np.abs(X @ D)), axis=1)[:, :4]
    outside = [np.setdiff1d(np.flatnonzero(c), f).size for c, f in zip(ws, first)]
    assert np.mean(np.array(outside) > 0) > 0.9
    if positive:
        assert (ws >= 0).all()


def test_working_set_too_small_is_solved_again():
    """A row whose set cannot hold its answer stops (steps negative) and is solved
    again over all atoms; FastSolver(working_set=True) certifies the same optimum."""
    from sparseedm.solvers.fast import lars_lasso_working_set

    D, X, obs, alpha = _masked_problems(4)
    _, stopped = lars_lasso_working_set(D, X, obs, alpha, n_init=4, add=3, max_ws=10,
                                        resolve=False)
    assert (stopped < 0).all()
    coef, steps = lars_lasso_working_set(D, X, obs, alpha, n_init=4, add=3, max_ws=10)
    assert (steps > 0).all()
    obj, gap = duality_gap(D, X, coef, alpha, False, obs)
    assert (gap <= 1e-9 * obj).all()
    res = FastSolver(working_set=True).solve_masked(D, X, obs, alpha)
    ref = FastSolver().solve_masked(D, X, obs, alpha)
    assert (res.status == "optimal").all() and not res.fallback.any()
    assert (res.gap <= 1e-6 * res.objective).all()
    np.testing.assert_allclose(res.objective, ref.objective, rtol=1e-8)


def test_auto_working_sets_from_many_atoms(monkeypatch):
    """FastSolver()'s default ("auto") codes masked batches on working sets from
    WS_MIN_ATOMS atoms (here lowered to the test dictionary's size) and by the
    full homotopy below: the same codes, objectives and statuses either way."""
    from sparseedm.solvers import fast

    D, X, obs, alpha = _masked_problems(3)
    used = []
    real = fast.lars_lasso_working_set
    monkeypatch.setattr(fast, "lars_lasso_working_set",
                        lambda *a, **k: used.append(1) or real(*a, **k))
    full = FastSolver(working_set=False, numpy_max=0).solve_masked(D, X, obs, alpha)
    below = FastSolver(numpy_max=0).solve_masked(D, X, obs, alpha)
    assert not used
    monkeypatch.setattr(fast, "WS_MIN_ATOMS", D.shape[1])
    auto = FastSolver(numpy_max=0).solve_masked(D, X, obs, alpha)
    assert used
    for res in (below, auto):
        assert res.status.tolist() == full.status.tolist()
        np.testing.assert_allclose(res.objective, full.objective, rtol=1e-9)
        np.testing.assert_allclose(res.coef, full.coef, atol=1e-7 * np.abs(full.coef).max())


@pytest.mark.parametrize("threads", [1, 2])
def test_rows_solved_again_as_lars_lasso_rows_solves_them(threads):
    """The rows a working set cannot finish are solved again in one compiled batch:
    each the very answer of lars_lasso_rows on its own observed sub-dictionary
    (the per-row form), bit for bit, whether threads share them or not."""
    import numba

    from sparseedm.solvers.fast import lars_lasso_rows, lars_lasso_working_set

    D, X, obs, alpha = _masked_problems(5, n=24)
    X[3] = 0.0  # a row with nothing to code
    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        _, stopped = lars_lasso_working_set(D, X, obs, alpha, n_init=4, add=3, max_ws=10,
                                            resolve=False)
        coef, steps = lars_lasso_working_set(D, X, obs, alpha, n_init=4, add=3, max_ws=10)
    finally:
        numba.set_num_threads(before)
    assert (stopped < 0).sum() > 20
    for i in np.flatnonzero(stopped < 0):
        ref, st = lars_lasso_rows(D[obs[i]], X[i:i + 1, obs[i]], alpha[i])
        np.testing.assert_array_equal(coef[i], ref[0])
        assert steps[i] == st[0]
