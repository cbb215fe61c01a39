"""``sparseedm evaluate --dictionary D --data TEST.npz -o report/``: the paper's protocol."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


from ..exceptions import FileFormatError, SparseEDMError
from . import _evaluate_real, _evaluate_video
from ._common import add_adaptation_rounds, add_quiet, load_npz, split_list


def add_parser(sub):
    """Add the ``sparseedm evaluate`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "evaluate",
        help="measure recovery against baselines with the paper's protocol (Table 2, Fig. 5)",
        description="Seeded random occlusion of 1, 2, 3 joints and their Mix on complete "
        "test poses; Err_ave (per cent, on pixel EDMs), 2D joint error in pixels and "
        "torso fractions, speed; per-action table and failure analysis. Writes "
        "report.md, results.csv, per_action.csv (sweep.csv with --sweep-atoms) and PNG "
        "figures (with matplotlib).",
    )
    p.add_argument("--dictionary", metavar="NAME|PATH", default=None,
                   help="dictionary .npz or shipped name (default: the shipped default; with "
                   "--protocol photos, recover's own: sparseedm-no-adapt is then --no-adapt's "
                   "CMU + COCO prior, mirror image and pose bank, and a dictionary given is "
                   "coded alone)")
    p.add_argument("--data", metavar="FILE", required=True, help="test .npz with poses2d (n, N, 2) in pixels; "
                   "labels (n,) optional")
    p.add_argument("--train", metavar="FILE", default=None,
                   help="training .npz (poses2d) for the knn, iterative and nearest baselines "
                   "and for --sweep-atoms")
    p.add_argument("--methods", metavar="LIST", default=None,
                   help="comma-separated methods (default all: sparse,mean-fill,knn,iterative,"
                   "nearest; with --protocol gaps or self-occlusion: linear,cubic,akima,pca,kalman,"
                   "sparse; a gap filler of your own as module:function; photos, video-real: see "
                   "real-people protocols)")
    p.add_argument("--counts", metavar="LIST", default="1,2,3,mix", help="occlusion counts (default 1,2,3,mix)")
    p.add_argument("--representations", metavar="LIST", default="average,zero",
                   help="occlusion representations (default average,zero)")
    p.add_argument("--seed", metavar="N", type=int, default=0, help="occlusion seed (default 0)")
    p.add_argument("--max-poses", metavar="N", type=int, default=None,
                   help="evaluate a seeded subsample of this many test poses "
                   "(default: every test pose)")
    p.add_argument("--max-train", metavar="N", type=int, default=5000,
                   help="the knn, iterative and nearest baselines are fitted on a seeded "
                   "sample of at most this many --train poses (default 5000, which keeps "
                   "the iterative imputer's fit to a minute or two; the Table 2 of "
                   "docs/results/ used 20000)")
    p.add_argument("--alpha", type=float, default=None,
                   help="recovery alpha (default: the dictionary's recommendation)")
    p.add_argument("--sweep-atoms", metavar="LIST", default=None,
                   help="comma-separated atom counts: learn a dictionary of each size on "
                   "--train and plot Mix Err_ave and time per pose (Fig. 5)")
    p.add_argument("--sweep-alpha", metavar="ALPHA", type=float, default=None,
                   help="training alpha of the sweep dictionaries (default: the "
                   "evaluated dictionary's; their recovery alpha is --alpha or its)")
    p.add_argument("--jobs", metavar="N", type=int, default=1, help="joblib workers for the recovery, as recover's --jobs (default 1)")
    p.add_argument("--fconv-model", action="append", default=[], metavar="PATH",
                   help="FConv model from `sparseedm fit-cnn` (repeat: one per representation); "
                   "adds the fconv method (needs the torch extra)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--adapt-from", default=None, metavar="FILE",
                   help="adaptation protocol: adapt the dictionary on the complete poses of "
                   "FILE (.npz with poses2d; other clips of --data's source) and add a "
                   "'sparse-adapted' row; knn, iterative and nearest are fitted on FILE "
                   "(--train is then not used)")
    g.add_argument("--adapt-clips", type=int, default=None, metavar="K",
                   help="adaptation protocol within --data (needs its 'clips'): clip i in "
                   "sorted order adapts when i %% K == 0, the other clips are scored")
    add_adaptation_rounds(
        p, "with --adapt-from/--adapt-clips: self-training rounds of the 'sparse-adapted' "
        "row on the occluded test poses (default 3, as `sparseedm recover`; 0: adaptation "
        "on FILE only)",
        "with --adapt-from/--adapt-clips: average K adapted dictionaries (seeds 0..K-1) in "
        "the 'sparse-adapted' row (default 1)")
    p.add_argument("-o", "--output", required=True, help="report directory")
    _evaluate_video.add_arguments(p)
    _evaluate_real.add_arguments(p)
    add_quiet(p)
    p.set_defaults(func=run)


def _load(path, what):
    """poses2d and, if present, labels from an .npz (not every dataset key is needed)."""
    arrays, files = load_npz(path, what, ("poses2d",), ("labels",))
    poses, labels = arrays["poses2d"], arrays.get("labels")
    if poses.dtype.kind not in "fiu" or poses.ndim != 3 or poses.shape[-1] != 2:
        raise FileFormatError(f"{path}: poses2d must be numeric (n, N, 2), got "
                              f"{poses.dtype} {poses.shape}")
    if labels is not None and (labels.dtype.kind not in "US" or labels.shape != poses.shape[:1]):
        raise FileFormatError(f"{path}: labels must be strings of shape ({len(poses)},)")
    return poses.astype(float), labels, files


def _check_report_dir(args):
    """-o is a folder to make (or reuse), never an input file: checked before the work."""
    from .._atomic import check_paths
    from ..exceptions import OutputPathError

    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise OutputPathError(f"-o {out} is a file; the report needs a directory")
    check_paths([("--data", args.data), ("--train", args.train),
                 ("--adapt-from", args.adapt_from)],
                [("report", out / name) for name in ("report.md", "results.csv",
                                                     "per_action.csv", "sweep.csv")])


def _split_clips(path, poses, labels, k):
    """(scored poses, their labels, adaptation poses) of --adapt-clips K."""
    if k < 2:
        raise SparseEDMError(f"--adapt-clips must be >= 2, got {k}")
    arrays, _ = load_npz(path, "test data", ("clips",))  # --adapt-clips needs its 'clips'
    clips = arrays["clips"].astype(str)
    order = {c: i for i, c in enumerate(np.unique(clips))}
    adapt = np.array([order[c] % k == 0 for c in clips])
    return poses[~adapt], (labels[~adapt] if labels is not None else None), poses[adapt]


def run(args):
    """Run ``sparseedm evaluate``: a protocol's report on a test set, written to ``-o``.

    The paper's protocol by default; with ``--protocol``, a real-people or a
    video protocol.

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
        If an option is malformed or the options do not go together; ``main`` turns it into
        exit code 2.
    """
    from ..dictionary import load_dictionary
    from ..evaluation import check_methods, evaluate

    if args.protocol in _evaluate_real.PROTOCOLS:
        return _evaluate_real.run(args, split_list(args.methods or ""))
    if args.protocol:
        return _evaluate_video.run(args, split_list(args.methods or _evaluate_video.VIDEO_METHODS))
    methods = split_list(args.methods or "sparse,mean-fill,knn,iterative,nearest")
    if args.fconv_model and "fconv" not in methods:
        methods = methods[:1] + ("fconv",) + methods[1:]
    methods = check_methods(methods)
    try:  # checked before the hour of evaluation that precedes the sweep
        atoms = tuple(int(a) for a in split_list(args.sweep_atoms or ""))
    except ValueError:
        raise SparseEDMError(f"--sweep-atoms must be comma-separated integers, got "
                             f"{args.sweep_atoms!r}") from None
    _check_report_dir(args)
    dictionary = load_dictionary(args.dictionary)
    test, labels, files = _load(args.data, "test data")
    train = _load(args.train, "training")[0] if args.train else None
    say = []
    if labels is None:
        say.append(f"{args.data}: no labels: the per-action table is skipped")
    if "poses3d" not in files:
        say.append(f"{args.data}: no poses3d: nothing needs it (the evaluation is 2D)")
    for s in say:
        print(f"sparseedm evaluate: {s}", file=sys.stderr)
    adapt_poses = None
    if args.ensemble != 1 and not (args.adapt_from or args.adapt_clips):
        raise SparseEDMError("--ensemble averages adapted dictionaries: it needs "
                             "--adapt-from or --adapt-clips")
    if args.adapt_from:
        adapt_poses = _load(args.adapt_from, "adaptation")[0]
    elif args.adapt_clips:
        test, labels, adapt_poses = _split_clips(args.data, test, labels, args.adapt_clips)
    if adapt_poses is not None:
        from ..evaluation import evaluate_adaptation

        report = evaluate_adaptation(
            dictionary, test, adapt_poses, methods=methods, counts=split_list(args.counts),
            representations=split_list(args.representations), random_state=args.seed,
            n_jobs=args.jobs, max_poses=args.max_poses, max_train=args.max_train,
            alpha=args.alpha, fconv_models=args.fconv_model,
            ensemble=args.ensemble,
            **({} if args.self_training is None else {"self_training": args.self_training}))
    else:
        report = evaluate(
            dictionary, test, train_poses2d=train, labels=labels, methods=methods,
            counts=split_list(args.counts), representations=split_list(args.representations),
            random_state=args.seed, n_jobs=args.jobs, max_poses=args.max_poses,
            max_train=args.max_train, alpha=args.alpha, fconv_models=args.fconv_model,
        )
    if args.sweep_atoms:
        _sweep(report, args, dictionary, train, test, atoms)
    _write_and_print(report, args, adapted=adapt_poses is not None)
    return 0


def _sweep(report, args, dictionary, train, test, atoms):
    """Fig. 5's sweep over dictionary sizes into `report` (skipped, with a note,
    without --train)."""
    from ..evaluation import sweep_atoms

    if train is None:
        msg = "--sweep-atoms needs --train: sweep skipped"
        report.notes.append(msg)
        print(f"sparseedm evaluate: {msg}", file=sys.stderr)
    else:
        # the sweep's dictionaries are used as the evaluated one is
        report.sweep = sweep_atoms(
            train, test, atoms,
            alpha=args.sweep_alpha if args.sweep_alpha is not None else dictionary.alpha_train,
            alpha_recover=args.alpha if args.alpha is not None else dictionary.alpha_recover,
            random_state=args.seed, max_poses=args.max_poses, n_jobs=args.jobs)


def _write_and_print(report, args, *, adapted):
    """The report written to --output; its Mix rows and notes on the terminal."""
    for note in report.notes:
        if note.startswith("no training poses"):
            print(f"sparseedm evaluate: {note}", file=sys.stderr)
    written, message = report.write(args.output)
    if message:
        print(f"sparseedm evaluate: {message}", file=sys.stderr)
    if adapted:
        print(next(n for n in report.notes if n.startswith("sparse-adapted:")))
    mix = report.table(count="mix", representation=report.settings["representations"][0])
    for r in mix:
        print(f"{r['method']:>10}  Mix Err_ave {r['err_ave_mean']:.2f} %  "
              f"filled poses {r['err_ave_filled']:.2f} %  "
              f"joint {r['joint_err_px']:.1f} px  {r['poses_per_s']:.0f} poses/s")
    for note in report.notes:
        if ": fitted on " in note:
            print(f"baseline {note}")
    print(f"wrote {len(written)} files to {args.output}/ (report.md)")
