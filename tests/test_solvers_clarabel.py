"""ClarabelSolver against the naive cvxpy reference, and the solver registry."""

import pickle

import numpy as np
import pytest

from sparseedm.edm import observed_entries, pose_to_vector
from sparseedm.exceptions import SparseEDMError
from sparseedm.normalize import normalize
from sparseedm.solvers import SOLVERS, BaseSolver, get_solver
from sparseedm.solvers.clarabel import ClarabelSolver
from sparseedm.solvers.reference import NaiveCvxpySolver

REST = np.array([
    [0.0, 0.45], [0.0, 0.0],
    [-0.2, -0.02], [-0.25, -0.32], [-0.27, -0.6],
    [0.2, -0.02], [0.25, -0.32], [0.27, -0.6],
    [-0.12, -0.75], [-0.14, -1.2], [-0.15, -1.65],
    [0.12, -0.75], [0.14, -1.2], [0.15, -1.65],
])
PARENTS = (1, -1, 1, 2, 3, 1, 5, 6, 1, 8, 9, 1, 11, 12)
SPREAD = np.array([0.4, 0, 0.25, 1.3, 1.3, 0.25, 1.3, 1.3, 0.15, 0.8, 0.8, 0.15, 0.8, 0.8])


def _edm_vectors(n, rng):
    """EDM vectors of jittered, articulated 14-joint stick figures."""
    acc = np.zeros((n, 14))
    P = np.zeros((n, 14, 2))
    ang = rng.normal(size=(n, 14)) * SPREAD
    fore = np.clip(rng.normal(1.0, 0.2, size=(n, 14)), 0.3, 1.2)
    for j in [0] + list(range(2, 14)):
        p = PARENTS[j]
        acc[:, j] = acc[:, p] + ang[:, j]
        cs, sn = np.cos(acc[:, j]), np.sin(acc[:, j])
        bx, by = REST[j] - REST[p]
        P[:, j] = P[:, p] + np.stack([cs * bx - sn * by, sn * bx + cs * by], 1) * fore[:, j, None]
    P += rng.normal(scale=0.01, size=P.shape)
    return pose_to_vector(normalize(P)[0])


@pytest.fixture(scope="module")
def problem():
    rng = np.random.default_rng(0)
    D = _edm_vectors(400, rng)
    D = (D / np.linalg.norm(D, axis=1, keepdims=True)).T  # (91, 400), unit columns
    T = _edm_vectors(30, rng)
    patterns = [(3,), (4, 9), (0, 7, 12)]
    cases = []
    for key in patterns:
        missing = np.zeros(14, bool)
        missing[list(key)] = True
        obs = observed_entries(missing)
        cases.append((key, D[obs], T[:, obs]))
    alpha = 0.02 * float(np.median(np.abs(T @ D).max(axis=1)))
    return cases, alpha


@pytest.mark.parametrize("positive", [False, True])
def test_agrees_with_naive_cvxpy(problem, positive):
    cases, alpha = problem
    fast, naive = ClarabelSolver(), NaiveCvxpySolver()
    for key, D, X in cases:
        X = X[:10]
        a = fast.solve(D, X, alpha, positive=positive, key=key)
        b = naive.solve(D, X, alpha, positive=positive)
        assert (a.status == "optimal").all()
        np.testing.assert_allclose(a.objective, b.objective, rtol=1e-6)
        if positive:
            assert (a.coef >= 0).all()


def test_dpp_method_agrees_and_reuses_compilation(problem):
    cases, alpha = problem
    dpp, ws = ClarabelSolver(method="dpp"), ClarabelSolver()
    key, D, X = cases[1]
    a = dpp.solve(D, X[:3], alpha, key=key)
    assert dpp.n_compilations_ == 1
    dpp.solve(D, X[3:5], alpha, key=key)          # same key: re-used
    dpp.solve(D, X[3:5], 2 * alpha, key=key)      # alpha is a Parameter too
    dpp.solve(D, X[3:5], alpha, positive=True, key=key)  # a different problem
    assert dpp.n_compilations_ == 2
    b = ws.solve(D, X[:3], alpha, key=key)
    assert (a.status == "optimal").all()
    np.testing.assert_allclose(a.objective, b.objective, rtol=1e-6)


def test_dpp_cache_is_bounded(problem):
    cases, alpha = problem
    s = ClarabelSolver(method="dpp", cache_size=2)
    for key, D, X in cases + cases[:1]:
        s.solve(D, X[:1], alpha, key=key)
    assert len(s._cache) == 2
    assert s.n_compilations_ == 4  # the first pattern was evicted, compiled again


def test_gap_bounds_suboptimality(problem):
    cases, alpha = problem
    key, D, X = cases[2]
    X = X[:5]
    res = ClarabelSolver().solve(D, X, alpha, key=key)
    tight = NaiveCvxpySolver(
        solver="CLARABEL",
        solver_opts=dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12),
    ).solve(D, X, alpha)
    optimum = tight.objective - tight.gap  # a lower bound on the true optimum
    assert (res.objective - optimum <= res.gap + 1e-12).all()
    assert (res.gap <= 1e-6 * res.objective).all()
    # an arbitrary feasible point: its gap still bounds its suboptimality
    c = np.zeros_like(res.coef)
    from sparseedm.solvers import duality_gap
    primal, gap = duality_gap(D, X, c, alpha)
    assert (primal - optimum <= gap + 1e-12).all()


def test_pickles_and_still_solves(problem):
    cases, alpha = problem
    key, D, X = cases[0]
    s = ClarabelSolver(method="dpp")
    s.solve(D, X[:1], alpha, key=key)
    s2 = pickle.loads(pickle.dumps(s))
    assert len(s2._cache) == 0
    res = s2.solve(D, X[:2], alpha, key=key)
    assert (res.status == "optimal").all()
    ws = pickle.loads(pickle.dumps(ClarabelSolver(init_size=8)))
    assert ws.init_size == 8


def test_joblib_workers(problem):
    joblib = pytest.importorskip("joblib")
    cases, alpha = problem
    s = ClarabelSolver()
    out = joblib.Parallel(n_jobs=2, backend="loky")(
        joblib.delayed(s.solve)(D, X[:2], alpha, key=key) for key, D, X in cases
    )
    assert all((r.status == "optimal").all() for r in out)


def test_exact_sparse_signal_recovered(problem):
    cases, _ = problem
    key, D, _ = cases[0]
    rng = np.random.default_rng(1)
    c_true = np.zeros(D.shape[1])
    c_true[rng.choice(D.shape[1], 4, replace=False)] = rng.uniform(0.5, 1.5, 4)
    x = D @ c_true
    res = ClarabelSolver().solve(D, x[None], alpha=1e-6, key=key)
    assert res.status[0] == "optimal"
    np.testing.assert_allclose(res.coef[0] @ D.T, x, atol=1e-4 * np.linalg.norm(x))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(alpha=0.0), "alpha must be a number > 0"),
        (dict(alpha=-1.0), "alpha must be a number > 0"),
        (dict(X=np.full((1, 5), np.nan)), "finite"),
        (dict(X=np.ones((2, 4))), r"X must have shape \(n_samples, 5\)"),
        (dict(D=np.ones(5)), "D must be 2-D"),
    ],
)
def test_bad_input_raises(kwargs, match):
    args = dict(D=np.eye(5), X=np.ones((1, 5)), alpha=0.1)
    args.update(kwargs)
    with pytest.raises(SparseEDMError, match=match):
        ClarabelSolver().solve(args["D"], args["X"], args["alpha"])


def test_registry():
    assert SOLVERS == ("clarabel", "cvxpy-naive", "fast", "local-ridge")
    assert isinstance(get_solver("clarabel"), ClarabelSolver)
    assert isinstance(get_solver("cvxpy-naive"), NaiveCvxpySolver)
    assert get_solver("clarabel", tol=1e-8).tol == 1e-8
    inst = ClarabelSolver()
    assert get_solver(inst) is inst
    with pytest.raises(SparseEDMError, match="known solvers: clarabel, cvxpy-naive, fast, local-ridge"):
        get_solver("lars")
    with pytest.raises(SparseEDMError, match="cannot be applied"):
        get_solver(inst, tol=1e-3)
    with pytest.raises(ValueError, match="method"):
        ClarabelSolver(method="magic")
    assert issubclass(ClarabelSolver, BaseSolver)
