"""A candidate shipped prior: the CMU atoms plus COCO's complete training poses as atoms.

COCO annotations are CC BY 4.0 (the COCO Consortium, https://cocodataset.org):
only poses of real2d's ``coco`` set in its ``train`` split (by image,
``benchmarks/real2d.split``) are used, so COCO's ``val`` and ``test`` poses stay
unseen. ``--mirror`` adds their left-right mirror images. ``--necks 0,0.2``
keeps each pose in two neck conventions: COCO's (the shoulders' midpoint, 0)
and an upper neck 0.2 of the way from there to the head top, as MPII and
PoseTrack annotate it (the lasso picks the exemplars whose neck fits).

    python studies/real_prior/coco_prior.py -o cmu-coco.npz [--mirror] [--necks 0,0.2] \\
        [--alpha 0.0005]

The shipped files: ``--mirror`` is ``cmu-coco-k2466``, ``--mirror --necks
0,0.2`` is ``cmu-coco-k2932``.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks import real2d  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.file_atoms import with_file_atoms  # noqa: E402
from sparseedm.skeleton import SKELETON_14  # noqa: E402


def raise_neck(poses, t):
    """`poses` with the neck moved to the shoulders' midpoint + `t` (head top - it)."""
    mid = (poses[:, 2] + poses[:, 5]) / 2
    out = poses.copy()
    out[:, 1] = mid + t * (poses[:, 0] - mid)
    return out


def coco_train_poses(mirror=False, necks=(0.0,)):
    """COCO's complete poses of the train split, (n, 14, 2): one copy per neck
    position in `necks` (:func:`raise_neck`), mirrored ones appended."""
    rs = real2d.load("coco")
    poses = rs.poses[rs.complete & (real2d.split(rs) == "train")]
    poses = np.concatenate([poses if t == 0 else raise_neck(poses, t) for t in necks])
    if mirror:
        flipped = poses[:, SKELETON_14.flip_permutation()].copy()
        flipped[..., 0] *= -1
        poses = np.concatenate([poses, flipped])
    return poses


def build(base="default", mirror=False, alpha=None, necks=(0.0,)):
    """The base dictionary with COCO's training poses as unit-norm atoms."""
    base = load_dictionary(base)
    poses = coco_train_poses(mirror, necks)
    out = with_file_atoms(base, poses, max_atoms=len(poses)).dictionary
    prov = dict(base.provenance or {})
    prov["coco_atoms"] = {
        "source": "COCO 2017 keypoint annotations (CC BY 4.0, the COCO Consortium, "
                  "https://cocodataset.org): the complete 14-joint poses of real2d's "
                  "coco set in its train split (neck = shoulders' midpoint, head top "
                  "derived from the face points)",
        "poses": int(len(poses)), "mirrored": bool(mirror),
        "builder": "studies/real_prior/coco_prior.py"}
    if tuple(necks) != (0.0,):
        prov["coco_atoms"]["necks"] = [float(t) for t in necks]
        prov["coco_atoms"]["source"] += (
            "; each also with its neck raised from the shoulders' midpoint toward the "
            "head top by the fractions in 'necks' (0: COCO's own)")
    return replace(out, provenance=prov,
                   alpha_recover=base.alpha_recover if alpha is None else alpha)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--out", type=Path, required=True)
    ap.add_argument("--base", default="default")
    ap.add_argument("--mirror", action="store_true")
    ap.add_argument("--alpha", type=float)
    ap.add_argument("--necks", default="0", help="neck positions, comma-separated "
                    "(0: the shoulders' midpoint, 1: the head top)")
    a = ap.parse_args(argv)
    d = build(a.base, a.mirror, a.alpha, tuple(float(t) for t in a.necks.split(",")))
    d.save(a.out)
    print(f"wrote {a.out}: {d.n_components} atoms", flush=True)


if __name__ == "__main__":
    main()
