"""Files with fewer than 250 complete poses: base + file atoms, or that averaged with its mirror.

``recover()``'s default path codes the occluded poses of a file with fewer
than ``MIN_COMPLETE_POSES`` usable complete poses over the shipped dictionary
with those poses as extra atoms (``base+atoms``). This script measures, per
validation file, two means of two codes beside it:

* ``avg mirrored dict``: ``base+atoms`` averaged with the code over its
  mirrored dictionary (``Dictionary.mirrored()``: what ``recover(...,
  mirror=True)`` does);
* ``avg mirrored atoms``: ``base+atoms`` averaged with the base with the
  file's poses and their mirror images as extra atoms;
* ``avg mirrored base``: ``base+atoms`` averaged with the mirrored base with
  the file's poses (not mirrored) as extra atoms;

and replays per-file choices: with at least ``--min-complete`` complete
poses, a held-back check (a seeded 20 % of them, each hidden as one of the
file's incomplete poses is: :func:`sparseedm.exemplars.held_masks`; the
others are the file atoms) takes a mean when its held-back hidden-joint
error is lower than ``base+atoms``'s (``rule <mean>``), or the candidate of
lowest held-back error (``rule best``).

Files (validation only): ``select_photo_atoms.py``'s photo files (MPII, COCO,
Bonn val; ``--complete`` complete poses, at most 1,000 occluded under mix and
transplanted masks), CMU held-out clips and Daz datasets (``--daz``, built with
``sparseedm dataset build``; Mix masks). Score: per occluded pose the mean
error of its hidden joints, % of body size; ``rule - base+atoms`` paired over
the occluded poses [mean, standard error].

    python studies/fast/select_few_poses.py --daz daz_indian.npz --out few.json
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_few_poses.py` finds benchmarks/
from sparseedm._atomic import json_text  # noqa: E402

CANDIDATES = ("base+atoms", "avg mirrored dict", "avg mirrored atoms", "avg mirrored base")


def codes(base, complete, given, missing):
    """{candidate: filled poses} of the rows `given` under `missing`, the file atoms
    made of `complete`."""
    import sparseedm
    from sparseedm.file_atoms import mirror_images, with_file_atoms

    d = with_file_atoms(base, complete).dictionary
    others = {"avg mirrored dict": d.mirrored(),
              "avg mirrored atoms": with_file_atoms(base, mirror_images(complete)).dictionary,
              "avg mirrored base": with_file_atoms(base.mirrored(), complete).dictionary}
    run = lambda dic: sparseedm.recover(given, missing, dictionary=dic, adapt=False,  # noqa
                                        solver="fast", n_jobs=2).poses
    out = {"base+atoms": run(d)}
    for name, other in others.items():
        out[name] = (out["base+atoms"] + run(other)) / 2
    return out


def per_pose(filled, truth, missing, size):
    """Per pose: the mean error of its hidden joints, % of `size`."""
    err = np.linalg.norm(filled - truth, axis=-1) / size[:, None] * 100
    return np.nanmean(np.where(missing, err, np.nan), axis=1)


def check(base, complete, given, missing, seed=0):
    """The held-back check's hidden-joint error (% of pose size) per candidate."""
    from sparseedm.exemplars import HELD_FRACTION, MAX_HELD, held_masks
    from sparseedm.normalize import rms_radius

    n = len(complete)
    want = min(int(round(HELD_FRACTION * n)), MAX_HELD)
    held = np.zeros(n, bool)
    held[np.random.default_rng([seed, 43]).choice(n, want, replace=False)] = True
    mask = held_masks(given, missing, want, seed)
    truth = complete[held]
    got = codes(base, complete[~held], np.where(mask[..., None], np.nan, truth), mask)
    _, size = rms_radius(truth, np.zeros(mask.shape, bool))
    return {k: round(float(np.nanmean(per_pose(v, truth, mask, size))), 4)
            for k, v in got.items()}


def measure(base, truth, missing, min_complete):
    """One file: each candidate's test error, the check, each rule's paired gain."""
    from sparseedm.real_protocol import body_size

    occ = missing.any(axis=1)
    complete = truth[~occ]
    given = np.where(missing[..., None], np.nan, truth)
    got = codes(base, complete, given[occ], missing[occ])
    size = body_size(truth[occ])
    scores = {k: per_pose(v, truth[occ], missing[occ], size) for k, v in got.items()}
    row = {"complete": int(len(complete)), "occluded": int(occ.sum()),
           "test": {k: round(float(np.nanmean(v)), 4) for k, v in scores.items()}}
    row["check"] = check(base, complete, given, missing) if len(complete) >= min_complete else {}
    best = min(CANDIDATES, key=lambda c: row["check"][c]) if row["check"] else CANDIDATES[0]
    for name in (*CANDIDATES[1:], "best"):
        pick = bool(row["check"]) and (best != CANDIDATES[0] if name == "best" else
                                       row["check"][name] < row["check"]["base+atoms"])
        d = (scores[best if name == "best" else name] if pick
             else scores["base+atoms"]) - scores["base+atoms"]
        d = d[np.isfinite(d)]
        picked = (best if pick else False) if name == "best" else pick
        row[f"rule {name}"] = {"picked": picked, "minus_base_atoms": [
            round(float(d.mean()), 4), round(float(d.std(ddof=1) / np.sqrt(len(d))), 4)]}
    return row


def files(a):
    """(name, truth, missing) of the validation files asked for."""
    from studies.fast.select_default_exemplars import mocap_file
    from studies.fast.select_fast import validation_file
    from studies.fast.select_photo_atoms import photo_files

    for c in (int(x) for x in a.complete.split(",")):
        for name, truth, missing in photo_files(a.sources, "val", "split",
                                                sizes=(c, a.occluded), seed=a.seed):
            yield name, truth, missing
    for c in (int(x) for x in a.complete.split(",")):
        for seed in (2 * a.seed, 2 * a.seed + 1):
            P, mask = validation_file(2 * c, seed)
            yield f"cmu {len(P)} poses seed {seed}", P, mask
        for path in filter(None, a.daz.split(",")):
            truth, missing = mocap_file(path, c, a.occluded, a.seed)
            yield f"{Path(path).stem} {c}+{a.occluded}", np.asarray(truth, float), missing


def table(doc):
    """Markdown: per file, each mean's test error against base+atoms and what the
    rules did (``*``: the check took the mean)."""
    lines = ["| file | complete | base+atoms | " + " | ".join(CANDIDATES[1:])
             + " | rule: mirrored atoms | rule: best |", "|---" * 8 + "|"]
    for name, r in doc["files"].items():
        t, b = r["test"], r["test"]["base+atoms"]
        cells = [f"{t[c] - b:+.2f}" for c in CANDIDATES[1:]]
        for rule in ("rule avg mirrored atoms", "rule best"):
            m, se = r[rule]["minus_base_atoms"]
            cells.append(f"{m:+.2f} ± {se:.2f}" + (" *" if r[rule]["picked"] else ""))
        lines.append(f"| {name} | {r['complete']} | {b:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sources", default="mpii,coco,bonn", help="real2d sources (val split)")
    ap.add_argument("--complete", default="60,120,240", help="complete poses per file")
    ap.add_argument("--occluded", type=int, default=600, help="occluded poses per file (cap)")
    ap.add_argument("--daz", default="", help="Daz dataset .npz paths, comma-separated")
    ap.add_argument("--min-complete", type=int, default=50,
                    help="complete poses from which the check runs")
    ap.add_argument("--seed", type=int, default=0, help="seed of the files' draws")
    ap.add_argument("--out", type=Path, default=Path("few_poses.json"))
    ap.add_argument("--table", type=Path, help="print the Markdown table of this JSON, stop")
    a = ap.parse_args(argv)
    if a.table:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        print(table(load_results(a.table)))
        return
    import sparseedm

    warnings.simplefilter("ignore")
    base = sparseedm.load_dictionary()
    doc = {"score": "per occluded pose: % body size of its hidden joints; rules: "
                    "[mean, standard error] paired against base+atoms", "files": {}}
    for name, truth, missing in files(a):
        doc["files"][name] = measure(base, truth, missing, a.min_complete)
        print(name, json.dumps(doc["files"][name]), flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
