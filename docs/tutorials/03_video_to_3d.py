"""
One person's video to 3D: an OpenSim TRC file
=============================================

``sparseedm lift`` turns 2D keypoints into 3D joint positions (metres, camera
axes): each pose's distance matrix is mapped to a 3D distance matrix by a
dictionary learned from motion capture, and the 3D joints are placed from it.
For a video it works on a person's frames together: the missing 2D joints are
filled across time first, the depth reflection (a single image cannot tell a
pose from its mirror in depth) is chosen along the track, and the 3D
trajectories are smoothed.

A ``.trc`` output is what OpenSim and most biomechanics tools read: one
person's markers, one row per frame.
"""

# %%
# One track of the example video
# ------------------------------
# ``examples/video_clip.csv`` holds two people (``track`` 02_01 and 02_05).
# A TRC file holds one person, so we keep the first.


# %%
# The script works in a temporary folder, ``work``, holding copies of
# ``video_clip.csv``; ``sh(...)`` runs a command there and prints what it
# prints, as a terminal would (both come from ``docs/tutorials/_workdir.py``;
# run the script from anywhere inside a clone).

# sphinx_gallery_start_ignore
from _workdir import repository, sh, work_folder  # noqa: F401

work = work_folder("examples/video_clip.csv")
# sphinx_gallery_end_ignore


# %%
# Asking for a TRC of the two-person file is refused before any work, and the
# message names the tracks and says what to do instead:
sh("sparseedm lift video_clip.csv -o both.trc", work, expect=2)

# %%
# A track that is not in the file is refused the same way:
sh("sparseedm lift video_clip.csv -o walk.trc --track 02_09", work, expect=2)

# %%
# Lift one person
# ---------------
# ``--track`` picks the first person's rows; ``--rate`` is the video's frame
# rate (the TRC's time column); ``--plot`` also draws a few lifted poses,
# those of the frames ``--frames`` chooses (at most 8; the first 4 without it).
sh("sparseedm lift video_clip.csv -o walk.trc --track 02_01 --rate 30 --plot walk3d.png "
   "--frames 0,28,56,84", work)

# %%
# The TRC file: a header, then a frame number, a time and x, y, z per joint.
print("\n".join(line[:120] for line in (work / "walk.trc").read_text().splitlines()[:8]))

# %%
# The same in Python
# ------------------
# :func:`sparseedm.lift` takes the poses with their frames; ``poses3d`` is in
# metres, pelvis at the origin, camera axes (x right, y down, z away from the
# camera). The depth of one image is only known up to scale, so metric poses
# use the size of the people the lifter learned from.
import numpy as np  # noqa: E402

import sparseedm  # noqa: E402
from sparseedm.keypoints import read_keypoints  # noqa: E402

kps = read_keypoints(work / "video_clip.csv")
walk = kps.tracks == "02_01"
res = sparseedm.lift(kps.poses[walk], frames=kps.frames[walk])
print(res.poses3d.shape, np.unique(res.status, return_counts=True))
height = np.linalg.norm(res.poses3d[:, 0] - res.poses3d[:, [10, 13]].mean(axis=1), axis=-1)
print(f"head top to ankles: {np.median(height):.2f} m (median over the frames)")

# %%
# The picture ``--plot`` drew: the chosen frames from the front (top) and from
# the side (bottom), left and right coloured; orange crosses mark the joints
# that were occluded in the 2D input, placed in 3D after being filled across
# time. From Python, :func:`sparseedm.lifting.plotting.plot_lifted` draws it
# from ``res.poses3d`` (both need the ``plot`` extra).
import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(figsize=(9, 5))
ax.imshow(plt.imread(work / "walk3d.png"))
ax.axis("off")
plt.show()
