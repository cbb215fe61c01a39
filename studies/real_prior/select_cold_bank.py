"""A shipped pose bank for ``recover(adapt=False)``: each pose's local Gaussian over it.

The cold prior codes each pose over ``cmu-coco-k2932`` (``mirror="auto"``)
and cannot learn from the file. This study sets beside it a linear answer
from a fixed bank of complete 2D poses, :func:`sparseedm.cold_bank.bank_fill`
(the per-pose local Gaussian of
:func:`sparseedm.gaussian_fill.local_gaussian_fill` over the bank turned to
the file's mean body axis; with a gate, a pose whose mean distance to its 20
nearest COCO poses is below the gate times that to its 20 nearest CMU poses
takes COCO's poses alone, any other the whole bank), and stacks the two,
``(1 - w) cold + w bank``, at a weight ``w`` per count of hidden joints
(:data:`GROUPS`), chosen on the photo files: per group the least error
(each file relative to its cold error) among the weights that leave no
source worse than the cold answer by more than one standard error.

Banks (only poses free to ship):

* COCO's complete poses of real2d's train split, both neck conventions,
  mirrored (the 932 poses ``cmu-coco-k2932`` appends as atoms:
  ``coco_prior.coco_train_poses(mirror=True, necks=(0, 0.2))``);
* ``coco+cmuN``: those plus N CMU poses (``benchmarks.load_cmu``: the CMU
  clips projected by ``sparseedm dataset build`` cameras), N/2 drawn (seed 0)
  and their mirror images (gate inf: COCO's alone, 0: the whole bank). On
  the photos the CMU draw is from every subject; on mocap (the control) from
  subjects 01-03 only, and the cold answer is then ``cmu-k2000+coco`` (as
  ``select_cold_default.py``'s control pair), so the other CMU subjects and
  the Daz clips are held out from both answers.

Files: ``harness.py``'s validation photo files (``mpii``, ``coco-val``,
``bonn`` val frames; 1 / 2 / 3 random hidden joints and transplanted real
masks; seeds 0 .. S-1) with IterativeImputer fitted on each, and on
``mpii+1000`` (the MPII file plus 1,000 complete poses of MPII's train split:
only IterativeImputer sees them, the cold answers are per pose); mocap: the
clips of ``select_cold_default.py`` (``cmu-others``, ``daz``), ``--per-clip``
poses each, Mix masks.

Score: the mean error of the hidden joints, % of body size; per pose the mean
over its hidden joints, pooled weighing each pose by its hidden count; the
ratio to IterativeImputer; paired differences to the cold answer per occluded
pose (photos) or per clip, clustered by subject (mocap).

    python studies/real_prior/select_cold_bank.py --part photos --seeds 2 \
        --banks coco+cmu2000,coco+cmu6000 --neighbours 100 --cache CACHE --out A.json
    python studies/real_prior/select_cold_bank.py --part cmu-others,daz --daz daz.npz \
        --banks coco+cmu2000,coco+cmu6000 --neighbours 100 --cache CACHE --out B.json
    # B's "mocap_rows" copied into A, then the mocap summary with A's weights:
    python studies/real_prior/select_cold_bank.py --part none --out A.json
    # the shipped bank:
    python studies/real_prior/select_cold_bank.py --ship OUT.npz --bank coco+cmu6000
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
import select_cold_default as scd  # noqa: E402

from benchmarks import load_cmu, real2d  # noqa: E402
from studies.results_json import load_results  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.cold_bank import PoseBank, bank_fill  # noqa: E402
from sparseedm.skeleton import SKELETON_14  # noqa: E402

WEIGHTS = (0.0, 0.25, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
#: hidden-joint counts that share a weight
GROUPS = ((1, 1), (2, 2), (3, 3), (4, 5), (6, 14))
BANKS = ("coco+cmu2000", "coco+cmu6000", "coco+cmu20000")
NEIGHBOURS = (100, 200)
#: bank_fill's gates: 0 the whole bank for every pose, inf COCO's poses alone
GATES = (0.0, 1.25, 1.5, 2.0, np.inf)


def mirror(poses):
    """Left-right mirror images (x negated, sides swapped)."""
    out = poses[:, SKELETON_14.flip_permutation()].copy()
    out[..., 0] *= -1
    return out


def cmu_draw(n, subjects=None, seed=0):
    """n CMU poses: n/2 drawn from the training set (of `subjects`) and their mirror images."""
    poses, clips, _ = load_cmu()
    rows = np.arange(len(poses))
    if subjects is not None:
        subject = np.char.partition(clips.astype(str), "_")[:, 0]
        rows = rows[np.isin(subject, subjects)]
    rows = np.sort(np.random.default_rng(seed).choice(rows, n // 2, replace=False))
    half = poses[rows].astype(float)
    return np.concatenate([half, mirror(half)])


def banks(names, subjects=None):
    """{name: PoseBank} (COCO's poses photographed, CMU's not)."""
    coco = coco_prior.coco_train_poses(mirror=True, necks=(0.0, 0.2))
    out = {}
    for name in names:
        n = int(name.split("cmu")[1]) if "cmu" in name else 0
        poses = np.concatenate([coco, cmu_draw(n, subjects)]) if n else coco
        out[name] = PoseBank(poses, np.arange(len(poses)) < len(coco))
    return out


def ship(path, name):
    """Write bank `name` (:func:`banks`, CMU from every subject) as a pose bank file
    (``poses`` float32, ``joint_names``, ``meta`` JSON)."""
    from sparseedm._atomic import save_npz

    bank = banks([name])[name]
    poses = bank.poses.astype(np.float32)
    n = int(name.split("cmu")[1]) if "cmu" in name else 0
    meta = {"kind": "pose bank", "poses": int(len(poses)), "builder": (
        f"python studies/real_prior/select_cold_bank.py --ship OUT.npz --bank {name}"),
        "source": [
            "COCO 2017 keypoint annotations (CC BY 4.0, the COCO Consortium, "
            "https://cocodataset.org): the complete 14-joint poses of real2d's coco set in "
            "its train split, neck at the shoulders' midpoint and raised 0.2 toward the "
            "head top, and their mirror images (932)",
            f"CMU Graphics Lab Motion Capture Database (http://mocap.cs.cmu.edu): {n // 2} "
            "poses drawn (seed 0) from the benchmarks' CMU training set (sparseedm "
            "dataset build ../shared/data/cmu-mocap --seed 0: every clip, virtual "
            "cameras) and their mirror images"]}
    save_npz(path, {"poses": poses, "photographed": bank.photographed, "joint_names": np.array(SKELETON_14.joint_names),
                    "meta": np.array(json.dumps(meta))}, compressed=True)
    print(f"wrote {path}: {len(poses)} poses", flush=True)


def answers(cold, given, missing, bank_sets, neighbours, gates=GATES):
    """{method: filled}: the cold answer, each bank's (per `neighbours` and
    gate) and their seconds."""
    out, seconds = {"cold": cold}, {}
    for name, bank in bank_sets.items():
        for k in neighbours:
            for g in gates:
                key = f"{name} k{k} gate{g:g}"
                t0 = time.perf_counter()
                out[key] = bank_fill(bank, given, missing, neighbours=k, gate=g)
                seconds[key] = time.perf_counter() - t0
    return out, seconds


def pose_errors(fills, truth, missing):
    """{method[ w]: per-pose error}: the cold answer, each bank's alone and
    stacked with the cold one at each of :data:`WEIGHTS`."""
    cold = fills["cold"]
    out = {"cold": scd.per_pose(cold, truth, missing)}
    for key, f in fills.items():
        if key == "cold":
            continue
        f = np.where(np.isfinite(f), f, cold)
        for w in WEIGHTS[1:]:
            out[f"{key} w{w}"] = scd.per_pose(w * f + (1 - w) * cold, truth, missing)
    return out


def cached_cold(path, dictionary, truth, missing):
    """recover(adapt=False) of the rows (the cold prior, or `dictionary`'s
    mirror="auto" answer), kept in `path`: (filled, seconds)."""
    import sparseedm

    if path is not None and path.exists():
        with np.load(path, allow_pickle=False) as z:
            return z["filled"], float(z["seconds"])
    given = np.where(missing[..., None], np.nan, truth)
    t0 = time.perf_counter()
    if dictionary is None:
        filled = sparseedm.recover(given, missing, adapt=False).poses
    else:
        filled = scd.cold(dictionary, truth, missing)["auto"]
    seconds = time.perf_counter() - t0
    if path is not None:
        np.savez(path, filled=filled, seconds=seconds)
    return filled, seconds


def photo_file(source, protocol, seed, rs, train_complete, cache):
    """(truth, missing, II errors {file: per-pose}) of one photo file's occluded
    poses (II's errors kept in `cache`)."""
    truth, missing = harness.make_file(source, protocol, seed, realset=rs)
    occ = missing.any(axis=1)
    path = cache and cache / f"ii {source} {protocol} {seed}.npz"
    if path is not None and path.exists():
        with np.load(path, allow_pickle=False) as z:
            return truth[occ], missing[occ], {k.replace("_", "+"): z[k] for k in z.files}
    ii = {source: scd.per_pose(harness.iterative(truth, missing)[occ], truth[occ],
                               missing[occ])}
    if train_complete is not None:
        extra = train_complete[np.random.default_rng([seed, 7]).choice(
            len(train_complete), 1000, replace=False)]
        t2 = np.concatenate([truth, extra])
        m2 = np.concatenate([missing, np.zeros((len(extra), 14), bool)])
        ii[f"{source}+1000"] = scd.per_pose(harness.iterative(t2, m2)[:len(truth)][occ],
                                            truth[occ], missing[occ])
    if path is not None:
        np.savez(path, **{k.replace("+", "_"): v for k, v in ii.items()})
    return truth[occ], missing[occ], ii


def run_photos(seeds, cache, bank_names, neighbours, sources=("mpii", "coco-val", "bonn")):
    """Per-pose rows of the photo files: {file protocol: {"hidden", method: errors}}."""
    bank_sets = banks(bank_names)
    rows, speed = {}, {"cold": 0.0, "poses": 0}
    for source in sources:
        rs = real2d.load(harness.FILES[source][0])
        train = None
        if source == "mpii":
            t = rs.take(real2d.split(rs) == "train")
            train = t.poses[t.complete & (real2d.body_size(t.poses) > 0)]
        for protocol in harness.PROTOCOLS:
            for seed in range(seeds):
                truth, missing, ii = photo_file(source, protocol, seed, rs, train, cache)
                given = np.where(missing[..., None], np.nan, truth)
                cold, sec = cached_cold(cache and cache / f"photo {source} {protocol} {seed}.npz",
                                        None, truth, missing)
                fills, seconds = answers(cold, given, missing, bank_sets, neighbours)
                errs = pose_errors(fills, truth, missing)
                speed["cold"] += sec
                speed["poses"] += len(truth)
                for k, s in seconds.items():
                    speed[k] = speed.get(k, 0.0) + s
                for name, e in ii.items():
                    row = rows.setdefault(f"{name} {protocol}", {})
                    for key, val in {"hidden": missing.sum(axis=1), "iterative": e,
                                     **errs}.items():
                        row.setdefault(key, []).append(val)
                print(source, protocol, seed, f"cold {errs['cold'].mean():.2f}",
                      f"ii {ii[source].mean():.2f}", flush=True)
    return {f: {k: np.concatenate(v) for k, v in r.items()} for f, r in rows.items()}, speed


def pooled(e, h):
    """Mean error per hidden joint of per-pose errors `e` with hidden counts `h`."""
    return float((e * h).sum() / h.sum())


def by_count(row, method, weights):
    """Per-pose errors of `method` (a bank's key) stacked at a weight per group of
    hidden counts (`weights`: one per :data:`GROUPS`)."""
    h = row["hidden"]
    out = row["cold"].copy()
    for (lo, hi), w in zip(GROUPS, weights):
        sel = (h >= lo) & (h <= hi)
        if w > 0:
            out[sel] = row[f"{method} w{w}"][sel]
    return out


def choose_weights(rows, method, files, guard=True):
    """Per group of hidden counts, the weight of the least pooled error over `files`
    (each file's error relative to its cold error, so every file counts alike);
    with `guard`, among the weights that leave no source (a file's name before
    its protocol) worse than the cold answer by more than one standard error
    of the paired difference over its poses in the group."""
    chosen = []
    for lo, hi in GROUPS:
        best, arg = np.inf, 0.0
        for w in WEIGHTS:
            key = "cold" if w == 0 else f"{method} w{w}"
            total, diffs = 0.0, {}
            for f in files:
                r = rows[f]
                sel = (r["hidden"] >= lo) & (r["hidden"] <= hi)
                if not sel.any():
                    continue
                total += pooled(r[key][sel], r["hidden"][sel]) / pooled(
                    r["cold"][sel], r["hidden"][sel])
                diffs.setdefault(f.rsplit(" ", 1)[0], []).append(r[key][sel] - r["cold"][sel])
            harm = [np.concatenate(d) for d in diffs.values()]
            if guard and w > 0 and any(len(d) > 1 and d.mean() > d.std(ddof=1) / np.sqrt(
                    len(d)) for d in harm):
                continue
            if total < best - 1e-12:
                best, arg = total, w
        chosen.append(arg)
    return chosen


def photo_summary(rows, methods):
    """{file protocol: {method: error, ratio, paired, se}}: `methods` {name: per-pose fn}."""
    out = {}
    for f, r in rows.items():
        h, ii = r["hidden"], pooled(r["iterative"], r["hidden"])
        out[f] = {"iterative": round(ii, 3)}
        for name, fn in methods.items():
            e = fn(r)
            d = e - r["cold"]
            out[f][name] = {"error": round(pooled(e, h), 3),
                            "ratio": round(pooled(e, h) / ii, 3),
                            "paired": round(float(d.mean()), 3),
                            "se": round(float(d.std(ddof=1) / np.sqrt(len(d))), 3)}
    return out


def run_mocap(parts, daz, per_clip, cache, bank_names, neighbours):
    """{part: rows} of the control: cold over cmu-k2000+coco, banks of COCO and CMU
    subjects 01-03; a row per clip: its poses and, per method and weight, the sum
    of its per-pose errors in each group of hidden counts."""
    dic = coco_prior.build("cmu-k2000", mirror=True, necks=(0.0, 0.2))
    bank_sets = banks(bank_names, scd.OWN_SUBJECTS)
    out = {}
    for part, data in scd.mocap_sets(parts, daz).items():
        rows = []
        for clip, group, protocol, truth, missing in scd.clip_files(*data, per_clip, ("mix",)):
            key = f"mocap {part} {clip} {protocol}".replace("/", "_")
            cold, _ = cached_cold(cache and cache / f"{key}.npz", dic, truth, missing)
            given = np.where(missing[..., None], np.nan, truth)
            fills, _ = answers(cold, given, missing, bank_sets, neighbours)
            h = missing.sum(axis=1)
            rows.append({"file": clip, "group": str(group), "protocol": protocol,
                         "poses": len(truth), "sums": {
                             m: [float(e[(h >= lo) & (h <= hi)].sum()) for lo, hi in GROUPS]
                             for m, e in pose_errors(fills, truth, missing).items()}})
        out[part] = rows
        print(part, len(rows), "clips", flush=True)
    return out


def mocap_summary(rows, weights):
    """{clips, subjects, cold, paired {bank key: vs cold}} of one part's rows with each
    bank stacked at its per-group `weights`."""
    def clip_mean(r, key, ws):
        return sum(r["sums"]["cold" if w == 0 else f"{key} w{w}"][g]
                   for g, w in enumerate(ws)) / r["poses"]

    flat = [{"file": r["file"], "group": r["group"],
             "cold": sum(r["sums"]["cold"]) / r["poses"],
             **{k: clip_mean(r, k, ws) for k, ws in weights.items()},
             **{f"{k} alone": clip_mean(r, k, [1.0] * len(GROUPS)) for k in weights}}
            for r in rows]
    keys = [k for k in flat[0] if k not in ("file", "group", "cold")]
    return {"clips": len(flat), "subjects": len({r["group"] for r in flat}),
            "cold": round(float(np.mean([r["cold"] for r in flat])), 3),
            "paired": {k: scd.paired_files(flat, k, "cold") for k in keys}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="photos", help="photos, cmu-others, daz")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--sources", default="mpii,coco-val,bonn", help="photo files")
    ap.add_argument("--banks", default=",".join(BANKS))
    ap.add_argument("--neighbours", default="100")
    ap.add_argument("--daz", type=Path)
    ap.add_argument("--per-clip", type=int, default=30)
    ap.add_argument("--cache", type=Path)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--ship", type=Path, help="write the bank --bank as a pose bank file and stop")
    ap.add_argument("--bank", default="coco+cmu6000", help="--ship's bank")
    a = ap.parse_args(argv)
    if a.ship:
        ship(a.ship, a.bank)
        return
    if a.cache:
        a.cache.mkdir(parents=True, exist_ok=True)
    doc = load_results(a.out) if a.out and a.out.exists() else {}  # null as NaN: summed below
    names, ks = a.banks.split(","), [int(k) for k in a.neighbours.split(",")]
    keys = [f"{b} k{k} gate{g:g}" for b in names for k in ks for g in GATES]
    parts = a.part.split(",")
    if "photos" in parts:
        rows, speed = run_photos(a.seeds, a.cache, names, ks, a.sources.split(","))
        choose_on = [f for f in rows if not f.startswith("mpii+1000")]
        weights = {k: choose_weights(rows, k, choose_on) for k in keys}
        methods = {"cold": lambda r: r["cold"]}
        for k in keys:
            methods[f"{k} alone"] = lambda r, k=k: r[f"{k} w1.0"]
            methods[f"{k} by count"] = lambda r, k=k: by_count(r, k, weights[k])
        doc["photos"] = {"seeds": a.seeds, "groups": GROUPS, "weights": weights,
                         "speed": {"poses": speed["poses"],
                                   **{k: round(speed["poses"] / v, 1)
                                      for k, v in speed.items() if k != "poses"}},
                         "files": photo_summary(rows, methods)}
        print(json.dumps(doc["photos"]["weights"]), json.dumps(doc["photos"]["speed"]))
    mocap = [p for p in parts if p not in ("photos", "none")]
    if mocap:
        doc.setdefault("mocap_rows", {"per_clip": a.per_clip}).update(
            run_mocap(mocap, a.daz, a.per_clip, a.cache, names, ks))
    if "photos" in doc and "mocap_rows" in doc:
        weights = doc["photos"]["weights"]
        doc["mocap"] = {part: mocap_summary(rows, {k: w for k, w in weights.items()
                                                   if f"{k} w1.0" in rows[0]["sums"]})
                        for part, rows in doc["mocap_rows"].items() if part != "per_clip"}
        print(json.dumps(doc["mocap"], indent=1))
    if a.out:
        a.out.write_text(json_text(doc, indent=1) + "\n")
    print(table(doc))


def table(doc):
    """Markdown: ratio to IterativeImputer per file (1 / 2 / 3 / real) per method."""
    files = doc.get("photos", {}).get("files", {})
    if not files:
        return ""
    names = list(dict.fromkeys(f.rsplit(" ", 1)[0] for f in files))
    methods = [m for m in next(iter(files.values())) if m != "iterative"]
    lines = ["| method | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for m in methods:
        cells = [" / ".join(f"{files[f'{n} {p}'][m]['ratio']:.2f}" for p in harness.PROTOCOLS)
                 for n in names]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
