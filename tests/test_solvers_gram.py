"""The process's Gram matrices (sparseedm.solvers.gram): shared by content,
bounded, and the same numbers as forming them anew."""

import numpy as np
import pytest

from sparseedm.solvers import gram
from sparseedm.solvers.fast import FastSolver


@pytest.fixture(autouse=True)
def fresh_cache():
    gram.clear_gram_cache()
    yield
    gram.clear_gram_cache()


def _atoms(seed, k=50, m=12):
    D = np.random.default_rng(seed).standard_normal((m, k))
    return D / np.linalg.norm(D, axis=0)


def test_one_gram_per_content_equal_to_a_fresh_product():
    D = _atoms(0)
    G = gram.gram_matrix(D)
    np.testing.assert_array_equal(G, D.T @ D)
    assert gram.gram_matrix(D.copy()) is G               # same atoms, another array
    other = D.copy()
    other[0, 0] += 1e-12                                  # one bit of one atom differs
    assert gram.gram_matrix(other) is not G
    assert gram.gram_matrix(D.reshape(6, 100)) is not G   # same bytes, another shape


def test_the_cache_keeps_the_last_few(monkeypatch):
    monkeypatch.setattr(gram, "GRAM_CACHE_SIZE", 2)
    a, b, c = (_atoms(s) for s in range(3))
    Ga = gram.gram_matrix(a)
    gram.gram_matrix(b)
    assert gram.gram_matrix(a) is Ga                      # used: now the most recent
    gram.gram_matrix(c)                                   # evicts b, the least recent
    assert gram.gram_matrix(a) is Ga
    assert len(gram._GRAMS) == 2
    monkeypatch.setattr(gram, "GRAM_CACHE_SIZE", 0)
    gram.gram_matrix(_atoms(4))
    assert len(gram._GRAMS) == 0


def test_fast_solvers_share_the_whole_dictionary_gram(monkeypatch):
    """Two solver instances (two calls) form a dictionary's Gram once; their
    answers are those of a solver that forms its own."""
    D = _atoms(5, k=80, m=15)
    rng = np.random.default_rng(1)
    X = rng.standard_normal((6, 15))
    observed = rng.random((6, 15)) > 0.2
    X = np.where(observed, X, 0.0)
    alpha = np.full(6, 0.05)
    formed = []
    real = gram.gram_matrix

    def spy(D):
        n = len(gram._GRAMS)
        G = real(D)
        formed.append(len(gram._GRAMS) > n)
        return G

    monkeypatch.setattr("sparseedm.solvers.fast.gram_matrix", spy)
    a = FastSolver().solve_masked(D, X, observed, alpha, key="a")
    b = FastSolver().solve_masked(D, X, observed, alpha, key="another label")
    assert formed == [True, False]
    np.testing.assert_array_equal(a.coef, b.coef)
    gram.clear_gram_cache()
    monkeypatch.setattr(gram, "GRAM_CACHE_SIZE", 0)
    c = FastSolver().solve_masked(D, X, observed, alpha, key="a")
    np.testing.assert_array_equal(a.coef, c.coef)
