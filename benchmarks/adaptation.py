"""``python -m benchmarks.adaptation [--quick] [--write-docs]``: time of dictionary
adaptation on 5,000 complete poses against its peers measured in the same run.

Data: the CMU training set (:func:`benchmarks.load_cmu`), the poses of subjects
other than 01-03 (whom the shipped default was learned from): a seeded sample of
5,000 complete poses. Dictionary: the shipped default (k = 2000). Rows:

- ``run_adaptation`` with its defaults, n_jobs = 2 (filters, held-back slice, the
  guard's two recoveries of the held-back poses included): what
  ``recover(adapt="auto")`` spends before recovering (4,500 poses learned from, 500 held back);
- ``self_train`` after it (what ``recover`` adds by default: rounds of
  recovering the 5,000 poses under Mix occlusion and adapting again on them),
  n_jobs = 2;
- ``adapt_vectors`` alone (the warm-started learning on the same 4,500 training
  vectors), n_jobs = 2;
- peers: scikit-learn ``IterativeImputer`` fitted on the same 5,000 poses (the
  baseline the accuracy goal compares with), a k = 2000 dictionary learned from
  scratch with the same passes and alpha on the same vectors, and ``recover`` of the same
  5,000 poses under Mix occlusion (n_jobs = 2).

Goal: ``run_adaptation`` <= 10 s on 2 cores. Writes its block between
``<!-- BEGIN ADAPTATION -->`` and ``<!-- END ADAPTATION -->`` in
benchmarks/README.md and its raw numbers to results-adaptation.json.
"""

from __future__ import annotations

import time
import warnings


import numpy as np

from . import bench_main, load_cmu, log, run_line, table


GOAL_SECONDS = 10.0


def run(quick=False):
    import sparseedm
    from sparseedm.adaptation import (DEFAULT_PASSES, SELF_TRAINING_MAX_POSES,
                                      SELF_TRAINING_ROUNDS, adapt_vectors,
                                      adaptation_alpha, pose_vectors as _vectors,
                                      run_adaptation, self_train)
    from sparseedm.baselines import fit_baseline
    from sparseedm.learning import OnlineDictionaryLearning
    from sparseedm.metrics import random_occlusion

    poses, clips, path = load_cmu()
    subjects = np.array([c.split("_")[0] for c in clips])
    pool = poses[~np.isin(subjects, ["01", "02", "03"])]
    n = 500 if quick else 5000
    rng = np.random.default_rng(0)
    sample = pool[np.sort(rng.choice(len(pool), n, replace=False))]
    base = sparseedm.load_dictionary()
    log(f"adaptation benchmark: {n} poses from {path}")
    # warm the JIT caches out of the timings
    run_adaptation(base, sample[:300], min_poses=1, passes=1)

    rows = {}
    t0 = time.perf_counter()
    res = run_adaptation(base, sample, n_jobs=2)
    rows["run_adaptation (defaults: filters + learning + guard), n_jobs=2"] = {
        "seconds": time.perf_counter() - t0, "note": res.line()}
    for step, secs in res.step_seconds.items():
        rows[f"  of which {step}"] = {"seconds": secs, "note": ""}
    mask = random_occlusion(n, 14, "mix", random_state=0)
    occluded = np.where(mask[..., None], np.nan, sample)
    t0 = time.perf_counter()
    st = self_train(base, res, sample, None, occluded, mask, n_jobs=2)
    rows[f"self_train after it ({SELF_TRAINING_ROUNDS} rounds on the {n} poses under Mix "
         f"occlusion: a sample of {min(n, SELF_TRAINING_MAX_POSES)}), n_jobs=2"] = {
        "seconds": time.perf_counter() - t0, "note": st.line()}
    X = _vectors(sample[: res.n_used])
    t0 = time.perf_counter()
    alpha = adaptation_alpha(base)  # what run_adaptation learns with
    adapt_vectors(base.components, X, alpha, n_jobs=2)
    rows[f"adapt_vectors only ({len(X)} vectors, {DEFAULT_PASSES} passes), n_jobs=2"] = {
        "seconds": time.perf_counter() - t0, "note": ""}
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit_baseline("iterative", sample, max_train=n)
    rows["peer: IterativeImputer fit on the same poses"] = {
        "seconds": time.perf_counter() - t0, "note": ""}
    k = base.n_components if len(X) >= base.n_components else len(X) // 2
    t0 = time.perf_counter()
    OnlineDictionaryLearning(k, alpha=alpha, batch_size=256,
                             n_passes=DEFAULT_PASSES, random_state=0, n_jobs=2).fit(X)
    rows[f"peer: k={k} dictionary from scratch, same vectors and passes, n_jobs=2"] = {
        "seconds": time.perf_counter() - t0, "note": ""}
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sparseedm.recover(np.where(mask[..., None], np.nan, sample), mask, dictionary=base,
                          adapt=False, n_jobs=2)
    rows["peer: recover the same poses under Mix occlusion, n_jobs=2"] = {
        "seconds": time.perf_counter() - t0, "note": ""}
    return {"n_poses": n, "rows": rows, "adaptation": res.summary()}


def render(res, meta):
    first = next(iter(res["rows"].values()))
    met = first["seconds"] <= GOAL_SECONDS
    lines = [
        run_line(meta, "python -m benchmarks.adaptation"),
        "",
        f"- Goal: adaptation on {res['n_poses']} complete poses <= {GOAL_SECONDS:.0f} s on 2 "
        f"cores: {'**met**' if met else '**NOT met**'} ({first['seconds']:.1f} s).",
        "",
    ]
    lines.append(render_rows(res))
    return "\n".join(lines)


def render_rows(res):
    """The table and run_adaptation's own line (also in ``python -m benchmarks``)."""
    first = next(iter(res["rows"].values()))
    ref = first["seconds"]
    return (f"{res['n_poses']:,} complete CMU poses of subjects other than 01-03, shipped "
            "default dictionary (k = 2000).\n\n"
            + table(["what", "seconds", "x run_adaptation"],
                    [[name, r["seconds"], r["seconds"] / ref] for name, r in res["rows"].items()])
            + f"\n\nrun_adaptation said: `{first['note']}`")


def main(argv=None):
    bench_main(argv, prog="python -m benchmarks.adaptation", doc=__doc__,
               quick_help="500 poses: a smoke test", run=run, render=render,
               tag="ADAPTATION", heading="Adaptation speed (benchmarks/adaptation.py)",
               results="results-adaptation.json")


if __name__ == "__main__":
    main()
