"""
Big files: parallel workers, chunks and a Dask cluster
======================================================

``sparseedm recover`` reads a file in chunks (``--chunk-size`` poses at a time,
50,000 by default), so memory stays bounded however large the file; a ``.npy``
file is even streamed from disk. Within a chunk, ``--jobs N`` uses N cores. On
a Dask cluster, ``--backend dask --scheduler ADDRESS`` sends the work to its
workers, and the results equal a local run.

This tutorial makes a file of 1,000 occluded poses (a stand-in: the same commands serve millions) from the CMU poses the
repository ships (``tests/fixtures/cmu_poses.npz``), recovers it with two
workers, then on a local Dask cluster (if the ``dask`` extra is installed).
"""

# %%
# A big file
# ----------
# Poses in an ``.npy`` array of shape (n, 14, 2), NaN at the hidden joints
# (here 1-3 joints per pose, drawn as the paper's evaluation does).

import numpy as np

from sparseedm.metrics import random_occlusion


# %%
# The script works in a temporary folder, ``work``; ``sh(...)`` runs a command
# there and prints what it prints, as a terminal would (both come from
# ``docs/tutorials/_workdir.py``; run the script from anywhere inside a
# clone).

# sphinx_gallery_start_ignore
from _workdir import repository, sh, work_folder  # noqa: F401

repo = repository()
work = work_folder()
# sphinx_gallery_end_ignore


with np.load(repo / "tests" / "fixtures" / "cmu_poses.npz") as data:
    base = data["poses2d"]
rng = np.random.default_rng(0)
poses = base[rng.integers(len(base), size=1000)] + rng.normal(0, 0.5, (1000, 14, 2))
hidden = random_occlusion(len(poses), 14, "mix", random_state=0)
poses[hidden] = np.nan
np.save(work / "big.npy", poses)
print(poses.shape, f"{hidden.sum()} hidden joints")

# %%
# Two workers, in chunks
# ----------------------
# ``--no-adapt`` keeps this tutorial short: by default the dictionary is first
# adapted on the file's own complete poses (:doc:`/howto/adaptation`).
sh("sparseedm recover big.npy -o filled.npy --jobs 2 --chunk-size 250 --no-adapt", work)

# %%
# A ``.npy`` output has a ``.status.npz`` beside it (each row's status, the
# filled joints, the solver's certificate):
filled = np.load(work / "filled.npy")
with np.load(work / "filled.status.npz") as status:
    print(np.unique(status["status"], return_counts=True))
print("any NaN left:", bool(np.isnan(filled).any()))

# %%
# From Python
# -----------
# :func:`sparseedm.recover` takes an array of any length and cuts it into
# chunks itself (``chunk_size`` poses, 2,048 by default): ``n_jobs=2`` codes
# two chunks at a time, and ``progress=True`` draws a bar over the chunks on
# stderr (the library is silent by default). ``res.summary()`` counts the
# statuses and says which way the file was coded; with 2,000 or more complete
# poses that is over the file's own poses (:doc:`/howto/adaptation`), and
# ``preset="fast"`` codes each pose over its nearest ones only, much faster on
# files of 100,000 poses and more.
import sparseedm  # noqa: E402

res = sparseedm.recover(poses, n_jobs=2, progress=True)
summary = res.summary()
print(summary["status"], "| no adaptation:" if not res.adapted else "| adapted:",
      summary["adaptation"]["reason"])
print(f"{summary['poses_per_second']:.0f} poses/s")

# %%
# On a Dask cluster
# -----------------
# With the ``dask`` extra (``pip install "sparseedm[dask]"``) on the client and
# on every worker, start a scheduler and workers (``dask scheduler``,
# ``dask worker tcp://HOST:8786``) and pass its address. Here a
# ``LocalCluster`` of two workers (threads of this process) stands in for a
# real one. Poses are grouped
# by their missing joints and cut into chunks that joblib's Dask backend sends
# to the workers. Without ``--no-adapt`` the check that chooses between the
# file's own atoms and adaptation, and the adaptation's recoveries when it
# adapts (the guard's and every self-training round's), go to the workers too,
# with the same results as on one machine; the online learning of the adapted
# atoms runs on the client (each mini-batch updates the atoms the next is coded
# on).
try:
    from dask.distributed import LocalCluster
except ImportError:
    LocalCluster = None
    print("the dask extra is not installed: this step is shown, not run")

if LocalCluster is not None:
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      protocol="tcp", dashboard_address=None) as cluster:
        print("scheduler:", cluster.scheduler_address)
        sh(f"sparseedm recover big.npy -o filled_dask.npy --no-adapt --backend dask "
           f"--scheduler {cluster.scheduler_address}", work)
        res = sparseedm.recover(poses[:300], backend="dask",
                                scheduler=cluster.scheduler_address, adapt=False)
    print(res.summary()["status"])
    same = np.array_equal(np.load(work / "filled_dask.npy"), filled, equal_nan=True)
    print("the cluster's output equals the local one:", same)

# %%
# How fast
# --------
# The benchmarks measure the lasso against SPAMS and scikit-learn on the same
# machine in the same run; see :doc:`/results/speed`. On two shared cores,
# half-occluded files of 6,000 and 30,000 poses ran at about 1,400 poses a
# second coded over the default dictionary alone, 1,500-1,700 with the
# defaults (half the poses complete: they are the atoms, nothing learned;
# ``benchmarks/results-default-path.json``) and about 500 with
# ``--no-adapt``'s prior, mirror image and pose bank
# (``benchmarks/results-frontier.json``). Adapting the dictionary costs a
# fixed few seconds to half a minute per file, and a file with 2,000 or more
# complete poses skips it (its own complete poses are the atoms).
