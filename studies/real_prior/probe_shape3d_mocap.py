"""Mocap control of ``probe_shape3d.py``: the 3D shape model learned from CMU
subjects 01-03 only, recover() with ``cmu-k2000`` (learned from the same three
subjects), on files of other CMU subjects viewed by ``sparseedm dataset build``'s
virtual cameras: C complete + M occluded poses (Mix masks of 1-3 joints, as
``mocap_check.py``). Same readings as ``probe_shape3d.py``.

    S=../shared/data/cmu-mocap/subjects
    sparseedm dataset build $S/07 $S/08 $S/35 -o cmu_07_08_35.npz --seed 0 --frame-step 20
    sparseedm dataset build $S/16 $S/49 $S/55 -o cmu_16_49_55.npz --seed 0 --frame-step 6
    python studies/real_prior/probe_shape3d_mocap.py cmu_07_08_35.npz cmu_16_49_55.npz \\
        --seeds 0,1,2 --out results_shape3d_mocap.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from sparseedm._atomic import json_text  # noqa: E402
import sparseedm  # noqa: E402
from probe_shape3d import add_model_args, scored_row  # noqa: E402
from sparseedm.metrics import occlusion_masks  # noqa: E402
from shape3d_model import build_model, calibrate, cmu_poses, shape_fill  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="+", type=Path)
    ap.add_argument("--complete", type=int, default=100)
    ap.add_argument("--occluded", type=int, default=300)
    add_model_args(ap)
    a = ap.parse_args(argv)
    model = build_model(cmu_poses(subjects=("01", "02", "03"), step=8), a.k)
    kw = dict(noise=a.noise, temperature=a.temperature)
    out = {}
    for path in a.data:
        with np.load(path, allow_pickle=False) as z:
            poses = z["poses2d"]
        for seed in map(int, a.seeds.split(",")):
            rng = np.random.default_rng(seed)
            truth = poses[rng.choice(len(poses), a.complete + a.occluded, replace=False)]
            missing = np.zeros((len(truth), 14), bool)
            missing[a.complete:] = occlusion_masks(a.occluded, 14, ("mix",), seed)["mix"]
            given = np.where(missing[..., None], np.nan, truth)
            got = {name: sparseedm.recover(given, missing, dictionary="cmu-k2000", **kw2).poses
                   for name, kw2 in (("cold", dict(adapt=False)), ("defaults", {}))}
            fills = {"raw": shape_fill(model, given, missing, **kw),
                     "calibrated": shape_fill(calibrate(model, truth[: a.complete],
                                                        noise=a.noise), given, missing, **kw)}
            row = scored_row(got, fills, truth, missing, seed)
            out.setdefault(path.name, {})[str(seed)] = row
            print(path.name, seed, json.dumps(row), flush=True)
    if a.out:
        a.out.write_text(json_text({"settings": vars(a) | {"data": [p.name for p in a.data],
                                                           "out": None}, "files": out},
                                   indent=1) + "\n")


if __name__ == "__main__":
    main()
