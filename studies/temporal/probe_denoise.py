"""Noisy observations (a detector's jitter) on the video protocols' validation split.

    python studies/temporal/probe_denoise.py --sources cmu,bandai --noise 0.01 --out /tmp/d.json

Motion capture projected by a camera is noise-free; detectors' keypoints are
not. Here every observed coordinate of each sequence gets seeded white noise
of ``--noise`` times the track's median vertical extent (the same noise for every
method), every method fills the hidden joints from the noisy track, and the
error is scored against the clean truth (% of body height, per gap / run
length, as ``benchmarks/video_protocols.py``). Rows: linear, cubic, Akima and
PCA gap filling, and the temporal model with defaults (``denoise`` on: noisy
observations become data instead of exact anchors,
``sparseedm.temporal.model.observation_weight``) and with ``denoise=False``.
One clip per call with defaults (each clip adapts). Validation only. Nothing
from Bandai-Namco is written but the scores. Results: dictionaries/README.md,
"Noisy observations".
"""
import functools
import hashlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.temporal.probe_relative import parser, run  # noqa: E402
from sparseedm.temporal.fillers import FILLERS  # noqa: E402
from sparseedm.temporal.model import TemporalSettings  # noqa: E402
from sparseedm.temporal.recover import recover_track  # noqa: E402


def noisy(fill, level):
    """`fill` on the track with seeded white noise on its observed coordinates:
    `level` x the track's median vertical extent of its observed joints (the
    seed and the scale come from the clean input, so every method sees the
    same noise)."""
    def run(poses, missing, frames):
        y = np.where(missing, np.nan, poses[..., 1])
        extent = float(np.nanmedian(np.nanmax(y, axis=1) - np.nanmin(y, axis=1)))
        clean = np.where(missing[..., None], 0.0, poses)
        rng = np.random.default_rng(int(hashlib.sha1(clean.tobytes()).hexdigest()[:8], 16))
        given = clean + rng.normal(scale=level * extent, size=poses.shape)
        return fill(np.where(missing[..., None], np.nan, given), missing, frames)
    return run


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--noise", type=float, default=0.01)
    args = ap.parse_args(argv)

    def methods(dictionary):
        fills = {k: FILLERS[k] for k in ("linear", "cubic", "akima", "pca")}
        fills["temporal"] = functools.partial(recover_track, dictionary=dictionary)
        fills["temporal, denoise=False"] = functools.partial(
            recover_track, dictionary=dictionary, settings=TemporalSettings(denoise=False))
        return [(name, noisy(fill, args.noise)) for name, fill in fills.items()]

    run(args, methods, {"split": "validation", "noise": args.noise, "runs": []},
        label=f", noise {args.noise}")


if __name__ == "__main__":
    main()
