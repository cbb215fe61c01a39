"""``python -m studies.parallel.jobs [--reps R] [--large-reps L]``: ``recover()`` with its
defaults, ``n_jobs=1`` against ``n_jobs=2``, on a small and a large file in one run,
and ``n_jobs=2`` under the rule before :data:`sparseedm._parallel.TASK_MIN_ROWS`
(tasks of at least 64 rows, up to four per worker: 199 occluded poses cut into
three tasks for two workers).

Files: the MPII validation photo file (``studies/real_prior/harness.py``: 200
complete + 199 poses with 1 random hidden joint, seed 0) and the frontier's
6,000-pose Bandai-Namco-1 file (``benchmarks/default_path.make_file``, half under
Mix masks). Calls alternate (1, 2, 2 old rule) so the machine's load falls on
each alike; the median wall time of each is kept, and the median over rounds of
each call's time over that round's ``n_jobs=1``, with the 1-minute load average
before and after. On a loaded machine the wall times hide what an idle one
shows, so the small file's lasso tasks under the rule before are also timed on
their own threads' CPU clocks: the makespan of two workers taking them in turn
(each task to the worker free first), against their CPU split evenly over two
cores (what numba's threads do with one task). Writes ``jobs.json`` beside this
script.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
sys.path.insert(0, str(HERE.parent / "real_prior"))

import harness  # noqa: E402

from sparseedm._atomic import json_text  # noqa: E402
import sparseedm  # noqa: E402
from benchmarks.default_path import load_bandai, make_file  # noqa: E402
from joblib import effective_n_jobs  # noqa: E402
from sparseedm import _parallel  # noqa: E402
from sparseedm.solvers.fast import NUMPY_MAX  # noqa: E402

RULE = _parallel.min_tasks


def old_rule(n_jobs, backend, n_rows, shared=False):
    """The rule before: up to four tasks per worker, none under NUMPY_MAX rows."""
    if n_jobs in (None, 1) and backend is None:
        return 1
    return max(min(4 * max(effective_n_jobs(n_jobs), 1), n_rows // NUMPY_MAX), 1)


def timed(X, mask, n_jobs, rule):
    _parallel.min_tasks = rule
    try:
        t = time.perf_counter()
        sparseedm.recover(X, mask, n_jobs=n_jobs)
        return time.perf_counter() - t
    finally:
        _parallel.min_tasks = RULE


def run_file(X, mask, reps):
    runs = {"n_jobs=1": [], "n_jobs=2": [], "n_jobs=2, old rule": []}
    load = [os.getloadavg()[0]]
    for _ in range(reps):
        runs["n_jobs=1"].append(timed(X, mask, 1, RULE))
        runs["n_jobs=2"].append(timed(X, mask, 2, RULE))
        runs["n_jobs=2, old rule"].append(timed(X, mask, 2, old_rule))
    load.append(os.getloadavg()[0])
    one = np.array(runs["n_jobs=1"])
    return {"poses": len(X), "occluded": int(mask.any(axis=1).sum()),
            "median_seconds": {k: round(float(np.median(v)), 2) for k, v in runs.items()},
            "median_ratio_to_n_jobs_1": {k: round(float(np.median(np.array(v) / one)), 3)
                                         for k, v in runs.items() if k != "n_jobs=1"},
            "seconds": {k: [round(s, 2) for s in v] for k, v in runs.items()},
            "load_1min_before_after": [round(x, 2) for x in load]}


def makespan(X, mask):
    """Under the rule before, n_jobs=2: (kernel CPU seconds in calls cut into tasks,
    two workers' makespan of them, tasks per call)."""
    from sparseedm import _recovery_kernel as kernel

    calls, solve, cut = [], kernel.solve_chunk, kernel.chunk_tasks

    def timed_solve(*args):
        t = time.thread_time()
        out = solve(*args)
        calls[-1].append(time.thread_time() - t)
        return out

    def noted_cut(*args, **kwargs):
        calls.append([])
        return cut(*args, **kwargs)

    kernel.solve_chunk, kernel.chunk_tasks, _parallel.min_tasks = timed_solve, noted_cut, old_rule
    try:
        sparseedm.recover(X, mask, n_jobs=2)
    finally:
        kernel.solve_chunk, kernel.chunk_tasks, _parallel.min_tasks = solve, cut, RULE
    total = span = 0.0
    for tasks in (c for c in calls if len(c) > 1):
        free = [0.0, 0.0]
        for t in tasks:
            free[int(np.argmin(free))] += t
        total, span = total + sum(tasks), span + max(free)
    return {"kernel_cpu_seconds": round(total, 2), "two_workers_makespan": round(span, 2),
            "even_split": round(total / 2, 2), "tasks_per_call": [len(c) for c in calls]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--large-reps", type=int, default=1)
    args = ap.parse_args(argv)
    truth, missing = harness.make_file("mpii", "1", 0)
    small = np.where(missing[..., None], np.nan, truth), missing
    pool, _ = load_bandai()
    P, mask = make_file(pool, 6000)
    large = np.where(mask[..., None], np.nan, P), mask
    for X, m in (small, (large[0][:600], large[1][:600])):  # JIT caches, out of the timings
        sparseedm.recover(X, m, n_jobs=1)
        sparseedm.recover(X, m, n_jobs=2)
    out = {"cpus": os.cpu_count(), "task_min_rows": _parallel.TASK_MIN_ROWS,
           "small_file_old_rule_tasks": makespan(*small),
           "files": {"MPII val photo file (1 hidden joint, seed 0)": run_file(*small, args.reps),
                     "6,000 Bandai-Namco-1 poses (half under Mix)": run_file(*large,
                                                                            args.large_reps)}}
    print(json.dumps(out, indent=1))
    (HERE / "jobs.json").write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
