"""Mocap check: a file of C complete + M occluded CMU poses (Mix of 1-3 hidden
joints), recovered cold and with defaults; mean error of the hidden joints as %
of body size (head top to the ankles' midpoint). Files below adaptation's size
take the file-atoms path.

    python studies/real_prior/mocap_check.py DATA.npz [DATA.npz ...] --complete 100 --occluded 300
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from sparseedm._atomic import json_text  # noqa: E402
import sparseedm  # noqa: E402
from benchmarks.real2d import body_size  # noqa: E402
from sparseedm.metrics import occlusion_masks  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="+", type=Path)
    ap.add_argument("--complete", type=int, default=100)
    ap.add_argument("--occluded", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dictionary", default=None, help="default: the shipped one")
    ap.add_argument("--alpha", type=float)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    out = {}
    for path in a.data:
        with np.load(path, allow_pickle=False) as z:
            poses = z["poses2d"]
        rng = np.random.default_rng(a.seed)
        truth = poses[rng.choice(len(poses), a.complete + a.occluded, replace=False)]
        missing = np.zeros((len(truth), 14), bool)
        missing[a.complete:] = occlusion_masks(a.occluded, 14, ("mix",), a.seed)["mix"]
        given = np.where(missing[..., None], np.nan, truth)
        row = {}
        for name, kw in (("cold", dict(adapt=False)), ("defaults", {})):
            res = sparseedm.recover(given, missing, dictionary=a.dictionary, alpha=a.alpha,
                                    **kw)
            err = np.linalg.norm(res.poses - truth, axis=-1) / body_size(truth)[:, None] * 100
            row[name] = {"joint_error_pct_body": round(float(err[missing].mean()), 3),
                         "file_atoms": (res.adaptation.file_atoms if res.adaptation else 0),
                         "adapted": res.adapted}
        out[path.name] = row
        print(path.name, row, flush=True)
    if a.out:
        a.out.write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
