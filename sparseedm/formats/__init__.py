"""Detector and tracker keypoint formats: OpenPose, MMPose, AlphaPose, DeepLabCut (and PoseTrack).

One module per format, each reading into the 14-joint layout and writing back
in the same format with the filled joints flagged:

- :mod:`~sparseedm.formats.openpose`: OpenPose ``--write_json`` frame files or a folder of them
- :mod:`~sparseedm.formats.mmpose`: MMPose prediction JSON (COCO-17, Halpe, COCO-WholeBody)
- :mod:`~sparseedm.formats.alphapose`: AlphaPose results JSON (COCO-17, Halpe, COCO-WholeBody)
- :mod:`~sparseedm.formats.deeplabcut`: DeepLabCut ``.csv`` / ``.h5`` tables with a joints map
- :mod:`~sparseedm.formats.posetrack`: ``track_id`` / ``frame_id`` of COCO files (PoseTrack)

Users call :func:`sparseedm.keypoints.read_keypoints` and
:func:`~sparseedm.keypoints.write_keypoints`, which dispatch here (COCO, CSV
and the array formats live in :mod:`sparseedm.keypoints`). :func:`detect`
tells a format from a path: a folder is OpenPose, or MMPose when its first
files are MMPose per-image files (lists of instances), ``.h5`` DeepLabCut, a
``.csv`` whose first cell is ``scorer`` DeepLabCut, and a ``.json`` by its
first MiB (``"people"``: OpenPose; ``"instance_info"`` or keypoints as
``[[x, y], ...]`` pairs: MMPose; a results list with AlphaPose's ``"idx"``
or ``"box"``, or flat keypoints of a Halpe or COCO-WholeBody layout (78, 399
or 408 values): AlphaPose; otherwise COCO).

Default confidence thresholds
-----------------------------
:data:`DEFAULT_THRESHOLDS` holds the threshold each format is read with when
none is given (a joint whose confidence is below it is missing, and recovered):

``dlc``: 0.6
    DeepLabCut's own ``pcutoff`` default (``config.yaml``): the likelihood
    below which DeepLabCut itself drops a body part from its plots and
    filtered outputs;
``mmpose``, ``coco``: 0.3
    MMPose's ``kpt_thr`` default (its demos and visualiser draw only keypoints
    scoring above it); MMPose's COCO metric counts keypoints above 0.2 as valid
    when it rescores instances, so detectors' occluded joints (0.02-0.2) fall
    below either. COCO ground truth (``v`` 0/1/2) is unaffected: labelled joints
    have v >= 1;
``alphapose``: 0.3
    as COCO results (AlphaPose's are COCO results lists): between the 0.2
    above which AlphaPose's default drawing shows a keypoint and the 0.4 of
    its fast drawing (``--vis_fast``);
``openpose``: 0.05
    OpenPose's ``--render_threshold`` default: below it OpenPose itself does
    not draw a keypoint (it writes 0 for joints it did not find at all);
``csv``, ``npz``, ``npy``: 0
    these hold whatever the user put in them, so only a confidence <= 0 is
    missing.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from .._safeio import load_json
from ..exceptions import FileFormatError
from . import alphapose, deeplabcut, mmpose, openpose, posetrack
from ._base import COCO_17, HEAD_TOP_FACTOR, Parsed, Rows, read_extra, to_14

__all__ = ["FORMATS", "DEFAULT_THRESHOLDS", "FILLED_SCORE", "detect", "read", "write",
           "default_threshold", "count_below", "threshold_line", "read_extra", "to_14",
           "COCO_17", "HEAD_TOP_FACTOR", "Parsed", "Rows", "alphapose", "deeplabcut", "mmpose",
           "openpose", "posetrack"]

#: formats read and written by this subpackage
FORMATS = ("openpose", "mmpose", "alphapose", "dlc")
#: confidence threshold per format when none is given (see the module docstring)
DEFAULT_THRESHOLDS = {"dlc": 0.6, "mmpose": 0.3, "coco": 0.3, "alphapose": 0.3,
                      "openpose": 0.05, "csv": 0.0, "npz": 0.0, "npy": 0.0}
#: the score a filled joint is written with by default: below every threshold,
#: and "not detected" to COCO and OpenPose readers
FILLED_SCORE = 0.0
_SNIFF_BYTES = 1 << 20
_OPENPOSE = re.compile(rb'"people"\s*:\s*\[')
_MMPOSE = re.compile(rb'"instance_info"\s*:|"instances"\s*:\s*\[|"keypoints"\s*:\s*\[\s*\[')
#: an MMPose per-image file: a list, empty or of instances with [x, y] keypoints
_EMPTY_LIST = re.compile(rb"\s*\[\s*\]\s*$")
_KEYPOINT_PAIRS = re.compile(rb'"keypoints"\s*:\s*\[\s*\[')
#: an AlphaPose results list: AlphaPose's own keys, or the first entry's flat keypoints
_ALPHAPOSE_KEYS = re.compile(rb'"(?:idx|box)"\s*:')
_FLAT_KEYPOINTS = re.compile(rb'"keypoints"\s*:\s*\[([^\[\]]*)\]')


def _inferencer_hint(doc):
    """What to do with an ``MMPoseInferencer`` result saved whole (``{"predictions":
    [[instance, ...]], "visualization": ...}``, or a list of them)."""
    first = doc[0] if isinstance(doc, list) and doc else doc
    if not (isinstance(first, dict) and "predictions" in first):
        return ""
    return ("; it looks like MMPoseInferencer's results saved whole: run the inferencer "
            "with pred_out_dir= (one file per image, a folder sparseedm reads), or save "
            "one image's instances, result['predictions'][0]")


def default_threshold(fmt):
    """The confidence threshold `fmt` is read with when none is given.

    >>> default_threshold("dlc")
    0.6

    Parameters
    ----------
    fmt : str
        A format name (a key of :data:`DEFAULT_THRESHOLDS`).

    Returns
    -------
    float
        Its default threshold.
    """
    return DEFAULT_THRESHOLDS.get(fmt, 0.0)


def count_below(confidence, threshold):
    """Joints scored above 0 but below `threshold` (read as missing by the threshold).

    >>> count_below(np.array([[0.0, 0.1, 0.5, np.nan]]), 0.3)
    1

    Parameters
    ----------
    confidence : ndarray or None
        Scores read.
    threshold : float
        The threshold.

    Returns
    -------
    int or None
        How many joints it turns missing (None when there are no scores).
    """
    if confidence is None:
        return None
    with np.errstate(invalid="ignore"):
        return int(((confidence > 0) & (confidence < threshold)).sum())


def threshold_line(threshold, given, fmt, below):
    """The summary line of ``sparseedm recover`` about the confidence threshold.

    >>> threshold_line(0.3, False, "mmpose", 4)
    'confidence threshold 0.3 (the mmpose default): 4 scored joints below it read as missing'
    >>> threshold_line(0.3, False, "coco", 0)
    'confidence threshold 0.3 (the coco default): the file has scores, none below it'

    Parameters
    ----------
    threshold : float
        The threshold used.
    given : bool
        Whether the user gave it.
    fmt : str
        The input's format.
    below : int or None
        Scored joints below it (None: the file has no scores).

    Returns
    -------
    str
        The line.
    """
    where = "given" if given else f"the {fmt} default"
    head = f"confidence threshold {threshold:g} ({where})"
    if below is None:
        return f"{head}: the file has no scores"
    if below == 0:
        return f"{head}: the file has scores, none below it"
    return f"{head}: {below} scored joints below it read as missing"


def detect(path):
    """The format of `path` if it is one of :data:`FORMATS`, else None.

    Raises FileFormatError for a folder that holds no ``.json`` file.

    Parameters
    ----------
    path : str or path-like
        A file or folder.

    Returns
    -------
    str or None
        ``"openpose"``, ``"mmpose"``, ``"alphapose"``, ``"dlc"`` or None.
    """
    path = Path(path)
    if path.is_dir():
        return _folder_format(path)
    ext = path.suffix.lower()
    if ext in deeplabcut.H5_SUFFIXES:
        return "dlc"
    if ext not in (".csv", ".json") or not path.is_file():
        return None
    try:
        with open(path, "rb") as f:
            head = f.read(_SNIFF_BYTES)
    except OSError:
        return None
    if ext == ".csv":
        first = head.lstrip(b"\xef\xbb\xbf").split(b"\n", 1)[0]
        return "dlc" if first.split(b",", 1)[0].strip() == b"scorer" else None
    if _OPENPOSE.search(head) and b'"annotations"' not in head:
        return "openpose"
    if _MMPOSE.search(head):
        return "mmpose"
    if _is_alphapose_head(head):
        return "alphapose"
    return None


def _is_alphapose_head(head):
    """Whether a JSON file's first bytes are an AlphaPose results list
    (:func:`sparseedm.formats.alphapose.is_alphapose`'s rule)."""
    if head.lstrip(b"\xef\xbb\xbf \t\r\n")[:1] != b"[":
        return False
    if _ALPHAPOSE_KEYS.search(head):
        return True
    first = _FLAT_KEYPOINTS.search(head)
    count = 0 if first is None or not first.group(1).strip() else first.group(1).count(b",") + 1
    return count % 3 == 0 and count // 3 in set(alphapose.LAYOUTS) - {len(COCO_17)}


def _folder_format(path, tries=20):
    """A folder's format by the content of its first frame files (name order):
    ``"mmpose"`` for MMPose per-image files (a list of instances), else
    ``"openpose"`` (whose reader names the problem of a folder that is neither)."""
    try:
        names = sorted(e.name for e in os.scandir(path) if e.name.lower().endswith(".json")
                       and not e.name.startswith(".") and e.is_file())
    except OSError:
        return "openpose"
    for name in names[:tries]:
        try:
            with open(path / name, "rb") as f:
                head = f.read(_SNIFF_BYTES)
        except OSError:
            continue
        if _OPENPOSE.search(head):
            return "openpose"
        if head.lstrip()[:1] == b"[" and (_EMPTY_LIST.match(head)
                                          or _KEYPOINT_PAIRS.search(head)):
            return "mmpose"
    return "openpose"


def read(fmt, path, *, joint_map=None):
    """Read `path` in format `fmt` (one of :data:`FORMATS`) into a :class:`Parsed`.

    Parameters
    ----------
    fmt : str
        One of :data:`FORMATS`.
    path : str or path-like
        The file or folder.
    joint_map : str, path-like or dict, optional
        DeepLabCut's joints map.

    Returns
    -------
    Parsed
        The keypoints in the 14-joint layout.
    """
    if fmt == "openpose":
        return openpose.read(path)
    if fmt == "mmpose" and Path(path).is_dir():
        return mmpose.read_folder(path)
    if fmt == "mmpose":
        doc = load_json(path)
        if not mmpose.is_mmpose(doc):
            raise FileFormatError(f"{path}: not an MMPose prediction file (no "
                                  "'instance_info' and no instances with [x, y] keypoints)"
                                  + _inferencer_hint(doc))
        return mmpose.read(path, doc)
    if fmt == "alphapose":
        doc = load_json(path)
        if not alphapose.is_alphapose(doc):
            raise FileFormatError(f"{path}: not an AlphaPose results file (a list of "
                                  "results with flat 'keypoints' and 'idx' or 'box')"
                                  + alphapose.cmu_hint(doc))
        return alphapose.read(path, doc)
    if fmt == "dlc":
        return deeplabcut.read(path, joint_map)
    raise FileFormatError(f"{path}: unknown format {fmt!r}; one of {FORMATS}")


def write(fmt, path, rows, meta, *, filled_score=FILLED_SCORE, row_fields=None):
    """Write :class:`Rows` to `path` in format `fmt`, with `meta` of a read of that format.

    Parameters
    ----------
    fmt : str
        One of :data:`FORMATS`.
    path : str or path-like
        The output file or folder.
    rows : Rows
        The poses to write.
    meta : dict
        ``Parsed.meta`` of the read (empty to write a fresh file).
    filled_score : float
        Score of a filled joint.
    row_fields : dict, optional
        Per-row fields (status, reason...) to add to each person.
    """
    module = {"openpose": openpose, "mmpose": mmpose, "alphapose": alphapose,
              "dlc": deeplabcut}[fmt]
    module.write(path, rows, meta if meta.get("format") == fmt else {}, filled_score,
                 row_fields)
