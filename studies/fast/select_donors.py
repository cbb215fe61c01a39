"""Donors: other rows of the file (complete or not) that observe a pose's hidden joint.

``recover()``'s photo path codes an occluded pose over the file's complete
poses (and the shipped dictionary). scikit-learn's KNNImputer instead takes,
for each hidden coordinate, the nearest rows that observe it, incomplete rows
included; on video frames given as photos those are the neighbouring frames of
the same person, and it wins there by far (Bonn val + 1,000 train complete
poses: 3.58 vs 6.77 % of body size under random masks). On files of distinct
people (MPII, COCO) it loses. This script measures a donor fill and a per-file
choice of it from evidence:

* ``donor``: for each occluded pose and hidden joint, the ``k`` nearest other
  rows observing that joint, by the RMS residual (% of the pose's RMS radius)
  of the similarity alignment (translation, rotation, scale: closed form in 2D
  with complex numbers) of the donor onto the pose over the joints both observe
  (at least ``MIN_SHARED``); the estimate is the mean of the donors' aligned
  joints weighted by ``1 / (1 + d)``. A joint without such donors keeps the
  default answer.
* ``mean``: the mean of ``default`` (``recover()``'s defaults) and ``donor``.
* ``probe``: a per-file choice among the weights ``WEIGHTS`` of the donor
  fill (0: default, 1: donor) and the gates ``GATES`` (the donor weight only
  where the nearest donor's residual is below the gate), by the error on
  probes: a seeded subset of the occluded poses (at most ``N_PROBES``, with
  at least ``MIN_SHARED + 1`` observed joints) with one more observed joint
  hidden, the file recovered again by the defaults and donor-filled; ties
  and differences within one paired standard error go to the default.
* ``oracle``: the grid's best on the true hidden joints; ``knn``: KNNImputer
  (k=5) on the 28 coordinates for reference.

Files (validation only): ``select_photo_atoms.photo_files`` (MPII, COCO,
Bonn val, complete poses from the split or 1,000 from train; ``mix`` and
``transplanted`` masks), CMU held-out clips of subjects other than 01-03 with
the ``cmu-k2000`` dictionary (an honest control: it saw subjects 01-03 only)
and Daz (``--daz``; C complete + C Mix poses; the default dictionary has
seen them). Score: per occluded pose the mean error of its hidden joints, %
of body size; paired difference with ``default`` [mean, standard error].

    python studies/fast/select_donors.py --seed 0 --daz daz_indian.npz --out donors0.json
    python studies/fast/select_donors.py --pool donors0.json donors1.json donors2.json
    python studies/fast/select_donors.py --pool donors?.json --compare other?.json
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

#: donors need at least this many joints observed in both poses
MIN_SHARED = 8
#: donors per hidden joint
K = 5
#: probes per file (occluded poses with one more joint hidden)
N_PROBES = 300
#: weights of the donor fill and gates (% of pose size) of the per-file choice
WEIGHTS = (0.0, 0.25, 0.5, 0.75, 1.0)
GATES = (np.inf, 10.0, 5.0, 2.5)


def _complex(poses, missing):
    z = poses[..., 0] + 1j * poses[..., 1]
    return np.where(missing, 0, np.nan_to_num(z))


def donor_fill(poses, missing, rows, k=K, min_shared=MIN_SHARED, chunk=64):
    """(filled, nearest): for `rows`, each hidden joint's donor estimate (NaN: no
    donor) and the nearest donor's residual (% of the pose's RMS radius)."""
    n, J = missing.shape
    obs = ~missing
    O = obs.astype(float)
    z = _complex(poses, missing)
    zz = np.abs(z) ** 2
    filled = np.full((len(rows), J), np.nan + 0j)
    nearest = np.full((len(rows), J), np.inf)
    for s in range(0, len(rows), chunk):
        T = rows[s:s + chunk]
        Ot, zt = O[T], z[T]
        nS = Ot @ O.T
        ok = nS >= min_shared
        nS = np.maximum(nS, 1)
        Sx, Sy = zt @ O.T, Ot @ z.T
        Sxx = (Ot * zz[T]) @ O.T - np.abs(Sx) ** 2 / nS
        Syy = Ot @ zz.T - np.abs(Sy) ** 2 / nS
        Sxy = zt @ z.conj().T - Sx * Sy.conj() / nS
        ok &= Syy > 1e-12 * np.maximum(Sxx, 1e-300)
        Syy = np.where(ok, Syy, 1.0)
        resid = np.maximum(Sxx - np.abs(Sxy) ** 2 / Syy, 0)
        ot = obs[T]
        zc = zt - (zt.sum(1) / ot.sum(1))[:, None]
        size = np.sqrt((np.abs(np.where(ot, zc, 0)) ** 2).sum(1) / ot.sum(1))
        d = np.sqrt(resid / nS) / size[:, None] * 100
        d[~ok] = np.inf
        d[np.arange(len(T)), T] = np.inf
        a = Sxy / Syy
        for j in range(J):
            need = np.flatnonzero(missing[T, j])
            if not len(need):
                continue
            dj = np.where(obs[:, j][None, :], d[need], np.inf)
            kk = min(k, dj.shape[1])
            idx = np.argpartition(dj, kk - 1, axis=1)[:, :kk]
            dk = np.take_along_axis(dj, idx, 1)
            w = np.where(np.isfinite(dk), 1 / (1 + dk), 0)
            r = need
            cx = np.take_along_axis(Sx[r] / nS[r], idx, 1)
            cy = np.take_along_axis(Sy[r] / nS[r], idx, 1)
            ar = np.take_along_axis(a[r], idx, 1)
            est = cx + ar * (z[idx, j] - cy)
            wsum = w.sum(1)
            good = wsum > 0
            filled[s + r[good], j] = (w * est).sum(1)[good] / wsum[good]
            nearest[s + r, j] = dk.min(1)
    out = np.stack([filled.real, filled.imag], -1)
    return out, nearest


def mix(default, donor, nearest, missing, weight, gate):
    """`default` with its hidden joints moved `weight` of the way to the donor
    estimate where one exists and its nearest donor is within `gate`."""
    use = missing & np.isfinite(donor[..., 0]) & (nearest < gate)
    w = np.where(use, weight, 0.0)[..., None]
    return np.where(use[..., None], (1 - w) * default + w * np.nan_to_num(donor), default)


def per_pose(filled, truth, missing):
    """Per pose: the mean error of its hidden joints, % of body size."""
    from sparseedm.real_protocol import body_size

    err = np.linalg.norm(filled - truth, axis=-1) / body_size(truth)[:, None] * 100
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.nanmean(np.where(missing, err, np.nan), axis=1)


def paired(a, b):
    """[mean, standard error] of a - b over the poses where both are finite."""
    d = a - b
    d = d[np.isfinite(d)]
    if len(d) < 2:
        return [float("nan"), float("nan")]
    return [round(float(d.mean()), 4), round(float(d.std(ddof=1) / np.sqrt(len(d))), 4)]


def probes(missing, seed, n=N_PROBES, min_shared=MIN_SHARED):
    """(rows, joints): a seeded subset of the occluded rows with more than
    `min_shared` observed joints, one observed joint each to hide."""
    rng = np.random.default_rng([seed, 91])
    cand = np.flatnonzero(missing.any(1) & ((~missing).sum(1) > min_shared))
    rows = np.sort(rng.permutation(cand)[:n])
    joints = np.array([rng.choice(np.flatnonzero(~missing[r])) for r in rows], int)
    return rows, joints


def probe_errors(default, donor, nearest, truth, rows, joints):
    """{(weight, gate): per-probe error, % of the pose's observed RMS radius}."""
    from sparseedm.normalize import rms_radius

    pm = np.zeros((len(rows), truth.shape[1]), bool)
    pm[np.arange(len(rows)), joints] = True
    _, size = rms_radius(truth[rows], pm)
    out = {}
    for g in GATES:
        for w in WEIGHTS:
            f = mix(default[rows], donor[rows], nearest[rows], pm, w, g)
            e = np.linalg.norm(f[np.arange(len(rows)), joints] - truth[rows, joints], axis=-1)
            out[(w, g)] = e / size * 100
    return out


def choose(errs):
    """The (weight, gate) with the lowest probe error, unless its gain over the
    default is within one paired standard error."""
    base = errs[(0.0, np.inf)]
    best = min(errs, key=lambda key: errs[key].mean())
    d = errs[best] - base
    if len(d) < 2 or d.mean() + d.std(ddof=1) / np.sqrt(len(d)) >= 0:
        return (0.0, np.inf)
    return best


def without_donors(given, missing, **kw):
    """recover()'s defaults without the donor step this study led to
    (:func:`sparseedm.donors.donor_step` keeping the default answer)."""
    import sparseedm
    import sparseedm.recovery

    kept = sparseedm.recovery.donor_step
    sparseedm.recovery.donor_step = lambda res, *a: res
    try:
        return sparseedm.recover(given, missing, n_jobs=2, **kw)
    finally:
        sparseedm.recovery.donor_step = kept


def measure(truth, missing, seed, dictionary=None):
    """One file's candidates' per-pose errors, the probe choice, the seconds."""
    import sparseedm

    occ = np.flatnonzero(missing.any(1))
    given = np.where(missing[..., None], np.nan, truth)
    kw = {} if dictionary is None else {"dictionary": dictionary}
    secs = {}
    t0 = time.perf_counter()
    default = without_donors(given, missing, **kw).poses
    secs["default"] = round(time.perf_counter() - t0, 2)
    t0 = time.perf_counter()
    shipped = sparseedm.recover(given, missing, n_jobs=2, **kw)
    secs["shipped"] = round(time.perf_counter() - t0, 2)
    t0 = time.perf_counter()
    donor = np.full_like(truth, np.nan)
    nearest = np.full(missing.shape, np.inf)
    donor[occ], nearest[occ] = donor_fill(given, missing, occ)
    secs["donor"] = round(time.perf_counter() - t0, 2)
    # probes: one more observed joint hidden, the file recovered again
    rows, joints = probes(missing, seed)
    pmiss = missing.copy()
    pmiss[rows, joints] = True
    pgiven = np.where(pmiss[..., None], np.nan, truth)
    t0 = time.perf_counter()
    pdef = without_donors(pgiven, pmiss, **kw).poses
    secs["probe default"] = round(time.perf_counter() - t0, 2)
    t0 = time.perf_counter()
    pdon = np.full_like(truth, np.nan)
    pnear = np.full(missing.shape, np.inf)
    pdon[rows], pnear[rows] = donor_fill(pgiven, pmiss, rows)
    secs["probe donor"] = round(time.perf_counter() - t0, 2)
    perrs = probe_errors(pdef, pdon, pnear, truth, rows, joints)
    chosen = choose(perrs)
    m = missing[occ]
    grid = {key: per_pose(mix(default[occ], donor[occ], nearest[occ], m, *key), truth[occ], m)
            for key in perrs}
    oracle = min(grid, key=lambda key: np.nanmean(grid[key]))
    got = {"default": grid[(0.0, np.inf)], "donor": grid[(1.0, np.inf)],
           "mean": grid[(0.5, np.inf)], "probe": grid[chosen], "oracle": grid[oracle]}
    got["shipped"] = per_pose(shipped.poses[occ], truth[occ], m)
    t0 = time.perf_counter()
    from sklearn.impute import KNNImputer
    flat = KNNImputer(n_neighbors=5).fit_transform(given.reshape(len(given), -1))
    got["knn"] = per_pose(flat.reshape(truth.shape)[occ], truth[occ], m)
    secs["knn"] = round(time.perf_counter() - t0, 2)
    probe_mean = {f"{w}@{g}": round(float(e.mean()), 3) for (w, g), e in perrs.items()}
    return {"n": int(len(occ)), "probes": int(len(rows)), "chosen": list(chosen),
            "shipped_donors": shipped.adaptation.settings.get("donors"),
            "oracle": list(oracle), "probe_errors": probe_mean, "seconds": secs,
            "donor_coverage": round(float(np.isfinite(donor[occ][..., 0])[m].mean()), 3),
            "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                               "minus_default": paired(e, got["default"])}
                           for k, e in got.items()}}


def cmu_file(n, seed):
    """n poses of the held-out CMU clips of subjects other than 01-03, half of
    them under Mix masks (benchmarks.default_path.make_file)."""
    from benchmarks import load_cmu, split_clips
    from benchmarks.default_path import make_file

    poses, clips, _ = load_cmu()
    held, _ = split_clips(clips)
    other = ~np.isin(np.char.partition(clips.astype(str), "_")[:, 0], ["01", "02", "03"])
    return make_file(np.asarray(poses[held & other], float), n, seed=seed)


def files(a):
    """(name, truth, missing, dictionary name or None) of the files asked for."""
    from studies.fast.select_default_exemplars import mocap_file
    from studies.fast.select_photo_atoms import photo_files

    for frm, c in (("split", 1000), ("train", a.train)):
        if c:
            for name, truth, missing in photo_files(a.sources, "val", frm,
                                                    sizes=(c, 1000), seed=a.seed):
                yield name, truth, missing, None
    for n in (int(x) for x in a.cmu.split(",") if x):
        P, mask = cmu_file(n, a.seed)
        yield f"cmu 04+ {len(P)} poses (cmu-k2000)", P, mask, "cmu-k2000"
    for c in (int(x) for x in a.mocap_sizes.split(",") if x):
        for path in filter(None, a.daz.split(",")):
            truth, missing = mocap_file(path, c, c, a.seed)
            yield f"{Path(path).stem} {c}+{c}", np.asarray(truth, float), missing, None


def pooled(docs):
    """Markdown: per file, each candidate's paired difference with the default
    averaged over the seeds (standard errors combined), the default's error and
    the probe's choices."""
    import re

    cands = ("donor", "mean", "probe", "oracle", "shipped", "knn")
    rows = {}
    for doc in docs:
        for name, r in doc["files"].items():
            rows.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
    lines = ["| file | seeds | default | " + " | ".join(cands)
             + " | probe chose (weight@gate) | s: default / donor / probes |",
             "|---|---:|---:|" + "---:|" * len(cands) + "---|---|"]
    for name, rs in rows.items():
        cells = []
        for c in cands:
            d = np.array([r["candidates"][c]["minus_default"] for r in rs])
            cells.append(f"{d[:, 0].mean():+.2f} ± {np.sqrt((d[:, 1] ** 2).sum()) / len(d):.2f}")
        de = np.mean([r["candidates"]["default"]["mean"] for r in rs])
        # no gate is inf, which strict JSON writes as null (read back as NaN)
        ch = ", ".join(f"{w:g}@{np.inf if np.isnan(g) else g:g}"
                       for w, g in (r["chosen"] for r in rs))
        s = rs[0]["seconds"]
        lines.append(f"| {name} | {len(rs)} | {de:.2f} | " + " | ".join(cells)
                     + f" | {ch} | {s['default']} / {s['donor']} / "
                     f"{s['probe default'] + s['probe donor']:.1f} |")
    return "\n".join(lines)


def compare(before, after):
    """Markdown: per file, ``shipped`` minus the default pooled over the seeds of
    two sets of runs (e.g. two values of ``DONOR_MIN_SHARED``)."""
    import re

    def rows(docs):
        out = {}
        for doc in docs:
            for name, r in doc["files"].items():
                out.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
        return out

    def cell(rs):
        d = np.array([r["candidates"]["shipped"]["minus_default"] for r in rs])
        return f"{d[:, 0].mean():+.2f} ± {np.sqrt((d[:, 1] ** 2).sum()) / len(d):.2f}"

    a, b = rows(before), rows(after)
    lines = ["| file | default | shipped, before | shipped, after |", "|---|---:|---:|---:|"]
    for name in (n for n in a if n in b):
        de = np.mean([r["candidates"]["default"]["mean"] for r in a[name]])
        lines.append(f"| {name} | {de:.2f} | {cell(a[name])} | {cell(b[name])} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sources", default="bonn,mpii,coco", help="real2d sources (val split)")
    ap.add_argument("--train", type=int, default=1000, help="complete poses from train (0: none)")
    ap.add_argument("--cmu", default="400,2000", help="CMU file sizes (subjects 04+)")
    ap.add_argument("--mocap-sizes", default="200,1000", help="Daz files: C complete + C Mix")
    ap.add_argument("--daz", default="", help="Daz dataset .npz paths, comma-separated")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("donors.json"))
    ap.add_argument("--pool", nargs="+", type=Path, help="print the pooled table, stop")
    ap.add_argument("--compare", nargs="+", type=Path,
                    help="with --pool: these JSONs (another setting's runs) against them")
    a = ap.parse_args(argv)
    from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

    if a.pool and a.compare:
        print(compare([load_results(p) for p in a.pool], [load_results(p) for p in a.compare]))
        return
    if a.pool:
        print(pooled([load_results(p) for p in a.pool]))
        return
    import sparseedm

    warnings.simplefilter("ignore")
    doc = {"score": "per occluded pose: % body size of its hidden joints; minus_default: "
                    "[mean, standard error] paired against recover()'s defaults",
           "settings": {"k": K, "min_shared": MIN_SHARED, "probes": N_PROBES,
                        "weights": WEIGHTS, "gates": [str(g) for g in GATES]}, "files": {}}
    if a.out.exists():
        doc = json.loads(a.out.read_text())
    for name, truth, missing, dname in files(a):
        key = f"{name} seed {a.seed}"
        if key in doc["files"]:
            continue
        d = sparseedm.load_dictionary(dname) if dname else None
        doc["files"][key] = r = measure(truth, missing, a.seed, d)
        print(key, r["chosen"], r["oracle"], r["seconds"],
              {k: v["minus_default"] for k, v in r["candidates"].items()}, flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
