"""Where ``recover`` spends its time: a cProfile breakdown by stage.

    python -m benchmarks.breakdown [--n N]

Runs ``recover(solver="fast", n_jobs=1)`` on held-out CMU poses under Mix
occlusion (the recovery benchmark's protocol) with the shipped k = 2000
dictionary, under cProfile, and reports the cumulative time of each stage.
Stages are found by function name, so the same script profiles older
versions of the code (``PYTHONPATH=<old checkout> python -m benchmarks.breakdown``)
for a before/after comparison; a stage a version does not have shows "-".
cProfile adds its own overhead to Python-level work (not to compiled kernels).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

import numpy as np
from threadpoolctl import threadpool_limits

from sparseedm import recover
from sparseedm.dictionary import load_dictionary
from sparseedm.metrics import random_occlusion

from . import SHIPPED_K2000, held_out_sample, load_cmu, split_clips

#: stage -> (file suffix, function names); cumulative times are summed
STAGES = {
    "normalise (represent)": ("normalize.py", ("represent",)),
    "Gram matrices": ("fast.py", ("_gram",)),
    "LARS kernels (incl. their Gram rows)": ("fast.py", ("lars_lasso_rows", "lars_lasso_gram",
                                                         "lars_lasso_masked")),
    "certificate (duality gap)": ("base.py", ("duality_gap",)),
    "Clarabel fallback": ("base.py", ("_fall_back",)),
    "joint placement": ("placement.py", ("place_missing_joints",)),
}


def profile(n=2000):
    dictionary = load_dictionary(SHIPPED_K2000)
    poses, clips, _ = load_cmu()
    is_val, _ = split_clips(clips)
    val = held_out_sample(poses[is_val], n, seed=2)
    mask = random_occlusion(len(val), 14, "mix", random_state=0)
    P = np.where(mask[..., None], np.nan, val)
    recover(P, mask, dictionary=dictionary)  # warm: every kernel compiled, Gram cached

    prof = cProfile.Profile()
    t0 = time.perf_counter()
    with threadpool_limits(None):
        prof.runcall(recover, P, mask, dictionary=dictionary)
    wall = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats
    cum = {}
    for (path, _, func), (_, _, _, ct, _) in stats.items():
        for stage, (suffix, names) in STAGES.items():
            if path.endswith(suffix) and func in names:
                cum[stage] = cum.get(stage, 0.0) + ct
    total = next(ct for (path, _, func), (_, _, _, ct, _) in stats.items()
                 if path.endswith("_recovery_kernel.py") and func == "recover_sparse")
    cum["other (validation, grouping, tasks, merge, assembly)"] = total - sum(cum.values())
    return dict(n=n, wall=wall, total=total, stages=cum)


def render(res):
    lines = [f"{res['n']:,} Mix poses, `recover(solver='fast', n_jobs=1)` under cProfile: "
             f"{res['total']:.2f} s ({res['n'] / res['wall']:.0f} poses/s with the profiler).",
             "", "| stage | seconds | share |", "|---|---|---|"]
    for stage in list(STAGES) + ["other (validation, grouping, tasks, merge, assembly)"]:
        t = res["stages"].get(stage)
        cells = ("-", "-") if t is None else (f"{t:.3f}", f"{100 * t / res['total']:.1f}%")
        lines.append(f"| {stage} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    args = ap.parse_args(argv)
    print(render(profile(args.n)))


if __name__ == "__main__":
    main()
