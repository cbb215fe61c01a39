"""``sparseedm fit-cnn TRAIN.npz -o fconv.npz``: train the FConv network (torch extra)."""

from __future__ import annotations

import sys
from pathlib import Path

from ..exceptions import FileFormatError, SparseEDMError
from ._common import add_quiet, channels, load_npz, occluded_range, show_progress


def add_parser(sub):
    """Add the ``sparseedm fit-cnn`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "fit-cnn",
        help="train the paper's FConv network (needs the torch extra)",
        description="Train the fully convolutional EDM network on the complete 2D poses of "
        "TRAIN (poses2d; clips, if present, give the validation split by clip). --task "
        "recover (default): occluded 2D EDM -> complete 2D EDM, 1-3 random occluded joints "
        "per pose, fresh every epoch; --task lift: 2D EDM -> 3D EDM (needs poses3d). "
        "Adam on mini-batches, early stopping on the held-out clips.",
    )
    p.add_argument("train", help="training .npz with poses2d (n, N, 2) (see `sparseedm "
                   "dataset build`)")
    p.add_argument("-o", "--output", required=True, help="model file to write (.npz)")
    p.add_argument("--task", choices=("recover", "lift"), default="recover",
                   help="recover (default) or lift (2D -> 3D EDM)")
    p.add_argument("--representation", choices=("average", "zero"), default="average",
                   help="occlusion representation of the inputs (default average)")
    p.add_argument("--occluded", default=None, metavar="LO-HI",
                   help="occluded joints per pose, drawn uniformly (default 1-3 for recover, "
                   "0-0 for lift)")
    p.add_argument("--channels", metavar="C1,C2", default="32,64", help="encoder channels C1,C2 (default 32,64)")
    p.add_argument("--kernel", metavar="K", type=int, default=3, help="filter size (default 3)")
    p.add_argument("--symmetrize", action="store_true",
                   help="add DMR's symmetrisation layer (Y + Y^T) / 2")
    p.add_argument("--batch-size", metavar="N", type=int, default=256, help="mini-batch size (default 256)")
    p.add_argument("--epochs", metavar="N", type=int, default=30, help="most epochs (default 30)")
    p.add_argument("--patience", metavar="N", type=int, default=4,
                   help="stop after this many epochs without validation improvement (default 4)")
    p.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (default 1e-3)")
    p.add_argument("--max-train", metavar="N", type=int, default=None,
                   help="train on a seeded subsample of this many poses (default: every pose)")
    p.add_argument("--seed", metavar="N", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--device", default="cpu", help="torch device (default cpu; e.g. cuda)")
    p.add_argument("--threads", metavar="N", type=int, default=None,
                   help="torch CPU threads (default: torch's choice)")
    add_quiet(p)
    p.set_defaults(func=run)


def _load(path, need3d):
    required = ("poses2d", "poses3d") if need3d else ("poses2d",)
    out, _ = load_npz(path, "training", required, ("clips",))
    for key in ("poses2d", "poses3d"):
        if key in out and out[key].dtype.kind not in "fiu":
            raise FileFormatError(f"{path}: {key} must be numeric, got {out[key].dtype}")
    return out


def run(args):
    """Run ``sparseedm fit-cnn``: train the FConv network on a training set and save it.

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
        If the output does not end in .npz or the training set is unusable; ``main`` turns
        it into exit code 2.
    """
    from .._atomic import check_paths
    from ..fconv.network import require_torch
    from ..fconv.training import fit_edm_lifter, fit_fconv

    torch = require_torch()
    if args.threads:
        torch.set_num_threads(args.threads)
    if Path(args.output).suffix != ".npz":
        raise SparseEDMError(f"{args.output}: a model file must end in .npz")
    check_paths([("training file", args.train)], [("output", args.output)])
    data = _load(args.train, args.task == "lift")
    common = dict(representation=args.representation, channels=channels(args.channels),
                  kernel=args.kernel,
                  symmetrize=args.symmetrize, batch_size=args.batch_size,
                  max_epochs=args.epochs, patience=args.patience, learning_rate=args.lr,
                  random_state=args.seed, device=args.device, progress=show_progress(args),
                  max_train=args.max_train, provenance={"files": [str(args.train)]})
    if args.task == "recover":
        model = fit_fconv(data["poses2d"], data.get("clips"),
                          occluded=occluded_range(args.occluded, (1, 3)), **common)
    else:
        model = fit_edm_lifter(data["poses2d"], data["poses3d"], data.get("clips"),
                               occluded=occluded_range(args.occluded, (0, 0)), **common)
    model.save(args.output)
    t = model.meta["training"]
    print(f"wrote {args.output}: {args.task} model, {t['epochs']} epochs on {t['n_train']} "
          f"poses in {t['seconds']:.1f} s, best validation loss {t['best_val_loss']:.4g} "
          f"({t['validation']})", file=sys.stderr if args.quiet else sys.stdout)
    return 0
