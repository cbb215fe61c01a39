"""Reproduce the README's results: CMU + part of Bandai-Namco for training,
held-out Bandai-Namco styles for testing.

    python examples/reproduce_results.py [--shared ../shared/data] [--work /tmp/sparseedm-results]

Steps (all through the public CLI/API):

1. build the CMU (subjects 01-03) and the Bandai-Namco training sets (one
   virtual camera per pose);
2. split Bandai-Namco **by style** (whole clips; frames of one clip are nearly
   identical): the styles in ``TEST_STYLES`` are the test set, the others join
   the CMU poses for training;
3. learn a k = 2000 dictionary on that training set with the shipped
   dictionary's settings (training alpha and recovery alpha chosen on the CMU
   validation split, ``studies/dictionary/selection.json``), in the work folder --
   Bandai-Namco is CC BY-NC, so nothing learned from it enters the project;
4. ``sparseedm evaluate`` that dictionary, the shipped CMU-only ``cmu-k2000``
   and the default (``cmu-all-k2000``), on the held-out styles against the
   baselines.

Nothing here is tuned on the test styles.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from sparseedm.cli import main as cli
from sparseedm.dataset import load_dataset, save_dataset

#: CMU subjects in training (those of the shipped cmu-k2000; 25,926 poses)
CMU_SUBJECTS = ("01", "02", "03")
#: Bandai-Namco styles held out for testing (about a fifth of its poses)
TEST_STYLES = ("angry", "childish", "old", "musical")
ROOT = Path(__file__).resolve().parents[1]


def run(*argv):
    code = cli([str(a) for a in argv])
    if code not in (0, 1):
        raise SystemExit(f"sparseedm {argv[0]} failed with exit code {code}")


def subset(data, rows):
    return {k: (v[rows] if k != "joint_names" else v) for k, v in data.items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--work", default="/tmp/sparseedm-results")
    ap.add_argument("--max-poses", default="3000", help="test poses evaluated (seeded subsample)")
    ap.add_argument("--sweep-atoms", default=None, help="e.g. 100,250,500,1000,2000 (Fig. 5)")
    args = ap.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    shared = Path(args.shared)

    cmu, bandai = work / "cmu.npz", work / "bandai.npz"
    if not cmu.exists():  # the README's setting: subjects 01-03 (the folder holds more)
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

    sel = json.loads((ROOT / "studies" / "dictionary" / "selection.json").read_text())["best"]
    dictionary = work / "cmu-bandai-k2000.npz"
    if not dictionary.exists():
        run("fit", work / "train.npz", "-o", dictionary, "--atoms", 2000,
            "--alpha", sel["alpha_train"], "--alpha-recover", sel["alpha_recover"],
            "--seed", 0, "--quiet")
    # the table's dictionary, the README's CMU-only paragraph (cmu-k2000) and the default
    for name, d in (("cmu-bandai", dictionary), ("cmu-k2000", "cmu-k2000"),
                    ("default", "default")):
        extra = ["--sweep-atoms", args.sweep_atoms, "--sweep-alpha", sel["alpha_train"]] \
            if args.sweep_atoms and name == "cmu-bandai" else []
        run("evaluate", "--dictionary", d, "--data", work / "test.npz",
            "--train", work / "train.npz", "--max-poses", args.max_poses, "--seed", 0,
            "--max-train", 20000,
            "-o", work / f"report-{name}", *extra)
        print(f"report: {work / f'report-{name}' / 'report.md'}")


if __name__ == "__main__":
    main()
