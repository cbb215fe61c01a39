"""The 3D radius and the filled-joint weights on CMU video validation sequences.

    nice python studies/uncertainty/lift3d_video.py [N_SEQUENCES] [LIFTER] > studies/uncertainty/lift3d_video.json

The video protocols' CMU validation sequences (``benchmarks/video_protocols.py``,
one fixed camera per clip; the first N, default 10) with their self-occlusion
and gap masks, lifted across time (``lift(poses, missing, frames=...)``, the
2D dictionary of the video protocols) by a lifter (default the shipped one,
which saw every CMU subject: these poses are not new to it). Per condition,
over the frames with a hidden joint: MPJPE and N-MPJPE (mm) with the
filled-joint weights (:func:`sparseedm.lifting.uncertainty3d.filled_weights`)
and without them, and with them the share of joints inside their 3D radius
(``uncertainty3d``): filled joints, joints seen in 2D, joints still missing,
and the mean radius of the filled joints (metres).
"""

import argparse
import json
import sys
from pathlib import Path
from unittest import mock

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks import video_protocols as vp  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.lifting import lift, load_lifter  # noqa: E402
from sparseedm.lifting import uncertainty3d as u3  # noqa: E402
from sparseedm.lifting.metrics import mpjpe, pelvis  # noqa: E402
from sparseedm.temporal.evaluation import protocol_masks  # noqa: E402


def conditions(seq):
    yield "self-occlusion", protocol_masks(seq, "self-occlusion")["self-occlusion"]
    for m in protocol_masks(seq, "gaps").values():
        yield "gaps", m


def one(acc, key, res, cam, rows, with_radius):
    P = res.poses3d
    ok = rows & np.isfinite(P).all(axis=(1, 2))
    if not ok.any():
        return
    a = acc.setdefault(key, {k: [] for k in ("mpjpe", "n_mpjpe", "covered_filled",
                                             "covered_seen", "covered_missing",
                                             "radius_filled_m")})
    a["mpjpe"].append(mpjpe(P[ok], cam[ok]))
    a["n_mpjpe"].append(mpjpe(P[ok], cam[ok], align="scale"))
    if with_radius:
        t = cam - pelvis(cam)[:, None]
        inside = np.linalg.norm((P - pelvis(P)[:, None]) - t, axis=-1) <= res.uncertainty3d
        f = res.filled & ok[:, None]
        a["covered_filled"].append(inside[f])
        a["covered_seen"].append(inside[~res.missing & ok[:, None]])
        a["covered_missing"].append(inside[res.missing & ~res.filled & ok[:, None]])
        a["radius_filled_m"].append(res.uncertainty3d[f])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("sequences", nargs="?", type=int, default=10,
                    help="the first N CMU validation sequences")
    ap.add_argument("lifter", nargs="?", help="a lifter file (default: the shipped one)")
    args = ap.parse_args(argv)
    n_seq = args.sequences
    lifter = load_lifter(args.lifter)
    dictionary = load_dictionary(vp.DICTIONARY["cmu"])
    acc = {}
    for seq in vp.sequences("cmu", "validation", n_seq, 0):
        cam = np.einsum("ij,nkj->nki", seq.camera.R[0], seq.poses3d) + seq.camera.t[0]
        for cond, missing in conditions(seq):
            given = np.where(missing[..., None], np.nan, seq.poses2d)
            kw = dict(frames=seq.frames, lifter=lifter, dictionary=dictionary)
            one(acc, (cond, "weighted"), lift(given, missing, uncertainty3d=True, **kw), cam,
                missing.any(axis=1), True)
            with mock.patch.object(u3, "FILLED_WEIGHT_SCALE", np.inf):  # w = 1: no weight
                one(acc, (cond, "unweighted"), lift(given, missing, **kw), cam,
                    missing.any(axis=1), False)
    out = {"sequences": n_seq, "lifter": args.lifter or "shipped"}
    for (cond, name), a in acc.items():
        out[f"{cond}, {name}"] = {
            k: round(float(np.concatenate(v).mean()), 3) for k, v in a.items()
            if v and len(np.concatenate(v))}
        out[f"{cond}, {name}"]["frames"] = int(sum(len(x) for x in a["mpjpe"]))
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
