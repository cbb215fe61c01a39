"""
Your own motion capture: learn a dictionary from BVH or ASF/AMC
===============================================================

The shipped dictionary is learned from the CMU motion capture database. If
the people you film move differently (a sport, a clinic, an animal-like
crawl), a dictionary learned from motion capture of such movement fills their
hidden joints better. sparseedm builds 2D training poses from 3D motion
capture by looking at each frame through seeded virtual cameras, and learns the
dictionary from them.

This tutorial uses the small CMU-derived files the repository ships for its
tests (``tests/fixtures/cmu_02_01_short.bvh``, and ``cmu_02.asf`` with
``cmu_02_01_short.amc``: a few seconds of subject 02 walking), and learns a
tiny dictionary in one pass so that it runs in seconds. A real one uses
thousands of atoms and many clips (see the commands at the end).
"""

# %%
# The files
# ---------

# The script works in a temporary folder, ``work``, holding copies of the
# three motion files (in ``mocap/``) and ``occluded_poses.csv``; ``sh(...)``
# runs a command there and prints what it prints, as a terminal would (both
# come from ``docs/tutorials/_workdir.py``; run the script from anywhere
# inside a clone).

# sphinx_gallery_start_ignore
import shutil

from _workdir import repository, sh, work_folder  # noqa: F401

repo = repository()
work = work_folder("tests/fixtures/cmu_02_01_short.bvh", "tests/fixtures/cmu_02.asf",
                   "tests/fixtures/cmu_02_01_short.amc", into="mocap")
shutil.copy(repo / "examples" / "occluded_poses.csv", work)
# sphinx_gallery_end_ignore


# %%
# What the loader makes of a file
# -------------------------------
# ``dataset inspect`` says which rig it recognised, the units it chose (from the
# standing height), the T-pose frames it would drop, and where each of the 14
# joints comes from. A rig it does not know needs a joint map
# (:doc:`/howto/joint_maps`).
sh("sparseedm dataset inspect mocap/cmu_02_01_short.bvh", work)

# %%
# Build the training poses
# ------------------------
# Every BVH and ASF/AMC clip of the folder, every frame (``--frame-step 1``;
# by default about 40 frames a second are kept) seen by ten seeded virtual
# cameras.
sh("sparseedm dataset build mocap -o train.npz --frame-step 1 --cameras-per-pose 10 --seed 0", work)

# %%
# Learn the dictionary
# --------------------
# 32 atoms and one pass keep this tutorial fast; ``fit``'s defaults are 2,000
# atoms and two passes.
sh("sparseedm fit train.npz -o mine.npz --atoms 32 --passes 1 --seed 0", work)
sh("sparseedm info mine.npz", work)

# %%
# Use it
# ------
sh("sparseedm recover occluded_poses.csv -o filled.csv --dictionary mine.npz --no-adapt", work)

# %%
# The same in Python
# ------------------
# :func:`sparseedm.mocap.load_mocap` reads a clip as (frames, 14, 3) joint
# positions in metres; :class:`sparseedm.learning.OnlineDictionaryLearning` has
# scikit-learn's ``fit`` / ``partial_fit``.
import numpy as np  # noqa: E402

import sparseedm  # noqa: E402
from sparseedm.dataset import load_dataset  # noqa: E402
from sparseedm.mocap import load_mocap  # noqa: E402

joints = load_mocap(work / "mocap" / "cmu_02_01_short.amc")
print("AMC clip:", joints.shape, "metres; height", np.round(np.ptp(joints[0, :, 1]), 2))
train = load_dataset(work / "train.npz")
print("training poses:", train["poses2d"].shape)
mine = sparseedm.load_dictionary(work / "mine.npz")
print(f"{len(mine.components)} atoms; recovery alpha {mine.alpha_recover}")

# %%
# A file that cannot be read is refused with the file and the reason; a folder
# build skips such files, lists them and builds the rest (exit code 1):
shutil.copy(repo / "tests" / "fixtures" / "bad_input" / "mocap" / "err_hierarchy_cut.bvh",
            work / "mocap")
sh("sparseedm dataset build mocap -o train2.npz --seed 0", work, expect=1)

# %%
# At full size
# ------------
# On a folder of many clips: ``sparseedm dataset build CLIPS/ -o train.npz
# --seed 0``, then ``sparseedm fit train.npz -o my.npz`` (2,000 atoms, two
# passes, training alpha 1.6: the defaults chosen for a training set of a few
# subjects; the shipped ``cmu-all-k2000`` was learned from every CMU clip,
# 52,145 poses, with ``--alpha 0.8 --alpha-recover 0.0005 --passes 1``, as
# ``sparseedm info default`` says and :doc:`/explanation/settings` explains).
# ``fit`` shows a progress bar with the time left; Ctrl-C leaves a checkpoint
# and ``--resume`` continues from it. To start from the shipped dictionary
# instead of from scratch, ``sparseedm fit train.npz -o tuned.npz --init default``
# fine-tunes it on your poses.
