"""``sparseedm dataset build``: a training set (.npz) from motion-capture files."""

from __future__ import annotations

import argparse
import warnings


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "dataset", help="build training sets from motion capture",
        description="Build training sets (2D/3D poses, labels, cameras) from motion capture.",
    )
    sub = parser.add_subparsers(dest="dataset_command", metavar="ACTION")
    build = sub.add_parser(
        "build", help="BVH / CMU ASF+AMC files or folders -> .npz",
        description="Read .bvh and .amc files (folders searched recursively), view each "
        "kept pose through seeded virtual cameras, write an .npz (see sparseedm.dataset).",
    )
    build.add_argument("paths", nargs="+", metavar="PATH", help="motion files or folders")
    build.add_argument("-o", "--output", required=True, help="output .npz")
    build.add_argument("--cameras-per-pose", type=_positive, default=1, metavar="K",
                       help="virtual cameras per 3D pose (default 1)")
    build.add_argument("--frame-step", type=_positive, default=None, metavar="S",
                       help="keep every S-th frame (default: about 40 frames/s of motion)")
    build.add_argument("--seed", type=int, default=0, metavar="N", help="camera seed (default 0)")
    build.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    build.set_defaults(func=run)
    parser.set_defaults(func=_help(parser))


def _positive(text):
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _help(parser):
    def show(args):
        parser.print_help()
        return 2
    return show


def run(args) -> int:
    """Build the dataset; exit code 0, or 1 if some files were skipped."""
    from ..dataset import build_dataset

    with warnings.catch_warnings():
        if args.quiet:
            warnings.simplefilter("ignore")
        data, report = build_dataset(
            args.paths, args.output,
            cameras_per_pose=args.cameras_per_pose, frame_step=args.frame_step,
            random_state=args.seed, progress=not args.quiet, return_report=True,
        )
    if not args.quiet:
        n_labels = len(set(data["labels"].tolist()))
        print(f"read {report['files']} file(s), skipped {len(report['skipped'])}; "
              f"wrote {report['poses']} poses ({n_labels} labels) to {args.output}")
        for path, reason in report["skipped"]:
            print(f"  skipped {path}: {reason}")
    return 1 if report["skipped"] else 0
