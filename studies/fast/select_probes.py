"""More probes per row on files of few occluded rows.

The default path chooses three weights per file on probes of its occluded rows
(``exemplars.probe_stack``'s Gaussian weight, ``cold_bank.bank_step``'s bank
weight, ``donors.donor_step``'s donor weight): each probe is an occluded row
with one more observed joint hidden, a weight taken only when its gain beats
one paired standard error clustered by row. ``old`` (the shipped
defaults): one probe per row (at most 300 rows); the Gaussian and bank weights
with up to four rounds of them (``exemplars.LINEAR_PROBE_ROUNDS``, a joint
drawn again each round, so a row may repeat a joint), the donor step with one
round (so nothing below 30 probed rows). Variants: every step with one draw of
``donors.probes(per_row=k)`` (``donors.PROBES_PER_ROW``): a file of fewer than
300 probed rows has each row probed up to k times, another observed joint
each, until 300 probes
(``k4``: 4, ``k2``: 2, ``all``: every observed joint); ``weights k4``: the
Gaussian's and the bank's probes so, the donor step's as before; ``donor k4``
the other way round; ``... pass`` (``old pass``, ``all pass``): the probes'
weight the lowest-error one among those passing one standard error.

End to end through ``recover()``'s defaults: the variant against ``old``
(cached per file), II (IterativeImputer) beside them. Files: as
``select_bank_default.py`` (``--few C+M``: ``select_few_stack.py``'s).
Score: per occluded pose the mean error of its hidden joints, % of body
size; paired differences [mean, standard error].

    python studies/fast/select_probes.py --seeds 0,1,2,3,4,5 --sources coco --parts split \\
        --variant k4 --out selection_probes_coco.json
    python studies/fast/select_probes.py --seeds 0 --variant k4 --few 28+200,40+200,100+200 \\
        --out selection_probes_few.json
    python studies/fast/select_probes.py --table selection_probes_coco.json
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from functools import partial
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

CACHE = Path("/tmp/photos_probes/cache")
ALIGN_CACHE = Path("/tmp/photos_align/cache")

#: probes per row of each variant ("old": the rounds described above)
VARIANTS = {"k4": 4, "k2": 2, "all": 14}


def _passing(shipped):
    """exemplars._best_weight on probes (clustered) taking the lowest-error weight
    among those whose gain exceeds LINEAR_MIN_SE standard errors (shipped: the
    lowest-error weight, 0 unless it passes)."""
    from sparseedm.exemplars import LINEAR_MIN_SE, LINEAR_WEIGHTS, paired_gain

    def best(per_pose, fewest, clusters=None):
        ok = np.isfinite(per_pose).all(axis=0)
        if clusters is None or ok.sum() < max(fewest, 2):
            return shipped(per_pose, fewest, clusters)
        per_pose, clusters = per_pose[:, ok], np.asarray(clusters)[ok]
        errors = per_pose.mean(axis=1)
        gains = [paired_gain(per_pose[0] - p, clusters) for p in per_pose]
        passing = [i for i, (mean, se) in enumerate(gains) if i and mean > LINEAR_MIN_SE * se]
        i = min(passing, key=lambda i: errors[i]) if passing else 0
        return float(LINEAR_WEIGHTS[i]), float(errors[i])
    return best


@contextlib.contextmanager
def patched(variant):
    """recover()'s defaults (``old``) or with the variant's probes."""
    import sparseedm.donors as dn
    import sparseedm.exemplars as ex

    kept = dn.PROBES_PER_ROW, ex.LINEAR_PROBE_ROUNDS, ex.probes, ex._best_weight
    if variant.endswith(" pass"):  # the probes' weight: the best of those passing
        ex._best_weight = _passing(kept[3])
        variant = variant[:-len(" pass")]
    if variant in VARIANTS:  # one draw of k per row for every step
        dn.PROBES_PER_ROW, ex.LINEAR_PROBE_ROUNDS = VARIANTS[variant], 1
    elif variant == "weights k4":  # the donor step's probes as before
        ex.probes, ex.LINEAR_PROBE_ROUNDS = partial(dn.probes, per_row=4), 1
    elif variant == "donor k4":  # the Gaussian's and the bank's probes as before
        dn.PROBES_PER_ROW, ex.probes = 4, partial(dn.probes, per_row=1)
    try:
        yield
    finally:
        dn.PROBES_PER_ROW, ex.LINEAR_PROBE_ROUNDS, ex.probes, ex._best_weight = kept


def _weights(res):
    s = res.adaptation.settings if res.adaptation is not None else {}
    return {"linear": s.get("linear_weight"), "linear_probes": s.get("linear_probes"),
            "bank": (s.get("bank") or {}).get("weight"),
            "donor": (s.get("donors") or {}).get("weight"),
            "donor_probes": (s.get("donors") or {}).get("probes")}


def measure(name, truth, missing, photo, kw, variant):
    """One file end to end: ``old`` (cached) and II, and the variant; its
    "weights" 10 x the bank weight + the donor weight."""
    import studies.fast.select_local_average as avg
    import studies.fast.select_local_gaussian as gaussian

    avg.CACHE, avg.ALIGN_CACHE, avg.patched = CACHE, ALIGN_CACHE, patched
    kept = gaussian._weight
    gaussian._weight = lambda res: float(_weights(res)["bank"] or 0.0) * 10 + float(
        _weights(res)["donor"] or 0.0)
    try:
        return avg.measure(name, truth, missing, photo, kw, variant)
    finally:
        gaussian._weight = kept


def main(argv=None):
    import studies.fast.select_local_gaussian as gaussian
    from studies.fast.select_bank_default import few_files
    from studies.fast.select_local_align import options, run

    ap = options(argparse.ArgumentParser(description=__doc__.splitlines()[0]), "", "k4")
    ap.add_argument("--few", default="", help="C+M,...: select_few_stack.py's files instead")
    ap.add_argument("--out", type=Path, default=Path("probes.json"))
    a = ap.parse_args(argv)
    if a.few:
        gaussian.files = few_files(a.few)
    run(a, None, measure)


if __name__ == "__main__":
    main()
