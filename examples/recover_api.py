"""Recover the occluded joints of examples/occluded_poses.csv with the Python API.

    python examples/recover_api.py [DICTIONARY]    # default: the shipped dictionary
"""

import sys
from pathlib import Path

import numpy as np

import sparseedm
from sparseedm.keypoints import read_keypoints, write_keypoints

here = Path(__file__).resolve().parent
kps = read_keypoints(here / "occluded_poses.csv")        # NaN marks the occluded joints
dictionary = sparseedm.load_dictionary(sys.argv[1] if len(sys.argv) > 1 else None)

res = sparseedm.recover(kps.poses, kps.missing, dictionary=dictionary)
print(res.summary())                                     # counts per status, poses/s
for pid, pose, miss, st in list(zip(kps.ids, res.poses, res.missing, res.status))[:3]:
    names = [dictionary.joint_names[j] for j in np.flatnonzero(miss)]
    print(pid, st, {n: pose[j].round(1).tolist() for n, j in zip(names, np.flatnonzero(miss))})

write_keypoints("recovered_api.csv", res.poses, ids=kps.ids,
                extra_columns={"status": res.status})    # `sparseedm recover` also writes flags, radii
