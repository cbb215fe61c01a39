"""Regenerate examples/video_clip.csv (and its ground truth) from CMU motion capture.

    python examples/make_video_example.py [--data-dir ../shared/data]

Two CMU clips of subject 02 (02_01 walk, 02_05 punch/strike; data from
mocap.cs.cmu.edu, created with funding from NSF EIA-0196217), each seen by one
seeded virtual camera at ~40 frames per second of motion, each as one track of
its first 150 frames (``N_FRAMES``), or all of it when the clip is shorter: the
walk has 86 frames, so the tracks have 86 and 150. Joints are hidden as the video evaluation's Protocol B hides them:
while behind the torso as seen from the camera, plus 5 % short dropouts
(:func:`sparseedm.temporal.evaluation.protocol_masks`). Written with
:func:`sparseedm.keypoints.write_keypoints`: columns ``track`` and ``frame``,
two decimals, empty cells for the hidden joints. The truth of every joint is
in ``video_clip_truth.npz`` (``poses2d``, ``missing``; allow_pickle=False).
"""

import argparse
import warnings
from pathlib import Path

import numpy as np

from sparseedm._atomic import save_npz
from sparseedm.dataset import build_dataset
from sparseedm.keypoints import KeypointSet, write_keypoints
from sparseedm.temporal.evaluation import protocol_masks
from sparseedm.temporal.sequences import sequences_from_dataset

HERE = Path(__file__).resolve().parent
OUTPUT = HERE / "video_clip.csv"
TRUTH = HERE / "video_clip_truth.npz"
CLIPS = ("02_01", "02_05")
N_FRAMES = 150
SEED = 2026


def example(data_dir):
    """(poses with NaN where hidden, missing, truth, tracks, frames) of the example."""
    files = [Path(data_dir) / "cmu-mocap" / "subjects" / "02" / f"{c}.amc" for c in CLIPS]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = build_dataset(files, camera="clip", random_state=SEED, progress=False)
    parts = []
    for seq in sequences_from_dataset(data, max_frames=10_000):
        keep = slice(0, N_FRAMES)
        truth = seq.poses2d[keep].round(2)
        missing = protocol_masks(seq, "self-occlusion", random_state=SEED)["self-occlusion"]
        missing = missing[keep]
        parts.append((truth, missing, np.full(len(truth), seq.clip), seq.frames[keep]))
    truth, missing, tracks, frames = (np.concatenate(x) for x in zip(*parts))
    poses = np.where(missing[..., None], np.nan, truth)
    return poses, missing, truth, tracks, frames


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default=HERE.parent.parent / "shared" / "data")
    args = ap.parse_args()
    poses, missing, truth, tracks, frames = example(args.data_dir)
    write_keypoints(OUTPUT, KeypointSet(poses, missing, tracks=tracks, frames=frames))
    save_npz(TRUTH, {"poses2d": truth, "missing": missing}, compressed=True)  # atomically
    print(f"wrote {OUTPUT}: {len(poses)} frames in {len(set(tracks))} tracks, "
          f"{int(missing.sum())} joints hidden; the truth in {TRUTH.name}")


if __name__ == "__main__":
    main()
