"""Should the dictionary lifter down-weight the 2D EDM entries touching a filled joint?

    python studies/lifting/select_lift_weight.py /tmp/lift/cmu.npz --lifter L.npz -o studies/lifting/selection_weight.json

A joint filled across time comes with a 2D 90 % radius r. The candidate: in
the lifting lasso, weight each 2D EDM entry (i, j) by ``w_i w_j`` with
``w = 1 / (1 + (r / (s h))^2)`` (h the diagonal of the pose's 2D bounding
box; w = 1 for an observed joint), i.e. solve the lasso on rows scaled by ``sqrt(w_i w_j)``. Judged on
CMU validation clips (``select_lifter.py``'s split; `L` a dictionary lifter
with the shipped settings fitted on the training clips), the clips halved
(seed 1): ``calib`` chooses s, ``check`` reports. Filled poses are simulated:
the Mix-occluded joints (1-3) put back at the truth plus 2D Gaussian noise
whose 90 % circle is r, drawn log-uniformly between 0.5 %
and 20 % of h (time fills range from under 1 % of the body's size in short gaps to
20 % for a joint never seen in a clip). Scores: MPJPE and
N-MPJPE (mm) of the filled poses; s = inf is today's lift (no weight), s = 0
drops the filled joints (lifts from the others).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from sparseedm._atomic import json_text
from sparseedm.edm import triu_indices
from sparseedm.lifting import load_lifter, training_pairs
from sparseedm.lifting.lift import poses_from_vectors
from sparseedm.lifting.metrics import mpjpe
from sparseedm.metrics import random_occlusion
from sparseedm.normalize import represent
from sparseedm.solvers import get_solver

sys.path.insert(0, str(Path(__file__).resolve().parent))
from select_lifter import arrays, split  # noqa: E402

#: the simulated 2D radii, a fraction of the pose's height drawn log-uniformly between
RADII = (0.005, 0.2)
SCALES = (0.0, 0.005, 0.01, 0.02, 0.05, 0.1, float("inf"))


def weighted_lift(lf, poses, joint_w):
    """3D poses from a lasso whose 2D entries are weighted by ``w_i w_j`` (w = 0: dropped)."""
    n, N = joint_w.shape
    mask = joint_w <= 0
    X2, _, _ = represent(np.where(mask[..., None], np.nan, poses), mask, "average")
    C = lf.components_
    m = C.shape[1] // 2
    r, c = triu_indices(N)
    solver = get_solver("fast")
    Y = np.full((n, m), np.nan)
    for i in range(n):
        we = joint_w[i, r] * joint_w[i, c]
        keep = we > 0
        sw = np.sqrt(we[keep])
        res = solver.solve(C[:, :m].T[keep] * sw[:, None], (X2[i, keep] * sw)[None],
                           lf.alpha_lift * keep.sum() / m)
        Y[i] = res.coef[0] @ C[:, m:] / lf.weight
    P, _, _ = poses_from_vectors(lf, Y, poses, mask)
    return P


def score(lf, data, ix, seed):
    _, _, _, truth = training_pairs(*arrays(data, ix), lf.normalization)
    p2 = data["poses2d"][ix]
    mask = random_occlusion(len(ix), 14, "mix", random_state=seed)
    rng = np.random.default_rng(seed)
    h = np.linalg.norm(np.ptp(p2, axis=1), axis=-1)
    lo, hi = RADII
    f = np.exp(rng.uniform(np.log(lo), np.log(hi), len(ix)))
    r = np.where(mask, (f * h)[:, None], 0.0)
    noisy = p2 + rng.standard_normal(p2.shape) * (r / np.sqrt(2 * np.log(10)))[..., None]
    out = {}
    for s in SCALES:
        w = 1.0 / (1.0 + (r / (s * h[:, None])) ** 2) if 0 < s < np.inf else (
            np.where(mask, 0.0, 1.0) if s == 0 else np.ones_like(r))
        P = weighted_lift(lf, noisy, w)
        out[str(s)] = {"mpjpe": round(float(np.nanmean(mpjpe(P, truth))), 2),
                       "n_mpjpe": round(float(np.nanmean(mpjpe(P, truth, align="scale"))), 2)}
        print(s, out[str(s)], flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("train")
    ap.add_argument("--lifter", required=True)
    ap.add_argument("-o", "--output", default="selection_weight.json")
    ap.add_argument("--max-val", type=int, default=600)
    args = ap.parse_args(argv)
    with np.load(args.train, allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    lf = load_lifter(args.lifter)
    _, val = split(data)
    clips = np.unique(data["clips"][val])
    first = set(np.random.default_rng(1).choice(clips, len(clips) // 2, replace=False).tolist())
    in_first = np.array([c in first for c in data["clips"][val]])
    rng = np.random.default_rng(0)
    res = {}
    for name, part in (("calib", val[in_first]), ("check", val[~in_first])):
        ix = np.sort(rng.choice(part, min(args.max_val, len(part)), replace=False))
        res[name] = score(lf, data, ix, seed=2 if name == "calib" else 3)
    best = min(SCALES, key=lambda s: res["calib"][str(s)]["n_mpjpe"])
    doc = {"data": "CMU validation clips (select_lifter.py split), halved by clip",
           "radii": "log-uniform %g-%g of the diagonal of the pose's 2D bounding box" % RADII,
           "n_poses_per_half": args.max_val, "results": res, "best_on_calib": best}
    with open(args.output, "w") as f:
        f.write(json_text(doc, indent=1))
    print(json.dumps(doc["best_on_calib"]))


if __name__ == "__main__":
    main()
