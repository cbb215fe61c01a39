"""The shape-model fill (``probe_shape3d.py``, the ``raw`` CMU model) stacked with
``recover(adapt=False)`` at fixed weights by the pose's count of hidden joints
(1, 2, 3, 4 or more), as ``cold_bank.COLD_BANK_WEIGHTS`` are: each count's
weight of ``probe_shape3d.WEIGHTS`` chosen on the seed-0 files of ``--choose``
(every masks protocol pooled, the lowest mean error of that count's poses),
then read on the other seeds and files (held out from the choice), and on the
mocap control of ``probe_shape3d_mocap.py`` (the model from CMU subjects 01-03
there, ``cmu-k2000``). Gains [mean, paired standard error over poses],
positive: lower error.

    python studies/real_prior/probe_shape3d_counts.py --choose mpii,bonn \\
        --files mpii,coco,coco-val,bonn,mpii-large --mocap cmu_07_08_35.npz cmu_16_49_55.npz \\
        --out results_shape3d_counts.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from sparseedm._atomic import json_text  # noqa: E402
import sparseedm  # noqa: E402
from benchmarks import real2d  # noqa: E402
import harness  # noqa: E402
from probe_shape3d import POSES, WEIGHTS, gain_se, per_pose  # noqa: E402
from shape3d_answers import answers  # noqa: E402
from shape3d_model import build_model, cmu_poses, shape_fill  # noqa: E402
from sparseedm.metrics import occlusion_masks  # noqa: E402

COUNTS = (1, 2, 3, 4)  # 4: four or more


def count_of(missing):
    return np.minimum(missing.sum(axis=1), 4)[missing.any(axis=1)]


def stacked_errors(cold, fill, truth, missing):
    """(weights, occluded poses) errors and the poses' counts."""
    return (np.array([per_pose((1 - w) * cold + w * fill, truth, missing) for w in WEIGHTS]),
            count_of(missing))


def apply(errs, counts, weights):
    """Per-pose errors at each count's weight, and the gain over w = 0."""
    idx = np.array([int(np.flatnonzero(WEIGHTS == weights[c])[0]) for c in counts])
    chosen = errs[idx, np.arange(errs.shape[1])]
    return gain_se(errs[0] - chosen)


def mocap_files(paths, model, kw, seeds):
    out = []
    for path in paths:
        with np.load(path, allow_pickle=False) as z:
            poses = z["poses2d"]
        for seed in seeds:
            rng = np.random.default_rng(seed)
            truth = poses[rng.choice(len(poses), 400, replace=False)]
            missing = np.zeros((400, 14), bool)
            missing[100:] = occlusion_masks(300, 14, ("mix",), seed)["mix"]
            given = np.where(missing[..., None], np.nan, truth)
            cold = sparseedm.recover(given, missing, dictionary="cmu-k2000", adapt=False).poses
            out.append((f"{Path(path).name} seed {seed}",
                        stacked_errors(cold, shape_fill(model, given, missing, **kw), truth,
                                       missing)))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--choose", default="mpii,coco,bonn")
    ap.add_argument("--files", default="mpii,coco,bonn,mpii-large")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--mocap", nargs="*", type=Path, default=[])
    ap.add_argument("--k", type=int, default=16)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--temperature", type=float, default=0.1)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    model = build_model(np.load(POSES), a.k)
    kw = dict(noise=a.noise, temperature=a.temperature)
    seeds = [int(s) for s in a.seeds.split(",")]
    files = {}
    for name in a.files.split(","):
        rs = real2d.load(harness.FILES[name][0])
        for protocol in harness.PROTOCOLS:
            for seed in seeds:
                truth, missing, got = answers(name, protocol, seed, rs, methods=("cold",))
                given = np.where(missing[..., None], np.nan, truth)
                files[(name, protocol, seed)] = stacked_errors(
                    got["cold"], shape_fill(model, given, missing, **kw), truth, missing)
    choice = [v for (n, _, s), v in files.items() if s == 0 and n in a.choose.split(",")]
    errs = np.concatenate([e for e, _ in choice], axis=1)
    counts = np.concatenate([c for _, c in choice])
    weights = {int(c): float(WEIGHTS[np.argmin(errs[:, counts == c].mean(axis=1))])
               for c in COUNTS if (counts == c).any()}
    print("weights by count of hidden joints:", weights)
    out = {"settings": {"k": a.k, "noise": a.noise, "temperature": a.temperature,
                        "choose": a.choose, "weights": weights}, "files": {}}
    for (name, protocol, seed), (e, c) in files.items():
        held = "chosen on" if (seed == 0 and name in a.choose.split(",")) else "held out"
        row = {"gain": apply(e, c, weights), "split": held}
        out["files"].setdefault(name, {}).setdefault(protocol, {})[str(seed)] = row
        print(name, protocol, seed, row, flush=True)
    mocap_model = build_model(cmu_poses(subjects=("01", "02", "03"), step=8), a.k)
    for label, (e, c) in mocap_files(a.mocap, mocap_model, kw, seeds):
        out["files"].setdefault("mocap", {})[label] = {"gain": apply(e, c, weights)}
        print(label, out["files"]["mocap"][label], flush=True)
    if a.out:
        a.out.write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
