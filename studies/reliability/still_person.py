"""A still person's frames and other people: does the exemplar rule
(``sparseedm.exemplars.choose_exemplars``: the file's complete poses as the only
atoms, unchecked, from EXEMPLAR_MIN_POSES of them) count poses
(REPEAT_TOLERANCE, 1e-4 of the pose's size) or the atoms file_dictionary makes
of them (near-copies within ATOM_SPACING, 5e-3, merged)?

Files from the CMU fixture poses (tests/fixtures/cmu_poses.npz, 200 px tall):
2,100 frames of one still person (its first pose with `noise` px of detector
noise) then the 333 other poses, every other one with 1-3 random joints hidden;
the hidden joints' mean error in px, ``recover()`` with its defaults, the rule
counting atoms (the default) against counting poses (as before). Also the
jittered-copies file of tests/test_exemplars.py (2,050 complete poses resampled
from the fixture with 0.5 px noise, 300 occluded).

Run from the repository root:
``python -m studies.reliability.still_person [--out studies/reliability/still_person.json]``
"""
from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from sparseedm._atomic import json_text
import sparseedm.exemplars as exemplars
from sparseedm import recover
from sparseedm.adaptation import guard_masks, pose_vectors, repeat_rows

ROOT = Path(__file__).resolve().parents[2]


def _counting_poses(file_dictionary):
    """file_dictionary whose count is the poses' (repeats once), as the rule was."""
    def counted(dictionary, poses, *args, **kwargs):
        found = file_dictionary(dictionary, poses, *args, **kwargs)
        distinct = len(poses) - int(repeat_rows(pose_vectors(poses)).sum())
        return replace(found, n_atoms=max(found.n_atoms, distinct))
    return counted


def still_file(cmu, noise, seed):
    rng = np.random.default_rng(seed)
    truth = np.concatenate([cmu[0] + rng.normal(0, noise, (2100, 14, 2)), cmu[1:]])
    hidden = np.zeros(truth.shape[:2], bool)
    for i in range(2100, len(truth), 2):
        hidden[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
    return truth, hidden


def copies_file(cmu, seed):
    rng = np.random.default_rng(seed)
    truth = cmu[np.sort(rng.integers(0, len(cmu), 2350))] + rng.normal(0, 0.5, (2350, 14, 2))
    hidden = np.zeros(truth.shape[:2], bool)
    hidden[2050:] = guard_masks(300, 14, random_state=seed)
    return truth, hidden


def errors(truth, hidden):
    """Hidden joints' mean error (px) with the rule counting atoms, and poses."""
    poses = np.where(hidden[..., None], np.nan, truth)
    out = {}
    for name in ("atoms", "poses"):
        kept = exemplars.file_dictionary
        if name == "poses":
            exemplars.file_dictionary = _counting_poses(kept)
        try:
            res = recover(poses, hidden)
        finally:
            exemplars.file_dictionary = kept
        out[name] = float(np.linalg.norm(res.poses - truth, axis=-1)[hidden].mean())
        out[f"{name}_path"] = res.adaptation.path
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="studies/reliability/still_person.json")
    args = ap.parse_args()
    with np.load(ROOT / "tests/fixtures/cmu_poses.npz") as d:
        cmu = d["poses2d"].astype(float)
    cmu = cmu * 200 / np.ptp(cmu[:, :, 1], axis=1).mean()
    rows = []
    for seed in (0, 1, 2):
        for noise in (0.1, 0.25):
            rows.append(dict(file=f"still person, {noise} px", seed=seed,
                             **errors(*still_file(cmu, noise, seed))))
        rows.append(dict(file="jittered copies", seed=seed, **errors(*copies_file(cmu, seed))))
    for r in rows:
        print(f"{r['file']:24s} seed {r['seed']}: counting atoms {r['atoms']:.2f} px "
              f"({r['atoms_path']}), counting poses {r['poses']:.2f} px ({r['poses_path']})")
    Path(args.out).write_text(json_text(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
