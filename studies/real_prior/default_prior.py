"""The default path from two starting dictionaries, paired: `recover()` with its
defaults (adaptation and self-training on files of 250+ complete poses, file
atoms below) started from the shipped default and from another prior, with the
same seeds and files, IterativeImputer in the same run.

* ``photos``: the files of ``harness.py`` (validation splits), defaults and
  ``adapt=False`` per dictionary.
* ``mocap``: dataset .npz files (``sparseedm dataset build ...``), C complete +
  M poses under Mix masks (1-3 hidden joints), one file per size.
* ``video``: ``evaluate_tracks`` on Bonn's validation clips (each clip alone,
  ``recover()`` with tracks and frames, and per frame), per gap bin.

Paired differences: per occluded pose, the mean error of its hidden joints (%
of body size) with the other prior minus with the default; mean and standard
error over the poses (photos and mocap). ``error``: the mean of those per-pose
errors; ``error_joints``: the mean over every hidden joint (``harness.score``;
the same unless poses hide different numbers of joints). Seconds: each call's wall time.

    python studies/real_prior/default_prior.py --photos mpii,coco-val,bonn,mpii-large \
        --mocap cmu.npz,bandai.npz --video --out studies/real_prior/results_default_prior.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sparseedm._atomic import json_text  # noqa: E402
import harness  # noqa: E402

from benchmarks import real2d  # noqa: E402

BASE = "cmu-all-k2000"


def per_pose(filled, truth, missing):
    """Mean error of each occluded pose's hidden joints, % of body size."""
    err = np.linalg.norm(filled - truth, axis=-1) / real2d.body_size(truth)[:, None] * 100
    occ = missing.any(axis=1)
    return (err * missing).sum(axis=1)[occ] / missing.sum(axis=1)[occ]


def compare(truth, missing, other, modes=("defaults", "cold")):
    """One file: {method: error, seconds}, and paired differences other - base."""
    out, per = {}, {}
    t0 = time.perf_counter()
    filled = harness.iterative(truth, missing)
    out["iterative"] = {"seconds": round(time.perf_counter() - t0, 1),
                        "error_joints": round(harness.score(filled, truth, missing), 3)}
    per["iterative"] = per_pose(filled, truth, missing)
    for mode in modes:
        for dic in (BASE, other):
            kw = {} if mode == "defaults" else {"adapt": False}
            t0 = time.perf_counter()
            filled = harness.sparse(dictionary=dic, **kw)(truth, missing)
            name = f"{mode} {dic}"
            out[name] = {"seconds": round(time.perf_counter() - t0, 1),
                         "error_joints": round(harness.score(filled, truth, missing), 3)}
            per[name] = per_pose(filled, truth, missing)
    for name, e in per.items():
        out[name]["error"] = round(float(e.mean()), 3)
    for mode in modes:
        d = per[f"{mode} {other}"] - per[f"{mode} {BASE}"]
        out[f"{mode}: {other} - {BASE}"] = {
            "mean": round(float(d.mean()), 3),
            "se": round(float(d.std(ddof=1) / np.sqrt(len(d))), 3),
            "poses": int(len(d))}
    return out


def photos(files, other, seed, protocols=harness.PROTOCOLS):
    """harness.py's files and protocols."""
    res = {}
    for name in files:
        rs = real2d.load(harness.FILES[name][0])
        for protocol in protocols:
            truth, missing = harness.make_file(name, protocol, seed, None, rs)
            res[f"{name} {protocol}"] = compare(truth, missing, other)
            print(name, protocol, json.dumps(res[f"{name} {protocol}"]), flush=True)
    return res


def mocap(paths, sizes, other, seed):
    """C complete + M Mix-occluded poses of each dataset, per size."""
    from sparseedm.metrics import occlusion_masks

    res = {}
    for path in paths:
        with np.load(path, allow_pickle=False) as z:
            poses = z["poses2d"].astype(float)
        for C, M in sizes:
            rng = np.random.default_rng(seed)
            truth = poses[rng.choice(len(poses), C + M, replace=False)]
            missing = np.zeros((len(truth), 14), bool)
            missing[C:] = occlusion_masks(M, 14, ("mix",), seed)["mix"]
            key = f"{Path(path).stem} {C}+{M}"
            res[key] = compare(truth, missing, other, modes=("defaults",))
            print(key, json.dumps(res[key]), flush=True)
    return res


def video(other, seed, max_clips, methods=("sparseedm", "per-frame", "linear")):
    """evaluate_tracks on Bonn val per dictionary: per gap bin mean error and seconds."""
    from sparseedm.evaluation_real import evaluate_tracks

    rs = real2d.load("bonn")
    s = rs.take(real2d.split(rs) == "val")
    tracks = np.char.add(np.char.add(s.group.astype(str), "#"), s.tracks.astype(str))
    res = {}
    for dic in (BASE, other):
        rep = evaluate_tracks(s.poses, tracks, s.frames, occluded=~s.visible,
                              gap_lengths=(3, 10, 30), head_size=s.head_size,
                              max_clips=max_clips, methods=methods, dictionary=dic,
                              random_state=seed)
        res[dic] = {"rows": [{k: r[k] for k in ("method", "condition", "group", "n", "mean")}
                             for r in rep.rows],
                    "seconds": rep.seconds, "settings": rep.settings}
        print(dic, json.dumps(res[dic]["seconds"]), flush=True)
    return res


def warm(other):
    """The JIT caches out of the timings: cold, file atoms and adaptation, both priors."""
    import warnings

    from sparseedm.adaptation import run_adaptation
    from sparseedm.dictionary import load_dictionary

    truth, missing = harness.make_file("mpii", "1", 1, (200, 40))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for dic in (BASE, other):
            harness.sparse(dictionary=dic)(truth, missing)
            harness.sparse(dictionary=dic, adapt=False)(truth, missing)
        run_adaptation(load_dictionary(), truth[:200], min_poses=1, passes=1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--other", default="cmu-coco-k2466")
    ap.add_argument("--photos", default="", help="harness files, comma-separated")
    ap.add_argument("--protocols", default=",".join(harness.PROTOCOLS))
    ap.add_argument("--mocap", default="", help="dataset .npz paths, comma-separated")
    ap.add_argument("--sizes", default="100+500,1000+1000", help="mocap C+M, comma-separated")
    ap.add_argument("--video", action="store_true", help="Bonn val clips")
    ap.add_argument("--max-clips", type=int, default=40)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    warm(a.other)
    doc = {"base": BASE, "other": a.other, "seed": a.seed}
    if a.photos:
        doc["photos"] = photos(a.photos.split(","), a.other, a.seed,
                              a.protocols.split(","))
    if a.mocap:
        sizes = [tuple(int(x) for x in s.split("+")) for s in a.sizes.split(",")]
        doc["mocap"] = mocap(a.mocap.split(","), sizes, a.other, a.seed)
    if a.video:
        doc["video"] = video(a.other, a.seed, a.max_clips)
    if a.out:
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
