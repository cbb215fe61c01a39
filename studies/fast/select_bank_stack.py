"""The shipped pose bank as its own candidate of the default path, weighted per file by probes.

The default path (``recover()``'s defaults on a file whose answers are
blended) now ends with a bank step (:func:`sparseedm.cold_bank.bank_step`,
between ``exemplars.probe_stack`` and ``donors.donor_step``): the shipped
pose bank's local Gaussian answer (:func:`sparseedm.cold_bank.bank_fill`,
what ``recover(adapt=False)`` stacks) is averaged into every occluded pose's
answer at the weight of ``exemplars.LINEAR_WEIGHTS`` chosen on probes of the
file's occluded rows (one more observed joint hidden;
``exemplars.probe_weight``, paired standard errors clustered by row), 0 unless
the gain exceeds one standard error. Variants, end to end through
``recover()`` against ``shipped`` (the step off, cached per file):

* ``bank step``: as shipped (skipped from
  ``cold_bank.BANK_STEP_MAX_COMPLETE`` = 200 complete poses);
* ``bank step all``: the step on every file whatever its complete poses.

Files: ``select_bank_default.py``'s (validation photo files of
``benchmarks/real_people.py``: MPII val 200 + 199, COCO val 28 + 27, Bonn val
frames 580 complete, each also with 1,000 (COCO 233) train complete poses;
mix = 1-3 random hidden joints, transplanted = real masks; ``--few C+M``:
``select_few_stack.py``'s C complete + M occluded of the val split), and
mocap dataset files (``--mocap path[:dictionary]``, C complete + C Mix
poses). Score: per occluded pose the mean error of its hidden joints, % of
body size; paired differences [mean, standard error].

    python studies/fast/select_bank_stack.py --seeds 0,1,2 --variant "bank step all" \\
        --out selection_bank_stack_all.json
    python studies/fast/select_bank_stack.py --seeds 0,1,2 --variant "bank step" \\
        --few 28+200,40+200 --out selection_bank_stack_few.json
    python studies/fast/select_bank_stack.py --seeds 0,1,2 --sources "" --mocap-sizes 28,200 \\
        --mocap cmu_other_subjects.npz:cmu-k2000,daz_indian.npz --out selection_bank_stack_mocap.json
    python studies/fast/select_bank_stack.py --timing --out selection_bank_stack_timing.json
    python studies/fast/select_bank_stack.py --oracle --seeds 0,1,2 --out selection_bank_stack_oracle.json
    python studies/fast/select_bank_stack.py --table selection_bank_stack_all.json

``--oracle``: on the same files (the shipped answers cached), the error of
``(1 - w) * shipped + w * bank`` at fixed weights w for every occluded pose,
and for the poses the cold gate's idea picks alone (the mean distance to the
20 nearest of the file's complete poses and their mirror images, on the
observed joints, above ``--gate`` times that to the 20 nearest bank poses):
whether a per-pose rule could replace the per-file choice.

``--timing``: seconds of ``recover()`` on three files of 28 and 100 complete
poses with the step off and on, back to back, twice (machine and load noted).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

import numpy as np

from sparseedm._atomic import json_text

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

#: the shipped answers (step off); seeded from select_bank_default.py's cache
#: (/tmp/photos_bankdef/cache: the same files and defaults before the step)
CACHE = Path("/tmp/bankstack/cache")

VARIANTS = {"shipped": 0, "bank step": None, "bank step all": 10 ** 9}


@contextlib.contextmanager
def patched(variant):
    """recover()'s defaults with the bank step's cap of the variant (0: off)."""
    import sparseedm.cold_bank as cb

    kept = cb.BANK_STEP_MAX_COMPLETE
    cap = VARIANTS[variant]
    cb.BANK_STEP_MAX_COMPLETE = kept if cap is None else cap
    try:
        yield
    finally:
        cb.BANK_STEP_MAX_COMPLETE = kept


def _bank_weight(res):
    settings = res.adaptation.settings if res.adaptation is not None else {}
    return float(settings.get("bank", {}).get("weight", np.nan))


def measure(name, truth, missing, photo, kw, variant):
    """One file end to end: per-pose errors of the shipped defaults (step off,
    cached), II (photos) and the variant; the Gaussian's and the bank's
    weights; seconds."""
    import sparseedm
    import studies.fast.select_local_average as avg
    from studies.fast.select_photo_blend import per_pose

    avg.CACHE, avg.ALIGN_CACHE = CACHE, Path("/tmp/photos_align/cache")
    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    with patched("shipped"):
        got, secs, w = avg._shipped(name, given, missing, photo, kw)
    t0 = time.perf_counter()
    with patched(variant):
        res = sparseedm.recover(given, missing, n_jobs=1, **kw)
    secs["variant"] = round(time.perf_counter() - t0, 2)
    got["variant"] = res.poses[occ]
    weights = {"shipped": w, "variant": _bank_weight(res)}
    return secs, weights, {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


ORACLE_WEIGHTS = (0.25, 0.5)


def oracle(name, truth, missing, photo, kw, gate):
    """--oracle on one file: {rule: paired [mean, se] against shipped}, the
    rules ``w`` (every occluded pose) and ``gate w`` (the gated poses alone)."""
    import studies.fast.select_local_average as avg
    from sparseedm.cold_bank import bank_fill, load_pose_bank
    from sparseedm.file_atoms import mirror_images
    from sparseedm.gaussian_fill import nearest_distances
    from studies.fast.select_photo_blend import paired, per_pose

    avg.CACHE, avg.ALIGN_CACHE = CACHE, Path("/tmp/photos_align/cache")
    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    with patched("shipped"):
        shipped = avg._shipped(name, given, missing, photo, kw)[0]["shipped"]
    bank = load_pose_bank()
    fill = bank_fill(bank, given, missing)[occ]
    fill = np.where(np.isfinite(fill), fill, shipped)
    own = mirror_images(truth[~occ])
    dist = nearest_distances(np.concatenate([own, bank.poses]), given[occ], missing[occ], 20,
                             np.r_[np.ones(len(own), bool), np.zeros(len(bank.poses), bool)])
    gated = (dist[:, 0] > gate * dist[:, 1])[:, None, None]
    base = per_pose(shipped, truth[occ], missing[occ])
    out = {"gated_share": round(float(gated.mean()), 3)}
    for w in ORACLE_WEIGHTS:
        for rule, weight in ((f"{w}", w), (f"gate {w}", np.where(gated, w, 0.0))):
            out[rule] = paired(per_pose((1 - weight) * shipped + weight * fill, truth[occ],
                                        missing[occ]), base)
    return out


def run_oracle(a):
    """--oracle over --seeds (the main files and --few's), pooled per file."""
    import warnings

    import studies.fast.select_local_gaussian as gaussian
    from studies.fast.select_bank_default import few_files

    warnings.simplefilter("ignore")
    doc = {"score": "paired [mean, se] against shipped, % body size", "gate": a.gate, "files": {}}
    for seed in (int(s) for s in a.seeds.split(",")):
        items = list(gaussian.files(a.sources, a.parts.split(","), "", [], seed))
        if a.few:
            items += list(few_files(a.few)(a.sources, None, None, None, seed))
        for name, truth, missing, photo, kw in items:
            doc["files"][name] = oracle(name, truth, missing, photo, kw, a.gate)
            print(name, doc["files"][name], flush=True)
    a.out.write_text(json_text(doc, indent=1) + "\n")


def timing(out):
    """--timing: recover()'s seconds with the step off and on, back to back."""
    import os
    import platform
    import warnings

    import sparseedm
    from studies.fast.select_bank_default import few_files
    from studies.fast.select_local_gaussian import files

    warnings.simplefilter("ignore")
    picked = [next(iter(files("coco", ["split"], "", [], 0)))]
    picked += [next(iter(few_files(f)("mpii", None, None, None, 0))) for f in ("28+200", "100+200")]
    doc = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
           "load_before": list(os.getloadavg()), "files": {}}
    for name, truth, missing, _, kw in picked:
        given = np.where(missing[..., None], np.nan, truth)
        secs = {"shipped": [], "bank step": []}
        for _ in range(2):
            for variant in secs:
                with patched(variant):
                    t0 = time.perf_counter()
                    sparseedm.recover(given, missing, n_jobs=1, **kw)
                secs[variant].append(round(time.perf_counter() - t0, 2))
        doc["files"][name] = secs
        print(name, secs, flush=True)
    doc["load_after"] = list(os.getloadavg())
    out.write_text(json_text(doc, indent=1) + "\n")


def main(argv=None):
    import studies.fast.select_local_gaussian as gaussian
    from studies.fast.select_bank_default import few_files
    from studies.fast.select_local_align import options, run

    ap = options(argparse.ArgumentParser(description=__doc__.splitlines()[0]),
                 "", "bank step")
    ap.add_argument("--few", default="", help="C+M,...: select_few_stack.py's files instead")
    ap.add_argument("--out", type=Path, default=Path("bank_stack.json"))
    ap.add_argument("--timing", action="store_true", help="seconds with the step off and on")
    ap.add_argument("--oracle", action="store_true", help="fixed and gated weights, per file")
    ap.add_argument("--gate", type=float, default=1.5, help="--oracle's gate")
    a = ap.parse_args(argv)
    if a.oracle:
        run_oracle(a)
        return
    if a.timing:
        timing(a.out)
        return
    if a.few:  # run() reads its files from select_local_gaussian
        gaussian.files = few_files(a.few)
    run(a, None, measure)


if __name__ == "__main__":
    main()
