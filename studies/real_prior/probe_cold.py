"""The cold prior (``recover(adapt=False)``) against IterativeImputer over several seeds.

A candidate is a prior, optionally ``NAME@ALPHA`` (another recovery alpha),
``NAME~none`` (alpha not scaled by the entries left) and ``NAME+mirror``
(``recover(..., mirror=True)``: each pose's answer averaged with its mirror
image's). Priors: the shipped ones by name and variants of
``cmu-coco-k2932``'s COCO exemplars (``head 1.1``: the raised-neck copies
with the head top 1.1 times as far from the shoulders' midpoint; ``hips``:
those copies' hips also moved toward their midpoint).

``harness.py``'s files (validation splits), drawn with seeds 0..S-1 (each seed
its own poses and masks), 1 / 2 / 3 hidden joints and real masks. For every
candidate prior: the mean error of the hidden joints (% of body size) pooled
over the seeds, its ratio to IterativeImputer's (fitted on each file, the
same files), and per occluded pose the paired difference to the reference
(``cmu-coco-k2932``), mean ± standard error. Mocap: ``sparseedm dataset
build`` files, 100 complete + 500 Mix poses, cold.

    python studies/real_prior/probe_cold.py --seeds 3 --photos mpii,coco-val,bonn \\
        --candidates cmu-coco-k2932,cmu-coco-k2932+mirror,default,default+mirror \\
        --mocap cmu.npz,daz_indian.npz --out studies/real_prior/results_cold.json

``--benchmark``: instead, the files of ``python -m benchmarks.real_people
--split val`` (``evaluate_photos`` on each source's validation split, seed
0, Mix and transplanted masks): IterativeImputer, ``adapt=False`` with the
default and with ``cmu-coco-k2932``, without and with ``mirror=True``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import coco_prior  # noqa: E402
import harness  # noqa: E402
from default_prior import per_pose  # noqa: E402
from probe_coco_atoms import exemplars, head_further, mirrored, mocap_file  # noqa: E402

from benchmarks import real2d  # noqa: E402
from benchmarks.real_people import photos  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402

REFERENCE = "cmu-coco-k2932"


def narrow_hips(poses, factor):
    """`poses` with the hips `factor` times as far from their midpoint."""
    mid = (poses[:, 8] + poses[:, 11]) / 2
    out = poses.copy()
    for j in (8, 11):
        out[:, j] = mid + factor * (poses[:, j] - mid)
    return out


def head_variant(heads=(1.1,), necks=(0.2,), plain_neck=True, alpha=None, hips=1.0):
    """CMU atoms + COCO exemplars: COCO's own (neck 0) if `plain_neck`, and for
    each raised neck t in `necks` and head factor h in `heads` a copy with the
    head top h times as far from the shoulders' midpoint and the neck at t of
    the (original) way; mirrored."""
    plain = coco_prior.coco_train_poses()
    parts = [plain] if plain_neck else []
    for t in necks:
        for h in heads:
            parts.append(narrow_hips(coco_prior.raise_neck(head_further(plain, h), t / h), hips))
    return exemplars(mirrored(np.concatenate(parts)), alpha)


def candidates(names):
    """{name: Dictionary} among the known candidates."""
    make = {
        REFERENCE: lambda: load_dictionary(REFERENCE),
        "default": lambda: load_dictionary(),
        "head 1.1": lambda: head_variant(),
        "head 1.15": lambda: head_variant((1.15,)),
        "head 1.05": lambda: head_variant((1.05,)),
        "heads 1+1.1": lambda: head_variant((1.0, 1.1)),
        "head 1.1 both": lambda: head_variant((1.1,), (0.0, 0.2), plain_neck=False),
        "head 1.1 hips 0.9": lambda: head_variant(hips=0.9),
        "head 1.15 hips 0.88": lambda: head_variant((1.15,), hips=0.88),
    }
    out = {}
    for name in names:
        rest, mirror, _ = name.partition("+mirror")
        rest, _, scaling = rest.partition("~")
        base, _, alpha = rest.partition("@")
        d = make[base]()
        d = replace(d, alpha_recover=float(alpha)) if alpha else d
        out[name] = (replace(d, alpha_scaling=scaling) if scaling else d, bool(mirror))
    return out


def run_file(truth, missing, dics, per, seconds):
    """Accumulate per-pose errors of IterativeImputer and each cold prior."""
    filled = harness.iterative(truth, missing)
    per.setdefault("iterative", []).append(per_pose(filled, truth, missing))
    joints = {"iterative": harness.score(filled, truth, missing)}
    for name, (d, mirror) in dics.items():
        t0 = time.perf_counter()
        filled = harness.sparse(adapt=False, dictionary=d, mirror=mirror)(truth, missing)
        seconds[name] = seconds.get(name, 0.0) + time.perf_counter() - t0
        per.setdefault(name, []).append(per_pose(filled, truth, missing))
        joints[name] = harness.score(filled, truth, missing)
    return joints


def summary(per, joints):
    """{name: error over the joints, ratio to IterativeImputer, paired vs reference}."""
    ii = np.mean([j["iterative"] for j in joints])
    out = {}
    ref = np.concatenate(per[REFERENCE]) if REFERENCE in per else None
    for name in per:
        e = np.mean([j[name] for j in joints])
        row = {"error": round(float(e), 3), "ratio": round(float(e / ii), 3)}
        p = np.concatenate(per[name])
        if ref is not None:
            diff = p - ref
            row["paired"] = round(float(diff.mean()), 3)
            row["se"] = round(float(diff.std(ddof=1) / np.sqrt(len(diff))), 3)
        out[name] = row
    return out


def benchmark(sources=("mpii", "coco", "bonn")):
    """{source: {condition: {method: mean error}}} on benchmarks.real_people's photo files."""
    methods = ["iterative", "sparseedm-no-adapt", "sparseedm-no-adapt-mirror"]
    out = {}
    for source in sources:
        rs = real2d.load(source)
        for name in ("default", REFERENCE):
            rep = photos(rs, "val", (1000, 1000), 0, methods=methods, dictionary=name)
            for r in rep.rows:
                if r["group"] == "overall" and not (name != "default" and r["method"] == "iterative"):
                    key = r["method"] if r["method"] == "iterative" else f"{name} {r['method']}"
                    out.setdefault(source, {}).setdefault(r["condition"], {})[key] = round(
                        float(r["mean"]), 3)
        print(source, json.dumps(out[source]), flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photos", default="mpii,bonn,coco-val")
    ap.add_argument("--mocap", default="")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--bonn-seeds", type=int, default=1, help="seeds of the bonn file "
                    "(500 + 500 poses: the slowest)")
    ap.add_argument("--protocols", default=",".join(harness.PROTOCOLS))
    ap.add_argument("--candidates", default=f"{REFERENCE},head 1.1",
                    help="names, comma-separated (see above)")
    ap.add_argument("--benchmark", action="store_true")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    if a.benchmark:
        doc = benchmark()
        if a.out:
            a.out.write_text(json_text(doc, indent=1) + "\n")
        return
    dics = candidates(a.candidates.split(","))
    doc, seconds = {}, {}
    for name in filter(None, a.photos.split(",")):
        rs = real2d.load(harness.FILES[name][0])
        for protocol in a.protocols.split(","):
            per, joints = {}, []
            for seed in range(a.bonn_seeds if name == "bonn" else a.seeds):
                truth, missing = harness.make_file(name, protocol, seed, realset=rs)
                joints.append(run_file(truth, missing, dics, per, seconds))
            doc[f"{name} {protocol}"] = summary(per, joints)
            print(name, protocol, json.dumps(doc[f"{name} {protocol}"]), flush=True)
    for path in filter(None, a.mocap.split(",")):
        per, joints = {}, []
        joints.append(run_file(*mocap_file(path), dics, per, seconds))
        doc[Path(path).stem] = summary(per, joints)
        print(path, json.dumps(doc[Path(path).stem]), flush=True)
    doc["seconds"] = {k: round(v, 1) for k, v in seconds.items()}
    print(json.dumps(doc["seconds"]))
    if a.out:
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
