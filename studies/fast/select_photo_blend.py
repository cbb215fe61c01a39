"""The default path's estimate from the same atoms: lasso, local ridge, elastic net, means.

``recover()``'s default path codes each occluded pose by the lasso over the
atoms :mod:`sparseedm.exemplars` chose (the base with the file's complete
poses as extra atoms, the file's poses alone, or a mean of such lasso codes):
one sparse code per dictionary. On real photos the losses concentrate where
the hidden joints are poorly determined (both legs hidden), where an average
of plausible poses does better than one committed code. This script
measures, per validation file, estimates nearer a posterior mean, built from
the same atoms:

* ``cur``: ``recover()``'s defaults on the whole file (the check included)
  without the blend this study led to; ``shipped``: with it (the poses whose
  knees and ankles are all hidden averaged with ``R atoms``:
  :func:`sparseedm.exemplars.blend_hidden_legs`);
* ``L atoms`` / ``L base+atoms``: the lasso over the file's complete poses
  (``file_dictionary``) / over the base with them as extra atoms;
* ``R atoms`` / ``R base+atoms``: the local ridge of ``preset="fast"``
  (:class:`~sparseedm.solvers.LocalRidgeSolver` with ``FAST_RIDGE``: about 48
  nearby atoms) over the same atoms;
* ``EN <atoms> l=...``: the elastic net (the lasso with ``0.5 * l * s *
  ||c||^2`` added, s the mean squared atom norm; Zou and Hastie's ``1 + l``
  rescaling), which spreads weight over similar atoms;
* ``avg(cur, X)``: the mean of two answers' filled joints;
* ``legs: ...``: a per-pose rule on what is observable, the mean for poses
  whose knees and ankles are all hidden, ``cur`` for the others.

Files (validation only): ``select_photo_atoms.py``'s photo files (MPII,
COCO, Bonn val; complete poses from the val split as
``benchmarks/real_people.py --split val`` draws them, and 1,000 from the train split as ``benchmarks/real_people.py --complete-from train``
draws them; ``mix`` and ``transplanted`` masks) with IterativeImputer in the
same run; CMU held-out clips (``select_fast.validation_file``: half under Mix
masks) and Daz datasets (``--daz``: C complete + C Mix poses). Score: per
occluded pose the mean error of its hidden joints, % of body size; each
candidate minus ``cur`` paired over the occluded poses [mean, standard error].

    python studies/fast/select_photo_blend.py --daz daz_indian.npz --out blend.json
    python studies/fast/select_photo_blend.py --table blend.json
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_photo_blend.py` finds benchmarks/
from sparseedm._atomic import json_text  # noqa: E402

#: elastic-net l2 weights (relative to the mean squared atom norm)
EN_WEIGHTS = (0.03, 0.3)
#: per-pose rules: the mean for poses with at least this many hidden joints
HIDDEN_RULES = (3, 4, 6)
#: knees and ankles (SKELETON_14)
LEGS = [9, 10, 12, 13]


def elastic_net_solver(l2):
    """A BaseSolver coding each row by the elastic net on its observed entries."""
    import numba

    from sparseedm.solvers.base import FAILED, OPTIMAL, BaseSolver, LassoResult
    from sparseedm.solvers.fast import _lars_core  # a study: the package's homotopy

    @numba.njit(parallel=True, cache=False)
    def batch(G, D, Dt, X0, miss, n_miss, alpha, max_steps, coef, steps):
        for i in numba.prange(X0.shape[0]):
            dtx = np.dot(Dt, X0[i])
            steps[i] = _lars_core(G, D, 2, miss[i, :n_miss[i]], dtx, alpha[i], False,
                                  max_steps, min(G.shape[0] - 1, 255), coef[i])

    class ElasticNet(BaseSolver):
        name = "elastic-net"

        def solve_masked(self, D, X, observed, alpha, *, positive=False, key=None):
            D, X, observed, alpha = self._check_masked(D, X, observed, alpha)
            G = D.T @ D
            s = l2 * float(np.mean(np.diag(G)))
            G[np.diag_indices_from(G)] += s
            n_miss = (~observed).sum(axis=1).astype(np.int64)
            miss = np.ascontiguousarray(np.argsort(observed, axis=1, kind="stable")[
                :, :max(int(n_miss.max(initial=0)), 1)].astype(np.int64))
            coef = np.zeros((len(X), D.shape[1]))
            steps = np.zeros(len(X), np.int64)
            batch(G, np.ascontiguousarray(D), np.ascontiguousarray(D.T),
                  np.ascontiguousarray(X), miss, n_miss, np.ascontiguousarray(alpha), 1000,
                  coef, steps)
            coef *= 1 + l2
            n = len(X)  # a path stopped at 256 atoms: failed (left out of the scores)
            status = np.where(steps < 0, FAILED, OPTIMAL).astype(object)
            return LassoResult(coef, np.zeros(n), np.zeros(n), status, steps)

    return ElasticNet()


def codes(base, complete, given, missing, en=EN_WEIGHTS):
    """{candidate: filled poses} of the rows `given` under `missing`, the atoms
    made of `complete`."""
    import sparseedm
    from sparseedm._recovery_kernel import FAST_RIDGE
    from sparseedm.file_atoms import file_dictionary, with_file_atoms
    from sparseedm.solvers import LocalRidgeSolver
    from sparseedm.solvers.fast import FastSolver

    dicts = {"atoms": file_dictionary(base, complete).dictionary,
             "base+atoms": with_file_atoms(base, complete).dictionary}
    out, secs = {}, {}
    for name, d in dicts.items():
        own = name == "atoms"
        solvers = {"L": FastSolver(working_set=True, numpy_max=0) if own else "fast",
                   "R": LocalRidgeSolver(**FAST_RIDGE)}
        solvers.update({f"EN l={l}": elastic_net_solver(l) for l in en})
        for tag, solver in solvers.items():
            t0 = time.perf_counter()
            out[f"{tag} {name}"] = sparseedm.recover(given, missing, dictionary=d, adapt=False,
                                                     solver=solver, n_jobs=2).poses
            secs[f"{tag} {name}"] = round(time.perf_counter() - t0, 2)
    return out, secs


def per_pose(filled, truth, missing):
    """Per pose: the mean error of its hidden joints, % of body size."""
    from sparseedm.real_protocol import body_size

    err = np.linalg.norm(filled - truth, axis=-1) / body_size(truth)[:, None] * 100
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.nanmean(np.where(missing, err, np.nan), axis=1)


def paired(a, b):
    """[mean, standard error] of a - b over the poses where both are finite."""
    d = a - b
    d = d[np.isfinite(d)]
    if len(d) < 2:
        return [float("nan"), float("nan")]
    return [round(float(d.mean()), 4), round(float(d.std(ddof=1) / np.sqrt(len(d))), 4)]


def unblended(given, missing):
    """recover()'s defaults without the blend of poses with hidden legs (the path
    before it: :func:`sparseedm.exemplars.blend_atoms` answering None)."""
    import sparseedm
    import sparseedm.recovery

    kept = sparseedm.recovery.blend_atoms
    sparseedm.recovery.blend_atoms = lambda *a: None
    try:
        return sparseedm.recover(given, missing, n_jobs=2)
    finally:
        sparseedm.recovery.blend_atoms = kept


def measure(base, truth, missing, photo, en=EN_WEIGHTS, iterative_too=True):
    """One file: each candidate's per-pose errors on the occluded poses."""
    import sparseedm
    from studies.fast.select_photo_atoms import iterative

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    t0 = time.perf_counter()
    res = unblended(given, missing)
    secs = {"cur": round(time.perf_counter() - t0, 2)}
    got = {"cur": res.poses[occ]}
    t0 = time.perf_counter()
    got["shipped"] = sparseedm.recover(given, missing, n_jobs=2).poses[occ]
    secs["shipped"] = round(time.perf_counter() - t0, 2)
    path = res.adaptation.summary().get("path") if res.adaptation is not None else None
    more, s = codes(base, truth[~occ], given[occ], missing[occ], en)
    got.update(more)
    secs.update(s)
    if photo and iterative_too:
        t0 = time.perf_counter()
        got["iterative"] = iterative(given, missing)[occ]
        secs["iterative"] = round(time.perf_counter() - t0, 2)
    for name in [k for k in got if k.startswith(("R ", "EN "))]:
        got[f"avg(cur, {name})"] = (got["cur"] + got[name]) / 2
    return path, secs, {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


def summarise(errors, missing_occ):
    """Per candidate: mean error, paired difference with cur overall and in the
    poses with every knee and ankle hidden (``legs``) and the others; the rules
    ``legs: X`` (X for legs-hidden poses, cur elsewhere)."""
    legs = missing_occ[:, LEGS].all(axis=1)
    cur = errors["cur"]
    out = {"n": int(len(cur)), "legs hidden": int(legs.sum()), "candidates": {}}
    for name, e in errors.items():
        out["candidates"][name] = {"mean": round(float(np.nanmean(e)), 4),
                                   "minus_cur": paired(e, cur),
                                   "minus_cur legs": paired(e[legs], cur[legs]),
                                   "minus_cur other": paired(e[~legs], cur[~legs])}
        if name.startswith("avg("):
            hidden = missing_occ.sum(axis=1)
            rules = {"legs": legs, **{f"hidden>={h}": hidden >= h for h in HIDDEN_RULES}}
            for tag, use in rules.items():
                rule = np.where(use, e, cur)
                out["candidates"][f"{tag}: {name}"] = {
                    "mean": round(float(np.nanmean(rule)), 4), "minus_cur": paired(rule, cur),
                    "poses": int(use.sum())}
    return out


def files(a):
    """(name, truth, missing, photo) of the validation files asked for."""
    from studies.fast.select_default_exemplars import mocap_file
    from studies.fast.select_fast import validation_file
    from studies.fast.select_photo_atoms import photo_files

    sizes = [int(x) for x in a.complete.split(",")]
    for c in sizes:
        for name, truth, missing in photo_files(a.sources, "val", "split",
                                                sizes=(c, a.occluded), seed=a.seed):
            yield name, truth, missing, True
    if a.train:
        for name, truth, missing in photo_files(a.sources, "val", "train",
                                                sizes=(a.train, a.occluded), seed=a.seed):
            yield name, truth, missing, True
    for c in (int(x) for x in a.mocap_sizes.split(",") if x):
        P, mask = validation_file(2 * c, a.seed)
        yield f"cmu {len(P)} poses seed {a.seed}", P, mask, False
        for path in filter(None, a.daz.split(",")):
            truth, missing = mocap_file(path, c, min(c, a.occluded), a.seed)
            yield f"{Path(path).stem} {c}+{min(c, a.occluded)}", np.asarray(truth, float), \
                missing, False


def table(doc, names=None):
    """Markdown: per file, cur's error and each candidate's paired difference."""
    files_ = doc["files"]
    cands = names or [c for c in next(iter(files_.values()))["candidates"] if c != "cur"]
    lines = ["| file | path | cur | " + " | ".join(cands) + " |",
             "|---|---|---:|" + "---:|" * len(cands)]
    for name, r in files_.items():
        cells = []
        for c in cands:
            m, se = r["candidates"].get(c, {}).get("minus_cur", [float("nan")] * 2)
            cells.append(f"{m:+.2f} ± {se:.2f}")
        lines.append(f"| {name} | {r['path']} | {r['candidates']['cur']['mean']:.2f} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sources", default="mpii,coco,bonn", help="real2d sources (val split)")
    ap.add_argument("--complete", default="1000",
                    help="complete poses per val file (scaled down with --occluded to the "
                    "split's poses as benchmarks/real_people.py does)")
    ap.add_argument("--mocap-sizes", default="200,1000",
                    help="complete poses of the CMU and Daz files")
    ap.add_argument("--train", type=int, default=1000,
                    help="complete poses from the train split (0: none)")
    ap.add_argument("--occluded", type=int, default=1000, help="occluded poses per file (cap)")
    ap.add_argument("--daz", default="", help="Daz dataset .npz paths, comma-separated")
    ap.add_argument("--en", default=",".join(map(str, EN_WEIGHTS)),
                    help="elastic-net l2 weights, comma-separated ('' for none)")
    ap.add_argument("--no-iterative", action="store_true",
                    help="leave IterativeImputer out (a re-run of the rules)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the files' draws")
    ap.add_argument("--out", type=Path, default=Path("photo_blend.json"))
    ap.add_argument("--table", type=Path, help="print the Markdown table of this JSON, stop")
    ap.add_argument("--columns", default="", help="with --table: candidates, separated by semicolons")
    a = ap.parse_args(argv)
    if a.table:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        print(table(load_results(a.table),
                    [c for c in a.columns.split(";") if c] or None))
        return
    import sparseedm

    warnings.simplefilter("ignore")
    base = sparseedm.load_dictionary()
    doc = {"score": "per occluded pose: % body size of its hidden joints; minus_cur: "
                    "[mean, standard error] paired against recover()'s defaults", "files": {}}
    for name, truth, missing, photo in files(a):
        path, secs, errors = measure(base, truth, missing, photo,
                                     [float(x) for x in a.en.split(",") if x], not a.no_iterative)
        row = {"path": path, "seconds": secs, **summarise(errors, missing[missing.any(axis=1)])}
        doc["files"][name] = row
        print(name, path, {k: v["minus_cur"] for k, v in row["candidates"].items()},
              flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
