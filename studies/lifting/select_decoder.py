"""Choose the dictionary lifter's 3D-half re-fit (``decoder_ridge``) and passes.

    python studies/lifting/select_decoder.py /tmp/lift/cmu.npz -o studies/lifting/selection_decoder.json

Chosen on the *training* clips of ``select_lifter.py``'s clip split only: a
seeded fifth of them (seed 1) is held out as an inner validation set, so the
validation clips that ``select_lifter.py`` and ``benchmarks/lifting.py``
report on play no part in this choice. Each fit uses the shipped settings
(``studies/lifting/selection.json`` ``"shipped"``) on 15,000 poses of the other
training clips; for each number of passes the lifting codes of those poses
are computed once and every ridge penalty rho re-fits the 3D halves from the
same statistics (``DictionaryLifter._decoder_stats`` / ``_solve_decoder``).
Criterion, as ``select_lifter.py``: the mean of complete and Mix 3D-EDM
Err_ave (per cent, one least-squares scale per pose) on 1,500 inner
validation poses.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.lifting.select_lifter import arrays, split  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.lifting import fit_lifter, lift, training_pairs  # noqa: E402
from sparseedm.lifting.metrics import err_ave_3d  # noqa: E402
from sparseedm.metrics import random_occlusion  # noqa: E402

RHOS = (None, 0.0001, 0.0003, 0.001, 0.003, 0.01, 0.03, 0.1)


def inner_split(data, tr, seed=1, frac=0.2):
    clips = np.unique(data["clips"][tr])
    rng = np.random.default_rng(seed)
    held = set(rng.choice(clips, int(round(frac * len(clips))), replace=False).tolist())
    is_held = np.array([c in held for c in data["clips"][tr]])
    return tr[~is_held], tr[is_held]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("train")
    ap.add_argument("-o", "--output", default="selection_decoder.json")
    ap.add_argument("--max-train", type=int, default=15000)
    ap.add_argument("--max-val", type=int, default=1500)
    args = ap.parse_args(argv)
    with np.load(args.train, allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    tr, _ = split(data)
    fit_ix, val = inner_split(data, tr)
    rng = np.random.default_rng(0)
    fit_ix = np.sort(rng.choice(fit_ix, min(args.max_train, len(fit_ix)), replace=False))
    val = np.sort(rng.choice(val, min(args.max_val, len(val)), replace=False))
    mask = random_occlusion(len(val), 14, "mix", random_state=1)
    shipped = json.loads((Path(__file__).parent / "selection.json").read_text())["shipped"]
    params = {k: shipped[k] for k in ("normalization", "alpha", "weight", "n_components",
                                      "alpha_lift")}
    X2, X3, _, _ = training_pairs(*arrays(data, fit_ix), params["normalization"])
    _, V3, _, _ = training_pairs(*arrays(data, val), params["normalization"])
    results = []
    for passes in (1, 2):
        t = time.perf_counter()
        lf = fit_lifter(*arrays(data, fit_ix), method="dictionary", n_passes=passes,
                        decoder_ridge=None, **params)
        fit_s = time.perf_counter() - t
        learned = lf.components_
        t = time.perf_counter()
        G, B = lf._decoder_stats(X2, lf.weight * X3)
        stats_s = time.perf_counter() - t
        for rho in RHOS:
            lf.components_ = learned  # every rho shrinks towards the learned halves
            if rho is not None:
                lf.components_ = lf._solve_decoder(G, B, rho, len(X2))
            c = float(np.nanmean(err_ave_3d(lift(data["poses2d"][val], lifter=lf).vectors3d, V3)))
            m = float(np.nanmean(err_ave_3d(
                lift(data["poses2d"][val], mask, lifter=lf).vectors3d, V3)))
            row = {"n_passes": passes, "decoder_ridge": rho, "complete": round(c, 3),
                   "mix": round(m, 3), "score": round((c + m) / 2, 3),
                   "fit_seconds": round(fit_s, 1), "refit_stats_seconds": round(stats_s, 1)}
            results.append(row)
            print(json.dumps(row), flush=True)
    chosen = min(results, key=lambda r: r["score"])
    doc = {
        "data": "CMU cmu-mocap (sparseedm dataset build --seed 0); the training clips of "
                "select_lifter.py's split, a fifth of them (seed 1) held out as inner validation",
        "n_train": int(len(fit_ix)), "n_val": int(len(val)), "settings": params,
        "criterion": "mean of complete and Mix 3D-EDM Err_ave (per cent, after one "
                     "least-squares scale per pose)",
        "results": results, "chosen": chosen,
    }
    Path(args.output).write_text(json_text(doc, indent=1))
    print("chosen:", json.dumps(chosen))


if __name__ == "__main__":
    main()
