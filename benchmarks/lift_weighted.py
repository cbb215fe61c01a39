"""The weighted dictionary lifter: rows coded one by one against rows grouped by pattern.

    nice python -m benchmarks.lift_weighted [--rows 2000] [--repeats 3]

``DictionaryLifter.predict(weights=)`` codes rows whose weights are not all 1
(joints filled across time, :func:`sparseedm.lifting.uncertainty3d.filled_weights`)
on their own weighted sub-dictionary, without the cached Gram of the plain rows.
Rows that share their observed entries and their weights share that
sub-dictionary and, from ``WEIGHTED_GROUP_MIN`` rows on, are coded in one
solve. This times, in one run and process, the shipped lifter on the fixture's
CMU poses (seeded jitter to `--rows`), one filled joint per row:

* ``repeated``: the filled joint's weight one of 5 values (5 patterns);
* ``repeated, small groups``: one of 50 values (groups under the minimum:
  row by row, as before);
* ``distinct``: weights from filled_weights with a seeded radius per row (every
  row its own pattern, as fills across time give);

each as one ``predict`` call against one call per row, with the largest
difference of the 3D vectors. The ``distinct`` row is one solve per row both
ways: its ratio is the per-call overhead of the row-by-row reference, which the
other rows' ratios include. Prints a table; writes nothing.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks import loadavg, machine, table

from sparseedm.lifting import load_lifter
from sparseedm.lifting.uncertainty3d import filled_weights
from sparseedm.normalize import represent

FIXTURE = "tests/fixtures/cmu_poses.npz"


def _poses(n, seed=0):
    with np.load(FIXTURE, allow_pickle=False) as data:
        base = data["poses2d"]
    rng = np.random.default_rng(seed)
    return base[rng.integers(0, len(base), n)] + rng.normal(0, 1.0, (n, 14, 2))


def _cases(poses, seed=0):
    rng = np.random.default_rng(seed)
    n = len(poses)
    filled = np.zeros((n, 14), bool)
    filled[:, 4] = True
    repeated, small = np.ones((n, 14)), np.ones((n, 14))
    repeated[:, 4] = rng.choice([0.2, 0.4, 0.6, 0.8, 0.9], n)
    small[:, 4] = rng.choice(np.linspace(0.1, 0.95, 50), n)
    radius = np.where(filled, rng.uniform(1.0, 40.0, (n, 1)), 0.0)
    distinct = filled_weights(poses, np.zeros((n, 14), bool), filled, radius)
    return {"repeated": repeated, "repeated, small groups": small, "distinct": distinct}


def _best(f, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    lf = load_lifter()
    poses = _poses(args.rows)
    none = np.zeros((len(poses), 14), bool)
    X2, _, _ = represent(poses, none, "average")
    lf.predict(X2[:2], none[:2], weights=np.full((2, 14), 0.5))  # warm-up (JIT, caches)
    print(f"machine: {machine()}; load average at start {loadavg()}")
    rows = []
    for name, w in _cases(poses).items():
        patterns = len(np.unique(w, axis=0))
        t_grouped, (Y, _) = _best(lambda: lf.predict(X2, none, weights=w), args.repeats)
        t_rows, Ys = _best(lambda: [lf.predict(X2[i:i + 1], none[i:i + 1],
                                               weights=w[i:i + 1])[0][0]
                                    for i in range(len(X2))], args.repeats)
        diff = float(np.max(np.abs(Y - np.array(Ys))))
        rows.append([name, f"{len(X2):,}", f"{patterns:,}", f"{len(X2) / t_rows:,.0f}",
                     f"{len(X2) / t_grouped:,.0f}", f"{t_rows / t_grouped:.2f}",
                     f"{diff:.1e}"])
    print(table(["weights", "rows", "patterns", "row by row, rows/s", "grouped, rows/s",
                 "speed-up", "max |diff|"], rows))
    print(f"load average at end {loadavg()}")


if __name__ == "__main__":
    main()
