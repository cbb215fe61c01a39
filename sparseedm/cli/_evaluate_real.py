"""``sparseedm evaluate --protocol photos|video-real --data FILE``: real-people protocols.

A thin layer over :func:`sparseedm.evaluation_real.evaluate_photos` and
:func:`~sparseedm.evaluation_real.evaluate_tracks` on any keypoint file
:func:`sparseedm.keypoints.read_keypoints` reads: photos hide joints of the
file's complete poses (transplanting the missing patterns of its incomplete
ones), video-real hides joints of its complete clips (transplanting the
missing runs of its other tracks). Prints a table per condition and writes
``<protocol>.json`` and ``<protocol>.csv`` to ``-o``. The options state the
API's defaults without importing it (tests/test_cli_defaults.py keeps them equal).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: the protocols of this module
PROTOCOLS = ("photos", "video-real")
#: evaluate_photos' default conditions
PHOTO_CONDITIONS = ("mix", "transplanted")


def pose_sizes(text):
    """``"1000,1000"`` -> (1000, 1000): complete and occluded poses.

    Parameters
    ----------
    text : str
        The option's value, ``C,M``.

    Returns
    -------
    tuple of int
        Complete poses (>= 0) and occluded poses (>= 1).

    Raises
    ------
    argparse.ArgumentTypeError
        If `text` is not two such integers.
    """
    try:
        values = tuple(int(t) for t in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 2 or values[0] < 0 or values[1] < 1:
        raise argparse.ArgumentTypeError(
            f"must be C,M: complete poses (>= 0) and occluded poses (>= 1), got {text!r}")
    return values


def conditions(text):
    """``"mix,transplanted"`` -> ("mix", "transplanted"); among 1, 2, 3, mix, transplanted.

    Parameters
    ----------
    text : str
        The option's comma-separated value.

    Returns
    -------
    tuple of str
        The conditions, in the order given.

    Raises
    ------
    argparse.ArgumentTypeError
        If `text` names none, or an unknown one.
    """
    values = tuple(t.strip() for t in text.split(",") if t.strip())
    if not values or any(v not in ("1", "2", "3", "mix", "transplanted") for v in values):
        raise argparse.ArgumentTypeError(
            f"must be among 1,2,3,mix,transplanted (comma-separated), got {text!r}")
    return values


def add_arguments(p):
    """Add the real-people protocols' options to ``sparseedm evaluate``'s parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The ``evaluate`` command's parser.
    """
    g = p.add_argument_group(
        "real-people protocols", "with --protocol photos or video-real, --data is any keypoint "
        "file (CSV, .npz, COCO JSON, detector formats) and the error of each hidden joint is "
        "printed in % of the body size (head top to the ankles' midpoint) as mean (median); "
        "-o gets <protocol>.json and .csv. photos: the file's complete poses, C kept "
        "complete and M with hidden joints, given to each method in one call; methods "
        "sparseedm, sparseedm-no-adapt, iterative, knn, mean-fill, nearest. video-real: each "
        "clip (a track's consecutive complete frames) alone; methods sparseedm, per-frame, "
        "linear, cubic, akima, pca (kalman when installed) or module:function")
    g.add_argument("--poses", type=pose_sizes, default=None, metavar="C,M",
                   help="photos: complete and occluded poses (default: half the complete "
                   "poses each; scaled down when the file has fewer)")
    g.add_argument("--conditions", type=conditions, default=PHOTO_CONDITIONS, metavar="LIST",
                   help="photos: 1, 2, 3 random joints, mix (1-3 per pose) and transplanted "
                   "(the missing pattern of another of the file's poses); default "
                   "mix,transplanted")
    g.add_argument("--min-frames", type=int, default=30, metavar="T",
                   help="video-real: a clip has at least T consecutive complete frames "
                   "(default 30)")
    g.add_argument("--max-clips", type=int, default=None, metavar="K",
                   help="video-real: a seeded sample of K clips (default all)")


def run(args, methods):
    """Run ``sparseedm evaluate --protocol photos|video-real``: print and write the tables.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    methods : sequence of str
        The methods asked for with ``--methods`` (empty: the protocol's default).

    Returns
    -------
    int
        The exit code, 0.

    Raises
    ------
    SparseEDMError
        If the data file does not fit the protocol (video-real without frame
        numbers); ``main`` turns it into exit code 2.
    """
    from .._atomic import check_paths
    from ..evaluation_real import evaluate_photos, evaluate_tracks
    from ..exceptions import SparseEDMError
    from ..keypoints import read_keypoints

    out = Path(args.output)
    name = args.protocol
    check_paths([("--data", args.data)],
                [("report", out / f"{name}.json"), ("report", out / f"{name}.csv")])
    kps = read_keypoints(args.data)
    chosen = {"methods": methods} if methods else {}  # else the API's defaults
    if name == "photos":
        complete = ~kps.missing.any(axis=1)
        c, m = args.poses if args.poses else (None, None)
        report = evaluate_photos(kps.poses[complete], kps.missing[~complete], n_complete=c,
                                 n_occluded=m, conditions=args.conditions,
                                 dictionary=args.dictionary, random_state=args.seed, **chosen)
        s = report.settings
        print(f"photos: {s['n_complete']} complete + {s['n_occluded']} occluded poses of "
              f"{s['poses']} complete in {args.data}; {s['pool']} missing patterns to "
              "transplant")
    else:
        if kps.frames is None:
            raise SparseEDMError(f"{args.data}: no frame numbers: video-real needs a video "
                                 "file (frames, and tracks for several people)")
        tracks = kps.tracks if kps.tracks is not None else [0] * len(kps)
        report = evaluate_tracks(kps.poses, tracks, kps.frames, gap_lengths=args.gap_lengths,
                                 min_frames=args.min_frames, max_clips=args.max_clips,
                                 dictionary=args.dictionary, random_state=args.seed, **chosen)
        s = report.settings
        print(f"video-real: {s['clips']} clips, {s['frames']} frames of {s['tracks']} "
              f"tracks in {args.data}")
    for note in report.settings["notes"]:
        print(f"sparseedm evaluate: {note}", file=sys.stderr)
    print("error of the hidden joints in % of body size: mean (median); no head sizes, "
          "so no PCKh")
    if name != "photos":
        print("edge jump: how much farther the filled joints move than the truth did at "
              "the gap edges (a hidden frame next to a seen one; 0 where they move less), "
              "mean in % of body size, over the edges every method filled")
    for condition in report.conditions:
        print(f"\n{condition}:")
        print(report.table(condition))
    report.write(out / f"{name}.json", out / f"{name}.csv")
    print(f"\nwrote {name}.json and {name}.csv to {out}/")
    return 0
