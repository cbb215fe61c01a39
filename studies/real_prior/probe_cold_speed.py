"""The cold prior's speed: ``recover(adapt=False)`` coded on working sets of atoms.

``recover(adapt=False)`` codes each pose twice (the pose and its mirror image,
``mirror="auto"``) over ``cmu-coco-k2932``'s 2,932 atoms. The fast solver's
homotopy walks over every atom; ``FastSolver(working_set=True)`` runs each
row's path over its most correlated atoms, grown until the full problem's
certificate holds: the same lasso (answers equal to round-off), fewer atoms
touched. Variants: ``full`` (the homotopy over every atom: the cold path
before), ``working_sets`` (one ``FastSolver(working_set=True)`` kept across
calls), ``shipped`` (``solver="fast"``, what ``recover(adapt=False)`` is
given: working sets since ``preset_solver(per_pose=True)``), ``old_cold``
(``cmu-all-k2000`` without the mirror, by the homotopy: the cold path before
``cmu-coco-k2932``), ``default_dictionary`` (``dictionary="default"``: the
CMU atoms alone, no mirror, as shipped now). Timed here, the variants alternating ``--repeats``
times per file (median poses/s; the machine's load noted), on:

* ``bandai``: the frontier's 6,000-pose Bandai-Namco-1 file (half under Mix;
  a benchmark reading, ``benchmarks/default_path.make_file``);
* ``bonn``, ``mpii``: ``harness.py``'s validation files (``--protocol``:
  2 random hidden joints by default), every pose.

    python studies/real_prior/probe_cold_speed.py --files mpii,bonn,bandai --repeats 2 \\
        --variants full,shipped,old_cold --out studies/real_prior/results_cold_speed.json

``--gate``: instead, could the mirror's code be skipped? The weight
``mirror="auto"`` gives each occluded pose's mirror answer
(:func:`sparseedm._recovery_base.mirror_weights`), its quantiles and the
share of poses where it is under 0.05 (a code that could be skipped) or
over 0.4 (about the mean).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from sparseedm._atomic import json_text  # noqa: E402
import sparseedm  # noqa: E402
from sparseedm.solvers.fast import FastSolver  # noqa: E402
from studies.real_prior import harness  # noqa: E402

VARIANTS = {
    "full": dict(solver=FastSolver()),          # the homotopy over every atom (before)
    "working_sets": dict(solver=FastSolver(working_set=True)),
    "shipped": dict(solver="fast"),             # what solver="fast" does now
    "old_cold": dict(solver=FastSolver(), dictionary="default", mirror=False),
    "default_dictionary": dict(solver="fast", dictionary="default"),  # now: working sets
}


def load_file(name, protocol, seed):
    """(truth, missing) of a file."""
    if name == "bandai":
        from benchmarks.default_path import load_bandai, make_file

        pool, _ = load_bandai()
        return make_file(pool, 6000, seed=seed)
    return harness.make_file(name, protocol, seed)


def time_file(truth, missing, repeats, variants):
    """{variant: dict(poses_per_s, err, max_px_from_first)}."""
    P = np.where(missing[..., None], np.nan, truth)
    occ = missing.any(axis=1)
    secs, out, first = {v: [] for v in variants}, {}, None
    for _ in range(repeats):
        for name in variants:
            t0 = time.perf_counter()
            res = sparseedm.recover(P, missing, adapt=False, n_jobs=2, **VARIANTS[name])
            secs[name].append(time.perf_counter() - t0)
            if name not in out:
                first = res.poses if first is None else first
                err = harness.score(res.poses[occ], truth[occ], missing[occ]) if \
                    np.isfinite(res.poses[occ]).all() else float("nan")
                out[name] = dict(err=round(err, 4),
                                 max_px_from_first=float(np.nanmax(np.abs(res.poses - first))))
    for name in variants:
        out[name]["poses_per_s"] = round(len(P) / float(np.median(secs[name])), 1)
        out[name]["seconds"] = [round(s, 2) for s in secs[name]]
    return out


def gate(files, protocol, seed):
    """{file: quantiles and shares of the mirror weight over the occluded poses}."""
    from sparseedm._recovery_base import mirror_weights
    from sparseedm.dictionary import load_dictionary

    d = load_dictionary("cmu-coco-k2932")
    out = {}
    for f in files:
        truth, missing = load_file(f, protocol, seed)
        P = np.where(missing[..., None], np.nan, truth)
        own, mirror = (sparseedm.recover(P, missing, adapt=False, dictionary=m, mirror=False)
                       for m in (d, d.mirrored()))
        w = mirror_weights([own, mirror])[1][missing.any(axis=1)]
        out[f] = dict(quantiles_10_25_50_75_90=np.round(
            np.quantile(w, [0.1, 0.25, 0.5, 0.75, 0.9]), 3).tolist(),
            share_below_005=round(float((w < 0.05).mean()), 3),
            share_above_04=round(float((w > 0.4).mean()), 3))
        print(f, out[f], flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", default="bandai,bonn,mpii")
    ap.add_argument("--protocol", default="2")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--gate", action="store_true")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    if a.gate:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            doc = gate(a.files.split(","), a.protocol, a.seed)
        if a.out:
            a.out.write_text(json_text(doc, indent=1) + "\n")
        return
    variants = a.variants.split(",")
    doc = {"load_start": os.getloadavg()[0], "files": {}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        warm = harness.make_file("mpii", "1", 0)
        for name in variants:  # JIT caches and Gram matrices, out of the timings
            sparseedm.recover(np.where(warm[1][..., None], np.nan, warm[0]), warm[1],
                              adapt=False, n_jobs=2, **VARIANTS[name])
        for f in a.files.split(","):
            truth, missing = load_file(f, a.protocol, a.seed)
            doc["files"][f] = time_file(truth, missing, a.repeats, variants)
            print(f, json.dumps(doc["files"][f]), flush=True)
    doc["load_end"] = os.getloadavg()[0]
    if a.out:
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
