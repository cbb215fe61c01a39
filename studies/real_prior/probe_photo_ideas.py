"""Ideas for the photo protocol measured on validation files, none adopted.

``--idea alpha``: a per-pose alpha chosen by a held-out-entry check. For each
pose, up to 3 of its observed joints are hidden in turn and recovered at each
alpha of a grid (0.3, 1, 3, 10 times the dictionary's); the pose is then
recovered at the alpha that predicted its own held-out joints best.

``--idea placement``: the hidden joints read from the completed EDM as one
shape (classical MDS of the merged distance matrix, aligned to the observed
joints by an orthogonal Procrustes fit, with or without a scale; "avg": the
mean of that answer and the least-squares placement) instead of the
least-squares placement on distances.

``--idea mirror``: the file's complete poses and their left/right mirror
images as atoms (mirroring a pose in the image swaps its left and right joints
and keeps its distances), on `cmu-all-k2000` and on `cmu-coco-k2466`.

``--idea blend``: several dictionaries, their answers averaged: the mean of
the filled joints from `cmu-all-k2000` and from `cmu-coco-k2466` (each with
the file's atoms; "blend+mirror": the second with mirrored file atoms too).

Each runs `recover(adapt=False)` on the shipped dictionary ("cold") and on it
plus the file's complete poses as atoms ("atoms": the defaults' path on files
below adaptation's size). Photo files from ``harness.FILES`` (validation
splits, seed 0) and mocap files of 100 complete + 500 Mix poses
(``select_scale.mocap_file``).

    python studies/real_prior/probe_photo_ideas.py --idea alpha --sources mpii,coco-val,bonn \\
        --mocap bandai.npz
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from sparseedm._atomic import json_text  # noqa: E402

from studies.real_prior import harness, select_scale  # noqa: E402


def recover(d, truth, missing, alpha=None):
    import sparseedm

    return sparseedm.recover(np.where(missing[..., None], np.nan, truth), missing,
                             dictionary=d, adapt=False, alpha=alpha)


def probe_masks(missing, probes, rng):
    """Rows, masks and held-out joints: each pose with up to `probes` more joints hidden
    in turn (keeping 3 observed)."""
    rows, masks, joints = [], [], []
    for i in np.flatnonzero(missing.any(axis=1)):
        obs = np.flatnonzero(~missing[i])
        for j in rng.choice(obs, size=max(0, min(probes, len(obs) - 3)), replace=False):
            m = missing[i].copy()
            m[j] = True
            rows.append(i), masks.append(m), joints.append(j)
    return np.array(rows, int), np.array(masks, bool).reshape(-1, missing.shape[1]), \
        np.array(joints, int)


def per_pose_alpha(d, truth, missing, factors=(0.3, 1, 3, 10), probes=3, seed=0):
    """Filled poses, each recovered at the alpha that predicted its held-out joints best."""
    grid = [d.alpha_recover * f for f in factors]
    rows, masks, joints = probe_masks(missing, probes, np.random.default_rng(seed))
    scores = np.zeros((len(grid), len(truth)))
    for g, a in enumerate(grid):
        if len(rows):
            res = recover(d, truth[rows], masks, a)
            err = np.linalg.norm(res.poses[np.arange(len(rows)), joints]
                                 - truth[rows, joints], axis=-1)
            np.add.at(scores[g], rows, err)
    best = np.where(np.bincount(rows, minlength=len(truth)) > 0, scores.argmin(axis=0),
                    list(factors).index(1))
    out = truth.copy()
    for g, a in enumerate(grid):
        sel = np.flatnonzero((best == g) & missing.any(axis=1))
        if len(sel):
            out[sel] = recover(d, truth[sel], missing[sel], a).poses
    return out


def mds_placement(res, truth, missing, with_scale=False):
    """Hidden joints from the MDS shape of each completed EDM, Procrustes-aligned."""
    from sparseedm.edm import vector_to_edm

    out = res.poses.copy()
    N = missing.shape[1]
    J = np.eye(N) - 1.0 / N
    for i in np.flatnonzero(missing.any(axis=1) & (res.status == "recovered")):
        B = -0.5 * J @ vector_to_edm(res.vectors[i]) ** 2 @ J
        w, V = np.linalg.eigh(B)
        X = V[:, -2:] * np.sqrt(np.maximum(w[-2:], 0))
        obs = ~missing[i]
        Y = (truth[i, obs] - res.center[i]) / res.scale[i]
        ma, my = X[obs].mean(axis=0), Y.mean(axis=0)
        U, S, Wt = np.linalg.svd((X[obs] - ma).T @ (Y - my))
        s = S.sum() / ((X[obs] - ma) ** 2).sum() if with_scale else 1.0
        Z = (X - ma) @ (U @ Wt) * s + my
        out[i, missing[i]] = Z[missing[i]] * res.scale[i] + res.center[i]
    return out


def mirrored_atoms(base, truth, missing):
    """`base` plus the file's complete poses and their mirror images as atoms."""
    from sparseedm.file_atoms import with_file_atoms
    from sparseedm.skeleton import SKELETON_14

    complete = truth[~missing.any(axis=1)]
    both = np.concatenate([complete, complete[:, SKELETON_14.flip_permutation()]])
    return with_file_atoms(base, both, max_atoms=10**6).dictionary


def run_case(idea, truth, missing):
    """``{variant: % body size}`` of one file."""
    from sparseedm.dictionary import load_dictionary
    from sparseedm.file_atoms import with_file_atoms

    base = load_dictionary()
    given = np.where(missing[..., None], np.nan, truth)
    row = {}
    for variant, d in (("cold", base),
                       ("atoms", with_file_atoms(base, given, missing).dictionary)):
        res = recover(d, truth, missing)
        row[variant] = harness.score(res.poses, truth, missing)
        if idea == "alpha":
            row[f"{variant}+cv"] = harness.score(per_pose_alpha(d, truth, missing), truth,
                                                 missing)
        elif idea == "placement":
            for tag, sc in (("mds", False), ("mdss", True)):
                placed = mds_placement(res, truth, missing, sc)
                row[f"{variant}+{tag}"] = harness.score(placed, truth, missing)
                row[f"{variant}+avg-{tag}"] = harness.score((placed + res.poses) / 2, truth,
                                                            missing)
    if idea == "blend":
        coco = load_dictionary("cmu-coco-k2466")
        mine = recover(with_file_atoms(base, given, missing).dictionary, truth, missing).poses
        theirs = recover(with_file_atoms(coco, given, missing).dictionary, truth,
                         missing).poses
        mirrored = recover(mirrored_atoms(coco, truth, missing), truth, missing).poses
        row["blend"] = harness.score((mine + theirs) / 2, truth, missing)
        row["blend+mirror"] = harness.score((mine + mirrored) / 2, truth, missing)
    if idea == "mirror":
        coco = load_dictionary("cmu-coco-k2466")
        row["coco atoms"] = harness.score(recover(
            with_file_atoms(coco, given, missing).dictionary, truth, missing).poses,
            truth, missing)
        for tag, b in (("atoms+mirror", base), ("coco atoms+mirror", coco)):
            row[tag] = harness.score(recover(mirrored_atoms(b, truth, missing), truth,
                                             missing).poses, truth, missing)
    return {k: round(v, 3) for k, v in row.items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--idea", choices=("alpha", "placement", "mirror", "blend"), required=True)
    ap.add_argument("--sources", default="mpii,coco-val,bonn")
    ap.add_argument("--mocap", default="", help="dataset .npz files, comma-separated")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    data = select_scale.files([s for s in a.sources.split(",") if s],
                              [m for m in a.mocap.split(",") if m])
    table = {}
    for name, cases in data.items():
        rows = [run_case(a.idea, t, m) for t, m in cases]
        table[name] = {k: [r[k] for r in rows] for k in rows[0]}
        print(name, table[name], flush=True)
    if a.out:
        a.out.write_text(json_text({"idea": a.idea, "protocols": list(harness.PROTOCOLS),
                                    "table": table}, indent=1) + "\n")


if __name__ == "__main__":
    main()
