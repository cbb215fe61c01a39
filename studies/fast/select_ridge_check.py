"""A per-file choice of the mean with the local ridge over the base and the file's poses.

``select_photo_blend.py`` measured ``avg(cur, R base+atoms)``: every occluded
pose's answer averaged with the local ridge's (``preset="fast"``'s coder) over
the shipped dictionary with the file's complete poses as extra atoms. It
helped the mocap files (CMU, Daz) and Bonn but lost on MPII under random
masks. This script replays, per validation file, a choice of that mean by
the default path's held-back check (:mod:`sparseedm.exemplars`):

* ``shipped``: ``recover()``'s defaults (the check, the blend of poses with
  at least 4 hidden joints) without the mean this study led to
  (:func:`sparseedm.exemplars.ridge_mean_atoms` answering None);
* ``always``: ``shipped`` averaged with ``R base+atoms`` on every occluded pose;
* ``checked``: ``always`` when, on the check's held-back complete poses
  (the same seeded 20 %, at most 300, hidden by the file's own missing
  patterns), the path's answer made of the other complete poses (its
  members, then the blend) averaged with ``R base+atoms`` made of them has
  a lower hidden-joint error than the path's answer alone; ``shipped``
  otherwise (and on adapted files, or below ``FEW_MIN_POSES`` complete
  poses, where the check does not run);
* ``checked, 1 se``: the same, chosen only when the held-back gain exceeds
  its paired standard error.

Files: ``select_photo_blend.files`` (validation photo files from the split
and from train, ``mix`` and ``transplanted`` masks; CMU held-out clips and
Daz files). Score: per occluded pose the mean error of its hidden joints, %
of body size; paired difference with ``shipped`` [mean, standard error].
Seconds: the held-back replay (what the check would add: the held-back
path answer is the check's own in :mod:`sparseedm.exemplars` except for its
blend) and the full file's local ridge (added only when chosen).

    python studies/fast/select_ridge_check.py --daz daz_indian.npz --out ridge_check.json
    python studies/fast/select_ridge_check.py --table ridge_check.json
    python studies/fast/select_ridge_check.py --pool seed0.json seed1.json seed2.json
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
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_ridge_check.py` finds benchmarks/
from sparseedm._atomic import json_text  # noqa: E402


def path_members(base, rest, path):
    """The dictionaries the default path codes with, made of the complete poses
    `rest` (None: an adapted or unchecked path, no candidate)."""
    from sparseedm.adaptation import AVERAGED_PATH, MIRRORED_ATOMS_PATH
    from sparseedm.exemplars import averaged_members
    from sparseedm.file_atoms import file_dictionary, mirror_images, with_file_atoms

    if path == "file atoms":
        return [file_dictionary(base, rest).dictionary]
    if path == AVERAGED_PATH:
        return averaged_members(base, rest)
    if path == MIRRORED_ATOMS_PATH:
        return [with_file_atoms(base, rest).dictionary,
                with_file_atoms(base, mirror_images(rest)).dictionary]
    if path == "base + file atoms":
        return [with_file_atoms(base, rest).dictionary]
    return None


def ridge(dictionary, given, missing):
    """The local ridge's (FAST_RIDGE) recovery of `given` over `dictionary`."""
    from sparseedm._recovery_kernel import FAST_RIDGE, recover_members
    from sparseedm.solvers import LocalRidgeSolver

    return recover_members(given, missing, [dictionary], [], check_input=False,
                           solver=LocalRidgeSolver(**FAST_RIDGE), n_jobs=2)


def held_errors(res, truth, mask):
    """The check's score per held-back pose: the hidden joints' mean error, % of
    the pose's RMS radius (NaN where not recovered)."""
    from sparseedm.normalize import rms_radius

    _, size = rms_radius(truth, np.zeros(mask.shape, bool))
    err = np.linalg.norm((res.poses - truth) / size[:, None, None], axis=-1) * 100
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        per = np.nanmean(np.where(mask, err, np.nan), axis=1)
    return np.where(res.ok, per, np.nan)


def held_check(base, given, missing, complete, path, seed=0):
    """(error of the path's answer, error of its mean with R base+atoms, their
    paired difference's standard error) on the check's held-back poses; None
    when the path has no check."""
    from sparseedm._recovery_base import combine
    from sparseedm._recovery_kernel import compiled_solver, recover_members
    from sparseedm.exemplars import (BLEND_MIN_POSES, FEW_MIN_POSES, HELD_FRACTION, MAX_HELD,
                                     blend_many_hidden, held_masks)
    from sparseedm.file_atoms import file_dictionary, with_file_atoms

    n = len(complete)
    if n < FEW_MIN_POSES:
        return None
    held = np.zeros(n, bool)  # exemplars._held_back's draw
    want = min(int(round(HELD_FRACTION * n)), MAX_HELD)
    held[np.random.default_rng([seed, 43]).choice(n, want, replace=False)] = True
    mask = held_masks(given, missing, want, seed)
    truth, rest = complete[held], complete[~held]
    members = path_members(base, rest, path)
    if members is None:
        return None
    hidden = np.where(mask[..., None], np.nan, truth)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = combine([recover_members(hidden, mask, [d], [], solver=compiled_solver(),
                                       check_input=False, n_jobs=2) for d in members])
        if len(rest) >= BLEND_MIN_POSES:
            res = blend_many_hidden(res, hidden, mask, file_dictionary(base, rest).dictionary,
                                    n_jobs=2)
        both = combine([res, ridge(with_file_atoms(base, rest).dictionary, hidden, mask)])
    a, b = held_errors(res, truth, mask), held_errors(both, truth, mask)
    ok = np.isfinite(a) & np.isfinite(b)
    d = b[ok] - a[ok]
    return float(a[ok].mean()), float(b[ok].mean()), float(d.std(ddof=1) / np.sqrt(len(d)))


def without_ridge_mean(given, missing):
    """recover()'s defaults without the mean with the local ridge over base + file
    atoms on every occluded pose (the path before it)."""
    import sparseedm
    import sparseedm.recovery

    kept = sparseedm.recovery.ridge_mean_atoms
    sparseedm.recovery.ridge_mean_atoms = lambda *a: None
    try:
        return sparseedm.recover(given, missing, n_jobs=2)
    finally:
        sparseedm.recovery.ridge_mean_atoms = kept


def measure(base, truth, missing):
    """One file: path, check errors, seconds, per-pose errors of each candidate."""
    from sparseedm._recovery_base import combine
    from sparseedm.file_atoms import with_file_atoms
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    t0 = time.perf_counter()
    res = without_ridge_mean(given, missing)
    secs = {"shipped": round(time.perf_counter() - t0, 2)}
    path = res.adaptation.summary().get("path") if res.adaptation is not None else None
    complete = truth[~occ]
    t0 = time.perf_counter()
    check = held_check(base, given, missing, complete, path)
    secs["check"] = round(time.perf_counter() - t0, 2)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = ridge(with_file_atoms(base, complete).dictionary, given[occ], missing[occ])
        always = combine([res.take(np.flatnonzero(occ)), r]).poses
    secs["full ridge"] = round(time.perf_counter() - t0, 2)
    chosen = check is not None and check[1] < check[0]
    sure = check is not None and check[1] + check[2] < check[0]
    got = {"shipped": res.poses[occ], "always": always,
           "checked": always if chosen else res.poses[occ],
           "checked, 1 se": always if sure else res.poses[occ]}
    errors = {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}
    return path, check, chosen, secs, errors


def table(doc):
    """Markdown: per file, the path, the check's errors, shipped's error, the
    candidates' paired differences and the seconds."""
    cands = ("always", "checked", "checked, 1 se")
    lines = ["| file | path | held: path / mean (se) | chosen | shipped | "
             + " | ".join(cands) + " | s: shipped / check / ridge |",
             "|---|---|---:|---|---:|---:|---:|---:|---:|"]
    for name, r in doc["files"].items():
        held = ("" if r["held"] is None else f"{r['held'][0]:.2f} / {r['held'][1]:.2f} "
                f"({r['held'][2]:.2f})")
        cells = [f"{r['candidates'][c]['minus_shipped'][0]:+.2f} ± "
                 f"{r['candidates'][c]['minus_shipped'][1]:.2f}" for c in cands]
        s = r["seconds"]
        lines.append(f"| {name} | {r['path']} | {held} | {'yes' if r['chosen'] else 'no'} | "
                     f"{r['candidates']['shipped']['mean']:.2f} | " + " | ".join(cells)
                     + f" | {s['shipped']} / {s['check']} / {s['full ridge']} |")
    return "\n".join(lines)


def pooled(docs):
    """Markdown: per file, each candidate's paired difference averaged over the
    seeds' runs (standard error combined), and the seeds where the check chose."""
    import re

    cands = ("always", "checked", "checked, 1 se")
    rows = {}
    for doc in docs:
        for name, r in doc["files"].items():
            rows.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
    lines = ["| file | seeds | chosen / 1 se | " + " | ".join(cands) + " |",
             "|---|---:|---:|" + "---:|" * len(cands)]
    for name, rs in rows.items():
        cells = []
        for c in cands:
            d = np.array([r["candidates"][c]["minus_shipped"] for r in rs])
            cells.append(f"{d[:, 0].mean():+.2f} ± {np.sqrt((d[:, 1] ** 2).sum()) / len(d):.2f}")
        sure = sum(r["held"] is not None and r["held"][1] + r["held"][2] < r["held"][0]
                   for r in rs)
        lines.append(f"| {name} | {len(rs)} | {sum(r['chosen'] for r in rs)} / {sure} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    from studies.fast.select_photo_blend import files, paired

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sources", default="mpii,coco,bonn", help="real2d sources (val split)")
    ap.add_argument("--complete", default="1000", help="complete poses per val file")
    ap.add_argument("--mocap-sizes", default="200,1000",
                    help="complete poses of the CMU and Daz files")
    ap.add_argument("--train", type=int, default=1000,
                    help="complete poses from the train split (0: none)")
    ap.add_argument("--occluded", type=int, default=1000, help="occluded poses per file (cap)")
    ap.add_argument("--daz", default="", help="Daz dataset .npz paths, comma-separated")
    ap.add_argument("--seed", type=int, default=0, help="seed of the files' draws")
    ap.add_argument("--out", type=Path, default=Path("ridge_check.json"))
    ap.add_argument("--table", type=Path, help="print the Markdown table of this JSON, stop")
    ap.add_argument("--pool", nargs="+", type=Path,
                    help="print the table pooled over these JSONs (seeds), stop")
    a = ap.parse_args(argv)
    if a.pool:
        print(pooled([json.loads(p.read_text()) for p in a.pool]))
        return
    if a.table:
        print(table(json.loads(a.table.read_text())))
        return
    import sparseedm

    warnings.simplefilter("ignore")
    base = sparseedm.load_dictionary()
    doc = {"score": "per occluded pose: % body size of its hidden joints; minus_shipped: "
                    "[mean, standard error] paired against recover()'s defaults", "files": {}}
    if a.out.exists():
        doc = json.loads(a.out.read_text())
    for name, truth, missing, _ in files(a):
        if name in doc["files"]:
            continue
        path, check, chosen, secs, errors = measure(base, truth, missing)
        doc["files"][name] = {
            "path": path, "held": check, "chosen": bool(chosen), "seconds": secs,
            "n": int(len(errors["shipped"])),
            "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                               "minus_shipped": paired(e, errors["shipped"])}
                           for k, e in errors.items()}}
        print(name, path, check, chosen, secs,
              {k: v["minus_shipped"] for k, v in doc["files"][name]["candidates"].items()},
              flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
