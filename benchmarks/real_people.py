"""sparseedm judged on hand-annotated real people, photos and video, against its peers.

Runs the real-people protocols of :mod:`sparseedm.evaluation_real` on
``../shared/data/real2d`` (:mod:`benchmarks.real2d`), one split at a time
(``--split val``, the default, for choosing settings; ``--split test`` for
held-out figures), every method measured in the same run:

* **photos** on ``mpii``, ``coco`` and ``bonn`` (video frames taken as photos):
  the split's complete poses (every joint annotated) become ONE file of C
  complete poses and M poses with hidden joints (``--poses C,M``, default
  1000,1000; scaled down in proportion when the split has fewer, and the
  sizes used are printed), under ``mix`` (1-3 random joints per pose) and
  ``transplanted`` (each pose gets the missing pattern, not annotated or
  flagged invisible, of a real pose of the same source and split, keeping 3
  observed joints). Methods: sparseedm's defaults (adapting on the file's
  complete poses when it has enough), sparseedm without adaptation,
  scikit-learn's IterativeImputer(max_iter=10, tol=0) and KNNImputer on the
  28 pixel coordinates, mean fill and the nearest complete pose of the file.
* **video** on ``bonn``: each clip (a track's run of at least 30 consecutive
  frames with every joint annotated) alone; contiguous gaps of 3, 10 and 30
  frames on 1-3 joints, and transplanted runs (a real track's runs of
  invisible or unannotated frames moved onto the clip). Methods: sparseedm
  with tracks and frames, per-frame sparseedm, linear, cubic, Akima and PCA
  gap filling (and the Kalman smoother when ``fill_kalman`` is installed).
  ``--max-clips`` (default 40) takes a seeded sample when the split has more.

``--complete-from train`` takes the photo files' C complete poses from the
source's train split instead (other images or videos than the M occluded
ones: enough for sparseedm to adapt on MPII, and no neighbouring Bonn frames
of the occluded poses) and writes ``results-real-people-<split>-train-complete.json``.

Errors are the distance of each hidden joint to its annotation in % of the
body size (head top to the ankles' midpoint: the pose's own for photos, the
clip's median for video), mean and median; PCKh@0.5 uses the annotated head
size (MPII, and the Bonn poses that have a head box); COCO has none, so its
PCKh is left out. Writes ``benchmarks/results-real-people-<split>.json`` and
prints Markdown tables. Run from the project root::

    nice python -m benchmarks.real_people --split val
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import loadavg, machine, real2d, versions
from sparseedm.evaluation_real import evaluate_photos, evaluate_tracks
from sparseedm._atomic import save_json

PHOTO_SOURCES = ("mpii", "coco", "bonn")
GAP_LENGTHS = (3, 10, 30)


def _sizes(text):
    c, m = (int(t) for t in text.split(","))
    return c, m


def photos(realset, part, sizes, seed, complete_from="split", **options):
    """evaluate_photos on one source's split: its complete poses, its real missing
    patterns; the file's complete poses from the train split with ``complete_from="train"``;
    `options` (methods, dictionary) passed on."""
    parts = real2d.split(realset)
    s = realset.take(parts == part)
    complete = s.complete
    head = s.head_size[complete] if np.isfinite(s.head_size).any() else None
    other = None
    if complete_from == "train":
        t = realset.take(parts == "train")
        other = t.poses[t.complete]
    return evaluate_photos(s.poses[complete], ~s.visible, complete=other, n_complete=sizes[0],
                           n_occluded=sizes[1], head_size=head, random_state=seed, **options)


def video(realset, part, max_clips, seed):
    """evaluate_tracks on Bonn's split: tracks are (video, person)."""
    s = realset.take(real2d.split(realset) == part)
    tracks = np.char.add(np.char.add(s.group.astype(str), "#"), s.tracks.astype(str))
    return evaluate_tracks(s.poses, tracks, s.frames, occluded=~s.visible,
                           gap_lengths=GAP_LENGTHS, head_size=s.head_size,
                           max_clips=max_clips, random_state=seed)


def render(results, meta):
    """The Markdown of a run: one table per source and condition."""
    m = meta["machine"]
    out = [f"Run: {meta['date']}, `{meta['command']}`; machine: {m['cpu']}, {m['cores']} "
           f"cores; load average at start {meta['loadavg_start']}, at end "
           f"{meta['loadavg_end']}; {meta['seconds']:.0f} s in all.",
           "Cells: mean (median) error of the hidden joints in % of body size, then "
           "PCKh@0.5 where head sizes are known; seconds: each method's time on the "
           "condition (one call per file for photos; the sum over clips for video)."]
    out += ["", *_summary(results)]
    for key, rep in results.items():
        s = rep["settings"]
        if rep["protocol"] == "photos":
            where = " (train split)" if s.get("complete_given") else ""
            head = f"### {key}: {s['n_complete']} complete{where} + {s['n_occluded']} " \
                   f"occluded poses (of the split's {s['poses']} complete), {s['pool']} real " \
                   "missing patterns"
        else:
            head = f"### {key}: {s['clips']} clips, {s['frames']} frames (of {s['tracks']} " \
                   "tracks), each alone"
        out += ["", head] + [f"- {n}" for n in s["notes"]]
        if key == "bonn photos":
            out.append("- frames of videos: an occluded pose's neighbouring frames are in the "
                       "file (near-duplicates, among the occluded poses too), which favours "
                       "knn and nearest")
        if not s["pckh"]:
            out.append("- no head sizes: no PCKh")
        for cond in rep["report"].conditions:
            out += ["", f"{key}, {cond}:", "", rep["report"].table(cond)]
    return "\n".join(out)


def _summary(results):
    """One Markdown table of the photo files: overall mean (median) per source and condition."""
    cols = [(key, cond) for key, rep in results.items() if rep["protocol"] == "photos"
            for cond in rep["report"].conditions]
    if not cols:
        return []
    methods = next(r["report"] for r in results.values() if r["protocol"] == "photos").methods
    lines = ["Photos, all hidden joints (overall): mean (median) % of body size, PCKh@0.5",
             "", "| method | " + " | ".join(f"{k.split()[0]} {c}" for k, c in cols) + " |",
             "|---|" + "---|" * len(cols)]
    for m in methods:
        cells = []
        for key, cond in cols:
            r = results[key]["report"].row(m, cond)
            cells.append(f"{r['mean']:.2f} ({r['median']:.2f})"
                         + (f" {r['pckh']:.0%}" if r["pckh_n"] else ""))
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", choices=("val", "test"), default="val")
    ap.add_argument("--poses", type=_sizes, default=(1000, 1000), metavar="C,M",
                    help="photos: complete and occluded poses per file (default 1000,1000)")
    ap.add_argument("--max-clips", type=int, default=40,
                    help="video: a seeded sample of at most this many clips (default 40)")
    ap.add_argument("--complete-from", choices=("split", "train"), default="split",
                    help="photos: the file's C complete poses come from the split itself "
                    "(default) or from the source's train split (other images or videos: "
                    "more of them, no near-duplicate frames); M from the split")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sources", default="mpii,coco,bonn,bonn-video",
                    help="among mpii, coco, bonn (photos), bonn-video")
    ap.add_argument("-o", "--output", default=None,
                    help="JSON file (default benchmarks/results-real-people-<split>.json)")
    args = ap.parse_args(argv)
    if not real2d.available():
        sys.exit(f"no {real2d.REAL2D}: the real2d annotations are needed")
    meta = dict(date=time.strftime("%Y-%m-%d %H:%M %Z"), machine=machine(),
                versions=versions(), loadavg_start=loadavg(), split=args.split,
                command="python -m benchmarks.real_people " + " ".join(argv or sys.argv[1:]))
    start, results, sets = time.perf_counter(), {}, {}
    for key in args.sources.split(","):
        source = key.removesuffix("-video")
        sets.setdefault(source, real2d.load(source))
        print(f"[{time.strftime('%H:%M:%S')}] {key} ({args.split})", file=sys.stderr, flush=True)
        if key.endswith("-video"):
            rep = video(sets[source], args.split, args.max_clips, args.seed)
            results[f"{source} video"] = {"protocol": "video", "report": rep}
        else:
            rep = photos(sets[source], args.split, args.poses, args.seed, args.complete_from)
            results[f"{source} photos"] = {"protocol": "photos", "report": rep}
        results[next(reversed(results))]["settings"] = rep.settings
    meta.update(loadavg_end=loadavg(), seconds=time.perf_counter() - start)
    print(render(results, meta))
    tail = "-train-complete" if args.complete_from == "train" else ""
    path = Path(args.output or Path(__file__).resolve().parent /
                f"results-real-people-{args.split}{tail}.json")
    doc = {"meta": meta, "results": {k: json.loads(v["report"].to_json())
                                     for k, v in results.items()}}
    save_json(path, doc, indent=1)
    print(f"\nwrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
