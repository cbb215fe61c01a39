"""Photos whose names hold numbers, read as a video: recovered across time
(frames taken from the names; ``sparseedm.batch.TIME_MIN_SHARE = 0``, as before
the rule) against the default, which recovers a file as photos when most of its
poses have no other frame of their track within MAX_SKIP frame numbers.

Validation photo files (COCO, MPII; up to 300 poses each): the real missing
joints kept, 1-3 random joints hidden on the complete poses, scored on those
(% of body size), the frame of each pose the number in its image's name.

Run from the repository root:
``python -m studies.reliability.photos_as_video [--out studies/reliability/photos_as_video.json]``
"""
from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import real2d  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm import batch  # noqa: E402
from sparseedm.batch import recover_file  # noqa: E402
from sparseedm.keypoints import read_keypoints, write_keypoints  # noqa: E402


def one_file(source, seed, tmp):
    """Hidden joints' mean error (% body size) across time and by the default."""
    s = real2d.load(source)
    v = s.take(real2d.split(s) == "val")
    v = v.take(np.arange(min(len(v), 300)))
    rng = np.random.default_rng(seed)
    poses = v.poses.copy()
    hidden = np.zeros(poses.shape[:2], bool)
    for i in np.flatnonzero(v.complete):
        hidden[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
    poses[hidden] = np.nan
    frames = [re.sub(r"\D", "", g.split("/")[-1]) or "0" for g in v.group]
    size = np.repeat(real2d.body_size(v.poses[v.complete]), hidden[v.complete].sum(1))
    src = tmp / f"{source}{seed}.csv"
    write_keypoints(src, poses, extra_columns={"frame": frames})
    out = {}
    for name, share in (("across_time", 0.0), ("default", batch.TIME_MIN_SHARE)):
        kept, batch.TIME_MIN_SHARE = batch.TIME_MIN_SHARE, share
        try:
            summary = recover_file(src, tmp / f"{name}.csv")
        finally:
            batch.TIME_MIN_SHARE = kept
        got = read_keypoints(tmp / f"{name}.csv").poses
        out[name] = 100 * float(np.mean(np.linalg.norm(got - v.poses, axis=-1)[hidden] / size))
        out[f"{name}_frames_unused"] = summary["frames_unused"]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="studies/reliability/photos_as_video.json")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for source in ("coco", "mpii"):
            for seed in (0, 1, 2):
                r = dict(source=source, seed=seed, **one_file(source, seed, Path(tmp)))
                print(f"{source} seed {seed}: across time {r['across_time']:.2f}, "
                      f"default {r['default']:.2f}", flush=True)
                rows.append(r)
    for source in ("coco", "mpii"):
        d = np.array([r["across_time"] - r["default"] for r in rows if r["source"] == source])
        print(f"{source}: across time - default {d.mean():+.2f} +- "
              f"{d.std(ddof=1) / np.sqrt(len(d)):.2f} (paired SE, 3 seeds)")
    Path(args.out).write_text(json_text(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
