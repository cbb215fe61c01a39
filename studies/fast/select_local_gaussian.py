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

from sparseedm._atomic import json_text

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
    """--oracle: per candidate Gaussian G, the ratio to II of (1 - w) before + w G per
    weight w; for the shipped one also with the best weight per number of hidden
    joints (``per k``)."""
    from sparseedm.exemplars import LINEAR_WEIGHTS
    from sparseedm.file_atoms import mirror_images
    from sparseedm.gaussian_fill import file_gaussian, local_gaussian_fill
    from studies.fast.select_photo_atoms import iterative
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    before, answer = _before(given, missing, kw)
    before = before[occ]
    cache = CACHE / f"{_key(name)}.npz"
    if cache.exists():
        with np.load(cache) as z:
            ii_poses = z["iterative"]
    else:
        ii_poses = iterative(given, missing)[occ]
    complete, g, m, t = truth[~occ], given[occ], missing[occ], truth[occ]
    ii = per_pose(ii_poses, t, m).mean()
    draws = mirror_images(file_gaussian(complete, g, m, augment=mirror_images)[1])
    cands = {"one Gaussian": file_gaussian(complete, g, m)[0],
             "with mirror images": file_gaussian(complete, g, m, augment=mirror_images)[0],
             "local (shipped: 100, 50)": local_gaussian_fill(draws, g, m)}
    for k, prior in ((50, 25), (100, 20), (200, 100)):
        cands[f"local ({k}, {prior})"] = local_gaussian_fill(draws, g, m, neighbours=k,
                                                            prior=prior)
    out = {"before / II": round(float(per_pose(before, t, m).mean() / ii), 4)}
    for key, v in cands.items():
        out[key] = [round(float(per_pose((1 - w) * before + w * v, t, m).mean() / ii), 4)
                    for w in LINEAR_WEIGHTS]
    v, hidden = cands["local (shipped: 100, 50)"], m.sum(axis=1)
    best = before.copy()
    for k in np.unique(hidden):
        r = hidden == k
        w = min(LINEAR_WEIGHTS, key=lambda w: per_pose((1 - w) * before[r] + w * v[r], t[r],
                                                       m[r]).mean())
        best[r] = (1 - w) * before[r] + w * v[r]
    out["local per k"] = round(float(per_pose(best, t, m).mean() / ii), 4)
    w = _probe_weight(truth, missing, answer)
    out["local, probe weight"] = [w, round(float(per_pose((1 - w) * before + w * v, t, m).mean()
                                                 / ii), 4)]
    return out


def variants(name, truth, missing, photo, kw):
    """--variants: other candidates beside the shipped local Gaussian (best weight,
    ratio to II), and where its stacked answer (w = 0.75) loses to II: per joint and
    per number of hidden joints."""
    import itertools

    from sparseedm.exemplars import LINEAR_WEIGHTS, _linear_draws
    from sparseedm.gaussian_fill import local_gaussian_fill
    from sparseedm.real_protocol import body_size
    from studies.fast.select_global_linear import file_linear
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    before = _before(given, missing, kw)[0][occ]
    with np.load(CACHE / f"{_key(name)}.npz") as z:
        ii_poses = z["iterative"]
    complete, g, m, t = truth[~occ], given[occ], missing[occ], truth[occ]
    ii = per_pose(ii_poses, t, m).mean()
    draws = _linear_draws(complete, g, m)
    local = local_gaussian_fill(draws, g, m)

    def best(v):
        return round(min(float(per_pose((1 - w) * before + w * v, t, m).mean() / ii)
                         for w in LINEAR_WEIGHTS), 4)

    out = {"local (shipped)": best(local),
           "local, rotated copies +-10 degrees": best(local_gaussian_fill(
               np.concatenate([draws, _rotated(draws, 10), _rotated(draws, -10)]), g, m)),
           "10 nearest draws' mean": best(_nearest_mean(draws, g, m, 10))}
    raw = file_linear(complete, g, m, "raw", 0.01)
    grid = [np.array(w) / 4 for w in itertools.product(range(5), repeat=3) if sum(w) == 4]
    out["local + a Gaussian in pixels (3 weights)"] = round(min(
        float(per_pose(w[0] * before + w[1] * local + w[2] * raw, t, m).mean() / ii)
        for w in grid), 4)
    stacked = 0.25 * before + 0.75 * local
    err = np.linalg.norm(stacked - t, axis=-1) / body_size(t)[:, None]
    err_ii = np.linalg.norm(ii_poses - t, axis=-1) / body_size(t)[:, None]
    out["per joint / II"] = [round(float(err[m[:, j], j].mean() / err_ii[m[:, j], j].mean()), 3)
                             for j in range(m.shape[1])]
    hidden = m.sum(axis=1)
    out["per hidden count / II"] = {
        int(k): round(float(per_pose(stacked[hidden == k], t[hidden == k], m[hidden == k]).mean()
                            / per_pose(ii_poses[hidden == k], t[hidden == k],
                                       m[hidden == k]).mean()), 3) for k in np.unique(hidden)}
    return out


def _rotated(poses, degrees):
    """`poses` turned by `degrees` about their centroids."""
    a = np.deg2rad(degrees)
    turn = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    centre = poses.mean(axis=1, keepdims=True)
    return (poses - centre) @ turn.T + centre


def _nearest_mean(draws, poses, missing, k):
    """Each pose's hidden joints: the mean of its `k` nearest draws' (in the frame
    of its observed joints, by those joints), one missing pattern at a time."""
    from sparseedm.normalize import rms_radius

    out = poses.copy()
    patterns, which = np.unique(missing, axis=0, return_inverse=True)
    for i, pattern in enumerate(patterns):
        rows = np.flatnonzero(np.ravel(which) == i)
        c, r = rms_radius(draws, np.broadcast_to(pattern, draws.shape[:2]))
        z = (draws - c[:, None]) / r[:, None, None]
        q = np.where(pattern[:, None], 0.0, poses[rows])
        cq, rq = rms_radius(q, np.broadcast_to(pattern, q.shape[:2]))
        zq = (q - cq[:, None]) / rq[:, None, None]
        d = ((zq[:, None, ~pattern] - z[None, :, ~pattern]) ** 2).sum(axis=(-1, -2))
        d = np.where(d > 1e-12, d, np.inf)  # the pose itself among the draws
        near = np.argsort(d, axis=1)[:, :k]
        fill = z[near].mean(axis=1) * rq[:, None, None] + cq[:, None]
        out[rows] = np.where(pattern[:, None], fill, poses[rows])
    return out


def _before(given, missing, kw):
    """recover()'s answer without the stacked mean (all rows), and the path's
    answer for other rows (donor_step's `answer`, caught on its way)."""
    import sparseedm
    import sparseedm.exemplars as ex
    import sparseedm.recovery

    caught = {}
    kept = sparseedm.recovery.donor_step, ex.linear_stack, ex.linear_weight

    def catch(res, poses, missing_, answer, *a, **k):
        caught["answer"] = answer
        return kept[0](res, poses, missing_, answer, *a, **k)

    sparseedm.recovery.donor_step = catch
    ex.linear_stack, ex.linear_weight = (lambda *a: None), (lambda *a: (0.0, float("nan")))
    try:
        return sparseedm.recover(given, missing, n_jobs=1, **kw).poses, caught["answer"]
    finally:
        sparseedm.recovery.donor_step, ex.linear_stack, ex.linear_weight = kept


def _probe_weight(truth, missing, answer, n=300, seed=0):
    """The weight of the local Gaussian chosen on probes: occluded rows with one more
    observed joint hidden (as donors.donor_step draws them), answered by the path and
    by the Gaussian of the file with those rows so hidden; the lowest error on the
    probe joints."""
    from sparseedm.exemplars import LINEAR_WEIGHTS, _linear_draws
    from sparseedm.gaussian_fill import local_gaussian_fill
    from sparseedm.normalize import rms_radius

    rng = np.random.default_rng([seed, 91])
    cand = np.flatnonzero(missing.any(1) & ((~missing).sum(1) > 6))
    rows = np.sort(rng.permutation(cand)[:n])
    joints = np.array([rng.choice(np.flatnonzero(~missing[r])) for r in rows], int)
    hidden = missing.copy()
    hidden[rows, joints] = True
    occ = missing.any(axis=1)
    given = np.where(hidden[..., None], np.nan, truth)
    path = answer(given[rows], hidden[rows]).poses
    fill = local_gaussian_fill(_linear_draws(truth[~occ], given[occ], hidden[occ]),
                               given[rows], hidden[rows])
    at = np.arange(len(rows)), joints
    _, size = rms_radius(truth[rows], hidden[rows])
    errors = [np.mean(np.linalg.norm(((1 - w) * path + w * fill)[at] - truth[rows][at], axis=-1)
                      / size) for w in LINEAR_WEIGHTS]
    return float(LINEAR_WEIGHTS[int(np.argmin(errors))])


def oracle_table(doc):
    """Markdown of --oracle: per file the best weight's ratio to II per candidate."""
    names = [k for k in next(iter(doc["files"].values())) if k != "before / II"]
    lines = ["| file | before / II | " + " | ".join(names) + " |",
             "|---|---:|" + "---:|" * len(names)]
    for name, r in doc["files"].items():
        cells = [f"{r[k][1]:.3f} (w {r[k][0]:g})" if k.endswith("probe weight") else
                 f"{min(r[k]):.3f}" if isinstance(r[k], list) else f"{r[k]:.3f}" for k in names]
        lines.append(f"| {name} | {r['before / II']:.3f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def timing(out, seed=0):
    """recover()'s seconds with the previous and the local Gaussian, alternated twice
    in one process, on the MPII val, MPII + 1,000 and Bonn + 1,000 files (mix
    masks; the load noted)."""
    import os

    import sparseedm
    from studies.fast.select_photo_atoms import photo_files

    made = [(n, t, m) for src, part in (("mpii", "split"), ("mpii", "train"), ("bonn", "train"))
            for n, t, m in photo_files(src, "val", part, seed=seed) if " mix " in n]
    doc = {"load": [], "files": {}}
    sparseedm.recover(made[0][1][:60], made[0][2][:60])  # compiled once
    for name, truth, missing in made:
        given = np.where(missing[..., None], np.nan, truth)
        row = {"previous": [], "local": []}
        for _ in range(2):
            for key in row:
                t0 = time.perf_counter()
                with previous() if key == "previous" else contextlib.nullcontext():
                    sparseedm.recover(given, missing, n_jobs=1)
                row[key].append(round(time.perf_counter() - t0, 2))
        doc["load"].append(round(os.getloadavg()[0], 1))
        doc["files"][name] = row
        print(name, row, doc["load"][-1], flush=True)
        out.write_text(json_text(doc, indent=1) + "\n")


def table(docs):
    """Markdown: per file (seeds pooled), previous's, local's and II's error, the
    paired difference, the weights."""
    return paired_table(docs, "previous", "local")


def paired_table(docs, base, arm):
    """Markdown: per file (seeds pooled), the `base` and `arm` candidates' and II's
    error, `arm` minus `base` (paired standard errors pooled over seeds), the weights."""
    rows = {}
    for doc in docs:
        for name, r in doc["files"].items():
            rows.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
    lines = [f"| file | seeds | weights ({base} / {arm}) | {base} | {arm} | {arm} - {base} "
             f"| II | {base} / II | {arm} / II |", "|---|---:|---|---:|---:|---:|---:|---:|---:|"]
    for name, rs in rows.items():
        d = np.array([r["candidates"][arm][f"minus_{base}"] for r in rs])
        prev = np.mean([r["candidates"][base]["mean"] for r in rs])
        loc = np.mean([r["candidates"][arm]["mean"] for r in rs])
        ii = [r["candidates"]["iterative"]["mean"] for r in rs if "iterative" in r["candidates"]]
        w = " ".join(f"{r['weights'][base]:g}/{r['weights'][arm]:g}" for r in rs)
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
    ap.add_argument("--variants", action="store_true",
                    help="other candidates; where the stacked answer loses to II")
    ap.add_argument("--timing", action="store_true", help="seconds, previous against local")
    ap.add_argument("--table", nargs="+", type=Path, help="print the pooled table, stop")
    ap.add_argument("--out", type=Path, default=Path("local_gaussian.json"))
    a = ap.parse_args(argv)
    if a.table:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        docs = [load_results(p) for p in a.table]
        print(oracle_table(docs[0]) if a.oracle else table(docs))
        return
    warnings.simplefilter("ignore")
    if a.timing:
        return timing(a.out)
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
            if a.oracle or a.variants:
                if not photo:
                    continue
                doc["files"][name] = (variants if a.variants else oracle)(name, truth, missing,
                                                                           photo, kw)
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
            a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
