"""Probe (not adopted): the lasso on a working set of the K atoms nearest to each
pose's observed entries (cosine over those entries), from the shipped dictionary
or from CMU training poses as exemplar atoms (every second pose of the
`sparseedm dataset build` sets given), against recover(adapt=False).

    python studies/real_prior/probe_working_set.py mpii 1,3 cmu_asf.npz daz_*.npz
"""
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
warnings.filterwarnings("ignore")
import numpy as np  # noqa: E402
import harness as H  # noqa: E402
from sklearn.linear_model import Lasso  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.normalize import represent  # noqa: E402
from sparseedm.edm import observed_entries, vector_to_edm  # noqa: E402
from sparseedm.placement import place_missing_joints  # noqa: E402
from sparseedm.learning import complete_pose_vectors  # noqa: E402
from benchmarks import real2d  # noqa: E402


def nn_recover(truth, missing, A, K, alpha=0.0005):
    out = truth.copy()
    occ = np.flatnonzero(missing.any(1))
    g = np.where(missing[..., None], np.nan, truth)
    T, c, s = represent(g[occ], missing[occ], "average")
    obs = observed_entries(missing[occ])
    V = np.empty_like(T)
    for r in range(len(occ)):
        o = obs[r]; y = T[r, o]; Ao = A[:, o]
        sim = Ao @ y / (np.linalg.norm(Ao, axis=1) + 1e-12)
        top = np.argsort(-sim)[:K]
        las = Lasso(alpha=alpha / 91, fit_intercept=False, max_iter=5000, tol=1e-8).fit(Ao[top].T, y)
        V[r] = np.where(o, T[r], las.coef_ @ A[top])
    for k in np.unique(missing[occ].sum(1)):
        rr = np.flatnonzero(missing[occ].sum(1) == k)
        rows = occ[rr]
        normed = (np.where(missing[rows, :, None], 0, truth[rows]) - c[rr, None]) / s[rr, None, None]
        P = place_missing_joints(normed, vector_to_edm(V[rr]), missing[rows])
        f = normed.copy(); f[missing[rows]] = P.reshape(-1, 2)
        out[rows] = f * s[rr, None, None] + c[rr, None]
    return out


def main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sources", help="harness files, comma-separated (mpii, coco, bonn...)")
    ap.add_argument("protocols", help="harness protocols, comma-separated (1,2,3,real)")
    ap.add_argument("data", nargs="+", help="dataset .npz files: the exemplar atoms")
    a = ap.parse_args(argv)
    D = load_dictionary().components
    ex = [np.load(f, allow_pickle=False)['poses2d'] for f in a.data]
    X, _ = complete_pose_vectors(np.concatenate(ex)); X = X[::2]
    X = X / np.linalg.norm(X, axis=1, keepdims=True)
    for src in a.sources.split(','):
        rs = real2d.load(H.FILES[src][0])
        for p in a.protocols.split(','):
            truth, missing = H.make_file(src, p, 0, None, rs)
            row = {"cold": H.score(H.METHODS["cold"](truth, missing), truth, missing)}
            for name, A in [("dict", D), ("exemplars", X)]:
                for K in [200, 1000]:
                    row[f"{name}_K{K}"] = H.score(nn_recover(truth, missing, A, K), truth,
                                                  missing)
            print(src, p, {k: round(v, 3) for k, v in row.items()}, flush=True)


if __name__ == "__main__":
    main()
