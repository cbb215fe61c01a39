"""
Photos of people: a COCO file, filled and lifted
================================================

A keypoint detector or an annotator run on photos leaves joints out: an arm
behind the body, legs outside the picture, a face turned away. This tutorial
takes ``examples/coco_photos.json``, 243 people in 87 COCO photos as COCO
annotates them (17 keypoints, ``v = 0`` where a keypoint is not there), fills
in their hidden joints, says what was done to each person, checks the answer on
joints whose truth is known, and lifts the people to 3D.

The same steps work on the output of OpenPose, MMPose, AlphaPose or
DeepLabCut: only the file's name changes (:doc:`/howto/formats`).

*COCO 2017 keypoint annotations © COCO Consortium, licensed CC BY 4.0
(https://cocodataset.org); these images' people are in no shipped dictionary.*
"""

# %%
# The file
# --------
# The script works in a temporary folder, ``work``, holding a copy of
# ``coco_photos.json``; ``sh(...)`` runs a command there and prints what it
# prints, as a terminal would (both come from ``docs/tutorials/_workdir.py``).

# sphinx_gallery_start_ignore
from _workdir import repository, sh, work_folder  # noqa: F401

repo = repository()
work = work_folder("examples/coco_photos.json")
# sphinx_gallery_end_ignore

import numpy as np

from sparseedm.keypoints import read_keypoints

kps = read_keypoints(work / "coco_photos.json")
hidden = kps.missing.sum(axis=1)
print(f"{len(kps.poses)} people; complete: {(hidden == 0).sum()}; "
      f"1-3 joints hidden: {((hidden > 0) & (hidden < 4)).sum()}; 4 or more: {(hidden >= 4).sum()}")

# %%
# COCO's 17 keypoints become sparseedm's 14 joints: the neck is the shoulders'
# midpoint and the head top is placed from the face (both missing when their
# keypoints are). Many people here lack most of their body: legs cut off by the
# photo's edge are the commonest gap.

# %%
# Fill the hidden joints
# ----------------------
# One command. It prints what it did: which prior the poses were coded
# over and why, and what their answers were averaged with. A person with too
# few visible joints is refused (written back unchanged and listed in
# ``filled.errors.csv``); the others are still done.
sh("sparseedm recover coco_photos.json -o filled.json", work, expect=1)

# %%
# The output is the same COCO file, the filled keypoints set (with ``v = 0``
# kept, so no tool mistakes them for annotations) and a ``"sparseedm"`` object
# per person: which joints were filled, each one's 90 % radius in pixels, the
# status. Exit code 1 says some rows were refused.
import json  # noqa: E402

person = json.loads((work / "filled.json").read_text())["annotations"][1]["sparseedm"]
print("filled:", ", ".join(f"{j} ({person['uncertainty'][j]:.0f} px)" for j in person["filled"]))
print("other fields:", sorted(set(person) - {"filled", "uncertainty"}))

# %%
# What was done, from Python
# --------------------------
# :func:`sparseedm.recover` returns a :class:`~sparseedm.recovery.RecoveryResult`.
# This file has 55 complete people: too few to learn from (adaptation needs 250),
# enough to join the shipped dictionary's atoms. ``summary()["adaptation"]``
# says which path ran and why, the shipped pose bank's weight (0: on probes of
# the occluded people it did not beat the file's own poses) and the donor
# step's (0: the file's other people did not help the probes).
import sparseedm  # noqa: E402

res = sparseedm.recover(kps.poses, kps.missing)
print(res.summary()["status"])
info = res.summary()["adaptation"]
print("path:", info["path"])
print("pose bank's weight:", info["bank"]["weight"])
print("donors' weight:", info["donors"]["weight"])

# %%
# On photos the default path averages a pose's answer with others where a
# check on the file's own complete poses says the mean errs less: the local
# ridge over the file's complete poses (for 4 or more hidden joints), over the
# shipped atoms plus them, and one Gaussian fitted to the file's poses
# (:doc:`/howto/adaptation`). ``res.averaged`` says, per person, what their
# answer was averaged with; ``res.spread`` how far apart the averaged answers
# were at each filled joint, in pixels: a large spread is a joint the methods
# disagree on.
kinds, counts = np.unique(res.averaged, return_counts=True)
for kind, count in zip(kinds, counts):
    print(f"{count:4d}  {kind or '(nothing averaged)'}")
filled = res.missing & res.ok[:, None]
print(f"spread at the filled joints: median {np.median(res.spread[filled]):.0f} px")

# %%
# How sure each filled joint is: ``res.uncertainty`` holds its 90 % radius in
# pixels (a circle that holds the true joint 9 times in 10,
# :doc:`/explanation/uncertainty`). A joint far from every visible one, a knee
# of a person seen down to the waist, gets a wide circle.
radius = res.uncertainty[filled]
print(f"90 % radius: median {np.median(radius):.0f} px, "
      f"a quarter over {np.percentile(radius, 75):.0f} px")

# %%
# A check on your own file
# ------------------------
# The truth of a hidden joint is unknown, but the complete people's joints are
# known: hide two joints in each of 20 of them (seeded), recover the whole file,
# and compare. Errors are in % of the body's size (head top to the ankles'
# midpoint), beside scikit-learn's IterativeImputer fitted on the same file and
# sparseedm without adaptation (``adapt=False``: the shipped CMU + COCO prior
# and pose bank alone, nothing learned from the file).
import warnings  # noqa: E402

from sklearn.exceptions import ConvergenceWarning  # noqa: E402
from sklearn.experimental import enable_iterative_imputer  # noqa: E402,F401
from sklearn.impute import IterativeImputer  # noqa: E402

rng = np.random.default_rng(0)
complete = np.flatnonzero(~kps.missing.any(axis=1))
probe = rng.choice(complete, 20, replace=False)
test_missing = kps.missing.copy()
for row in probe:
    test_missing[row, rng.choice(14, 2, replace=False)] = True
truth = kps.poses[probe]
size = np.linalg.norm(truth[:, 0] - truth[:, [10, 13]].mean(axis=1), axis=-1)
mask = test_missing[probe] & ~kps.missing[probe]


def error(poses):
    """Mean distance of the probes' hidden joints to the truth, % of body size."""
    return np.mean((np.linalg.norm(poses[probe] - truth, axis=-1) / size[:, None] * 100)[mask])


test_res = sparseedm.recover(kps.poses, test_missing)
cold = sparseedm.recover(kps.poses, test_missing, adapt=False)
flat = np.where(test_missing[..., None], np.nan, kps.poses).reshape(len(kps.poses), -1)
usable = (~test_missing).sum(axis=1) >= 4
imputed = np.full_like(flat, np.nan)
with warnings.catch_warnings():  # its rounds stop at max_iter on this file
    warnings.simplefilter("ignore", ConvergenceWarning)
    imputed[usable] = IterativeImputer(max_iter=10, random_state=0).fit_transform(flat[usable])
inside = np.linalg.norm(test_res.poses[probe] - truth, axis=-1) <= test_res.uncertainty[probe]
print(f"defaults: {error(test_res.poses):.1f} %   adapt=False: {error(cold.poses):.1f} %   "
      f"IterativeImputer: {error(imputed.reshape(kps.poses.shape)):.1f} %")
print(f"truth inside the 90 % circle: {inside[mask].mean():.0%} of {mask.sum()} joints")

# %%
# Twenty people make a rough check, not a benchmark: the figures over
# hundreds of annotated people are on the :doc:`/results/index` page.

# %%
# See what was filled
# -------------------
# ``sparseedm plot`` (the ``plot`` extra) draws the people as read beside the
# file ``recover`` wrote: visible joints black, filled joints orange crosses.
sh("sparseedm plot coco_photos.json filled.json -o check.png --rows 1,5:8 -q", work)

import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(figsize=(9, 5))
ax.imshow(plt.imread(work / "check.png"))
ax.axis("off")
plt.show()

# %%
# To 3D
# -----
# ``sparseedm lift`` turns the filled people into 3D joints in metres (camera
# axes, pelvis at the origin; one photo gives depth only up to scale, so the
# size is that of the people the lifter learned from). ``--plot`` draws a few
# of them from the front and the side. Given the filled file, it lifts the
# filled joints as if seen; given ``coco_photos.json`` itself, its lifter
# codes the visible joints alone and marks the hidden ones (orange crosses).
sh("sparseedm lift filled.json -o people3d.csv --plot people3d.png --frames 1,5:8", work,
   expect=1)

fig, ax = plt.subplots(figsize=(9, 5))
ax.imshow(plt.imread(work / "people3d.png"))
ax.axis("off")
plt.show()

# %%
# ``people3d.csv`` holds ``<joint>_x``, ``_y``, ``_z`` per person and each
# joint's 3D 90 % radius; ``.npz``, ``.json`` and OpenSim's ``.trc`` are the
# other outputs (:doc:`/howto/formats`). From Python:
# ``sparseedm.lift(res.poses[res.ok])``.
