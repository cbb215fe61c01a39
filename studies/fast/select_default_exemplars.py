"""Should the default path take the file's complete poses as its only atoms?

On files with many complete poses, ``recover(preset="fast")`` codes the
occluded poses over those poses alone (:func:`sparseedm.file_atoms.resolve_fast`,
at most ``MAX_FAST_ATOMS`` sampled atoms, ``FAST_ALPHA``), nothing learned;
``recover()``'s defaults adapt the shipped dictionary on them and self-train
(one member, ``ensemble=1``). Both are run here on the same validation files,
each call timed (``n_jobs=2``):

* ``cmu``: CMU clips held out by ``benchmarks.split_clips``, files of n poses
  with half of them under Mix masks (``select_fast.validation_file(n, seed)``);
  several sizes and seeds (the held-out clips hold 7,282 poses: a larger n
  takes them all).
* ``--mocap``: dataset .npz files (``sparseedm dataset build ...``, e.g. the
  Daz-retargeted CMU clips ``cmu-bvh-daz/indian``), C complete + M Mix poses
  drawn as ``studies/real_prior/mocap_check.py`` draws them.
* photos: the ``mpii-large`` and ``bonn`` files of ``studies/real_prior/harness.py``
  (validation splits), under its hidden-joint protocols.

Per occluded pose: the mean error of its hidden joints (% of body size) and
the Err_ave (%) of its returned pose's EDM; the paired difference, fast minus
defaults, with its standard error over the occluded poses. Results are
written after every file.

    sparseedm dataset build ../shared/data/cmu-bvh-daz/indian -o daz_indian.npz
    python studies/fast/select_default_exemplars.py --mocap daz_indian.npz
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_default_exemplars.py` finds benchmarks/
from sparseedm._atomic import json_text  # noqa: E402

METHODS = {"fast": {"preset": "fast"}, "defaults": {"ensemble": 1}}


def per_pose(filled, truth, missing):
    """(% body size of the hidden joints, Err_ave %) of each occluded pose."""
    from sparseedm.edm import pose_to_vector
    from sparseedm.metrics import err_ave
    from sparseedm.real_protocol import body_size

    occ = missing.any(axis=1)
    err = np.linalg.norm(filled - truth, axis=-1) / body_size(truth)[:, None] * 100
    joints = np.nanmean(np.where(missing, err, np.nan)[occ], axis=1)
    edm = err_ave(pose_to_vector(filled[occ]), pose_to_vector(truth[occ]))
    return joints, np.asarray(edm, float)


def paired(a, b):
    """Mean and standard error of a - b."""
    d = np.asarray(a) - np.asarray(b)
    return round(float(d.mean()), 4), round(float(d.std(ddof=1) / np.sqrt(len(d))), 4)


def compare(truth, missing):
    """Both methods on one file: errors, seconds, paired differences."""
    import sparseedm

    given = np.where(missing[..., None], np.nan, truth)
    row, scores = {"poses": len(truth), "complete": int((~missing.any(axis=1)).sum())}, {}
    for name, kw in METHODS.items():
        t0 = time.perf_counter()
        res = sparseedm.recover(given, missing, n_jobs=2, **kw)
        seconds = time.perf_counter() - t0
        scores[name] = per_pose(res.poses, truth, missing)
        ad = res.adaptation
        row[name] = {"pct_body": round(float(scores[name][0].mean()), 3),
                     "err_ave": round(float(np.nanmean(scores[name][1])), 3),
                     "seconds": round(seconds, 1), "adapted": bool(res.adapted),
                     "file_atoms": int(ad.file_atoms) if ad is not None else 0}
    row["fast_minus_defaults"] = {
        "pct_body": paired(scores["fast"][0], scores["defaults"][0]),
        "err_ave": paired(scores["fast"][1], scores["defaults"][1])}
    return row


def mocap_file(path, complete, occluded, seed):
    """C complete + M Mix poses of a dataset .npz, drawn as mocap_check.py draws them."""
    from sparseedm.metrics import occlusion_masks

    with np.load(path, allow_pickle=False) as z:
        poses = z["poses2d"]
    rng = np.random.default_rng(seed)
    truth = poses[rng.choice(len(poses), complete + occluded, replace=False)]
    missing = np.zeros((len(truth), 14), bool)
    missing[complete:] = occlusion_masks(occluded, 14, ("mix",), seed)["mix"]
    return truth, missing


def files(a):
    """(name, loader) of every file asked for, cheapest first."""
    from studies.fast.select_fast import validation_file
    from studies.real_prior import harness

    out = []
    for source in filter(None, a.photos.split(",")):
        for protocol in filter(None, a.protocols.split(",")):
            out.append((f"{source} protocol {protocol}",
                        lambda s=source, p=protocol: harness.make_file(s, p, 0)))
    for path in filter(None, a.mocap.split(",")):
        for size in filter(None, a.mocap_sizes.split(",")):
            c, m = (int(x) for x in size.split("+"))
            out.append((f"{Path(path).stem} {c}+{m}",
                        lambda p=path, c=c, m=m: mocap_file(p, c, m, 0)))
    for n in sorted(int(x) for x in a.cmu.split(",") if x):
        for seed in (int(s) for s in a.seeds.split(",")):
            out.append((f"cmu n={n} seed={seed}",
                        lambda n=n, seed=seed: validation_file(n, seed)))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cmu", default="2000,4000,6000,12000", help="CMU file sizes (poses)")
    ap.add_argument("--seeds", default="0,1,2", help="seeds of the CMU files")
    ap.add_argument("--mocap", default="", help="dataset .npz paths, comma-separated")
    ap.add_argument("--mocap-sizes", default="1000+1000,2500+2500",
                    help="C+M (complete + Mix poses) of the mocap files, comma-separated")
    ap.add_argument("--photos", default="mpii-large,bonn", help="harness.py files")
    ap.add_argument("--protocols", default="2,real", help="harness.py protocols")
    ap.add_argument("--out", type=Path,
                    default=Path(__file__).with_name("selection_default_exemplars.json"))
    a = ap.parse_args(argv)
    import sparseedm

    warnings.simplefilter("ignore")
    probe = np.random.default_rng(0).normal(size=(300, 14, 2))
    sparseedm.recover(probe, np.eye(14, dtype=bool)[np.arange(300) % 14], adapt=False)
    doc = {"methods": {k: f"recover(..., {v}, n_jobs=2)" for k, v in METHODS.items()},
           "score": "per occluded pose: % body size of its hidden joints, Err_ave % of "
                    "its EDM; fast_minus_defaults: [mean, standard error]", "files": {}}
    for name, load in files(a):
        truth, missing = load()
        doc["files"][name] = compare(np.asarray(truth, float), missing)
        print(name, json.dumps(doc["files"][name]), flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
