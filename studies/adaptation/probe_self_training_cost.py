"""Cheaper self-training, tried on the validation splits (one adopted: only
the last round judged, ``today`` now; ``guardall`` is the earlier default).

    python studies/adaptation/probe_self_training_cost.py "cmu->bandai" today a2 a4 ...

A 6,000-pose file per target source, as users' files are: a seeded sample of
the target's *validation* clips (select_adaptation.py's split: sorted clip
index mod 3 == 1), half complete, half occluded by the protocol's Mix masks.
``today`` re-implements recover()'s default path step by step (it reproduces
``recover()``'s answer: the same Err_ave); the variants change one thing each
(VARIANTS). Printed and appended to --out: the Err_ave (%) of the occluded
poses' completed EDMs and the seconds per step. Bandai-Namco data is used
from ../shared, never written anywhere but the --work folder. Results:
dictionaries/README.md, "Self-training cost".
"""
import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.adaptation.select_adaptation import build, split  # noqa: E402
from sparseedm._atomic import json_text
from sparseedm import load_dictionary, recover
from sparseedm.dictionary import Dictionary
from sparseedm.edm import pose_to_vector
from sparseedm.metrics import err_ave, occlusion_masks
from sparseedm.adaptation import run_adaptation, _incomplete_rows
from sparseedm._recovery_kernel import recover_sparse, recover_members
from threadpoolctl import threadpool_limits
warnings.simplefilter("ignore")

DIRS = {"cmu->bandai": ("bandai", "default"), "cmu0103->daz": ("daz", "cmu-k2000"),
        "cmu0103->cmu": ("cmu", "cmu-k2000")}

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
WORK = "/tmp/probe_self_training_cost"


def score(res, P, mask):
    """Mean Err_ave (%) of the occluded poses' completed EDMs."""
    e = err_ave(res.vectors * res.scale[:, None], pose_to_vector(P))
    return float(np.nanmean(np.where(res.ok, e, np.nan)[mask.any(axis=1)]))


def make_file(target, seed=0, n=6000):
    P, clips = build(DATA, WORK, target, 1)
    if target == "cmu":  # subjects other than 01-03 (cmu-k2000 learned on those)
        keep = ~np.isin(np.array([c.split("_")[0] for c in clips]), ["01", "02", "03"])
        P, clips = P[keep], clips[keep]
    _, val, _ = split(P, clips)
    rng = np.random.default_rng(seed)
    P = val[np.sort(rng.choice(len(val), min(n, len(val)), replace=False))]
    occ = np.zeros(len(P), bool); occ[rng.permutation(len(P))[: len(P) // 2]] = True
    mask = np.zeros(P.shape[:2], bool)
    mask[occ] = occlusion_masks(int(occ.sum()), 14, ("mix",), random_state=seed)["mix"]
    return P, mask

def with_atoms(base, comps, factor):
    return Dictionary(components=comps, joint_names=base.joint_names,
                      alpha_recover=base.alpha_recover * factor, alpha_train=base.alpha_train,
                      alpha_scaling=base.alpha_scaling, positive_code=base.positive_code,
                      representation=base.representation, normalization=base.normalization,
                      provenance=dict(base.provenance or {}))

def pipeline(d, X, mask, rounds=3, max_poses=2000, st_alpha=1.0, warm=False, passes=2,
             final_factor=0.5, guard_rounds=False):
    t0 = time.perf_counter(); steps = {}
    with threadpool_limits(1, user_api="blas"):
        r = run_adaptation(d, X, mask, n_jobs=2)
        steps["first"] = time.perf_counter() - t0
        cur = r
        if r.adapted and rounds:
            inc, m = _incomplete_rows(X, mask, max_poses, 0)
            for k in range(rounds):
                t = time.perf_counter()
                rec = recover_sparse(inc, m, dictionary=cur.dictionary, n_jobs=2,
                                     alpha=cur.dictionary.alpha_recover * st_alpha)
                steps[f"rec{k}"] = time.perf_counter() - t
                filled = rec.poses[rec.status == "recovered"]
                start = with_atoms(d, cur.dictionary.components, 1.0) if warm else d
                t = time.perf_counter()
                new = run_adaptation(start, X, mask, extra=filled, n_jobs=2, reuse=r,
                                     passes=passes, guard=guard_rounds or k == rounds - 1)
                steps[f"adapt{k}"] = time.perf_counter() - t
                if not new.adapted:  # rejected: the first adaptation (self_train does so)
                    cur = r
                    break
                cur = new
        final = with_atoms(d, cur.dictionary.components, final_factor) if cur.adapted else d
        t = time.perf_counter()
        res = recover_members(X, mask, [final], [], n_jobs=2)
        steps["final"] = time.perf_counter() - t
    return res, time.perf_counter() - t0, steps

VARIANTS = {
    "today": {}, "off": None,
    "s1000": dict(max_poses=1000), "s600": dict(max_poses=600),
    "a4": dict(st_alpha=4.0), "a2": dict(st_alpha=2.0),
    "warm1": dict(warm=True, passes=1), "f1": dict(final_factor=1.0),
    "r2": dict(rounds=2), "a4": dict(st_alpha=4.0), "a8": dict(st_alpha=8.0), "a4f1": dict(st_alpha=4.0, final_factor=1.0),
    "guardall": dict(guard_rounds=True),  # every round judged (the earlier default)
    "combo": dict(max_poses=1000, st_alpha=4.0, warm=True, passes=1, final_factor=1.0),
    "combo2": dict(max_poses=1000, st_alpha=2.0, warm=True, passes=1),
}

def parser():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("direction", choices=sorted(DIRS))
    ap.add_argument("variants", nargs="+", choices=sorted(VARIANTS), metavar="VARIANT",
                    help=f"one or more of {', '.join(VARIANTS)}")
    return ap


if __name__ == "__main__":
    args = parser().parse_args()
    direction = args.direction
    Path(WORK).mkdir(parents=True, exist_ok=True)
    target, dname = DIRS[direction]
    P, mask = make_file(target)
    X = np.where(mask[..., None], np.nan, P)
    d = load_dictionary(dname)
    recover_sparse(X[:300], mask[:300], dictionary=d)
    for v in args.variants:
        kw = VARIANTS[v]
        t = time.perf_counter()
        if kw is None:
            with threadpool_limits(1, user_api="blas"):
                res = recover_members(X, mask, [d], [], n_jobs=2); steps = {}
            el = time.perf_counter() - t
        else:
            res, el, steps = pipeline(d, X, mask, **kw)
        out = dict(direction=direction, variant=v, err=round(score(res, P, mask), 4),
                   seconds=round(el, 1), steps={k: round(s, 1) for k, s in steps.items()},
                   load=open("/proc/loadavg").read().split()[0])
        print(json.dumps(out), flush=True)
        with open(Path(WORK) / "results.jsonl", "a") as f:
            f.write(json_text(out) + "\n")
