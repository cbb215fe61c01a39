"""Choose the dictionary lifter's settings on a clip-level validation split of CMU data.

    python studies/lifting/select_lifter.py /tmp/lift/cmu.npz -o studies/lifting/selection.json

The CMU training set (``sparseedm dataset build ../shared/data/cmu-mocap``) is
split by clip (a seeded fifth of the clips held out, so no validation frame has
a near-duplicate in training); each setting is learned on a seeded subsample
of the training clips and judged on validation poses, complete and Mix-occluded
(1-3 joints, coded on the observed entries only). Criterion: the mean of the
complete and Mix 3D-EDM Err_ave (after one scale per pose). Stage 1 picks the
3D normalisation and the training alpha at w = 1, k = 1000; stage 2 the weight
w and atom count k; every fit sweeps the lifting alpha (cheap).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from sparseedm._atomic import json_text
from sparseedm.lifting import fit_lifter, lift, training_pairs
from sparseedm.lifting.metrics import err_ave_3d
from sparseedm.metrics import random_occlusion

ALPHA_LIFT = (0.0005, 0.002, 0.01, 0.05)


def split(data, seed=0, frac=0.2):
    clips = np.unique(data["clips"])
    rng = np.random.default_rng(seed)
    val = set(rng.choice(clips, int(round(frac * len(clips))), replace=False).tolist())
    is_val = np.array([c in val for c in data["clips"]])
    return np.flatnonzero(~is_val), np.flatnonzero(is_val)


def arrays(data, ix):
    return (data["poses2d"][ix], data["poses3d"][ix], data["camera_R"][ix],
            data["camera_t"][ix], data["camera_f"][ix])


def judge(lifter, data, val, mask):
    _, X3, _, _ = training_pairs(*arrays(data, val), lifter.normalization)
    out = {}
    for a in ALPHA_LIFT:
        lifter.alpha_lift = a
        t = time.perf_counter()
        full = lift(data["poses2d"][val], lifter=lifter)
        sec = time.perf_counter() - t
        occ = lift(data["poses2d"][val], mask, lifter=lifter)
        c = float(np.nanmean(err_ave_3d(full.vectors3d, X3)))
        m = float(np.nanmean(err_ave_3d(occ.vectors3d, X3)))
        out[str(a)] = {"complete": round(c, 3), "mix": round(m, 3),
                       "score": round((c + m) / 2, 3), "poses_per_s": round(len(val) / sec, 1)}
    best = min(out, key=lambda k: out[k]["score"])
    return out, float(best)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("train")
    ap.add_argument("-o", "--output", default="selection.json")
    ap.add_argument("--max-train", type=int, default=15000)
    ap.add_argument("--max-val", type=int, default=1500)
    ap.add_argument("--stage", type=int, default=0, help="0 = both stages")
    args = ap.parse_args(argv)
    with np.load(args.train, allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    tr, val = split(data)
    rng = np.random.default_rng(0)
    tr = np.sort(rng.choice(tr, min(args.max_train, len(tr)), replace=False))
    val = np.sort(rng.choice(val, min(args.max_val, len(val)), replace=False))
    mask = random_occlusion(len(val), 14, "mix", random_state=1)
    results = []

    def run(**p):
        t = time.perf_counter()
        lf = fit_lifter(*arrays(data, tr), method="dictionary", **p)
        fit_s = time.perf_counter() - t
        grid, best = judge(lf, data, val, mask)
        row = dict(p, fit_seconds=round(fit_s, 1), alpha_lift_grid=grid, best_alpha_lift=best,
                   best=grid[str(best)])
        results.append(row)
        print(json.dumps({k: v for k, v in row.items() if k != "alpha_lift_grid"}), flush=True)
        return row

    if args.stage in (0, 1):
        for norm in ("tied", "unit"):
            for a in (0.2, 1.6):
                run(normalization=norm, alpha=a, weight=1.0, n_components=1000)
    if args.stage in (0, 2):
        first = min(results, key=lambda r: r["best"]["score"]) if results else dict(
            normalization="tied", alpha=0.2)
        for w, k in ((0.5, 1000), (2.0, 1000), (1.0, 500), (1.0, 2000)):
            run(normalization=first["normalization"], alpha=first["alpha"], weight=w,
                n_components=k)
    chosen = min(results, key=lambda r: r["best"]["score"])
    doc = {
        "data": "CMU cmu-mocap (sparseedm dataset build --seed 0), split by clip (seed 0, "
                "a fifth of the clips held out)",
        "n_train": int(len(tr)), "n_val": int(len(val)),
        "criterion": "mean of complete and Mix 3D-EDM Err_ave (per cent, after one "
                     "least-squares scale per pose)",
        "results": results,
        "chosen": {k: chosen[k] for k in ("normalization", "alpha", "weight", "n_components",
                                          "best_alpha_lift", "best")},
    }
    with open(args.output, "w") as f:
        f.write(json_text(doc, indent=1))
    print("chosen:", json.dumps(doc["chosen"]))


if __name__ == "__main__":
    main()
