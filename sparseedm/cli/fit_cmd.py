"""``sparseedm fit TRAIN -o DICT.npz``: learn a dictionary from complete poses.

TRAIN is a training set (``sparseedm dataset build``) or a keypoint file of
real people, read as ``sparseedm recover`` reads its input.
"""

from __future__ import annotations

import sys
import time

from ..exceptions import ParameterError
from ._common import add_input_format, add_joint_map, add_quiet, refusals_said, show_progress

#: options of learning from scratch that fine-tuning (--init) has no use for: (dest,
#: option); their defaults (None, False) say they were not given
SCRATCH_ONLY = (("atoms", "--atoms"), ("checkpoint", "--checkpoint"), ("resume", "--resume"),
                ("positive_code", "--positive-code"))


def add_parser(sub):
    """Add the ``sparseedm fit`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "fit",
        help="learn a dictionary from a training set or a keypoint file's complete poses",
        description="Online dictionary learning (Mairal et al. 2009) over the normalised "
        "EDM vectors of the complete 2D poses in TRAIN: a training .npz (key poses2d, "
        "`sparseedm dataset build`), or a keypoint file or folder of real people as "
        "`sparseedm recover` reads it (COCO JSON, OpenPose, MMPose, AlphaPose, "
        "DeepLabCut, PoseTrack, CSV); poses with a joint missing (or filled by a "
        "previous recovery) are skipped. Rows refused as bad input (an infinite "
        "coordinate, all joints at one point, an extent out of range) and frame files "
        "that cannot be read are listed in the errors file, as recover's. Exit code "
        "0: done; 1: the dictionary written without some rows or files; 2: bad input.",
    )
    p.add_argument("train", help="training .npz with poses2d (n, N, 2), or a keypoint file "
                   "or folder")
    p.add_argument("-o", "--output", required=True, help="dictionary file to write (.npz)")
    p.add_argument("--errors", default=None, metavar="FILE",
                   help="errors file listing refused rows and unreadable input files "
                   "(default OUTPUT stem + .errors.csv)")
    p.add_argument("--atoms", metavar="K", type=int, default=None,
                   help="number of atoms k (default 2000; not with --init)")
    p.add_argument("--alpha", type=float, default=None,
                   help="lasso penalty while learning (default 1.6, chosen on a "
                   "validation split: docs/explanation/settings.md; with --init, the initial "
                   "dictionary's)")
    p.add_argument("--alpha-recover", metavar="ALPHA", type=float, default=None,
                   help="recommended recovery alpha to store (default 0.002, chosen "
                   "likewise; with --init, the initial dictionary's)")
    p.add_argument("--init", default=None, metavar="default|PATH",
                   help="fine-tune this dictionary (shipped name or .npz) on TRAIN instead "
                   "of learning from scratch: online learning continued from its atoms "
                   "(sparseedm.adaptation; its atoms kept: --atoms, --checkpoint, --resume "
                   "and --positive-code do not apply and are refused)")
    p.add_argument("--passes", metavar="P", type=float, default=2.0,
                   help="passes over the data (default 2: better held-out error than "
                   "one, still faster than SPAMS trainDL's one; benchmarks/README.md)")
    p.add_argument("--batch-size", metavar="N", type=int, default=None,
                   help="mini-batch size (default 512; with --init, the adaptation's 256, "
                   "chosen on validation: docs/explanation/settings.md)")
    p.add_argument("--positive-code", action="store_true", help="non-negative codes")
    p.add_argument("--seed", metavar="N", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--jobs", metavar="N", type=int, default=None, help="threads for the coding step (default: numba's thread count, normally all cores)")
    p.add_argument("--checkpoint", metavar="FILE", default=None,
                   help="checkpoint file, written every 20 mini-batches (default "
                   "OUTPUT with .ckpt.npz)")
    p.add_argument("--resume", action="store_true",
                   help="continue from the checkpoint of an interrupted run")
    add_input_format(p, "TRAIN")
    add_joint_map(p)
    add_quiet(p)
    p.set_defaults(func=run)


def run(args):
    """Run ``sparseedm fit``: learn a dictionary from a training set's complete poses.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 when done, 1 when rows were refused or files of a folder of
        frames could not be read (the dictionary written without them, the errors
        file listing them).
    """
    from ..keypoints import default_errors_path
    from ..learning import fit_dictionary_file

    t0 = time.perf_counter()
    # options left unset take the API's defaults (which differ between learning
    # from scratch and fine-tuning)
    given = {} if args.batch_size is None else {"batch_size": args.batch_size}
    given.update(input_format=args.input_format, joint_map=args.joint_map,
                 errors_path=args.errors)
    if args.init is not None:
        from ..adaptation import fine_tune_file

        refuse_scratch_options(args)
        d = fine_tune_file(args.train, args.output, args.init, passes=args.passes,
                           alpha=args.alpha, alpha_recover=args.alpha_recover,
                           random_state=args.seed, n_jobs=args.jobs, **given)
        how = f"fine-tuned from {args.init}"
    else:
        for name, key in (("alpha", "alpha"), ("alpha_recover", "alpha_recover"),
                          ("atoms", "n_components")):
            if getattr(args, name) is not None:
                given[key] = getattr(args, name)
        d = fit_dictionary_file(
            args.train, args.output, n_passes=args.passes,
            positive_code=args.positive_code, random_state=args.seed, n_jobs=args.jobs,
            checkpoint=args.checkpoint, resume=args.resume, progress=show_progress(args),
            **given,
        )
        how = "learned"
    print(f"wrote {args.output}: {d.n_components} atoms {how} from "
          f"{d.provenance['n_poses']} poses in {time.perf_counter() - t0:.1f} s",
          file=sys.stderr if args.quiet else sys.stdout)
    errors = args.errors or default_errors_path(args.output)
    return refusals_said("fit", {"refused": d.provenance.get("refused_rows", 0),
                                 "skipped_files": d.provenance.get("skipped_files"),
                                 "errors": errors})


def refuse_scratch_options(args):
    """Refuse, before any work, the options of learning from scratch given with
    ``--init`` (:data:`SCRATCH_ONLY`): fine-tuning would run without them.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line, with ``init`` set.

    Raises
    ------
    ParameterError
        Naming the options given (exit code 2).
    """
    given = [option for dest, option in SCRATCH_ONLY
             if getattr(args, dest) is not None and getattr(args, dest) is not False]
    if given:
        many = len(given) > 1
        names = " and ".join([", ".join(given[:-1]), given[-1]] if many else given)
        raise ParameterError(
            f"{names} {'do' if many else 'does'} not apply to fine-tuning (--init "
            f"{args.init}): it continues the initial dictionary's learning (its atoms, its "
            f"settings) and writes no checkpoint; leave {'them' if many else 'it'} out, or "
            "drop --init to learn a dictionary from scratch")
