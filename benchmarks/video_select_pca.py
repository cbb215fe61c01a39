"""How fill_pca's `variance` (components kept) was chosen: validation sequences only.

PCA gap filling (:func:`sparseedm.temporal.fillers.fill_pca`) at 0.99, 0.999,
0.9999 and 0.99999 of the variance, Akima beside it, on the validation
splits of both sources of ``benchmarks/video_protocols.py`` under both
protocols; the default is the setting with the lowest mean of the four
'overall' errors (two sources x two protocols). Writes the tables and the
choice to JSON::

    nice python benchmarks/video_select_pca.py -o benchmarks/results-video-pca.json
"""

from __future__ import annotations

import argparse
import functools
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.video_protocols import sequences  # noqa: E402
from sparseedm._atomic import save_json  # noqa: E402

GRID = (0.99, 0.999, 0.9999, 0.99999)


def main(argv=None):
    from sparseedm.temporal.evaluation import evaluate_video
    from sparseedm.temporal.fillers import fill_pca

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("-o", "--output", default=None)
    p.add_argument("--max-sequences", type=int, default=10)
    args = p.parse_args(argv)
    methods = ["akima"] + [(f"pca {v}", functools.partial(fill_pca, variance=v)) for v in GRID]
    overall, runs = {f"pca {v}": [] for v in GRID}, []
    for source in ("bandai", "cmu"):
        seqs = sequences(source, "validation", args.max_sequences, 0)
        for protocol in ("gaps", "self-occlusion"):
            report = evaluate_video(seqs, methods, protocol)
            print(f"{source} validation {protocol}\n{report.table()}\n", flush=True)
            runs.append({"source": source, "protocol": protocol, "rows": report.rows})
            for name in overall:
                overall[name].append(report.row(name, "overall")["error"])
    score = {name: sum(v) / len(v) for name, v in overall.items()}
    chosen = min(score, key=score.get)
    print("mean overall error:", {k: round(v, 2) for k, v in score.items()}, "->", chosen)
    if args.output:
        save_json(args.output, {"grid": GRID, "score": score, "chosen": chosen, "runs": runs},
                  indent=1)


if __name__ == "__main__":
    main()
