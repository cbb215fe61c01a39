"""Gram matrices of dictionaries, kept for the process (the last few, by content).

A Gram matrix ``D^T D`` of 2000 atoms is 32 MB and about 35 ms to form, and it
is memory-bound (a second BLAS thread barely helps). One call that adapts a
dictionary needs the base dictionary's Gram in its filter, in the first
mini-batch of every learning (each starts from the base atoms), in its guard
and, when the base is kept, in its recovery; each candidate's in its guard and
again in the recovery when it is adopted. Each of those ran in its own solver
or learner and formed its own. Here they share one per dictionary: the last
:data:`GRAM_CACHE_SIZE` dictionaries' Grams, keyed by the atoms' bytes (not
by a caller's label), each computed by the same expression as before, so
every answer is the same to the last bit.

Examples
--------
>>> import numpy as np
>>> D = np.eye(3)[:, :2]
>>> G = gram_matrix(D)
>>> G.tolist(), gram_matrix(D.copy()) is G
([[1.0, 0.0], [0.0, 1.0]], True)
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

import numpy as np

__all__ = ["gram_matrix", "clear_gram_cache", "atoms_key", "GRAM_CACHE_SIZE"]

#: Gram matrices kept (32 MB each at 2000 atoms): the base dictionary, this
#: round's candidate and the previous ones
GRAM_CACHE_SIZE = 4

_GRAMS = OrderedDict()
_LOCK = threading.Lock()


def atoms_key(components):
    """A hex digest of the atoms: the key of a solver's per-dictionary caches."""
    return hashlib.sha1(np.ascontiguousarray(components).tobytes()).hexdigest()


def gram_matrix(D):
    """``D.T @ D`` of a dictionary D (n_features, k), from the process cache
    when these atoms were seen last; computed and kept otherwise. The result is
    shared: do not modify it.

    Parameters
    ----------
    D : ndarray, shape (n_features, k)
        Atoms as columns (``components.T``).

    Returns
    -------
    ndarray, shape (k, k)
    """
    key = D.shape, atoms_key(D.T)  # D.T: the atoms as rows, as callers hold them (no copy)
    with _LOCK:  # threads of one process share the cache
        G = _GRAMS.get(key)
        if G is not None:
            _GRAMS.move_to_end(key)
            return G
    G = D.T @ D  # outside the lock: two threads may both form it, never wait on it
    with _LOCK:
        _GRAMS[key] = G
        while len(_GRAMS) > max(int(GRAM_CACHE_SIZE), 0):
            _GRAMS.popitem(last=False)
    return G


def clear_gram_cache():
    """Forget the kept Gram matrices (their memory is freed once unused).

    Examples
    --------
    >>> clear_gram_cache()
    """
    with _LOCK:
        _GRAMS.clear()
