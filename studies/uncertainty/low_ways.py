"""The low end of the fast preset's and the adapted path's radius: re-fits compared.

Re-fits the ``local_ridge`` (``preset="fast"``) and ``adapted`` rules of
:data:`sparseedm.uncertainty.CALIBRATION` on one cache of
``calibrate.py`` (validation, mask seed 0) and reads them on another (mask
seed 1): candidate features (the file's complete poses, the residual for the
adapted path, the hidden count's square or its excess over 8 joints) and
higher conformal floors (the coverage below which no real-people protocol of
the way may fall on the fitting seed; ``calibrate.WAY_MIN_COVERAGE``). Per
variant: coverage, mean radius over the pose's size and informativeness (the
smallest-radius quarter's mean error over the largest's) of each photo
protocol of the two ways.

    python studies/uncertainty/calibrate.py --check --cache /tmp/val0.npz -o /tmp/c0.json
    python studies/uncertainty/calibrate.py --check --mask-seed 1 --cache /tmp/val1.npz -o /tmp/c1.json
    python studies/uncertainty/low_ways.py --fit-cache /tmp/val0.npz --check-cache /tmp/val1.npz
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

WAYS = ("local_ridge", "adapted")
BASE = dict(uncertainty.FEATURES)
#: name: (extra features per way, {way: conformal floor})
VARIANTS = {
    "shipped before": (None, {}),
    "refit": ({}, {}),
    "+ log complete poses": ({w: ("log_complete",) for w in WAYS}, {}),
    "adapted + residual": ({"adapted": ("log_residual",)}, {}),
    "+ hidden beyond 8": ({w: ("many_hidden",) for w in WAYS}, {}),
    "+ log hidden squared": ({w: ("log_missing_sq",) for w in WAYS}, {}),
    "floors 0.89 / 0.89": ({}, {"local_ridge": 0.89, "adapted": 0.89}),
    "floors 0.90 / 0.90": ({}, {"local_ridge": 0.90, "adapted": 0.90}),
    "floors 0.91 / 0.89": ({}, {"local_ridge": 0.91, "adapted": 0.89}),
    "+ hidden beyond 8, floors 0.89": ({w: ("many_hidden",) for w in WAYS},
                                       {"local_ridge": 0.89, "adapted": 0.89}),
}
#: the table as it was before the floors (the rules fitted on answers of one code)
BEFORE = {"adapted": {"conformal": 1.1945, "coef": (-1.7005, 0.3744, 0.4231, 0.2761, 0.0855)},
          "local_ridge": {"conformal": 1.086,
                          "coef": (-0.1289, 0.4269, 0.4935, 0.3076, 0.4877, 0.1854)}}


def load(path):
    """A calibrate.py cache with the derived candidate features."""
    with np.load(path, allow_pickle=False) as f:
        data = {k: f[k] for k in f.files if k != "settings"}
    hidden = np.round(np.exp(data["log_missing"]))
    data["many_hidden"] = np.maximum(hidden - 8, 0)
    data["log_missing_sq"] = data["log_missing"] ** 2
    return data


def rows_of(data, table):
    """{protocol: coverage, radius / size, informativeness} of the two ways' photos."""
    out = {}
    for lab, row in calibrate.report(data, table).items():
        if "|" in lab and set(row["by_way"]) <= set(WAYS) and "photos" in lab:
            out[lab] = {"coverage": row["coverage"],
                        "radius_of_size": row["mean_radius_of_size"],
                        "informativeness": row["informativeness"]}
    return out


def variant(fit_data, check_data, extra, floors):
    """One variant's table (fitted on `fit_data`) and its rows on both caches."""
    uncertainty.FEATURES.clear()
    uncertainty.FEATURES.update(BASE)
    if extra is None:
        table = dict(uncertainty.CALIBRATION)
        table.update(BEFORE)
    else:
        uncertainty.FEATURES.update({w: BASE[w] + f for w, f in extra.items()})
        calibrate.WAY_MIN_COVERAGE = floors
        table = calibrate.fit(fit_data, ways=list(WAYS))
    return {"table": {w: table[w] for w in WAYS}, "fit_seed": rows_of(fit_data, table),
            "check_seed": rows_of(check_data, table)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fit-cache", required=True, help="calibrate.py cache, mask seed 0")
    ap.add_argument("--check-cache", required=True, help="calibrate.py cache, mask seed 1")
    ap.add_argument("-o", "--output", default=str(Path(__file__).with_name("low_ways.json")))
    args = ap.parse_args(argv)
    fit_data, check_data = load(args.fit_cache), load(args.check_cache)
    calibrate.KEYS = sorted(set(calibrate.KEYS) | {"many_hidden", "log_missing_sq"})
    out = {}
    for name, (extra, floors) in VARIANTS.items():
        out[name] = variant(fit_data, check_data, extra, floors)
        low = min(r["coverage"] for r in out[name]["check_seed"].values())
        print(f"{name:34s} lowest on the check seed {low:.3f}")
        for lab, r in out[name]["check_seed"].items():
            print(f"   {lab:38s} {r['coverage']:.3f} radius/size {r['radius_of_size']:.3f} "
                  f"informativeness {r['informativeness']:.2f}")
    Path(args.output).write_text(json_text(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
