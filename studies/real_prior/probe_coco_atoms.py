"""Variants of the COCO exemplar atoms for the cold prior (``recover(adapt=False)``),
paired per occluded pose against ``cmu-coco-k2466``.

Every variant is the default's 2000 CMU atoms plus exemplar atoms made from
COCO's training poses (``coco_prior.py``'s, the train split only):

* ``necks``: each pose also with its neck raised toward the head top by the
  listed fractions (0: COCO's shoulders' midpoint); ``0,0.2`` is the shipped
  ``cmu-coco-k2932``; ``one-neck``: half the poses (and the other half's
  mirror images) raised, the other half kept, so the count stays 466;
* ``completed``: also COCO's training poses with 1-3 unannotated joints, filled
  by ``cmu-coco-k2932`` (``adapt=False``);
* ``xscale``: also one copy with x stretched by a random factor in
  0.8-1.25 (camera foreshortening);
* ``pruned``: ``cmu-coco-k2932`` without the 466 CMU atoms least used by the
  lasso codes of 3,000 CMU training poses and of COCO's (over the CMU atoms);
* ``COCO only``: ``cmu-coco-k2932``'s 932 COCO atoms without the CMU ones;
* ``raised head``: as ``cmu-coco-k2932``, but the raised-neck copies also have
  their head top 1.1 times as far from the shoulders' midpoint (MPII's head
  tops lie higher than COCO's derived ones).

Photos: ``harness.py``'s files (validation splits); mocap: ``sparseedm dataset
build`` files, 100 complete + 500 Mix-occluded poses. Score: per occluded pose
the mean error of its hidden joints (% of body size); paired: variant minus
``cmu-coco-k2466``, mean ± standard error over the poses.

    python studies/real_prior/probe_coco_atoms.py --photos mpii,bonn,coco-val \\
        --mocap cmu.npz,bandai.npz,daz_indian.npz --out studies/real_prior/results_coco_atoms.json
    python studies/real_prior/probe_coco_atoms.py --photos mpii,bonn --only "COCO only" \
        --out studies/real_prior/results_coco_only.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import coco_prior  # noqa: E402
import harness  # noqa: E402
from default_prior import per_pose  # noqa: E402

from benchmarks import real2d  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm import recover  # noqa: E402
from sparseedm.adaptation import pose_vectors  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.file_atoms import with_file_atoms  # noqa: E402
from sparseedm.learning import sparse_code  # noqa: E402
from sparseedm.metrics import occlusion_masks  # noqa: E402
from sparseedm.skeleton import SKELETON_14  # noqa: E402

REFERENCE = "cmu-coco-k2466"


def mirrored(poses):
    flipped = poses[:, SKELETON_14.flip_permutation()].copy()
    flipped[..., 0] *= -1
    return np.concatenate([poses, flipped])


def with_necks(poses, necks):
    return np.concatenate([coco_prior.raise_neck(poses, t) if t else poses for t in necks])


def exemplars(poses, alpha=None):
    """The default's atoms with `poses` appended as exemplar atoms."""
    base = load_dictionary()
    d = with_file_atoms(base, poses, max_atoms=len(poses)).dictionary
    return replace(d, alpha_recover=base.alpha_recover if alpha is None else alpha)


def completed_poses(shipped):
    """COCO's training poses with 1-3 unannotated joints, filled by `shipped`."""
    rs = real2d.load("coco")
    train = real2d.split(rs) == "train"
    n_missing = (~rs.annotated).sum(axis=1)
    complete = rs.poses[rs.complete & train]
    partial = rs.poses[train & (n_missing >= 1) & (n_missing <= 3)]
    res = recover(np.concatenate([complete, partial]), dictionary=shipped, adapt=False)
    return res.poses[len(complete):]


def head_further(poses, factor):
    """`poses` with the head top `factor` times as far from the shoulders' midpoint."""
    mid = (poses[:, 2] + poses[:, 5]) / 2
    out = poses.copy()
    out[:, 0] = mid + factor * (poses[:, 0] - mid)
    return out


def stretched(poses, seed=0):
    rng = np.random.default_rng(seed)
    s = np.exp(rng.uniform(np.log(0.8), np.log(1.25), len(poses)))[:, None]
    out = poses.copy()
    c = out[..., 0].mean(axis=1, keepdims=True)
    out[..., 0] = (out[..., 0] - c) * s + c
    return out


def pruned(shipped, n_drop=466, seed=1, cmu_path=None):
    """`shipped` without its `n_drop` least used CMU atoms."""
    k = shipped.n_components - 932
    cmu = np.load(cmu_path)["poses2d"]
    cmu = cmu[np.random.default_rng(seed).choice(len(cmu), 3000, replace=False)]
    use = np.zeros(k)
    for poses, atoms in ((cmu, shipped.components), (coco_prior.coco_train_poses(True, (0, 0.2)),
                                                      shipped.components[:k])):
        u = np.abs(sparse_code(pose_vectors(poses), atoms, shipped.alpha_recover)[:, :k]).sum(0)
        use += u / u.sum()
    keep = np.concatenate([np.sort(np.argsort(use)[n_drop:]), np.arange(k, shipped.n_components)])
    return replace(shipped, components=shipped.components[keep])


def variants(cmu_path=None):
    """{name: Dictionary} of the measured variants."""
    plain = coco_prior.coco_train_poses()
    shipped = exemplars(mirrored(with_necks(plain, (0, 0.2))))
    half = np.random.default_rng(0).random(len(plain)) < 0.5
    one = mirrored(plain)
    one[np.concatenate([half, ~half])] = coco_prior.raise_neck(
        one[np.concatenate([half, ~half])], 0.2)
    more = np.concatenate([plain, completed_poses(shipped)])
    out = {REFERENCE: load_dictionary(REFERENCE), "necks 0,0.2": shipped,
           "necks 0,0.2, alpha 0.001": replace(shipped, alpha_recover=0.001),
           "one-neck": exemplars(one)}
    for necks in ((0, 0.1), (0, 0.3), (0.2,), (0, 0.1, 0.2, 0.3)):
        out["necks " + ",".join(map(str, necks))] = exemplars(mirrored(with_necks(plain, necks)))
    out["necks 0,0.2 + completed"] = exemplars(mirrored(with_necks(more, (0, 0.2))))
    out["necks 0,0.2 + xscale"] = exemplars(mirrored(with_necks(
        np.concatenate([plain, stretched(plain)]), (0, 0.2))))
    out["COCO only"] = replace(shipped, components=shipped.components[-932:])
    out["raised head"] = exemplars(mirrored(np.concatenate(
        [plain, coco_prior.raise_neck(head_further(plain, 1.1), 0.2 / 1.1)])))
    if cmu_path:
        out["necks 0,0.2, pruned to 2466"] = pruned(shipped, cmu_path=cmu_path)
    return out


def neck_positions(mocap=()):
    """{set: median of where the neck lies from the shoulders' midpoint (0) to the
    head top (1)} over complete poses (real2d's validation splits, mocap files)."""
    sets = {}
    for source in ("coco", "mpii", "bonn"):
        rs = real2d.load(source)
        sets[f"{source} val"] = rs.poses[rs.complete & (real2d.split(rs) == "val")]
    for path in mocap:
        with np.load(path, allow_pickle=False) as z:
            sets[Path(path).stem] = z["poses2d"][::10].astype(float)
    out = {}
    for name, poses in sets.items():
        mid = (poses[:, 2] + poses[:, 5]) / 2
        up, neck = poses[:, 0] - mid, poses[:, 1] - mid
        out[name] = round(float(np.median((up * neck).sum(-1) / (up * up).sum(-1))), 3)
    return out


def paired(truth, missing, dics):
    """{name: {error, paired mean, se, seconds}} of one file, cold."""
    per, sec = {}, {}
    for name, d in dics.items():
        t0 = time.perf_counter()
        per[name] = per_pose(harness.sparse(adapt=False, dictionary=d)(truth, missing),
                             truth, missing)
        sec[name] = time.perf_counter() - t0
    out = {}
    for name, e in per.items():
        diff = e - per[REFERENCE]
        out[name] = {"error": round(float(e.mean()), 3), "seconds": round(sec[name], 1),
                     "paired": round(float(diff.mean()), 3),
                     "se": round(float(diff.std(ddof=1) / np.sqrt(len(diff))), 3)}
    return out


def mocap_file(path, C=100, M=500, seed=0):
    with np.load(path, allow_pickle=False) as z:
        poses = z["poses2d"].astype(float)
    truth = poses[np.random.default_rng(seed).choice(len(poses), C + M, replace=False)]
    missing = np.zeros((C + M, 14), bool)
    missing[C:] = occlusion_masks(M, 14, ("mix",), seed)["mix"]
    return truth, missing


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photos", default="mpii,bonn,coco-val")
    ap.add_argument("--mocap", default="", help="dataset .npz paths, comma-separated; the "
                    "first is also the CMU training sample of 'pruned'")
    ap.add_argument("--only", default="", help="these variants (comma-separated) and the "
                    "reference only")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    mocap = [p for p in a.mocap.split(",") if p]
    doc = {"neck_positions": neck_positions(mocap)}
    print(json.dumps(doc), flush=True)
    dics = variants(mocap[0] if mocap else None)
    if a.only:
        dics = {k: v for k, v in dics.items() if k in (REFERENCE, *a.only.split(","))}
    for name in filter(None, a.photos.split(",")):
        for protocol in harness.PROTOCOLS:
            doc[f"{name} {protocol}"] = paired(*harness.make_file(name, protocol), dics)
            print(name, protocol, json.dumps(doc[f"{name} {protocol}"]), flush=True)
    for path in mocap:
        doc[Path(path).stem] = paired(*mocap_file(path), dics)
        print(path, json.dumps(doc[Path(path).stem]), flush=True)
    if a.out:
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
