"""Calibrate the 3D radius of lifted joints (:mod:`sparseedm.lifting.uncertainty3d`) on CMU.

    python studies/uncertainty/lift3d.py /tmp/lift/cmu.npz -o studies/uncertainty/lift3d.json

The CMU training set (``sparseedm dataset build ../shared/data/cmu-mocap``) is
split by clip as ``studies/lifting/select_lifter.py`` splits it; a dictionary
lifter with the shipped settings is fitted on (a subsample of) the training
clips, and the validation clips are split in two halves by clip: the numbers
are chosen on the first ("calib") and their coverage checked on the second.

* per joint, the 90 % quantile of the 3D error (pelvis-centred, the lift at
  the size prior against the true pose in metres) relative to the size prior:
  of joints seen in 2D (complete and Mix-occluded poses) and of joints missing
  in 2D (Mix, 1-3 joints);
* filled joints: the Mix-occluded joints are put back at the truth plus 2D
  Gaussian noise whose 90 % circle is a radius r drawn log-uniformly between
  0.5 % and 20 % of the diagonal of the pose's 2D bounding box (what a
  calibrated time fill claims), the pose is lifted as lift() lifts filled
  joints (their 2D entries down-weighted by their radius), and the factor on the re-lift spread is the grid value whose
  coverage of the filled joints is closest to 90 %.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from sparseedm._atomic import json_text
from sparseedm.lifting import fit_lifter, lift, load_lifter, training_pairs
from sparseedm.lifting import uncertainty3d as u3
from sparseedm.lifting.defaults import DEFAULTS
from sparseedm.lifting.lift import lift_reflections, poses_from_vectors
from sparseedm.lifting.metrics import mpjpe, pelvis
from sparseedm.metrics import random_occlusion
from sparseedm.normalize import represent

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lifting"))
from select_lifter import arrays, split  # noqa: E402

FACTORS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0)


def errors(P, truth, size_prior):
    """Per-joint distance (n, N) between pelvis-centred poses, in size priors."""
    p = P - pelvis(P)[:, None]
    t = truth - pelvis(truth)[:, None]
    return np.linalg.norm(p - t, axis=-1) / size_prior


def measure(lf, data, ix, seed):
    """Errors (in size priors) and spreads of one half of the validation poses."""
    _, _, _, truth = training_pairs(*arrays(data, ix), lf.normalization)
    p2 = data["poses2d"][ix]
    k = lf.size_prior_
    mask = random_occlusion(len(ix), 14, "mix", random_state=seed)
    full = lift(p2, lifter=lf)
    occ = lift(p2, mask, lifter=lf)
    rng = np.random.default_rng(seed)
    size = np.linalg.norm(np.ptp(p2, axis=1), axis=-1)
    frac = np.exp(rng.uniform(np.log(0.005), np.log(0.2), len(ix)))
    r2 = np.where(mask, (frac * size)[:, None], 0.0)
    noisy = p2 + rng.standard_normal(p2.shape) * (r2 / np.sqrt(2 * np.log(10)))[..., None]
    none = np.zeros_like(mask)
    w = u3.filled_weights(noisy, none, mask, r2)   # as lift() weighs filled joints
    Y, _ = lf.predict(represent(noisy, none, "average")[0], none, weights=w)
    fil = poses_from_vectors(lf, Y, noisy, none)[0]
    spread = u3.spread3d(lambda p: lift_reflections(lf, p, weights=w), noisy, mask, r2) / k
    return {"complete": errors(full.poses3d, truth, k), "mix": errors(occ.poses3d, truth, k),
            "filled": errors(fil, truth, k), "mask": mask, "spread": spread,
            "mpjpe_complete": float(np.nanmean(mpjpe(full.poses3d, truth))),
            "n_mpjpe_complete": float(np.nanmean(mpjpe(full.poses3d, truth, align="scale"))),
            "mpjpe_mix": float(np.nanmean(mpjpe(occ.poses3d, truth))),
            "n_mpjpe_mix": float(np.nanmean(mpjpe(occ.poses3d, truth, align="scale")))}


def table(m):
    obs = [np.concatenate([m["complete"][:, j], m["mix"][~m["mask"][:, j], j]]) for j in range(14)]
    miss = [m["mix"][m["mask"][:, j], j] for j in range(14)]
    return (np.array([np.nanquantile(o, 0.9) for o in obs]),
            np.array([np.nanquantile(o, 0.9) for o in miss]))


def coverage(m, base_obs, base_miss, factor):
    mask = m["mask"]
    filled_r = np.sqrt(base_obs ** 2 + (factor * m["spread"]) ** 2)
    cov = {"complete": m["complete"] <= base_obs, "mix_observed": (m["mix"] <= base_obs)[~mask],
           "mix_missing": (m["mix"] <= base_miss)[mask],
           "filled_joints": (m["filled"] <= filled_r)[mask],
           "filled_poses_other_joints": (m["filled"] <= filled_r)[~mask]}
    return {k: round(float(np.mean(v)), 4) for k, v in cov.items()}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("train")
    ap.add_argument("-o", "--output", default="lift3d.json")
    ap.add_argument("--lifter", help="a lifter fitted on the training clips (else fitted here)")
    ap.add_argument("--max-train", type=int, default=15000)
    ap.add_argument("--max-val", type=int, default=800)
    args = ap.parse_args(argv)
    with np.load(args.train, allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    tr, val = split(data)
    rng = np.random.default_rng(0)
    if args.lifter:
        lf = load_lifter(args.lifter)
    else:
        tr = np.sort(rng.choice(tr, min(args.max_train, len(tr)), replace=False))
        lf = fit_lifter(*arrays(data, tr), method="dictionary", **DEFAULTS["dictionary"])
    clips = np.unique(data["clips"][val])
    first = set(np.random.default_rng(1).choice(clips, len(clips) // 2, replace=False).tolist())
    in_first = np.array([c in first for c in data["clips"][val]])
    halves = {}
    for name, part in (("calib", val[in_first]), ("check", val[~in_first])):
        ix = np.sort(rng.choice(part, min(args.max_val, len(part)), replace=False))
        halves[name] = measure(lf, data, ix, seed=2 if name == "calib" else 3)
    base_obs, base_miss = table(halves["calib"])
    grid = {f: coverage(halves["calib"], base_obs, base_miss, f) for f in FACTORS}
    factor = min(FACTORS, key=lambda f: abs(grid[f]["filled_joints"] - 0.9))
    doc = {
        "data": "CMU cmu-mocap, validation clips of studies/lifting/select_lifter.py's split "
                "(seed 0), halved by clip (seed 1): calib chooses, check reports",
        "lifter": "dictionary, shipped settings, fitted on <= %d training-clip poses" % args.max_train,
        "n_poses": {k: int(len(v["mask"])) for k, v in halves.items()},
        "base_observed": [round(float(x), 4) for x in base_obs],
        "base_missing": [round(float(x), 4) for x in base_miss],
        "spread_factor_grid": {str(f): v for f, v in grid.items()},
        "spread_factor": factor,
        "n_perturbations": u3.N_PERTURBATIONS,
        "coverage_check": coverage(halves["check"], base_obs, base_miss, factor),
        "mpjpe_mm": {k: {m: round(v[m], 1) for m in v if "mpjpe" in m}
                     for k, v in halves.items()},
        "mean_radius_m": {
            "observed": round(float(base_obs.mean() * lf.size_prior_), 4),
            "missing": round(float(base_miss.mean() * lf.size_prior_), 4)},
    }
    with open(args.output, "w") as f:
        f.write(json_text(doc, indent=1))
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
