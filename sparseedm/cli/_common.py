"""Options and helpers shared by the sub-commands."""

from __future__ import annotations

import sys
from pathlib import Path


#: INPUT of recover and lift: the keypoint files read_keypoints reads
INPUT_HELP = ("keypoints: .csv, .npz, .npy, COCO-style or PoseTrack .json, OpenPose .json or "
              "a folder of them, MMPose predictions .json or a folder of per-image files, "
              "AlphaPose results .json, DeepLabCut .csv/.h5 (see sparseedm.formats)")

#: how --frames / --rows are read (sparseedm.plotting.select_values)
SELECTION_HELP = ("a range LO:HI (HI excluded; an end may be left out), single numbers, or "
                  "several joined by commas, e.g. 10:40 or 3,10:20")


def add_quiet(parser):
    """Add ``-q/--quiet`` (no progress bar or lines) to a command's parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress bar or progress lines on stderr (the bar is also off "
                        "when stderr is not a terminal)")


def add_joint_map(parser):
    """``--joint-map FILE``, as recover and lift take it (DeepLabCut input).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument("--joint-map", default=None, metavar="FILE",
                        help="DeepLabCut input: JSON file naming the body part of each of "
                        "the 14 joints ({\"joints\": {\"head_top\": \"head\", ...}})")


#: the keypoint formats read_keypoints reads (with its aliases json, posetrack, deeplabcut);
#: tests/test_cli_defaults.py keeps the two equal
INPUT_FORMATS = ("csv", "npz", "npy", "coco", "json", "posetrack", "openpose", "mmpose",
                 "alphapose", "dlc", "deeplabcut")


def add_input_format(parser, what="INPUT"):
    """``--input-format FORMAT``, as recover, lift and fit take it: the keypoint file's
    format when its name does not tell (``/dev/stdin``, a pipe, an odd extension).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    what : str, default "INPUT"
        The argument the option is about, as its help names it.
    """
    parser.add_argument("--input-format", choices=INPUT_FORMATS, default=None,
                        metavar="FORMAT",
                        help=f"{what}'s keypoint format when its name does not tell (e.g. "
                        "/dev/stdin): " + ", ".join(INPUT_FORMATS) + f" (default: told from "
                        f"{what}'s content and extension)")


def add_adaptation_rounds(parser, self_training_help, ensemble_help):
    """``--self-training ROUNDS`` and ``--ensemble K``, as recover and evaluate take them
    (defaults: the API's, None meaning ``SELF_TRAINING_ROUNDS``, and 1).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    self_training_help : str
        The help text of ``--self-training``.
    ensemble_help : str
        The help text of ``--ensemble``.
    """
    parser.add_argument("--self-training", type=int, default=None, metavar="ROUNDS",
                        help=self_training_help)
    parser.add_argument("--ensemble", type=int, default=1, metavar="K", help=ensemble_help)


def refusals_said(command, summary) -> int:
    """The exit code of a run that wrote its outputs (1 when some rows were
    refused or some input files could not be read, else 0), said on stderr.

    Parameters
    ----------
    command : str
        The command's name, for the message.
    summary : dict
        The run's summary: ``refused``, ``errors`` (the errors file) and
        optionally ``skipped_files``.

    Returns
    -------
    int
        The exit code, 0 or 1.
    """
    refused, skipped = summary["refused"], len(summary.get("skipped_files") or [])
    if not refused and not skipped:
        return 0
    what = [f"{refused} row(s) refused"] if refused else []
    what += [f"{skipped} input file(s) unreadable"] if skipped else []
    print(f"sparseedm {command}: {' and '.join(what)}; see {summary['errors']}",
          file=sys.stderr)
    return 1


def show_progress(args) -> bool:
    """Progress bars only for a person watching a terminal.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (its ``quiet`` flag, if any).

    Returns
    -------
    bool
        True when not ``--quiet`` and stderr is a terminal.
    """
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def load_npz(path, what, required, optional=()):
    """The `required` and present `optional` arrays of an .npz, read by the bounded
    reader (:func:`sparseedm._safeio.load_npz`: sizes checked first, pickles refused).

    Returns ``(arrays, names)``: a dict of the arrays read and the set of all
    array names in the file. Raises FileNotFoundError or FileFormatError
    naming the file.

    Parameters
    ----------
    path : str or Path
        The .npz file.
    what : str
        What the file is, for messages (``"training set"``...).
    required : sequence of str
        Arrays the file must hold.
    optional : sequence of str, optional
        Arrays read when present.

    Returns
    -------
    arrays : dict of str to ndarray
        The arrays read.
    names : set of str
        Every array name in the file.

    Raises
    ------
    FileNotFoundError
        If `path` does not exist.
    FileFormatError
        If the file is not a readable .npz or lacks a required array.
    """
    from .._safeio import load_npz as load_bounded
    from ..exceptions import FileFormatError

    from .._safeio import regular_file

    path = Path(path)
    try:
        regular_file(path, f"{what} file {path}")  # a folder or device: said so
    except FileNotFoundError:
        raise FileNotFoundError(f"no such {what} file: {path}") from None
    arrays, names = load_bounded(path, (*required, *optional),
                                 what=f"{path}: not a readable .npz:")
    lacking = [k for k in required if k not in arrays]
    if lacking:
        raise FileFormatError(
            f"{path}: no {' or '.join(map(repr, lacking))} array (has: "
            f"{', '.join(sorted(names)) or 'nothing'}); see `sparseedm dataset build`")
    return arrays, set(names)


def occluded_range(text, default):
    """``--occluded LO-HI`` as (lo, hi); `default` when not given.

    Parameters
    ----------
    text : str or None
        The option's value, ``LO-HI``; None: not given.
    default : tuple of int
        The range when not given.

    Returns
    -------
    tuple of int
        ``(lo, hi)``.

    Raises
    ------
    SparseEDMError
        If `text` is not two integers joined by ``-``.
    """
    from ..exceptions import SparseEDMError

    if text is None:
        return default
    try:
        lo, hi = (int(t) for t in text.split("-"))
    except ValueError:
        raise SparseEDMError(f"--occluded must look like LO-HI (e.g. 1-3), got {text!r}") \
            from None
    return lo, hi


def channels(text):
    """``--channels C1,C2`` as two positive integers.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    tuple of int
        The two channel counts.

    Raises
    ------
    SparseEDMError
        If `text` is not two positive integers.
    """
    from ..exceptions import SparseEDMError

    try:
        out = tuple(int(c) for c in text.split(","))
    except ValueError:
        out = ()
    if len(out) != 2 or min(out) < 1:
        raise SparseEDMError(f"--channels must be two positive integers, got {text!r}")
    return out


def split_list(text):
    """The items of a comma-separated option value, stripped, empty ones dropped.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    tuple of str
        The items, in order.
    """
    return tuple(t.strip() for t in text.split(",") if t.strip())
