"""Checks on the choice of select_all_cmu.py: noise, the grid's edge, and the old default's alpha.

On the same held-out subjects and validation poses as ``select_all_cmu.py``:

* the chosen setting (training alpha 0.8, one pass) at recovery alpha 0.0002
  (below the grid) and 0.0005 (chosen);
* ``cmu-k2000`` at its own recovery alpha (0.002) and at 0.0005, so the gain
  is not only the recovery alpha;
* paired per-pose differences (new - cmu-k2000) with their standard error.

    python studies/dictionary/check_all_cmu.py --cmu cmu_asf.npz \\
        --daz salsa=daz_salsa.npz,martial=daz_martial.npz,indian=daz_indian.npz \\
        --out studies/dictionary/selection_all_cmu_check.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.dictionary.select_all_cmu import data_parser, load_split, sample  # noqa: E402

from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import Dictionary, load_dictionary  # noqa: E402
from sparseedm.edm import pose_to_vector  # noqa: E402
from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors  # noqa: E402
from sparseedm.metrics import err_ave, random_occlusion  # noqa: E402
from sparseedm.recovery import recover  # noqa: E402


def per_pose(dictionary, poses, alpha, seed=0):
    mask = random_occlusion(len(poses), 14, "mix", random_state=seed)
    res = recover(np.where(mask[..., None], np.nan, poses), mask, dictionary=dictionary,
                  alpha=alpha)
    return err_ave(res.vectors * res.scale[:, None], pose_to_vector(poses))


def main(argv=None):
    ap = data_parser(__doc__)
    ap.add_argument("--max-val", type=int, default=1000)
    ap.add_argument("--out", default="selection_all_cmu_check.json")
    args = ap.parse_args(argv)
    poses, groups, sources, is_val = load_split(args)
    val = {s: sample(poses[is_val & (sources == s)], args.max_val // 2) for s in ("cmu-asf", "daz")}
    X, _ = complete_pose_vectors(poses[~is_val])
    odl = OnlineDictionaryLearning(2000, alpha=0.8, batch_size=512, n_passes=1,
                                   random_state=0).fit(X)
    new = Dictionary(odl.components_, alpha_recover=0.0005, alpha_train=0.8)
    old = load_dictionary("cmu-k2000")
    errs = {}
    for label, d, alpha in [("new@0.0002", new, 0.0002), ("new@0.0005", new, 0.0005),
                            ("cmu-k2000@0.002", old, 0.002), ("cmu-k2000@0.0005", old, 0.0005)]:
        errs[label] = {s: per_pose(d, v, alpha) for s, v in val.items()}
        print(label, {s: float(np.nanmean(e)) for s, e in errs[label].items()}, flush=True)

    def mean(label):
        return float(np.mean([np.nanmean(e) for e in errs[label].values()]))

    def paired(a, b):
        out = {}
        for s in val:
            diff = errs[a][s] - errs[b][s]
            diff = diff[np.isfinite(diff)]
            out[s] = {"mean": float(diff.mean()), "se": float(diff.std(ddof=1) / np.sqrt(len(diff))),
                      "n": int(len(diff))}
        return out

    result = {
        "mix_err_ave": {label: mean(label) for label in errs},
        "mix_err_ave_per_source": {label: {s: float(np.nanmean(e)) for s, e in v.items()}
                                   for label, v in errs.items()},
        "paired_new@0.0005_minus_cmu-k2000@0.002": paired("new@0.0005", "cmu-k2000@0.002"),
        "paired_new@0.0002_minus_new@0.0005": paired("new@0.0002", "new@0.0005"),
    }
    with open(args.out, "w") as f:
        f.write(json_text(result, indent=1))
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
