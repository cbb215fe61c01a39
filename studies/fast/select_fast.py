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
as ``(1 - cos)^power`` of its atom; with a first pass on ``first`` atoms, the
K atoms and their cosines are those of the whole pose as that pass filled
it) over every complete pose of the file. The grid (``GRID_LOCAL``, a first
pass no larger than K; each setting run twice) runs on two files: the
6,000-pose validation file above (3,000 complete poses) and every held-out
pose with a quarter under Mix masks (5,462 complete), each beside
IterativeImputer (one BLAS thread, ``n_jobs=1``: both run on one core). The
choice: the preset is judged by its speed first. The speed of a (K, first)
is the median CPU seconds of its runs (every (lam, power) does the same
work; the file's dictionary included): on a shared machine the CPU seconds
of a one-core run do not count the time other processes take, which
wall-clock seconds, also recorded, do. A (K, first) qualifies when it is at
least ``MIN_SPEEDUP`` times as fast as the imputer (the median of 3 runs)
and takes at most ``MAX_SLOWDOWN`` times the seconds of the previous coder
(``PREVIOUS_RIDGE``, one pass) on both files: more accuracy at the same
speed, as the preset must stay fast on files several times larger than these
(its scoring grows with poses times atoms); among the qualified settings the
lowest Err_ave averaged over the two files. Writes
``selection_fast_local.json``.

``--real`` checks the choice on real people: ``recover(preset="fast")`` with
the shipped coder (``FAST_RIDGE``) and with the previous one
(``PREVIOUS_RIDGE``) on the validation files of
``studies/real_prior/harness.py`` (Bonn val frames as photos, 500 + 500; MPII
train + val, 800 + 800; 1, 2 or 3 random hidden joints, or real missing
patterns). Writes ``selection_fast_real.json``.

``--gaps`` does the same on every held-out CMU pose in clip order, 1-3 joints
of each clip hidden in runs of 3-90 frames as the frontier's video file hides
them (two draws; each pose recovered on its own). Writes
``selection_fast_gaps.json``.

``--scale`` times the previous coder, the shipped one and two with a longer
first pass on a file the size of the larger benchmark file: 30,000 poses of
every CMU clip, half under Mix (timing only: its errors choose nothing), CPU
seconds, the median of 5 interleaved runs. Writes ``selection_fast_scale.json``.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_fast.py` finds benchmarks/
from sparseedm._atomic import json_text  # noqa: E402

GRID_ATOMS = (1000, 2000, 3000, 4000)
GRID_ALPHA = (0.0002, 0.0005, 0.001)
#: --local: working-set atoms K, atoms of the first pass (None: none; at most K), and
#: (ridge weight lam, penalty power) pairs around the previous coder's
GRID_LOCAL = {"K": (32, 48, 64, 96), "first": (None, 16, 32, 64),
              "lam_power": ((1e-4, 3.0), (3e-4, 2.0), (3e-4, 3.0), (3e-4, 4.0), (1e-3, 3.0))}
#: the speed the choice needs against IterativeImputer, and at most this many times
#: the CPU seconds of the previous coder (PREVIOUS_RIDGE), both in the same run
MIN_SPEEDUP, MAX_SLOWDOWN = 1.5, 1.10
#: --real: the preset's coder before the first pass, compared with the shipped one
PREVIOUS_RIDGE = {"n_atoms": 64, "lam": 3e-4, "power": 3.0, "first_atoms": None}


def pose_error(filled, truth, mask):
    """Mean Err_ave (%) of the occluded poses' EDMs of `filled` against `truth`."""
    from sparseedm.edm import pose_to_vector
    from sparseedm.metrics import err_ave

    e = err_ave(pose_to_vector(filled), pose_to_vector(truth))
    return float(np.nanmean(e[mask.any(axis=1)]))


def validation_file(n=6000, seed=0, occluded=None):
    """(poses, mask): n poses of the benchmarks' held-out CMU clips
    (``benchmarks.split_clips``; ``cmu-all-k2000`` learned from every clip),
    half under Mix masks (or the fraction `occluded`)."""
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


def timed(f, *args, **kwargs):
    """``f(*args, **kwargs)``, its wall-clock seconds and the process's CPU seconds."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = f(*args, **kwargs)
    return out, time.perf_counter() - t0, time.process_time() - c0


def local_grid(base, name, P, mask):
    """The local ridge grid on one file, beside IterativeImputer (rows of a JSON;
    seconds: wall clock, cpu: CPU seconds of the process)."""
    import sparseedm
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer
    from sparseedm.file_atoms import FAST_ALPHA, file_dictionary
    from sparseedm.solvers.local_ridge import LocalRidgeSolver

    X = np.where(mask[..., None], np.nan, P)
    head = {"file": name, "poses": len(P), "occluded": int(mask.any(axis=1).sum())}
    runs = [timed(IterativeImputer(max_iter=10, tol=0).fit_transform, X.reshape(len(X), -1))
            for _ in range(3)]  # the speed bar: the median of 3 runs
    rows = [dict(head, what="IterativeImputer", seconds=float(np.median([r[1] for r in runs])),
                 cpu=float(np.median([r[2] for r in runs])), runs=[r[1:] for r in runs],
                 err=pose_error(runs[0][0].reshape(P.shape), P, mask))]
    print(rows[0], flush=True)
    d, build, build_cpu = timed(file_dictionary, base, X, mask, max_atoms=10 ** 9,
                                alpha_recover=FAST_ALPHA)
    for K, first, (lam, power) in itertools.product(
            GRID_LOCAL["K"], GRID_LOCAL["first"], GRID_LOCAL["lam_power"]):
        if first is not None and first > K:
            continue
        runs = [timed(sparseedm.recover, X, mask, dictionary=d.dictionary, adapt=False,
                      n_jobs=1, solver=LocalRidgeSolver(n_atoms=K, lam=lam, power=power,
                                                        first_atoms=first))
                for _ in range(2)]  # the faster of 2 runs
        res = runs[0][0]
        rows.append(dict(head, what="local ridge", atoms=d.n_atoms, K=K, first=first,
                         lam=lam, power=power, seconds=build + min(r[1] for r in runs),
                         cpu=build_cpu + min(r[2] for r in runs),
                         err=pose_error(res.poses, P, mask),
                         fallback=int(res.fallback.sum()),
                         statuses={s: int(c) for s, c in
                                   zip(*np.unique(res.status, return_counts=True))}))
        print(rows[-1], flush=True)
    return rows


def local_speed(rows):
    """``{(K, first): {file: CPU seconds}}``: the median over the (lam, power)
    settings of each (K, first), which all do the same work."""
    runs = {}
    for r in rows:
        if r["what"] == "local ridge":
            runs.setdefault((r["K"], r["first"]), {}).setdefault(r["file"], []).append(r["cpu"])
    return {key: {f: float(np.median(c)) for f, c in by_file.items()}
            for key, by_file in runs.items()}


def choose_local(rows):
    """The --local choice (see the module docstring): the setting, its mean error,
    and how many (K, first) were fast enough."""
    imputer = {r["file"]: r["cpu"] for r in rows if r["what"] == "IterativeImputer"}
    speed = local_speed(rows)
    previous = speed[PREVIOUS_RIDGE["n_atoms"], PREVIOUS_RIDGE["first_atoms"]]
    fast = {key for key, cpu in speed.items()
            if all(imputer[f] >= MIN_SPEEDUP * c and c <= MAX_SLOWDOWN * previous[f]
                   for f, c in cpu.items())}
    errors = {}
    for r in rows:
        if r["what"] == "local ridge" and (r["K"], r["first"]) in fast:
            errors.setdefault((r["K"], r["first"], r["lam"], r["power"]), []).append(r["err"])
    key = min(errors, key=lambda k: np.mean(errors[k]))
    return {"K": key[0], "first": key[1], "lam": key[2], "power": key[3],
            "err": float(np.mean(errors[key])), "cpu": speed[key[:2]],
            "fast_enough": sorted(fast, key=str), "K_first": len(speed)}


def local_table(rows):
    """Markdown: per K and first pass, the best error of each file over lam and
    power (at its lam, power) and the speed-up on the imputer (CPU seconds,
    :func:`local_speed`)."""
    files = list(dict.fromkeys(r["file"] for r in rows))
    imputer = {r["file"]: r["cpu"] for r in rows if r["what"] == "IterativeImputer"}
    speed = local_speed(rows)
    out = ["| K | first pass | " + " | ".join(f"file {i + 1}: Err_ave % (lam, power), "
                                             "speed-up" for i in range(len(files))) + " |",
           "|---|---|" + "---|" * len(files)]
    keys = dict.fromkeys((r["K"], r["first"]) for r in rows if r["what"] == "local ridge")
    for K, first in keys:
        cells = []
        for f in files:
            rs = [r for r in rows if r["what"] == "local ridge" and r["file"] == f
                  and (r["K"], r["first"]) == (K, first)]
            b = min(rs, key=lambda r: r["err"])
            cells.append(f"{b['err']:.3f} ({b['lam']:g}, {b['power']:g}), "
                         f"{imputer[f] / speed[K, first][f]:.2f}x")
        out.append(f"| {K} | {first or 'none'} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def scale(base, settings, repeats=5, n=30000):
    """CPU seconds of the local ridge with each of `settings` on a file of `n`
    CMU poses of every clip (half under Mix; timing only, errors not used),
    one BLAS thread, ``n_jobs=1``, the median of `repeats` interleaved runs
    (rows of a JSON)."""
    import sparseedm
    from benchmarks import load_cmu
    from benchmarks.default_path import make_file
    from sparseedm.file_atoms import file_dictionary
    from sparseedm.solvers.local_ridge import LocalRidgeSolver

    P, mask = make_file(np.asarray(load_cmu()[0], dtype=float), n, seed=0)
    X = np.where(mask[..., None], np.nan, P)

    def one(kw):
        d = file_dictionary(base, X, mask, max_atoms=10 ** 9).dictionary
        return sparseedm.recover(X, mask, dictionary=d, adapt=False, n_jobs=1,
                                 solver=LocalRidgeSolver(**kw))

    cpu = [[timed(one, kw)[2] for kw in settings] for _ in range(repeats)]
    rows = [{"settings": kw, "poses": n, "cpu": float(np.median(c)), "runs": list(c),
             "vs_first": float(np.median(c) / np.median([r[0] for r in cpu]))}
            for kw, c in zip(settings, zip(*cpu))]
    for r in rows:
        print(r, flush=True)
    return rows


def gap_file(seed):
    """(poses, mask): every held-out CMU pose in clip order, each clip's 1-3 joints
    hidden in runs of 3, 10, 30 or 90 frames as ``benchmarks/temporal.py``'s video
    file hides them."""
    from benchmarks import load_cmu, split_clips

    poses, clips, _ = load_cmu()
    held, _ = split_clips(clips)
    P, C = np.asarray(poses[held], dtype=float), clips[held]
    rng = np.random.default_rng(seed)
    mask = np.zeros(P.shape[:2], bool)
    for clip in np.unique(C):
        rows = np.flatnonzero(C == clip)
        for j in rng.choice(14, rng.integers(1, 4), replace=False):
            t = int(rng.integers(0, 30))
            while t < len(rows):
                gap = int(rng.choice([3, 10, 30, 90]))
                mask[rows[t:t + gap], j] = True
                t += gap + int(rng.integers(gap, 4 * gap + 1))
    return P, mask


def with_coders(fill):
    """``{"shipped": fill(), "previous": fill()}`` with ``FAST_RIDGE`` as shipped
    and as ``PREVIOUS_RIDGE`` (restored after)."""
    from sparseedm import _recovery_kernel as kernel

    shipped, out = dict(kernel.FAST_RIDGE), {}
    for what, settings in (("shipped", shipped), ("previous", PREVIOUS_RIDGE)):
        kernel.FAST_RIDGE.clear()
        kernel.FAST_RIDGE.update(settings)
        try:
            out[what] = fill()
        finally:
            kernel.FAST_RIDGE.clear()
            kernel.FAST_RIDGE.update(shipped)
    return out


def _photo_errors(truth, missing):
    """The preset's mean hidden-joint error (% of body size), per occluded pose,
    and its lasso fallbacks."""
    import sparseedm
    from benchmarks import real2d

    res = sparseedm.recover(np.where(missing[..., None], np.nan, truth), missing,
                            preset="fast")
    err = np.linalg.norm(res.poses - truth, axis=-1) / real2d.body_size(truth)[:, None] * 100
    per_pose = np.nanmean(np.where(missing, err, np.nan)[missing.any(axis=1)], axis=1)
    return float(err[missing].mean()), per_pose, int(res.fallback.sum())


def gaps(seeds=(0, 1)):
    """``recover(preset="fast")``, shipped and previous coder, on :func:`gap_file`
    (each pose on its own; rows of a JSON)."""
    import sparseedm

    rows = []
    for seed in seeds:
        P, mask = gap_file(seed)
        X = np.where(mask[..., None], np.nan, P)
        err = with_coders(lambda: pose_error(sparseedm.recover(X, mask, preset="fast").poses,
                                             P, mask))
        rows.append({"seed": seed, "poses": len(P), "occluded": int(mask.any(axis=1).sum()),
                     "err_shipped": err["shipped"], "err_previous": err["previous"]})
        print(rows[-1], flush=True)
    return rows


def real_people(files=("bonn", "mpii-large"), protocols=("1", "2", "3", "real")):
    """``recover(preset="fast")`` with :data:`~sparseedm._recovery_kernel.FAST_RIDGE`
    and with ``PREVIOUS_RIDGE`` on the real-people validation files of
    ``studies/real_prior/harness.py`` (error of the hidden joints, % of body
    size; the difference paired per occluded pose, mean and standard error;
    rows of a JSON)."""
    from benchmarks import real2d
    from sparseedm._recovery_kernel import FAST_RIDGE
    from studies.real_prior.harness import FILES, make_file

    shipped, rows = dict(FAST_RIDGE), []
    for name in files:
        realset = real2d.load(FILES[name][0])
        for protocol in protocols:
            truth, missing = make_file(name, protocol, 0, None, realset)
            errs = with_coders(lambda: _photo_errors(truth, missing))
            d = errs["shipped"][1] - errs["previous"][1]
            rows.append({"file": name, "protocol": protocol, "occluded": int(len(d)),
                         "shipped": shipped, "previous": PREVIOUS_RIDGE,
                         "err_shipped": errs["shipped"][0], "err_previous": errs["previous"][0],
                         "diff_per_pose": float(d.mean()),
                         "diff_se": float(d.std() / np.sqrt(len(d))),
                         "fallback_shipped": errs["shipped"][2]})
            print(rows[-1], flush=True)
    return rows


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
                    help="choose the local ridge coder's K, first pass, lam and power")
    ap.add_argument("--scale", action="store_true",
                    help="time the previous and the shipped coder on 30,000 CMU poses")
    ap.add_argument("--gaps", action="store_true",
                    help="the preset's settings against the previous ones on held-out CMU "
                         "clips with a video's gaps")
    ap.add_argument("--real", action="store_true",
                    help="the preset's settings against the previous ones on real people "
                         "(validation splits)")
    args = ap.parse_args(argv)
    if args.real:
        out = Path(__file__).with_name("selection_fast_real.json")
        out.write_text(json_text({"rows": real_people()}, indent=1))
        return
    if args.gaps:
        out = Path(__file__).with_name("selection_fast_gaps.json")
        out.write_text(json_text({"rows": gaps()}, indent=1))
        return
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
    if args.scale:
        from sparseedm._recovery_kernel import FAST_RIDGE

        with threadpool_limits(1, user_api="blas"):
            rows = scale(base, [PREVIOUS_RIDGE, FAST_RIDGE, dict(FAST_RIDGE, first_atoms=32),
                                dict(PREVIOUS_RIDGE, first_atoms=32)])
        out = Path(__file__).with_name("selection_fast_scale.json")
        out.write_text(json_text({"blas_threads": 1, "loadavg": os.getloadavg(),
                                  "rows": rows}, indent=1))
        return
    if args.local:
        with threadpool_limits(1, user_api="blas"):
            rows = (local_grid(base, "6,000 CMU held-out-clip poses, half under Mix", P, mask)
                    + local_grid(base, "every held-out CMU pose, a quarter under Mix",
                                 *validation_file(n=10 ** 6, occluded=0.25)))
        out = Path(__file__).with_name("selection_fast_local.json")
        out.write_text(json_text({"blas_threads": 1, "loadavg": os.getloadavg(),
                                  "choice": choose_local(rows), "rows": rows}, indent=1))
        print(choose_local(rows))
        print(local_table(rows))
        return
    if args.caps:
        out = Path(__file__).with_name("selection_fast_caps.json")
        out.write_text(json_text({"file": "every held-out CMU pose, a quarter under Mix",
                                  "rows": caps(base)}, indent=1))
        return
    if args.solvers:
        out = Path(__file__).with_name("selection_fast_solvers.json")
        out.write_text(json_text({"file": "6,000 CMU held-out-clip poses, half under Mix",
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
    out.write_text(json_text({"file": "6,000 CMU held-out-clip poses, half under Mix",
                              "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
