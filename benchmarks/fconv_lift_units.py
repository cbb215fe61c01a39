"""Which 3D units should the fconv lifter regress? Tied (the lifter base's) vs metres.

    python -m benchmarks.fconv_lift_units TRAIN.npz TIED_LIFTER.npz METRES_MODEL.npz

TIED_LIFTER from ``sparseedm fit-lifter TRAIN.npz --method fconv`` (3D EDMs in
the lifter's "tied" normalisation), METRES_MODEL from ``sparseedm fit-cnn
TRAIN.npz --task lift`` (3D EDMs in metres, ``sparseedm.fconv.fit_edm_lifter``),
same architecture and budget. Judged on the clips both held out for early
stopping (every 5th training clip from the 3rd, ``split_by_clip``): validation
data of the training set, never the test clips. Score: 3D-EDM Err_ave (one
least-squares scale per pose, so the units do not matter) on complete and
Mix-occluded input fed as the 'average' EDM.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from sparseedm.fconv import lift_edm_vectors as fconv_lift
from sparseedm.fconv import load_model
from sparseedm.fconv.training import split_by_clip
from sparseedm.lifting import load_lifter, training_pairs
from sparseedm.lifting.metrics import err_ave_3d
from sparseedm.metrics import random_occlusion
from sparseedm.normalize import represent


def main(argv=None):
    train, tied_path, metres_path = (argv or sys.argv[1:])[:3]
    with np.load(train, allow_pickle=False) as npz:
        d = {k: npz[k] for k in npz.files}
    val, note = split_by_clip(d["clips"], len(d["clips"]))
    ix = np.flatnonzero(val)
    _, _, metric, _ = training_pairs(d["poses2d"][ix], d["poses3d"][ix], d["camera_R"][ix],
                                     d["camera_t"][ix], d["camera_f"][ix])
    tied, metres = load_lifter(tied_path), load_model(metres_path, kind="lift")
    mask = random_occlusion(len(ix), 14, "mix", random_state=1)
    out = {"validation": note, "n_poses": int(len(ix))}
    for name, m in (("complete", np.zeros_like(mask)), ("mix", mask)):
        p2 = np.where(m[..., None], np.nan, d["poses2d"][ix])
        t = tied.predict(represent(p2, m, "average")[0])[0]
        e = fconv_lift(metres, p2)
        out[name] = {"tied": float(np.nanmean(err_ave_3d(t, metric))),
                     "metres": float(np.nanmean(err_ave_3d(e, metric)))}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
