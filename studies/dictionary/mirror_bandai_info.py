"""Information only (never used to choose): does mirroring help on foreign poses?

The chosen setting (training alpha 0.8, recovery alpha 0.0005, one pass)
learned on the training groups of select_all_cmu.py with and without
left-right mirrored copies, scored (Mix Err_ave) on Bandai-Namco poses -- the
cross-source check the 4 % figure of dictionaries/README.md came from. Bandai-Namco is CC BY-NC:
only these numbers are kept.

    python studies/dictionary/mirror_bandai_info.py --cmu cmu_asf.npz \\
        --daz salsa=daz_salsa.npz,martial=daz_martial.npz,indian=daz_indian.npz \\
        --bandai bandai.npz --out studies/dictionary/selection_all_cmu_mirror_bandai.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.dictionary.check_all_cmu import per_pose  # noqa: E402
from studies.dictionary.select_all_cmu import data_parser, load_split, mirrored, sample  # noqa: E402

from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import Dictionary  # noqa: E402
from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors  # noqa: E402


def main(argv=None):
    ap = data_parser(__doc__)
    ap.add_argument("--bandai", required=True)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--out", default="selection_all_cmu_mirror_bandai.json")
    args = ap.parse_args(argv)
    poses, _, _, is_val = load_split(args)
    train = poses[~is_val]
    with np.load(args.bandai, allow_pickle=False) as npz:
        bandai = sample(npz["poses2d"], args.n)
    errs = {}
    for label, data in (("plain", train), ("mirrored", np.concatenate([train, mirrored(train)]))):
        X, _ = complete_pose_vectors(data)
        odl = OnlineDictionaryLearning(2000, alpha=0.8, batch_size=512, n_passes=1,
                                       random_state=0).fit(X)
        d = Dictionary(odl.components_, alpha_recover=0.0005, alpha_train=0.8)
        errs[label] = per_pose(d, bandai, 0.0005)
        print(label, float(np.nanmean(errs[label])), flush=True)
    diff = errs["mirrored"] - errs["plain"]
    diff = diff[np.isfinite(diff)]
    result = {"n_bandai": int(len(bandai)),
              "mix_err_ave": {k: float(np.nanmean(v)) for k, v in errs.items()},
              "paired_mirrored_minus_plain": {"mean": float(diff.mean()),
                                              "se": float(diff.std(ddof=1) / np.sqrt(len(diff)))}}
    with open(args.out, "w") as f:
        f.write(json_text(result, indent=1))
    print(json.dumps(result))


if __name__ == "__main__":
    main()
