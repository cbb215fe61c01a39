"""``sparseedm lift INPUT -o OUTPUT``: 2D keypoints (occluded or not) -> 3D poses.

Exit codes: 0 every row lifted, 1 some rows refused (output still written,
errors file lists them), 2 bad input (nothing written).
"""

from __future__ import annotations

import sys

from ._common import (INPUT_HELP, SELECTION_HELP, add_input_format, add_joint_map, add_quiet,
                      refusals_said, show_progress)


def add_parser(sub):
    """Add the ``sparseedm lift`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "lift", help="lift 2D keypoints to 3D poses (any keypoint file recover reads)",
        description="Lift every pose in INPUT to 3D with a lifter (default: the shipped "
        "CMU-learned coupled dictionary, which codes only the observed joints' distances, "
        "so occluded poses need no separate recovery). Writes x, y, z per joint in metres "
        "(pelvis at the origin, camera axes, size from the lifter's body-size prior) "
        "with a status per row to OUTPUT (.csv, .npz or .json), or as OpenSim marker "
        "trajectories (.trc: one frame per pose, y up); refused rows go to an "
        "errors file. --plot draws a few lifted poses. "
        "Exit code 0: all rows lifted; 1: some refused; 2: bad input.",
    )
    p.add_argument("input", help=INPUT_HELP)
    p.add_argument("-o", "--output", required=True,
                   help="3D output: .csv, .npz, .json or .trc (OpenSim)")
    p.add_argument("--lifter", default=None, metavar="NAME|PATH",
                   help="shipped lifter name or lifter .npz (default: the shipped default)")
    p.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="worker threads over chunks of poses (-1: all cores; default 1: none, "
                   "the lasso's kernels still run on every core)")
    p.add_argument("--format", choices=("csv", "npz", "json", "trc"), default=None,
                   help="output format (default: from OUTPUT's extension)")
    p.add_argument("--errors", default=None, metavar="FILE",
                   help="errors file listing refused rows and unreadable input files "
                   "(default OUTPUT stem + .errors.csv)")
    p.add_argument("--representation", choices=("average", "zero"), default=None,
                   help="how an MLP or FConv lifter sees occluded joints (default: the one "
                   "an FConv lifter was trained on, else average)")
    p.add_argument("--confidence-threshold", type=float, default=None, metavar="T",
                   help="joints with a confidence below T count as missing (default: the "
                   "input format's, as for recover)")
    p.add_argument("--rate", type=float, default=30.0, metavar="HZ",
                   help="frames per second written to a .trc output (default 30)")
    p.add_argument("--plot", default=None, metavar="FIG",
                   help="also draw lifted poses from the front and the side, left/right "
                   "coloured, to FIG (.png, .pdf or .svg; needs matplotlib: pip install "
                   "'sparseedm[plot]'): the first 4 lifted, or those of --frames")
    p.add_argument("--frames", default=None, metavar="LO:HI",
                   help="with --plot: the frames drawn (rows, 0-based, for an input without "
                   f"frames): {SELECTION_HELP}; at most 8, spread over them")
    p.add_argument("--no-temporal", action="store_true",
                   help="lift every pose on its own even when INPUT gives frames (by "
                   "default a CSV 'frame' column or .npz 'frames' array, with 'track' / "
                   "'tracks' for several people, turns on lifting across time: missing 2D "
                   "joints filled across time first, each person's depth reflections "
                   "chosen together)")
    p.add_argument("--track", default=None, metavar="ID",
                   help="lift only this person's rows (a track id of INPUT: a CSV 'track' "
                   "cell, an .npz 'tracks' value, a detector's track id), as a .trc output "
                   "(one person) needs from a file of several people; the errors file keeps "
                   "INPUT's row numbers")
    add_joint_map(p)
    add_input_format(p)
    p.add_argument("--dictionary", default=None, metavar="NAME|PATH",
                   help="with frames: the 2D dictionary that fills missing joints across "
                   "time before lifting (default: the shipped default, as recover's)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--no-adapt", action="store_true",
                   help="with frames: do not adapt that 2D dictionary to INPUT (faster; by "
                   "default it is adapted and guarded as recover adapts)")
    g.add_argument("--self-training", type=int, default=None, metavar="ROUNDS",
                   help="with frames: rounds of self-training after adapting (default 3 "
                   "from 1000 poses on, none below; 0 turns it off: faster)")
    p.add_argument("--chunk-size", type=int, default=50_000, metavar="N",
                   help="poses lifted at a time (whole tracks at a time with frames, a "
                   "longer track in windows); "
                   "bounds memory (default 50000)")
    add_quiet(p)
    p.set_defaults(func=run)


def run(args):
    """Run ``sparseedm lift``: lift a keypoint file's 2D poses to 3D and write them.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 every row lifted, 1 some rows refused (the output still written).
    """
    from .._atomic import is_stream
    from ..lifting.io import lift_file

    s = lift_file(args.input, args.output, lifter=args.lifter, n_jobs=args.jobs,
                  output_format=args.format, errors_path=args.errors,
                  confidence_threshold=args.confidence_threshold,
                  representation=args.representation, rate=args.rate, plot=args.plot,
                  temporal=not args.no_temporal, chunk_size=args.chunk_size,
                  joint_map=args.joint_map, dictionary=args.dictionary,
                  adapt=not args.no_adapt, self_training=args.self_training,
                  plot_frames=args.frames, input_format=args.input_format,
                  progress=show_progress(args), track=args.track)
    out = sys.stderr if args.quiet or is_stream(args.output) else sys.stdout  # -o /dev/stdout
    rate = f"{s['poses_per_second']:,.0f} poses/s" if s["poses_per_second"] else "-"
    counts = ", ".join(f"{k} {v}" for k, v in s["status"].items()) or "none"
    across = (f"lifted across time: {s['filled_across_time']} pose(s) had missing 2D "
              "joints filled across time first\n") if s["temporal"] else ""
    print(f"wrote {s['output']}\nposes: {s['poses']}  rows refused: {s['refused']}  "
          f"ambiguous depth reflections: {s['ambiguous_reflection']}\n{across}"
          f"time: {s['seconds']:.2f} s  ({rate})\nstatus: {counts}", file=out)
    if s.get("plot"):
        print(f"figure: {s['plot']}", file=out)
    return refusals_said("lift", s)
