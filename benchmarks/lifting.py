"""Lifting benchmark: the coupled-dictionary lifter against DMR's FConn (MLP), one run.

    python -m benchmarks.lifting --cmu /tmp/iss12-lift/cmu.npz \
        [--bandai /tmp/iss12-lift/bandai.npz] [-o benchmarks/results-lifting.json]

Both lifters are learned on the same poses: a seeded subsample of the CMU
training clips of ``lifters/select_lifter.py``'s clip split (the dictionary
with the settings chosen there, ``lifters/selection.json``; the MLP with
``sparseedm.lifting.defaults``). Judged on the CMU validation clips and, across
sources, on Bandai-Namco poses (read from ../shared only; nothing learned from
them): 3D-EDM Err_ave (after one scale per pose) on complete input, and Mix
(1-3 occluded joints) through the joint lasso; speed of ``sparseedm.lift``
(end to end: normalise, lasso or network, MDS + SMACOF, alignment, reflection)
for both lifters in the same process, 1 and 2 threads.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import loadavg, log, machine, versions
from sparseedm.lifting import fit_lifter, lift, training_pairs
from sparseedm.lifting.defaults import DEFAULTS
from sparseedm.lifting.metrics import err_ave_3d
from sparseedm.metrics import random_occlusion

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "lifters"))
from select_lifter import arrays, split  # noqa: E402


def _load(path):
    with np.load(path, allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def judge(lifters, data, ix, seed=1):
    _, _, metric, _ = training_pairs(*arrays(data, ix))
    mask = random_occlusion(len(ix), 14, "mix", random_state=seed)
    out = {}
    for name, lf in lifters.items():
        full = lift(data["poses2d"][ix], lifter=lf)
        occ = lift(data["poses2d"][ix], mask, lifter=lf)
        out[name] = {"complete": float(np.nanmean(err_ave_3d(full.vectors3d, metric))),
                     "mix": float(np.nanmean(err_ave_3d(occ.vectors3d, metric))),
                     "ambiguous_reflection": float(np.mean(full.chirality_margin < 1))}
    return out


def speed(lifters, poses, repeats=3, mask=None):
    rows = {}
    for name, lf in lifters.items():
        lift(poses[:50], lifter=lf)  # warm the JIT caches
        for jobs in (1, 2):
            best = np.inf
            for _ in range(repeats):
                t = time.perf_counter()
                lift(poses, mask, lifter=lf, n_jobs=jobs)
                best = min(best, time.perf_counter() - t)
            rows[f"{name}, n_jobs={jobs}"] = len(poses) / best
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--cmu", required=True)
    ap.add_argument("--bandai", default=None)
    ap.add_argument("--max-train", type=int, default=15000)
    ap.add_argument("--max-test", type=int, default=2000)
    ap.add_argument("--mlp-max-iter", type=int, default=60)
    ap.add_argument("-o", "--output", default=str(ROOT / "benchmarks" / "results-lifting.json"))
    ap.add_argument("--speed-only", nargs=2, metavar=("DICT_LIFTER", "MLP_LIFTER"),
                    help="only time lift() with these two lifter files (no fitting) and "
                    "write results-lifting-speed.json")
    args = ap.parse_args(argv)
    cmu = _load(args.cmu)
    if args.speed_only:
        from sparseedm.lifting import load_lifter

        lifters = {"dictionary": load_lifter(args.speed_only[0]),
                   "mlp": load_lifter(args.speed_only[1])}
        poses = cmu["poses2d"][np.sort(np.random.default_rng(0).choice(
            len(cmu["poses2d"]), args.max_test, replace=False))]
        mask = random_occlusion(len(poses), 14, "mix", random_state=0)
        res = {"machine": machine(), "loadavg_start": loadavg(),
               "lifters": list(args.speed_only),
               "complete": speed(lifters, poses), "mix": speed(lifters, poses, mask=mask),
               "loadavg_end": loadavg()}
        out = Path(args.output).with_name("results-lifting-speed.json")
        out.write_text(json.dumps(res, indent=1))
        print(json.dumps(res, indent=1))
        return
    tr, val = split(cmu)
    rng = np.random.default_rng(0)
    tr = np.sort(rng.choice(tr, min(args.max_train, len(tr)), replace=False))
    val = np.sort(rng.choice(val, min(args.max_test, len(val)), replace=False))
    shipped = json.loads((ROOT / "lifters" / "selection.json").read_text())["shipped"]
    dparams = {k: shipped[k] for k in ("n_components", "alpha", "weight", "alpha_lift",
                                       "normalization")}
    mparams = dict(DEFAULTS["mlp"], max_iter=args.mlp_max_iter)
    lifters, fit_s = {}, {}
    for name, method, params in (("dictionary", "dictionary", dparams), ("mlp", "mlp", mparams)):
        log(f"fit {name} on {len(tr)} poses")
        t = time.perf_counter()
        lifters[name] = fit_lifter(*arrays(cmu, tr), method=method, **params)
        fit_s[name] = time.perf_counter() - t
    res = {"machine": machine(), "versions": versions(), "loadavg_start": loadavg(),
           "n_train": int(len(tr)), "dictionary_params": dparams,
           "mlp_params": {k: list(v) if isinstance(v, tuple) else v for k, v in mparams.items()},
           "fit_seconds": fit_s}
    log("judge on CMU validation clips")
    res["cmu_validation"] = dict(judge(lifters, cmu, val), n_poses=int(len(val)))
    if args.bandai:
        bandai = _load(args.bandai)
        bi = np.sort(rng.choice(len(bandai["poses2d"]), min(args.max_test, len(bandai["poses2d"])),
                                replace=False))
        log("judge on Bandai-Namco (cross-source)")
        res["bandai"] = dict(judge(lifters, bandai, bi), n_poses=int(len(bi)))
    log("speed")
    res["poses_per_s"] = speed(lifters, cmu["poses2d"][val])
    res["loadavg_end"] = loadavg()
    Path(args.output).write_text(json.dumps(res, indent=1))
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
