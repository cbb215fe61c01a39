"""The video protocols on real mocap: gap fillers vs per-frame sparseedm.

Builds video sequences (one fixed seeded camera per clip, ~30 frames/s, clips
of 31-300 frames; :mod:`sparseedm.temporal.sequences`) from two sources in
``../shared/data`` and runs :func:`sparseedm.temporal.evaluation.evaluate_video`
under Protocol A (contiguous gaps of 3/10/30/90 frames) and Protocol B
(self-occlusion behind the torso + 5 % dropouts) for linear, cubic, Akima,
PCA gap filling, the constant-velocity Kalman smoother and per-frame sparseedm
(``recover`` per clip, defaults):

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
``fill(poses, missing, frames) -> filled``; repeatable; bound to the source's
dictionary when it takes ``dictionary=``), e.g. the temporal model::

    nice python benchmarks/video_protocols.py --methods akima \
        --method temporal=sparseedm.temporal.recover:recover_track -o results-video-temporal.json

Run from the project root (nothing from Bandai is written but these scores)::

    nice python benchmarks/video_protocols.py -o benchmarks/results-video.json
"""

from __future__ import annotations

import argparse
import functools
import importlib
import inspect
import json
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sparseedm._atomic import save_json

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


def validation_probe(rows_of, summarise, out, sources=("bandai", "cmu"), split="validation"):
    """Run a validation probe of dictionaries/: each source's rows printed as they
    come, then ``{"split", "rows", "summary"}`` written to `out` and the summary printed."""
    rows = []
    for source in sources:
        for row in rows_of(source):
            print(json.dumps(row), flush=True)
            rows.append(row)
    doc = dict(split=split, rows=rows, summary=summarise(rows))
    save_json(out, doc, indent=1)
    for line in doc["summary"]:
        print(json.dumps(line))


def probe_main(doc, rows_of, summarise, *, count, default, out, test_split=False):
    """The command line of a validation probe: ``--data-dir``, ``--<count>``
    (`default`) and ``--out`` (`out`), then :func:`validation_probe` with
    ``rows_of(source, <count>)``. With `test_split`, ``--split test`` measures
    the held-out split once the settings are chosen: ``rows_of(source, <count>,
    split)``."""
    global DATA
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--data-dir", default="../shared/data")
    ap.add_argument(f"--{count}", type=int, default=default)
    ap.add_argument("--out", default=out)
    if test_split:
        ap.add_argument("--split", choices=("validation", "test"), default="validation")
    args = ap.parse_args()
    DATA = Path(args.data_dir).resolve()
    n = getattr(args, count.replace("-", "_"))
    if not test_split:
        validation_probe(lambda source: rows_of(source, n), summarise, args.out)
        return
    validation_probe(lambda source: rows_of(source, n, args.split), summarise, args.out,
                     split=args.split)


def extra_method(text):
    name, _, target = text.partition("=")
    module, _, attr = target.partition(":")
    if not (name and module and attr):
        raise argparse.ArgumentTypeError(f"expected NAME=module:function, got {text!r}")
    return name, getattr(importlib.import_module(module), attr)


def with_dictionary(fill, dictionary):
    """`fill` bound to the source's dictionary when it takes one (``dictionary=`` or
    ``**kwargs``), so a method under test uses the same dictionary as "sparse"."""
    params = inspect.signature(fill).parameters.values()
    if any(p.name == "dictionary" or p.kind is p.VAR_KEYWORD for p in params):
        return functools.partial(fill, dictionary=dictionary)
    return fill


def run(args):
    from sparseedm.dictionary import load_dictionary
    from sparseedm.temporal.evaluation import evaluate_video

    results = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                           "load_start": os.getloadavg()},
               "settings": {"max_sequences": args.max_sequences, "seed": args.seed,
                            "noise": args.noise, "argv": sys.argv[1:]},
               "runs": []}
    for source in args.sources:
        for split in args.splits:
            seqs = sequences(source, split, args.max_sequences, args.seed)
            dictionary = load_dictionary(DICTIONARY[source])
            methods = list(args.methods) + [(name, with_dictionary(fill, dictionary))
                                            for name, fill in args.method]
            for protocol in ("gaps", "self-occlusion"):
                start = time.perf_counter()
                report = evaluate_video(seqs, methods, protocol, random_state=args.seed,
                                        dictionary=dictionary, noise=args.noise)
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
    print("\n" + intervals(results))
    if args.output:
        save_json(args.output, results, indent=1)
        print(f"wrote {args.output}")


def merge(many):
    """One results dict whose runs hold the rows of every file (first file first;
    a method already there is not added again)."""
    runs = {}
    for results in many:
        for run in results["runs"]:
            key = (run["source"], run["split"], run["protocol"])
            if key not in runs:
                runs[key] = dict(run, rows=list(run["rows"]))
                continue
            have = {r["method"] for r in runs[key]["rows"]}
            runs[key]["rows"] += [r for r in run["rows"] if r["method"] not in have]
    return {"runs": list(runs.values())}


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
                       "% of body height; edge jump: the mean excess jump at the gaps' edges")
            out.append("| method | " + " | ".join(groups) + " | edge jump |")
            out.append("|---|" + "---|" * (len(groups) + 1))
            for m in methods:
                cells = [_cells(pair, m, g, end, "error") for g in groups]
                cells.append(_cells(pair, m, "overall", end, "edge_jump"))
                out.append(f"| {m} | " + " | ".join(cells) + " |")
            counts = []
            for g in groups:
                n = [next(x for x in pair[s]["rows"] if (x["group"], x["end"]) == (g, end))
                     for s in ("validation", "test")]
                counts.append(" / ".join(f"{x['scored']}" for x in n))
            out.append("| scored joint-frames | " + " | ".join(counts) + " | |")
            out.append("")
    return "\n".join(out)


def _cells(pair, method, group, end, key):
    """'validation / test' of one row's `key` (error or edge jump; "–" where none)."""
    vals = []
    for split in ("validation", "test"):
        x = next(x for x in pair[split]["rows"]
                 if (x["method"], x["group"], x["end"]) == (method, group, end))
        value = x.get(key)  # results written before the edge jump have none
        known = value is not None and np.isfinite(value)  # null or NaN: no value
        vals.append("–" if x["scored"] == 0 or not known else f"{value:.2f}")
    return " / ".join(vals)


#: the gap fillers the goals are stated against, and the Kalman smoother
PEERS = ("linear", "cubic", "akima", "pca", "kalman")


def intervals(results, method="temporal", peers=PEERS, level=0.9):
    """Markdown tables, one per protocol: `method`'s error over the best of
    `peers` per run and group, with its bootstrap interval over the
    sequences (sparseedm.temporal.evaluation.ratio_interval)."""
    from sparseedm.temporal.evaluation import ratio_interval

    out = [f"{method} / best of {', '.join(peers)}: ratio [{level:.0%} interval, clips "
           "resampled] (clips scored)"]
    for protocol in ("gaps", "self-occlusion"):
        runs = [r for r in results["runs"] if r["protocol"] == protocol
                and method in {x["method"] for x in r["rows"]}
                and "sequence_sums" in r["rows"][0]]
        if not runs:
            continue
        groups = list(dict.fromkeys(x["group"] for x in runs[0]["rows"]))
        out += ["", "| run | " + " | ".join(groups) + " |", "|---|" + "---|" * len(groups)]
        for run in runs:
            present = [p for p in peers if any(x["method"] == p for x in run["rows"])]
            cells = []
            for g in groups:
                r = ratio_interval(run["rows"], method, present, g, level=level)
                cells.append("–" if not r["sequences"] else
                             f"{r['ratio']:.2f} [{r['low']:.2f}, {r['high']:.2f}] "
                             f"({r['sequences']})")
            out.append(f"| {run['source']} {run['split']} {protocol} | "
                       + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("-o", "--output", default=None, help="results JSON")
    p.add_argument("--sources", default="bandai,cmu", type=lambda s: s.split(","))
    p.add_argument("--max-sequences", type=int, default=12)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--splits", default="validation,test", type=lambda s: s.split(","),
                   help="e.g. 'test' alone once the settings are chosen")
    p.add_argument("--methods", default="linear,cubic,akima,pca,kalman,sparse",
                   type=lambda s: [m for m in s.split(",") if m],
                   help="built-in methods (default linear,cubic,akima,pca,kalman,sparse); keep "
                   "one of the splines beside a method run alone, so rows are scored on the "
                   "same joint-frames as a full run")
    p.add_argument("--noise", type=float, default=0.0, metavar="F",
                   help="observed joints jittered by F x the body height (evaluate_video's "
                   "noise; default 0)")
    p.add_argument("--method", action="append", default=[], type=extra_method,
                   metavar="NAME=module:function", help="another gap filler to evaluate")
    p.add_argument("--summary", nargs="+", default=None, metavar="JSON",
                   help="only print the tables of results files (their rows merged)")
    args = p.parse_args(argv)
    if args.summary:
        results = merge([json.loads(Path(f).read_text()) for f in args.summary])
        print(summary(results))
        print(summary(results, end="end"))
        print(intervals(results))
        return 0
    if not DATA.is_dir():
        sys.exit(f"needs the real motion capture in {DATA}")
    run(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
