"""Feature-sign search (``solvers._active_set``): from any start to the certified optimum."""

import numpy as np
import pytest

from sparseedm.solvers import get_solver
from sparseedm.solvers._active_set import refine_row, refine_rows
from sparseedm.solvers.base import duality_gap


def _problem(seed, n=25, k=60):
    rng = np.random.default_rng(seed)
    D = np.abs(rng.standard_normal((n, k)))
    D /= np.linalg.norm(D, axis=0)
    x = D[:, :5] @ rng.uniform(0.5, 1, 5) + 0.02 * rng.standard_normal(n)
    return D, x


@pytest.mark.parametrize("positive", [False, True])
@pytest.mark.parametrize("start", ["zero", "wrong support", "optimum with an atom swapped"])
def test_reaches_the_certified_optimum_from_any_start(positive, start):
    D, x = _problem(0)
    alpha = 0.002
    ref = get_solver("clarabel").solve(D, x[None], alpha, positive=positive)
    rng = np.random.default_rng(1)
    c0 = np.zeros(D.shape[1])
    if start == "wrong support":
        c0[rng.choice(D.shape[1], 8, replace=False)] = rng.uniform(0.1, 0.5, 8)
    elif start == "optimum with an atom swapped":
        c0 = ref.coef[0].copy()
        on, off = np.flatnonzero(np.abs(c0) > 1e-9), np.flatnonzero(np.abs(c0) <= 1e-9)
        c0[off[0]], c0[on[0]] = c0[on[0]], 0.0
    c, done = refine_row(D, x, alpha, c0, positive=positive)
    assert done
    primal, gap = duality_gap(D, x[None], c[None], alpha, positive)
    assert gap[0] <= 1e-9 * primal[0]
    assert primal[0] <= ref.objective[0] * (1 + 1e-7)
    if positive:
        assert (c >= 0).all()


def test_objective_never_rises_and_unfinished_rows_say_so():
    """With one step allowed from zero it cannot finish: it says so, and what it
    returns is no worse than the start."""
    D, x = _problem(2)
    c, done = refine_row(D, x, 0.001, np.zeros(D.shape[1]), max_steps=1)
    assert not done
    primal, _ = duality_gap(D, x[None], c[None], 0.001)
    assert primal[0] <= 0.5 * x @ x


def test_rows_of_a_batch_on_their_observed_entries():
    D, x = _problem(4)
    X = np.vstack([x, x[::-1]])
    obs = np.ones_like(X, dtype=bool)
    obs[1, :4] = False
    out = refine_rows(D, X, np.zeros((2, D.shape[1])), np.array([0.002, 0.05]), np.array([1]),
                      observed=obs)
    one, done = refine_row(D[obs[1]], X[1, obs[1]], 0.05, np.zeros(D.shape[1]))
    assert done and out.shape == (1, D.shape[1])
    np.testing.assert_array_equal(out[0], one)


def test_zero_is_recognised_as_the_answer():
    """No atom worth its penalty: zero comes back at once, also from a wrong start."""
    D = np.eye(3)
    c, done = refine_row(D, np.zeros(3), 0.1, np.zeros(3))
    assert done and not c.any()
    c, done = refine_row(D, np.array([0.05, 0.0, 0.0]), 0.1, np.array([0.3, 0.0, 0.0]))
    assert done and not c.any()
