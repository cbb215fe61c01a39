"""OpenPose folders with low-scored wrong and right points, from annotated clips.

Each Bonn PoseTrack clip (``benchmarks/real2d.py``) is written as an OpenPose
BODY_25 folder (one file per frame, ``person_id`` the track; the head top
through the nose, so that the reader's face rule gives it back). A detector
is imitated per annotated joint:

- a joint annotated as occluded is, with probability `wrong_share` (default
  ``WRONG``; 1: every occluded stretch wrong throughout), placed at a wrong
  place scored U(0.02, 0.2): half of them at the other side's joint
  (a left/right confusion), half moved 0.15-0.5 body sizes in a random
  direction; the other occluded joints are placed near right, scored
  U(0.1, 0.6);
- a visible joint is, with probability ``LOW_RIGHT``, scored U(0.02, 0.2) at
  its place (a right point with a low score), else U(0.5, 1);
- every placed point gets Gaussian noise of 1 % of the body size.

:func:`measure` scores a recovered output against the annotation: the error
of the wrong points (hidden joints, % of body size), that of the right
low-scored points kept (scored >= 0.05, the OpenPose cut-off) and how many of
those were flagged.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import NamedTuple

import numpy as np

from sparseedm.real_protocol import body_size
from sparseedm.skeleton import JOINT_NAMES

WRONG = 0.6
LOW_RIGHT = 0.1
NOISE = 0.01
_BODY_25 = ("nose", "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder",
            "left_elbow", "left_wrist", "mid_hip", "right_hip", "right_knee", "right_ankle",
            "left_hip", "left_knee", "left_ankle")
_OTHER_SIDE = [JOINT_NAMES.index(n.replace("left", "#").replace("right", "left")
                                 .replace("#", "right")) for n in JOINT_NAMES]
_NECK, _HEAD = JOINT_NAMES.index("neck"), JOINT_NAMES.index("head_top")


class Case(NamedTuple):
    """One clip's truth and what the imitated detector gave."""

    truth: np.ndarray      # (n, 14, 2) annotated, NaN where not
    given: np.ndarray      # (n, 14, 2) written
    score: np.ndarray      # (n, 14) written (0: not given)
    wrong: np.ndarray      # (n, 14) bool: placed wrong
    low_right: np.ndarray  # (n, 14) bool: right place, score < 0.3
    size: np.ndarray       # (n,) body size of the track (median)
    tracks: np.ndarray
    frames: np.ndarray


def track_sizes(truth, tracks):
    """Each row's body size: its track's median over annotated frames."""
    size = body_size(truth)
    out = np.full(len(truth), np.nan)
    for t in np.unique(tracks):
        rows = tracks == t
        ok = np.isfinite(size[rows])
        out[rows] = np.median(size[rows][ok]) if ok.any() else np.nan
    return out


def imitate(truth, visible, tracks, frames, seed, wrong_share=WRONG):
    """The detector's points and scores for one clip (a :class:`Case`)."""
    rng = np.random.default_rng(seed)
    n = len(truth)
    size = track_sizes(truth, tracks)
    annotated = np.isfinite(truth).all(axis=-1) & np.isfinite(size)[:, None]
    occluded = annotated & ~visible
    given = truth + rng.normal(0, NOISE, truth.shape) * size[:, None, None]
    score = np.where(annotated, rng.uniform(0.5, 1.0, (n, 14)), 0.0)
    low_right = annotated & visible & (rng.random((n, 14)) < LOW_RIGHT)
    score[low_right] = rng.uniform(0.02, 0.2, low_right.sum())
    score[occluded] = rng.uniform(0.1, 0.6, occluded.sum())
    wrong = occluded & (rng.random((n, 14)) < wrong_share)
    score[wrong] = rng.uniform(0.02, 0.2, wrong.sum())
    low_right |= occluded & ~wrong & (score < 0.3)
    swap = wrong & (rng.random((n, 14)) < 0.5)
    other = truth[:, _OTHER_SIDE]
    swap &= np.isfinite(other).all(axis=-1) & (np.arange(14) != np.array(_OTHER_SIDE))
    given[swap] = other[swap] + rng.normal(0, NOISE, (swap.sum(), 2)) * \
        np.broadcast_to(size[:, None], (n, 14))[swap][:, None]
    moved = wrong & ~swap
    angle = rng.uniform(0, 2 * np.pi, moved.sum())
    reach = rng.uniform(0.15, 0.5, moved.sum()) * np.broadcast_to(size[:, None], (n, 14))[moved]
    given[moved] = truth[moved] + reach[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1)
    given[~annotated] = np.nan
    return Case(truth, given, score, wrong, low_right, size, tracks, frames)


def write_openpose(case, folder, stem="clip"):
    """The case as an OpenPose BODY_25 folder (one file per frame)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for f in np.unique(case.frames):
        people = []
        for r in np.flatnonzero(case.frames == f):
            kp = np.zeros((25, 3))
            pose, score = case.given[r], case.score[r]
            for k, name in enumerate(_BODY_25):
                j = None if name in ("nose", "mid_hip") else JOINT_NAMES.index(name)
                if j is not None and np.isfinite(pose[j]).all():
                    kp[k] = (*pose[j], score[j])
            if np.isfinite(pose[[_HEAD, _NECK]]).all():  # the reader's head top: the nose
                kp[0] = (*((pose[_HEAD] + 0.8 * pose[_NECK]) / 1.8),
                         min(score[_HEAD], score[_NECK]))
            people.append({"person_id": [int(case.tracks[r])],
                           "pose_keypoints_2d": [float(v) for v in kp.ravel()]})
        with open(folder / f"{stem}_{int(f):012d}_keypoints.json", "w") as fh:
            json.dump({"version": 1.3, "people": people}, fh)
    return folder


def row_order(case, ids):
    """Row of the case for each id read back (``<stem>_<frame>_keypoints`` order
    of the reader, persons in file order)."""
    order = []
    for f in np.unique(case.frames):
        order.extend(np.flatnonzero(case.frames == f))
    order = np.asarray(order)
    assert len(order) == len(ids)
    return order


class Measure(NamedTuple):
    """Errors in % of body size; counts of points."""

    wrong_error: float      # mean over the wrong points kept by the cut-off (None: none)
    wrong_count: int
    right_error: float      # mean over the right low-scored points kept by the cut-off
    right_count: int
    right_flagged: int      # right low-scored points flagged as outliers
    wrong_flagged: int


def measure(case, out, outlier=None, cut=0.05):
    """`out` (n, 14, 2) rows in the case's order against the truth."""
    err = np.linalg.norm(out - case.truth, axis=-1) / case.size[:, None] * 100
    kept = case.score >= cut
    w, r = case.wrong & kept, case.low_right & kept & (case.score < 0.3)
    outlier = np.zeros_like(w) if outlier is None else outlier
    return Measure(float(np.nanmean(err[w])) if w.any() else None, int(w.sum()),
                   float(np.nanmean(err[r])) if r.any() else None, int(r.sum()),
                   int((outlier & r).sum()), int((outlier & w).sum()))


def main():
    """Write one Bonn clip of a split as such an OpenPose folder."""
    import argparse
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from benchmarks import real2d

    ap = argparse.ArgumentParser(description="Write a Bonn PoseTrack clip as an OpenPose "
                                 "folder with wrong and right low-scored points.")
    ap.add_argument("output", help="the folder to write")
    ap.add_argument("--split", choices=("val", "test"), default="val")
    ap.add_argument("--clip", type=int, default=0, help="the clip's index in the split")
    args = ap.parse_args()
    s = real2d.load("bonn")
    groups = sorted(set(s.group[real2d.split(s) == args.split]))
    c = s.take(s.group == groups[args.clip])
    write_openpose(imitate(c.poses, c.visible, c.tracks, c.frames, seed=args.clip),
                   args.output)
    print(f"{groups[args.clip]} -> {args.output}")


if __name__ == "__main__":
    main()
