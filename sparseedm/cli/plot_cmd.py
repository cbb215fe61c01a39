"""``sparseedm plot INPUT RECOVERED -o FIG``: see what a recovery did.

Exit codes: 0 the figure was written, 2 bad input (an unreadable file, an
unknown track, frame, row or joint, matplotlib missing): nothing written.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ._common import SELECTION_HELP, add_input_format, add_joint_map, add_quiet, split_list


def add_parser(sub):
    """Add the ``sparseedm plot`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "plot", help="draw what a recovery did: trajectories over time and a few poses",
        description="Draw INPUT (the keypoints as read) against RECOVERED (the file "
        "`sparseedm recover` wrote from it, any format it writes) to check the recovery "
        "by eye. For a file with frames: per joint, x and y against the frame number "
        "(observed dots, the recovered trajectory, filled frames marked and shaded), "
        "then a few poses of the first track as skeletons with the filled joints marked. "
        "Without frames: the poses of the chosen rows. Example: sparseedm plot "
        "clip.csv clip_filled.csv -o check.png --frames 10:40 --joints right_wrist. "
        "Needs matplotlib: pip install 'sparseedm[plot]'.",
    )
    p.add_argument("input", help="the keypoint file that was recovered (as recover reads it)")
    p.add_argument("recovered", help="the file `sparseedm recover` wrote from INPUT")
    p.add_argument("-o", "--output", required=True,
                   help="figure to write: .png, .pdf or .svg (at exactly this path)")
    p.add_argument("--tracks", default=None, metavar="T1,T2",
                   help="tracks (people) to draw, by their ids in the file (default: the "
                   "track with the most filled joints)")
    p.add_argument("--frames", default=None, metavar="LO:HI",
                   help=f"frames to draw: {SELECTION_HELP} (default: all)")
    p.add_argument("--rows", default=None, metavar="LO:HI",
                   help="for a file without frames: the rows whose poses are drawn, as "
                   "--frames (0-based; default: those with the most filled joints)")
    p.add_argument("--joints", default=None, metavar="NAME,NAME",
                   help="joints whose trajectories are drawn, by name (right_wrist, "
                   "left_knee, ...; default: those filled in the frames drawn)")
    p.add_argument("--poses", type=int, default=4, metavar="K",
                   help="skeleton panels at most, spread over the frames or rows drawn, "
                   "those with filled joints first (default 4)")
    p.add_argument("--confidence-threshold", type=float, default=None, metavar="T",
                   help="read INPUT as recover read it: joints scored below T are "
                   "missing (default: the input format's)")
    add_joint_map(p)
    add_input_format(p)
    add_quiet(p)
    p.set_defaults(func=run)


def run(args):
    """Run ``sparseedm plot``: draw a keypoint file's poses beside their recovery.

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
        If the figure's name or the files do not fit (different numbers of poses); ``main``
        turns it into exit code 2.
    """
    from .. import _progress
    from .._atomic import check_paths
    from .._extras import require
    from ..exceptions import SparseEDMError
    from ..keypoints import read_keypoints
    from ..plotting import FIGURE_FORMATS, plot_recovery

    require("plot", "sparseedm plot")  # before any file is read
    suffix = args.output.rsplit(".", 1)[-1].lower() if "." in args.output else ""
    if suffix not in FIGURE_FORMATS:
        raise SparseEDMError(f"-o {args.output}: give a figure name ending in "
                             f"{', '.join('.' + f for f in FIGURE_FORMATS)}")
    check_paths([("input", args.input), ("recovered file", args.recovered)],
                [("output", args.output)])
    _progress.say(f"reading {args.input} and {args.recovered}")
    seen = read_keypoints(args.input, format=args.input_format,
                          confidence_threshold=args.confidence_threshold,
                          joint_map=args.joint_map)
    done_format = _recovered_format(args)
    done = read_keypoints(args.recovered, format=done_format,  # a DeepLabCut output: its map
                          joint_map=args.joint_map if done_format == "dlc" else None)
    if len(done.poses) != len(seen.poses):
        raise SparseEDMError(f"{args.recovered} has {len(done.poses)} poses, {args.input} "
                             f"{len(seen.poses)}: is it the file recover wrote from it?")
    order = _aligned(seen.frames, done.frames, len(done.poses))
    filled = None if done.filled is None else done.filled[order]
    # people linked by recover (an input without track ids): the recovered file's tracks
    tracks = seen.tracks if seen.tracks is not None or done.tracks is None \
        else done.tracks[order]
    plot_recovery(seen.poses, done.poses[order], filled, frames=seen.frames,
                  tracks=tracks, ids=seen.ids,
                  show_tracks=split_list(args.tracks) if args.tracks else None,
                  show_frames=args.frames, show_rows=args.rows,
                  show_joints=split_list(args.joints) if args.joints else None,
                  n_poses=args.poses, path=args.output)
    print(f"wrote {args.output}", file=sys.stderr if args.quiet else sys.stdout)
    return 0


def _recovered_format(args):
    """RECOVERED's format as recover chose it: told by its content or name, else INPUT's
    (recover writes INPUT's format where OUTPUT's name does not tell: ``out.keypoints``,
    a pipe), which ``--input-format`` gives when INPUT's name does not tell either."""
    from ..exceptions import FileFormatError
    from ..keypoints import format_of

    try:
        return format_of(Path(args.recovered), None)
    except FileFormatError:
        return format_of(Path(args.input), args.input_format)


def _aligned(frames_in, frames_out, n):
    """The recovered file's row of each input row. Row i of recover's output is
    row i of its input, except in the formats written one file per frame (OpenPose,
    MMPose folders), whose rows read back frame by frame: matched by frame number
    and order within the frame.

    >>> _aligned(np.array([2, 1, 2, 1]), np.array([1, 1, 2, 2]), 4).tolist()
    [2, 0, 3, 1]
    >>> _aligned(np.arange(3), None, 3).tolist()
    [0, 1, 2]
    """
    if frames_in is None or frames_out is None or np.array_equal(frames_in, frames_out):
        return np.arange(n)
    a, b = np.asarray(frames_in), np.asarray(frames_out)
    by_in, by_out = np.argsort(a, kind="stable"), np.argsort(b, kind="stable")
    if not np.array_equal(a[by_in], b[by_out]):  # other frame numbers (a DeepLabCut row number)
        return np.arange(n)
    order = np.empty(n, dtype=np.int64)
    order[by_in] = by_out
    return order
