"""Relative smoothing in the temporal model, measured on the video protocols' validation split.

    python studies/temporal/probe_relative.py --sources bandai,cmu --out /tmp/relative.json

The temporal model with defaults (``TemporalSettings.relative`` True: each
joint smoothed relative to its parent's trajectory) against the same model
with every trajectory smoothed on its own (``relative=False``, the model
before), beside the gap fillers, on the sequences of
``benchmarks/video_protocols.py --splits validation`` (the same seeded
sequences, masks and scored joint-frames; one clip per call, defaults, so
each clip adapts on what it offers). Validation only: the test split is
scored by ``benchmarks/video_protocols.py`` once the choice is made. Nothing
from Bandai-Namco is written but the scores. Results: dictionaries/README.md,
"Relative smoothing".
"""
import argparse
import functools
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from benchmarks.video_protocols import DICTIONARY, sequences  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.temporal.evaluation import evaluate_video  # noqa: E402
from sparseedm.temporal.model import TemporalSettings  # noqa: E402
from sparseedm.temporal.recover import recover_track  # noqa: E402


def parser(doc):
    """The probes' command line: --sources, --max-sequences, --seed, --out."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--sources", default="bandai,cmu", type=lambda s: s.split(","))
    ap.add_argument("--max-sequences", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", required=True)
    return ap


def run(args, methods_for, out, label=""):
    """Score ``methods_for(dictionary)`` on each source's validation sequences
    under both protocols; the runs go into `out`, written after each."""
    for source in args.sources:
        seqs = sequences(source, "validation", args.max_sequences, args.seed)
        dictionary = load_dictionary(DICTIONARY[source])
        methods = methods_for(dictionary)
        for protocol in ("gaps", "self-occlusion"):
            report = evaluate_video(seqs, methods, protocol, random_state=args.seed,
                                    dictionary=dictionary)
            print(f"\n{source} validation {protocol}{label}\n{report.table()}", flush=True)
            out["runs"].append({"source": source, "protocol": protocol,
                                "settings": report.settings, "seconds": report.seconds,
                                "rows": report.rows})
            Path(args.out).write_text(json_text(out, indent=1) + "\n")


def methods(dictionary):
    """The gap fillers and the temporal model with and without relative smoothing."""
    return ["linear", "cubic", "akima", "pca",
            ("temporal", functools.partial(recover_track, dictionary=dictionary)),
            ("temporal, relative=False", functools.partial(
                recover_track, dictionary=dictionary, settings=TemporalSettings(relative=False)))]


def main(argv=None):
    args = parser(__doc__).parse_args(argv)
    run(args, methods, {"split": "validation", "max_sequences": args.max_sequences,
                        "runs": []})


if __name__ == "__main__":
    main()
