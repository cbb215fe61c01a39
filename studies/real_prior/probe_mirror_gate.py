"""A per-pose gate on the mirror image's answer of the cold prior (``recover(adapt=False)``).

``recover(..., mirror=True)`` codes each pose over the dictionary and over
its mirror image (``Dictionary.mirrored()``) and averages the two answers:
on photos of real people that lowers the hidden joints' error, on motion
capture (which the default dictionary learned from) it raises it. This probe
asks whether the pose itself says which answer to trust: each pose's two
lasso objectives (the same observed entries, the same alpha; the objective
is the fit to the observed distances plus the code's penalty) decide the
mirror answer's weight ``w``, the returned joints being ``(1 - w) * own + w
* mirror``. Nothing is learned from the file. Gates, with ``r`` the mirror's
objective relative to the pose's own (``obj_m / obj_o - 1``):

* ``plain``: w = 0 (``mirror=False``); ``mean``: w = 1/2 (``mirror=True``);
* ``pick``: w = 1 where r < 0, else 0 (the lower objective's answer);
* ``soft T``: w = 1 / (1 + exp(r / T)) (1/2 at equal objectives);
* ``half T``: w = min(1/2, soft T's): never more mirror than the mean;
* ``gate K``: w = 1/2 where r <= K, else 0;
* ``choose D <gate>`` (both dictionaries): the union dictionary's
  (``cmu-coco-k2932``) answer with that mirror gate where its objective is
  below the default's by more than a fraction D (the COCO atoms fit the pose
  much better), else the default's own answer, no mirror.

``recover(mirror="auto")`` is ``half 0.05``.

Files (validation only): ``harness.py``'s photo files (``mpii``, ``coco-val``
with seeds 0..S-1, ``bonn`` seed 0; 1 / 2 / 3 hidden and real masks) and
mocap files of 100 complete + 500 Mix poses drawn as ``mocap_check.py``
draws them: the CMU training set (``benchmarks.load_cmu``: the poses the
default learned from), its clips held out by ``benchmarks.split_clips`` (held
out from ``cmu-k2000``; ``cmu-all-k2000`` learned from every CMU clip),
and ``--mocap`` dataset files (Daz Indian dance, Bandai-Namco-1: ``sparseedm
dataset build DIR --seed 0``). Per dictionary and gate: the mean error of the
hidden joints (% of body size) pooled over the seeds, its ratio to
IterativeImputer's (fitted on each file) and, per occluded pose, the paired
difference to ``plain`` of the default dictionary (mean, standard error).

    python studies/real_prior/probe_mirror_gate.py --mocap daz_indian.npz,bandai.npz \\
        --cache CACHE_DIR --out studies/real_prior/results_mirror_gate.json
    python studies/real_prior/probe_mirror_gate.py --photos "" --dictionaries cmu-k2000 \\
        --cmu-subjects 01,02,03 --mocap bandai.npz \\
        --out studies/real_prior/results_mirror_gate_k2000.json
    python studies/real_prior/probe_mirror_gate.py --benchmark \\
        --out studies/real_prior/results_mirror_gate_benchmark.json

(the second: ``cmu-k2000``, learned from CMU subjects 01-03, also on the CMU
training set's poses of those subjects and of the others; the third: the
photo files of ``python -m benchmarks.real_people --split val``,
``cmu-coco-k2932`` cold with ``mirror=True`` and ``mirror="auto"``.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import harness  # noqa: E402
from default_prior import per_pose  # noqa: E402
from probe_coco_atoms import mocap_file  # noqa: E402

from benchmarks import load_cmu, real2d, split_clips  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.metrics import occlusion_masks  # noqa: E402

REFERENCE = "default plain"
UNION = "cmu-coco-k2932"


def gates(temperatures=(0.02, 0.05, 0.1, 0.2), margins=(0.0, 0.02, 0.05, 0.1)):
    """{gate name: r -> mirror weight w}."""
    out = {"plain": lambda r: np.zeros_like(r), "mean": lambda r: np.full_like(r, 0.5),
           "pick": lambda r: (r < 0).astype(float)}
    for t in temperatures:
        out[f"soft {t}"] = lambda r, t=t: 1 / (1 + np.exp(np.clip(r / t, -50, 50)))
        out[f"half {t}"] = lambda r, t=t: np.minimum(0.5, 1 / (1 + np.exp(np.clip(r / t, -50, 50))))
    for k in margins:
        out[f"gate {k}"] = lambda r, k=k: np.where(r <= k, 0.5, 0.0)
    return out


def chosen(rows, objective, drops=(0.05, 0.1, 0.15, 0.2),
           union_gates=("plain", "half 0.05", "mean")):
    """{name: joints}: per pose the union dictionary's answer (with a mirror gate)
    where its objective is below the default's by more than a fraction D
    (``choose D <gate>``), else the default's own answer (no mirror)."""
    gain = np.nan_to_num(1 - objective[UNION] / objective["default"])
    out = {}
    for drop in drops:
        use = (gain > drop)[:, None, None]
        for gate in union_gates:
            out[f"choose {drop} {gate}"] = np.where(use, rows[f"{UNION} {gate}"],
                                                    rows["default plain"])
    return out


def answers(truth, missing, dictionary, cache=None):
    """(own joints, mirror joints, own objective, mirror objective) of the occluded rows
    (kept in the .npz `cache` when given)."""
    import sparseedm

    if cache is not None and cache.exists():
        with np.load(cache, allow_pickle=False) as z:
            return z["own"], z["mir"], z["obj_o"], z["obj_m"]

    occ = missing.any(axis=1)
    given = np.where(missing[occ][..., None], np.nan, truth[occ])
    out = []
    for d in (dictionary, dictionary.mirrored()):
        res = sparseedm.recover(given, missing[occ], dictionary=d, adapt=False)
        out.append(res)
    got = out[0].poses, out[1].poses, out[0].objective, out[1].objective
    if cache is not None:
        np.savez(cache, **dict(zip(("own", "mir", "obj_o", "obj_m"), got)))
    return got


def iterative(truth, missing, cache=None):
    """IterativeImputer fitted on the file (kept in `cache`.npz when given)."""
    path = cache and cache.with_name(f"{cache.name} iterative.npz")
    if path is not None and path.exists():
        with np.load(path, allow_pickle=False) as z:
            return z["filled"]
    filled = harness.iterative(truth, missing)
    if path is not None:
        np.savez(path, filled=filled)
    return filled


def run_file(truth, missing, dics, per, joints_acc, seconds, cache=None):
    """Accumulate per-pose errors and joint sums of IterativeImputer and every gate."""
    occ = missing.any(axis=1)
    t, m = truth[occ], missing[occ]
    size = real2d.body_size(t)[:, None]
    filled = iterative(truth, missing, cache)[occ]
    rows, objective = {"iterative": filled}, {}
    for name, d in dics.items():
        t0 = time.perf_counter()
        own, mir, obj_o, obj_m = answers(
            truth, missing, d, cache and cache.with_name(f"{cache.name} {name}.npz"))
        seconds[name] = seconds.get(name, 0.0) + time.perf_counter() - t0
        r = obj_m / obj_o - 1
        for gate, weight in gates().items():
            w = np.nan_to_num(weight(r))[:, None, None]
            rows[f"{name} {gate}"] = (1 - w) * own + w * mir
        per.setdefault("weights", {}).setdefault(name, []).append(r)
        objective[name] = obj_o
    if {"default", UNION} <= set(dics):
        rows.update(chosen(rows, objective))
        per.setdefault("gains", []).append(1 - objective[UNION] / objective["default"])
    for key, filled in rows.items():
        err = np.linalg.norm(filled - t, axis=-1) / size * 100
        acc = joints_acc.setdefault(key, [0.0, 0])
        acc[0] += float(err[m].sum())
        acc[1] += int(m.sum())
        per.setdefault(key, []).append(per_pose(filled, t, m))


def summary(per, joints_acc, reference=REFERENCE):
    """{key: error over the joints, ratio to IterativeImputer, paired vs `reference`}."""
    ii = joints_acc["iterative"][0] / joints_acc["iterative"][1]
    ref = np.concatenate(per[reference])
    out = {}
    for key, (s, n) in joints_acc.items():
        e = s / n
        diff = np.concatenate(per[key]) - ref
        out[key] = {"error": round(e, 3), "ratio": round(e / ii, 3),
                    "paired": round(float(diff.mean()), 3),
                    "se": round(float(diff.std(ddof=1) / np.sqrt(len(diff))), 3)}
    for name, rs in per["weights"].items():
        r = np.concatenate(rs)
        out[f"{name} r"] = {"median": round(float(np.nanmedian(r)), 4),
                            "mirror_lower": round(float(np.nanmean(r < 0)), 3)}
    if "gains" in per:
        g = np.concatenate(per["gains"])
        out["union gain r"] = {"quartiles": [round(float(q), 4) for q in
                                             np.nanpercentile(g, [25, 50, 75])]}
    return out


def mocap_files(paths, subjects=()):
    """(name, truth, missing) of the mocap files: CMU training, CMU held-out clips,
    with `subjects` the CMU poses of those subjects and of the others, `paths`."""
    poses, clips, cmu = load_cmu()
    held, _ = split_clips(clips)
    out = [("cmu-train", *mocap_file(cmu)), ("cmu-held-out", *drawn(poses[held]))]
    if subjects:
        of = np.isin(np.char.partition(clips.astype(str), "_")[:, 0], subjects)
        out += [(f"cmu subjects {','.join(subjects)}", *drawn(poses[of])),
                ("cmu other subjects", *drawn(poses[~of]))]
    out += [(Path(p).stem, *mocap_file(p)) for p in paths]
    return out


def drawn(poses, C=100, M=500, seed=0):
    """C complete + M Mix poses of `poses`, drawn as ``mocap_file`` draws a file's."""
    truth = poses[np.random.default_rng(seed).choice(len(poses), C + M, replace=False)]
    missing = np.zeros((C + M, 14), bool)
    missing[C:] = occlusion_masks(M, 14, ("mix",), seed)["mix"]
    return truth.astype(float), missing


def benchmark(sources=("mpii", "coco", "bonn")):
    """{source: {condition: {method: mean error}}}: the files of ``python -m
    benchmarks.real_people --split val``, cold with ``cmu-coco-k2932``, the mirror
    averaged and gated (``mirror="auto"``), IterativeImputer."""
    from benchmarks.real_people import photos

    methods = ["iterative", "sparseedm-no-adapt-mirror", "sparseedm-no-adapt-mirror-auto"]
    out = {}
    for source in sources:
        rep = photos(real2d.load(source), "val", (1000, 1000), 0, methods=methods,
                     dictionary=UNION)
        for r in rep.rows:
            if r["group"] == "overall":
                out.setdefault(source, {}).setdefault(r["condition"], {})[r["method"]] = round(
                    float(r["mean"]), 3)
        print(source, json.dumps(out[source]), flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photos", default="mpii,coco-val,bonn")
    ap.add_argument("--protocols", default=",".join(harness.PROTOCOLS))
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--mocap", default="", help="dataset .npz paths, comma-separated")
    ap.add_argument("--cmu-subjects", default="", help="also CMU files of these subjects' "
                    "poses and of the others' (comma-separated, e.g. 01,02,03)")
    ap.add_argument("--dictionaries", default="default,cmu-coco-k2932")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--cache", type=Path, help="folder keeping each file's answers (.npz)")
    ap.add_argument("--benchmark", action="store_true", help="instead, the benchmark's "
                    "photo files (real_people --split val), cmu-coco-k2932 cold")
    a = ap.parse_args(argv)
    if a.benchmark:
        doc = benchmark()
        if a.out:
            a.out.write_text(json_text(doc, indent=1) + "\n")
        return
    dics = {n: load_dictionary(None if n == "default" else n) for n in a.dictionaries.split(",")}
    doc, seconds = {}, {}

    def save():
        doc["seconds"] = {k: round(v, 1) for k, v in seconds.items()}
        if a.out:
            a.out.write_text(json_text(doc, indent=1) + "\n")

    subjects = tuple(filter(None, a.cmu_subjects.split(",")))
    for name, truth, missing in mocap_files(filter(None, a.mocap.split(",")), subjects):
        per, acc = {}, {}
        run_file(truth.astype(float), missing, dics, per, acc, seconds,
                 a.cache and a.cache / name)
        doc[name] = summary(per, acc, f"{next(iter(dics))} plain")
        print(name, json.dumps(doc[name]), flush=True)
        save()
    for name in filter(None, a.photos.split(",")):
        rs = real2d.load(harness.FILES[name][0])
        for protocol in a.protocols.split(","):
            per, acc = {}, {}
            for seed in range(1 if name == "bonn" else a.seeds):
                truth, missing = harness.make_file(name, protocol, seed, realset=rs)
                run_file(truth, missing, dics, per, acc, seconds,
                         a.cache and a.cache / f"{name} {protocol} {seed}")
            doc[f"{name} {protocol}"] = summary(per, acc, f"{next(iter(dics))} plain")
            print(name, protocol, json.dumps(doc[f"{name} {protocol}"]), flush=True)
            save()


if __name__ == "__main__":
    main()
