"""``sparseedm recover INPUT -o OUTPUT``: fill in the occluded joints of a keypoint file.

Exit codes: 0 every row came back usable (recovered or complete), 1 some rows
were refused (the output is still written, the errors file lists them),
2 bad input (unreadable file, unusable dictionary, bad option): nothing written.
"""

from __future__ import annotations

import sys

from ._common import (INPUT_HELP, add_adaptation_rounds, add_input_format, add_joint_map,
                      add_quiet, refusals_said, show_progress)


def add_parser(sub):
    """Add the ``sparseedm recover`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser(
        "recover",
        help="recover occluded joints in a keypoint file (.csv, .npz, .npy, COCO, "
        "PoseTrack, MMPose or AlphaPose .json, an OpenPose folder or .json, DeepLabCut "
        ".csv/.h5)",
        description="Fill in the missing joints of every pose in INPUT by sparse coding "
        "of its distance matrix and write them to OUTPUT, with a status per row. "
        "Rows that cannot be recovered are written back unchanged and listed in an "
        "errors file. Exit code 0: all rows usable; 1: some rows refused; 2: bad input.",
    )
    p.add_argument("input", help=INPUT_HELP)
    p.add_argument("-o", "--output", required=True,
                   help="file (or OpenPose/MMPose folder) to write, at exactly this path, in "
                   "--format, else INPUT's own format when the extension suits it "
                   "(OpenPose: no extension for a folder, .json for one frame file; "
                   "MMPose .json, no extension for a folder of per-image files; AlphaPose "
                   ".json; DeepLabCut "
                   ".csv or .h5), else its extension's (.csv "
                   ".npz .npy, .json COCO, .h5 DeepLabCut), else INPUT's; never the "
                   "input, the dictionary or the errors file")
    _add_recovery_options(p)
    _add_format_options(p)
    _add_run_options(p)
    _add_adaptation_options(p)
    add_quiet(p)
    p.set_defaults(func=run)


def _add_recovery_options(p):
    """The dictionary, alpha, workers, representation and solver."""
    p.add_argument("--dictionary", default=None, metavar="NAME|PATH",
                   help="shipped dictionary name or path to a dictionary .npz "
                   "(default: the shipped default)")
    p.add_argument("--alpha", type=float, default=None,
                   help="lasso penalty (default: the dictionary's recommended alpha)")
    p.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="parallel workers (-1: all cores; default 1: none, the fast "
                   "solver's kernels still run on every core): threads with the default "
                   "fast solver (its kernels release the GIL), processes with --solver "
                   "clarabel, or --backend's")
    p.add_argument("--representation", choices=("average", "zero"), default=None,
                   help="occlusion representation (default: the one a --model was trained "
                   "on, else average)")
    p.add_argument("--solver", choices=("fast", "clarabel"), default="fast",
                   help="lasso backend (default fast: certified LARS, Clarabel fallback)")


def _add_format_options(p):
    """The output format, errors file, confidence threshold, joint map, filled score."""
    p.add_argument("--format", choices=("csv", "npz", "npy", "coco", "json", "openpose",
                                        "mmpose", "alphapose", "dlc"), default=None,
                   help="output format (default: from OUTPUT's extension, else INPUT's)")
    p.add_argument("--errors", default=None, metavar="FILE",
                   help="errors file listing refused rows and unreadable input files "
                   "(default OUTPUT stem + .errors.csv)")
    p.add_argument("--confidence-threshold", type=float, default=None, metavar="T",
                   help="joints with a confidence below T count as missing and are "
                   "recovered (default: the input format's: DeepLabCut 0.6 (its pcutoff), "
                   "MMPose, AlphaPose and COCO 0.3, OpenPose 0.05, csv/npz/npy 0; see "
                   "sparseedm.formats)")
    add_joint_map(p)
    add_input_format(p)
    p.add_argument("--filled-score", type=float, default=0.0, metavar="S",
                   help="score in [0, 1] written for filled joints (OpenPose, MMPose, "
                   "AlphaPose, COCO; a DeepLabCut table's likelihood says how sure the "
                   "fill is instead, at most 0.5); default 0, below every threshold")
    p.add_argument("--no-outliers", action="store_true",
                   help="trust every point the threshold keeps (by default a point scored "
                   "below 0.3 that the pose model and its track both contradict is treated "
                   "as missing, filled and named in the output's 'outliers': "
                   "sparseedm.outliers)")


def _add_run_options(p):
    """Chunks, the parallel backend, the method and model, time, EDMs."""
    p.add_argument("--chunk-size", type=int, default=50_000, metavar="N",
                   help="poses per chunk; bounds memory (default 50000)")
    p.add_argument("--backend", choices=("loky", "threading", "dask"), default=None,
                   help="joblib backend for --jobs (default: threads with the fast "
                   "solver, loky processes with clarabel); 'dask' runs on a Dask cluster "
                   "(pip install 'sparseedm[dask]'; --scheduler)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address with --backend dask, e.g. tcp://host:8786")
    p.add_argument("--method", choices=("sparse", "fconv"), default="sparse",
                   help="sparse coding (default) or a trained FConv network (--model; "
                   "needs the torch extra)")
    p.add_argument("--model", default=None, metavar="PATH",
                   help="FConv model .npz from `sparseedm fit-cnn` (with --method fconv)")
    p.add_argument("--no-temporal", action="store_true",
                   help="recover every pose on its own even when INPUT gives frames (by "
                   "default a CSV 'frame' column or .npz 'frames' array, with 'track' / "
                   "'tracks' for several people, turns on recovery across time: "
                   "sparseedm.temporal; several people in a frame without track ids are "
                   "linked into tracks first)")
    p.add_argument("--save-edm", action="store_true",
                   help="also store the completed EDM vectors (see sparseedm.batch)")


def _add_adaptation_options(p):
    """Adaptation, its rounds and ensembles, the dictionary saved."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--no-adapt", action="store_true",
                   help="learn nothing from INPUT (by default "
                   "INPUT's complete poses are extra atoms, the only atoms or the poses "
                   "the dictionary adapts on, whichever a check on held-back poses "
                   "prefers: sparseedm.exemplars, sparseedm.adaptation); without "
                   "--dictionary, poses are coded one by one over cmu-coco-k2932 with "
                   "--mirror-auto and averaged with the shipped pose bank's local Gaussian "
                   "(--dictionary default: over the default dictionary alone, no bank)")
    g.add_argument("--adapt-from", default=None, metavar="FILE",
                   help="adapt on the complete poses of FILE (same source, any keypoint "
                   "format; a video's time-completed frames too) instead of INPUT's")
    add_adaptation_rounds(
        p, "after adapting, rounds of self-training on INPUT's incomplete poses (recover a "
        "sample, adapt again with them; the last round guarded); default 3 (with frames: "
        "from 1000 poses on, none below), 0 turns it off",
        "adapt K times (seeds 0..K-1) and average the K recoveries: lower error, K times "
        "the work (default 1; sparseedm.ensemble); one dictionary, with a warning, when "
        "the adaptation is not adopted or INPUT's own poses are the atoms")
    p.add_argument("--preset", choices=("default", "fast"), default="default",
                   help="'default': adaptation and self-training as set above; 'fast': "
                   "INPUT's complete poses (or --adapt-from's) are the dictionary's atoms, "
                   "nothing learned, each occluded pose a local ridge over its 48 most "
                   "similar ones (not the lasso; the lasso when the dictionary's codes "
                   "are non-negative): much faster on a file with many "
                   "complete poses (per pose: needs --no-temporal on a file with "
                   "frames; sparseedm.file_atoms)")
    p.add_argument("--no-exemplars", action="store_true",
                   help="adapt even where INPUT's own complete poses, as the dictionary's only "
                   "atoms, would be chosen (by default they are from 2000 complete poses, "
                   "and from 250 when a check on held-back poses prefers them: "
                   "sparseedm.exemplars; not with --preset fast, which always takes them)")
    mirror = p.add_mutually_exclusive_group()
    mirror.add_argument("--mirror", action="store_true",
                        help="also recover each pose's mirror image (left and right swapped) "
                        "and average the two answers: twice the work (per pose: needs "
                        "--no-temporal on a file with frames)")
    mirror.add_argument("--mirror-auto", action="store_true",
                        help="as --mirror, the two answers weighed by their lasso objectives "
                        "(the mirror's weight falls from one half as its objective exceeds "
                        "the pose's own); the default with --no-adapt and no --dictionary")
    p.add_argument("--save-dictionary", default=None, metavar="FILE",
                   help="write the dictionary used (adapted or not; with --ensemble, the "
                   "first member's) to FILE (.npz)")


def run(args):
    """Run ``sparseedm recover``: fill in the occluded joints of a keypoint file and write them.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 every row usable, 1 some rows refused (the outputs still written).

    Raises
    ------
    SparseEDMError
        If the options do not go together (``--method fconv`` without ``--model``); ``main``
        turns it into exit code 2.
    """
    from .._atomic import is_stream
    from ..adaptation import FILE_ATOMS_PATHS
    from ..batch import recover_file
    from ..exceptions import SparseEDMError

    if (args.method == "fconv") != (args.model is not None):
        raise SparseEDMError("--method fconv and --model PATH go together")

    summary = recover_file(
        args.input, args.output, dictionary=args.dictionary, alpha=args.alpha,
        representation=args.representation, solver=args.solver, n_jobs=args.jobs,
        chunk_size=args.chunk_size, output_format=args.format, errors_path=args.errors,
        progress=show_progress(args), save_edm=args.save_edm,
        confidence_threshold=args.confidence_threshold,
        backend=args.backend, scheduler=args.scheduler,
        method=args.method, model=args.model,
        adapt=False if args.no_adapt else (args.adapt_from or "auto"),
        save_dictionary=args.save_dictionary, self_training=args.self_training,
        ensemble=args.ensemble, joint_map=args.joint_map, filled_score=args.filled_score,
        temporal=not args.no_temporal, input_format=args.input_format,
        preset=args.preset,
        outliers=not args.no_outliers, exemplars=False if args.no_exemplars else "auto",
        mirror="auto" if args.mirror_auto else (True if args.mirror else None),
    )
    out = sys.stderr if args.quiet or is_stream(args.output) else sys.stdout  # -o /dev/stdout
    ad = summary.get("adaptation")
    fast = args.preset == "fast"  # its summary line says what it did: not a refusal
    chosen = ad is not None and ad.get("path") in FILE_ATOMS_PATHS  # nor this
    if ad is not None and not ad["adapted"] and ad["poses_used"] == 0 and not (fast or chosen):
        print(f"sparseedm recover: no adaptation: {ad['reason']}", file=sys.stderr)
    if summary.get("linked_tracks") is not None:
        print(f"sparseedm recover: {args.input} has frames, no track ids and several poses in "
              f"a frame: linked them into {summary['linked_tracks']} track(s) by pose distance "
              "(written back as its tracks)", file=sys.stderr)
    if summary.get("frames_unused"):
        f = summary["frames_unused"]
        print(f"sparseedm recover: {args.input} has frame numbers{_frame_range(summary)} "
              f"(from its rows, or its file or image names), but {f['alone']} of "
              f"{f['poses']} poses have no other "
              f"frame of their track within {f['max_skip']} frame numbers: recovered as "
              "photos, pose by pose (their frames written back as read; a video's frames "
              "need frame indices 0, 1, 2..., not timestamps)", file=sys.stderr)
    if summary.get("temporal"):
        t = summary["temporal"]
        print(f"sparseedm recover: {args.input} has frames{_frame_range(summary)}: "
              "recovered across time "
              f"({t['segments']} track segment(s), {t['per_frame_poses']} per-frame answers)"
              f"{_alone_note(t)}; --no-temporal turns it off", file=sys.stderr)
    if summary.get("outliers"):
        print(f"sparseedm recover: {summary['outliers']} low-scored point(s) contradicted by "
              "the pose model and their track were treated as missing (named in 'outliers'); "
              "--no-outliers keeps them", file=sys.stderr)
    print(format_summary(summary), file=out)
    return refusals_said("recover", summary)


def _frame_range(summary) -> str:
    """The first and last frame numbers read, as " LO-HI" ("" without): what was
    inferred, for a file whose frames come from its image or file names."""
    span = summary.get("frame_range")
    return "" if not span else f" {span[0]}-{span[1]}"


def _alone_note(temporal) -> str:
    """What the rows answered frame by frame in a file with frames have in
    common: their count and the commonest reason ("" when there are none)."""
    alone = temporal.get("alone") or {}
    if not alone:
        return ""
    why, count = max(alone.items(), key=lambda kv: kv[1])
    note = f"; {sum(alone.values())} row(s) on their own, {count} because {why}"
    if temporal["segments"] == 0 and why.startswith("the only frame"):
        note += " (no two rows of a track are within 30 frame numbers: are they timestamps? " \
                "time needs frame indices 0, 1, 2...)"
    return note


def format_summary(s) -> str:
    """The lines printed at the end of a run.

    Parameters
    ----------
    s : dict
        The run's summary (output, format, poses, recovered joints, refused rows,
        time, status counts and, when present, the threshold, adaptation and
        temporal lines).

    Returns
    -------
    str
        The lines, joined by newlines.
    """
    rate = f"{s['poses_per_second']:,.0f} poses/s" if s["poses_per_second"] else "-"
    counts = ", ".join(f"{k} {v}" for k, v in s["status"].items()) or "none"
    lines = [
        f"wrote {s['output']} ({s['format']})",
        f"poses: {s['poses']}  recovered joints: {s['recovered_joints']}  "
        f"rows refused: {s['refused']}",
        f"time: {s['seconds']:.2f} s  ({rate})",
        f"status: {counts}",
    ]
    if s.get("threshold_line"):
        lines.append(s["threshold_line"])
    for name, reason in s.get("skipped_files", []):
        lines.append(f"skipped {reason}")
    if s.get("fallbacks"):
        lines.append(f"poses re-solved by Clarabel: {s['fallbacks']} (the fast solver's "
                     "answer missed its duality-gap certificate; the interior-point answer "
                     "is kept)")
    if s.get("sidecars"):
        lines.append("also wrote: " + ", ".join(s["sidecars"]))
    if s.get("adaptation_line"):
        lines.append(s["adaptation_line"])
    if s.get("ensemble", 1) > 1 and (s.get("adaptation") or {}).get("adapted"):
        lines.append(f"ensemble: the mean of {s['ensemble']} adapted dictionaries' recoveries")
    for kind, seen in ((s.get("averaged") or {}).get("with") or {}).items():
        lines.append(f"averaged with the answer of the {kind}: {seen['poses']} pose(s) "
                     "(their field 'averaged' says so)")
    if s.get("mirror") == "auto":
        lines.append("mirror: each pose's answer weighed with its mirror image's by their "
                     "lasso objectives")
    elif s.get("mirror"):
        lines.append("mirror: each pose's answer averaged with its mirror image's")
    if s.get("dictionary"):
        lines.append(f"dictionary written to {s['dictionary']}")
    return "\n".join(lines)
