"""
OpenPose and MMPose: a two-person video
=======================================

A pose detector run on a video writes, for every frame, the people it found
and a score per keypoint. A joint hidden behind the other person or behind the
body gets a low score. sparseedm fills those joints in across time: a
person's frames around a gap are the best evidence of where the joint is.

When the detector ran without a tracker, nothing says which pose in frame 12
is the same person as which pose in frame 11. sparseedm links the poses into
tracks first (by the distance of their common joints, frame to frame), then
fills each track, and writes the track ids back into the file.

This tutorial makes a two-person video from ``examples/video_clip.csv`` (two
CMU clips through a virtual camera; 279 joint-frames hidden as a body hides its
own joints, with the truth in ``examples/video_clip_truth.npz``), writes it as
an OpenPose folder and as an MMPose predictions file **without track ids**, and
recovers both.
"""

# %%
# Two people in the same frames
# -----------------------------

import numpy as np

from sparseedm.keypoints import read_keypoints, write_keypoints


# %%
# The script works in a temporary folder, ``work``, holding copies of
# ``video_clip.csv``; ``sh(...)`` runs a command there and prints what it
# prints, as a terminal would (both come from ``docs/tutorials/_workdir.py``;
# run the script from anywhere inside a clone).

# sphinx_gallery_start_ignore
from _workdir import repository, sh, work_folder  # noqa: F401

repo = repository()
work = work_folder("examples/video_clip.csv")
# sphinx_gallery_end_ignore


clip = read_keypoints(work / "video_clip.csv")
print("tracks:", np.unique(clip.tracks), " frames:", clip.frames.min(), "-", clip.frames.max())
# the second person stands 250 px to the right of the first
poses = clip.poses.copy()
poses[clip.tracks == "02_05", :, 0] += 250

# %%
# The detector's files: an OpenPose ``--write_json`` folder (one file per
# frame) and an MMPose predictions file, both without track ids. The hidden
# joints are written with score 0, as detectors write an undetected keypoint.
write_keypoints(work / "openpose_json", poses, clip.missing, format="openpose",
                frames=clip.frames)
write_keypoints(work / "predictions.json", poses, clip.missing, format="mmpose",
                frames=clip.frames)
files = sorted(p.name for p in (work / "openpose_json").glob("*.json"))
print(len(files), "frame files:", files[:2], "...")
print((work / "openpose_json" / files[0]).read_text()[:300], "...")

# %%
# Recover the OpenPose folder
# ---------------------------
# A folder in, a folder out: every frame file comes back with the hidden joints
# filled (score 0, so that nothing reads them as detections) and a
# ``person_id`` per person.
sh("sparseedm recover openpose_json/ -o filled_json/", work)

# %%
# Recover the MMPose file
# -----------------------
# The same for MMPose; the linked tracks are written as ``track_id``.
sh("sparseedm recover predictions.json -o filled.json", work)

# %%
# How close the filled joints are
# -------------------------------
# The truth of every joint is in ``examples/video_clip_truth.npz``; errors
# are in pixels (the people are about 180 px tall here). Each filled joint
# also comes with its 90 % radius: a circle around it that holds the true
# joint 9 times in 10 (:doc:`/explanation/uncertainty`).
filled = read_keypoints(work / "filled.json")
with np.load(repo / "examples" / "video_clip_truth.npz") as truth:
    true_poses = truth["poses2d"].copy()
true_poses[clip.tracks == "02_05", :, 0] += 250
# the files hold the people frame by frame: put the truth in that order
order = np.argsort(clip.frames, kind="stable")
true_poses, hidden = true_poses[order], clip.missing[order]
# joints missing as the file was read (a hidden neck is the shoulders' midpoint in
# COCO-17, MMPose's layout, so it is not missing there)
given = read_keypoints(work / "predictions.json")
hidden &= given.missing
# the rows come back in the input's order
error = np.linalg.norm(filled.poses[hidden] - true_poses[hidden], axis=-1)
print(f"{hidden.sum()} hidden joints filled: mean error {error.mean():.1f} px, "
      f"90th percentile {np.percentile(error, 90):.1f} px")
print("track ids written back:", np.unique(filled.tracks))
# how sure each filled joint is: its 90 % radius in pixels, stored in each
# person's "sparseedm" object and read back as ``uncertainty``
radius = filled.uncertainty[hidden]
print(f"their 90 % radius: median {np.median(radius):.1f} px; the truth lies within it "
      f"for {np.mean(error <= radius):.0%} of them")

# %%
# From Python
# -----------
# :func:`sparseedm.recover` takes the frames (and the tracks, when you have
# them); ``res.linked_tracks`` holds the tracks it linked, ``res.source`` says
# where each joint came from.
import sparseedm  # noqa: E402

kps = read_keypoints(work / "predictions.json")
res = sparseedm.recover(kps.poses, kps.missing, frames=kps.frames)
print("linked tracks:", np.unique(res.linked_tracks))
sources, counts = np.unique(res.source[kps.missing], return_counts=True)
print("hidden joints filled from:", dict(zip(sources.tolist(), counts.tolist())))

# %%
# See what was filled
# -------------------
# :func:`sparseedm.plotting.plot_recovery` (``sparseedm plot`` on the command
# line; needs the ``plot`` extra) draws the poses as read beside their
# recovery. The file has no track ids, so give it the tracks the recovery
# linked; here the right wrist of track 0, frames 35 to 70:
import matplotlib.pyplot as plt  # noqa: E402

from sparseedm.plotting import plot_recovery  # noqa: E402

plot_recovery(kps.poses, res.poses, frames=kps.frames, tracks=res.linked_tracks,
              show_tracks=[0], show_frames="35:70", show_joints=["right_wrist"],
              path=work / "check.png")
fig, ax = plt.subplots(figsize=(9, 6.5))
ax.imshow(plt.imread(work / "check.png"))
ax.axis("off")
plt.show()

# %%
# The top row is the wrist's x and y against the frame: black dots where it was
# seen, the blue line through the recovered positions, orange crosses on a
# shaded band where it was filled. A filled stretch should continue the
# observed motion on both sides without a jump. Below, a few of the track's
# poses as skeletons, the filled joints orange crosses.

# %%
# A file that is not what its name says is refused before any work, with the
# reason; a bad frame file inside an OpenPose folder is skipped with a warning
# and the good frames are recovered. See :doc:`/howto/formats`.
