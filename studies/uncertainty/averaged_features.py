"""Features that see the averaged answers: do they calibrate the 90 % radius better?

The default path averages some poses' answers with a local ridge's
(``RecoveryResult.averaged``: poses of at least 4 hidden joints, or every
occluded pose when the held-back check prefers the mean) and averages three or
two codes on its averaging paths. The table of ``sparseedm.uncertainty`` was
fitted on answers of one code. This study re-fits the two ways of filling
whose answers are averaged (``per_frame``, ``file_atoms``; the other ways'
answers are unchanged and keep their entries) with candidate features read
from the result's record (:func:`sparseedm.uncertainty.joint_features`):

* ``averaged``: how many answers were averaged into the pose's (0, 1, 2);
* ``log_spread``: log of the distance between the two answers averaged at
  the joint over the pose's size, plus ``SPREAD_FLOOR`` (0 when nothing
  was averaged: the floor's log);
* ``log_complete``: log(1 + the file's complete poses);
* ``checked``, ``log_held_error``: whether the default path's check measured
  its answer's error on held-back complete poses of the file, and the log of
  that error (a fraction of the pose's size; 0 unchecked).

It fits on the joints ``calibrate.py`` collected on validation masks of seed 0
and reads the coverage on new validation masks (seed 1); the test split is
never read here::

    python studies/uncertainty/calibrate.py --check --cache /tmp/val0.npz -o /tmp/c0.json
    python studies/uncertainty/calibrate.py --check --mask-seed 1 --cache /tmp/val1.npz \
        -o /tmp/c1.json
    python studies/uncertainty/averaged_features.py --fit-cache /tmp/val0.npz \
        --check-cache /tmp/val1.npz          # writes averaged_features.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
sys.path.insert(0, str(HERE))

import calibrate  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.uncertainty import CALIBRATION, FEATURES  # noqa: E402

#: the ways of filling whose answers the default path averages
WAYS = ("per_frame", "file_atoms")
#: their features and entries before this study (fitted on answers of one code)
BEFORE_FEATURES = ("const", "log_missing", "hops", "depth", "log_disagreement", "log_residual")
BEFORE = {"per_frame": {"conformal": 1.0682,
                        "coef": (2.4431, 0.6146, 0.4932, 0.1552, 0.4376, 0.7945)},
          "file_atoms": {"conformal": 1.0632,
                         "coef": (1.8037, 0.3945, 0.3829, 0.2546, 0.6612, 0.48)}}
#: log_spread = log(spread / size + SPREAD_FLOOR)
SPREAD_FLOOR = 0.01
#: candidate feature sets added to each way's own (None: its BEFORE entry, no fit)
#: marks a variant fitted on the checked files only (:func:`fit_variant`)
CHECKED = "checked files only"
_BOTH = {
    "refit": (),
    "averaged": ("averaged",),
    "spread": ("log_spread",),
    "averaged+spread": ("averaged", "log_spread"),
    "averaged+spread+complete": ("averaged", "log_spread", "log_complete"),
    "held": ("checked", "log_held_error"),
    "spread+held": ("log_spread", "checked", "log_held_error"),
    "averaged+spread+held": ("averaged", "log_spread", "checked", "log_held_error"),
}
VARIANTS = {"before": {"per_frame": None, "file_atoms": None},
            **{name: {"per_frame": extra, "file_atoms": extra} for name, extra in _BOTH.items()},
            # file atoms only (per_frame's entry as before): its files are the ones checked
            **{f"file_atoms:{name}": {"per_frame": None, "file_atoms": _BOTH[name]}
               for name in ("held", "spread+held", "averaged+spread+held")},
            # the held-back error, fitted on the checked files only; files without
            # it keep the rule before (its unchecked term rested on one mocap file)
            "file_atoms:held, checked files": {"per_frame": None,
                                               "file_atoms": (CHECKED, "log_held_error")}}
#: the rule a real-people protocol's coverage is held to (calibrate.MIN_COVERAGE)
LOW = calibrate.MIN_COVERAGE
calibrate.KEYS.append("log_spread")  # derived here from rel_spread (load)


def load(path):
    with np.load(path, allow_pickle=False) as f:
        data = {k: f[k] for k in f.files if k != "settings"}
    data["log_spread"] = np.log(data["rel_spread"] + SPREAD_FLOOR)
    return data


def _subset(data, at):
    return {k: (v if k == "refused" else v[at]) for k, v in data.items()}


def fit_variant(data, extras):
    """The table of WAYS, each re-fitted on `data` with its `extras` features
    added to BEFORE_FEATURES (None: its BEFORE entry), and each way's feature names."""
    saved = {w: FEATURES[w] for w in WAYS}
    entries = {w: CALIBRATION[w] for w in WAYS}
    fitted = [w for w in WAYS if extras[w] is not None]
    table = dict(BEFORE)
    try:
        for w in WAYS:
            extra = tuple(extras[w] or ())
            # CHECKED: fitted on the checked files only, the others keep BEFORE's rule
            CALIBRATION[w] = dict(BEFORE[w], **(
                {"unchecked": BEFORE[w]} if extra[:1] == (CHECKED,) else {}))
            FEATURES[w] = BEFORE_FEATURES + tuple(f for f in extra if f != CHECKED)
        if fitted:
            found = calibrate.fit(_subset(data, np.isin(data["way"], fitted)))
            table.update({w: found[w] for w in fitted})
        return {w: table[w] for w in WAYS}, {w: FEATURES[w] for w in WAYS}
    finally:
        FEATURES.update(saved)
        CALIBRATION.update(entries)


def measure(data, table, names):
    """Coverage per label and way (calibrate.report) with `names` as WAYS' features."""
    saved = {w: FEATURES[w] for w in WAYS}
    try:
        FEATURES.update(names)
        return calibrate.report(data, table)
    finally:
        FEATURES.update(saved)


def digest(rows):
    """The real-people protocols' coverage (the ones WAYS fill), their lowest,
    how many fall below LOW, each way's pooled coverage and rank correlation."""
    real = {lab: r for lab, r in rows.items()
            if "|" in lab and not lab.startswith("cmu|video") and not lab.endswith("gaps")
            and set(r["by_way"]) & set(WAYS)}
    photos = {lab: r["coverage"] for lab, r in real.items() if not lab.startswith("cmu|")}
    return {"protocols": {lab: real[lab]["coverage"] for lab in sorted(real)},
            "rank": {lab: real[lab]["spearman"] for lab in sorted(real)},
            "lowest_real": min(photos.values()),
            "below_rule": sorted(lab for lab, c in photos.items() if c < LOW),
            "ways": {w: {"coverage": rows[w]["coverage"], "spearman": rows[w]["spearman"],
                         "informativeness": rows[w]["informativeness"]}
                     for w in WAYS if w in rows}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fit-cache", required=True, help="calibrate.py's cache, val seed 0")
    ap.add_argument("--check-cache", required=True, help="calibrate.py's cache, val seed 1")
    ap.add_argument("-o", "--output", default=str(HERE / "averaged_features.json"))
    args = ap.parse_args(argv)
    fit_data, check_data = load(args.fit_cache), load(args.check_cache)
    out = {"spread_floor": SPREAD_FLOOR, "variants": {}}
    for name, extras in VARIANTS.items():
        table, names = fit_variant(fit_data, extras)
        out["variants"][name] = {
            "features": {w: list(v) for w, v in names.items()}, "calibration": table,
            "fit_seed0": digest(measure(fit_data, table, names)),
            "check_seed1": digest(measure(check_data, table, names))}
        c = out["variants"][name]["check_seed1"]
        print(f"{name:26s} seed 1: lowest {c['lowest_real']:.3f} below {c['below_rule']} "
              + " ".join(f"{w} {v['coverage']:.3f}/{v['spearman']:.2f}"
                         for w, v in c["ways"].items()), flush=True)
    Path(args.output).write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
