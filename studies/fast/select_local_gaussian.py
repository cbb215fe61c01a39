"""The stacked mean's Gaussian: one Gaussian of the file, or one per pose of its neighbours.

The default path averages every occluded pose's answer with the conditional
mean of its hidden joints under a Gaussian of the file's poses
(:func:`sparseedm.exemplars.linear_stack`, weighted by the held-back check's
:func:`sparseedm.exemplars.linear_weight`). Two Gaussians are compared, end to
end through ``recover()``'s defaults:

* ``previous``: one Gaussian of the file's complete poses and its incomplete
  ones as filled (:func:`sparseedm.gaussian_fill.file_gaussian`), each pose
  in the frame of the observed joints (:func:`~sparseedm.gaussian_fill.gaussian_fill`);
* ``local``: the same refits over the poses and their mirror images
  (:func:`sparseedm.file_atoms.mirror_images`), then per pose the Gaussian of
  the :data:`~sparseedm.gaussian_fill.LOCAL_NEIGHBOURS` draws nearest it on its
  observed joints shrunk toward the global one
  (:func:`~sparseedm.gaussian_fill.local_gaussian_fill`): what ships.

``--oracle`` instead measures, on the default path's answers without the
stacked mean (``before``), the error of ``(1 - w) before + w G`` for every
weight w of :data:`~sparseedm.exemplars.LINEAR_WEIGHTS` and candidate G (the
one Gaussian, with mirror images, the local Gaussian), as a ratio to
IterativeImputer's error: how far a better Gaussian, or a better weight, can
go.

Files: the validation photo files of ``benchmarks/real_people.py`` (MPII val,
MPII val + 1,000 train complete poses, COCO val, COCO val + 233 train, Bonn val
frames and Bonn + 1,000 train; ``mix``: 1-3 random hidden joints,
``transplanted``: real masks), and mocap dataset files ``path[:dictionary]``
(C complete + C Mix poses). Score: per occluded pose the mean error of its
hidden joints, % of body size; paired differences [mean, standard error].

    python studies/fast/select_local_gaussian.py --seeds 0,1,2 --out selection_local_gaussian.json
    python studies/fast/select_local_gaussian.py --seeds 0,1,2 --sources "" \\
        --mocap cmu_other_subjects.npz:cmu-k2000,daz_indian.npz --out selection_local_gaussian_mocap.json
    python studies/fast/select_local_gaussian.py --table selection_local_gaussian*.json
"""

from __future__ import annotations

import argparse
import contextlib
import json
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

CACHE = Path("/tmp/photos_local/cache")


@contextlib.contextmanager
def previous():
    """recover()'s stacked mean with one Gaussian of the file (no mirror images,
    no neighbours): the default path before the local Gaussian."""
    import sparseedm.exemplars as ex
    from sparseedm.gaussian_fill import file_gaussian, gaussian_fill

    def draws(complete, *given):
        return file_gaussian(complete, np.concatenate(given[::2]),
                             np.concatenate(given[1::2]))[1]

    kept = ex.local_gaussian_fill, ex._linear_draws
    ex.local_gaussian_fill, ex._linear_draws = gaussian_fill, draws
    try:
        yield
    finally:
        ex.local_gaussian_fill, ex._linear_draws = kept


def files(sources, parts, mocap, mocap_sizes, seed):
    """(name, truth, missing, photo, recover() options) of the files asked for."""
    from studies.fast.select_default_exemplars import mocap_file
    from studies.fast.select_photo_atoms import photo_files

    for part in parts:
        for name, truth, missing in photo_files(sources, "val", part, seed=seed):
            yield f"{name} seed {seed}", truth, missing, not name.startswith("bonn"), {}
    for item in filter(None, mocap.split(",")):
        path, _, dictionary = item.partition(":")
        for c in mocap_sizes:
            truth, missing = mocap_file(path, c, c, seed)
            yield (f"{Path(path).stem} {c}+{c} {dictionary or 'default'} seed {seed}",
                   np.asarray(truth, float), missing, False,
                   {"dictionary": dictionary} if dictionary else {})


def _key(name):
    return re.sub(r"[^A-Za-z0-9+,.-]+", "_", name)


def measure(name, truth, missing, photo, kw):
    """One file: per-pose errors of previous, local and II (photos), weights, seconds."""
    import sparseedm
    from studies.fast.select_photo_atoms import iterative
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    cache = CACHE / f"{_key(name)}.npz"
    got, secs, weights = {}, {}, {}
    if cache.exists():
        with np.load(cache) as z:
            got = {k: z[k] for k in z.files if k not in ("secs", "weights")}
            secs = dict(zip(("previous", "iterative"), z["secs"].tolist()))
            weights["previous"] = float(z["weights"])
    else:
        t0 = time.perf_counter()
        with previous():
            res = sparseedm.recover(given, missing, n_jobs=1, **kw)
        secs["previous"] = round(time.perf_counter() - t0, 2)
        got["previous"] = res.poses[occ]
        weights["previous"] = _weight(res)
        secs["iterative"] = np.nan
        if photo:
            t0 = time.perf_counter()
            got["iterative"] = iterative(given, missing)[occ]
            secs["iterative"] = round(time.perf_counter() - t0, 2)
        CACHE.mkdir(parents=True, exist_ok=True)
        np.savez(cache, **got, secs=[secs["previous"], secs["iterative"]],
                 weights=weights["previous"])
    t0 = time.perf_counter()
    res = sparseedm.recover(given, missing, n_jobs=1, **kw)
    secs["local"] = round(time.perf_counter() - t0, 2)
    got["local"] = res.poses[occ]
    weights["local"] = _weight(res)
    return secs, weights, {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


def _weight(res):
    settings = res.adaptation.settings if res.adaptation is not None else {}
    return float(settings.get("linear_weight", np.nan))


def oracle(name, truth, missing, photo, kw):
    """--oracle: per candidate Gaussian, the ratio to II of (1 - w) before + w G per w."""
    from sparseedm.exemplars import LINEAR_WEIGHTS
    from sparseedm.file_atoms import mirror_images
    from sparseedm.gaussian_fill import file_gaussian, local_gaussian_fill
    from studies.fast.select_global_linear import without_linear
    from studies.fast.select_photo_atoms import iterative
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    before = without_linear(given, missing, **kw).poses[occ]
    ii = per_pose(iterative(given, missing)[occ], truth[occ], missing[occ]).mean()
    complete, g, m = truth[~occ], given[occ], missing[occ]
    cands = {"one Gaussian": file_gaussian(complete, g, m)[0],
             "with mirror images": file_gaussian(complete, g, m, augment=mirror_images)[0]}
    draws = file_gaussian(complete, g, m, augment=mirror_images)[1]
    cands["local (shipped)"] = local_gaussian_fill(mirror_images(draws), g, m)
    out = {"before / II": round(float(per_pose(before, truth[occ], m).mean() / ii), 4)}
    for k, v in cands.items():
        out[k] = [round(float(per_pose((1 - w) * before + w * v, truth[occ], m).mean() / ii), 4)
                  for w in LINEAR_WEIGHTS]
    return out


def table(docs):
    """Markdown: per file (seeds pooled), previous's, local's and II's error, the
    paired difference, the weights."""
    rows = {}
    for doc in docs:
        for name, r in doc["files"].items():
            rows.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
    lines = ["| file | seeds | weights (previous / local) | previous | local | local - previous "
             "| II | previous / II | local / II |", "|---|---:|---|---:|---:|---:|---:|---:|---:|"]
    for name, rs in rows.items():
        d = np.array([r["candidates"]["local"]["minus_previous"] for r in rs])
        prev = np.mean([r["candidates"]["previous"]["mean"] for r in rs])
        loc = np.mean([r["candidates"]["local"]["mean"] for r in rs])
        ii = [r["candidates"]["iterative"]["mean"] for r in rs if "iterative" in r["candidates"]]
        w = " ".join(f"{r['weights']['previous']:g}/{r['weights']['local']:g}" for r in rs)
        cells = (f"{np.mean(ii):.2f} | {prev / np.mean(ii):.3f} | {loc / np.mean(ii):.3f}"
                 if ii else "- | - | -")
        lines.append(f"| {name} | {len(rs)} | {w} | {prev:.2f} | {loc:.2f} | "
                     f"{d[:, 0].mean():+.2f} ± {np.sqrt((d[:, 1] ** 2).sum()) / len(d):.2f} | "
                     f"{cells} |")
    return "\n".join(lines)


def main(argv=None):
    from studies.fast.select_photo_blend import paired

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--sources", default="mpii,coco,bonn")
    ap.add_argument("--parts", default="split,train",
                    help="where the complete poses come from: the split itself, train")
    ap.add_argument("--conditions", default="mix,transplanted")
    ap.add_argument("--mocap", default="", help="dataset files path[:dictionary], comma-separated")
    ap.add_argument("--mocap-sizes", default="200,1000")
    ap.add_argument("--oracle", action="store_true", help="the weights' and candidates' reach")
    ap.add_argument("--table", nargs="+", type=Path, help="print the pooled table, stop")
    ap.add_argument("--out", type=Path, default=Path("local_gaussian.json"))
    a = ap.parse_args(argv)
    if a.table:
        print(table([json.loads(p.read_text()) for p in a.table]))
        return
    warnings.simplefilter("ignore")
    doc = json.loads(a.out.read_text()) if a.out.exists() else {
        "score": "per occluded pose: % body size of its hidden joints; minus_previous: "
                 "[mean, standard error] paired against the stacked mean with one Gaussian",
        "files": {}}
    conditions = a.conditions.split(",")
    sizes = [int(x) for x in a.mocap_sizes.split(",") if x]
    for seed in (int(s) for s in a.seeds.split(",")):
        for name, truth, missing, photo, kw in files(a.sources, a.parts.split(","), a.mocap,
                                                     sizes, seed):
            if name in doc["files"] or (photo or name.startswith("bonn")) and not any(
                    f" {c} " in name for c in conditions):
                continue
            if a.oracle:
                if not photo:
                    continue
                doc["files"][name] = oracle(name, truth, missing, photo, kw)
                print(name, doc["files"][name], flush=True)
            else:
                secs, weights, errors = measure(name, truth, missing, photo, kw)
                doc["files"][name] = {
                    "seconds": secs, "weights": weights, "n": int(len(errors["local"])),
                    "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                                       "minus_previous": paired(e, errors["previous"])}
                                   for k, e in errors.items()}}
                print(name, secs, weights, {k: v["mean"] for k, v in
                                            doc["files"][name]["candidates"].items()},
                      doc["files"][name]["candidates"]["local"]["minus_previous"], flush=True)
            a.out.write_text(json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
