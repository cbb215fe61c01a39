"""The prior of ``recover(adapt=False)`` without a dictionary, on mocap held out from it.

``recover(adapt=False, dictionary="cmu-coco-k2932", mirror="auto")`` reaches
IterativeImputer on MPII's validation photos; the mocap checks that kept it
off the cold default measured CMU and Daz poses that ``cmu-all-k2000`` (and
so ``cmu-coco-k2932``) learned from. This study builds the same comparison
from a dictionary those poses are held out from, without refitting:

* ``control``: ``cmu-k2000`` (learned from CMU subjects 01-03 only) against
  ``cmu-k2000+coco``, the same 2000 atoms plus the 932 COCO exemplar atoms
  that ``cmu-coco-k2932`` appends to ``cmu-all-k2000``
  (``coco_prior.build("cmu-k2000", mirror=True, necks=(0, 0.2))``: the
  atoms are identical to the shipped file's last 932). Each keeps its own
  recovery alpha: ``cmu-k2000``'s 0.002 for both (``cmu-all-k2000`` and
  ``cmu-coco-k2932`` use 0.0005);
* ``shipped``: ``cmu-all-k2000`` against ``cmu-coco-k2932`` (alpha 0.0005).

Each dictionary cold (``adapt=False``), mirror off and ``"auto"`` (the pose's
own code and its mirror image's code once; the gate is
:func:`sparseedm._recovery_base.mirror_weights`, which
``recover(mirror="auto")`` applies: the same joints to 1e-13).

Files:

* ``cmu-others``: the CMU training set's clips (``benchmarks.load_cmu``) of
  subjects other than 01-03 (13 subjects, 67 clips), each clip a file of at
  most ``--per-clip`` poses (seeded draw), every pose occluded by one
  protocol: Mix (1-3 joints, :func:`sparseedm.metrics.occlusion_masks`) or 1,
  2, 3 random joints. ``daz``: the 24 Daz-named BVH clips of CMU dance and
  martial arts (``sparseedm dataset build ../shared/data/cmu-bvh-daz --seed
  0``), the same way. Both are held out from ``cmu-k2000``; both were learned
  by ``cmu-all-k2000``;
* ``bandai``: Bandai-Namco-1 (in no dictionary; a benchmark reading only:
  no setting is chosen on it), its 174 clips the same way;
* ``defaults``: ``recover()``'s defaults (the path that adapts) started from
  each dictionary, on files of 100 complete + 500 Mix poses drawn from the
  ``cmu-others`` poses (one file per seed);
* ``coverage`` (no pair): the share of hidden joints within the 90 % radius
  of ``RecoveryResult.uncertainty`` on the MPII and Bonn photo files, cold
  over ``dictionary="default"`` and without a dictionary;
* ``photos``: ``harness.py``'s validation photo files (MPII val, COCO val,
  Bonn PoseTrack val frames; 1 / 2 / 3 random hidden joints and transplanted
  real masks), seeds 0 .. S-1, with IterativeImputer fitted on each file.

Score: per file the mean error of its hidden joints, % of body size. Mocap:
paired differences to the pair's first dictionary without the mirror, mean
over files with its standard error over files and clustered by subject (the
clips of one actor are not independent). Photos: the error pooled over the
seeds' hidden joints, its ratio to IterativeImputer's, and the paired
difference per occluded pose (mean, standard error).

    python studies/real_prior/select_cold_default.py --part cmu-others,daz --pair control \\
        --daz /tmp/daz.npz --out studies/real_prior/selection_cold_default.json
    python studies/real_prior/select_cold_default.py --part photos --pair control,shipped \\
        --out studies/real_prior/selection_cold_default.json
    python studies/real_prior/select_cold_default.py --part bandai --pair shipped --per-clip 30 \\
        --protocols mix --out studies/real_prior/selection_cold_default.json
    python studies/real_prior/select_cold_default.py --part cmu-others,daz --pair shipped \\
        --protocols mix --daz /tmp/daz.npz --out studies/real_prior/selection_cold_default.json
    python studies/real_prior/select_cold_default.py --part defaults --pair control --seeds 3 \\
        --out studies/real_prior/selection_cold_default.json
    python studies/real_prior/select_cold_default.py --part coverage --pair control \\
        --out studies/real_prior/selection_cold_default.json
    python studies/real_prior/select_cold_default.py --table studies/real_prior/selection_cold_default.json

(each run adds its parts to the JSON; ``--cache DIR`` keeps each file's rows.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coco_prior  # noqa: E402
import harness  # noqa: E402

from benchmarks import load_cmu, real2d  # noqa: E402
from studies.results_json import load_results  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm._recovery_base import mirror_weights  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.metrics import occlusion_masks  # noqa: E402

MOCAP_PROTOCOLS = ("mix", "1", "2", "3")
OWN_SUBJECTS = ("01", "02", "03")  # what cmu-k2000 learned from


def pairs():
    """{pair: {dictionary name: Dictionary}}; the first of each is the reference."""
    return {
        "control": {"cmu-k2000": load_dictionary("cmu-k2000"),
                    "cmu-k2000+coco": coco_prior.build("cmu-k2000", mirror=True,
                                                       necks=(0.0, 0.2))},
        "shipped": {"cmu-all-k2000": load_dictionary(None),
                    "cmu-coco-k2932": load_dictionary("cmu-coco-k2932")}}


def cold(dictionary, truth, missing):
    """{"off": joints, "auto": joints}: recover(adapt=False) with its own alpha,
    without the mirror and with ``mirror="auto"``, of the rows of `truth`."""
    import sparseedm

    given = np.where(missing[..., None], np.nan, truth)
    own, mir = (sparseedm.recover(given, missing, dictionary=d, adapt=False)
                for d in (dictionary, dictionary.mirrored()))
    w = mirror_weights([own, mir])
    return {"off": own.poses,
            "auto": w[0][:, None, None] * own.poses + w[1][:, None, None] * mir.poses}


def per_pose(filled, truth, missing):
    """Mean error of each occluded pose's hidden joints, % of body size."""
    err = np.linalg.norm(filled - truth, axis=-1) / real2d.body_size(truth)[:, None] * 100
    occ = missing.any(axis=1)
    return (err * missing).sum(axis=1)[occ] / missing.sum(axis=1)[occ]


def clip_files(poses, clips, groups, per_clip, protocols=MOCAP_PROTOCOLS, seed=0):
    """(clip, group, protocol, truth, missing): each clip's poses (at most
    `per_clip`, a seeded draw), every one occluded by the protocol's masks."""
    for i, clip in enumerate(sorted(set(clips.tolist()))):
        rows = np.flatnonzero(clips == clip)
        rng = np.random.default_rng([seed, i])
        rows = np.sort(rng.choice(rows, min(per_clip, len(rows)), replace=False))
        truth = poses[rows].astype(float)
        for protocol in protocols:
            count = protocol if protocol == "mix" else int(protocol)
            missing = occlusion_masks(len(rows), 14, (count,), seed * 1000 + i)[count]
            yield clip, groups[rows[0]], protocol, truth, missing


def mocap_sets(parts, daz_path):
    """{part: (poses, clips, groups)} of the mocap parts asked for."""
    from benchmarks.default_path import load_bandai

    out = {}
    if "cmu-others" in parts:
        poses, clips, _ = load_cmu()
        subject = np.char.partition(clips.astype(str), "_")[:, 0]
        keep = ~np.isin(subject, OWN_SUBJECTS)
        out["cmu-others"] = poses[keep], clips[keep].astype(str), subject[keep]
    for part, path in (("daz", daz_path), ("bandai", None)):
        if part not in parts:
            continue
        if path is None:
            path = load_bandai()[1]
        with np.load(path, allow_pickle=False) as z:
            clips = z["clips"].astype(str)
            groups = z["subjects"].astype(str) if part == "bandai" else np.array(
                [c.split("/")[0] for c in clips])
            out[part] = z["poses2d"], clips, groups
    return out


def run_mocap(part, data, dics, per_clip, protocols, cache):
    """Rows {file, group, protocol, method: error} of one mocap part."""
    rows = []
    for clip, group, protocol, truth, missing in clip_files(*data, per_clip, protocols):
        key = f"{part} {clip} {protocol}".replace("/", "_")
        path = cache and cache / f"{key} {'+'.join(dics)}.json"
        if path is not None and path.exists():
            rows.append(json.loads(path.read_text()))
            continue
        row = {"file": clip, "group": str(group), "protocol": protocol}
        for name, d in dics.items():
            for mode, filled in cold(d, truth, missing).items():
                row[f"{name} {mode}"] = float(per_pose(filled, truth, missing).mean())
        rows.append(row)
        if path is not None:
            path.write_text(json.dumps(row))
    return rows


def paired_files(rows, key, ref):
    """Mean over files of `key` - `ref`, its standard error over files and
    clustered by group (subject)."""
    d = np.array([r[key] - r[ref] for r in rows])
    g = np.array([r["group"] for r in rows])
    n, m = len(d), d.mean()
    se = d.std(ddof=1) / np.sqrt(n) if n > 1 else float("nan")
    sums = np.array([(d[g == k] - m).sum() for k in np.unique(g)])
    k = len(sums)
    cl = np.sqrt(k / (k - 1) * (sums ** 2).sum()) / n if k > 1 else float("nan")
    return {"mean": round(float(m), 3), "se_files": round(float(se), 3) if n > 1 else None,
            "se_groups": round(float(cl), 3) if k > 1 else None}  # one group: none


def mocap_summary(rows, dics):
    """{protocol or "all": {method: mean error, paired: {method: vs reference}}}."""
    methods = [f"{n} {m}" for n in dics for m in ("off", "auto")]
    ref = methods[0]
    out = {}
    for protocol in (*dict.fromkeys(r["protocol"] for r in rows), "all"):
        sel = [r for r in rows if protocol in ("all", r["protocol"])]
        if protocol == "all":  # one row per clip: its protocols' mean
            by = {}
            for r in sel:
                by.setdefault(r["file"], []).append(r)
            sel = [{"group": rs[0]["group"], **{m: float(np.mean([r[m] for r in rs]))
                                               for m in methods}} for rs in by.values()]
        out[protocol] = {"files": len(sel), "groups": len({r["group"] for r in sel}),
                         "error": {m: round(float(np.mean([r[m] for r in sel])), 3)
                                   for m in methods},
                         "paired": {m: paired_files(sel, m, ref) for m in methods[1:]}}
        if len(dics) == 2:  # the union's gated answer against its own without the mirror
            out[protocol]["paired"][f"{methods[3]} - {methods[2]}"] = paired_files(
                sel, methods[3], methods[2])
    return out


def run_defaults(part, data, dics, seeds, cache, C=100, M=500):
    """Rows {file, group, method: error} of ``recover()``'s defaults (the path that
    adapts) started from each dictionary, on files of C complete + M Mix poses
    drawn from the part's poses (one per seed)."""
    import sparseedm

    rows = []
    for seed in range(seeds):
        path = cache and cache / f"defaults {part} {seed} {'+'.join(dics)}.json"
        if path is not None and path.exists():
            rows.append(json.loads(path.read_text()))
            continue
        poses = data[0]
        truth = poses[np.random.default_rng(seed).choice(len(poses), C + M, replace=False)]
        truth = truth.astype(float)
        missing = np.zeros((C + M, 14), bool)
        missing[C:] = occlusion_masks(M, 14, ("mix",), seed)["mix"]
        row = {"file": f"seed {seed}", "group": f"seed {seed}", "protocol": "mix"}
        for name, d in dics.items():
            res = sparseedm.recover(np.where(missing[..., None], np.nan, truth), missing,
                                    dictionary=d)
            row[f"{name} defaults"] = float(per_pose(res.poses, truth, missing).mean())
            row[f"{name} path"] = res.summary()["adaptation"]["path"]
        rows.append(row)
        print(part, json.dumps(row), flush=True)
        if path is not None:
            path.write_text(json.dumps(row))
    return rows


def run_coverage(seeds):
    """{file protocol: {"default": coverage, "cold prior": coverage}}: the share
    of hidden joints within ``RecoveryResult.uncertainty``'s 90 % radius, cold
    over ``dictionary="default"`` and without a dictionary (the cold prior)."""
    import sparseedm

    out = {}
    for source in ("mpii", "bonn"):
        rs = real2d.load(harness.FILES[source][0])
        for protocol in harness.PROTOCOLS:
            hit = {"default": [], "cold prior": []}
            for seed in range(seeds):
                truth, missing = harness.make_file(source, protocol, seed, realset=rs)
                given = np.where(missing[..., None], np.nan, truth)
                for key, kw in (("default", dict(dictionary="default")), ("cold prior", {})):
                    res = sparseedm.recover(given, missing, adapt=False, **kw)
                    err = np.linalg.norm(res.poses - truth, axis=-1)
                    hit[key].append(err[missing] <= res.uncertainty[missing])
            out[f"{source} {protocol}"] = {k: round(float(np.concatenate(v).mean()), 3)
                                           for k, v in hit.items()}
            print(source, protocol, out[f"{source} {protocol}"], flush=True)
    return out


def run_photos(dics, seeds, cache):
    """{file protocol: {method: error, ratio, paired}} on harness.py's photo files."""
    out = {}
    for source in ("mpii", "coco-val", "bonn"):
        rs = real2d.load(harness.FILES[source][0])
        for protocol in harness.PROTOCOLS:
            per, acc = {}, {}
            for seed in range(seeds):
                truth, missing = harness.make_file(source, protocol, seed, realset=rs)
                occ = missing.any(axis=1)
                rows = {"iterative": iterative(truth, missing, cache and cache /
                                               f"photo {source} {protocol} {seed}.npz")[occ]}
                for name, d in dics.items():
                    for mode, filled in cold(d, truth[occ], missing[occ]).items():
                        rows[f"{name} {mode}"] = filled
                for key, filled in rows.items():
                    e = per_pose(filled, truth[occ], missing[occ])
                    per.setdefault(key, []).append(e)
                    a = acc.setdefault(key, [0.0, 0])
                    a[0] += float((e * missing[occ].sum(axis=1)).sum())
                    a[1] += int(missing[occ].sum())
            out[f"{source} {protocol}"] = photo_summary(per, acc, f"{next(iter(dics))} off")
            print(source, protocol, json.dumps(out[f"{source} {protocol}"]), flush=True)
    return out


def iterative(truth, missing, path=None):
    """IterativeImputer fitted on the file (kept in `path` when given)."""
    if path is not None and path.exists():
        with np.load(path, allow_pickle=False) as z:
            return z["filled"]
    filled = harness.iterative(truth, missing)
    if path is not None:
        np.savez(path, filled=filled)
    return filled


def photo_summary(per, acc, ref):
    """{method: error over the hidden joints, ratio to IterativeImputer, paired vs `ref`}."""
    ii = acc["iterative"][0] / acc["iterative"][1]
    base = np.concatenate(per[ref])
    out = {}
    for key, (s, n) in acc.items():
        d = np.concatenate(per[key]) - base
        out[key] = {"error": round(s / n, 3), "ratio": round(s / n / ii, 3),
                    "paired": round(float(d.mean()), 3),
                    "se": round(float(d.std(ddof=1) / np.sqrt(len(d))), 3)}
    return out


def table(doc):
    """Markdown tables of the JSON's mocap parts (paired vs the reference)."""
    lines = []
    for pair, parts in doc.items():
        for part, res in parts.items():
            if part == "photos" or not isinstance(res, dict) or "all" not in res:
                continue
            lines += [f"\n{pair}, {part} ({res['all']['files']} clips, "
                      f"{res['all']['groups']} subjects)", "",
                      "| protocol | " + " | ".join(res["all"]["error"]) + " |",
                      "|---" * (len(res["all"]["error"]) + 1) + "|"]
            for protocol, r in res.items():
                ref = next(iter(r["error"]))
                cells = [f"{r['error'][ref]:.2f}"] + [
                    f"{p['mean']:+.3f} ± {p['se_files']:.3f}"
                    + (f" ({p['se_groups']:.3f})" if p["se_groups"] is not None and np.isfinite(p["se_groups"]) else "")
                    for m, p in r["paired"].items() if " - " not in m]
                lines.append(f"| {protocol} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def photo_table(doc):
    """Markdown: per pair and method, the ratios to IterativeImputer (1 / 2 / 3 / real)."""
    lines = []
    for pair, parts in doc.items():
        photos = parts.get("photos") if isinstance(parts, dict) else None
        if not photos:
            continue
        files = list(dict.fromkeys(k.rsplit(" ", 1)[0] for k in photos))
        methods = list(next(iter(photos.values())))
        lines += [f"\n{pair}, photos (ratio to IterativeImputer, 1 / 2 / 3 / real)", "",
                  "| method | " + " | ".join(files) + " |", "|---" * (len(files) + 1) + "|"]
        for m in methods:
            cells = [" / ".join(f"{photos[f'{f} {p}'][m]['ratio']:.2f}"
                                for p in harness.PROTOCOLS) for f in files]
            lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="cmu-others,daz,photos",
                    help="cmu-others, daz, bandai, photos, defaults, coverage "
                    "(comma-separated)")
    ap.add_argument("--pair", default="control", help="control, shipped (comma-separated)")
    ap.add_argument("--daz", type=Path, help="the Daz dataset .npz (dataset build)")
    ap.add_argument("--per-clip", type=int, default=80)
    ap.add_argument("--protocols", default=",".join(MOCAP_PROTOCOLS),
                    help="mocap masks: mix, 1, 2, 3 (comma-separated)")
    ap.add_argument("--seeds", type=int, default=2, help="photo files' seeds")
    ap.add_argument("--cache", type=Path)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--table", type=Path, help="print the tables of this JSON and stop")
    a = ap.parse_args(argv)
    if a.table:
        doc = load_results(a.table)
        print(table(doc), photo_table(doc), sep="\n")
        return
    doc = load_results(a.out) if a.out and a.out.exists() else {}  # null as NaN: tabled below
    parts = a.part.split(",")
    all_pairs = pairs()
    sets = mocap_sets([p for p in parts if p not in ("defaults", "coverage")], a.daz)
    for pair in a.pair.split(","):
        dics = all_pairs[pair]
        entry = doc.setdefault(pair, {"alpha": {n: d.alpha_recover for n, d in dics.items()}})
        t0 = time.perf_counter()
        for part, data in sets.items():
            entry[part] = mocap_summary(run_mocap(part, data, dics, a.per_clip,
                                                  a.protocols.split(","), a.cache), dics)
            print(pair, part, json.dumps(entry[part]["all"]), flush=True)
        if "coverage" in parts:
            doc["coverage"] = run_coverage(a.seeds)
        if "defaults" in parts:
            entry["defaults"] = {part: run_defaults(part, data, dics, a.seeds, a.cache)
                                 for part, data in mocap_sets(("cmu-others",), None).items()}
        if "photos" in parts:
            entry["photos"] = run_photos(dics, a.seeds, a.cache)
        entry.setdefault("seconds", {})[a.part] = round(time.perf_counter() - t0, 1)
        if a.out:
            a.out.write_text(json_text(doc, indent=1) + "\n")
    print(table(doc), photo_table(doc), sep="\n")


if __name__ == "__main__":
    main()
