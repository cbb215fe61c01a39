"""
DeepLabCut: fill in the body parts your network missed
======================================================

DeepLabCut writes one row per video frame with ``x``, ``y`` and a
``likelihood`` per body part. Where a body part is hidden, the likelihood drops;
DeepLabCut's own ``pcutoff`` (0.6 by default) is the line below which it stops
trusting a detection. sparseedm reads the same table, treats every body part
below that line as missing, fills it in from the body parts it can see, and
writes the table back in DeepLabCut's layout.

This tutorial uses a small DeepLabCut table the repository ships,
``tests/fixtures/formats/dlc.csv`` (four frames of a walking person, the left
knee at likelihood 0.1-0.3 in two of them).
"""

# %%
# Where the files are
# -------------------
# The script works in a temporary folder, ``work``, holding copies of
# ``dlc.csv`` and ``dlc_joints.json``; ``sh(...)`` runs a command there and
# prints what it prints, as a terminal would (both come from
# ``docs/tutorials/_workdir.py``; run the script from anywhere inside a
# clone).


# sphinx_gallery_start_ignore
from _workdir import repository, sh, work_folder  # noqa: F401

work = work_folder("tests/fixtures/formats/dlc.csv", "tests/fixtures/formats/dlc_joints.json")
# sphinx_gallery_end_ignore


# %%
# The table
# ---------
# Three header rows (scorer, bodyparts, coords), then a row per frame:
print("\n".join(line[:110] for line in (work / "dlc.csv").read_text().splitlines()[:5]))

# %%
# Your body part names are your project's own
# -------------------------------------------
# sparseedm works on 14 joints (head top, neck, shoulders, elbows, wrists, hips,
# knees, ankles), so it needs to know which of your body parts is which. A joint
# map says so, once per project. Without one the file is refused, and the
# message says what to do:
sh("sparseedm recover dlc.csv -o filled.csv", work, expect=2)

# %%
# The map of this project: ``{"joints": {"<sparseedm joint>": "<your body part>"}}``
# (a neck your project does not label can be ``null``: it is then the midpoint
# of the shoulders).
print((work / "dlc_joints.json").read_text())

# %%
# Fill in the low-likelihood body parts
# -------------------------------------
sh("sparseedm recover dlc.csv -o filled.csv --joint-map dlc_joints.json", work)

# %%
# The output is a DeepLabCut table again (``create_labeled_video`` and the
# other DeepLabCut tools read it). A filled body part's likelihood says how
# sure the fill is, ``0.5 * exp(-radius / size)``: at most 0.5, below the 0.6
# ``pcutoff``, so it never reads as a detection at DeepLabCut's default (with
# a lower ``pcutoff``, tell filled parts by the flags instead). A
# ``.status.npz`` file beside it says which joints were filled and each row's
# status.
import numpy as np  # noqa: E402

print("\n".join(line[:110] for line in (work / "filled.csv").read_text().splitlines()[:5]))
with np.load(work / "filled.status.npz") as status:
    print(sorted(status.files))
    print("filled joints per frame:", status["filled"].sum(axis=1))

# %%
# See what was filled
# -------------------
# ``sparseedm plot`` draws the input beside the file recover wrote from it
# (``--joint-map`` as for recover, so that it reads the body parts the same
# way):
sh("sparseedm plot dlc.csv filled.csv -o check.png --joint-map dlc_joints.json", work)

# %%
# The top row is the filled joint over time, x and y against the frame: black
# dots where DeepLabCut's detection was kept, the blue line through the
# recovered positions, orange crosses on a shaded band where the body part was
# filled. Below, the poses as skeletons, the filled joint an orange cross: a
# filled knee should sit where the thigh and shin make a plausible leg.
# ``--frames``, ``--joints`` and ``--tracks`` choose what is drawn.
import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(figsize=(9, 6.5))
ax.imshow(plt.imread(work / "check.png"))
ax.axis("off")
plt.show()

# %%
# The same from Python
# --------------------
# :func:`~sparseedm.keypoints.read_keypoints` gives the poses in the 14-joint
# layout, with NaN where a body part was missing;
# :func:`sparseedm.recover` fills them.
import sparseedm  # noqa: E402
from sparseedm.keypoints import read_keypoints  # noqa: E402

kps = read_keypoints(work / "dlc.csv", joint_map=work / "dlc_joints.json")
print("poses:", kps.poses.shape, " missing joints per frame:", kps.missing.sum(axis=1))
res = sparseedm.recover(kps.poses, kps.missing)
print(res.status)
knee = 12  # sparseedm.skeleton.SKELETON_14's left knee
print("left knee, filled:", np.round(res.poses[kps.missing[:, knee], knee], 1))

# %%
# A stricter or looser line
# -------------------------
# ``--confidence-threshold`` (``confidence_threshold=`` in Python) overrides
# DeepLabCut's 0.6; the command prints how many scored body parts fell below it.
sh("sparseedm recover dlc.csv -o strict.csv --joint-map dlc_joints.json "
   "--confidence-threshold 0.95", work, expect=1)

# %%
# At 0.95 most body parts of this table fall below the line: every row keeps
# too few joints to be filled, is refused (exit code 1), and is listed with its
# reason in ``strict.errors.csv``:
print((work / "strict.errors.csv").read_text())

# %%
# ``.h5`` files work the same way once the ``dlc`` extra is installed
# (``pip install "sparseedm[dlc]"``: pandas and PyTables). Read ``.h5`` files
# only from sources you trust: pandas unpickles the metadata it stores in them.
# Multi-animal tables (a fourth header row, ``individuals``) give one track per
# animal; see :doc:`/howto/tracks`.
