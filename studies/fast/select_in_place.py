"""Donors in place: hidden joints from the rows nearest in the image itself.

The donor step (``sparseedm.donors.donor_step``) aligns a donor onto the pose
over at least ``DONOR_MIN_SHARED`` (6) joints both observe. Under real
occlusion many poses show 3-5 joints: on Bonn video frames with 1,000
complete poses of other videos, their hidden joints (about a sixth of all)
kept the default path's answer, 15.2 % of body size against KNNImputer's
7.3, and KNNImputer won the file (5.99 vs 7.21). Donors in place
(``sparseedm.donors.in_place_estimates``: the rows observing the joint whose
shared observed joints lie nearest in the image, no alignment, at least
``IN_PLACE_MIN_SHARED`` of them) move the joints without an aligned donor
and, with another weight, those with one, each weight and gate chosen on
probes.

This script runs ``recover()`` on each validation file with donors in place
(``after``) and without them (``before``: ``IN_PLACE_MIN_SHARED`` set to 15,
so no such donors), and KNNImputer; per occluded pose the mean error of its
hidden joints (% of body size); the paired difference after - before, mean
and standard error. Files: ``select_donors.py``'s.

    sparseedm dataset build ../shared/data/cmu-bvh-daz/indian -o daz_indian.npz
    python studies/fast/select_in_place.py --seeds 0,1,2 --daz daz_indian.npz \
        --out studies/fast/selection_in_place.json
    python studies/fast/select_in_place.py --table studies/fast/selection_in_place.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from sparseedm._atomic import json_text  # noqa: E402
from studies.results_json import load_results  # noqa: E402


def joint_errors(filled, truth):
    from benchmarks import real2d

    return np.linalg.norm(filled - truth, axis=-1) / real2d.body_size(truth)[:, None] * 100


def per_pose(filled, truth, missing):
    return np.array([e[m].mean() for e, m in zip(joint_errors(filled, truth), missing)])


def paired(a, b):
    d = a - b
    return [round(float(d.mean()), 4), round(float(d.std(ddof=1) / np.sqrt(len(d))), 4)]


def measure(truth, missing, dictionary=None):
    import sparseedm
    from sparseedm import donors
    from sklearn.impute import KNNImputer

    occ = np.flatnonzero(missing.any(1))
    given = np.where(missing[..., None], np.nan, truth)
    out, secs, joints = {}, {}, {}
    keep = donors.IN_PLACE_MIN_SHARED
    for name, low in (("before", 15), ("after", keep)):  # 15 shared joints: never
        donors.IN_PLACE_MIN_SHARED = low
        try:
            t0 = time.perf_counter()
            res = sparseedm.recover(given, missing, dictionary=dictionary)
            secs[name] = round(time.perf_counter() - t0, 2)
        finally:
            donors.IN_PLACE_MIN_SHARED = keep
        out[name] = per_pose(res.poses[occ], truth[occ], missing[occ])
        joints[name] = joint_errors(res.poses[occ], truth[occ])[missing[occ]].mean()
        chosen = res.adaptation.settings.get("donors", {}) if res.adaptation else {}
    knn = KNNImputer(n_neighbors=5).fit_transform(given.reshape(len(given), -1))
    out["knn"] = per_pose(knn.reshape(truth.shape)[occ], truth[occ], missing[occ])
    shown = (~missing[occ]).sum(1)
    few = shown <= donors.DONOR_MIN_SHARED
    return {"n": int(len(occ)), "few_shown": int(few.sum()), "seconds": secs,
            "in_place": chosen.get("in_place"), "aligned": {k: v for k, v in chosen.items()
                                                            if k != "in_place"},
            "mean": {k: round(float(v.mean()), 4) for k, v in out.items()},
            "joint_mean": {k: round(float(v), 4) for k, v in joints.items()},
            "after_minus_before": paired(out["after"], out["before"]),
            "few_after_minus_before": paired(out["after"][few], out["before"][few])
            if few.sum() > 1 else None}


def files(a, seed):
    """(name, truth, missing, dictionary): the photo files of select_donors.py,
    then its mocap files (CMU subjects 04 and up with ``cmu-k2000``; Daz)."""
    from studies.fast.select_default_exemplars import mocap_file
    from studies.fast.select_donors import cmu_file
    from studies.fast.select_photo_atoms import photo_files

    for frm, c in (("split", 1000), ("train", 1000)):
        for name, truth, missing in photo_files(a.sources, "val", frm, sizes=(c, 1000),
                                                seed=seed):
            yield name, truth, missing, None
    for n in (int(x) for x in a.cmu.split(",") if x):
        truth, missing = cmu_file(n, seed)
        yield f"cmu 04+ {len(truth)} poses (cmu-k2000)", truth, missing, "cmu-k2000"
    for path in filter(None, a.daz.split(",")):
        for c in (200, 1000):
            truth, missing = mocap_file(path, c, c, seed)
            yield f"{Path(path).stem} {c}+{c}", np.asarray(truth, float), missing, None


def table(docs):
    rows = {}
    for doc in docs:
        for seed, files_ in doc["seeds"].items():
            for name, r in files_.items():
                rows.setdefault(name, []).append(r)
    print("| file | seeds | poses showing <= 6 joints | before | after - before | on those poses | "
          "KNNImputer | in place chose, per draw (weight@gate: joints without / with an aligned donor) |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for name, rs in rows.items():
        def comb(key):
            vals = [r[key] for r in rs if isinstance(r[key], list)]
            if not vals:
                return "-"
            m = np.mean([v[0] for v in vals])
            se = np.sqrt(np.sum([v[1] ** 2 for v in vals])) / len(vals)
            return f"{m:+.2f} ± {se:.2f}"
        def pick(r, name):
            got = r["in_place"].get(name) if isinstance(r["in_place"], dict) else None
            return "-" if not isinstance(got, dict) else f"{got['weight']}@{got['gate'] or 'inf'}"
        chose = ", ".join(f"{pick(r, 'bare')} / {pick(r, 'aligned')}" for r in rs)
        print(f"| {name} | {len(rs)} | {np.mean([r['few_shown'] for r in rs]):.0f} | "
              f"{np.mean([r['mean']['before'] for r in rs]):.2f} | {comb('after_minus_before')} | "
              f"{comb('few_after_minus_before')} | {np.mean([r['mean']['knn'] for r in rs]):.2f} | "
              f"{chose} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sources", default="bonn,mpii,coco")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--cmu", default="400,2000", help="CMU file sizes (subjects 04+)")
    ap.add_argument("--daz", default="", help="Daz dataset .npz paths (sparseedm dataset build)")
    ap.add_argument("--out", type=Path, default=Path("selection_in_place.json"))
    ap.add_argument("--table", nargs="+", type=Path, help="print the table of these runs, stop")
    a = ap.parse_args(argv)
    if a.table:
        table([load_results(p) for p in a.table])
        return
    doc = {"command": "python studies/fast/select_in_place.py " + " ".join(argv or sys.argv[1:]),
           "seeds": {}}
    for seed in (int(s) for s in a.seeds.split(",")):
        doc["seeds"][str(seed)] = got = {}
        for name, truth, missing, dictionary in files(a, seed):
            got[name] = measure(truth, missing, dictionary)
            print(seed, name, got[name]["mean"], got[name]["after_minus_before"],
                  got[name]["in_place"], flush=True)
            a.out.write_text(json_text(doc))
    table([doc])


if __name__ == "__main__":
    main()
