"""The paper's protocol on held-out motion capture: CMU + part of Bandai-Namco
for training, the held-out Bandai-Namco styles for testing.

    python -m benchmarks.paper_protocol [--shared ../shared/data] [--work /tmp/sparseedm-results]
                                        [--sweep-atoms 100,250,500,1000,2000] [--write-docs]

Steps (all through the public CLI/API):

1. build the CMU (subjects 01-03) and the Bandai-Namco training sets (one
   virtual camera per pose);
2. split Bandai-Namco **by style** (whole clips; frames of one clip are nearly
   identical): the styles in ``TEST_STYLES`` are the test set, the others join
   the CMU poses for training;
3. learn a k = 2000 dictionary on that training set with the shipped
   ``cmu-k2000``'s settings (training alpha and recovery alpha chosen on the CMU
   validation split, ``studies/dictionary/selection.json``), in the work folder:
   Bandai-Namco is CC BY-NC, so nothing learned from it enters the project;
4. ``sparseedm evaluate`` that dictionary, the shipped CMU-only ``cmu-k2000``
   and the default (``cmu-all-k2000``) on the held-out styles against the
   baselines (``--sweep-atoms``: also Mix Err_ave and time against the number
   of atoms, dictionaries learned on the same training set).

Nothing here is tuned on the test styles. The reports go to the work folder;
``--write-docs`` also collects their tables into
``benchmarks/results-paper-protocol.json``, which the documentation's results
page renders, and copies the learned dictionary's figures to ``docs/``. About half an hour on two cores (the dictionary, the imputers on
20,000 training poses; the sweep adds its dictionaries).
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks import loadavg, machine, versions
from sparseedm.cli import main as cli
from sparseedm.dataset import load_dataset, save_dataset
from sparseedm._atomic import save_json

#: CMU subjects in training (those of the shipped cmu-k2000; 25,926 poses)
CMU_SUBJECTS = ("01", "02", "03")
#: Bandai-Namco styles held out for testing (about a fifth of its poses)
TEST_STYLES = ("angry", "childish", "old", "musical")
ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results-paper-protocol.json"
#: the report's figures the documentation shows (``--write-docs`` copies them to docs/)
FIGURES = ("error_by_count.png", "sweep_atoms.png")
#: the dictionaries evaluated: report name -> what the results file calls it
DICTIONARIES = {"cmu-bandai": "k = 2000 learned on the training set (CMU 01-03 + 11 styles)",
                "cmu-k2000": "shipped cmu-k2000 (CMU subjects 01-03)",
                "default": "shipped default cmu-all-k2000 (every CMU clip)"}


def run(*argv):
    code = cli([str(a) for a in argv])
    if code not in (0, 1):
        raise SystemExit(f"sparseedm {argv[0]} failed with exit code {code}")


def subset(data, rows):
    return {k: (v[rows] if k != "joint_names" else v) for k, v in data.items()}


def build_sets(shared, work):
    """The training and test files in `work` (built once; reused on a second run)."""
    cmu, bandai = work / "cmu.npz", work / "bandai.npz"
    if not cmu.exists():  # subjects 01-03 (the folder holds more)
        run("dataset", "build", *(shared / "cmu-mocap" / "subjects" / s for s in CMU_SUBJECTS),
            "-o", cmu, "--seed", 0, "--quiet")
    if not bandai.exists():
        run("dataset", "build", shared / "bandai-namco-1", "-o", bandai, "--seed", 1, "--quiet")
    b = load_dataset(bandai)
    is_test = np.isin(b["styles"], TEST_STYLES)
    save_dataset(work / "test.npz", subset(b, is_test))
    c = load_dataset(cmu)
    train = {k: (np.concatenate([c[k], b[k][~is_test]]) if k != "joint_names" else c[k])
             for k in c}
    save_dataset(work / "train.npz", train)
    return {"train_poses": int(len(train["poses2d"])), "test_poses": int(is_test.sum())}


def read_csv(path):
    """A report's CSV as a list of rows, numbers as numbers."""
    def value(text):
        try:
            return int(text)
        except ValueError:
            try:
                return float(text)
            except ValueError:
                return text
    with open(path, newline="", encoding="utf-8") as f:
        return [{k: value(v) for k, v in row.items()} for row in csv.DictReader(f)]


def collect(work, meta, sizes, sweep):
    """The reports' tables as one results document (with `sweep`, the sweep's too)."""
    runs = {}
    for name, what in DICTIONARIES.items():
        report = work / f"report-{name}"
        runs[name] = {"dictionary": what, "rows": read_csv(report / "results.csv")}
        if sweep and (report / "sweep.csv").is_file():
            runs[name]["sweep"] = read_csv(report / "sweep.csv")
    return {"meta": meta, "data": {**sizes, "cmu_subjects": list(CMU_SUBJECTS),
                                   "test_styles": list(TEST_STYLES)},
            "paper_protocol": runs}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--work", default="/tmp/sparseedm-results")
    ap.add_argument("--max-poses", default="3000", help="test poses evaluated (seeded subsample)")
    ap.add_argument("--sweep-atoms", default=None, help="e.g. 100,250,500,1000,2000 (Fig. 5)")
    ap.add_argument("--write-docs", action="store_true",
                    help=f"also write {RESULTS.relative_to(ROOT)} (a tracked file the "
                    "documentation renders); default: the reports in --work only")
    args = ap.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    meta = dict(date=time.strftime("%Y-%m-%d %H:%M %Z"), machine=machine(),
                versions=versions(), loadavg_start=loadavg(),
                command="python -m benchmarks.paper_protocol "
                        + " ".join(argv if argv is not None else sys.argv[1:]))
    sizes = build_sets(Path(args.shared), work)

    sel = json.loads((ROOT / "studies" / "dictionary" / "selection.json").read_text())["best"]
    dictionary = work / "cmu-bandai-k2000.npz"
    if not dictionary.exists():
        run("fit", work / "train.npz", "-o", dictionary, "--atoms", 2000,
            "--alpha", sel["alpha_train"], "--alpha-recover", sel["alpha_recover"],
            "--seed", 0, "--quiet")
    for name, d in (("cmu-bandai", dictionary), ("cmu-k2000", "cmu-k2000"),
                    ("default", "default")):
        extra = ["--sweep-atoms", args.sweep_atoms, "--sweep-alpha", sel["alpha_train"]] \
            if args.sweep_atoms and name == "cmu-bandai" else []
        run("evaluate", "--dictionary", d, "--data", work / "test.npz",
            "--train", work / "train.npz", "--max-poses", args.max_poses, "--seed", 0,
            "--max-train", 20000, "-q",
            "-o", work / f"report-{name}", *extra)
        print(f"report: {work / f'report-{name}' / 'report.md'}")
    meta["loadavg_end"] = loadavg()
    if args.write_docs:
        doc = collect(work, meta, sizes, bool(args.sweep_atoms))
        save_json(RESULTS, doc, indent=1)
        print(f"wrote {RESULTS}")
        for figure in FIGURES:  # the figures of the documentation's results page
            made = work / "report-cmu-bandai" / figure
            if made.is_file():
                shutil.copyfile(made, ROOT / "docs" / figure)
                print(f"wrote docs/{figure}")


if __name__ == "__main__":
    main()
