"""The Kalman smoother against the splines on real video: Bonn PoseTrack's hand-annotated tracks.

    nice python benchmarks/video_kalman.py [--split val] [--seeds 5] [--out results.json]

The validation videos of Bonn Multi-Person PoseTrack (:mod:`benchmarks.real2d`,
``split(d) == "val"``; every frame annotated by hand, so the observed joints
carry a person's clicking noise, not a detector's) as tracks: each person's
complete poses (all 14 joints annotated) cut into runs of consecutive frames,
runs of at least ``--min-frames`` kept. In each run contiguous gaps of 3, 10
and 30 frames are hidden on 1-3 joints at a time (Protocol A's
:func:`sparseedm.temporal.protocols.gap_mask`, one seed per run, gap length
and ``--seeds`` repeat) and filled by linear, cubic and Akima interpolation and
by the constant-velocity Kalman smoother (:func:`sparseedm.temporal.fillers.fill_kalman`)
with its defaults and with the settings they were chosen among (the noise
pooled per joint or per joint coordinate instead of per clip; the velocity's
persistence past a run end: 0 holds, inf extrapolates at constant velocity).
Errors of the hidden joints are in % of the true pose's body size
(:func:`benchmarks.real2d.body_size`, per pose), per gap length, split by
whether the gap touches a run end; ``jump`` is the mean excess jump at the
gaps' edges (:func:`sparseedm.temporal.evaluation.edge_jumps`), in the same
units. Only these scores are written: nothing of the annotations.
"""

from __future__ import annotations

import argparse
import functools
import os
import platform
import time
import zlib

import numpy as np

from sparseedm.temporal.evaluation import edge_jumps
from sparseedm.temporal.fillers import fill_akima, fill_cubic, fill_kalman, fill_linear
from sparseedm.temporal.protocols import gap_mask, run_lengths
from sparseedm._atomic import save_json

try:
    from . import real2d
except ImportError:  # run as a script
    import real2d

GAPS = (3, 10, 30)
#: the splines, fill_kalman's defaults, and the settings they were chosen among
METHODS = {"linear": fill_linear, "cubic": fill_cubic, "akima": fill_akima,
           "kalman": fill_kalman,
           **{f"kalman pooling={p}": functools.partial(fill_kalman, pooling=p)
              for p in ("joint", "coordinate")},
           **{f"kalman persistence={x:g}": functools.partial(fill_kalman, persistence=x)
              for x in (0.0, 5.0, 10.0, 40.0, np.inf)}}


def runs(realset, split, min_frames):
    """[(id, poses (T, 14, 2), frames (T,))]: complete poses in consecutive frames."""
    keep = (real2d.split(realset) == split) & np.isfinite(realset.poses).all(axis=(1, 2))
    out = []
    for group in np.unique(realset.group[keep]):
        for person in np.unique(realset.tracks[keep & (realset.group == group)]):
            rows = np.flatnonzero(keep & (realset.group == group) & (realset.tracks == person))
            rows = rows[np.argsort(realset.frames[rows])]
            cuts = np.flatnonzero(np.diff(realset.frames[rows]) != 1) + 1
            for i, part in enumerate(np.split(rows, cuts)):
                if len(part) >= min_frames:
                    out.append((f"{group}/{person}/{i}", realset.poses[part],
                                realset.frames[part]))
    return out


def measure(tracks, n_seeds, methods=METHODS):
    """Per method, gap length and place (all / end / inside): errors and edge jumps."""
    scores = {(m, L, place): {"error": [], "jump": []} for m in methods for L in GAPS
              for place in ("all", "end", "inside")}
    seconds = dict.fromkeys(methods, 0.0)
    for clip, truth, frames in tracks:
        size = real2d.body_size(truth)[:, None]
        for L in GAPS:
            for seed in range(n_seeds):
                rng = [seed, L, zlib.crc32(clip.encode())]
                missing = gap_mask(len(truth), L, random_state=rng)
                if not missing.any():
                    continue
                _, at_end = run_lengths(missing)
                given = np.where(missing[..., None], np.nan, truth)
                for name, fill in methods.items():
                    start = time.perf_counter()
                    filled = fill(given, missing, frames)
                    seconds[name] += time.perf_counter() - start
                    err = np.linalg.norm(filled - truth, axis=-1) / size * 100
                    jump = edge_jumps(truth, filled, missing, frames) / size[..., None] * 100
                    for place, sel in (("all", missing), ("end", missing & at_end),
                                       ("inside", missing & ~at_end)):
                        scores[name, L, place]["error"].append(err[sel])
                        scores[name, L, place]["jump"].append(jump[sel].ravel())
    rows = []
    for (name, L, place), s in scores.items():
        err, jump = np.concatenate(s["error"]), np.concatenate(s["jump"])
        jump = jump[np.isfinite(jump)]
        rows.append(dict(method=name, gap=L, place=place, n=int(err.size),
                         error=float(err.mean()) if err.size else float("nan"),
                         median=float(np.median(err)) if err.size else float("nan"),
                         edges=int(jump.size),
                         jump=float(jump.mean()) if jump.size else float("nan")))
    return rows, seconds


def table(rows, place="all"):
    methods = list(dict.fromkeys(r["method"] for r in rows))
    pick = {(r["method"], r["gap"]): r for r in rows if r["place"] == place}
    lines = [f"{place}: mean error % of body size (mean excess edge jump)",
             "| method | " + " | ".join(f"gap {L}" for L in GAPS) + " |",
             "|---|" + "---|" * len(GAPS)]
    for m in methods:
        lines.append(f"| {m} | " + " | ".join(
            f"{pick[m, L]['error']:.2f} ({pick[m, L]['jump']:+.2f})" for L in GAPS) + " |")
    lines.append("| hidden joint-frames (edges) | " + " | ".join(
        f"{pick[methods[0], L]['n']} ({pick[methods[0], L]['edges']})" for L in GAPS) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", choices=("val", "test"), default="val")
    ap.add_argument("--seeds", type=int, default=5, help="masks per run and gap length")
    ap.add_argument("--min-frames", type=int, default=31)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    tracks = runs(real2d.load("bonn"), args.split, args.min_frames)
    rows, seconds = measure(tracks, args.seeds)
    frames = sum(len(t[1]) for t in tracks)
    print(f"bonn {args.split}: {len(tracks)} runs, {frames} frames, {args.seeds} seeds")
    for place in ("all", "inside", "end"):
        print(table(rows, place) + "\n")
    print("seconds per method:", {m: round(s, 2) for m, s in seconds.items()})
    if args.out:
        doc = dict(split=args.split, runs=len(tracks), frames=frames, seeds=args.seeds,
                   machine=f"{platform.platform()}, {os.cpu_count()} cores",
                   load_average=[round(x, 2) for x in os.getloadavg()],
                   seconds=seconds, rows=rows)
        save_json(args.out, doc, indent=1)


if __name__ == "__main__":
    main()
