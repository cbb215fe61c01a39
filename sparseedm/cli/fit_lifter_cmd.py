"""``sparseedm fit-lifter TRAIN.npz -o L.npz --method dictionary|mlp|fconv``: learn a lifter."""

from __future__ import annotations

import sys
import time

import numpy as np

from ._common import add_quiet


def add_parser(sub):
    """Add the ``sparseedm fit-lifter`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "fit-lifter", help="learn a 2D -> 3D lifter from a training .npz with poses3d",
        description="Learn a lifter from the complete poses of TRAIN (as written by "
        "`sparseedm dataset build`: poses2d, poses3d, camera_R/t/f). Methods: "
        "dictionary (coupled [2D ; w 3D] dictionary, the default), mlp (DMR's FConn) and "
        "fconv (DMR's fully convolutional network; needs the torch extra). "
        "Defaults are the settings chosen on CMU validation clips "
        "(docs/explanation/settings.md).",
    )
    p.add_argument("train", help="training .npz with poses2d, poses3d and cameras")
    p.add_argument("-o", "--output", required=True, help="lifter file to write (.npz)")
    p.add_argument("--method", default="dictionary",
                   help="dictionary (default), mlp or fconv (torch extra)")
    p.add_argument("--atoms", metavar="K", type=int, default=None, help="dictionary: atoms k (default 2000)")
    p.add_argument("--alpha", type=float, default=None,
                   help="dictionary: training lasso alpha (default 1.6); mlp: L2 penalty "
                   "(default 0.0001)")
    p.add_argument("--alpha-lift", metavar="ALPHA", type=float, default=None, help="dictionary: lifting alpha (default 0.002)")
    p.add_argument("--weight", metavar="W", type=float, default=None, help="dictionary: 3D weight w (default 1)")
    p.add_argument("--passes", metavar="P", type=float, default=None, help="dictionary: passes (default 2)")
    p.add_argument("--decoder-ridge", type=_ridge, default=None, metavar="RHO|none",
                   help="dictionary: ridge penalty per pose of the 3D-half re-fit "
                   "(default 0.01; 'none' keeps the learned 3D halves)")
    p.add_argument("--hidden", metavar="SIZES", default=None, help="mlp: hidden layer sizes (default 400,400,400)")
    p.add_argument("--max-iter", metavar="N", type=int, default=None, help="mlp: epochs at most (default 200)")
    p.add_argument("--representation", choices=("average", "zero"), default=None,
                   help="fconv: occlusion representation of the input (default average)")
    p.add_argument("--occluded", default=None, metavar="LO-HI",
                   help="fconv: occluded joints per training pose, e.g. 1-3 to retrain end "
                   "to end on occluded input (default 0-0, complete)")
    p.add_argument("--channels", metavar="C1,C2", default=None, help="fconv: encoder channels C1,C2 (default 32,64)")
    p.add_argument("--epochs", metavar="N", type=int, default=None, help="fconv: most epochs (default 30)")
    p.add_argument("--batch-size", metavar="N", type=int, default=None, help="fconv: mini-batch size (default 256)")
    p.add_argument("--normalization", choices=("tied", "unit"), default=None,
                   help="3D EDM normalisation (default tied)")
    p.add_argument("--max-train", metavar="N", type=int, default=None,
                   help="use a seeded subsample of this many training poses (default: "
                   "every training pose)")
    p.add_argument("--seed", metavar="N", type=int, default=0, help="random seed (default 0)")
    add_quiet(p)
    p.set_defaults(func=run)


_DICT_OPTS = {"atoms": "n_components", "alpha": "alpha", "alpha_lift": "alpha_lift",
              "weight": "weight", "passes": "n_passes", "decoder_ridge": "decoder_ridge",
              "normalization": "normalization"}
def _ridge(text):
    import argparse

    if text.lower() == "none":
        return "none"
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0 or 'none', got {text!r}")
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a number > 0 or 'none', got {text!r}")
    return value


_MLP_OPTS = {"alpha": "alpha", "max_iter": "max_iter", "normalization": "normalization"}
_FCONV_OPTS = {"representation": "representation", "epochs": "max_epochs",
               "batch_size": "batch_size", "normalization": "normalization"}


def run(args):
    """Run ``sparseedm fit-lifter``: learn a 2D-to-3D lifter from a training set and save it.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 when done.

    Raises
    ------
    SparseEDMError
        If the training set has too few usable poses; ``main`` turns it into exit code 2.
    """
    from pathlib import Path

    from ..dataset import load_dataset
    from ..exceptions import SparseEDMError
    from ..learning import poses_sha256
    from ..lifting import fit_lifter
    from ..lifting.base import LIFTERS, lifter_class
    from ..lifting.defaults import DEFAULTS

    from .._atomic import check_paths

    lifter_class(args.method, "--method")  # refuses unknown methods, naming the known
    check_paths([("training file", args.train)], [("output", args.output)])
    opts = {"dictionary": _DICT_OPTS, "mlp": _MLP_OPTS, "fconv": _FCONV_OPTS}[args.method]
    params = dict(DEFAULTS.get(args.method, {}))
    for opt, name in opts.items():
        if getattr(args, opt) is not None:
            params[name] = None if getattr(args, opt) == "none" else getattr(args, opt)
    if args.method == "mlp" and args.hidden:
        params["hidden_layer_sizes"] = tuple(int(h) for h in args.hidden.split(","))
    if args.method == "fconv":
        from ..fconv.network import require_torch
        from ._common import channels, occluded_range

        require_torch()  # before any data is read: names the torch extra
        params["occluded"] = occluded_range(args.occluded, params["occluded"])
        if args.channels:
            params["channels"] = channels(args.channels)
    params["random_state"] = args.seed
    data = load_dataset(args.train)
    idx = np.arange(len(data["poses2d"]))  # load_dataset refuses NaN: all complete
    if args.max_train and args.max_train < len(idx):
        idx = np.sort(np.random.default_rng(args.seed).choice(idx, args.max_train, replace=False))
    if len(idx) < 10:
        raise SparseEDMError(f"{args.train}: {len(idx)} training poses are too few")
    t0 = time.perf_counter()
    prov = {"files": [Path(args.train).name], "sha256": poses_sha256(data["poses2d"][idx]),
            "sha256_of": "poses2d float64 values", "seed": args.seed}
    clips = data["clips"][idx] if "clips" in data else None
    lifter = fit_lifter(data["poses2d"][idx], data["poses3d"][idx], data["camera_R"][idx],
                        data["camera_t"][idx], data["camera_f"][idx], method=args.method,
                        provenance=prov, clips=clips, **params)
    lifter.save(args.output)
    print(f"wrote {args.output}: {args.method} lifter from {len(idx)} poses in "
          f"{time.perf_counter() - t0:.1f} s (known methods: {', '.join(LIFTERS)})",
          file=sys.stderr if args.quiet else sys.stdout)
    return 0

