"""The local ridge backend: each row's ridge code on its K most correlated atoms,
against a direct per-row numpy solve of the same problem."""

import numpy as np
import pytest

from sparseedm.exceptions import SparseEDMError
from sparseedm.solvers import LocalRidgeSolver, get_solver


def direct(D, x, obs, K, lam, power=0.0, first=None, pool=None):
    """One row by the definition: score, working set, normal equations; with
    `first`, a first pass on `first` atoms fills the row, and the working set and
    the penalty's cosines are those of the whole filled row, among the `pool`
    atoms of highest score (None: all)."""
    A = D[obs]                                   # (m_obs, k)
    score = (x[obs] @ A) / np.linalg.norm(A, axis=0)
    S = np.argsort(-score)[:K]
    cos = (A[:, S].T @ x[obs]) / (np.linalg.norm(A[:, S], axis=0) * np.linalg.norm(x[obs]))
    if first is not None:
        S1 = np.argsort(-score)[:first]
        c1 = ridge(A[:, S1], x[obs], lam, (A[:, S1].T @ x[obs]) / (
            np.linalg.norm(A[:, S1], axis=0) * np.linalg.norm(x[obs])), power)
        filled = np.where(obs, x, D[:, S1] @ c1)
        cand = np.argsort(-score)[:pool]
        S = cand[np.argsort(-(filled @ D[:, cand]) / np.linalg.norm(D[:, cand], axis=0))[:K]]
        cos = (D[:, S].T @ filled) / (np.linalg.norm(D[:, S], axis=0)
                                      * np.linalg.norm(filled))
    AS = A[:, S]
    c = ridge(AS, x[obs], lam, cos, power)
    mu = lam * np.trace(AS.T @ AS) / len(S)
    w = np.maximum(1 - cos, 1e-12) ** power
    w /= w.mean()
    coef = np.zeros(D.shape[1])
    coef[S] = c
    r = x[obs] - AS @ c
    return coef, 0.5 * r @ r + 0.5 * mu * (w * c) @ c


def ridge(AS, y, lam, cos, power):
    """The weighted ridge code of `y` on the columns of `AS`."""
    G = AS.T @ AS
    w = np.maximum(1 - cos, 1e-12) ** power
    return np.linalg.solve(G + lam * np.trace(G) / AS.shape[1] * np.diag(w / w.mean()),
                           AS.T @ y)


def problem(seed, n=40, m=15, k=60, hide=4):
    rng = np.random.default_rng(seed)
    D = np.abs(rng.standard_normal((m, k)))
    D /= np.linalg.norm(D, axis=0)
    X = np.abs(rng.standard_normal((n, m)))
    obs = np.ones((n, m), bool)
    for i in range(n):
        obs[i, rng.choice(m, rng.integers(0, hide + 1), replace=False)] = False
    return D, X, obs


@pytest.mark.parametrize("K,lam,power,first,pool", [
    (5, 1e-3, 0.0, None, None), (16, 1e-1, 2.0, None, None), (60, 1e-4, 1.0, None, None),
    (200, 1e-3, 2.0, None, None), (8, 1e-2, 3.0, 4, None), (16, 1e-2, 3.0, 16, None),
    (20, 1e-2, 2.0, 100, None), (200, 1e-3, 3.0, 8, None), (8, 1e-2, 3.0, 4, 20),
    (12, 1e-1, 2.0, 6, 12)])
def test_matches_direct_solve(K, lam, power, first, pool, monkeypatch):
    from sparseedm.solvers import local_ridge

    if pool is not None:                         # the first pass's candidates
        monkeypatch.setattr(local_ridge, "REFINE_POOL", pool)
    assert local_ridge.REFINE_POOL >= 60 or pool is not None
    D, X, obs = problem(K if first is None else K + first)
    Xn = np.where(obs, X, np.nan)                # unobserved values are ignored
    res = LocalRidgeSolver(n_atoms=K, lam=lam, block=7, power=power,
                           first_atoms=first).solve_masked(D, Xn, obs, 0.5)
    for i in range(len(X)):
        coef, obj = direct(D, X[i], obs[i], min(K, D.shape[1]), lam, power,
                           None if first is None else min(first, D.shape[1]), pool)
        np.testing.assert_allclose(res.coef[i], coef, rtol=0, atol=1e-8)
        np.testing.assert_allclose(res.objective[i], obj, rtol=1e-9)
    assert ((res.coef != 0).sum(axis=1) == min(K, D.shape[1])).all()
    assert (res.status == "optimal").all() and (res.gap < 1e-10).all()
    assert not res.fallback.any() and (res.n_iter == min(K, D.shape[1])).all()


def test_few_observed_entries():
    D, X, obs = problem(1, n=3)
    obs[0] = False
    obs[0, [2, 7]] = True                        # two entries, K far above them
    res = get_solver("local-ridge", n_atoms=20, lam=1e-3, power=2.0).solve_masked(
        D, X, obs, 1.0)
    coef, obj = direct(D, X[0], obs[0], 20, 1e-3, 2.0)
    np.testing.assert_allclose(res.coef[0], coef, atol=1e-8)
    assert res.status[0] == "optimal"
    # the fit is near-exact on the two entries it sees, and says nothing else
    assert abs(res.objective[0] - obj) <= 1e-9 * max(obj, 1e-300)


def test_solve_is_all_observed():
    D, X, _ = problem(2, n=5)
    solver = LocalRidgeSolver(n_atoms=8)
    a = solver.solve(D, X, 0.1)
    b = solver.solve_masked(D, X, np.ones(X.shape, bool), 0.1)
    np.testing.assert_array_equal(a.coef, b.coef)


@pytest.mark.parametrize("kw", [dict(n_atoms=0), dict(lam=0.0), dict(block=0),
                                dict(power=-1.0), dict(first_atoms=0),
                                dict(first_atoms=2.5)])
def test_bad_settings(kw):
    with pytest.raises(SparseEDMError):
        LocalRidgeSolver(**kw)


def test_positive_refused():
    D, X, obs = problem(3, n=2)
    with pytest.raises(SparseEDMError, match="signed"):
        LocalRidgeSolver().solve_masked(D, X, obs, 0.1, positive=True)


def test_an_extrapolating_row_is_coded_by_the_lasso():
    """Two atoms almost equal on the observed entries but not on the hidden one: the
    ridge's code cancels two huge coefficients and its fill leaves the atoms'
    envelope, so that row goes to the lasso (certified); a row the atoms span
    keeps its ridge code."""
    from sparseedm.solvers.fast import FastSolver

    D = np.array([[1.0, 1.0, 0.2], [0.0, 1e-4, 0.3], [0.0, 0.0, 0.9], [0.0, 1.0, 0.1]])
    D /= np.linalg.norm(D, axis=0)
    X = np.array([[1.0, 1.0, 0.0, 0.0],            # needs c2 ~ 1e4: extrapolates
                  [1.0, 0.0, 0.0, 0.0]])           # the first atom itself
    obs = np.array([[True, True, True, False]] * 2)
    res = LocalRidgeSolver(n_atoms=2, lam=1e-12).solve_masked(D, X, obs, 0.01)
    assert res.fallback.tolist() == [True, False]
    lasso = FastSolver().solve_masked(D, X[:1], obs[:1], 0.01)
    np.testing.assert_allclose(res.coef[0], lasso.coef[0], atol=1e-9)
    assert res.status[0] == "optimal" and res.gap[0] <= 1e-6 * max(res.objective[0], 1e-300)
    fit = res.coef @ D.T
    assert abs(fit[0, 3]) < 10 and (res.coef[1] != 0).sum() <= 2


def test_a_stronger_ridge_brings_an_extrapolating_row_back():
    """A milder case: the first solve leaves the envelope, a ten-times stronger ridge
    does not, and the row keeps a ridge code (no lasso fallback), its fill inside."""
    from sparseedm.solvers.local_ridge import local_ridge_codes

    D = np.array([[1.0, 1.0, 0.2], [0.0, 1e-2, 0.3], [0.0, 0.0, 0.9], [0.0, 1.0, 0.1]])
    D /= np.linalg.norm(D, axis=0)
    X = np.array([[1.0, 1.0, 0.0, 0.0]])
    obs = np.array([[True, True, True, False]])
    first = np.zeros((1, 3))
    _, _, outside = local_ridge_codes(np.ascontiguousarray(D.T), X, obs, 2, 1e-5, first)
    assert outside[0]
    res = LocalRidgeSolver(n_atoms=2, lam=1e-5).solve_masked(D, X, obs, 0.01)
    assert not res.fallback[0] and res.status[0] == "optimal"
    assert (res.coef[0] != 0).sum() == 2 and not np.allclose(res.coef[0], first[0])
    assert 0 <= (res.coef @ D.T)[0, 3] <= 1


def test_support_names_every_coefficient_and_rebuilds_the_same_poses():
    """The result's support holds each row's non-zero coefficients, and the
    reconstruction that gathers there equals the one that scans the whole row."""
    from dataclasses import replace

    from sparseedm._recovery_kernel import _reconstruct

    rng = np.random.default_rng(3)
    D = np.abs(rng.standard_normal((21, 300)))
    X = D[:, rng.integers(0, 300, 40)].T + 0.05 * rng.standard_normal((40, 21))
    obs = rng.random((40, 21)) > 0.3
    res = LocalRidgeSolver(n_atoms=12, first_atoms=4, lam=1e-3).solve_masked(D, X, obs, 0.1)
    assert res.support.shape == (40, 12)
    inside = np.zeros(res.coef.shape, bool)
    np.put_along_axis(inside, res.support, True, axis=1)
    assert not (res.coef[~inside] != 0).any() and (res.coef[inside] != 0).all()
    gathered = _reconstruct(res, D.T)
    scanned = _reconstruct(replace(res, support=None), D.T)
    np.testing.assert_array_equal(gathered[0], scanned[0])
    np.testing.assert_array_equal(gathered[1], scanned[1])
