"""Probe: does re-fitting the read-out of an adapted dictionary help recovery?

    python studies/adaptation/probe_readout_refit.py "cmu->bandai" [DATA_DIR] [WORK]

The lifter's 3D halves gained 7-8 % from a re-fit to the codes lifting computes
(lifters/README.md). The same idea for 2D recovery: adapt the default on
3,000 complete poses of the target's adaptation clips (``run_adaptation``
defaults), code those poses under three seeded Mix masks each as recovery
does, and re-fit the atoms to the complete vectors by ridge regression on
those codes (one k x k solve over all 91 entries, shrunk towards the adapted
atoms); the codes are unchanged and, by Eq. 10, only the missing entries of a
recovered pose are read from the re-fitted atoms. Scored on 600 poses of the *validation* clips of
``select_adaptation.py``'s split (Mix masks of the guard), Err_ave of the
filled EDM vectors. Result in dictionaries/README.md ("Read-out re-fit").
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.sparse import csr_matrix
from scipy.sparse import vstack as svstack

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.adaptation.select_adaptation import build, sample, source_dictionary, split  # noqa: E402
from sparseedm.adaptation import guard_masks, masked_error, run_adaptation  # noqa: E402
from sparseedm.edm import observed_entries, pose_to_vector  # noqa: E402
from sparseedm.metrics import err_ave  # noqa: E402
from sparseedm.normalize import represent  # noqa: E402
from sparseedm.solvers import get_solver  # noqa: E402


def codes(D, P, mask, key):
    """Recovery's lasso codes of poses P under `mask` (n, k), their normalised X and scale."""
    C = D.components
    m = C.shape[1]
    X, _, scale = represent(np.where(mask[..., None], np.nan, P), mask, "average")
    obs = observed_entries(mask)
    alpha = D.alpha_recover * obs.sum(1) / m
    out = get_solver("fast").solve_masked(C.T, np.where(obs, X, 0), obs, alpha, key=key)
    return out.coef, X, obs, scale


def parser():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("direction", help='source->target, e.g. "cmu->bandai"')
    ap.add_argument("data_dir", nargs="?", default="../shared/data")
    ap.add_argument("work", nargs="?", default="/tmp/select_adaptation",
                    help="the training sets and dictionaries of select_adaptation.py")
    return ap


def main(argv=None):
    args = parser().parse_args(argv)
    src, dst = args.direction.split("->")
    data_dir, work = args.data_dir, args.work
    base = source_dictionary(src, data_dir, work)
    poses, clips = build(data_dir, work, dst, {"cmu": 0, "bandai": 1, "daz": 0}[dst])
    pool, val, _ = split(poses, clips)
    scored, A = sample(val, 600, 1), sample(pool, 3000, 2)
    t = time.time()
    D = run_adaptation(base, A, n_jobs=2).dictionary
    print(f"{args.direction}: adapted in {time.time() - t:.1f} s; Mix Err_ave cold "
          f"{masked_error(base, scored):.3f}, adapted {masked_error(D, scored):.3f}", flush=True)
    C = D.components
    Z, Y = [], []
    for r in range(3):  # three seeded Mix masks per adaptation pose
        coef, _, _, scale = codes(D, A, guard_masks(len(A), 14, None, 100 + r), ("ro", r))
        Z.append(csr_matrix(coef))
        Y.append(pose_to_vector(A) / scale[:, None])
    Z, Y = svstack(Z).tocsr(), np.vstack(Y)
    G, B = (Z.T @ Z).toarray(), Z.T @ Y
    mask = guard_masks(len(scored), 14, None, 0)
    coef, X, obs, scale = codes(D, scored, mask, ("scored",))
    truth = pose_to_vector(scored)

    def score(atoms):
        filled = np.where(obs, X, coef @ atoms)  # Eq. 10
        return float(np.nanmean(err_ave(filled * scale[:, None], truth)))

    print(f"adapted atoms: {score(C):.3f}", flush=True)
    for rho in (1e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1):
        lam = rho * Z.shape[0]
        atoms = cho_solve(cho_factor(G + lam * np.eye(len(G))), B + lam * C)
        print(f"re-fitted, rho {rho:g}: {score(atoms):.3f}", flush=True)


if __name__ == "__main__":
    main()
