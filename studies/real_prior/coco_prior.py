"""A candidate shipped prior: the CMU atoms plus COCO's complete training poses as atoms.

COCO annotations are CC BY 4.0 (the COCO Consortium, https://cocodataset.org):
only poses of real2d's ``coco`` set in its ``train`` split (by image,
``benchmarks/real2d.split``) are used, so COCO's ``val`` and ``test`` poses stay
unseen. ``--mirror`` adds their left-right mirror images.

    python studies/real_prior/coco_prior.py -o cmu-coco.npz [--mirror] [--alpha 0.0005]
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


def coco_train_poses(mirror=False):
    """COCO's complete poses of the train split, (n, 14, 2), mirrored ones appended."""
    rs = real2d.load("coco")
    poses = rs.poses[rs.complete & (real2d.split(rs) == "train")]
    if mirror:
        flipped = poses[:, SKELETON_14.flip_permutation()].copy()
        flipped[..., 0] *= -1
        poses = np.concatenate([poses, flipped])
    return poses


def build(base="default", mirror=False, alpha=None):
    """The base dictionary with COCO's training poses as unit-norm atoms."""
    base = load_dictionary(base)
    poses = coco_train_poses(mirror)
    out = with_file_atoms(base, poses, max_atoms=len(poses)).dictionary
    prov = dict(base.provenance or {})
    prov["coco_atoms"] = {
        "source": "COCO 2017 keypoint annotations (CC BY 4.0, the COCO Consortium, "
                  "https://cocodataset.org): the complete 14-joint poses of real2d's "
                  "coco set in its train split (neck = shoulders' midpoint, head top "
                  "derived from the face points)",
        "poses": int(len(poses)), "mirrored": bool(mirror),
        "builder": "studies/real_prior/coco_prior.py"}
    return replace(out, provenance=prov,
                   alpha_recover=base.alpha_recover if alpha is None else alpha)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--out", type=Path, required=True)
    ap.add_argument("--base", default="default")
    ap.add_argument("--mirror", action="store_true")
    ap.add_argument("--alpha", type=float)
    a = ap.parse_args(argv)
    d = build(a.base, a.mirror, a.alpha)
    d.save(a.out)
    print(f"wrote {a.out}: {d.n_components} atoms", flush=True)


if __name__ == "__main__":
    main()
