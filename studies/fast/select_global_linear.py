"""A global linear candidate (one Gaussian over the file's poses) and stacking.

IterativeImputer, the photo protocols' strongest peer, is in effect a global
linear regression of the hidden coordinates on the observed ones, fitted on
the file. ``recover()``'s default path codes each occluded pose sparsely over
the file's complete poses (:mod:`sparseedm.exemplars`). Modes:

* ``--probe`` (MPII val, Bonn val + 1,000 train; random masks): ``G``, the
  conditional mean of the hidden joints under one Gaussian of the file's
  complete poses, the covariance shrunk by a ridge, in pixels (``raw``), in
  the frame of the observed joints (``radius``: their centroid and RMS
  radius, :mod:`sparseedm.gaussian_fill`) or similarity-aligned on them
  (``procrustes``); ``F``, the same refitted 3 times on the complete poses
  and the occluded ones as last filled; each alone and averaged with the
  defaults (``shipped``), IterativeImputer beside them;
* ``--replay``: stacking replayed with the default path's held-back check:
  convex weights in steps of 0.25 over the path's answer and ``F``
  (``stack2``), with the local ridge over base + file atoms (``stack3``),
  or per number of hidden joints (``stack2 per k``);
* default (end to end): ``recover()``'s defaults before the stacked mean
  (``before``: :func:`sparseedm.exemplars.linear_stack` answering None) and
  with it (``stacked``), IterativeImputer on the photo files; ``--mocap``:
  dataset files ``path[:dictionary]`` instead;
* ``--rule``: the check's weight under ``LINEAR_MIN_SE`` re-run on the end-to-end
  runs' files; ``--table`` (with ``--ruled``) pools them; ``--timing``.

Files: ``select_photo_blend.files`` (validation photo files; CMU held-out
clips and Daz files). Score: per occluded pose the mean error of its hidden
joints, % of body size; paired differences [mean, standard error]. Commands:
``studies/fast/README.md``.

    python studies/fast/select_global_linear.py --probe --out probe.json
    python studies/fast/select_global_linear.py --seeds 0 --daz daz_indian.npz --out seed0.json
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
from sparseedm._atomic import json_text  # noqa: E402

RIDGES = (0.001, 0.01)
FRAMES = ("raw", "radius", "procrustes")


def radius_frame(poses, observed):
    """(normalised poses, centre, radius): each pose shifted to its observed joints'
    centroid and divided by their RMS radius."""
    from sparseedm.normalize import rms_radius

    c, r = rms_radius(poses, np.broadcast_to(~observed, poses.shape[:-1]))
    return (poses - c[:, None]) / r[:, None, None], c, r


def _similarity(src, dst):
    """Per row: a (2x2 scaled rotation) and t with src @ a + t ~ dst (least squares),
    src, dst (n, k, 2)."""
    ms, md = src.mean(axis=1, keepdims=True), dst.mean(axis=1, keepdims=True)
    s, d = src - ms, dst - md
    # complex form: z_d ~ w z_s, w = sum conj(z_s) z_d / sum |z_s|^2
    zs = s[..., 0] + 1j * s[..., 1]
    zd = d[..., 0] + 1j * d[..., 1]
    w = (np.conj(zs) * zd).sum(axis=1) / (np.abs(zs) ** 2).sum(axis=1)
    a = np.stack([np.stack([w.real, w.imag], -1), np.stack([-w.imag, w.real], -1)], 1)
    t = md[:, 0] - np.einsum("nj,njk->nk", ms[:, 0], a)
    return a, t


def procrustes_frame(poses, observed, reference=None, iters=3):
    """(aligned poses, a, t, reference): each pose mapped by the similarity taking
    its observed joints onto `reference` (None: their generalised Procrustes mean
    over `poses`, of unit RMS radius)."""
    obs = poses[:, observed]
    fit_ref = reference is None
    if fit_ref:
        reference, _, _ = radius_frame(obs[:1], np.ones(obs.shape[1], bool))
        reference = reference[0]
    for _ in range(iters if fit_ref else 1):
        a, t = _similarity(obs, np.broadcast_to(reference, obs.shape))
        if fit_ref:
            m = (np.einsum("nij,njk->nik", obs, a) + t[:, None]).mean(axis=0)
            reference = radius_frame(m[None], np.ones(len(m), bool))[0][0]
    a, t = _similarity(obs, np.broadcast_to(reference, obs.shape))
    return np.einsum("nij,njk->nik", poses, a) + t[:, None], a, t, reference


def global_linear(complete, given, missing, frame="radius", ridge=0.01):
    """The filled poses: each missing pattern's poses given the conditional mean of
    their hidden joints under one Gaussian of `complete` in the pattern's frame
    (``"radius"``: :func:`sparseedm.gaussian_fill.gaussian_fill`, as shipped;
    ``"raw"``: pixel coordinates; ``"procrustes"``: similarity-aligned)."""
    from sparseedm.gaussian_fill import conditional_mean, gaussian_fill

    if frame == "radius":
        return gaussian_fill(complete, given, missing, ridge=ridge)
    out = given.copy()
    n, N = missing.shape
    pats, inv = np.unique(missing, axis=0, return_inverse=True)
    inv = np.ravel(inv)
    for k, pat in enumerate(pats):
        if not pat.any():
            continue
        rows = np.flatnonzero(inv == k)
        q = np.where(pat[:, None], 0.0, given[rows])
        cols = np.repeat(~pat, 2)
        if frame == "raw":
            back = conditional_mean(complete.reshape(len(complete), -1),
                                    q.reshape(len(rows), -1), cols, ridge).reshape(q.shape)
        else:
            Z, _, _, ref = procrustes_frame(complete, ~pat)
            zq, a, t, _ = procrustes_frame(q, ~pat, ref)
            filled = conditional_mean(Z.reshape(len(Z), -1), zq.reshape(len(rows), -1), cols,
                                      ridge).reshape(q.shape)
            back = np.einsum("nij,njk->nik", filled - t[:, None], np.linalg.inv(a))
        out[rows] = np.where(pat[:, None], back, given[rows])
    return out


def file_linear(complete, given, missing, frame="radius", ridge=0.001, rounds=3):
    """global_linear refitted on the whole file: each round, the Gaussian fitted to
    the complete poses and the occluded ones as last filled, the occluded poses
    filled again (``"radius"``: :func:`sparseedm.gaussian_fill.file_gaussian`)."""
    from sparseedm.gaussian_fill import file_gaussian

    if frame == "radius":
        return file_gaussian(complete, given, missing, rounds=rounds, ridge=ridge)[0]
    filled = global_linear(complete, given, missing, frame, ridge)
    for _ in range(rounds):
        filled = global_linear(np.concatenate([complete, filled]), given, missing, frame, ridge)
    return filled


def measure(name, truth, missing, photo, ridges=RIDGES, frames=FRAMES):
    """One file: per candidate the per-pose errors of its occluded poses, seconds."""
    import sparseedm
    from studies.fast.select_photo_atoms import iterative
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    secs, got = {}, {}
    cache = Path("/tmp/stack/cache") / (name.replace(" ", "_").replace("/", "") + ".npz")
    if cache.exists():
        with np.load(cache) as z:
            got["shipped"], path, secs["shipped"] = z["poses"], str(z["path"]), float(z["secs"])
    else:
        t0 = time.perf_counter()
        res = sparseedm.recover(given, missing, n_jobs=2)
        secs["shipped"] = round(time.perf_counter() - t0, 2)
        got["shipped"] = res.poses[occ]
        path = res.adaptation.summary().get("path") if res.adaptation is not None else None
        cache.parent.mkdir(parents=True, exist_ok=True)
        np.savez(cache, poses=got["shipped"], path=str(path), secs=secs["shipped"])
    complete = truth[~occ]
    for frame in frames:
        for lam in ridges:
            name = f"G {frame} r={lam}"
            t0 = time.perf_counter()
            got[name] = global_linear(complete, given[occ], missing[occ], frame, lam)
            secs[name] = round(time.perf_counter() - t0, 2)
            got[f"avg(shipped, {name})"] = (got["shipped"] + got[name]) / 2
            if frame != "procrustes":
                name = f"F {frame} r={lam}"
                t0 = time.perf_counter()
                got[name] = file_linear(complete, given[occ], missing[occ], frame, lam)
                secs[name] = round(time.perf_counter() - t0, 2)
                got[f"avg(shipped, {name})"] = (got["shipped"] + got[name]) / 2
    icache = cache.with_suffix(".ii.npz")
    if photo and icache.exists():
        with np.load(icache) as z:
            got["iterative"], secs["iterative"] = z["poses"], float(z["secs"])
    elif photo:
        t0 = time.perf_counter()
        got["iterative"] = iterative(given, missing)[occ]
        secs["iterative"] = round(time.perf_counter() - t0, 2)
        np.savez(icache, poses=got["iterative"], secs=secs["iterative"])
    return path, secs, {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


def probe_files(seed):
    """MPII val (split) and Bonn + 1,000 train under mix masks."""
    from studies.fast.select_photo_atoms import photo_files

    for name, truth, missing in photo_files("mpii", "val", "split", seed=seed):
        if "mix" in name:
            yield f"{name} seed {seed}", truth, missing, True
    for name, truth, missing in photo_files("bonn", "val", "train", seed=seed):
        if "mix" in name:
            yield f"{name} seed {seed}", truth, missing, True


def main(argv=None):
    from studies.fast.select_photo_blend import paired

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--probe", action="store_true", help="the probe's candidates only")
    ap.add_argument("--replay", action="store_true",
                    help="the study's replay of stacking variants (else end to end)")
    ap.add_argument("--rule", nargs="+", type=Path,
                    help="end-to-end JSONs: the check's weight under LINEAR_MIN_SE per file")
    ap.add_argument("--ruled", nargs="*", type=Path, default=[],
                    help="with --table: --rule's JSONs, the weights the check now takes")
    ap.add_argument("--timing", action="store_true",
                    help="recover()'s seconds with and without the stacked mean")
    ap.add_argument("--table", nargs="+", type=Path,
                    help="print the end-to-end table pooled over these JSONs, stop")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--out", type=Path, default=Path("global_linear.json"))
    ap.add_argument("--sources", default="mpii,coco,bonn")
    ap.add_argument("--complete", default="1000")
    ap.add_argument("--mocap-sizes", default="200,1000")
    ap.add_argument("--train", type=int, default=1000)
    ap.add_argument("--occluded", type=int, default=1000)
    ap.add_argument("--daz", default="")
    ap.add_argument("--mocap", default="",
                    help="dataset .npz files, each path[:dictionary], comma-separated: "
                    "these files only (end to end)")
    a = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    if a.table:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        docs = [load_results(p) for p in a.table]
        rule = {}
        for p in a.ruled:
            rule.update(load_results(p))
        print(replay_table(docs[0]) if a.replay else shipped_table(docs, rule))
        return None
    if a.timing:
        return timing(a.out)
    if a.rule:
        return rule_main(a)
    if a.replay:
        return stack_main(a)
    if not a.probe:
        return shipped_main(a)
    doc = {"files": {}}
    for seed in (int(s) for s in a.seeds.split(",")):
        for name, truth, missing, photo in probe_files(seed):
            path, secs, errors = measure(name, truth, missing, photo)
            row = {"path": path, "seconds": secs, "n": int(len(errors["shipped"])),
                   "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                                      "minus_shipped": paired(e, errors["shipped"])}
                                  for k, e in errors.items()}}
            doc["files"][name] = row
            print(name, path, secs, flush=True)
            for k, v in row["candidates"].items():
                print(f"   {k:40s} {v['mean']:.3f}  {v['minus_shipped']}", flush=True)
            a.out.write_text(json_text(doc, indent=1) + "\n")



GRID = np.arange(5) / 4


def simplex(k):
    """Convex weights over k candidates in steps of 0.25."""
    import itertools

    return [np.array(w) / 4 for w in itertools.product(range(5), repeat=k) if sum(w) == 4]


def held_answers(base, given, missing, complete, path, seed=0, frame="radius", ridge=0.01):
    """On the check's held-back poses: (truth, mask, the shipped answer, F's, the local
    ridge's over base + atoms); None when the path has no check."""
    from sparseedm._recovery_base import combine
    from sparseedm._recovery_kernel import compiled_solver, recover_members
    from sparseedm.exemplars import (BLEND_MIN_POSES, FEW_MIN_POSES, HELD_FRACTION, MAX_HELD,
                                     blend_many_hidden, held_masks)
    from sparseedm.file_atoms import file_dictionary, with_file_atoms
    from studies.fast.select_ridge_check import held_errors, path_members, ridge as lridge

    n = len(complete)
    if n < FEW_MIN_POSES:
        return None
    held = np.zeros(n, bool)
    want = min(int(round(HELD_FRACTION * n)), MAX_HELD)
    held[np.random.default_rng([seed, 43]).choice(n, want, replace=False)] = True
    mask = held_masks(given, missing, want, seed)
    truth, rest = complete[held], complete[~held]
    members = path_members(base, rest, path)
    if members is None:
        return None
    hidden = np.where(mask[..., None], np.nan, truth)
    res = combine([recover_members(hidden, mask, [d], [], solver=compiled_solver(),
                                   check_input=False, n_jobs=2) for d in members])
    if len(rest) >= BLEND_MIN_POSES:
        res = blend_many_hidden(res, hidden, mask, file_dictionary(base, rest).dictionary,
                                n_jobs=2)
    r = lridge(with_file_atoms(base, rest).dictionary, hidden, mask)
    both = combine([res, r])
    a, b = held_errors(res, truth, mask), held_errors(both, truth, mask)
    ok = np.isfinite(a) & np.isfinite(b)
    shipped = both if b[ok].mean() < a[ok].mean() else res
    occ = missing.any(axis=1)
    f = file_linear(rest, np.concatenate([hidden, given[occ]]),
                    np.concatenate([mask, missing[occ]]), frame, ridge)[:len(truth)]
    return truth, mask, shipped.poses, f, r.poses


def stack_weights(truth, mask, cands, per_hidden=False):
    """The convex weights (steps of 0.25) of `cands` with the lowest held-back error
    (ties: the first in grid order, most weight on the first candidate)."""
    from studies.fast.select_ridge_check import held_errors

    class R:  # held_errors reads .poses and .ok
        def __init__(self, p):
            self.poses, self.ok = p, np.isfinite(p).all(axis=(1, 2))

    grid = sorted(simplex(len(cands)), key=lambda w: -w[0])
    errs = []
    for w in grid:
        e = held_errors(R(np.einsum("k,knjd->njd", w, np.stack(cands))), truth, mask)
        errs.append(np.nanmean(e))
    return grid[int(np.argmin(errs))], float(min(errs)), float(errs[0])


def measure_stack(name, base, truth, missing, photo, seed):
    """One file: shipped, F, their mean, the stacked answers (2 and 3 candidates),
    II; per-pose errors, the chosen weights, seconds."""
    import sparseedm
    from sparseedm.file_atoms import with_file_atoms
    from studies.fast.select_photo_blend import per_pose
    from studies.fast.select_ridge_check import ridge as lridge

    _, secs, errors = None, {}, {}
    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    path, s0, e0 = measure(name, truth, missing, photo, ridges=(0.01,), frames=())
    secs.update(s0)
    cache = Path("/tmp/stack/cache") / (name.replace(" ", "_").replace("/", "") + ".npz")
    with np.load(cache) as z:
        shipped = z["poses"]
    complete = truth[~occ]
    t0 = time.perf_counter()
    f = file_linear(complete, given[occ], missing[occ], "radius", 0.01)
    secs["F"] = round(time.perf_counter() - t0, 2)
    t0 = time.perf_counter()
    held = held_answers(base, given, missing, complete, path, seed)
    secs["held"] = round(time.perf_counter() - t0, 2)
    got = {"shipped": shipped, "F": f, "avg(shipped, F)": (shipped + f) / 2}
    weights = {}
    if held is not None:
        t0 = time.perf_counter()
        r = lridge(with_file_atoms(base, complete).dictionary, given[occ], missing[occ]).poses
        secs["R"] = round(time.perf_counter() - t0, 2)
        ht, hm, hs, hf, hr = held
        w2, _, _ = stack_weights(ht, hm, [hs, hf])
        w3, _, _ = stack_weights(ht, hm, [hs, hf, hr])
        weights = {"stack2": w2.tolist(), "stack3": w3.tolist()}
        got["stack2"] = w2[0] * shipped + w2[1] * f
        got["stack3"] = w3[0] * shipped + w3[1] * f + w3[2] * r
        # per number of hidden joints (1, 2, 3+), each its own weights
        hk = np.minimum(hm.sum(axis=1), 3)
        fk = np.minimum(missing[occ].sum(axis=1), 3)
        per = shipped.copy()
        for k in (1, 2, 3):
            rows = hk == k
            w = w2 if rows.sum() < 30 else stack_weights(ht[rows], hm[rows],
                                                          [hs[rows], hf[rows]])[0]
            weights[f"stack2 k={k}"] = w.tolist()
            per[fk == k] = w[0] * shipped[fk == k] + w[1] * f[fk == k]
        got["stack2 per k"] = per
    else:
        got["stack2"] = got["stack3"] = got["stack2 per k"] = shipped
    for k, v in got.items():
        errors[k] = per_pose(v, truth[occ], missing[occ])
    if "iterative" in e0:
        errors["iterative"] = e0["iterative"]
    return path, secs, errors, weights


def stack_main(a):
    import sparseedm
    from studies.fast.select_photo_blend import files, paired

    base = sparseedm.load_dictionary()
    doc = json.loads(a.out.read_text()) if a.out.exists() else {"files": {}}
    for seed in (int(s) for s in a.seeds.split(",")):
        a.seed = seed
        for name, truth, missing, photo in files(a):
            name = f"{name} seed {seed}" if "seed" not in name else name
            if name in doc["files"]:
                continue
            path, secs, errors, weights = measure_stack(name, base, truth, missing, photo, seed)
            row = {"path": path, "seconds": secs, "weights": weights,
                   "n": int(len(errors["shipped"])),
                   "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                                      "minus_shipped": paired(e, errors["shipped"])}
                                  for k, e in errors.items()}}
            doc["files"][name] = row
            print(name, path, secs, weights, flush=True)
            for k, v in row["candidates"].items():
                print(f"   {k:24s} {v['mean']:.3f}  {v['minus_shipped']}", flush=True)
            a.out.write_text(json_text(doc, indent=1) + "\n")



def without_linear(given, missing, **kw):
    """recover()'s defaults without the stacked mean with the Gaussian (the path
    before it: :func:`sparseedm.exemplars.linear_stack` answering None, and the
    check's :func:`sparseedm.exemplars.linear_weight` not run)."""
    import sparseedm
    import sparseedm.exemplars
    import sparseedm.recovery

    kept = sparseedm.exemplars.linear_stack, sparseedm.exemplars.linear_weight
    sparseedm.exemplars.linear_stack = lambda *a: None
    sparseedm.exemplars.linear_weight = lambda *a: (0.0, float("nan"))
    try:
        return sparseedm.recover(given, missing, n_jobs=2, **kw)
    finally:
        sparseedm.exemplars.linear_stack, sparseedm.exemplars.linear_weight = kept


def measure_shipped(name, truth, missing, photo, **kw):
    """One file, end to end: recover()'s defaults before (``before``, cached) and
    with the stacked mean (``stacked``), IterativeImputer (photos, cached)."""
    import sparseedm
    from studies.fast.select_photo_atoms import iterative
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    cache = Path("/tmp/stack/cache") / (name.replace(" ", "_").replace("/", "") + ".npz")
    cache.parent.mkdir(parents=True, exist_ok=True)
    got, secs = {}, {}
    if cache.exists():
        with np.load(cache) as z:
            got["before"], secs["before"] = z["poses"], float(z["secs"])
    else:
        t0 = time.perf_counter()
        res = without_linear(given, missing, **kw)
        secs["before"] = round(time.perf_counter() - t0, 2)
        got["before"] = res.poses[occ]
        path = res.adaptation.summary().get("path") if res.adaptation is not None else None
        np.savez(cache, poses=got["before"], path=str(path), secs=secs["before"])
    t0 = time.perf_counter()
    res = sparseedm.recover(given, missing, n_jobs=2, **kw)
    secs["stacked"] = round(time.perf_counter() - t0, 2)
    got["stacked"] = res.poses[occ]
    settings = res.adaptation.settings if res.adaptation is not None else {}
    path = res.adaptation.summary().get("path") if res.adaptation is not None else None
    icache = cache.with_suffix(".ii.npz")
    if photo and icache.exists():
        with np.load(icache) as z:
            got["iterative"], secs["iterative"] = z["poses"], float(z["secs"])
    elif photo:
        t0 = time.perf_counter()
        got["iterative"] = iterative(given, missing)[occ]
        secs["iterative"] = round(time.perf_counter() - t0, 2)
        np.savez(icache, poses=got["iterative"], secs=secs["iterative"])
    weight = settings.get("linear_weight", float("nan"))
    return path, weight, secs, {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


def mocap_files(a):
    """(name, truth, missing, False, recover() options) of --mocap's dataset files
    (``path[:dictionary]``), C complete + C Mix poses as mocap_check.py draws them."""
    from studies.fast.select_default_exemplars import mocap_file

    for item in a.mocap.split(","):
        path, _, dictionary = item.partition(":")
        for c in (int(x) for x in a.mocap_sizes.split(",") if x):
            truth, missing = mocap_file(path, c, c, a.seed)
            kw = {"dictionary": dictionary} if dictionary else {}
            yield (f"{Path(path).stem} {c}+{c} {dictionary or 'default'}",
                   np.asarray(truth, float), missing, False, kw)


def shipped_main(a):
    from studies.fast.select_photo_blend import files, paired

    doc = json.loads(a.out.read_text()) if a.out.exists() else {
        "score": "per occluded pose: % body size of its hidden joints; minus_before: "
                 "[mean, standard error] paired against recover()'s defaults without the "
                 "stacked mean", "files": {}}
    for seed in (int(s) for s in a.seeds.split(",")):
        a.seed = seed
        for name, truth, missing, photo, kw in (mocap_files(a) if a.mocap else
                                                ((*f, {}) for f in files(a))):
            name = f"{name} seed {seed}" if "seed" not in name else name
            if name in doc["files"]:
                continue
            path, weight, secs, errors = measure_shipped(name, truth, missing, photo, **kw)
            doc["files"][name] = {
                "path": path, "linear_weight": weight, "seconds": secs,
                "n": int(len(errors["before"])),
                "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                                   "minus_before": paired(e, errors["before"])}
                               for k, e in errors.items()}}
            print(name, path, weight, secs, {k: v["minus_before"] for k, v in
                                             doc["files"][name]["candidates"].items()},
                  flush=True)
            a.out.write_text(json_text(doc, indent=1) + "\n")


def timing(out):
    """recover()'s seconds with and without the stacked mean, alternated twice in
    one process, on four validation files (the load noted)."""
    import os

    import sparseedm
    from studies.fast.select_fast import validation_file
    from studies.fast.select_photo_atoms import photo_files

    made = [(n, t, m) for src, part in (("mpii", "split"), ("mpii", "train"), ("bonn", "train"))
            for n, t, m in photo_files(src, "val", part) if "mix" in n][:3]
    made.append(("cmu 2000 poses", *validation_file(2000, 0)))
    doc = {"load": [], "files": {}}
    sparseedm.recover(made[0][1][:60], made[0][2][:60])  # compiled once
    for name, truth, missing in made:
        given = np.where(missing[..., None], np.nan, truth)
        row = {"before": [], "stacked": []}
        for _ in range(2):
            for key, run in (("before", without_linear), ("stacked", sparseedm.recover)):
                t0 = time.perf_counter()
                run(given, missing, n_jobs=2) if key == "stacked" else run(given, missing)
                row[key].append(round(time.perf_counter() - t0, 2))
        doc["load"].append(round(os.getloadavg()[0], 1))
        doc["files"][name] = row
        print(name, row, doc["load"][-1], flush=True)
        out.write_text(json_text(doc, indent=1) + "\n")


def rule_main(a):
    """The check's weight under LINEAR_MIN_SE per file of --rule's JSONs (the
    end-to-end runs: weights without the rule), re-run by choose_exemplars."""
    import re

    import sparseedm
    from sparseedm.dictionary import load_dictionary
    from sparseedm.exemplars import choose_exemplars
    from studies.fast.select_photo_blend import files
    from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

    out = json.loads(a.out.read_text()) if a.out.exists() else {}
    runs = {n: r for p in a.rule for n, r in load_results(p)["files"].items()}
    for seed in (int(s) for s in a.seeds.split(",")):
        a.seed = seed
        made = mocap_files(a) if a.mocap else ((*f, {}) for f in files(a))
        for name, truth, missing, _, kw in made:
            name = f"{name} seed {seed}" if "seed" not in name else name
            if name not in runs or name in out or not np.isfinite(runs[name]["linear_weight"]):
                continue
            given = np.where(missing[..., None], np.nan, truth)
            base = load_dictionary(kw["dictionary"]) if kw else sparseedm.load_dictionary()
            check = choose_exemplars(base, given, missing)
            r = runs[name]
            out[name] = {"weight": r["linear_weight"], "ruled": check.linear_weight,
                         "stacked - before": r["candidates"]["stacked"]["minus_before"]}
            print(re.sub(r" \(.*\)", "", name), out[name], flush=True)
            a.out.write_text(json_text(out, indent=1) + "\n")


def replay_table(doc):
    """Markdown of a --replay JSON: per file, shipped's and II's error, each
    candidate's paired difference, the stacked weights."""
    cands = ("F", "avg(shipped, F)", "stack2", "stack3", "stack2 per k")
    lines = ["| file | shipped | II | " + " | ".join(cands) + " | weights (2 / 3) |",
             "|---|---:|---:|" + "---:|" * len(cands) + "---|"]
    for name, r in doc["files"].items():
        c = r["candidates"]
        ii = f"{c['iterative']['mean']:.2f}" if "iterative" in c else "-"
        cells = [f"{c[k]['minus_shipped'][0]:+.2f} ± {c[k]['minus_shipped'][1]:.2f}"
                 for k in cands]
        w = r["weights"]
        ws = (f"{'/'.join(f'{x:g}' for x in w['stack2'])} ; "
              f"{'/'.join(f'{x:g}' for x in w['stack3'])}" if w else "no check")
        lines.append(f"| {name} | {c['shipped']['mean']:.2f} | {ii} | " + " | ".join(cells)
                     + f" | {ws} |")
    return "\n".join(lines)


def ruled(doc, rule):
    """`doc` (an end-to-end JSON) as the check under LINEAR_MIN_SE answers: where
    `rule` (--rule's JSON) says weight 0, the stacked answer is the one before."""
    import copy

    doc = copy.deepcopy(doc)
    for name, r in doc["files"].items():
        if name in rule and rule[name]["ruled"] == 0 and r["linear_weight"] > 0:
            r["linear_weight"] = 0.0
            r["candidates"]["stacked"] = dict(r["candidates"]["before"])
        elif name in rule:
            assert rule[name]["ruled"] == r["linear_weight"], name  # else re-run the file
    return doc


def shipped_table(docs, rule=None):
    """Markdown: per file (seeds pooled), before's and II's error, the stacked
    mean's paired difference, the weights (`rule`: as :func:`ruled`). The runs'
    seconds are in the JSONs; --timing measures the cost."""
    import re

    rows = {}
    for doc in docs:
        for name, r in (ruled(doc, rule) if rule else doc)["files"].items():
            rows.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
    lines = ["| file | seeds | weights | before | II | stacked - before | stacked / II |",
             "|---|---:|---|---:|---:|---:|---:|"]
    for name, rs in rows.items():
        d = np.array([r["candidates"]["stacked"]["minus_before"] for r in rs])
        before = np.mean([r["candidates"]["before"]["mean"] for r in rs])
        stacked = np.mean([r["candidates"]["stacked"]["mean"] for r in rs])
        ii = [r["candidates"]["iterative"]["mean"] for r in rs if "iterative" in r["candidates"]]
        iis = f"{np.mean(ii):.2f}" if ii else "-"
        ratio = f"{stacked / np.mean(ii):.2f}" if ii else "-"
        w = "/".join("-" if not np.isfinite(r["linear_weight"]) else f"{r['linear_weight']:g}"
                     for r in rs)
        lines.append(f"| {name} | {len(rs)} | {w} | {before:.2f} | {iis} | "
                     f"{d[:, 0].mean():+.2f} ± {np.sqrt((d[:, 1] ** 2).sum()) / len(d):.2f} | "
                     f"{ratio} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
