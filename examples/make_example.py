"""Regenerate examples/occluded_poses.csv from the committed CMU test fixture.

    python examples/make_example.py

Takes 50 real 2D poses (every few frames of the 9 CMU clips in
tests/fixtures/cmu_poses.npz, projected by seeded virtual cameras; data from
mocap.cs.cmu.edu, created with funding from NSF EIA-0196217), blanks 1-3
joints of each with the paper's seeded Mix occlusion
(:func:`sparseedm.metrics.random_occlusion`) and writes them with
:func:`sparseedm.keypoints.write_keypoints`: one pose per row, an ``id``
column ``<clip>_f<frame>``, empty cells for the occluded joints.
The ground truth of the blanked joints is in the fixture.
"""

from pathlib import Path

import numpy as np

from sparseedm.keypoints import write_keypoints
from sparseedm.metrics import random_occlusion

HERE = Path(__file__).resolve().parent
FIXTURE = HERE.parent / "tests" / "fixtures" / "cmu_poses.npz"
OUTPUT = HERE / "occluded_poses.csv"
N_POSES = 50
SEED = 2024


def example_rows(n_poses=N_POSES):
    """Indices into the fixture: evenly spread, so every clip appears."""
    with np.load(FIXTURE, allow_pickle=False) as data:
        n = len(data["poses2d"])
    return np.linspace(0, n - 1, n_poses).round().astype(int)


def main():
    with np.load(FIXTURE, allow_pickle=False) as data:
        rows = example_rows()
        poses = data["poses2d"][rows].copy()
        ids = [f"{c}_f{f}" for c, f in zip(data["clips"][rows], data["frames"][rows])]
    missing = random_occlusion(len(poses), poses.shape[1], "mix", random_state=SEED)
    poses[missing] = np.nan
    # two decimals: pixel keypoints as a detector would give them
    write_keypoints(OUTPUT, poses.round(2), ids=ids)
    print(f"wrote {OUTPUT}: {len(poses)} poses, {int(missing.sum())} joints blanked")


if __name__ == "__main__":
    main()
