"""Does adapting the lifter's 2D half on 3D-free 2D poses help? Measured across sources.

    python studies/lifting/select_lift_adaptation.py /tmp/lift-adapt/bandai.npz -o /tmp/lift-adapt/bandai.json

The base lifter (shipped ``cmu-lift``, CMU data only) is adapted with
:func:`sparseedm.lifting.adaptation.adapt_lifter` on the complete 2D poses
of some clips of another source (the 3D is not used). The clips are split
three ways (seeded, by clip, so no frame has a near-duplicate across parts):
adaptation clips (their 2D poses adapt the lifter), validation clips (the
settings are chosen on them: mean of complete and Mix 3D-EDM Err_ave) and
scored clips (reported once, for the base and the chosen setting).
Each row also records ``mix2d``, :func:`masked_error_2d` on the same poses:
the only figure a guard without 3D could use. Scores: 3D-EDM Err_ave (after one scale per pose) and PA-MPJPE (mm), complete
input and Mix-occluded input (1-3 joints, the joint lasso on observed entries),
via :func:`sparseedm.lifting.evaluation.evaluate_lifting`.

Never commit the output when the source is Bandai-Namco (CC BY-NC): only the
numbers go into lifters/README.md.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time

import numpy as np

from sparseedm._atomic import json_text
from sparseedm.dataset import load_dataset
from sparseedm.lifting import load_lifter
from sparseedm.lifting.adaptation import adapt_lifter, masked_error_2d
from sparseedm.lifting.evaluation import evaluate_lifting

# round 1 was coarse; round 2 refines where round 1 pointed (both in lifters/README.md)
GRIDS = {
    "round1": {
        "2d-half": {"memory": (1.0, 10.0, 100.0), "passes": (1.0, 3.0), "alpha": (None, 0.2)},
        "reweight": {"gamma": (0.25, 0.5, 1.0), "alpha": (None, 0.2)},
    },
    "round2": {
        "2d-half": {"memory": (30.0, 100.0, 300.0, 1000.0), "passes": (1.0, 3.0)},
        "reweight": {"gamma": (0.25, 0.5, 1.0), "alpha": (0.05, 0.2, 1.0)},
    },
    "round3": {"reweight": {"gamma": (0.25, 0.5, 0.75), "alpha": (1.0, 3.0)}},
}


def split_clips(clips, seed=0, fractions=(0.5, 0.15)):
    names = np.unique(clips)
    order = np.random.default_rng([seed, 12]).permutation(names)
    n_a = int(round(fractions[0] * len(names)))
    n_v = int(round(fractions[1] * len(names)))
    part = {c: 0 for c in order[:n_a]}
    part.update({c: 1 for c in order[n_a:n_a + n_v]})
    part.update({c: 2 for c in order[n_a + n_v:]})
    return np.array([part[c] for c in clips])


def sample(ix, n, seed):
    if len(ix) <= n:
        return ix
    return np.sort(np.random.default_rng([seed, 5, n]).choice(ix, n, replace=False))


def subset(data, ix):
    return {k: data[k][ix] for k in ("poses2d", "poses3d", "camera_R", "camera_t", "camera_f")}


def score(lifter, test, seed):
    rep = evaluate_lifting({"l": lifter}, test, pipelines=["complete", "joint"],
                           counts=("mix",), seed=seed)
    out = {}
    for r in rep.rows:
        key = "complete" if r["pipeline"] == "complete" else "mix"
        out[key] = {"err3d": r["err3d"], "pa_mpjpe": r["pa_mpjpe"]}
    out["criterion"] = 0.5 * (out["complete"]["err3d"] + out["mix"]["err3d"])
    # what a 3D-free guard could see: the 2D half's Mix completion error
    out["mix2d"] = masked_error_2d(lifter, test["poses2d"], random_state=seed)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--lifter", default="cmu-lift")
    ap.add_argument("--n-adapt", type=int, default=3000)
    ap.add_argument("--n-val", type=int, default=400)
    ap.add_argument("--n-score", type=int, default=800)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--method", default="2d-half", choices=("2d-half", "reweight"))
    ap.add_argument("--grid", default="round2", choices=sorted(GRIDS))
    ap.add_argument("--control", help="a dataset .npz of the lifter's own source: the "
                    "chosen setting is also applied with its 2D poses (no domain shift), "
                    "to tell adaptation from a generic change of the lifter")
    ap.add_argument("--in-source", action="store_true",
                    help="DATA is the lifter's own source: fit a k=1000 lifter on its "
                    "adaptation clips, adapt it (each method) on 3,000 of its own training "
                    "poses and score all on the scored clips (what does adapting in-source "
                    "cost?)")
    ap.add_argument("--only", nargs="*", help="with --final: these methods only")
    ap.add_argument("--final", action="store_true",
                    help="no grid: score the shipped defaults of both methods on the "
                    "scored clips, adapted on the target poses and on --control poses")
    a = ap.parse_args(argv)
    data = load_dataset(a.data)
    part = split_clips(data["clips"], a.seed)
    ia = sample(np.flatnonzero(part == 0), a.n_adapt, a.seed)
    iv = sample(np.flatnonzero(part == 1), a.n_val, a.seed)
    isc = sample(np.flatnonzero(part == 2), a.n_score, a.seed)
    base = load_lifter(a.lifter)
    val, scored = subset(data, iv), subset(data, isc)
    if a.in_source:
        return in_source(a, data, part)
    if a.final:
        return final(a, data, ia, isc, iv)
    grid = GRIDS[a.grid][a.method]
    result = {"data": a.data, "lifter": a.lifter, "seed": a.seed, "method": a.method,
              "grid_name": a.grid,
              "n": {"adapt": len(ia), "val": len(iv), "scored": len(isc)},
              "clips": {"adapt": int(len(np.unique(data["clips"][part == 0]))),
                        "val": int(len(np.unique(data["clips"][part == 1]))),
                        "scored": int(len(np.unique(data["clips"][part == 2])))},
              "grid": [], "base": {"val": score(base, val, a.seed)}}
    print("base val", result["base"]["val"], flush=True)
    for values in itertools.product(*grid.values()):
        setting = dict(zip(grid, values))
        t0 = time.perf_counter()
        lf = adapt_lifter(base, data["poses2d"][ia], method=a.method, random_state=a.seed,
                          **setting)
        sec = time.perf_counter() - t0
        row = dict(setting, adapt_s=sec, val=score(lf, val, a.seed))
        result["grid"].append(row)
        print(json.dumps(row), flush=True)
    best = min(result["grid"], key=lambda r: r["val"]["criterion"])
    result["chosen"] = {k: best[k] for k in grid}
    lf = adapt_lifter(base, data["poses2d"][ia], method=a.method, random_state=a.seed,
                      **result["chosen"])
    result["base"]["scored"] = score(base, scored, a.seed)
    result["adapted_scored"] = score(lf, scored, a.seed)
    print("scored base", result["base"]["scored"], "adapted", result["adapted_scored"],
          flush=True)
    if a.control:
        ctl = load_dataset(a.control)
        ic = sample(np.arange(len(ctl["poses2d"])), len(ia), a.seed)
        lf = adapt_lifter(base, ctl["poses2d"][ic], method=a.method, random_state=a.seed,
                          **result["chosen"])
        result["control_scored"] = score(lf, scored, a.seed)
        print("scored control", result["control_scored"], flush=True)
    with open(a.output, "w") as f:
        f.write(json_text(result, indent=1))


def in_source(a, data, part):
    from sparseedm.lifting import fit_lifter

    itr = sample(np.flatnonzero(part == 0), 15000, a.seed)
    isc = sample(np.flatnonzero(part == 2), a.n_score, a.seed)
    t0 = time.perf_counter()
    base = fit_lifter(*(subset(data, itr)[k] for k in ("poses2d", "poses3d", "camera_R",
                                                         "camera_t", "camera_f")),
                      n_components=1000, random_state=a.seed)
    fit_s = time.perf_counter() - t0
    scored = subset(data, isc)
    result = {"n": {"train": len(itr), "scored": len(isc)}, "fit_s": fit_s,
              "base": score(base, scored, a.seed)}
    print("base", json.dumps(result["base"]), flush=True)
    own = data["poses2d"][sample(itr, a.n_adapt, a.seed)]
    for name, setting in FINAL.items():
        lf = adapt_lifter(base, own, random_state=a.seed, **setting)
        result[f"{name}/own"] = score(lf, scored, a.seed)
        print(f"{name}/own", json.dumps(result[f"{name}/own"]), flush=True)
    with open(a.output, "w") as f:
        f.write(json_text(result, indent=1))


FINAL = {"reweight": {"method": "reweight"},  # the defaults of adapt_lifter
         "2d-half": {"method": "2d-half", "memory": 100.0, "passes": 1.0},
         "both": {"method": "both", "memory": 100.0, "passes": 1.0}}


def final(a, data, ia, isc, iv):
    """Base, and each method adapted on the target's and on the control's poses.

    Each target row is also scored on the validation clips (``.../val``): the
    choice among methods is made there.
    """
    base = load_lifter(a.lifter)
    scored = subset(data, isc)
    result = {"data": a.data, "control": a.control, "n": {"adapt": len(ia), "scored": len(isc)},
              "base": score(base, scored, a.seed)}
    print("base", json.dumps(result["base"]), flush=True)
    sources = {"target": data["poses2d"][ia]}
    if a.control:
        ctl = load_dataset(a.control)
        sources["control"] = ctl["poses2d"][sample(np.arange(len(ctl["poses2d"])), len(ia),
                                                   a.seed)]
    for name, setting in FINAL.items():
        if a.only and name not in a.only:
            continue
        for src, poses in sources.items():
            lf = adapt_lifter(base, poses, random_state=a.seed, **setting)
            if src == "target":
                result[f"{name}/val"] = score(lf, subset(data, iv), a.seed)
                print(f"{name}/val", json.dumps(result[f"{name}/val"]), flush=True)
            result[f"{name}/{src}"] = score(lf, scored, a.seed)
            print(f"{name}/{src}", json.dumps(result[f"{name}/{src}"]), flush=True)
    with open(a.output, "w") as f:
        f.write(json_text(result, indent=1))


if __name__ == "__main__":
    main()
