"""Other levels than 90 %; sharper radii for the adapted path and the shipped dictionary.

Four questions on caches of ``calibrate.py`` (validation; fitted on mask seed
0, read on mask seed 1):

1. **Levels.** :func:`sparseedm.uncertainty.radius_at` scaled the 90 % radius
   as a 2D Gaussian's radii scale; the errors have heavier tails. The
   measured factors (per way, the real people's quantiles of error over the
   90 % radius at :data:`sparseedm.uncertainty.LEVELS`,
   :func:`calibrate.fit_levels`) against that rule: the observed coverage at
   each level per way, pooled and per source x protocol.
2. **The adapted path's own error.** The adaptation's guard measures the
   adapted dictionary's error on held-back complete poses of the file
   (``res.adaptation.err_adapted``, the Mix Err_ave in %); the ``adapted``
   rule did not read it. Variants of that rule (its log as a feature,
   ``log_guard_error``; conformal floors) re-fitted on seed 0 and read on
   seed 1: coverage, mean radius over mean error and the rank correlation of
   radius and error per photo protocol of the way.
3. **The shipped dictionary's rule** (``per_frame``) re-fitted on the current
   answers, with conformal floors from 0.86 to 0.91 (``--part per_frame``).
4. **Clean motion capture in short gaps** (``--part temporal``): the track's
   noise weighed more near the observed frames (its log over ``1 + log
   frames``, or times ``exp(-log frames)``), against the rule as it is.

The adapted path runs on five validation files (``calibrate.py``'s
defaults): Bonn frames, Bonn topped up to 1,500 complete poses with training
frames, and MPII topped up to 500, 1,000 and 2,000 (1,418) with training
poses::

    python studies/uncertainty/calibrate.py --check --cache /tmp/val0.npz -o /tmp/c0.json
    python studies/uncertainty/calibrate.py --check --mask-seed 1 --cache /tmp/val1.npz -o /tmp/c1.json
    python studies/uncertainty/sharp_levels.py --part levels \\
        --fit-cache /tmp/val0.npz --check-cache /tmp/val1.npz     # and --part adapted, per_frame

(``--part levels`` reads the module's rules as they are: run it on the
table shipped.)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import calibrate  # noqa: E402

from sparseedm._atomic import json_text  # noqa: E402
from sparseedm import uncertainty  # noqa: E402

BASE = dict(uncertainty.FEATURES)
#: the adapted rule before it read the guard's error (its features, and its entry)
OLD = uncertainty.UNCHECKED_FEATURES["adapted"]
#: the entries shipped before
BEFORE = {"temporal": uncertainty.CALIBRATION["temporal"],
          "adapted": {"conformal": 1.3181, "coef": (-1.7032, 0.3743, 0.4231, 0.2755, 0.0849)},
          "per_frame": {"conformal": 1.0682,
                        "coef": (2.4431, 0.6146, 0.4932, 0.1552, 0.4376, 0.7945)}}
GAUSSIAN = tuple(float(np.sqrt(-2 * np.log1p(-p)) / uncertainty.NOISE_RADIUS)
                 for p in uncertainty.LEVELS)
#: name: (features of the adapted rule, its conformal floor)
#: per way: name: (features of the way's rule, its conformal floor; None: as before)
VARIANTS = {
    "adapted": {
        "before": (OLD, None),
        "refit": (OLD, 0.89),
        "+ log guard error": (OLD + ("log_guard_error",), 0.89),
        "+ log guard error, floor 0.86": (OLD + ("log_guard_error",), 0.86),
        "+ log guard error, residual": (OLD + ("log_guard_error", "log_residual"), 0.89),
    },
    "per_frame": {"before": (BASE["per_frame"], None),
                  **{f"refit, floor {f:.2f}": (BASE["per_frame"], f)
                     for f in (0.86, 0.89, 0.90, 0.91)}},
    # the track's noise weighed more near the observed frames (clean mocap, short gaps)
    "temporal": {"before": (BASE["temporal"], None),
                 "refit": (BASE["temporal"], 0.86),
                 "+ noise / (1 + log frames)": (BASE["temporal"] + ("noise_near",), 0.86),
                 "+ noise * exp(-log frames)": (BASE["temporal"] + ("noise_decay",), 0.86)},
}


def load(path):
    """The joints of a calibrate.py cache, with the candidate interactions of the
    track's noise and the frames to the nearest observation."""
    with np.load(path, allow_pickle=False) as f:
        data = {k: f[k] for k in f.files if k not in ("settings", "refused")}
    data["noise_near"] = data["log_noise"] / (1 + data["log_frames"])
    data["noise_decay"] = data["log_noise"] * np.exp(-data["log_frames"])
    return data


def reliability(data, table):
    """{group: {level: observed coverage}} with `table`'s level factors, per way,
    every joint, the real people's, and per source x protocol; and the pooled
    factors' on every joint."""
    radius = calibrate._radius(data, np.ones(len(data["error"]), bool), table)
    labels, ways = data["label"].astype(str), data["way"].astype(str)
    groups = {lab: labels == lab for lab in np.unique(labels)}
    groups.update({f"way {w}": ways == w for w in np.unique(ways)})
    groups["all"] = np.ones(len(labels), bool)
    groups["all real"] = ~np.char.startswith(labels, "cmu|")
    out = {}
    for name, at in groups.items():
        r, e = radius[at], data["error"][at]
        out[name] = {str(p): round(float((e <= uncertainty.radius_at(
            r, p, ways[at], table)).mean()), 4) for p in uncertainty.LEVELS}
    out["all, pooled factors"] = {str(p): round(float((data["error"] <= uncertainty.radius_at(
        radius, p, None, table)).mean()), 4) for p in uncertainty.LEVELS}
    return out


def worst(rows, names):
    """The largest |observed - nominal| over the levels and the rows `names`."""
    return max(abs(rows[n][p] - float(p)) for n in names for p in rows[n])


def levels_part(fit_data, check_data):
    gauss = {w: dict(e, levels=GAUSSIAN) for w, e in uncertainty.CALIBRATION.items()}
    measured = calibrate.fit_levels(fit_data, dict(uncertainty.CALIBRATION))
    out = {}
    for name, table in (("gaussian", gauss), ("measured factors", measured)):
        rows = reliability(check_data, table)
        summary = [n for n in rows if n.startswith("way ") or n.startswith("all")]
        out[name] = {"levels": {w: table[w]["levels"] for w in table},
                     "worst_way_or_pooled": round(worst(rows, summary), 4),
                     "check_seed": rows}
        print(f"{name}: worst |observed - nominal| per way / pooled on the check seed "
              f"{out[name]['worst_way_or_pooled']:.3f}")
        for n in summary:
            print(f"   {n:24s} " + " ".join(f"{p}:{v:.3f}" for p, v in rows[n].items()))
    return out


def sharpness(data, table, way):
    """{protocol of `way`: coverage, mean radius / mean error, Spearman}."""
    from scipy.stats import spearmanr

    radius = calibrate._radius(data, np.ones(len(data["error"]), bool), table)
    out = {}
    for lab in np.unique(data["label"][data["way"] == way]):
        at = (data["label"] == lab) & (data["way"] == way)
        r, e = radius[at], data["error"][at]
        out[str(lab)] = {"joints": int(at.sum()), "coverage": round(float((e <= r).mean()), 4),
                         "radius_over_error": round(float(r.mean() / e.mean()), 3),
                         "spearman": round(float(spearmanr(r, e)[0]), 3)}
    return out


def refit_part(fit_data, check_data, way):
    """Each of the way's :data:`VARIANTS` re-fitted on `fit_data` (the way only),
    its protocols read on both caches."""
    out = {}
    calibrate.KEYS = sorted(set(calibrate.KEYS) | {"noise_near", "noise_decay"})
    for name, (features, floor) in VARIANTS[way].items():
        uncertainty.FEATURES[way] = features
        if floor is None:
            table = dict(uncertainty.CALIBRATION, **{way: BEFORE[way]})
        else:
            calibrate.WAY_MIN_COVERAGE = dict(calibrate.WAY_MIN_COVERAGE, **{way: floor})
            table = calibrate.fit(fit_data, ways=[way])
        rows = sharpness(check_data, table, way)
        out[name] = {"features": list(features), "entry": table[way],
                     "fit_seed": sharpness(fit_data, table, way), "check_seed": rows}
        print(f"{name}: {table[way]}")
        for lab, r in rows.items():
            print(f"   {lab:40s} coverage {r['coverage']:.3f} radius/error "
                  f"{r['radius_over_error']:.2f} spearman {r['spearman']:.2f}")
    uncertainty.FEATURES.clear()
    uncertainty.FEATURES.update(BASE)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fit-cache", required=True, help="calibrate.py cache, mask seed 0")
    ap.add_argument("--check-cache", required=True, help="calibrate.py cache, mask seed 1")
    ap.add_argument("--part", choices=("levels", "adapted", "per_frame", "temporal"),
                    required=True)
    ap.add_argument("-o", "--output", help="default sharp_levels_<part>.json beside this script")
    args = ap.parse_args(argv)
    fit_data, check_data = load(args.fit_cache), load(args.check_cache)
    out = levels_part(fit_data, check_data) if args.part == "levels" else \
        refit_part(fit_data, check_data, args.part)
    output = args.output or Path(__file__).with_name(f"sharp_levels_{args.part}.json")
    Path(output).write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
