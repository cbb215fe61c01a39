"""Learn a candidate prior from CMU mocap seen through wider virtual cameras.

The training sets of ``sparseedm dataset build`` (CMU ASF/AMC and the Daz BVH
folders, built as in dictionaries/README.md) are re-projected through new
seeded cameras (their 3D poses kept), and a dictionary is learned with the
shipped default's settings (k = 2000, training alpha 0.8, batch 512, one
pass, seed 0).

    python studies/real_prior/fit_prior.py /tmp/cmu/*.npz -o wide.npz \
        --height 0.2 3.5 --distance 2.5 6
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from sparseedm.cameras import project, sample_cameras
from sparseedm.dictionary import Dictionary, load_dictionary
from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors


def reproject(paths, height, distance, views=1, seed=0):
    """2D poses of every 3D pose of `paths` through `views` new cameras each."""
    rng = np.random.default_rng(seed)
    out = []
    for path in paths:
        with np.load(path, allow_pickle=False) as z:
            p3 = z["poses3d"]
        for _ in range(views):
            cams = sample_cameras(targets=p3.mean(axis=1), height=tuple(height),
                                  distance=tuple(distance), random_state=rng)
            out.append(project(p3, cams))
    return np.concatenate(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="+", type=Path)
    ap.add_argument("-o", "--out", type=Path, required=True)
    ap.add_argument("--height", type=float, nargs=2, default=(0.2, 3.5))
    ap.add_argument("--distance", type=float, nargs=2, default=(2.5, 6.0))
    ap.add_argument("--views", type=int, default=1)
    ap.add_argument("--keep-original", action="store_true",
                    help="add the datasets' own 2D views too")
    a = ap.parse_args(argv)
    poses = reproject(a.data, a.height, a.distance, a.views)
    if a.keep_original:
        orig = [np.load(p, allow_pickle=False)["poses2d"] for p in a.data]
        poses = np.concatenate([poses] + orig)
    X, _ = complete_pose_vectors(poses)
    t0 = time.perf_counter()
    odl = OnlineDictionaryLearning(2000, alpha=0.8, batch_size=512, n_passes=1,
                                   random_state=0).fit(X)
    base = load_dictionary()
    d = Dictionary(odl.components_, alpha_recover=base.alpha_recover, alpha_train=0.8,
                   provenance={"files": [p.name for p in a.data], "n_poses": int(len(X)),
                               "cameras": {"height": list(a.height),
                                           "distance": list(a.distance),
                                           "views": a.views,
                                           "original_views": a.keep_original},
                               "n_passes": 1, "batch_size": 512, "random_state": 0})
    d.save(a.out)
    print(f"wrote {a.out}: {len(X)} poses, {time.perf_counter() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
