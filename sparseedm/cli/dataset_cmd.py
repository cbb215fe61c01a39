"""``sparseedm dataset build``: a training set (.npz) from motion-capture files;
``sparseedm dataset inspect``: the rig, units and joint sources of one file."""

from __future__ import annotations

import argparse
import sys
import warnings


def add_parser(subparsers) -> None:
    """Add the ``sparseedm dataset`` command, its options and help, to `subparsers`.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
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
    build.add_argument("--camera-per", choices=("pose", "clip"), default="pose",
                       help="pose (default): a camera per kept pose, a training set; clip: "
                       "one fixed camera per clip at about 30 frames/s, video sequences "
                       "for `sparseedm evaluate --protocol`")
    build.add_argument("-q", "--quiet", action="store_true",
                       help="no progress bar or summary")
    _rig_options(build)
    build.add_argument("--keep-tpose", action="store_true",
                       help="keep T-pose frames (dropped by default)")
    build.set_defaults(func=run)
    inspect = sub.add_parser(
        "inspect", help="show a file's rig, units and the source of each of the 14 joints",
        description="Load one .bvh/.amc file and print the rig detected, the units chosen, "
        "the standing height, T-pose frames, the plausibility check and the source joint "
        "of each of the 14 joints.",
    )
    inspect.add_argument("path", metavar="FILE", help="a .bvh or .amc file")
    _rig_options(inspect)
    inspect.add_argument("--write-map", metavar="JSON",
                         help="also write the resolved joint map (a starting point to edit)")
    inspect.set_defaults(func=run_inspect)
    parser.set_defaults(func=_help(parser))


def _rig_options(parser):
    parser.add_argument("--units", choices=("auto", "m", "cm", "mm", "inch", "cmu"),
                        default="auto",
                        help="length unit of the files (default auto: from the standing height)")
    parser.add_argument("--joint-map", metavar="MAP",
                        help="JSON (or TOML) joint map naming the source joint of some or all "
                        "of the 14 joints (see docs/howto/joint_maps.md)")


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
    """Build the dataset; exit code 0, or 1 if some files were skipped.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``sparseedm dataset build``.

    Returns
    -------
    int
        The exit code: 0, or 1 if some files were skipped.
    """
    from ..dataset import build_dataset

    # skipped files and implausible poses come back in the report and are printed
    # below as one line each, not as Python warnings with their source line
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        data, report = build_dataset(
            args.paths, args.output,
            cameras_per_pose=args.cameras_per_pose, frame_step=args.frame_step,
            random_state=args.seed, progress=not args.quiet, return_report=True,
            units=args.units, joint_map=args.joint_map, keep_tpose=args.keep_tpose,
            camera=args.camera_per,
        )
    if not args.quiet:
        for f in report["chosen"]:
            height = f"{f['height']:.2f} m" if f["height"] is not None else "unknown"
            print(f"  {f['path']}: rig {f['rig']}, units {f['units']}, height {height}, "
                  f"{f['frames']} frames")
        reported = {f"skipping {p}: {r}" for p, r in report["skipped"]} | {
            w for _, w in report["warnings"]}
        for w in caught:
            if str(w.message) not in reported:
                print(f"  warning: {w.message}")
        n_labels = len(set(data["labels"].tolist()))
        print(f"read {report['files']} file(s), skipped {len(report['skipped'])}; "
              f"wrote {report['poses']} poses ({n_labels} labels) to {args.output}")
        if report["tpose_frames"]:
            print(f"dropped {report['tpose_frames']} T-pose frame(s) (--keep-tpose keeps them)")
        for path, reason in report["skipped"]:
            print(f"  skipped {path}: {reason}")
        for _, problem in report["warnings"]:
            print(f"  warning: {problem}")
    forced = args.units != "auto" and report["warnings"]
    if forced:  # a unit the user chose that makes no person: said even with --quiet
        print(f"sparseedm dataset build: --units {args.units} gives implausible poses in "
              f"{len(report['warnings'])} clip(s): {report['warnings'][0][1]}",
              file=sys.stderr)
    return 1 if report["skipped"] or forced else 0


def run_inspect(args) -> int:
    """Print what the loader makes of one file; exit code 0 (1 if implausible).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``sparseedm dataset inspect``.

    Returns
    -------
    int
        The exit code: 0, or 1 if the file looks implausible.
    """
    from pathlib import Path

    from .._atomic import check_paths, save_json
    from ..exceptions import OutputPathError
    from ..mocap import load_mocap, plausibility
    from ..mocap.rigs import joint_map_to_json

    if args.write_map:
        check_paths([("motion file", args.path), ("--joint-map", args.joint_map)],
                    [("--write-map", args.write_map)])
        if Path(args.write_map).suffix.lower() != ".json":
            raise OutputPathError(
                f"--write-map {args.write_map}: the map is written as JSON; give a name "
                "ending in .json (--joint-map reads a .toml name as TOML)")
    poses, info = load_mocap(args.path, units=args.units, joint_map=args.joint_map,
                             return_info=True)
    problems = plausibility(poses, height=info["height"], name=args.path)
    tpose = info["tpose_frames"]
    print(f"file:    {args.path}")
    print(f"rig:     {info['rig']}")
    print(f"units:   {info['units']} ({info['scale']:.6g} m per file unit)")
    print(f"height:  {info['height']:.3f} m (head top to ankles)")
    print(f"frames:  {len(poses)} at {info['frame_rate']:.4g} fps; T-pose frames: {len(tpose)}"
          + (f" ({', '.join(map(str, tpose[:10]))}{' ...' if len(tpose) > 10 else ''})"
             if len(tpose) else ""))
    print("joints:")
    for joint, source in info["sources"].items():
        print(f"  {joint:<15} <- {source}")
    for problem in problems:
        print(f"warning: {problem}")
    if args.write_map:
        if "joint_map" not in info:
            print("--write-map: joint maps are written for BVH files only")
            return 2
        units = info["units"] if info["units"] in ("m", "cm", "mm", "inch", "cmu") else None
        save_json(args.write_map, joint_map_to_json(info["joint_map"], units=units), indent=1)
        print(f"wrote the joint map to {args.write_map}")
    return 1 if problems else 0
