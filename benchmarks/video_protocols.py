"""Issue 23's video protocols on real mocap: gap fillers vs per-frame sparseedm.

Builds video sequences (one fixed seeded camera per clip, ~30 frames/s, clips
of 31-300 frames; :mod:`sparseedm.temporal.sequences`) from two sources in
``../shared/data`` and runs :func:`sparseedm.temporal.evaluation.evaluate_video`
under Protocol A (contiguous gaps of 3/10/30/90 frames) and Protocol B
(self-occlusion behind the torso + 5 % dropouts) for linear, cubic, Akima,
PCA gap filling and per-frame sparseedm (``recover`` per clip, defaults):

* ``bandai``: Bandai-Namco-1 (another lab, other actors); its clips in sorted
  order alternate validation / test. Per-frame sparseedm uses the shipped
  default dictionary (``cmu-all-k2000``, learned on CMU only).
* ``cmu``: CMU ASF/AMC subjects other than 01-03, alternating subjects in
  sorted order into validation (05, 07, 10, 32, 38, 43, 55) and test (06, 08,
  16, 35, 39, 49). Per-frame sparseedm uses ``cmu-k2000`` (learned on
  subjects 01-03 only); the shipped default saw every CMU subject.

Settings are to be chosen on the validation rows only; the test rows are the
held-out figures. Each split evaluates at most ``--max-sequences`` seeded
sequences (the per-frame recovery dominates the time).

Add a method under test with ``--method NAME=module:function`` (a gap filler,
``fill(poses, missing, frames) -> filled``; repeatable), e.g. the temporal
model once it exists.

Run from the project root (nothing from Bandai is written but these scores)::

    nice python benchmarks/video_protocols.py -o benchmarks/results-video.json
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
CMU_VALIDATION = ("05", "07", "10", "32", "38", "43", "55")
CMU_TEST = ("06", "08", "16", "35", "39", "49")
DICTIONARY = {"bandai": "default", "cmu": "cmu-k2000"}


def source_files(source, split):
    """The motion files of one source's validation or test split."""
    if source == "bandai":
        files = sorted((DATA / "bandai-namco-1" / "data").glob("*.bvh"))
        return files[{"validation": 0, "test": 1}[split]::2]
    subjects = CMU_VALIDATION if split == "validation" else CMU_TEST
    return sorted(f for s in subjects for f in (DATA / "cmu-mocap" / "subjects" / s).glob("*.amc"))


def sequences(source, split, max_sequences, seed):
    from sparseedm.dataset import build_dataset
    from sparseedm.temporal.sequences import sequences_from_dataset

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = build_dataset(source_files(source, split), camera="clip", random_state=seed,
                             progress=False)
    seqs = sequences_from_dataset(data)
    if len(seqs) > max_sequences:
        keep = np.sort(np.random.default_rng(seed).choice(len(seqs), max_sequences,
                                                         replace=False))
        seqs = [seqs[i] for i in keep]
    return seqs


def extra_method(text):
    name, _, target = text.partition("=")
    module, _, attr = target.partition(":")
    if not (name and module and attr):
        raise argparse.ArgumentTypeError(f"expected NAME=module:function, got {text!r}")
    return name, getattr(importlib.import_module(module), attr)


def run(args):
    from sparseedm.temporal.evaluation import evaluate_video

    results = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                           "load_start": os.getloadavg()},
               "settings": {"max_sequences": args.max_sequences, "seed": args.seed},
               "runs": []}
    for source in args.sources:
        for split in ("validation", "test"):
            seqs = sequences(source, split, args.max_sequences, args.seed)
            methods = ["linear", "cubic", "akima", "pca", "sparse"] + list(args.method)
            for protocol in ("gaps", "self-occlusion"):
                start = time.perf_counter()
                report = evaluate_video(seqs, methods, protocol, random_state=args.seed,
                                        dictionary=DICTIONARY[source])
                print(f"\n{source} {split} {protocol}: {report.settings['sequences']} "
                      f"sequences, {report.settings['frames']} frames, "
                      f"{report.settings['hidden_fraction']:.1%} hidden "
                      f"({time.perf_counter() - start:.0f} s)", flush=True)
                print(report.table())
                results["runs"].append({"source": source, "split": split, "protocol": protocol,
                                        "dictionary": DICTIONARY[source],
                                        "settings": report.settings,
                                        "seconds": report.seconds, "rows": report.rows})
    results["machine"]["load_end"] = os.getloadavg()
    print("\n" + summary(results))
    if args.output:
        Path(args.output).write_text(json.dumps(results, indent=1) + "\n")
        print(f"wrote {args.output}")


def summary(results, end="all"):
    """Markdown tables: per source and protocol, 'validation / test' per group."""
    out = []
    runs = results["runs"]
    for source in dict.fromkeys(r["source"] for r in runs):
        for protocol in ("gaps", "self-occlusion"):
            pair = {r["split"]: r for r in runs
                    if r["source"] == source and r["protocol"] == protocol}
            if set(pair) != {"validation", "test"}:
                continue
            groups = list(dict.fromkeys(x["group"] for x in pair["validation"]["rows"]))
            methods = list(dict.fromkeys(x["method"] for x in pair["validation"]["rows"]))
            out.append(f"{source}, {protocol} ({end}): validation / test, "
                       "% of body height")
            out.append("| method | " + " | ".join(groups) + " |")
            out.append("|---|" + "---|" * len(groups))
            for m in methods:
                cells = []
                for g in groups:
                    vals = []
                    for split in ("validation", "test"):
                        x = next(x for x in pair[split]["rows"]
                                 if (x["method"], x["group"], x["end"]) == (m, g, end))
                        vals.append("–" if x["scored"] == 0 else f"{x['error']:.2f}")
                    cells.append(" / ".join(vals))
                out.append(f"| {m} | " + " | ".join(cells) + " |")
            counts = []
            for g in groups:
                n = [next(x for x in pair[s]["rows"] if (x["group"], x["end"]) == (g, end))
                     for s in ("validation", "test")]
                counts.append(" / ".join(f"{x['scored']}" for x in n))
            out.append("| scored joint-frames | " + " | ".join(counts) + " |")
            out.append("")
    return "\n".join(out)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("-o", "--output", default=None, help="results JSON")
    p.add_argument("--sources", default="bandai,cmu", type=lambda s: s.split(","))
    p.add_argument("--max-sequences", type=int, default=12)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--method", action="append", default=[], type=extra_method,
                   metavar="NAME=module:function", help="another gap filler to evaluate")
    p.add_argument("--summary", default=None, metavar="JSON",
                   help="only print the tables of a results file")
    args = p.parse_args(argv)
    if args.summary:
        print(summary(json.loads(Path(args.summary).read_text())))
        print(summary(json.loads(Path(args.summary).read_text()), end="end"))
        return 0
    if not DATA.is_dir():
        sys.exit(f"needs the real motion capture in {DATA}")
    run(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
