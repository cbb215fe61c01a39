"""``python -m studies.fast.select_fast``: the settings of ``recover(preset="fast")``.

The fast preset codes each occluded pose over the file's own complete poses
as atoms (:func:`sparseedm.file_atoms.file_dictionary`) with the certified
fast solver, nothing learned. Its two settings, the most atoms
(``MAX_FAST_ATOMS``: the solver's time grows with them) and the recovery alpha
(``FAST_ALPHA``), are chosen here on validation files made of CMU clips held
out by ``benchmarks.split_clips`` (every 5th clip): a seeded sample of 6,000
poses, half of them complete and half under the evaluation protocol's Mix
masks (1-3 joints), as ``benchmarks/default_path.py`` makes its files. Each
setting is scored by the Err_ave (%) of the occluded poses' returned poses'
EDMs (what a user gets) and its seconds (n_jobs=2), beside scikit-learn's
IterativeImputer fitted on and filling the whole file (pixel coordinates,
``max_iter=10, tol=0``) in the same run. Writes ``selection_fast.json``
beside this script.

``--solvers`` instead times the preset's solver (the lasso on working sets
of atoms, ``FastSolver(working_set=True)``) against the homotopy over every
atom (``FastSolver()``) at the shipped setting, both on the same file in the
same run (``--repeats``, median): the same lasso, so the same error, and
what the working sets save. Writes ``selection_fast_solvers.json``.

``--caps`` asks whether more atoms than ``MAX_FAST_ATOMS`` would pay: the
validation files above hold at most 3,641 complete poses, so it uses every
held-out pose with a quarter under Mix masks (about 5,460 complete), and
scores the preset at several caps (error and seconds, working sets).
Writes ``selection_fast_caps.json``.

``--local`` chooses the settings of the preset's coder since it stopped
solving the lasso: the local ridge code
(:class:`sparseedm.solvers.local_ridge.LocalRidgeSolver`: each occluded pose's
K most correlated atoms, ridge weight lam, each coefficient's penalty growing
as ``(1 - cos)^power`` of its atom) over at most ``cap`` of the file's
complete poses. The grid (``GRID_LOCAL``) runs on two files: the 6,000-pose
validation file above (3,000 complete poses) and the every-held-out-pose
file of ``--caps`` (5,462 complete: there 6,000 and "all" are the same
cap), each beside the exact lasso of the old preset and IterativeImputer
(one BLAS thread, ``n_jobs=1``). The choice: the preset is judged by its speed
first, so only settings at least ``MIN_SPEEDUP`` times as fast as the imputer
on both files (seconds of the same run, the file's dictionary included)
qualify (the imputer's: the median of 3 runs); among them the lowest Err_ave averaged over the two files, then the
larger cap (the two files cannot tell 6,000 from every pose; more atoms
lowered the lasso's error, ``--caps``). Writes
``selection_fast_local.json``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_fast.py` finds benchmarks/

GRID_ATOMS = (1000, 2000, 3000, 4000)
GRID_ALPHA = (0.0002, 0.0005, 0.001)
#: --local: working-set atoms K, ridge weight lam, atom cap (None: every complete pose)
#: --local: working-set atoms K, ridge weight lam, penalty power, atom cap (None: every
#: complete pose); the speed the choice needs against IterativeImputer (same run)
GRID_LOCAL = {"K": (32, 64, 128), "lam": (3e-5, 1e-4, 3e-4, 1e-3, 3e-3),
              "power": (0.0, 1.0, 2.0, 3.0), "cap": (3000, 6000, None)}
MIN_SPEEDUP = 1.5


def pose_error(filled, truth, mask):
    """Mean Err_ave (%) of the occluded poses' EDMs of `filled` against `truth`."""
    from sparseedm.edm import pose_to_vector
    from sparseedm.metrics import err_ave

    e = err_ave(pose_to_vector(filled), pose_to_vector(truth))
    return float(np.nanmean(e[mask.any(axis=1)]))


def validation_file(n=6000, seed=0, occluded=None):
    """(poses, mask): n poses of the held-out CMU clips, half under Mix masks
    (or the fraction `occluded`)."""
    from benchmarks import load_cmu, split_clips
    from benchmarks.default_path import make_file

    poses, clips, _ = load_cmu()
    held, _ = split_clips(clips)
    P, mask = make_file(np.asarray(poses[held], dtype=float), n, seed=seed)
    if occluded is not None:  # unmask rows at random down to the fraction asked
        rows = np.flatnonzero(mask.any(axis=1))
        keep = np.random.default_rng(seed + 1).permutation(rows)[:int(occluded * len(P))]
        mask[np.setdiff1d(rows, keep)] = False
    return P, mask


def caps(base):
    """The preset's error and seconds at several atom caps on a file with more
    complete poses than ``validation_file`` (rows of a JSON)."""
    import sparseedm
    from sparseedm.file_atoms import FAST_ALPHA, file_dictionary
    from sparseedm.solvers.fast import FastSolver

    P, mask = validation_file(n=10 ** 6, occluded=0.25)
    X = np.where(mask[..., None], np.nan, P)
    rows = []
    for k in (2000, 3000, 4000, 5000, 10 ** 6):
        t0 = time.perf_counter()
        d = file_dictionary(base, X, mask, max_atoms=k, alpha_recover=FAST_ALPHA).dictionary
        res = sparseedm.recover(X, mask, dictionary=d, adapt=False, n_jobs=2,
                                solver=FastSolver(working_set=True))
        rows.append({"max_atoms": k, "atoms": d.n_components, "poses": len(P),
                     "occluded": int(mask.any(axis=1).sum()),
                     "seconds": time.perf_counter() - t0, "err": pose_error(res.poses, P, mask)})
        print(rows[-1], flush=True)
    return rows


def local_grid(base, name, P, mask):
    """The local ridge grid on one file, beside the old preset's lasso and
    IterativeImputer (rows of a JSON)."""
    import sparseedm
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer
    from sparseedm.file_atoms import FAST_ALPHA, MAX_FAST_ATOMS, file_dictionary
    from sparseedm.solvers.fast import FastSolver
    from sparseedm.solvers.local_ridge import LocalRidgeSolver

    X = np.where(mask[..., None], np.nan, P)
    head = {"file": name, "poses": len(P), "occluded": int(mask.any(axis=1).sum())}
    secs = []
    for _ in range(3):  # the speed bar: the median of 3 runs
        t0 = time.perf_counter()
        imp = IterativeImputer(max_iter=10, tol=0).fit_transform(X.reshape(len(X), -1))
        secs.append(time.perf_counter() - t0)
    rows = [dict(head, what="IterativeImputer", seconds=float(np.median(secs)), runs=secs,
                 err=pose_error(imp.reshape(P.shape), P, mask))]
    t0 = time.perf_counter()
    d = file_dictionary(base, X, mask, max_atoms=MAX_FAST_ATOMS, alpha_recover=FAST_ALPHA)
    res = sparseedm.recover(X, mask, dictionary=d.dictionary, adapt=False, n_jobs=1,
                            solver=FastSolver(working_set=True))
    rows.append(dict(head, what="lasso (the old preset)", cap=MAX_FAST_ATOMS,
                     atoms=d.n_atoms, seconds=time.perf_counter() - t0,
                     err=pose_error(res.poses, P, mask)))
    print(rows[0], rows[1], sep="\n", flush=True)
    for cap in GRID_LOCAL["cap"]:
        t0 = time.perf_counter()
        d = file_dictionary(base, X, mask, max_atoms=cap or 10 ** 9, alpha_recover=FAST_ALPHA)
        build = time.perf_counter() - t0
        for K, lam, power in itertools.product(
                GRID_LOCAL["K"], GRID_LOCAL["lam"], GRID_LOCAL["power"]):
            t0 = time.perf_counter()
            res = sparseedm.recover(X, mask, dictionary=d.dictionary, adapt=False, n_jobs=1,
                                    solver=LocalRidgeSolver(n_atoms=K, lam=lam, power=power))
            rows.append(dict(head, what="local ridge", cap=cap, atoms=d.n_atoms, K=K,
                             lam=lam, power=power, seconds=build + time.perf_counter() - t0,
                             err=pose_error(res.poses, P, mask),
                             statuses={s: int(c) for s, c in
                                       zip(*np.unique(res.status, return_counts=True))}))
            print(rows[-1], flush=True)
    return rows


def choose_local(rows):
    """The --local choice (see the module docstring): the setting and its mean
    error and seconds over the files."""
    grid, imputer = {}, {}
    for r in rows:
        if r["what"] == "IterativeImputer":
            imputer[r["file"]] = r["seconds"]
        if r["what"] == "local ridge":
            grid.setdefault((r["K"], r["lam"], r["power"], r["cap"]), []).append(r)
    fast = {key: rs for key, rs in grid.items()
            if all(imputer[r["file"]] >= MIN_SPEEDUP * r["seconds"] for r in rs)}
    mean = {key: (float(np.mean([r["err"] for r in rs])),
                  float(np.mean([r["seconds"] for r in rs]))) for key, rs in fast.items()}
    # the lowest error, then the larger cap (None: every pose)
    key = min(mean, key=lambda k: (round(mean[k][0], 6), -(k[3] or np.inf)))
    return {"K": key[0], "lam": key[1], "power": key[2], "cap": key[3], "err": mean[key][0],
            "seconds": mean[key][1], "fast_enough": len(fast), "settings": len(grid)}


def solvers(X, P, mask, repeats):
    """The preset's working-set solver against the full homotopy (rows of a JSON)."""
    import sparseedm
    from sparseedm.solvers.fast import FastSolver

    rows = []
    for name, ws in (("working sets", True), ("full-dictionary LARS", False)):
        secs = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = sparseedm.recover(X, mask, preset="fast", n_jobs=2,
                                    solver=FastSolver(working_set=ws))
            secs.append(time.perf_counter() - t0)
        rows.append({"what": f"preset 'fast', {name}", "seconds": float(np.median(secs)),
                     "runs": secs, "err": pose_error(res.poses, P, mask),
                     "statuses": {s: int(c) for s, c in
                                  zip(*np.unique(res.status, return_counts=True))}})
        print(rows[-1], flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--solvers", action="store_true",
                    help="time the preset's working-set solver against the full homotopy")
    ap.add_argument("--repeats", type=int, default=3, help="runs per solver (--solvers)")
    ap.add_argument("--caps", action="store_true",
                    help="score more atoms than MAX_FAST_ATOMS on a file with more complete poses")
    ap.add_argument("--local", action="store_true",
                    help="choose the local ridge coder's K, lam and atom cap")
    args = ap.parse_args(argv)
    import sparseedm
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer
    from sparseedm.file_atoms import file_dictionary
    from sparseedm.solvers.fast import FastSolver
    from threadpoolctl import threadpool_limits

    P, mask = validation_file()
    X = np.where(mask[..., None], np.nan, P)
    base = sparseedm.load_dictionary()
    warnings.simplefilter("ignore")
    sparseedm.recover(X[:300], mask[:300], adapt=False, n_jobs=2)  # JIT caches
    sparseedm.recover(X[:300], mask[:300], preset="fast", n_jobs=2)
    if args.local:
        with threadpool_limits(1, user_api="blas"):
            rows = (local_grid(base, "6,000 CMU held-out-clip poses, half under Mix", P, mask)
                    + local_grid(base, "every held-out CMU pose, a quarter under Mix",
                                 *validation_file(n=10 ** 6, occluded=0.25)))
        out = Path(__file__).with_name("selection_fast_local.json")
        out.write_text(json.dumps({"blas_threads": 1, "choice": choose_local(rows),
                                   "rows": rows}, indent=1))
        print(choose_local(rows))
        return
    if args.caps:
        out = Path(__file__).with_name("selection_fast_caps.json")
        out.write_text(json.dumps({"file": "every held-out CMU pose, a quarter under Mix",
                                   "rows": caps(base)}, indent=1))
        return
    if args.solvers:
        out = Path(__file__).with_name("selection_fast_solvers.json")
        out.write_text(json.dumps({"file": "6,000 CMU held-out-clip poses, half under Mix",
                                   "rows": solvers(X, P, mask, args.repeats)}, indent=1))
        return
    t0 = time.perf_counter()
    imp = IterativeImputer(max_iter=10, tol=0).fit_transform(X.reshape(len(X), -1))
    rows = [{"what": "IterativeImputer", "seconds": time.perf_counter() - t0,
             "err": pose_error(imp.reshape(P.shape), P, mask)}]
    print(rows[-1], flush=True)
    for k in GRID_ATOMS:
        for a in GRID_ALPHA:
            t0 = time.perf_counter()
            d = file_dictionary(base, X, mask, max_atoms=k, alpha_recover=a).dictionary
            res = sparseedm.recover(X, mask, dictionary=d, adapt=False, n_jobs=2,
                                    solver=FastSolver(working_set=True))  # the preset's
            rows.append({"what": "file dictionary", "max_atoms": k, "alpha": a,
                         "atoms": d.n_components, "seconds": time.perf_counter() - t0,
                         "err": pose_error(res.poses, P, mask),
                         "statuses": {s: int(c) for s, c in
                                      zip(*np.unique(res.status, return_counts=True))}})
            print(rows[-1], flush=True)
    out = Path(__file__).with_name("selection_fast.json")
    out.write_text(json.dumps({"file": "6,000 CMU held-out-clip poses, half under Mix",
                               "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
