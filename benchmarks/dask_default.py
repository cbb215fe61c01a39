"""``python -m benchmarks.dask_default [--quick] [--write-docs]``:
``recover(exemplars=False)``, the default path's adaptation and self-training
(what the defaults run where the file's own poses are not taken as the atoms;
on this file, with 3,000 complete poses, the defaults would take them and
learn nothing), in this process against the same call with ``backend="dask"`` on a local Dask cluster of 1 and of 2 worker
processes (one thread each), measured in one run.

Data: the default-path benchmark's 6,000-pose file (:mod:`benchmarks.default_path`:
Bandai-Namco-1 poses, half complete and half under Mix occlusion; ``--quick``:
1,200), the shipped default dictionary. With ``backend="dask"`` the recoveries
(the guard's, the self-training rounds' and the final one) run on the workers;
the online learning of the atoms and the filters stay in this process. Each
cluster's workers are warmed first (a recovery of 400 poses compiles their
kernels). Reported: seconds, poses/s and the largest absolute difference of the
filled poses (pixels) from the local run, and whether the adaptation made the
same decisions (adopted, the guard's errors).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from . import bench_main, log, run_line, table
from .default_path import load_bandai, make_file, occluded_error


def _timed(X, mask, base, **kw):
    import sparseedm

    t0 = time.perf_counter()
    res = sparseedm.recover(X, mask, dictionary=base, exemplars=False, **kw)
    return res, time.perf_counter() - t0


def _row(res, secs, P, mask, local=None):
    a = res.adaptation
    row = {"seconds": secs, "poses_per_s": len(P) / secs,
           "err_occluded": occluded_error(res, P, mask), "adapted": bool(res.adapted),
           "err_adapted": float(a.err_adapted), "self_training": a.self_training}
    if local is not None:
        row["max_abs_diff_px"] = float(np.nanmax(np.abs(res.poses - local.poses)))
        row["same_status"] = bool(np.array_equal(res.status, local.status))
    return row


def run(quick=False):
    import sparseedm
    from distributed import Client, LocalCluster
    from sparseedm.adaptation import run_adaptation

    pool, path = load_bandai()
    base = sparseedm.load_dictionary()
    n = 1200 if quick else 6000
    log(f"dask default-path benchmark: {n:,} poses of the pool at {path}")
    P, mask = make_file(pool, n)
    X = np.where(mask[..., None], np.nan, P)
    W, wmask = make_file(pool, 400, seed=1)
    warm = dict(adapt=False)
    out = {"n_poses": len(P), "n_occluded": int(mask.any(axis=1).sum())}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run_adaptation(base, pool[:300], min_poses=1, passes=1)  # the JIT caches
        _timed(np.where(wmask[..., None], np.nan, W), wmask, base, **warm)
        log("  local (this process, n_jobs=1)")
        local, secs = _timed(X, mask, base)
        out["local"] = _row(local, secs, P, mask)
        for workers in (1, 2):
            with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                              host="127.0.0.1", dashboard_address=None) as cluster, \
                    Client(cluster):
                _timed(np.where(wmask[..., None], np.nan, W), wmask, base, backend="dask",
                       **warm)
                log(f"  dask, {workers} worker(s)")
                res, secs = _timed(X, mask, base, backend="dask")
                out[f"dask {workers}"] = _row(res, secs, P, mask, local)
    out["speedup_2_vs_1"] = out["dask 1"]["seconds"] / out["dask 2"]["seconds"]
    return out


def render(res, meta):
    lines = [run_line(meta, "python -m benchmarks.dask_default"), "",
             f"{res['n_poses']:,} Bandai-Namco-1 poses, half occluded (Mix), shipped "
             "dictionary, `recover(exemplars=False)` (the defaults' adaptation and "
             "self-training); dask rows: `backend=\"dask\"` on a "
             "`LocalCluster(n_workers=k, threads_per_worker=1)` on the same machine "
             "(the recoveries of the guard, the self-training rounds and the final one on "
             "the workers; the learning in this process).", ""]
    rows = []
    for name in ("local", "dask 1", "dask 2"):
        r = res[name]
        rows.append([name, r["seconds"], r["poses_per_s"], r["err_occluded"],
                     r.get("max_abs_diff_px", 0.0), str(r.get("same_status", True))])
    lines.append(table(["run", "seconds", "poses/s", "Err_ave (%)",
                        "max abs diff vs local (px)", "same statuses"], rows))
    lines += ["", f"2 workers against 1: {res['speedup_2_vs_1']:.2f}x (one run each). The "
              "local run (`n_jobs=1`) has numba's threads on every core for its kernels; "
              "the clusters' workers share this machine's cores with the client's "
              "learning, where separate machines would add cores."]
    return "\n".join(lines)


def main(argv=None):
    bench_main(argv, prog="python -m benchmarks.dask_default", doc=__doc__,
               quick_help="1,200 poses: a smoke test", run=run, render=render,
               tag="DASK DEFAULT", heading="The default path on a Dask cluster "
               "(benchmarks/dask_default.py)", results="results-dask-default.json")


if __name__ == "__main__":
    main()
