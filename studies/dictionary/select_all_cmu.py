"""Relearn the default dictionary from every CMU clip we have, choosing on held-out subjects.

Training data: the CMU ASF/AMC subjects (``sparseedm dataset build
../shared/data/cmu-mocap``) and the CMU Daz-named BVH clips, one dataset per
folder (``salsa``, ``martial``, ``indian``: each folder is treated as one
"subject" group, since the files do not say which CMU subject performed).

Split **by subject**: the groups the current default (``cmu-k2000``, subjects
01-03) never saw, in sorted order (05 ... 55, daz-indian, daz-martial,
daz-salsa), every third from the second is held out for validation; all
other groups train. The validation set takes up to ``--max-val / 2`` poses
from the held-out CMU ASF subjects and as many from the held-out Daz group,
and the error is the mean of the two sources' Mix Err_ave (1-3 occluded
joints, seeded).

Steps (all single-threaded, k = 2000):

1. grid: training alpha x recovery alpha, one pass;
2. at the grid's best alphas: two passes, and left-right mirrored training
   poses added (``--variants``);
3. the current ``cmu-k2000`` on the same validation poses (its own alpha);
4. information only, never used to choose: Mix Err_ave on Bandai-Namco poses
   (``--bandai``) for ``cmu-k2000`` and the chosen setting;
5. with ``--ship PATH``: the chosen setting learned on ALL groups, saved.

    python studies/dictionary/select_all_cmu.py --cmu cmu_asf.npz \\
        --daz salsa=daz_salsa.npz,martial=daz_martial.npz,indian=daz_indian.npz \\
        [--bandai bandai.npz] --out studies/dictionary/selection_all_cmu.json \\
        [--ship dictionaries/cmu-all-k2000.npz]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.dictionary.select_alpha import choose  # noqa: E402

from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import Dictionary, load_dictionary  # noqa: E402
from sparseedm.edm import pose_to_vector  # noqa: E402
from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors  # noqa: E402
from sparseedm.metrics import err_ave, random_occlusion  # noqa: E402
from sparseedm.recovery import recover  # noqa: E402
from sparseedm.skeleton import SKELETON_14  # noqa: E402

#: groups the current default was trained on: never held out
OLD_TRAINING = {"01", "02", "03"}


def load_groups(cmu, daz):
    """poses2d (n, 14, 2), group per row, source ("cmu-asf"/"daz") per row."""
    poses, groups, sources = [], [], []
    with np.load(cmu, allow_pickle=False) as npz:
        poses.append(npz["poses2d"])
        groups.append(npz["subjects"])
        sources.append(np.full(len(npz["subjects"]), "cmu-asf"))
    for name, path in daz.items():
        with np.load(path, allow_pickle=False) as npz:
            n = len(npz["poses2d"])
            poses.append(npz["poses2d"])
            groups.append(np.full(n, f"daz-{name}"))
            sources.append(np.full(n, "daz"))
    return np.concatenate(poses), np.concatenate(groups), np.concatenate(sources)


def held_out(groups):
    """Every third group from the second, among those cmu-k2000 never saw."""
    names = sorted(set(groups.tolist()) - OLD_TRAINING)
    return [g for i, g in enumerate(names) if i % 3 == 1]


def data_parser(doc):
    """An argument parser with the --cmu and --daz datasets every script here reads."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--cmu", required=True)
    ap.add_argument("--daz", required=True, help="name=path,... one dataset per Daz folder")
    return ap


def load_split(args):
    """(poses2d, groups, sources, is_val) of the --cmu/--daz datasets, split by subject."""
    daz = dict(item.split("=", 1) for item in args.daz.split(","))
    poses, groups, sources = load_groups(args.cmu, daz)
    return poses, groups, sources, np.isin(groups, held_out(groups))


def mirrored(poses2d):
    """Left-right mirror images: x negated and left/right joints swapped."""
    out = poses2d[:, SKELETON_14.flip_permutation()].copy()
    out[..., 0] *= -1
    return out


def mix_error(dictionary, poses, seed=0):
    mask = random_occlusion(len(poses), 14, "mix", random_state=seed)
    res = recover(np.where(mask[..., None], np.nan, poses), mask, dictionary=dictionary)
    err = float(np.nanmean(err_ave(res.vectors * res.scale[:, None], pose_to_vector(poses))))
    return err, float(res.n_active.mean())


def sample(poses, n, seed=0):
    rng = np.random.default_rng(seed)
    return poses[np.sort(rng.choice(len(poses), min(n, len(poses)), replace=False))]


def main(argv=None):
    ap = data_parser(__doc__)
    ap.add_argument("--bandai", help="Bandai-Namco dataset: cross-source information only")
    ap.add_argument("--atoms", type=int, default=2000)
    ap.add_argument("--train-alphas", default="0.8,1.6,3.2")
    ap.add_argument("--recover-alphas", default="0.0005,0.002,0.005")
    ap.add_argument("--variants", default="2:no,1:mirror",
                    help="passes:mirror|no, ... tried at the grid's best alphas")
    ap.add_argument("--max-val", type=int, default=1000)
    ap.add_argument("--out", default="selection_all_cmu.json")
    ap.add_argument("--ship", help="learn the chosen setting on all groups and save it here")
    args = ap.parse_args(argv)

    daz = dict(item.split("=", 1) for item in args.daz.split(","))
    poses, groups, sources, is_val = load_split(args)
    val_groups = held_out(groups)
    val = {s: sample(poses[is_val & (sources == s)], args.max_val // 2) for s in ("cmu-asf", "daz")}
    train = poses[~is_val]
    X, _ = complete_pose_vectors(train)
    X_mirror, _ = complete_pose_vectors(np.concatenate([train, mirrored(train)]))
    print(f"train {len(X)} poses ({len(set(groups[~is_val].tolist()))} groups), "
          f"validation groups {val_groups}: " + ", ".join(f"{k} {len(v)}" for k, v in val.items()),
          flush=True)

    def evaluate(d):
        errs = {s: mix_error(d, v) for s, v in val.items()}
        return {"mix_err_ave": float(np.mean([e for e, _ in errs.values()])),
                **{f"mix_err_ave_{s}": e for s, (e, _) in errs.items()},
                "mean_active": float(np.mean([a for _, a in errs.values()]))}

    cache = {}

    def learn(data, a_train, passes, mirror=None):
        if mirror is not None and (a_train, passes, mirror) in cache:
            return cache[(a_train, passes, mirror)]
        t0 = time.perf_counter()
        odl = OnlineDictionaryLearning(args.atoms, alpha=a_train, batch_size=512,
                                       n_passes=passes, random_state=0).fit(data)
        out = odl.components_, time.perf_counter() - t0
        if mirror is not None:
            cache[(a_train, passes, mirror)] = out
        return out

    rows = []

    def run(components, fit_s, a_train, a_rec, passes, mirror):
        d = Dictionary(components, alpha_recover=a_rec, alpha_train=a_train)
        row = dict(alpha_train=a_train, alpha_recover=a_rec, passes=passes, mirror=mirror,
                   fit_s=fit_s, **evaluate(d))
        rows.append(row)
        print(json.dumps(row), flush=True)
        return row

    a_recs = [float(a) for a in args.recover_alphas.split(",")]
    for a_train in [float(a) for a in args.train_alphas.split(",")]:
        comp, fit_s = learn(X, a_train, 1, False)
        for a_rec in a_recs:
            run(comp, fit_s, a_train, a_rec, 1, False)
    grid_best = choose(rows)
    a_train = grid_best["alpha_train"]
    variants = []
    for item in args.variants.split(","):
        passes, mirror = int(item.split(":")[0]), item.split(":")[1] == "mirror"
        comp, fit_s = learn(X_mirror if mirror else X, a_train, passes, mirror)
        variants.append(run(comp, fit_s, a_train, grid_best["alpha_recover"], passes, mirror))
    best = min([grid_best] + variants, key=lambda r: r["mix_err_ave"])

    old = load_dictionary("cmu-k2000")
    baseline = dict(name="cmu-k2000", alpha_train=old.alpha_train,
                    alpha_recover=old.alpha_recover, **evaluate(old))
    print("cmu-k2000:", json.dumps(baseline), flush=True)
    result = {"validation_groups": val_groups,
              "training_groups": sorted(set(groups[~is_val].tolist())),
              "n_train": int(len(X)), "n_val": {k: int(len(v)) for k, v in val.items()},
              "rows": rows, "grid_best": grid_best, "best": best, "cmu_k2000": baseline,
              "new_is_better": best["mix_err_ave"] < baseline["mix_err_ave"]}

    if args.bandai:  # information only: never used to choose
        with np.load(args.bandai, allow_pickle=False) as npz:
            bandai = sample(npz["poses2d"], args.max_val)
        comp, _ = learn(X_mirror if best["mirror"] else X, best["alpha_train"], best["passes"],
                        best["mirror"])
        new = Dictionary(comp, alpha_recover=best["alpha_recover"],
                         alpha_train=best["alpha_train"])
        result["bandai_information_only"] = {
            "n": int(len(bandai)),
            "cmu_k2000": mix_error(old, bandai)[0],
            "best_setting_trained_on_training_groups": mix_error(new, bandai)[0],
        }
        print("bandai:", json.dumps(result["bandai_information_only"]), flush=True)
    if args.ship and not result["new_is_better"]:
        print("not shipped: cmu-k2000 is better on the held-out subjects", flush=True)
    elif args.ship:
        every = np.concatenate([poses, mirrored(poses)]) if best["mirror"] else poses
        X_all, _ = complete_pose_vectors(every)
        comp, fit_s = learn(X_all, best["alpha_train"], best["passes"])
        d = Dictionary(comp, alpha_recover=best["alpha_recover"], alpha_train=best["alpha_train"],
                       provenance={
                           "files": ["cmu-mocap (all subjects, ASF/AMC)",
                                     "cmu-bvh-daz (" + ", ".join(sorted(daz)) + ")"],
                           "n_poses": int(len(X_all)), "mirrored": bool(best["mirror"]),
                           "n_passes": int(best["passes"]), "batch_size": 512,
                           "random_state": 0, "selection": "studies/dictionary/selection_all_cmu.json",
                       })
        d.save(args.ship)
        result["shipped"] = {"path": str(args.ship), "n_poses": int(len(X_all)), "fit_s": fit_s}
        print(f"wrote {args.ship}", flush=True)
    with open(args.out, "w") as f:
        f.write(json_text(result, indent=1))
    print("best:", json.dumps(best), "| cmu-k2000:", baseline["mix_err_ave"])


if __name__ == "__main__":
    main()
