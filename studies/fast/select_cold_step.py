"""The cold prior's answer as the default path's bank step's candidate.

The default path's bank step (:func:`sparseedm.cold_bank.bank_step`, in
``exemplars.finish_blend``) averages every occluded pose's answer with the
shipped pose bank's local Gaussian (``bank_fill``) at a weight chosen on
probes of the file's occluded rows, skipped from ``BANK_STEP_MAX_COMPLETE``
(200) complete poses. Variants of that step, each followed by the donor step
as in ``finish_blend`` (the path before the step run once per file and shared):

* ``today``: the bank step as shipped;
* ``cold``: the candidate is the cold prior's answer, what
  ``recover(adapt=False)`` answers (the codes over ``cmu-coco-k2932``, or the
  call's dictionary, with ``mirror="auto"`` and the pose bank stacked by
  ``cold_bank_stack``), under the 200 cap;
* ``cold nocap``: the same on every file;
* ``both``: the bank step as shipped, then the cold step without the cap.

Files (validation splits only): ``harness.make_file``'s MPII val 200 + 199,
MPII val 28 + 200 and 100 + 200, COCO val 27 + 28, Bonn val frames 500 + 500,
and the train-complete files of ``benchmarks/real_people.py --complete-from
train`` (the val split's complete poses occluded, the file's complete poses
1,000 (COCO 233) of the train split); protocols 1, 2, 3 random hidden joints
and ``real`` (transplanted visibility masks). Mocap (``--mocap``): CMU
subjects other than 01-03 coded with ``cmu-k2000``, Daz, Bandai-Namco (a
reading only), Mix masks, ``mocap_check.py``'s draws.
Score: the hidden joints' mean error in % of body size; differences against
``today`` pooled over seeds with a paired standard error clustered by pose.

    python studies/fast/select_cold_step.py --files mpii,mpii-28,mpii-100 --seeds 0,1,2 \\
        --out selection_cold_step_mpii.json
    python studies/fast/select_cold_step.py --mocap /tmp/cmu_other_subjects.npz:cmu-k2000,\\
        /tmp/daz_indian.npz,/tmp/bandai.npz --seeds 0,1,2 --out selection_cold_step_mocap.json
    python studies/fast/select_cold_step.py --table selection_cold_step_*.json
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
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "studies" / "real_prior"))

VARIANTS = {"today": [{}], "cold": [{"cold": True}],
            "cold nocap": [{"cold": True, "max_complete": np.inf}],
            "both": [{}, {"cold": True, "max_complete": np.inf}]}
#: file -> (harness file, sizes) or ("train", source, complete poses)
FILES = {"mpii": ("mpii", None), "mpii-28": ("mpii", (28, 200)),
         "mpii-100": ("mpii", (100, 200)), "coco-val": ("coco-val", None),
         "bonn": ("bonn", None), "mpii+1000": ("train", "mpii", 1000),
         "coco+233": ("train", "coco", 233), "bonn+1000": ("train", "bonn", 1000)}
SETS = {}


def train_file(source, n_complete, protocol, seed):
    """benchmarks/real_people.py --complete-from train's file under `protocol`:
    `n_complete` train complete poses, then the val split's complete poses
    (at most 1,000) with joints hidden as harness.make_file hides them."""
    from benchmarks import real2d
    from harness import PROTOCOLS, real_patterns

    rs = SETS.setdefault(source, real2d.load(source))
    parts = real2d.split(rs)
    ok = rs.complete & (real2d.body_size(rs.poses) > 0)
    rng = np.random.default_rng([seed, PROTOCOLS.index(protocol), 11])
    kept = rng.permutation(np.flatnonzero(ok & (parts == "train")))[:n_complete]
    occ = rng.permutation(np.flatnonzero(ok & (parts == "val")))[:1000]
    truth = rs.poses[np.concatenate([kept, occ])]
    missing = np.zeros((len(truth), 14), bool)
    if protocol == "real":
        pats = real_patterns(rs)
        missing[len(kept):] = pats[rng.integers(len(pats), size=len(occ))]
    else:
        for i in range(len(kept), len(truth)):
            missing[i, rng.choice(14, size=int(protocol), replace=False)] = True
    return truth, missing


def make(name, protocol, seed):
    from benchmarks import real2d
    from harness import make_file

    spec = FILES[name]
    if spec[0] == "train":
        return train_file(spec[1], spec[2], protocol, seed)
    source = "coco" if spec[0] == "coco-val" else spec[0]
    rs = SETS.setdefault(source, real2d.load(source))
    return make_file(spec[0], protocol, seed, sizes=spec[1], realset=rs)


class ColdCodes:
    """The cold prior's codes of other rows (recover(adapt=False) without the
    bank), remembered by question; the seconds spent."""

    def __init__(self, dictionary):
        from sparseedm import load_dictionary
        from sparseedm._recovery_base import COLD_DICTIONARY

        d = load_dictionary(dictionary or COLD_DICTIONARY)
        self.members, self.seen, self.seconds = [d, d.mirrored()], {}, 0.0

    def __call__(self, p, m):
        from sparseedm._recovery_kernel import recover_members

        key = (np.asarray(p).tobytes(), np.asarray(m).tobytes())
        if key not in self.seen:
            t0 = time.perf_counter()
            self.seen[key] = recover_members(p, m, self.members, [], mirror_gate=True,
                                             check_input=False)
            self.seconds += time.perf_counter() - t0
        return self.seen[key]


def cold_step(res, poses, missing, answer, cold=None, max_complete=200):
    """The bank step (``cold_bank.bank_step``) with the cold prior's answer as its
    candidate (`cold`: :class:`ColdCodes`; None: the bank step as shipped),
    skipped from `max_complete` complete poses: `cold`'s codes of the occluded
    rows with the bank stacked as ``cold_bank_stack`` stacks it (turned to the
    file's body axis), its weight chosen by ``exemplars.probe_weight``."""
    from sparseedm.cold_bank import bank_step
    from sparseedm.exemplars import probe_weight, remembered, stack_fill
    from sparseedm.file_atoms import complete_rows

    if cold is None:
        return bank_step(res, poses, missing, answer)
    n_complete = int(complete_rows(poses, missing).sum())
    if n_complete >= max_complete:
        return _noted(res, {"weight": 0.0, "probes": 0, "skipped": n_complete}), answer
    candidate = cold_candidate(cold, poses)

    def stacked(r, p, m, filled, weight):
        rows = np.flatnonzero(m.any(axis=1) & r.ok)
        return stack_fill(r, rows, filled[rows], weight, "cold") if len(rows) else r

    answer = remembered(answer)
    fill = remembered(candidate, lambda f, k: f[:k])
    choice = probe_weight(poses, missing, answer, lambda rows, joints, p, m: fill(p, m))
    res = _noted(res, {"weight": choice.weight, "probes": choice.probes,
                       "probe_err_default": round(choice.err_default, 4),
                       "probe_err_chosen": round(choice.err_chosen, 4)})
    if not choice.weight > 0:
        return res, answer
    return (stacked(res, poses, missing, candidate(poses, missing), choice.weight),
            lambda p, m: stacked(answer(p, m), p, m, fill(p, m), choice.weight))


def cold_candidate(cold, poses):
    """``candidate(p, m)``: the occluded rows' cold answers (`cold`'s codes with
    the bank stacked as ``cold_bank_stack`` stacks it, turned to the body axis
    of the file `poses`), the other rows as given."""
    from sparseedm.cold_bank import COLD_BANK_WEIGHTS, bank_fill, load_pose_bank
    from sparseedm.exemplars import stack_fill
    from sparseedm.file_atoms import body_axis

    bank, axis = load_pose_bank(), body_axis(poses)

    def candidate(p, m):
        out, occ = np.array(p, float), m.any(axis=1)
        if occ.any():
            codes, po, mo = cold(p[occ], m[occ]), p[occ], m[occ]
            w = np.asarray(COLD_BANK_WEIGHTS)[mo.sum(axis=1)]
            rows = np.flatnonzero((w > 0) & codes.ok)
            if len(rows):
                fill = bank_fill(bank, po, mo, axis=axis)[rows]
                codes = stack_fill(codes, rows, fill, w[rows], "bank")
            out[occ] = codes.poses
        return out
    return candidate


def _noted(res, record):
    from dataclasses import replace

    return replace(res, adaptation=replace(res.adaptation, settings=dict(
        res.adaptation.settings, cold=record)))


def run_file(truth, missing, kw):
    """Every variant's answer to one file (the path before the bank step shared):
    {variant: (poses, records, step seconds)}, the path's seconds before the step,
    the cold codes' seconds, and the curves: the hidden joints' error of
    ``(1 - w) * path + w * cold`` before the step (``truth``) and the cold
    step's probes' (``probes``, without the cap), w in LINEAR_WEIGHTS."""
    import sparseedm
    import sparseedm.exemplars as ex
    import sparseedm.recovery as recovery
    from sparseedm.donors import donor_step

    cold = ColdCodes(kw.get("dictionary"))
    got, t, curves = {}, {}, {}
    shipped, best = recovery.bank_step, ex._best_weight

    def probed(per_pose, fewest, clusters=None):
        ok = np.isfinite(per_pose).all(axis=0)
        curves.setdefault("probes", per_pose[:, ok].mean(axis=1).round(4).tolist())
        return best(per_pose, fewest, clusters)

    def variants(res, poses, missing_, answer):
        t["before"] = time.perf_counter() - t["start"]
        cand = cold_candidate(cold, poses)(poses, missing_)
        curves["truth"] = [float(joint_errors((1 - w) * res.poses + w * cand, truth,
                                              missing_)[0].mean().round(4))
                           for w in ex.LINEAR_WEIGHTS]
        for name, steps in VARIANTS.items():
            t0, r, a, records = time.perf_counter(), res, answer, []
            for step in steps:
                ex._best_weight = probed if name == "cold nocap" else best
                try:
                    r, a = cold_step(r, poses, missing_, a, cold if step.get("cold") else None,
                                     step.get("max_complete", 200))
                finally:
                    ex._best_weight = best
                records.append(dict(r.adaptation.settings.get(
                    "cold" if step.get("cold") else "bank", {})))
            r = donor_step(r, poses, missing_, a)
            records.append({"donor_weight": r.adaptation.settings.get("donors", {}).get(
                "weight")})
            got[name] = (r.poses, records, time.perf_counter() - t0)
        return shipped(res, poses, missing_, answer)

    recovery.bank_step = variants
    try:
        t["start"] = time.perf_counter()
        sparseedm.recover(np.where(missing[..., None], np.nan, truth), missing, n_jobs=1, **kw)
    finally:
        recovery.bank_step = shipped
    return got, t.get("before", np.nan), cold.seconds, curves


def joint_errors(filled, truth, missing):
    """(errors of the hidden joints in % of body size, their pose's row)."""
    from benchmarks import real2d

    err = np.linalg.norm(filled - truth, axis=-1) / real2d.body_size(truth)[:, None] * 100
    return err[missing], np.nonzero(missing)[0]


def measure(truth, missing, photo, kw):
    """One file's record: each variant's error, weights, seconds; II's error on photos."""
    got, before, cold_secs, curves = run_file(truth, missing, kw)
    if not got:  # the path had no bank step (not blended)
        return None
    rows = np.nonzero(missing)[0]
    out = {"before_seconds": round(before, 2), "cold_seconds": round(cold_secs, 2),
           "pose_keys": [truth[r].tobytes().hex()[:24] for r in rows], "variants": {},
           "curves": curves}
    for name, (poses, records, secs) in got.items():
        err, _ = joint_errors(poses, truth, missing)
        out["variants"][name] = {"err": err.round(4).tolist(), "records": records,
                                 "step_seconds": round(secs, 2)}
    if photo:
        from harness import iterative

        given = np.where(missing[..., None], np.nan, truth)
        out["ii"] = joint_errors(iterative(given, missing), truth, missing)[0].round(4).tolist()
    return out


def mocap_files(spec, seed):
    from studies.fast.select_default_exemplars import mocap_file

    for item in filter(None, spec.split(",")):
        path, _, dictionary = item.partition(":")
        for c in (40, 200):
            truth, missing = mocap_file(path, c, c, seed)
            yield (f"{Path(path).stem} {c}+{c} {dictionary or 'default'}", "mix",
                   np.asarray(truth, float), missing, False,
                   {"dictionary": dictionary} if dictionary else {})


def files(a, seed):
    for name in filter(None, a.files.split(",")):
        for protocol in a.protocols.split(","):
            truth, missing = make(name, protocol, seed)
            yield name, protocol, truth, missing, True, {}
    yield from mocap_files(a.mocap, seed)


def clustered(diff, keys):
    """Mean of `diff` and its standard error clustered by `keys`."""
    d = np.asarray(diff, float)
    mean = d.mean()
    _, idx = np.unique(keys, return_inverse=True)
    sums = np.bincount(idx, weights=d - mean)
    g = len(sums)
    se = np.sqrt((sums ** 2).sum() * g / max(g - 1, 1)) / len(d)
    return float(mean), float(se)


def pooled_rows(docs):
    """Per file and protocol, pooled over seeds: each variant's error and its
    difference from today [mean, clustered SE], II's error, the chosen weights
    (bank, cold) per seed and mean seconds; and each file's curves."""
    files, pooled = {}, {}
    for doc in docs:  # a file measured twice (a second run, with curves): the later
        files.update(doc["files"])
    for rec in files.values():
        pooled.setdefault((rec["file"], rec["protocol"]), []).append(rec)
    rows = []
    for (name, protocol), recs in sorted(pooled.items()):
        keys = sum((r["pose_keys"] for r in recs), [])
        base = np.concatenate([r["variants"]["today"]["err"] for r in recs])
        row = {"file": name, "protocol": protocol, "seeds": sorted(r["seed"] for r in recs),
               "today": round(float(base.mean()), 3), "minus_today": {}, "weights": {},
               "ii": (round(float(np.concatenate([r["ii"] for r in recs]).mean()), 3)
                      if all("ii" in r for r in recs) else None),
               "seconds": dict(zip(("path before the step", "today's step and donors",
                                    "cold nocap's step and donors with its codes"),
                                   np.mean([[r["before_seconds"],
                                             r["variants"]["today"]["step_seconds"],
                                             r["variants"]["cold nocap"]["step_seconds"]
                                             + r["cold_seconds"]] for r in recs],
                                           axis=0).round(2).tolist()))}
        for v in VARIANTS:
            e = np.concatenate([r["variants"][v]["err"] for r in recs])
            row["minus_today"][v] = [round(x, 4) for x in clustered(e - base, keys)]
            row["weights"][v] = [[rec.get("weight") for rec in r["variants"][v]["records"][:-1]]
                                 for r in recs]
        rows.append(row)
    curves = [{"file": r["file"], "protocol": r["protocol"], "seed": r["seed"], **r["curves"]}
              for r in files.values() if r.get("curves", {}).get("truth")]
    return rows, curves


def table(docs):
    """The pooled rows (:func:`pooled_rows`) as text."""
    rows, curves = pooled_rows(docs)
    lines = [f"{'file':36s} {'prot':4s} {'today':>6s} {'II':>6s} "
             + " ".join(f"{v:>14s}" for v in VARIANTS if v != "today")
             + "  weights (both: bank/cold per seed)  seconds"]
    for row in rows:
        ii = f"{row['ii']:6.2f}" if row["ii"] is not None else "   -  "
        cells = " ".join("{:+.3f}±{:.3f}".format(*row["minus_today"][v]).rjust(14)
                         for v in VARIANTS if v != "today")
        w = " ".join("/".join(f"{x:g}" for x in ws) for ws in row["weights"]["both"])
        lines.append(f"{row['file']:36s} {row['protocol']:4s} {row['today']:6.2f} {ii} "
                     f"{cells}  {w:30s} " + "/".join(f"{x:.1f}" for x in row["seconds"].values()))
    lines += ["", "curves (w = 0 .. 1; truth: the hidden joints before the step, probes: "
              "the cold step's probes):"]
    lines += [f"{c['file']:10s} {c['protocol']:4s} seed {c['seed']}  truth "
              + " ".join(f"{x:6.2f}" for x in c["truth"]) + "  probes "
              + " ".join(f"{x:6.2f}" for x in c.get("probes", [])) for c in curves]
    return "\n".join(lines)


def main(argv=None):
    from sparseedm._atomic import json_text

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", default="")
    ap.add_argument("--protocols", default="1,2,3,real")
    ap.add_argument("--mocap", default="", help="dataset files path[:dictionary], comma-separated")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--table", nargs="+", type=Path, help="print the pooled table, stop")
    ap.add_argument("--summary", type=Path, help="with --table: also write the pooled rows")
    ap.add_argument("--out", type=Path, default=Path("cold_step.json"))
    a = ap.parse_args(argv)
    if a.table:
        docs = [json.loads(p.read_text()) for p in a.table]
        print(table(docs))
        if a.summary:
            rows, curves = pooled_rows(docs)
            a.summary.write_text(json_text({"score": docs[0]["score"], "rows": rows,
                                            "curves": curves}, indent=1) + "\n")
        return
    warnings.simplefilter("ignore")
    doc = json.loads(a.out.read_text()) if a.out.exists() else {
        "score": "per hidden joint: % of body size; variants' step seconds include the "
                 "donor step; cold_seconds: the cold codes (shared by the cold variants)",
        "files": {}}
    for seed in (int(s) for s in a.seeds.split(",")):
        for name, protocol, truth, missing, photo, kw in files(a, seed):
            key = f"{name} protocol {protocol} seed {seed}"
            if key in doc["files"]:
                continue
            rec = measure(truth, missing, photo, kw)
            if rec is None:
                print(key, "no bank step", flush=True)
                continue
            doc["files"][key] = dict(rec, file=name, protocol=protocol, seed=seed)
            v = rec["variants"]
            print(key, {k: round(float(np.mean(x["err"])), 3) for k, x in v.items()},
                  "w", v["cold nocap"]["records"][0].get("weight"),
                  "II", round(float(np.mean(rec["ii"])), 3) if "ii" in rec else "-",
                  "s", rec["before_seconds"], v["cold nocap"]["step_seconds"],
                  rec["cold_seconds"], flush=True)
            a.out.write_text(json_text(doc) + "\n")


if __name__ == "__main__":
    main()
