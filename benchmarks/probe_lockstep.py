"""Probe (not adopted): LARS rows advanced in lockstep, the correlation update BLAS-3.

    python -m benchmarks.probe_lockstep [--n 2000] [--slots 64]

The idea: advance many poses together so the step's correlation
update is one matrix product. Here B poses ("slots") of *any* missing pattern
take one LARS step at a time; each slot's direction ``u = D_A w`` (zeroed at
its missing entries) is a row of U, and ``U @ D`` (B x 91 by 91 x k, one
dgemm) gives every slot's change of correlations, so no Gram row and no Gram
downdate is needed (the active block G_AA comes from dot products over the
observed entries). A finished slot takes the next pose. The event search,
the updates and the polish are the shipped kernel's (``sparseedm.solvers.fast``).

It gives the shipped kernel's answers (identical supports; largest coefficient
difference within 7e-10 on 2,000 held-out Mix poses) at the same speed on one core:
the product costs 91 x k per pose-step (dgemm at ~12-14 GFMA/s here), against
the Gram path's n_active x k gemv plus the m_miss x k downdate per entering
atom at a lower rate -- 15 vs 21 us per pose-step, eaten by the event search
and the slot bookkeeping. Measured numbers are in benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
from threadpoolctl import threadpool_limits

from sparseedm.solvers.fast import _chol_solve, _next_event, lars_lasso_masked


@numba.njit(cache=True, nogil=True)
def _start(D, X0, obsf, alpha, positive, s, r, DTX, C, state, lam, tiny, nact, ent, nsgn, drp,
           nst, limit, maxa):
    """Put row r into slot s; False if its answer is zero (lam <= alpha)."""
    k = D.shape[1]
    np.dot(X0[r], D, DTX[s])
    best = -1
    v_best = -1.0
    for j in range(k):
        C[s, j] = DTX[s, j]
        state[s, j] = 0
        v = C[s, j] if positive else abs(C[s, j])
        if v > v_best:
            v_best = v
            best = j
    if v_best <= alpha[r]:
        return False
    lam[s] = v_best
    tiny[s] = 1e-14 * v_best
    nact[s] = 0
    ent[s] = best
    nsgn[s] = 1.0 if C[s, best] > 0 else -1.0
    drp[s] = -1
    nst[s] = 0
    m_obs = 0
    for q in range(obsf.shape[1]):
        m_obs += obsf[r, q] > 0
    limit[s] = min(maxa, m_obs + 1)
    return True


@numba.njit(cache=True, nogil=True)
def lockstep(D, X0, obsf, alpha, positive, max_steps, coef, steps, B):
    """The masked lasso of every row of X0 (zero off its observed entries)."""
    m, k = D.shape
    nr = X0.shape[0]
    B = max(1, min(B, nr))
    maxa = min(k, max_steps + 1, m + 1)
    C = np.empty((B, k))
    Acor = np.zeros((B, k))
    DTX = np.empty((B, k))
    U = np.zeros((B, m))
    act = np.zeros((B, maxa), np.int64)
    sgn = np.zeros((B, maxa))
    beta = np.zeros((B, maxa))
    W = np.zeros((B, maxa))
    rhs = np.empty(maxa)
    L = np.zeros((B, maxa, maxa))
    GA = np.zeros((B, maxa, maxa))
    state = np.zeros((B, k), np.int8)
    lam = np.zeros(B)
    tiny = np.zeros(B)
    nact = np.zeros(B, np.int64)
    ent = np.full(B, -1, np.int64)
    nsgn = np.zeros(B)
    drp = np.full(B, -1, np.int64)
    nst = np.zeros(B, np.int64)
    rowof = np.full(B, -1, np.int64)
    limit = np.zeros(B, np.int64)
    gcol = np.empty(maxa)
    nxt = 0
    live = 0
    for s in range(B):
        while nxt < nr:
            r = nxt
            nxt += 1
            if _start(D, X0, obsf, alpha, positive, s, r, DTX, C, state, lam, tiny, nact, ent,
                      nsgn, drp, nst, limit, maxa):
                rowof[s] = r
                live += 1
                break
            steps[r] = 0
    while live > 0:
        # 1: enter atoms, directions, u = D_A w on the observed entries
        for s in range(B):
            r = rowof[s]
            if r < 0:
                continue
            nst[s] += 1
            n = nact[s]
            j = ent[s]
            if j >= 0:
                if n >= limit[s]:
                    steps[r] = -nst[s]
                    rowof[s] = -1
                    U[s, :] = 0.0
                    continue
                gjj = 0.0
                for q in range(m):
                    gjj += obsf[r, q] * D[q, j] * D[q, j]
                for i in range(n):
                    ai = act[s, i]
                    g = 0.0
                    for q in range(m):
                        g += obsf[r, q] * D[q, j] * D[q, ai]
                    gcol[i] = g
                for i in range(n):
                    t_ = gcol[i]
                    for t in range(i):
                        t_ -= L[s, i, t] * L[s, n, t]
                    L[s, n, i] = t_ / L[s, i, i]
                d = gjj
                for t in range(n):
                    d -= L[s, n, t] * L[s, n, t]
                if d <= 1e-10 * gjj:
                    state[s, j] = 2
                else:
                    L[s, n, n] = np.sqrt(d)
                    act[s, n] = j
                    sgn[s, n] = nsgn[s]
                    beta[s, n] = 0.0
                    state[s, j] = 1
                    for i in range(n):
                        GA[s, n, i] = gcol[i]
                        GA[s, i, n] = gcol[i]
                    GA[s, n, n] = gjj
                    n += 1
                    nact[s] = n
                ent[s] = -1
            for i in range(n):
                rhs[i] = sgn[s, i]
            _chol_solve(L[s], n, rhs, W[s])
            U[s, :] = 0.0
            for i in range(n):
                wi = W[s, i]
                ai = act[s, i]
                for q in range(m):
                    U[s, q] += wi * D[q, ai]
            for q in range(m):
                U[s, q] *= obsf[r, q]
        # 2: every slot's change of correlations, one BLAS-3 call
        np.dot(U, D, Acor)
        # 3: next event and move (the shipped kernel's scan)
        for s in range(B):
            r = rowof[s]
            if r < 0:
                continue
            n = nact[s]
            a = Acor[s]
            c = C[s]
            st = state[s]
            lm = lam[s]
            al = alpha[r]
            gamma, event, best = _next_event(st, drp[s], a, c, lm, al, tiny[s], positive,
                                             W[s], sgn[s], beta[s], n)
            for i in range(n):
                beta[s, i] += gamma * W[s, i]
            for j in range(k):
                c[j] -= gamma * a[j]
            lam[s] = lm - gamma
            drp[s] = -1
            finished = False
            if event == 0:
                for i in range(n):
                    rhs[i] = DTX[s, act[s, i]] - al * sgn[s, i]
                _chol_solve(L[s], n, rhs, gcol)
                consistent = True
                for i in range(n):
                    if gcol[i] * sgn[s, i] < 0.0:
                        consistent = False
                for i in range(n):
                    coef[r, act[s, i]] = gcol[i] if consistent else beta[s, i]
                steps[r] = nst[s]
                finished = True
            elif event == 3:
                dropped = act[s, best]
                st[dropped] = 0
                last = n - 1
                if best != last:
                    act[s, best] = act[s, last]
                    sgn[s, best] = sgn[s, last]
                    beta[s, best] = beta[s, last]
                    for i in range(n):
                        GA[s, best, i] = GA[s, last, i]
                    for i in range(n):
                        GA[s, i, best] = GA[s, i, last]
                    GA[s, best, best] = GA[s, last, last]
                n -= 1
                nact[s] = n
                drp[s] = dropped
                ok = True
                for i in range(n):
                    for j2 in range(i + 1):
                        t_ = GA[s, i, j2]
                        for t in range(j2):
                            t_ -= L[s, i, t] * L[s, j2, t]
                        if i == j2:
                            if t_ <= 0.0:
                                ok = False
                                break
                            L[s, i, i] = np.sqrt(t_)
                        else:
                            L[s, i, j2] = t_ / L[s, j2, j2]
                    if not ok:
                        break
                if not ok:
                    steps[r] = -nst[s]
                    finished = True
            else:
                ent[s] = best
                nsgn[s] = 1.0 if event == 1 else -1.0
            if not finished and nst[s] >= max_steps:
                steps[r] = -nst[s]
                finished = True
            if finished:
                rowof[s] = -1
        # refill the empty slots
        live = 0
        for s in range(B):
            if rowof[s] < 0:
                U[s, :] = 0.0
                while nxt < nr:
                    r = nxt
                    nxt += 1
                    if _start(D, X0, obsf, alpha, positive, s, r, DTX, C, state, lam, tiny,
                              nact, ent, nsgn, drp, nst, limit, maxa):
                        rowof[s] = r
                        break
                    steps[r] = 0
            if rowof[s] >= 0:
                live += 1


def problems(n):
    """The recovery benchmark's held-out Mix sub-problems, shipped k = 2000 dictionary."""
    from sparseedm.dictionary import load_dictionary
    from sparseedm.edm import observed_entries
    from sparseedm.metrics import random_occlusion
    from sparseedm.normalize import represent

    from . import SHIPPED_K2000, held_out_sample, load_cmu, split_clips

    d = load_dictionary(SHIPPED_K2000)
    poses, clips, _ = load_cmu()
    val = held_out_sample(poses[split_clips(clips)[0]], n, seed=2)
    mask = random_occlusion(len(val), 14, "mix", random_state=0)
    T, _, _ = represent(np.where(mask[..., None], 0, val), mask, "average")
    obs = observed_entries(mask)
    order = np.lexsort(mask.T[::-1])
    X = np.where(obs[order], T[order], 0.0)
    alpha = d.alpha_recover * obs[order].sum(1) / d.n_features
    return np.ascontiguousarray(d.components.T), X, obs[order], alpha


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--slots", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    D, X, obs, alpha = problems(args.n)
    G = D.T @ D
    obsf = obs.astype(float)

    def shipped():
        return lars_lasso_masked(G, D, X, obs, alpha)

    def probe():
        coef = np.zeros((len(X), D.shape[1]))
        steps = np.zeros(len(X), np.int64)
        lockstep(D, X, obsf, alpha, False, 500, coef, steps, args.slots)
        return coef, steps

    out = {}
    with threadpool_limits(1, user_api="blas"):
        for name, fn in (("shipped Gram-row kernel", shipped), ("lockstep BLAS-3", probe)):
            coef, _ = fn()  # compiled and warm
            best = min(_timed(fn) for _ in range(args.repeats))
            out[name] = coef
            print(f"{name}: {len(X) / best:.0f} poses/s on one core (best of {args.repeats})")
    a, b = out.values()
    print(f"largest coefficient difference {np.abs(a - b).max():.1e}; "
          f"rows with another support: {int(((a != 0) != (b != 0)).any(axis=1).sum())}")


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
