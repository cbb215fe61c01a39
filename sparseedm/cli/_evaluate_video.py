"""``sparseedm evaluate --protocol gaps|self-occlusion``: the video protocols.

A thin layer over :func:`sparseedm.temporal.evaluation.evaluate_video` on a
sequence file (``sparseedm dataset build --camera-per clip``): prints the
table and writes video.json, video.csv and, with ``--plot-joint``, a figure.
The options state the API's defaults without importing it
(tests/test_cli_defaults.py keeps them equal).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: evaluate_video's default methods, as the CLI states them
VIDEO_METHODS = "linear,cubic,akima,pca,kalman,sparse"
#: evaluate_video's default gap lengths
GAP_LENGTHS = (3, 10, 30, 90)


def gap_lengths(text):
    """``"3,10"`` -> (3, 10); positive integers only.

    Parameters
    ----------
    text : str
        The option's comma-separated value.

    Returns
    -------
    tuple of int
        The gap lengths, in frames.

    Raises
    ------
    argparse.ArgumentTypeError
        If a value is not a positive integer, or there is none.
    """
    try:
        values = tuple(int(t) for t in text.split(",") if t.strip())
    except ValueError:
        values = ()
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"must be comma-separated positive integers, got {text!r}")
    return values


def noise_level(text):
    """``"0.01"`` -> 0.01; a fraction of the body height in [0, 1).

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    float
        The noise level.

    Raises
    ------
    argparse.ArgumentTypeError
        If `text` is not a number in [0, 1).
    """
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 <= value < 1:  # NaN fails too
        raise argparse.ArgumentTypeError(
            f"must be a fraction of the body height in [0, 1), got {text!r}")
    return value


def add_arguments(p):
    """Add the video protocols' options to ``sparseedm evaluate``'s parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The ``evaluate`` command's parser.
    """
    g = p.add_argument_group(
        "video protocols", "with --protocol, --data is a sequence file (sparseedm dataset "
        "build --camera-per clip) and --methods are gap fillers (default "
        f"{VIDEO_METHODS}); the 2D error of the filled joints in % of the body's pixel "
        "height is printed per gap length or run length, and -o gets video.json, video.csv")
    g.add_argument("--protocol", choices=("gaps", "self-occlusion", "photos", "video-real"),
                   default=None,
                   help="gaps: contiguous gaps on 1-3 joints (17%% of joint-frames) per gap "
                   "length; self-occlusion: joints behind the torso from the camera plus 5%% "
                   "short dropouts, per run length; photos, video-real: real keypoints (see "
                   "'real-people protocols')")
    g.add_argument("--gap-lengths", type=gap_lengths, default=GAP_LENGTHS, metavar="L,L,...",
                   help="gap lengths in frames (default 3,10,30,90)")
    g.add_argument("--noise", type=noise_level, default=0.0, metavar="FRACTION",
                   help="add seeded white noise of FRACTION x the body height to every "
                   "observed coordinate, as a detector's jitter (0.01: a good detector; "
                   "default 0: motion capture as projected); errors stay against the truth")
    g.add_argument("--plot-joint", default=None, metavar="JOINT",
                   help="also plot this joint's filled trajectory against the truth (needs "
                   "matplotlib), for the first sequence or --plot-clip")
    g.add_argument("--plot-clip", default=None, metavar="ID", help="the sequence to plot")


def run(args, methods):
    """Run ``sparseedm evaluate --protocol gaps|self-occlusion``: print and write the table.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    methods : sequence of str
        The gap fillers to compare.

    Returns
    -------
    int
        The exit code, 0.

    Raises
    ------
    ParameterError
        If ``--plot-joint`` names no joint; ``main`` turns it into exit code 2.
    """
    from .._atomic import check_paths
    from ..dictionary import load_dictionary
    from ..temporal.evaluation import evaluate_video, plot_fill
    from ..temporal.sequences import load_sequences

    from ..exceptions import ParameterError
    from ..skeleton import JOINT_NAMES

    if args.plot_joint is not None and args.plot_joint not in JOINT_NAMES:
        raise ParameterError(f"--plot-joint must be one of {', '.join(JOINT_NAMES)}; "
                             f"got {args.plot_joint!r}")
    out = Path(args.output)
    check_paths([("--data", args.data)],
                [("report", out / "video.json"), ("report", out / "video.csv")])
    sequences = load_sequences(args.data)
    dictionary = load_dictionary(args.dictionary) if "sparse" in methods else None
    report = evaluate_video(sequences, methods, args.protocol, gap_lengths=args.gap_lengths,
                            random_state=args.seed, dictionary=dictionary, noise=args.noise)
    s = report.settings
    jitter = f", observed joints jittered by {args.noise:g} x body height" if args.noise else ""
    print(f"{args.protocol}: {s['sequences']} sequences, {s['frames']} frames, "
          f"{s['hidden_fraction']:.1%} of joint-frames hidden{jitter}; error in % of body "
          "height")
    print(report.table())
    print("\nruns touching a clip end:")
    print(report.table("end"))
    report.write(out / "video.json", out / "video.csv")
    print(f"wrote video.json and video.csv to {out}/")
    if args.plot_joint:
        _plot(args, sequences, methods, dictionary, out, plot_fill)
    return 0


def _plot(args, sequences, methods, dictionary, out, plot_fill):
    from ..exceptions import SparseEDMError

    chosen = [s for s in sequences if args.plot_clip in (None, s.clip)][:1]
    if not chosen:
        raise SparseEDMError(f"--plot-clip {args.plot_clip}: no such sequence in {args.data}")
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print("sparseedm evaluate: figure skipped: matplotlib is not installed "
              "(pip install sparseedm[plot])", file=sys.stderr)
        return
    path = out / f"fill_{args.plot_joint}.png"
    plot_fill(chosen[0], methods, args.protocol, args.plot_joint, gap_lengths=args.gap_lengths,
              random_state=args.seed, dictionary=dictionary, path=path)
    print(f"wrote {path}")
