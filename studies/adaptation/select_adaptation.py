"""Choose the adaptation settings of sparseedm.adaptation on cross-source validation splits.

    python studies/adaptation/select_adaptation.py --data-dir ../shared/data \\
        --work /tmp/select_adaptation --out studies/adaptation/selection_adaptation.json

Directions (dictionary learned on one source, adapted to and scored on another):

* ``cmu->bandai``: the shipped default (CMU ASF/AMC subjects 01-03) on Bandai-Namco;
* ``bandai->cmu``: a k = 2000 dictionary learned here on all Bandai-Namco poses
  (kept in --work, never committed: CC BY-NC) on the CMU ASF/AMC clips;
* ``cmu->daz``: the shipped default on the CMU Daz-rig BVH clips (dance,
  martial arts; another rig: its head top is 0.18 m beyond the head joint
  along the neck-head bone, :mod:`sparseedm.mocap.rigs`; 0.2 m in grids
  1-7). Since the default became ``cmu-all-k2000`` (learned on the Daz
  clips too) this is in-domain, so
* ``cmu0103->daz``: the shipped ``cmu-k2000`` (CMU subjects 01-03 only) on the
  Daz clips, the cross-source Daz direction of grids 6, 7 and 3.

(``cmu->bandai`` used subjects 01-03's ``cmu-k2000`` in grids 1-4, the
all-CMU default in grids 5-7 and the final grid 3.)

The target's clips, sorted, are split three ways by clip: clip i with
``i % 3 == 0`` is an *adaptation* clip (its complete poses adapt), ``1`` a
*validation* clip (scored here), ``2`` a *test* clip (left for the README's
table, ``sparseedm evaluate --adapt-fraction``; never looked at here). Scored
poses: a seeded sample of --n-score validation poses, Mix occlusion (1-3
joints), the masks of :func:`sparseedm.evaluation.occlusion_masks`; the
figure is the mean Err_ave (%) of the recovered pixel EDMs.

Grid 1 (n_adapt = 3000 poses, no guard, no filter): one axis at a time
around fresh statistics / 3 passes / training alpha 1.6 / no replay: inner
statistics (fresh / carried with memory 1 or 10), passes (1, 3, 5), training
alpha (0.4, 0.8, 1.6), replay of base atoms (0, 0.25). Grid 2: the chosen setting against the number of adaptation poses,
with the guard on (what ``recover(adapt="auto")`` does), to choose
MIN_COMPLETE_POSES. Grid 4: 2 vs 3 passes of the chosen setting, and recovery
alpha 0.002 vs 0.0005 for the adapted dictionary (and the cold one). Grids
5-7 (the follow-up with the all-CMU default, ``--n-score 400``): one change at
a time around the shipped setting (passes, batch size, forgetting, replay of
real source vectors, re-drawing atoms from all poses, mirrored poses, union
with the base atoms, k), then training alpha x recovery alpha and passes, then
k = 3000. Grid 3
(``--grid 3``, after the choice): the README's
table, cold vs adapted vs baselines on the *test* clips, through
``sparseedm evaluate --adapt-from``; it records the Err_ave of the completed
EDMs and of the filled poses (``<method> filled``), and with ``--ensemble K``
(key ``test_ensembleK``) the adapted row averages K adapted dictionaries
(:mod:`sparseedm.ensemble`); with ``--self-training R`` (key
``test_self_trainingR``) the adapted row runs R self-training rounds instead
of the default's (0: adaptation only). Grid 9: ensembles of 1, 3 and 5 adapted dictionaries
on the validation poses. Grid 8: rounds of self-training
(:func:`sparseedm.adaptation.self_train`) after the adaptation, on the
validation poses and, as a check, on other poses of the adaptation clips.
About 15 minutes per grid single-threaded on an idle machine.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

from sparseedm._atomic import json_text
from sparseedm.adaptation import adapt_vectors, masked_error, pose_vectors as _vectors, run_adaptation
from sparseedm.dictionary import Dictionary, load_dictionary

def build(data_dir, work, name, seed):
    """The target's dataset .npz in `work` (built once)."""
    from sparseedm.dataset import build_dataset

    out = Path(work) / f"{name}.npz"
    if not out.is_file():
        folder = {"cmu": "cmu-mocap", "bandai": "bandai-namco-1", "daz": "cmu-bvh-daz"}[name]
        # the rig registry (sparseedm.mocap.rigs) names every joint; grids 1-7
        # predate it and read the Daz clips with a head top 0.2 m beyond the
        # head joint along the neck-head bone, the registry puts it 0.18 m
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            build_dataset(Path(data_dir) / folder, out, random_state=seed, progress=False)
    with np.load(out, allow_pickle=False) as z:
        return z["poses2d"].astype(float), z["clips"].astype(str)


def split(poses, clips):
    """(adaptation, validation, test) poses by clip: sorted clip index mod 3."""
    uc = np.unique(clips)
    part = {c: i % 3 for i, c in enumerate(uc)}
    which = np.array([part[c] for c in clips])
    return poses[which == 0], poses[which == 1], poses[which == 2]


def sample(poses, n, seed):
    if len(poses) <= n:
        return poses
    rng = np.random.default_rng(seed)
    return poses[np.sort(rng.choice(len(poses), n, replace=False))]


def source_dictionary(name, data_dir, work):
    if name == "cmu":
        return load_dictionary("default")
    if name == "cmu0103":  # subjects 01-03 only: the all-CMU default has seen the Daz clips
        return load_dictionary("cmu-k2000")
    path = Path(work) / "bandai-k2000.npz"
    if not path.is_file():
        from sparseedm.learning import fit_dictionary_file

        build(data_dir, work, "bandai", 1)
        fit_dictionary_file(Path(work) / "bandai.npz", path, n_components=2000, alpha=1.6,
                            n_passes=2, random_state=0, progress=False)
    return load_dictionary(path)


def with_atoms(base, components):
    return Dictionary(components, joint_names=base.joint_names,
                      alpha_recover=base.alpha_recover, alpha_train=base.alpha_train,
                      alpha_scaling=base.alpha_scaling, positive_code=base.positive_code)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default="../shared/data")
    ap.add_argument("--work", default="/tmp/select_adaptation")
    ap.add_argument("--out", default="selection_adaptation.json")
    ap.add_argument("--n-adapt", type=int, default=3000)
    ap.add_argument("--n-score", type=int, default=600)
    ap.add_argument("--directions", default="cmu->bandai,bandai->cmu,cmu->daz")
    ap.add_argument("--ensemble", type=int, default=1,
                    help="grid 3: average this many adapted dictionaries (sparseedm.ensemble)")
    ap.add_argument("--self-training", type=int, default=None, metavar="ROUNDS",
                    help="grid 3: self-training rounds of the adapted row (default: recover's)")
    ap.add_argument("--grid", default="1,2",
                    help="1, 2, 4 (the adaptation settings), 5, 6, 7 (the tuning follow-up), 8 (self-training), "
                    "9 (ensembles), 3 (test table)")
    args = ap.parse_args(argv)
    Path(args.work).mkdir(parents=True, exist_ok=True)
    out = {"settings": vars(args), "directions": {}}
    if Path(args.out).is_file():
        out = json.loads(Path(args.out).read_text())
    seeds = {"cmu": 0, "bandai": 1, "daz": 2}
    # one axis at a time around fresh / 3 passes / training alpha 1.6 / no replay
    # (a full product is too slow for a shared 2-core machine)
    base_cell = dict(stats="fresh", memory=0.0, passes=3, alpha=1.6, replay=0.0)
    grid = [base_cell] + [dict(base_cell, **change) for change in (
        {"passes": 1}, {"passes": 5}, {"alpha": 0.4}, {"alpha": 0.8}, {"replay": 0.25},
        {"stats": "carried", "memory": 1.0}, {"stats": "carried", "memory": 1.0, "passes": 5},
        {"stats": "carried", "memory": 10.0}, {"stats": "carried", "memory": 1.0,
                                               "replay": 0.25})]
    for direction in args.directions.split(","):
        src, dst = direction.split("->")
        base = source_dictionary(src, args.data_dir, args.work)
        poses, clips = build(args.data_dir, args.work, dst, seeds[dst])
        pool, val, _ = split(poses, clips)
        scored = sample(val, args.n_score, 1)
        rec = out["directions"].setdefault(direction, {})
        cold = masked_error(base, scored)
        if set("124") & set(args.grid):  # grids 1, 2 and 4 share these
            rec.update(n_pool=len(pool), n_val=len(val), n_scored=len(scored), cold=cold)
        tuned = dict(dictionary={"cmu": "default (cmu-all-k2000)", "cmu0103": "cmu-k2000",
                                 "bandai": "bandai-k2000"}[src],
                     n_adapt=args.n_adapt, n_scored=len(scored), cold=cold)
        print(f"{direction}: pool {len(pool)}, validation {len(val)}; cold {cold:.3f}",
              flush=True)
        if "1" in args.grid:
            A = sample(pool, args.n_adapt, 2)
            X = _vectors(A)
            rows = []
            for g in grid:
                t0 = time.perf_counter()
                comps = adapt_vectors(base.components, X, g["alpha"], passes=g["passes"],
                                      stats=g["stats"], memory=g["memory"] or 1.0,
                                      replay=g["replay"], random_state=0)
                secs = time.perf_counter() - t0
                err = masked_error(with_atoms(base, comps), scored)
                rows.append({**g, "err": err, "ratio_cold": err / cold, "seconds": secs})
                print(f"  {g} -> {err:.3f} ({err / cold:.2f}x cold) {secs:.1f} s", flush=True)
            rec["grid"] = rows
        if "2" in args.grid:
            chosen = out.get("chosen", dict(stats="fresh", memory=1.0, passes=3, alpha=1.6,
                                            replay=0.0))
            rows = []
            for n in (100, 250, 500, 1000, 2000, 5000):
                A = sample(pool, n, 3)
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    r = run_adaptation(base, A, min_poses=1, passes=chosen["passes"],
                                       alpha=chosen["alpha"], stats=chosen["stats"],
                                       memory=chosen["memory"], replay=chosen["replay"])
                secs = time.perf_counter() - t0
                used = masked_error(r.dictionary, scored)
                cand = masked_error(r.candidate, scored) if r.candidate is not None else cold
                rows.append({"n_adapt": len(A), "adapted": r.adapted, "n_used": r.n_used,
                             "guard_base": r.err_base, "guard_adapted": r.err_adapted,
                             "err_used": used, "err_candidate": cand,
                             "ratio_cold": used / cold, "seconds": secs})
                print(f"  n={len(A)}: adapted={r.adapted} guard {r.err_base:.2f}->"
                      f"{r.err_adapted:.2f}; scored {used:.3f} (candidate {cand:.3f}) "
                      f"{secs:.1f} s", flush=True)
            rec["min_poses"] = rows
        if "4" in args.grid:
            # after grids 1-2: 2 vs 3 passes, and the adapted dictionary's recovery alpha
            A = sample(pool, args.n_adapt, 2)
            X = _vectors(A)
            r = {}
            for passes in (2, 3):
                t0 = time.perf_counter()
                d = with_atoms(base, adapt_vectors(base.components, X, base.alpha_train,
                                                   passes=passes))
                r[f"passes{passes}_seconds"] = time.perf_counter() - t0
                for ar in ((0.002, 0.0005) if passes == 3 else (0.002,)):
                    r[f"passes{passes}_alpha_recover{ar}"] = masked_error(d, scored, alpha=ar)
            r["cold_alpha_recover0.0005"] = masked_error(base, scored, alpha=0.0005)
            rec["passes_and_recovery_alpha"] = r
            print(f"  grid 4: {r}", flush=True)
        if "5" in args.grid:
            rec["tune"] = dict(tuned, rows=tune_grid(base, src, pool, scored, cold, args))
        if "6" in args.grid:
            rec["alpha"] = dict(tuned, rows=alpha_grid(base, src, pool, scored, cold, args))
        if "7" in args.grid:
            cells = [("alpha_train 3.2, k 3000 (1000 atoms drawn from the adaptation poses "
                      "added)", {"alpha": 3.2, "extra_atoms": 1000})]
            rec["k3000"] = dict(tuned, rows=tune_grid(base, src, pool, scored, cold, args,
                                                      cells, (0.5,)))
        if "8" in args.grid:
            rec["self_training"] = dict(tuned, rows=self_training_grid(base, pool, scored, args))
        if "9" in args.grid:
            rec["ensemble"] = dict(tuned, rows=ensemble_grid(base, pool, scored, args))
        if "3" in args.grid:
            key = "test" if args.ensemble == 1 else f"test_ensemble{args.ensemble}"
            if args.self_training is not None:
                key += f"_self_training{args.self_training}"
            rec[key] = test_table(base, src, dst, args, poses, clips)
        Path(args.out).write_text(json_text(out, indent=1, default=float))
    return 0


#: grid 5 (a follow-up with the all-CMU default): one change at a time
#: around the first shipped setting (fresh, 2 passes, batch 256, training
#: alpha = the base's, recovery alpha x 0.25). Keys besides adapt_vectors'
#: arguments: ``replay_real`` (replay a sample of the source's own training
#: vectors), ``most_used`` (keep only the k base atoms the adaptation poses use
#: most), ``union`` (recover with the adapted atoms and the base atoms),
#: ``mirror`` (add the left/right mirror of every adaptation pose),
#: ``alpha_factor`` (training alpha = the base's times this).
TUNE_CELLS = [
    ("shipped", {}),
    ("passes 4", {"passes": 4}),
    ("batch 128", {"batch_size": 128}),
    ("reinit from all poses", {"reinit": True}),
    ("forget 0.9", {"forget": 0.9}),
    ("replay 0.25 source training vectors", {"replay": 0.25, "replay_real": True}),
    ("union of adapted and base atoms (k 4000)", {"union": True}),
    ("mirrored poses added, 1 pass", {"mirror": True, "passes": 1}),
    ("mirrored poses added, 2 passes", {"mirror": True}),
    ("k 1000 most used base atoms", {"most_used": 1000}),
    ("k 500 most used base atoms", {"most_used": 500}),
]
TUNE_FACTORS = (0.1, 0.25, 0.5)
#: grid 6: the adaptation's training alpha (absolute: the EDM vectors are
#: normalised, the bases' own are 0.8 for the all-CMU default and 1.6 for the
#: Bandai-Namco one) against the recovery alpha (x the base's); then passes
GRID6_ALPHAS = (1.6, 2.4, 3.2, 4.8)
RECOVER_FACTORS = (0.25, 0.5, 1.0)


def _adapt_cell(base, src, A, X, change, args, cache):
    """Atoms adapted as one grid-5/6 cell says (see TUNE_CELLS)."""
    from sparseedm.adaptation import _swap
    from sparseedm.learning import sparse_code
    from sparseedm.skeleton import SKELETON_14

    change = dict(change)
    C0 = base.components
    alpha = change.pop("alpha", base.alpha_train * change.pop("alpha_factor", 1.0))
    if change.pop("replay_real", False):
        if "real" not in cache:
            name = "bandai" if src == "bandai" else "cmu"
            src_poses, _ = build(args.data_dir, args.work, name, {"cmu": 0, "bandai": 1}[name])
            cache["real"] = _vectors(sample(src_poses, 20000, 5))
        change["replay_vectors"] = cache["real"]
    if change.pop("mirror", False):
        pairs = list(zip(SKELETON_14.joints_left, SKELETON_14.joints_right))
        X = np.vstack([X, _vectors(_swap(A, pairs))])
    extra = change.pop("extra_atoms", 0)
    if extra:  # more atoms: rows of X, unit-normalised, appended to the base's
        rows = X[np.random.default_rng(7).choice(len(X), extra, replace=False)]
        C0 = np.vstack([C0, rows / np.linalg.norm(rows, axis=1, keepdims=True)])
    k = change.pop("most_used", None)
    if k:
        use = (sparse_code(X, C0, base.alpha_train) != 0).sum(axis=0)
        C0 = C0[np.sort(np.argsort(-use, kind="stable")[:k])]
    union = change.pop("union", False)
    comps = adapt_vectors(C0, X, alpha, random_state=0, **change)
    return np.vstack([comps, base.components]) if union else comps


def tune_grid(base, src, pool, scored, cold, args, cells=TUNE_CELLS, factors=None):
    """Grids 5 and 6 on the validation clips: each cell's atoms, scored with
    the recovery alpha factors (`factors`, default TUNE_FACTORS for the
    shipped cell and 0.25 for the others)."""
    A = sample(pool, args.n_adapt, 2)
    X = _vectors(A)
    cache, rows = {}, []
    for name, change in cells:
        t0 = time.perf_counter()
        comps = _adapt_cell(base, src, A, X, change, args, cache)
        secs = time.perf_counter() - t0
        d = with_atoms(base, comps)
        for f in factors or (TUNE_FACTORS if name == "shipped" else (0.25,)):
            err = masked_error(d, scored, alpha=base.alpha_recover * f)
            rows.append({"cell": name, "alpha_recover_factor": f, "err": err,
                         "ratio_cold": err / cold, "seconds": secs})
            print(f"  {name}, alpha x{f}: {err:.3f} ({err / cold:.2f}x cold) {secs:.1f} s",
                  flush=True)
    return rows


def alpha_grid(base, src, pool, scored, cold, args):
    """Grid 6: training alpha x recovery alpha of the adapted dictionary, then
    passes 1 and 4 at alpha 3.2."""
    cells = [(f"alpha_train {a}", {"alpha": a}) for a in GRID6_ALPHAS]
    rows = tune_grid(base, src, pool, scored, cold, args, cells, RECOVER_FACTORS)
    cells = [(f"alpha_train 3.2, passes {p}", {"alpha": 3.2, "passes": p}) for p in (1, 4)]
    return rows + tune_grid(base, src, pool, scored, cold, args, cells, (0.5,))


def self_training_grid(base, pool, scored, args, rounds=(0, 1, 2, 3, 4)):
    """Grid 8: rounds of :func:`sparseedm.adaptation.self_train` after adapting.

    ``recover(occluded scored poses, adapt=A, self_training=r)``: A = the
    --n-adapt adaptation poses, the scored (validation) poses occluded by the
    protocol's Mix masks, so each round learns from the recovered validation
    poses' observed joints (their hidden joints are only ever the scores').
    Also: IterativeImputer fitted on A (the goal's baseline), and the same
    rounds on poses of the *adaptation* clips not in A (the input and the
    complete poses from the same clips, as in one video file).
    """
    from sparseedm import recover
    from sparseedm.baselines import fit_baseline
    from sparseedm.edm import pose_to_vector
    from sparseedm.evaluation import occlusion_masks
    from sparseedm.metrics import err_ave

    rng = np.random.default_rng(2)
    ia = np.sort(rng.choice(len(pool), min(args.n_adapt, len(pool)), replace=False))
    A = pool[ia]
    rest = np.setdiff1d(np.arange(len(pool)), ia)
    same = pool[np.sort(np.random.default_rng(3).choice(rest, min(len(scored), len(rest)),
                                                        replace=False))]
    rows = []
    for name, P in (("validation clips", scored), ("adaptation clips, other poses", same)):
        mask = occlusion_masks(len(P), P.shape[1], ("mix",), random_state=0)["mix"]
        inputs = np.where(mask[..., None], np.nan, P)
        truth = pose_to_vector(P)

        def err(res):
            e = err_ave(res.vectors * res.scale[:, None], truth)
            return float(np.nanmean(np.where(res.ok, e, np.nan)))

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            imputer = err(fit_baseline("iterative", A).complete(inputs, mask))
            cold = err(recover(inputs, mask, dictionary=base, adapt=False))
            for r in rounds if name == "validation clips" else (0, 3):
                t0 = time.perf_counter()
                res = recover(inputs, mask, dictionary=base, adapt=A, self_training=r, n_jobs=2)
                rows.append({"scored": name, "rounds": r, "err": err(res), "cold": cold,
                             "iterative": imputer, "adapted": res.adapted,
                             "seconds": time.perf_counter() - t0,
                             "self_training": res.adaptation.summary()["self_training"]})
                print(f"  grid 8 [{name}] rounds {r}: {rows[-1]['err']:.3f} (cold {cold:.3f}, "
                      f"iterative {imputer:.3f}) {rows[-1]['seconds']:.1f} s", flush=True)
    return rows


def ensemble_grid(base, pool, scored, args, sizes=(1, 3, 5)):
    """Grid 9: ``recover(..., ensemble=K)`` (:mod:`sparseedm.ensemble`) on the validation poses.

    The grid-8 protocol (A = the --n-adapt adaptation poses, the scored
    validation poses under the Mix masks, default self-training), scored on
    the completed EDMs and on the filled poses' EDMs, with cold and
    IterativeImputer (fitted on A) scored the same two ways.
    """
    from sparseedm import recover
    from sparseedm.baselines import fit_baseline
    from sparseedm.edm import pose_to_vector
    from sparseedm.evaluation import occlusion_masks
    from sparseedm.metrics import err_ave

    A = pool[np.sort(np.random.default_rng(2).choice(len(pool), min(args.n_adapt, len(pool)),
                                                     replace=False))]
    mask = occlusion_masks(len(scored), scored.shape[1], ("mix",), random_state=0)["mix"]
    inputs = np.where(mask[..., None], np.nan, scored)
    truth = pose_to_vector(scored)

    def errs(res):
        ok = res.ok
        e = err_ave(res.vectors * res.scale[:, None], truth)
        f = err_ave(pose_to_vector(res.poses), truth)
        return (float(np.nanmean(np.where(ok, e, np.nan))),
                float(np.nanmean(np.where(ok, f, np.nan))))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows = [dict(zip(("method", "err", "err_filled"),
                         ("iterative",) + errs(fit_baseline("iterative", A).complete(inputs,
                                                                                    mask)))),
                dict(zip(("method", "err", "err_filled"),
                         ("cold",) + errs(recover(inputs, mask, dictionary=base, adapt=False))))]
        for K in sizes:
            t0 = time.perf_counter()
            res = recover(inputs, mask, dictionary=base, adapt=A, ensemble=K, n_jobs=2)
            rows.append(dict(zip(("method", "err", "err_filled"),
                                 (f"adapted, ensemble {K}",) + errs(res)),
                             members=res.members, seconds=time.perf_counter() - t0))
            print(f"  grid 9: {rows[-1]}", flush=True)
    return rows


def test_table(base, src, dst, args, poses, clips):
    """Grid 3, run once after the choice: the README's table on the *test* clips.

    ``sparseedm evaluate --adapt-from`` (the CLI, in process) with the
    adaptation clips' poses (a seeded sample of --n-adapt) and the test clips'
    poses (a seeded subsample of 2 x --n-score), Mix occlusion; baselines fitted
    on the same adaptation poses.
    """
    import csv

    from sparseedm.cli import main as cli

    pool, _, test = split(poses, clips)
    work = Path(args.work) / f"test_{src}_{dst}"
    work.mkdir(parents=True, exist_ok=True)
    np.savez(work / "adapt.npz", poses2d=sample(pool, args.n_adapt, 2))
    np.savez(work / "test.npz", poses2d=test)
    dict_path = work / "base.npz"
    base.save(dict_path)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cli(["evaluate", "--dictionary", str(dict_path), "--data", str(work / "test.npz"),
             "--adapt-from", str(work / "adapt.npz"), "--methods",
             "sparse,mean-fill,knn,iterative,nearest", "--counts", "mix",
             "--representations", "average", "--max-poses", str(2 * args.n_score),
             "--ensemble", str(args.ensemble),
             *(["--self-training", str(args.self_training)]
               if args.self_training is not None else []),
             "-o", str(work / "report")])
    with open(work / "report" / "results.csv") as f:
        table = list(csv.DictReader(f))
    rows = {r["method"]: float(r["err_ave_mean"]) for r in table}
    # the same metric on the filled poses' EDM (column added after the first
    # tables; the imputers fill joints, so theirs is unchanged)
    rows.update({f"{r['method']} filled": float(r["err_ave_filled"]) for r in table
                 if "err_ave_filled" in r})
    rows["seconds"] = time.perf_counter() - t0
    rows["n_test_clips_poses"] = int(len(test))
    print(f"  test: {rows}", flush=True)
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
