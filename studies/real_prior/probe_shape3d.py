"""A view-aware 3D shape-model fill (``shape3d_model.py``) on the validation photo
files, alone and stacked with recover()'s answers.

The model: mean + K principal components of CMU motion-capture poses (every
8th frame of the 95 ASF/AMC clips, canonical facing, mirrored), fitted to each
occluded pose's observed joints through a scaled orthographic camera searched
over 24 azimuths x 7 elevations (roll from a similarity fit), ridge prior on the
coefficients (noise ``--noise``), soft-min over views (``--temperature``).
``calibrated``: the model's mean first moved so that it explains the file's
complete poses (per joint a 3D offset, least squares over their fitted
cameras: the annotation conventions of head top, neck, shoulders and hips are
not the mocap skeleton's); ``raw``: the CMU model as is (a cold candidate, no
file information); ``coco``: the mean moved so on the complete poses of
COCO's training images (``real2d.split == "train"``; CC BY 4.0, could shape a
shipped file), again no information from the file (the coco file's complete
poses are drawn from the same training images, so its reading is optimistic).

Files: ``harness.py``'s (mpii, coco, bonn, mpii-large; protocols 1/2/3/real;
seeds), answers of the defaults, ``adapt=False`` (cold) and IterativeImputer
from ``shape3d_answers.py``'s cache. Stacked: ``(1 - w) * base + w * shape3d``
for w in 0, 0.1, ..., 1; ``best`` is the per-file best w chosen on the truth
(an upper bound); ``cross`` chooses w on one half of the occluded poses and
scores it on the other (two folds), the honest reading of a weight chosen per
file; its gain over the base is [mean, paired standard error over poses].
Score: per occluded pose the mean error of its hidden joints, % of body size.

    python studies/real_prior/probe_shape3d.py --seeds 0,1,2 --out results_shape3d.json
    python studies/real_prior/probe_shape3d.py --table results_shape3d.json
    python studies/real_prior/probe_shape3d.py --files mpii,bonn --protocols 1,real --local \
        --out results_shape3d_local.json

``--table`` prints, per file and protocol, the means over seeds and the
cross-fitted gains pooled over seeds (mean of the seeds' gains, its standard
error from theirs).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from sparseedm._atomic import json_text  # noqa: E402

from benchmarks import real2d  # noqa: E402
import harness  # noqa: E402
from shape3d_answers import answers  # noqa: E402
from shape3d_model import (build_model, calibrate, canonical, cmu_poses, local_fill,  # noqa: E402
                           mirrored, shape_fill)

WEIGHTS = np.round(np.arange(0, 1.01, 0.1), 2)
POSES = Path("/tmp/shape3d/cmu_all_step8.npy")


def per_pose(filled, truth, missing):
    """Mean hidden-joint error per occluded pose, % of body size."""
    err = np.linalg.norm(filled - truth, axis=-1) / real2d.body_size(truth)[:, None] * 100
    occ = missing.any(axis=1)
    return np.where(missing, err, 0).sum(axis=1)[occ] / missing.sum(axis=1)[occ]


def gain_se(g):
    return [round(float(g.mean()), 3), round(float(g.std(ddof=1) / np.sqrt(len(g))), 3)]


def stacked(base, fill, truth, missing, seed):
    """best w, its gain; cross-fitted gain [mean, se] (positive: lower error)."""
    errs = np.array([per_pose((1 - w) * base + w * fill, truth, missing) for w in WEIGHTS])
    best = int(np.argmin(errs.mean(axis=1)))
    fold = np.random.default_rng(seed).permutation(errs.shape[1]) % 2
    cross = np.empty(errs.shape[1])
    chosen = []
    for f in (0, 1):
        k = int(np.argmin(errs[:, fold == f].mean(axis=1)))
        chosen.append(float(WEIGHTS[k]))
        cross[fold != f] = errs[k, fold != f]
    return {"best_w": float(WEIGHTS[best]),
            "best_gain": round(float(errs[0].mean() - errs[best].mean()), 3),
            "cross_w": chosen, "cross_gain": gain_se(errs[0] - cross)}


def scored_row(got, fills, truth, missing, seed):
    """One file's row: each answer of `got` and each shape-model fill of `fills`
    scored alone, and each fill stacked with the defaults and with ``cold``."""
    row = {m: round(harness.score(f, truth, missing), 3) for m, f in got.items()}
    row.update({f"shape3d_{k}": round(harness.score(f, truth, missing), 3)
                for k, f in fills.items()})
    for k, f in fills.items():
        for base in ("defaults", "cold"):
            row[f"{base}+{k}"] = stacked(got[base], f, truth, missing, seed)
    return row


def add_model_args(ap):
    """The shape model's arguments, shared by the shape3d probes."""
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--k", type=int, default=16)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--temperature", type=float, default=0.1)
    ap.add_argument("--out", type=Path)


def table(paths):
    """Markdown rows: file, protocol, II / defaults / cold / shape3d alone (means
    over seeds) and the pooled cross-fitted gains of the stacks."""
    from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

    files = {}
    for path in paths:
        for name, protos in load_results(path)["files"].items():
            for proto, seeds in protos.items():
                files.setdefault((name, proto), {}).update(seeds)
    stacks = ("defaults+raw", "defaults+calibrated", "defaults+coco", "cold+raw", "cold+coco",
              "cold+calibrated")
    lines = ["| file | masks | II | defaults | cold | shape3d raw / calibrated / coco | "
             + " | ".join(stacks) + " |", "|" + "---|" * (6 + len(stacks))]
    for (name, proto), seeds in files.items():
        rows = list(seeds.values())

        def mean(key):
            return f"{np.mean([r[key] for r in rows]):.2f}"

        cells = [name, proto, mean("iterative"), mean("defaults"), mean("cold"),
                 " / ".join(mean(f"shape3d_{k}") for k in ("raw", "calibrated", "coco"))]
        for st in stacks:
            g = np.array([r[st]["cross_gain"] for r in rows])
            se = np.sqrt((g[:, 1] ** 2).sum()) / len(g)
            cells.append(f"{g[:, 0].mean():+.2f} ± {se:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table", nargs="+", type=Path, help="print the table of these JSONs")
    ap.add_argument("--files", default="mpii,coco,bonn,mpii-large")
    ap.add_argument("--protocols", default=",".join(harness.PROTOCOLS))
    add_model_args(ap)
    ap.add_argument("--local", action="store_true",
                    help="also the local 3D model (shape3d_model.local_fill: 3,000 CMU poses"
                         " and their mirror images seen through each pose's fitted camera)")
    a = ap.parse_args(argv)
    if a.table:
        print(table(a.table))
        return
    if POSES.exists():
        poses3d = np.load(POSES)
    else:
        poses3d = cmu_poses(step=8)
        POSES.parent.mkdir(parents=True, exist_ok=True)
        np.save(POSES, poses3d)
    model = build_model(poses3d, a.k)
    coco = real2d.load("coco")
    coco_train = coco.poses[coco.complete & (real2d.split(coco) == "train")
                            & (real2d.body_size(coco.poses) > 0)]
    coco_model = calibrate(model, coco_train, noise=a.noise)
    kw = dict(noise=a.noise, temperature=a.temperature)
    bank = canonical(poses3d[np.random.default_rng(0).choice(len(poses3d), 3000, replace=False)])
    bank = np.concatenate([bank, mirrored(bank)])
    out = {"settings": {"k": a.k, "noise": a.noise, "temperature": a.temperature,
                        "weights": WEIGHTS.tolist()}, "files": {}, "seconds_per_1000": {}}
    secs = {"raw": [0.0, 0], "calibrated": [0.0, 0], "calibration": [0.0, 0]}
    for name in a.files.split(","):
        rs = real2d.load(harness.FILES[name][0])
        for protocol in a.protocols.split(","):
            for seed in map(int, a.seeds.split(",")):
                truth, missing, got = answers(name, protocol, seed, rs)
                given = np.where(missing[..., None], np.nan, truth)
                complete = truth[~missing.any(axis=1)]
                n_occ = int(missing.any(axis=1).sum())
                t0 = time.perf_counter()
                cal = calibrate(model, complete, noise=a.noise)
                t1 = time.perf_counter()
                fills = {"raw": shape_fill(model, given, missing, **kw)}
                t2 = time.perf_counter()
                fills["calibrated"] = shape_fill(cal, given, missing, **kw)
                t3 = time.perf_counter()
                fills["coco"] = shape_fill(coco_model, given, missing, **kw)
                if a.local:
                    f = local_fill(model, bank, given, missing, noise=a.noise)
                    fills["local"] = np.where(np.isfinite(f), f, got["cold"])
                for key, dt, n in (("calibration", t1 - t0, len(complete)),
                                   ("raw", t2 - t1, n_occ), ("calibrated", t3 - t2, n_occ)):
                    secs[key][0] += dt
                    secs[key][1] += n
                row = scored_row(got, fills, truth, missing, seed)
                out["files"].setdefault(name, {}).setdefault(protocol, {})[str(seed)] = row
                print(name, protocol, seed, json.dumps(row), flush=True)
    out["seconds_per_1000"] = {k: round(1000 * v[0] / max(v[1], 1), 2) for k, v in secs.items()}
    print(json.dumps(out["seconds_per_1000"]))
    if a.out:
        a.out.write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
