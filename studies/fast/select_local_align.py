"""The local Gaussian's draws turned to each pose, chosen again on the filled pose, or kernel-weighted.

The default path's stacked mean fills every occluded pose with the
conditional mean of its hidden joints under a Gaussian of the 100 draws (the
file's poses and their mirror images) nearest it on its observed joints, in
the frame of those joints (centroid and RMS radius: translation and scale,
not rotation), shrunk toward the Gaussian of every draw
(:func:`sparseedm.gaussian_fill.local_gaussian_fill`). Variants of it:

* ``align search`` / ``align fit``: every draw turned onto the pose (2D
  Procrustes on the observed joints in their frame, the angle
  ``atan2(sum cross, sum dot)``) before the nearest are chosen; ``fit``: the
  Gaussian fitted on the turned draws too (``search``: on the draws as they
  are). ``cap N``: the angle clipped to +-N degrees (the upright draws kept
  near upright);
* ``reselect W``: after the first fill, the neighbours chosen again by their
  distance to the whole filled pose (hidden joints weighted W, observed 1) and
  the Gaussian refitted (one pass);
* ``kernel K``: the 2K nearest draws weighted ``exp(-d^2 / 2 h^2)``, ``h`` the
  K-th nearest's distance, instead of the K nearest alike.

Turning the draws by their angle to the pose keeps a file rotated in the
image filled as rotated (the angles between poses do not change).

``--screen``: the Gaussian's own fill (no path), paired against the shipped
one, per file (fast). End to end (the default): ``recover()``'s defaults with
the variant in place of ``local_gaussian_fill`` against the shipped defaults,
II on the same files. Files: ``select_local_gaussian.py``'s (validation photo
files of ``benchmarks/real_people.py``, mocap dataset files). Score: per
occluded pose the mean error of its hidden joints, % of body size; paired
differences [mean, standard error].

    python studies/fast/select_local_align.py --screen --seeds 0,1,2 --sources mpii,coco \\
        --out selection_local_align_screen.json
    python studies/fast/select_local_align.py --seeds 0,1,2 --variant "align fit cap 45" \\
        --out selection_local_align.json
    python studies/fast/select_local_align.py --seeds 0,1,2 --sources "" --variant "align fit cap 45" \\
        --mocap cmu_other_subjects.npz:cmu-k2000,daz_indian.npz --out selection_local_align_mocap.json
    python studies/fast/select_local_align.py --table selection_local_align.json selection_local_align_mocap.json
"""

from __future__ import annotations

import argparse
import contextlib
import json
import re
import sys
import time
import warnings
from functools import partial
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from sparseedm._atomic import json_text  # noqa: E402

CACHE = Path("/tmp/photos_align/cache")

#: the screened variants (parsed by :func:`parse`)
VARIANTS = ("shipped", "align search", "align fit", "align search cap 45", "align fit cap 90",
            "align fit cap 45", "align fit cap 30", "align fit cap 20", "reselect 0.5",
            "reselect 0.25", "align fit cap 45 reselect 0.5", "kernel 100",
            "align fit cap 45 kernel 100", "align fit cap 45 reselect 0.5 kernel 100")


def parse(variant):
    """Keyword options of :func:`variant_fill` from a name of :data:`VARIANTS`."""
    words = variant.split()
    opts = {"align": None, "cap": None, "reselect": None, "kernel": None}
    for i, w in enumerate(words):
        if w == "align":
            opts["align"] = words[i + 1]
        elif w in ("cap", "reselect", "kernel"):
            opts[w] = float(words[i + 1])
    return opts


def variant_fill(train, poses, missing, *, align=None, cap=None, reselect=None, kernel=None,
                 neighbours=100, prior=50, ridge=0.01):
    """local_gaussian_fill's signature and frame, with the variant's options."""
    from sparseedm.gaussian_fill import _fill_by_pattern

    return _fill_by_pattern(train, poses, missing, partial(
        _means, neighbours=neighbours, prior=prior, ridge=ridge, align=align,
        cap=None if cap is None else np.deg2rad(cap), reselect=reselect, kernel=kernel))


def _perp(flat):
    """Each joint (x, y) of flat interleaved rows turned a quarter: (-y, x)."""
    out = np.empty_like(flat)
    out[:, 0::2], out[:, 1::2] = -flat[:, 1::2], flat[:, 0::2]
    return out


def _means(train, query, observed, neighbours, prior, ridge, align, cap, reselect, kernel):
    """_local_means with the variant's options (flat rows in one frame)."""
    mu = train.mean(axis=0)
    centred = train - mu
    cov = centred.T @ centred / max(len(train) - 1, 1)
    cov = cov + ridge * np.trace(cov) / len(cov) * np.eye(len(cov))
    obs, hid = np.flatnonzero(observed), np.flatnonzero(~observed)
    out = np.array(query, dtype=float)
    seen, perp = train[:, obs], _perp(train[:, obs])
    for s in range(0, len(out), 256):
        q = out[s:s + 256, obs]
        dot, cross = q @ seen.T, q @ perp.T
        theta = np.arctan2(cross, dot) if align else np.zeros_like(dot)
        if cap is not None:
            theta = np.clip(theta, -cap, cap)
        c, si = np.cos(theta), np.sin(theta)
        with np.errstate(invalid="ignore", over="ignore"):
            d = ((seen * seen).sum(1)[None] + (q * q).sum(1)[:, None]
                 - 2 * (c * dot + si * cross))
        d = np.where(d > 1e-12 * len(obs), d, np.inf)
        out[s:s + 256, hid] = _fit(train, q, d, c, si, obs, hid, mu, cov, neighbours, prior,
                                   align == "fit", kernel)
        if reselect is not None:
            full = out[s:s + 256]
            wcol = np.where(observed, 1.0, reselect)
            dot_w, cross_w = (full * wcol) @ train.T, (full * wcol) @ _perp(train).T
            with np.errstate(invalid="ignore", over="ignore"):
                d2 = ((train * train * wcol).sum(1)[None] + (full * full * wcol).sum(1)[:, None]
                      - 2 * (c * dot_w + si * cross_w))
            d2 = np.where(np.isfinite(d), d2, np.inf)
            out[s:s + 256, hid] = _fit(train, q, d2, c, si, obs, hid, mu, cov, neighbours,
                                       prior, align == "fit", kernel)
    return out


def _fit(train, q, d, c, si, obs, hid, mu, cov, neighbours, prior, turn, kernel):
    """The hidden columns' conditional mean per query row under its neighbours'
    Gaussian (turned by their angles when `turn`; kernel-weighted when `kernel`)."""
    k = int(min(kernel if kernel else neighbours, len(train)))
    m = min(2 * k, len(train)) if kernel else k
    near = np.argpartition(d, m - 1, axis=1)[:, :m]
    dn = np.take_along_axis(d, near, axis=1)
    w = np.isfinite(dn).astype(float)
    if kernel:
        h = np.partition(np.where(np.isfinite(dn), dn, np.inf), k - 1, axis=1)[:, k - 1:k]
        with np.errstate(invalid="ignore", over="ignore"):
            w = w * np.exp(-0.5 * np.where(np.isfinite(dn), dn, 0) / np.maximum(h, 1e-12))
    w = w[..., None]
    draws = train[near]
    if turn:
        cn = np.take_along_axis(c, near, axis=1)[..., None]
        sn = np.take_along_axis(si, near, axis=1)[..., None]
        x, y = draws[..., 0::2].copy(), draws[..., 1::2].copy()
        draws = np.empty_like(draws)
        draws[..., 0::2], draws[..., 1::2] = cn * x - sn * y, sn * x + cn * y
    counts = w.sum(axis=1)
    local = (w * draws).sum(axis=1) / np.maximum(counts, 1e-12)
    dev = np.sqrt(w) * (draws - local[:, None])
    scatter = np.matmul(dev.transpose(0, 2, 1), dev)
    mean = (counts * local + prior * mu) / (counts + prior)
    sigma = (scatter + prior * cov) / (counts + prior)[..., None]
    coef = np.linalg.solve(sigma[:, obs][:, :, obs], sigma[:, obs][:, :, hid])
    return mean[:, hid] + np.einsum("bo,boh->bh", q - mean[:, obs], coef)


@contextlib.contextmanager
def patched(variant):
    """recover()'s stacked mean with the variant in place of local_gaussian_fill
    (``shipped``: the local Gaussian chosen once, on the observed joints;
    ``default``: the package's as it is)."""
    import sparseedm.exemplars as ex

    kept = ex.local_gaussian_fill
    if variant != "default":
        ex.local_gaussian_fill = partial(variant_fill, **parse(variant))
    try:
        yield
    finally:
        ex.local_gaussian_fill = kept


def _key(name):
    return re.sub(r"[^A-Za-z0-9+,.-]+", "_", name)


def screen(name, truth, missing, variants, fill=None):
    """The Gaussian's own fill per variant (``fill(draws, poses, missing,
    variant)``, default :func:`variant_fill` of :func:`parse`'s options): mean
    error, paired against shipped."""
    from sparseedm.exemplars import _linear_draws
    from studies.fast.select_photo_blend import paired, per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    g, m, t = given[occ], missing[occ], truth[occ]
    draws = _linear_draws(truth[~occ], g, m)
    errs, secs = {}, {}
    for v in variants:
        t0 = time.perf_counter()
        filled = (variant_fill(draws, g, m, **parse(v)) if fill is None else
                  fill(draws, g, m, v))
        errs[v] = per_pose(filled, t, m)
        secs[v] = round(time.perf_counter() - t0, 2)
    return {v: {"mean": round(float(np.nanmean(e)), 4), "minus_shipped":
                paired(e, errs["shipped"]), "seconds": secs[v]} for v, e in errs.items()}


def measure(name, truth, missing, photo, kw, variant):
    """One file end to end: per-pose errors of the shipped defaults (cached), II
    (photos, cached) and the variant; weights; seconds."""
    import sparseedm
    from studies.fast.select_local_gaussian import _weight
    from studies.fast.select_photo_atoms import iterative
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    cache = CACHE / f"{_key(name)}.npz"
    got, secs, weights = {}, {}, {}
    if cache.exists():
        with np.load(cache) as z:
            got = {k: z[k] for k in z.files if k not in ("secs", "weights")}
            secs["shipped"], secs["iterative"] = z["secs"].tolist()
            weights["shipped"] = float(z["weights"])
    else:
        t0 = time.perf_counter()
        with patched("shipped"):
            res = sparseedm.recover(given, missing, n_jobs=1, **kw)
        secs["shipped"] = round(time.perf_counter() - t0, 2)
        got["shipped"], weights["shipped"] = res.poses[occ], _weight(res)
        secs["iterative"] = np.nan
        if photo:
            t0 = time.perf_counter()
            got["iterative"] = iterative(given, missing)[occ]
            secs["iterative"] = round(time.perf_counter() - t0, 2)
        CACHE.mkdir(parents=True, exist_ok=True)
        np.savez(cache, **got, secs=[secs["shipped"], secs["iterative"]],
                 weights=weights["shipped"])
    t0 = time.perf_counter()
    with patched(variant):
        res = sparseedm.recover(given, missing, n_jobs=1, **kw)
    secs["variant"] = round(time.perf_counter() - t0, 2)
    got["variant"], weights["variant"] = res.poses[occ], _weight(res)
    return secs, weights, {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


def timing(out, variants, seed=0):
    """recover()'s seconds on the MPII val file (mix masks) with each variant,
    alternated twice in one process (the load noted)."""
    import os

    import sparseedm
    from studies.fast.select_photo_atoms import photo_files

    name, truth, missing = next((n, t, m) for n, t, m in photo_files("mpii", "val", "split",
                                                                     seed=seed) if " mix " in n)
    given = np.where(missing[..., None], np.nan, truth)
    sparseedm.recover(given[:60], missing[:60])  # compiled once
    doc = {"file": f"{name} seed {seed}", "seconds": {v: [] for v in variants}, "load": []}
    for _ in range(2):
        for v in variants:
            t0 = time.perf_counter()
            with patched(v):
                sparseedm.recover(given, missing, n_jobs=1)
            doc["seconds"][v].append(round(time.perf_counter() - t0, 2))
        doc["load"].append(round(os.getloadavg()[0], 1))
    out.write_text(json_text(doc, indent=1) + "\n")
    print(doc)


def screen_table(docs, columns=None):
    """Markdown of --screen: per file (seeds pooled; the variants of every doc
    merged per draw) each variant's fill minus shipped (`columns`: those alone)."""
    merged = {}
    for doc in docs:
        for name, r in doc["files"].items():
            merged.setdefault(name, {}).update(r)
    rows = {}
    for name, r in merged.items():
        rows.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
    names = columns or [v for v in next(iter(rows.values()))[0] if v != "shipped"]
    lines = ["| file | seeds | shipped | " + " | ".join(names) + " |",
             "|---|---:|---:|" + "---:|" * len(names)]
    for name, rs in rows.items():
        cells = []
        for v in names:
            d = np.array([r[v]["minus_shipped"] for r in rs])
            cells.append(f"{d[:, 0].mean():+.2f} ± {np.sqrt((d[:, 1] ** 2).sum()) / len(d):.2f}")
        ship = np.mean([r["shipped"]["mean"] for r in rs])
        lines.append(f"| {name} | {len(rs)} | {ship:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def table(docs):
    """Markdown: per file (seeds pooled), shipped's, the variant's and II's error,
    the paired difference, the weights."""
    from studies.fast.select_local_gaussian import paired_table

    return paired_table(docs, "shipped", "variant")


def options(ap, variants, variant):
    """The arguments of this study's command line (shared with its siblings):
    `variants` --screen's default, `variant` the end-to-end one."""
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--sources", default="mpii,coco,bonn")
    ap.add_argument("--parts", default="split,train")
    ap.add_argument("--conditions", default="mix,transplanted")
    ap.add_argument("--mocap", default="", help="dataset files path[:dictionary], comma-separated")
    ap.add_argument("--mocap-sizes", default="200,1000")
    ap.add_argument("--screen", action="store_true", help="the Gaussian's own fill per variant")
    ap.add_argument("--variants", default=variants, help="--screen's")
    ap.add_argument("--variant", default=variant, help="end to end")
    ap.add_argument("--columns", default="", help="--screen --table: these variants alone")
    ap.add_argument("--table", nargs="+", type=Path, help="print the pooled table, stop")
    return ap


def run(a, screen_file, measure_file, sep=","):
    """The study's files (``a``: :func:`options`' arguments) screened
    (``screen_file(name, truth, missing, variants)``) or measured end to end
    (``measure_file(name, truth, missing, photo, kw, variant)``), written to
    ``a.out`` file by file (files already there skipped); --table: the table."""
    from studies.fast.select_local_gaussian import files
    from studies.fast.select_photo_blend import paired

    if a.table:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        docs = [load_results(p) for p in a.table]
        print(screen_table(docs, a.columns and a.columns.split(sep)) if a.screen else
              table(docs))
        return
    warnings.simplefilter("ignore")
    doc = json.loads(a.out.read_text()) if a.out.exists() else {
        "score": "per occluded pose: % body size of its hidden joints; minus_*: "
                 "[mean, standard error] paired", "variant": None if a.screen else a.variant,
        "files": {}}
    conditions = a.conditions.split(",")
    sizes = [int(x) for x in a.mocap_sizes.split(",") if x]
    for seed in (int(s) for s in a.seeds.split(",")):
        for name, truth, missing, photo, kw in files(a.sources, a.parts.split(","), a.mocap,
                                                     sizes, seed):
            if name in doc["files"] or (photo or name.startswith("bonn")) and not any(
                    f" {c} " in name for c in conditions):
                continue
            if a.screen:
                doc["files"][name] = screen_file(name, truth, missing, a.variants.split(sep))
                print(name, {v: r["minus_shipped"] for v, r in doc["files"][name].items()},
                      flush=True)
            else:
                secs, weights, errors = measure_file(name, truth, missing, photo, kw, a.variant)
                doc["files"][name] = {
                    "seconds": secs, "weights": weights, "n": int(len(errors["variant"])),
                    "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                                       "minus_shipped": paired(e, errors["shipped"])}
                                   for k, e in errors.items()}}
                print(name, secs, weights, {k: v["mean"] for k, v in
                                            doc["files"][name]["candidates"].items()},
                      doc["files"][name]["candidates"]["variant"]["minus_shipped"], flush=True)
            a.out.write_text(json_text(doc, indent=1) + "\n")


def main(argv=None):
    ap = options(argparse.ArgumentParser(description=__doc__.splitlines()[0]),
                 ",".join(VARIANTS), "align fit cap 45")
    ap.add_argument("--timing", action="store_true", help="seconds on MPII val, --variants")
    ap.add_argument("--out", type=Path, default=Path("local_align.json"))
    a = ap.parse_args(argv)
    if a.timing and not a.table:
        warnings.simplefilter("ignore")
        return timing(a.out, a.variants.split(","))
    run(a, screen, measure)


if __name__ == "__main__":
    main()
