"""``sparseedm evaluate-lift --data TEST.npz -o report/``: the paper's application table."""

from __future__ import annotations

import sys

from ._common import add_quiet


def add_parser(sub):
    """Add the ``sparseedm evaluate-lift`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "evaluate-lift",
        help="measure 3D lifting after occlusion and recovery (the paper's application table)",
        description="Seeded occlusion (1, 2, 3 joints, Mix) of held-out poses with known 3D; "
        "lifts them complete, occluded as is ('average', 'zero'), after sparse recovery "
        "(applyspar), after FConv recovery (applyzero/applyave, torch extra), after 2D imputers, "
        "through the joint coupled lasso, and through lifters retrained on occluded input "
        "(zero+basl/ave+basl); reports "
        "3D-EDM Err_ave, PA-MPJPE, N-MPJPE, MPJPE, reflection accuracy, speed, per action, "
        "and 3D skeleton figures. Writes lift_report.md, lift_results.json, lift_poses.png.",
    )
    p.add_argument("--data", metavar="FILE", required=True,
                   help="test .npz with poses2d, poses3d, cameras (sparseedm dataset build)")
    p.add_argument("--lifter", metavar="NAME|PATH", default="default", help="dictionary lifter (name or .npz; default: the shipped default)")
    p.add_argument("--mlp", metavar="FILE", default=None, help="an mlp (FConn) lifter .npz to compare")
    p.add_argument("--fconv", metavar="FILE", default=None, help="an fconv lifter .npz to compare (torch extra)")
    p.add_argument("--fconv-zero", default=None, metavar="MODEL",
                   help="FConv 'zero' recovery model (sparseedm fit-cnn) for applyzero")
    p.add_argument("--fconv-average", default=None, metavar="MODEL",
                   help="FConv 'average' recovery model (sparseedm fit-cnn) for applyave")
    p.add_argument("--basl-zero", default=None, metavar="LIFTER",
                   help="lifter retrained on occluded 'zero' input (fit-lifter --occluded 1-3 "
                   "--representation zero) for zero+basl")
    p.add_argument("--basl-average", default=None, metavar="LIFTER",
                   help="lifter retrained on occluded 'average' input, for ave+basl")
    p.add_argument("--dictionary", metavar="NAME|PATH", default="default",
                   help="2D dictionary for applyspar (default: the shipped one)")
    p.add_argument("--train", metavar="FILE", default=None, help="training .npz (poses2d) for the imputers")
    p.add_argument("--pipelines", metavar="LIST", default=None,
                   help="comma-separated subset of: complete, as-is average, as-is zero, "
                   "applyspar, knn, iterative, nearest, joint, applyzero, applyave, "
                   "zero+basl, ave+basl (default all; FConv rows need their models)")
    p.add_argument("--counts", metavar="LIST", default="1,2,3,mix", help="occlusion counts (default 1,2,3,mix)")
    p.add_argument("--max-poses", metavar="N", type=int, default=None, help="seeded subsample of test poses (default: every test pose)")
    p.add_argument("--max-train", metavar="N", type=int, default=20000, help="imputer training poses: a seeded sample of at most "
                   "this many --train poses (default 20000)")
    p.add_argument("--seed", metavar="N", type=int, default=0, help="occlusion seed (default 0)")
    p.add_argument("--jobs", metavar="N", type=int, default=1, help="worker threads for the lasso (default 1: none, its kernels still run on every core)")
    p.add_argument("-o", "--output", required=True, help="report directory")
    add_quiet(p)
    p.set_defaults(func=run)


def run(args):
    """Run ``sparseedm evaluate-lift``: the lifting table of a test set, written to ``-o``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 when done.
    """
    from ..dataset import load_dataset
    from ..metrics import check_counts
    from ..lifting import load_lifter
    from ._common import split_list
    from ..lifting.evaluation import evaluate_lifting

    lifters = {"dictionary": load_lifter(args.lifter)}
    if args.mlp:
        lifters["mlp"] = load_lifter(args.mlp)
    if args.fconv:
        lifters["fconv"] = load_lifter(args.fconv)
    fconv_models = {rep: path for rep, path in (("zero", args.fconv_zero),
                                                 ("average", args.fconv_average)) if path}
    retrained = {rep: load_lifter(path) for rep, path in (("zero", args.basl_zero),
                                                           ("average", args.basl_average))
                 if path}
    test = load_dataset(args.data)
    train = load_dataset(args.train)["poses2d"] if args.train else None
    counts = check_counts(split_list(args.counts))
    pipes = split_list(args.pipelines) if args.pipelines else None
    report = evaluate_lifting(lifters, test, dictionary=args.dictionary, train_poses2d=train,
                              counts=counts, pipelines=pipes, max_poses=args.max_poses,
                              seed=args.seed, n_jobs=args.jobs, max_train=args.max_train,
                              data_name=str(args.data), fconv_models=fconv_models,
                              retrained=retrained)
    written = report.write(args.output)
    for note in report.notes:
        print(f"sparseedm evaluate-lift: {note}", file=sys.stderr)
    for r in report.rows:
        if str(r["count"]) in ("mix", "none"):
            print(f"{r['lifter']:>10} {r['pipeline']:>14} {str(r['count']):>4}  err3d "
                  f"{r['err3d']:.2f} %  PA-MPJPE {r['pa_mpjpe']:.1f} mm  "
                  f"{r['poses_per_s']:.0f} poses/s")
    print(f"wrote {len(written)} files to {args.output}/ (lift_report.md)")
    return 0
