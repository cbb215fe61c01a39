"""Cached answers of the peers on studies/real_prior/harness.py's files: recover()'s
defaults, recover(adapt=False) and IterativeImputer (``iterative``), one .npz per
file under ``CACHE`` (the shape-model study, ``probe_shape3d.py``, stacks on them).

    python studies/real_prior/shape3d_answers.py --files mpii,coco,bonn,mpii-large --seeds 0,1,2
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchmarks import real2d  # noqa: E402
import harness  # noqa: E402

CACHE = Path("/tmp/shape3d/cache")
METHODS = {"defaults": harness.sparse(), "cold": harness.sparse(adapt=False),
           "iterative": harness.iterative}


def answers(name, protocol, seed, realset=None, methods=tuple(METHODS)):
    """``(truth, missing, {method: filled})`` of one harness file, cached."""
    path = CACHE / f"{name}_{protocol}_{seed}.npz"
    truth, missing = harness.make_file(name, protocol, seed, realset=realset)
    got = {}
    if path.exists():
        with np.load(path, allow_pickle=False) as z:
            got = {k: z[k] for k in z.files}
    todo = [m for m in methods if m not in got]
    for m in todo:
        t0 = time.perf_counter()
        got[m] = METHODS[m](truth, missing)
        got[f"{m}_seconds"] = np.array(time.perf_counter() - t0)
    if todo:
        CACHE.mkdir(parents=True, exist_ok=True)
        np.savez(path, **got)
    return truth, missing, {m: got[m] for m in methods}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", default="mpii,coco,bonn,mpii-large")
    ap.add_argument("--protocols", default=",".join(harness.PROTOCOLS))
    ap.add_argument("--seeds", default="0,1,2")
    a = ap.parse_args(argv)
    for seed in map(int, a.seeds.split(",")):
        for name in a.files.split(","):
            rs = real2d.load(harness.FILES[name][0])
            for protocol in a.protocols.split(","):
                t0 = time.perf_counter()
                truth, missing, got = answers(name, protocol, seed, rs)
                print(name, protocol, seed, {m: round(harness.score(f, truth, missing), 3)
                                             for m, f in got.items()},
                      f"{time.perf_counter() - t0:.0f}s", flush=True)


if __name__ == "__main__":
    main()
