"""Where ``recover`` spends its time: a cProfile breakdown by stage.

    python -m benchmarks.breakdown [--n N]
    python -m benchmarks.breakdown --photo mpii|coco|bonn [--bandai N]

Runs ``recover(solver="fast", n_jobs=1)`` on held-out CMU poses under Mix
occlusion (the recovery benchmark's protocol) with the shipped k = 2000
dictionary, under cProfile, and reports the cumulative time of each stage.
``--photo`` profiles ``recover()`` with its defaults (``n_jobs=1``) on a real
people's validation photo file instead (:mod:`benchmarks.real_people`'s: the
split's complete poses, half of them under Mix masks, seed 0); ``--bandai N``
on the default-path benchmark's file of N Bandai-Namco poses
(:func:`benchmarks.default_path.make_file`). Both report the default path's
steps (what ``recover`` calls in turn) and the kernels under them.
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

from . import SHIPPED_K2000, held_out_sample, load_cmu, loadavg, split_clips

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


#: the default path's steps: (caller's file suffix, caller, callee's file suffix, callee)
STEPS = {
    "choice of atoms (held-back check, adapt_members)": ("recovery.py", "_dispatch",
                                                         "ensemble.py", "adapt_members"),
    "the answer (recover_members)": ("recovery.py", "_dispatch", "_recovery_kernel.py",
                                     "recover_members"),
    "parts the answer is averaged with (blend_parts)": ("recovery.py", "_dispatch",
                                                        "exemplars.py", "blend_parts"),
    "blend of poses with many hidden joints": ("recovery.py", "_dispatch", "exemplars.py",
                                               "blend_many_hidden"),
    "donor step (its probes' answers included)": ("recovery.py", "_dispatch", "donors.py",
                                                  "donor_step"),
    "radii (joint_uncertainty)": ("recovery.py", "_with_uncertainty", "uncertainty.py",
                                  "joint_uncertainty"),
}
#: kernels under them, wherever called: numba's by their own time, the others cumulative
KERNELS = {
    "lasso on working sets (numba)": ("fast.py", ("_ws_batch", "_ws_batch_serial")),
    "lasso, rows solved again over all atoms (numba)": (
        "fast.py", ("_resolve_batch", "_resolve_batch_serial", "_lars_rows_batch",
                    "_lars_rows_batch_serial")),
    "lasso, full homotopy (numba)": ("fast.py", ("_lars_masked_batch",
                                                 "_lars_masked_batch_serial")),
    "certificate (duality gap)": ("base.py", ("duality_gap",)),
    "Gaussian fill (per missing pattern)": ("gaussian_fill.py", ("gaussian_fill",)),
    "local ridge codes": ("local_ridge.py", ("local_ridge_codes",)),
    "joint placement": ("placement.py", ("place_missing_joints",)),
    "donors' search (donor_estimates)": ("donors.py", ("donor_estimates",)),
}


def photo_file(source=None, bandai=None):
    """(poses with NaN, missing, label): a validation photo file or a Bandai-Namco file."""
    if bandai:
        from .default_path import load_bandai, make_file

        P, mask = make_file(load_bandai()[0], bandai)
        return np.where(mask[..., None], np.nan, P), mask, f"{len(P):,} Bandai-Namco poses"
    from sparseedm.metrics import occlusion_masks

    from . import real2d

    realset = real2d.load(source)
    s = realset.take(real2d.split(realset) == "val")
    poses = s.poses[s.complete]
    rng = np.random.default_rng([0, 3])
    poses = poses[rng.permutation(len(poses))[:2000]]
    mask = np.zeros(poses.shape[:2], bool)
    m = len(poses) // 2
    mask[m:] = occlusion_masks(len(poses) - m, 14, ("mix",), 0)["mix"]
    return (np.where(mask[..., None], np.nan, poses), mask,
            f"{source} validation photo file, {len(poses):,} poses ({len(poses) - m:,} under Mix)")


def profile_default(X, mask):
    """cProfile of recover() with its defaults, n_jobs=1: (wall, total, steps, kernels)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        recover(X[:400], mask[:400])  # warm: the kernels loaded
        prof = cProfile.Profile()
        t0 = time.perf_counter()
        prof.runcall(recover, X, mask)
        wall = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats
    total = max(ct for (path, _, func), (_, _, _, ct, _) in stats.items()
                if path.endswith("recovery.py") and func == "recover")
    steps = {}
    for name, (csuf, cname, suf, fname) in STEPS.items():
        for (path, _, func), (_, _, _, _, callers) in stats.items():
            if path.endswith(suf) and func == fname:
                steps[name] = sum(v[3] for (cp, _, cf), v in callers.items()
                                  if cp.endswith(csuf) and cf == cname)
    kernels = {}
    for name, (suf, names) in KERNELS.items():
        for (path, _, func), (_, _, tt, ct, _) in stats.items():
            if path.endswith(suf) and func in names:
                kernels[name] = kernels.get(name, 0.0) + (tt if "numba" in name else ct)
    return wall, total, steps, kernels


def render_default(label, n, wall, total, steps, kernels):
    lines = [f"{label}: `recover()` defaults, `n_jobs=1`, under cProfile: {total:.2f} s "
             f"({n / wall:.0f} poses/s with the profiler; machine load {loadavg()}).", "",
             "| step of the default path | seconds | share |", "|---|---|---|"]
    for name, t in list(steps.items()) + [("other", total - sum(steps.values()))]:
        lines.append(f"| {name} | {t:.3f} | {100 * t / total:.1f}% |")
    lines += ["", "| kernel (wherever called) | seconds | share |", "|---|---|---|"]
    lines += [f"| {name} | {t:.3f} | {100 * t / total:.1f}% |" for name, t in kernels.items()]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--photo", choices=("mpii", "coco", "bonn"),
                    help="profile the defaults on this source's validation photo file")
    ap.add_argument("--bandai", type=int, metavar="N",
                    help="profile the defaults on N Bandai-Namco poses, half under Mix")
    args = ap.parse_args(argv)
    if args.photo or args.bandai:
        X, mask, label = photo_file(args.photo, args.bandai)
        print(render_default(label, len(X), *profile_default(X, mask)))
        return
    print(render(profile(args.n)))


if __name__ == "__main__":
    main()
