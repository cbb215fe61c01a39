"""Recovery's normalisation rule and alpha, chosen on validation photos and mocap.

For each rule ("box": the observed joints' bounding box; "radius": their
centroid and RMS radius, the same for the pose rotated in the image plane) and
each recovery alpha, a shipped dictionary recovers the harness's validation
photo files (1 / 2 / 3 random hidden joints and transplanted real masks) and
mocap files of 100 complete + 500 poses under Mix masks (1-3 hidden joints);
the score is the mean error of the hidden joints in % of body size
(``harness.score``). ``--mode cold`` is ``recover(adapt=False)``, ``defaults``
is ``recover()`` (file atoms, or adaptation on files of 250 complete poses).

    python studies/real_prior/select_scale.py --rules box,radius --alphas 0.0005,0.001 \\
        --mode cold --sources mpii,coco-val,bonn --mocap bandai.npz,daz_indian.npz,cmu.npz \\
        --out studies/real_prior/selection_scale.json

The mocap files are ``sparseedm dataset build DIR --seed 0`` of
``../shared/data/bandai-namco-1`` (held out from every shipped dictionary),
``cmu-bvh-daz/indian`` and ``cmu-mocap`` + ``cmu-bvh-daz`` (the default's own
training poses).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from sparseedm._atomic import json_text  # noqa: E402

from benchmarks import real2d  # noqa: E402
from studies.real_prior import harness  # noqa: E402


def mocap_file(path, complete=100, occluded=500, seed=0):
    """``(truth, missing)``: `complete` + `occluded` poses of a dataset file, Mix masks."""
    from sparseedm.metrics import occlusion_masks

    with np.load(path, allow_pickle=False) as z:
        poses = z["poses2d"]
    rng = np.random.default_rng(seed)
    truth = poses[rng.choice(len(poses), complete + occluded, replace=False)]
    missing = np.zeros((len(truth), truth.shape[1]), bool)
    missing[complete:] = occlusion_masks(occluded, truth.shape[1], ("mix",), seed)["mix"]
    return truth, missing


def files(sources, mocap):
    """``{name: [(truth, missing), ...]}``: the photo files per protocol, one per mocap file."""
    out = {}
    for src in sources:
        rs = real2d.load(harness.FILES[src][0])
        out[src] = [harness.make_file(src, p, 0, None, rs) for p in harness.PROTOCOLS]
    for path in mocap:
        out[Path(path).stem] = [mocap_file(path)]
    return out


def scan(dictionary, rules, alphas, mode, data):
    """``{"rule alpha": {file: [% body size per protocol]}}`` and seconds per setting."""
    import sparseedm

    table, seconds = {}, {}
    kwargs = dict(adapt=False) if mode == "cold" else {}
    for rule in rules:
        for alpha in alphas:
            d = replace(dictionary, recovery_scale=rule, alpha_recover=alpha)
            key, t0 = f"{rule} {alpha:g}", time.perf_counter()
            for name, cases in data.items():
                table.setdefault(key, {})[name] = [
                    round(harness.score(sparseedm.recover(
                        np.where(m[..., None], np.nan, t), m, dictionary=d, **kwargs).poses,
                        t, m), 3) for t, m in cases]
            seconds[key] = round(time.perf_counter() - t0, 1)
            print(key, mode, table[key], seconds[key], flush=True)
    return table, seconds


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dictionary", default="default")
    ap.add_argument("--rules", default="box,radius")
    ap.add_argument("--alphas", default="0.0005,0.001")
    ap.add_argument("--mode", choices=("cold", "defaults"), default="cold")
    ap.add_argument("--sources", default="mpii,coco-val,bonn")
    ap.add_argument("--mocap", default="", help="dataset .npz files, comma-separated")
    ap.add_argument("--out", type=Path, help="JSON to write (merged into an existing one)")
    a = ap.parse_args(argv)
    from sparseedm.dictionary import load_dictionary

    data = files([s for s in a.sources.split(",") if s], [m for m in a.mocap.split(",") if m])
    table, seconds = scan(load_dictionary(a.dictionary), a.rules.split(","),
                          [float(x) for x in a.alphas.split(",")], a.mode, data)
    if a.out:
        doc = json.loads(a.out.read_text()) if a.out.exists() else {}
        doc.setdefault(f"{a.dictionary} {a.mode}", {}).update(
            {k: {"errors": v, "seconds": seconds[k]} for k, v in table.items()})
        doc["protocols"] = list(harness.PROTOCOLS)
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
