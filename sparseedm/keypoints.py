"""Read and write users' 2D keypoints: ``.npz``/``.npy``, CSV, COCO-style JSON, and
(through :mod:`sparseedm.formats`) OpenPose, MMPose, AlphaPose and DeepLabCut output.

Every reader returns one in-memory form, a :class:`KeypointSet`:

``poses``
    (n, 14, 2) float, joints in :data:`~sparseedm.skeleton.SKELETON_14`
    order, **NaN for every missing joint**;
``missing``
    (n, 14) bool, True = missing;
``confidence``
    (n, 14) float or None;
``ids``
    (n,) str or None (image / frame ids);
``meta``
    dict of format details needed to write the same file back
    (extra CSV columns, the original COCO document, ...).

:func:`write_keypoints` writes poses (e.g. recovered ones) in any of the formats,
atomically (:func:`sparseedm._atomic.atomic_path`). The format comes from the
extension (``.npz``, ``.npy``, ``.csv``, ``.json``) unless ``format=`` says
``"npz"``, ``"npy"``, ``"csv"`` or ``"coco"``.

When is a joint missing?
------------------------
In every format a joint is missing when any of its coordinates is NaN (or an
empty CSV cell), when the file marks it missing (the ``missing`` array of an
``.npz``, COCO visibility ``v = 0``), when its confidence is not positive
(0, negative or NaN: "not detected" in COCO and OpenPose alike), or when its
confidence is below ``confidence_threshold`` (default: the format's,
:data:`sparseedm.formats.DEFAULT_THRESHOLDS`: 0.3 for COCO, 0 for the array
and CSV formats). In CSV, ``.npy`` and ``.npz`` files a joint at exactly
(0, 0) of a pose in pixels (no negative coordinate) is missing too, with a
warning (:func:`origin_joints`: many tools write ``0, 0`` for a joint they did
not find); :func:`write_keypoints` refuses to write such a joint as observed.
Missing joints are read as NaN; their coordinates are not kept in ``poses``.

Array files
-----------
``.npz``: key ``poses`` (n, 14, 2) float; optional ``missing`` (n, 14) bool
(or 0/1), ``confidence`` (n, 14) float, ``ids`` (n,) str (or integers, or
UTF-8 bytes), ``tracks`` (n,) (or ``clips``, as ``sparseedm dataset build``
names them) and ``frames`` (n,) integers for video. The per-row result arrays :func:`sparseedm.batch.recover_file`
writes (:data:`RESULT_FIELDS`) are kept in ``meta["npz_extra"]`` and written
back; any other member is ignored, never decompressed or copied (its name is
listed in ``meta["npz_ignored"]``). Each member's declared size is checked
against the archive before it is read (:mod:`sparseedm._safeio`). ``.npy``: one (n, 14, 2) array with
NaN for missing joints, or (n, 14, 3) whose third column is a confidence;
ids cannot be stored in ``.npy`` (a warning says they were dropped). A single
pose (14, 2) / (14, 3) is read as n = 1. Both are loaded with
``allow_pickle=False``: a file holding pickled objects is refused, never
unpickled.

CSV columns
-----------
One pose per row after a header row::

    id,head_top_x,head_top_y,neck_x,neck_y,...,left_ankle_x,left_ankle_y[,<joint>_conf ...][,extra ...]

* ``id`` (optional): the image / frame id, read as text;
* ``<joint>_x``, ``<joint>_y`` for each of the 14 joints of
  :data:`~sparseedm.skeleton.JOINT_NAMES` (all 28 required; any order on read,
  SKELETON_14 order on write);
* ``<joint>_conf`` (optional, for all 14 joints or for none): the joint's
  confidence; ``_score``, ``_confidence`` or ``_likelihood``
  (:data:`CONF_SYNONYMS`) are read the same way, one suffix per file (a file
  mixing them is an error);
* ``track`` and ``frame`` (optional, video): the person and frame number of
  each pose, read into ``tracks`` (text) and ``frames`` (integers, or the
  cells as text when one is not an integer: the recovery then says which row);
  they stay extra columns too and are written back as read;
* any other column (no ``_x``/``_y``/``_conf`` suffix, e.g. ``status``; a
  confidence synonym after a name that is not a joint, e.g. ``bbox_score``) is
  kept as text in ``meta["extra_columns"]`` and written back. A column with
  such a suffix but an unknown joint name (``lefty_wrist_x``) is an error.

An empty cell or ``nan`` marks a missing coordinate. Numbers are plain
decimals (``12``, ``-3.5e2``; not ``1_0``, hex or non-ASCII digits). Rows
with the wrong number of fields or non-numeric text raise
:class:`FileFormatError` naming the file, line and column. The file is UTF-8
(a leading BOM is dropped; other bytes are an error naming the line and byte
offset) and no line may exceed 1 MiB. Floats are written with ``repr``
(exact round trip).

COCO-style keypoint JSON
------------------------
Either a list of annotations (a COCO *results* file) or a dict with an
``"annotations"`` list (a COCO *ground-truth* file), UTF-8, at most 1 GiB,
nested at most 64 deep, integers of at most 40 digits; keypoint values must be
JSON numbers (not strings, booleans or null) and ``image_id`` an integer or a
string. Each annotation has
``keypoints`` = [x1, y1, v1, ..., x17, y17, v17] in COCO-17 order (nose,
left_eye, right_eye, left_ear, right_ear, left_shoulder, right_shoulder,
left_elbow, right_elbow, left_wrist, right_wrist, left_hip, right_hip,
left_knee, right_knee, left_ankle, right_ankle). ``v`` is the COCO visibility
(0 = not labelled, 1 = labelled but occluded, 2 = visible) in ground truth,
or a per-keypoint detector score in results files (next to the annotation's
``score``); either way it is the joint's ``confidence``, and ``v <= 0`` (or
``v < confidence_threshold``, by default 0.3) is missing. ``ids`` are ``str(image_id)``
(``""`` when absent).

Mapping COCO-17 onto the 14 joints:

* shoulders, elbows, wrists, hips, knees, ankles: copied directly;
* ``neck`` = midpoint of left and right shoulder; missing if either is
  missing; confidence = the smaller of the two;
* ``head_top`` = ``H + HEAD_TOP_FACTOR * (H - neck)`` with ``H`` the mean of
  the present head keypoints (nose, eyes, ears) and ``HEAD_TOP_FACTOR`` =
  0.8 (the top of the head lies about 0.8 times the neck-to-face distance
  beyond the face centre in adult proportions); missing if no head keypoint
  is present or the neck is missing; confidence = the smallest used;
* nose, eyes and ears are not part of the 14-joint layout.

If an annotation carries a ``"sparseedm"`` field (written by this module),
its ``neck`` and ``head_top`` are used instead of the derived ones, so a file
written here reads back to the same poses.

Writing COCO JSON with the ``meta`` of a COCO read writes the original
document back with, per annotation, the limb keypoints that were missing (or
below the threshold) and are now recovered filled in as ``[x, y, s]``, ``s``
the filled score (``filled_score``, default 0: below every threshold, so a
filled joint never reads as a detection); ``num_keypoints``, where present,
counts the keypoints with ``v > 0`` again; all other keypoints and fields
(``image_id``, ``score``, ``track_id``, ...) are untouched. Neck and head top
are not COCO keypoints, so they go into an extra field, with the 14-joint names
of the joints filled::

    "sparseedm": {"neck": [x, y] or null, "head_top": [x, y] or null,
                  "filled": ["left_wrist", ...]}

A reader reads the joints listed in ``filled`` as present (and flagged in
``KeypointSet.filled``), whatever their score; a null neck or head top as
missing (as written; left out, it is derived from the keypoints).

Without COCO ``meta`` a results-style list is written: one annotation per
pose with ``image_id`` (the id, as int when it is one), ``category_id`` 1,
the limb keypoints (``v = 2`` when present, the filled score when filled,
``[0, 0, 0]`` when missing), head keypoints ``[0, 0, 0]``, the ``"sparseedm"``
field, and ``track_id`` when the poses have tracks; with frames (tracks or
not) a PoseTrack document ``{"images": [{"id", "frame_id"}], "annotations"}``,
whose frames read back (without ``track_id``: frames only).

Filled flags
------------
Every format says which joints sparseedm filled (``filled=`` of
:func:`write_keypoints`; by default the joints a read had missing that the
poses now hold): CSV ``<joint>_filled`` columns (1/0, all 14 or none),
``.npz`` a ``filled`` (n, 14) bool array, COCO the ``"sparseedm"`` field, the
detector formats as :mod:`sparseedm.formats` describes.

Uncertainty
-----------
How sure each filled joint is (``RecoveryResult.uncertainty``, the radius in
pixels of the circle that holds the true joint 9 times in 10;
:mod:`sparseedm.uncertainty`), given as ``uncertainty=`` of
:func:`write_keypoints` and read back into ``KeypointSet.uncertainty``: CSV
``<joint>_uncertainty`` columns (all 14 or none; 0 for an observed joint,
empty for a refused pose), ``.npz`` an ``uncertainty`` (n, 14) float array,
COCO, OpenPose and MMPose ``"uncertainty"`` in the ``"sparseedm"`` object
(``{joint name: radius}`` of the joints whose radius is known, 0 for an
observed one; null for a refused pose). ``.npy`` and DeepLabCut
outputs of ``sparseedm recover`` hold it in the status sidecar. ``.npy`` and
DeepLabCut tables cannot hold them (:data:`FLAGS_IN_SIDECAR`): ``sparseedm
recover`` puts them in the ``<stem>.status.npz`` sidecar beside its output
(:func:`status_sidecar`), and :func:`read_keypoints` reads them back from
there, the flagged joints present whatever their score. A new DeepLabCut
table's rows are frames (one individual per track), not the poses in order:
its sidecar then holds the poses' ``tracks`` and ``frames`` too, and its rows
are matched to the table's by them.

PoseTrack, OpenPose, MMPose, DeepLabCut
---------------------------------------
COCO annotations with ``track_id`` fill ``tracks`` and ``frames``, those
without it ``frames`` when every image has a ``frame_id``
(:mod:`sparseedm.formats.posetrack`); the detector formats are read and
written by :mod:`sparseedm.formats`, which :func:`read_keypoints` and
:func:`write_keypoints` dispatch to.

Examples
--------
>>> import os, tempfile
>>> import numpy as np
>>> from sparseedm.keypoints import read_keypoints, write_keypoints
>>> poses = np.arange(2 * 14 * 2, dtype=float).reshape(2, 14, 2)
>>> poses[0, 7] = np.nan                       # left wrist of pose 0 missing
>>> path = os.path.join(tempfile.mkdtemp(), "poses.csv")
>>> _ = write_keypoints(path, poses, ids=["frame0", "frame1"])
>>> kps = read_keypoints(path)
>>> kps.poses.shape, int(kps.missing.sum()), kps.ids.tolist()
((2, 14, 2), 1, ['frame0', 'frame1'])
"""

from __future__ import annotations

import contextlib
import copy
import csv
import json
import math
import re
import warnings
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path

import numpy as np

from ._atomic import atomic_path, fit_name, is_stream, save_json, save_npy, save_npz
from ._safeio import MAX_LINE_BYTES, load_json, load_npy, load_npz, text_lines
from . import formats
from ._validation import (NUMBER_TEXT, SCORE, Interval, check_poses, frame_value,
                          validate_params)
from .exceptions import FileFormatError, ParameterError, PoseError
from .formats import posetrack
from .formats.deeplabcut import H5_SUFFIXES
from .formats._base import csv_cells, filled_likelihood, radii_object, read_radii, track_value
from .skeleton import JOINT_NAMES, SKELETON_14

__all__ = [
    "KeypointSet",
    "read_keypoints",
    "write_keypoints",
    "check_output_fits",
    "origin_joints",
    "FORMATS",
    "output_format",
    "COCO_KEYPOINTS",
    "COCO_TO_14",
    "HEAD_TOP_FACTOR",
    "FLAGS_IN_SIDECAR",
    "status_sidecar",
    "beside",
    "default_errors_path",
    "write_errors",
    "ERRORS_HEADER",
]

#: Formats, by the name ``format=`` accepts (the last three: :mod:`sparseedm.formats`).
FORMATS = ("npz", "npy", "csv", "coco") + formats.FORMATS
#: Per-row result arrays of :func:`sparseedm.batch.recover_file` an ``.npz`` keeps.
RESULT_FIELDS = ("status", "reason", "objective", "gap", "n_active", "edm_vectors",
                 "center", "scale", "outliers", "averaged")
#: The errors file's columns (:func:`write_errors`).
ERRORS_HEADER = ["row", "id", "status", "reason"]
EXTENSIONS = {".npz": "npz", ".npy": "npy", ".csv": "csv", ".json": "coco"}
#: formats whose files have no room for the filled flags: ``sparseedm recover``
#: writes them to the file's status sidecar (:func:`status_sidecar`), and
#: :func:`read_keypoints` reads them back from there
FLAGS_IN_SIDECAR = ("npy", "dlc")
#: CSV column suffixes of the joint columns
_SUFFIXES = ("x", "y", "conf", "filled", "uncertainty")
#: other suffixes detectors and tools give a joint's confidence column, read as ``_conf``
CONF_SYNONYMS = ("score", "confidence", "likelihood")
_CONF_SUFFIXES = ("conf",) + CONF_SYNONYMS

N_JOINTS = SKELETON_14.num_joints

#: The 17 COCO keypoints, in COCO order.
COCO_KEYPOINTS = (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
    "left_wrist", "right_wrist", "left_hip", "right_hip",
    "left_knee", "right_knee", "left_ankle", "right_ankle",
)
#: 14-joint index -> COCO-17 index, for the joints copied directly.
COCO_TO_14 = {
    SKELETON_14.index(name): COCO_KEYPOINTS.index(name)
    for name in JOINT_NAMES
    if name in COCO_KEYPOINTS
}
_NECK = SKELETON_14.index("neck")
_HEAD_TOP = SKELETON_14.index("head_top")
#: head_top = H + HEAD_TOP_FACTOR * (H - neck), H = mean of present head keypoints.
HEAD_TOP_FACTOR = formats.HEAD_TOP_FACTOR


@dataclass
class KeypointSet:
    """Keypoints of n poses in the 14-joint layout.

    Parameters
    ----------
    poses : ndarray, shape (n, 14, 2)
        Coordinates; NaN for every missing joint.
    missing : ndarray of bool, shape (n, 14)
        True where a joint is missing.
    confidence : ndarray, shape (n, 14), optional
        Per-joint detector confidence / COCO visibility.
    ids : ndarray of str, shape (n,), optional
        Image or frame id of each pose.
    tracks : ndarray, shape (n,), optional
        Track (person) of each pose, for video: poses sharing a value are one
        person over time. Any values numpy can compare (ints or strings).
    frames : ndarray of int, shape (n,), optional
        Frame number of each pose within its track (may skip and be unsorted).
    filled : ndarray of bool, shape (n, 14), optional
        Joints the file flags as filled by sparseedm (read as present).
    uncertainty : ndarray, shape (n, 14), optional
        The 90 % radius of each joint the file holds (pixels; 0 observed,
        NaN unknown), as ``sparseedm recover`` writes it.
    meta : dict
        Format details for writing the file back (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> kps = KeypointSet(np.zeros((3, 14, 2)), np.zeros((3, 14), bool))
    >>> len(kps)
    3
    """

    poses: np.ndarray
    missing: np.ndarray
    confidence: np.ndarray | None = None
    ids: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    tracks: np.ndarray | None = None
    frames: np.ndarray | None = None
    filled: np.ndarray | None = None
    uncertainty: np.ndarray | None = None

    def __post_init__(self):
        self.poses = np.asarray(self.poses, dtype=float)
        self.missing = np.asarray(self.missing, dtype=bool)
        n = len(self.poses)
        if self.poses.shape != (n, N_JOINTS, 2):
            raise PoseError(f"poses must have shape (n, 14, 2), got {self.poses.shape}")
        if self.missing.shape != (n, N_JOINTS):
            raise PoseError(f"missing must have shape ({n}, 14), got {self.missing.shape}")
        if self.confidence is not None:
            self.confidence = np.asarray(self.confidence, dtype=float)
            if self.confidence.shape != (n, N_JOINTS):
                raise PoseError(
                    f"confidence must have shape ({n}, 14), got {self.confidence.shape}"
                )
        if self.ids is not None:
            self.ids = np.asarray(self.ids, dtype=str)
            if self.ids.shape != (n,):
                raise PoseError(f"ids must have shape ({n},), got {self.ids.shape}")
        if self.tracks is not None:
            self.tracks = np.asarray(self.tracks)
            if self.tracks.shape != (n,):
                raise PoseError(f"tracks must have shape ({n},), got {self.tracks.shape}")
        if self.frames is not None:
            self.frames = np.asarray(self.frames)
            if self.frames.shape != (n,):
                raise PoseError(f"frames must have shape ({n},), got {self.frames.shape}")
        if self.filled is not None:
            self.filled = np.asarray(self.filled, dtype=bool)
            if self.filled.shape != (n, N_JOINTS):
                raise PoseError(f"filled must have shape ({n}, 14), got {self.filled.shape}")
        if self.uncertainty is not None:
            self.uncertainty = np.asarray(self.uncertainty, dtype=float)
            if self.uncertainty.shape != (n, N_JOINTS):
                raise PoseError(f"uncertainty must have shape ({n}, 14), "
                                f"got {self.uncertainty.shape}")

    def __len__(self) -> int:
        return len(self.poses)


# --------------------------------------------------------------------------
# shared helpers


def format_of(path: Path, format):
    if format is not None:
        fmt = {"json": "coco", "posetrack": "coco", "deeplabcut": "dlc"}.get(format, format)
        if fmt not in FORMATS:
            raise FileFormatError(
                f"{path}: unknown keypoint format {format!r}; use one of {FORMATS}"
            )
        return fmt
    detected = formats.detect(path)
    if detected is not None:
        return detected
    ext = path.suffix.lower()
    if ext not in EXTENSIONS:
        raise FileFormatError(
            f"{path}: cannot tell the keypoint format from the extension {ext!r}; "
            f"use {', '.join(EXTENSIONS)}, .h5 (DeepLabCut), a folder (OpenPose) or "
            f"pass format= (--input-format on the command line; one of {FORMATS})"
        )
    return EXTENSIONS[ext]


def output_format(path, format=None, read_format=None):
    """The format a file written at `path` gets: `format` if given; else the
    format it was read in (`read_format`) when the extension suits it
    (OpenPose and MMPose: ``.json``, or none for a folder; DeepLabCut
    ``.csv`` / ``.h5``); else from the extension (``.h5`` is DeepLabCut).

    >>> output_format(Path("out.json"), read_format="mmpose")
    'mmpose'
    >>> output_format(Path("out.json"), read_format="csv")
    'coco'

    Parameters
    ----------
    path : str or path-like
        The output.
    format : str, optional
        The format asked for.
    read_format : str, optional
        The input's format.

    Returns
    -------
    str
        The format name.
    """
    path = Path(path)
    if format is not None:
        return format_of(path, format)
    ext = path.suffix.lower()
    suits = {"openpose": ("", ".json"), "mmpose": ("", ".json"), "alphapose": (".json",),
             "dlc": (".csv",) + H5_SUFFIXES}
    if ext in suits.get(read_format, ()):
        return read_format
    if ext in H5_SUFFIXES:
        return "dlc"
    if ext not in EXTENSIONS:
        raise FileFormatError(
            f"{path}: cannot tell the keypoint format from the extension {ext!r}; "
            f"use {', '.join(EXTENSIONS)}, .h5 or pass format= (--input-format on the "
            f"command line; one of {FORMATS})")
    return EXTENSIONS[ext]


def _joint_count_error(where, n_joints):
    return FileFormatError(
        f"{where} has {n_joints} joints; sparseedm uses the 14-joint layout "
        f"({', '.join(JOINT_NAMES)})"
        + ("; COCO-17 keypoints are read from COCO JSON files" if n_joints == 17 else "")
    )


def origin_joints(poses, missing=None):
    """Joints at exactly (0, 0) in pixel poses: the mark many tools write for a
    joint they did not find.

    A pose is in pixels when none of its observed coordinates is negative (a
    pose centred on a joint has negative coordinates, and its joint at the
    origin stays observed).

    Parameters
    ----------
    poses : array_like, shape (n, 14, 2)
    missing : array_like of bool, shape (n, 14), optional
        The joints already missing; default the NaN ones (as ``recover(poses)``
        reads them).

    Returns
    -------
    ndarray of bool, shape (n, 14)
        The observed joints at (0, 0) of poses with no negative coordinate.

    Examples
    --------
    >>> poses = np.array([[[0.0, 0.0], [120.0, 80.0]], [[0.0, 0.0], [-3.0, 5.0]]])
    >>> origin_joints(poses, np.zeros((2, 2), bool))
    array([[ True, False],
           [False, False]])
    """
    poses = np.asarray(poses, dtype=float)
    missing = (np.isnan(poses).any(axis=-1) if missing is None
               else np.asarray(missing, dtype=bool))
    with np.errstate(invalid="ignore"):
        seen = ~missing[..., None] & np.isfinite(poses)
        in_pixels = ~(seen & (poses < 0)).any(axis=(1, 2))
        return (poses == 0).all(axis=-1) & ~missing & in_pixels[:, None]


def _refuse_origin_joints(poses, missing, filled, where):
    """A writer's check: an observed joint at exactly (0, 0) of a pixel pose
    would be read back as missing (:func:`origin_joints`; a joint flagged
    filled reads back as written)."""
    origin = origin_joints(poses, missing) & ~filled
    if origin.any():
        i, j = np.argwhere(origin)[0]
        raise FileFormatError(
            f"{where}: pose {i}, joint {JOINT_NAMES[j]} is at exactly (0, 0), which "
            f"sparseedm reads as a missing joint ({int(origin.sum())} such joint(s)); "
            "mark them missing (NaN or missing=) or give their true coordinates")


def finish_missing(poses, missing, confidence, threshold, where=None, filled=None,
                   origin=None):
    """Combine every missing source, blank the missing joints.

    With `origin` (default: when `where` is given; the CSV and NumPy formats,
    whose missing joints have no score of their own), joints at exactly (0, 0)
    in a pixel pose (:func:`origin_joints`) are missing too, unless the file
    flags them `filled` (kept as written); with `where` (the file's name), a
    warning says how many.
    """
    missing = missing | np.isnan(poses).any(axis=-1)
    if confidence is not None:
        with np.errstate(invalid="ignore"):
            missing = missing | ~(confidence > 0)
            if threshold is not None:
                missing = missing | (confidence < threshold)
    if origin is None:
        origin = where is not None
    origin = origin_joints(poses, missing) if origin else None
    if origin is not None and filled is not None:
        origin &= ~filled
    if origin is not None and origin.any():
        missing = missing | origin
    if origin is not None and origin.any() and where is not None:
        warnings.warn(
            f"{where}: read {int(origin.sum())} joint(s) at exactly (0, 0) in "
            f"{int(origin.any(axis=1).sum())} pose(s) as missing (a tool's mark for a "
            "joint it did not find); leave a missing joint's cells empty or NaN to "
            "say so directly", UserWarning, stacklevel=2)
    poses = np.where(missing[..., None], np.nan, poses)
    return poses, missing


def _keep_filled(raw, poses, missing, filled):
    """Joints a file flags as filled by sparseedm (or holds in its own object):
    present with the file's coordinates, whatever their score (a filled score
    is below any threshold)."""
    if filled is None:
        return poses, missing
    keep = filled & np.isfinite(raw).all(axis=-1)
    return np.where(keep[..., None], raw, poses), missing & ~keep


def _check_pose_array(poses, where):
    poses = np.asarray(poses, dtype=float)
    if poses.ndim == 2:
        poses = poses[None]
    if poses.ndim != 3 or poses.shape[-1] not in (2, 3):
        raise FileFormatError(
            f"{where}: poses must have shape (n, 14, 2), got {poses.shape}"
        )
    if poses.shape[1] != N_JOINTS:
        raise _joint_count_error(where, poses.shape[1])
    # an infinite coordinate is a bad row, not a bad file: it is read as it is and
    # refused by recover()/lift() (status invalid_coordinates), the other rows go on
    return poses


def _optional(arr, n, name, where, dtype):
    if arr is None:
        return None
    arr = np.asarray(arr, dtype=dtype)
    expected = (n,) if name in ("ids", "frames") else (n, N_JOINTS)
    if arr.shape != expected:
        raise FileFormatError(
            f"{where}: {name} must have shape {expected}, got {arr.shape}"
        )
    return arr


# --------------------------------------------------------------------------
# reading


def read_keypoints(path, *, format=None, confidence_threshold=None, joint_map=None):
    """Read 2D keypoints into a :class:`KeypointSet`.

    Parameters
    ----------
    path : str or path-like
        A file, or a folder of OpenPose frame files or MMPose per-image files.
    format : {"npz", "npy", "csv", "coco", "openpose", "mmpose", "alphapose", "dlc"}, optional
        Default: told from the path (:func:`sparseedm.formats.detect`: a
        folder is OpenPose or MMPose by its files' content, ``.h5``
        DeepLabCut, a ``.json`` by its content, else the extension; ``.json``
        is COCO).
    confidence_threshold : float, optional
        Joints whose confidence is below it are missing (joints with a
        confidence <= 0 are always missing). Default: the format's,
        :data:`sparseedm.formats.DEFAULT_THRESHOLDS` (DeepLabCut 0.6, MMPose,
        AlphaPose and COCO 0.3, OpenPose 0.05, npz/npy/CSV 0).
    joint_map : str or path-like, optional
        DeepLabCut only: the joints map file (:mod:`sparseedm.formats.deeplabcut`).

    Returns
    -------
    KeypointSet

    Raises
    ------
    FileFormatError
        Malformed, truncated or unsafe file; the message names the file and
        the row or annotation.

    Examples
    --------
    >>> import json, os, tempfile
    >>> kp = [0.0] * 51
    >>> for k, (x, y) in enumerate([(10, 10), (9, 9), (11, 9), (8, 10), (12, 10),
    ...                             (6, 20), (14, 20)]):
    ...     kp[3 * k: 3 * k + 3] = [x, y, 2]
    >>> path = os.path.join(tempfile.mkdtemp(), "ann.json")
    >>> with open(path, "w") as f:
    ...     json.dump([{"image_id": 7, "keypoints": kp, "score": 0.9}], f)
    >>> kps = read_keypoints(path)
    >>> kps.ids.tolist(), kps.poses[0, 1].tolist()       # neck: shoulder midpoint
    (['7'], [10.0, 20.0])
    >>> kps.poses[0, 0].round(2).tolist()                # head_top: above the face
    [10.0, 1.28]
    >>> int(kps.missing[0].sum())                        # no arms or legs labelled
    10
    """
    validate_params("read_keypoints", dict(
        path=path, confidence_threshold=confidence_threshold, joint_map=joint_map),
        _READ_PARAMS)
    path = Path(path)
    fmt = format_of(path, format)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    check_joint_map(path, fmt, joint_map)
    if confidence_threshold is None:
        confidence_threshold = formats.default_threshold(fmt)
    if fmt in formats.FORMATS:
        parsed = formats.read(fmt, path, joint_map=joint_map)
        if fmt in FLAGS_IN_SIDECAR:
            keys = (parsed.tracks, parsed.frames)
            flags = sidecar_flags(path, len(parsed.poses), parsed.ids, keys)
            if flags is not None:
                parsed.filled = flags if parsed.filled is None else parsed.filled | flags
        kps = _from_parsed(parsed, confidence_threshold)
        if fmt in FLAGS_IN_SIDECAR:
            kps.uncertainty = sidecar_uncertainty(path, len(kps), keys)
    else:
        reader = {"npz": _read_npz, "npy": _read_npy, "csv": _read_csv, "coco": _read_coco}
        kps = reader[fmt](path, confidence_threshold)
    kps.meta["format"] = fmt
    kps.meta["confidence_threshold"] = confidence_threshold
    kps.meta.setdefault("read_missing", kps.missing.copy())
    kps.meta["read_filled"] = kps.filled
    return kps


def check_joint_map(path, fmt, joint_map):
    """Refuse a joints map given with an input that is not a DeepLabCut table
    (its joints are named by the format itself: the map would be ignored).

    >>> check_joint_map("poses.csv", "csv", "map.json")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: poses.csv: --joint-map (joint_map=) applies to DeepLabCut inputs only; this input's format is csv
    """
    if joint_map is not None and fmt != "dlc":
        raise ParameterError(f"{path}: --joint-map (joint_map=) applies to DeepLabCut inputs "
                             f"only; this input's format is {fmt}")


def _from_parsed(parsed, threshold):
    """A KeypointSet from a :class:`sparseedm.formats.Parsed`: thresholds applied,
    the joints the file flags as filled kept present."""
    poses, missing = finish_missing(parsed.poses, ~parsed.present, parsed.confidence, threshold)
    kept = [m for m in (parsed.filled, parsed.stored) if m is not None]
    poses, missing = _keep_filled(parsed.poses, poses, missing,
                                  np.logical_or.reduce(kept) if kept else None)
    parsed.meta.update(read_missing=missing)
    return KeypointSet(poses, missing, parsed.confidence, parsed.ids, parsed.meta,
                       tracks=parsed.tracks, frames=parsed.frames, filled=parsed.filled,
                       uncertainty=parsed.uncertainty)


_READ_PARAMS = {
    "path": ["path"],
    "confidence_threshold": [Interval(Real, None, None), None],
    "joint_map": ["path", None],
}
_ZIP_MAGIC = b"PK\x03\x04"


def load_single_npy(path, mmap_mode=None):
    """One ``.npy`` array, bounded (:func:`sparseedm._safeio.load_npy`): pickles
    refused, every failure a FileFormatError."""
    with open(path, "rb") as f:
        if f.read(4) == _ZIP_MAGIC:
            raise FileFormatError(f"{path}: expected a single .npy array, found an .npz archive")
    return load_npy(path, mmap_mode=mmap_mode)


def _kind(arr, kinds, path, name, what):
    if arr.dtype.kind not in kinds:
        raise FileFormatError(f"{path}: {name!r} must hold {what}, got dtype {arr.dtype}")


def _read_npz(path, threshold):
    with open(path, "rb") as f:
        if f.read(4) != _ZIP_MAGIC:
            raise FileFormatError(f"{path}: expected an .npz archive, found no zip archive "
                                  "(a single .npy array?)")
    known = ("poses", "missing", "confidence", "ids", "filled", "uncertainty") + TIME_KEYS \
        + RESULT_FIELDS
    arrays, names = load_npz(path, known)
    if "poses" not in arrays:
        raise FileFormatError(
            f"{path}: no 'poses' array (found {sorted(names)}); a "
            "keypoint .npz needs 'poses' (n, 14, 2)"
        )
    poses = arrays.pop("poses")
    _kind(poses, "fiu", path, "poses", "real numbers")
    poses = _check_pose_array(poses, f"{path}: 'poses'")
    if poses.shape[-1] != 2:
        raise FileFormatError(
            f"{path}: 'poses' must have shape (n, 14, 2), got {poses.shape}; "
            "put confidences in a separate 'confidence' array"
        )
    n = len(poses)
    missing, filled = (_flags(arrays.pop(key, None), n, key, path)
                       for key in ("missing", "filled"))
    confidence = arrays.pop("confidence", None)
    if confidence is not None:
        _kind(confidence, "fiu", path, "confidence", "real numbers")
        confidence = _optional(confidence, n, "confidence", path, float)
    uncertainty = _radii(arrays.pop("uncertainty", None), n, path)
    ids = arrays.pop("ids", None)
    if ids is not None:
        ids = _optional(_ids_text(ids, path), n, "ids", path, str)
    tracks, frames, time_meta = _npz_time(arrays, n, path)
    # result fields are kept only as what they claim to be: plain values, one per row
    odd = [k for k, a in arrays.items()
           if a.dtype.kind not in "fiuU" or a.ndim < 1 or len(a) != n]
    for key in odd:
        del arrays[key]
    if missing is None:
        missing = np.zeros((n, N_JOINTS), dtype=bool)
    raw = poses
    poses, missing = finish_missing(poses, missing, confidence, threshold, where=path,
                                    filled=filled)
    poses, missing = _keep_filled(raw, poses, missing, filled)
    ignored = sorted(set(names) - set(arrays) - {"poses", "missing", "confidence", "ids",
                                                 "filled", "uncertainty"} - set(TIME_KEYS))
    return KeypointSet(poses, missing, confidence, ids,
                       {"npz_extra": arrays, "npz_ignored": ignored, **time_meta},
                       tracks=tracks, frames=frames, filled=filled, uncertainty=uncertainty)


def _radii(arr, n, where):
    """An (n, 14) uncertainty array (pixels, >= 0 or NaN), or None; a negative or
    infinite radius is refused."""
    if arr is None:
        return None
    arr = np.asarray(arr)
    _kind(arr, "fiu", where, "uncertainty", "real numbers")
    arr = _optional(arr, n, "uncertainty", where, float)
    if (arr < 0).any() or np.isinf(arr).any():
        raise FileFormatError(f"{where}: 'uncertainty' must hold radii >= 0 (NaN: unknown)")
    return arr


#: .npz keys of a pose's track and frame (``clips``: as ``dataset build`` writes)
TIME_KEYS = ("tracks", "clips", "frames")


def _npz_time(arrays, n, path):
    """``tracks`` (or ``clips``) and ``frames`` of `arrays`, checked (n,), and
    the meta that writes them back under the names read (they stay in
    `arrays`, the extra arrays written back, as CSV keeps its columns)."""
    key = "tracks" if "tracks" in arrays else "clips"
    tracks, frames = arrays.get(key), arrays.get("frames")
    for name, arr in ((key, tracks), ("frames", frames)):
        if arr is not None and arr.shape != (n,):
            raise FileFormatError(f"{path}: {name!r} must have shape ({n},), got {arr.shape}")
    if tracks is not None:
        tracks = _ids_text(tracks, path) if tracks.dtype.kind in "SU" else tracks
        _kind(tracks, "Uiu", path, key, "text or integers")
    if frames is not None:
        _kind(frames, "fiu", path, "frames", "numbers")
    return tracks, frames, ({"track_key": key} if tracks is not None else {})


def _flags(arr, n, name, path):
    """An (n, 14) boolean array of an .npz (``missing``, ``filled``), or None."""
    if arr is None:
        return None
    _kind(arr, "biu", path, name, "booleans (or 0/1)")
    if arr.dtype.kind != "b" and not np.isin(arr, (0, 1)).all():
        raise FileFormatError(f"{path}: {name!r} must hold booleans (or 0/1)")
    return _optional(arr, n, name, path, bool)


def _ids_text(ids, path):
    """ids as str: text as is, integers formatted, bytes decoded as UTF-8."""
    if ids.dtype.kind == "S":
        try:
            return np.array([b.decode("utf-8") for b in ids.ravel()], dtype=str).reshape(ids.shape)
        except UnicodeDecodeError as exc:
            raise FileFormatError(f"{path}: 'ids' holds bytes that are not UTF-8 text "
                                  f"({exc.reason}); store ids as str") from None
    _kind(ids, "Uiu", path, "ids", "text or integers")
    return ids.astype(str)


def npy_confidence(block, where, first_row=0):
    """The third column of an (n, 14, 3) pose array: confidences in [0, 1].

    Anything else (x, y, z poses: z in metres or pixels, negative...) is
    refused, naming the pose and joint: it would silently hide joints.
    """
    conf = np.asarray(block[..., 2], dtype=float)
    bad = np.isfinite(conf) & ((conf < 0) | (conf > 1))
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise FileFormatError(
            f"{where}: an (n, {block.shape[1]}, 3) array is x, y, confidence, but pose "
            f"{first_row + i}, joint {j} has confidence {conf[i, j]:g} (confidences lie in "
            "[0, 1]); for x, y, z poses save poses[..., :2]")
    return conf.copy()


def _read_npy(path, threshold):
    arr = load_single_npy(path)
    _kind(arr, "fiu", path, "the array", "real numbers")
    arr = _check_pose_array(arr, str(path))
    poses = arr[..., :2]
    confidence = npy_confidence(arr, str(path)) if arr.shape[-1] == 3 else None
    missing = np.zeros(poses.shape[:2], dtype=bool)
    filled = sidecar_flags(path, len(poses), None)
    poses, missing = finish_missing(poses, missing, confidence, threshold, where=path,
                                    filled=filled)
    poses, missing = _keep_filled(arr[..., :2], poses, missing, filled)
    return KeypointSet(poses, missing, confidence, None, {}, filled=filled,
                       uncertainty=sidecar_uncertainty(path, len(poses)))


def beside(path, ending) -> Path:
    """``<stem><ending>`` beside `path` (in the current folder when `path` is a
    device or a pipe, such as ``/dev/stdout``).

    Parameters
    ----------
    path : str or path-like
        The file the new name goes beside.
    ending : str
        What replaces `path`'s suffix, e.g. ``".status.npz"``.

    Returns
    -------
    Path
        The sibling path. A name over 255 bytes keeps the stem's first 120
        bytes and a hash of the whole stem before `ending`.

    Examples
    --------
    >>> str(beside("out/poses.csv", ".status.npz"))
    'out/poses.status.npz'
    """
    path = Path(path)
    name = fit_name(path.stem, ending)  # within 255 bytes, by the temporaries' rule
    return Path(name) if is_stream(path) else path.with_name(name)


def default_errors_path(output) -> Path:
    """``<output stem>.errors.csv`` beside `output` (in the current folder when
    `output` is a device or a pipe, such as ``/dev/null``); when that name would
    pass 255 bytes, the stem's first 120 bytes and a hash of the whole stem
    (:func:`beside`), so that any output name file systems
    take has an errors file name they take too.

    Parameters
    ----------
    output : str or path-like
        The output file.

    Returns
    -------
    Path
        Where the refused rows are listed.
    """
    return beside(output, ".errors.csv")


def write_errors(path, refused, ids, status, reason, skipped=(), rows=None):
    """Write the errors file of ``recover``, ``lift`` and ``fit``: CSV with the
    columns :data:`ERRORS_HEADER`, a row per refused pose (row, id, status,
    reason), then a row per input file that could not be read at all (no row,
    the file as id, status ``unreadable_file``); an errors file an earlier run
    left at `path` is removed when there is nothing to list.

    Parameters
    ----------
    path : str or path-like
        Where to write (atomically).
    refused : ndarray of bool (n,)
        The poses to list.
    ids : array_like of str (n,) or None
        Each pose's id (image or frame), or None: the column left empty.
    status, reason : array_like of str (n,)
        Each pose's status and why.
    skipped : sequence of (str, str), optional
        ``(file, why)`` for each file of a folder of frames not read.
    rows : array_like of int (n,), optional
        Each pose's row in the input, for poses that are some of its rows
        (default their positions).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "out.errors.csv"
    >>> write_errors(path, np.array([False, True]), None, ["complete", "degenerate"],
    ...              ["", "all joints coincide"], [("f9.json", "invalid JSON")])
    >>> print(path.read_text().strip())
    row,id,status,reason
    1,,degenerate,all joints coincide
    ,f9.json,unreadable_file,invalid JSON
    """
    if not refused.any() and not len(skipped):
        _remove_stale_errors(path)
        return
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(ERRORS_HEADER)
            for r in np.flatnonzero(refused):
                w.writerow([int(r if rows is None else rows[r]), "" if ids is None else ids[r],
                            status[r], reason[r]])
            for name, why in skipped:
                w.writerow(["", name, "unreadable_file", why])


def _remove_stale_errors(path):
    """Remove an errors file an earlier run left at `path` (only if it is one)."""
    path = Path(path)
    if not path.is_file():
        return
    with contextlib.suppress(OSError, UnicodeDecodeError):
        with open(path, encoding="utf-8") as f:
            first = f.readline().strip()
        if first == ",".join(ERRORS_HEADER):
            path.unlink()


def status_sidecar(path) -> Path:
    """The status sidecar of a keypoint file, ``<stem>.status.npz`` beside it:
    ``sparseedm recover`` writes there the per-row status and, for the
    :data:`FLAGS_IN_SIDECAR` formats, the ``filled`` (n, 14) flags.

    Parameters
    ----------
    path : str or path-like
        The keypoint file.

    Returns
    -------
    Path
        Where its sidecar is (whether or not it exists), as :func:`beside`
        names it.
    """
    return beside(path, ".status.npz")


def sidecar_flags(path, n, ids, keys=None):
    """The filled flags (n, 14) of a :data:`FLAGS_IN_SIDECAR` file, read from its
    status sidecar; None without one. A sidecar that is not this file's (another
    row count, other ids) or cannot be read is ignored with a warning naming it.
    A sidecar holding ``frames`` (and ``tracks``) has its rows matched to the
    file's poses by track and frame (`keys`, the file's (tracks, frames)): a
    DeepLabCut table's rows are frames, and a pose of no sidecar row has none
    filled."""
    side = status_sidecar(path)
    if is_stream(path) or not side.is_file():
        return None
    try:
        arrays, _ = load_npz(side, ("filled", "ids", "tracks", "frames"), what=f"{side}:")
    except (FileFormatError, OSError) as exc:
        warnings.warn(f"ignored {side} (the filled flags of {path}): {exc}", stacklevel=4)
        return None
    flags, side_ids = arrays.get("filled"), arrays.get("ids")
    rows = _sidecar_rows(arrays, keys)
    m = n if rows is None else len(arrays["frames"])
    why = None
    if flags is None or flags.dtype != bool or flags.shape != (m, N_JOINTS):
        why = f"no 'filled' (bool, {m} x {N_JOINTS}) array for its {m} poses"
    elif rows is None and side_ids is not None and ids is not None and not np.array_equal(
            np.asarray(side_ids).astype(str), np.asarray(ids).astype(str)):
        why = "its ids are not the file's"
    if why is not None:
        warnings.warn(f"ignored {side} (the filled flags of {path}): {why}", stacklevel=4)
        return None
    return flags if rows is None else np.where((rows >= 0)[:, None], flags[rows], False)


def _sidecar_rows(arrays, keys):
    """The sidecar's row of each of the file's poses (-1: none) when the sidecar
    keys its rows by track and frame and the file has frames; else None (in order)."""
    frames = arrays.get("frames")
    if frames is None or keys is None or keys[1] is None:
        return None
    tracks = arrays.get("tracks")
    tracks = np.zeros(len(frames), dtype=np.int64) if tracks is None else tracks
    row = {(str(t), int(f)): k for k, (t, f) in enumerate(zip(tracks.tolist(),
                                                              frames.tolist()))}
    file_tracks = np.zeros(len(keys[1]), dtype=np.int64) if keys[0] is None else keys[0]
    return np.asarray([row.get((str(t), int(f)), -1)
                       for t, f in zip(file_tracks.tolist(), keys[1].tolist())], dtype=int)


def sidecar_uncertainty(path, n, keys=None):
    """The 90 % radii (n, 14) a :data:`FLAGS_IN_SIDECAR` file's status sidecar
    holds (``sparseedm recover`` writes them there); None without them (a
    sidecar that cannot be read is reported by :func:`sidecar_flags`). `keys`:
    as :func:`sidecar_flags` (a pose of no sidecar row: NaN, unknown)."""
    side = status_sidecar(path)
    if is_stream(path) or not side.is_file():
        return None
    try:
        arrays, _ = load_npz(side, ("uncertainty", "tracks", "frames"), what=f"{side}:")
        rows = _sidecar_rows(arrays, keys)
        if rows is None:
            return _radii(arrays.get("uncertainty"), n, str(side))
        radii = _radii(arrays.get("uncertainty"), len(arrays["frames"]), str(side))
        return None if radii is None else \
            np.where((rows >= 0)[:, None], radii[rows], np.nan)
    except (FileFormatError, OSError, ValueError, TypeError):
        return None


#: a plain decimal number (or nan/inf): not Python's extras ("1_0", full-width digits)
_NUMBER = NUMBER_TEXT


def _parse_float(text, path, line, column):
    text = text.strip()
    if text == "":
        return math.nan
    try:
        if not _NUMBER.fullmatch(text):
            raise ValueError(text)
        value = float(text)
    except ValueError:
        raise FileFormatError(
            f"{path}, line {line}, column {column!r}: {text!r} is not a number"
        ) from None
    return value  # inf: a bad row, refused by recover()/lift(), not a bad file


#: every character a plain number, nan/inf/infinity or a blank cell may hold: a
#: string of only these that float() reads is one _NUMBER accepts (no "1_0", no
#: non-ASCII digits: those characters are not here)
_NUMBER_CHARS = frozenset("0123456789+-.eEnNaAiIfFtTyY \t\n\r\f\v")


def _float_columns(rows, cols, path, header):
    """The cells of columns `cols` of every row, as floats (n, len(cols)).

    One check of the characters of all the cells and one conversion when they
    are all plain numbers or blank; otherwise cell by cell with
    :func:`_parse_float`, which names the first bad one.
    """
    cells = [fields[c] for _, fields in rows for c in cols]
    if set("".join(cells)) <= _NUMBER_CHARS:
        try:
            return np.array([float(x) if x.strip() else math.nan for x in cells],
                            dtype=float).reshape(len(rows), len(cols))
        except ValueError:
            pass  # e.g. "1e" or "+-1": the per-cell check words it
    return np.array([[_parse_float(fields[c], path, line, header[c]) for c in cols]
                     for line, fields in rows], dtype=float).reshape(len(rows), len(cols))


#: rows of a CSV parsed into arrays at a time: the text of a block is dropped
#: once its numbers are read, so a file of millions of rows needs the arrays'
#: memory, not its cells' (about 4.5 GB of Python strings for a million rows)
CSV_BLOCK_ROWS = 1 << 16


def _csv_rows(reader, header, path):
    """Blocks of at most :data:`CSV_BLOCK_ROWS` ``(line, fields)`` pairs, blank
    lines skipped, a row of the wrong width refused by its line."""
    rows = []
    try:
        for fields in reader:
            if not fields or all(not x.strip() for x in fields) and len(fields) <= 1:
                continue  # blank line
            if len(fields) != len(header):
                raise FileFormatError(
                    f"{path}, line {reader.line_num}: {len(fields)} fields, "
                    f"the header has {len(header)}"
                )
            rows.append((reader.line_num, fields))
            if len(rows) == CSV_BLOCK_ROWS:
                yield rows
                rows = []
    except csv.Error as exc:
        raise FileFormatError(f"{path}, line {reader.line_num}: {exc}") from None
    if rows:
        yield rows


def _csv_block(rows, columns, path, header):
    """One block's poses (m, 14, 2), confidences, filled flags, ids and extra cells."""
    m = len(rows)
    poses = np.full((m, N_JOINTS, 2), np.nan)
    xy = _float_columns(rows, list(columns["xy"].values()), path, header)
    for k, (j, axis) in enumerate(columns["xy"]):
        poses[:, j, axis] = xy[:, k]
    conf = None
    if columns["conf"]:
        conf = np.full((m, N_JOINTS), np.nan)
        conf[:, list(columns["conf"])] = _float_columns(rows, list(columns["conf"].values()),
                                                        path, header)
    filled = None
    if columns["filled"]:
        filled = np.zeros((m, N_JOINTS), dtype=bool)
        for r, (line, fields) in enumerate(rows):
            for j, c in columns["filled"].items():
                filled[r, j] = _parse_flag(fields[c], path, line, header[c])
    radii = None
    if columns["uncertainty"]:
        radii = np.full((m, N_JOINTS), np.nan)
        radii[:, list(columns["uncertainty"])] = _float_columns(
            rows, list(columns["uncertainty"].values()), path, header)
    ids = [fields[columns["id"]].strip() for _, fields in rows] if "id" in columns else None
    extra = {name: [fields[c] for _, fields in rows] for name, c in columns["extra"].items()}
    return poses, conf, filled, ids, extra, radii


def _joined(parts, shape, dtype):
    return np.concatenate(parts) if parts else np.zeros(shape, dtype=dtype)


def _read_csv(path, threshold):
    # a field may fill a line (text_lines caps those); the csv module's own cap is 128 KiB
    csv.field_size_limit(max(csv.field_size_limit(), MAX_LINE_BYTES))
    lines = (text for _, text in text_lines(path))
    reader = csv.reader(lines)
    try:
        header = next(reader)
    except StopIteration:
        raise FileFormatError(f"{path}: empty file; expected a header row") from None
    except csv.Error as exc:
        raise FileFormatError(f"{path}, line 1: {exc}") from None
    header = [h.strip() for h in header]
    columns = _csv_columns(header, path)
    blocks = [_csv_block(rows, columns, path, header)
              for rows in _csv_rows(reader, header, path)]
    poses = _joined([b[0] for b in blocks], (0, N_JOINTS, 2), float)
    n = len(poses)
    conf = _joined([b[1] for b in blocks], (0, N_JOINTS), float) if columns["conf"] else None
    filled = _joined([b[2] for b in blocks], (0, N_JOINTS), bool) if columns["filled"] else None
    ids = [i for b in blocks for i in b[3]] if "id" in columns else None
    extra = {name: [v for b in blocks for v in b[4][name]] for name in columns["extra"]}
    radii = _radii(_joined([b[5] for b in blocks], (0, N_JOINTS), float), n, path) \
        if columns["uncertainty"] else None
    del blocks
    missing = np.zeros((n, N_JOINTS), dtype=bool)
    raw = poses
    poses, missing = finish_missing(poses, missing, conf, threshold, where=path, filled=filled)
    poses, missing = _keep_filled(raw, poses, missing, filled)
    ids = None if ids is None else np.asarray(ids, dtype=str).reshape(n)
    tracks = np.asarray([t.strip() for t in extra["track"]], dtype=str).reshape(n) \
        if "track" in extra else None
    frames = _frame_cells(extra["frame"], n) if "frame" in extra else None
    return KeypointSet(poses, missing, conf, ids, {"extra_columns": extra},
                       tracks=tracks, frames=frames, filled=filled, uncertainty=radii)


def _frame_cells(cells, n):
    """A CSV ``frame`` column: int64 when every cell is an integer, else the
    cells as text (the recovery refuses the odd rows by name, by the one
    frame-number rule, :func:`sparseedm._validation.frame_value`)."""
    text = [c.strip() for c in cells]
    if all(re.fullmatch(r"[+-]?[0-9]{1,18}", c) for c in text):  # ASCII digits only
        return np.asarray([int(c) for c in text], dtype=np.int64).reshape(n)
    return np.asarray(text, dtype=object).reshape(n)


def _parse_flag(text, path, line, column):
    text = text.strip()
    if text not in ("", "0", "1"):
        raise FileFormatError(f"{path}, line {line}, column {column!r}: {text[:20]!r} is "
                              "not a filled flag (1, 0 or empty)")
    return text == "1"


def _warn_unread_joint_columns(extra, path):
    """Warn of a column per joint with a suffix the reader does not know (e.g.
    ``<joint>_visibility``): kept as extra columns, never read as scores."""
    by_suffix = {}
    for name in extra:
        stem, _, suffix = name.rpartition("_")
        if stem in JOINT_NAMES:
            by_suffix.setdefault(suffix, set()).add(stem)
    for suffix, stems in by_suffix.items():
        if len(stems) == N_JOINTS:
            warnings.warn(
                f"{path}: the <joint>_{suffix} columns are kept as they are, not read; "
                "if they are the joints' confidences, name them <joint>_conf (or "
                + ", ".join("_" + k for k in CONF_SYNONYMS) + ")", UserWarning, stacklevel=4)


def _csv_columns(header, path):
    """Map header names to column indices, with clear errors."""
    xy, conf, filled, radii, extra = {}, {}, {}, {}, {}
    out = {"xy": xy, "conf": conf, "filled": filled, "uncertainty": radii, "extra": extra}
    seen, conf_suffixes = set(), set()
    for c, name in enumerate(header):
        if name in seen:
            raise FileFormatError(f"{path}, line 1: column {name!r} appears twice")
        seen.add(name)
        if name == "id":
            out["id"] = c
            continue
        stem, _, suffix = name.rpartition("_")
        if stem in JOINT_NAMES and suffix in _CONF_SUFFIXES:  # left_wrist_score: a conf
            conf_suffixes.add(suffix)
            conf[JOINT_NAMES.index(stem)] = c
        elif stem and suffix in _SUFFIXES:
            if stem not in JOINT_NAMES:
                raise FileFormatError(
                    f"{path}, line 1: column {name!r} names an unknown joint "
                    f"{stem!r}; joints: {', '.join(JOINT_NAMES)}"
                )
            j = JOINT_NAMES.index(stem)
            if suffix == "filled":
                filled[j] = c
            elif suffix == "uncertainty":
                radii[j] = c
            else:
                xy[(j, "xy".index(suffix))] = c
        else:
            extra[name] = c
    absent = [
        f"{JOINT_NAMES[j]}_{'xy'[a]}"
        for j in range(N_JOINTS) for a in (0, 1) if (j, a) not in xy
    ]
    if absent:
        shown = ", ".join(repr(h) for h in header[:6]) + (", ..." if len(header) > 6 else "")
        raise FileFormatError(
            f"{path}, line 1: missing column(s) {', '.join(absent)}; a keypoint CSV "
            f"needs <joint>_x and <joint>_y for all 14 joints (its columns: {shown})"
        )
    _warn_unread_joint_columns(extra, path)
    if len(conf_suffixes) > 1:
        raise FileFormatError(
            f"{path}, line 1: the confidence columns mix the suffixes "
            f"{', '.join('_' + k for k in sorted(conf_suffixes))}; use one for all 14 "
            "joints (_conf, or one of " + ", ".join("_" + k for k in CONF_SYNONYMS) + ")")
    for kind, cols in ((next(iter(conf_suffixes), "conf"), conf), ("filled", filled),
                       ("uncertainty", radii)):
        if cols and len(cols) != N_JOINTS:
            absent = [f"{JOINT_NAMES[j]}_{kind}" for j in range(N_JOINTS) if j not in cols]
            raise FileFormatError(
                f"{path}, line 1: <joint>_{kind} columns must be given for all 14 joints "
                f"or none; missing {', '.join(absent)}"
            )
    return out


#: what a .json is read as, for a message refusing one
JSON_KINDS = ("a .json is read as COCO or PoseTrack keypoints ('annotations', or a "
              "results list with 'keypoints'), an OpenPose frame ('people'), MMPose "
              "predictions ('instance_info', or instances with [x, y] 'keypoints') or "
              "AlphaPose results (a results list with 'idx' or 'box')")


def _some_keys(obj, at_most=8):
    """The first keys of a JSON object, quoted, for a message."""
    keys = [repr(k) for k in list(obj)[:at_most]]
    return ", ".join(keys) + (", ..." if len(obj) > at_most else "") if keys else "none"


def _read_coco(path, threshold):
    doc = load_json(path)
    if isinstance(doc, dict):
        if not isinstance(doc.get("annotations"), list):
            hint = formats.alphapose.cmu_hint(doc)
            raise FileFormatError(f"{path}: not COCO keypoints{hint}" if hint else (
                f"{path}: a COCO JSON object needs an 'annotations' list (its keys: "
                f"{_some_keys(doc)}); {JSON_KINDS}"))
        anns = doc["annotations"]
    elif isinstance(doc, list):
        anns = doc
    else:
        raise FileFormatError(
            f"{path}: expected a list of annotations or an object with "
            f"'annotations', got {type(doc).__name__}"
        )
    n = len(anns)
    coco = np.zeros((n, 17, 3))
    stored = {}  # annotation index -> its "sparseedm" neck / head_top
    ids = []
    for a, ann in enumerate(anns):
        where = f"{path}: annotation {a}"
        if not isinstance(ann, dict) or "keypoints" not in ann:
            keys = f" (its keys: {_some_keys(ann)})" if isinstance(ann, dict) else ""
            raise FileFormatError(f"{where} has no 'keypoints'{keys}; {JSON_KINDS}")
        kp = ann["keypoints"]
        if not isinstance(kp, list) or len(kp) != 51:
            count = len(kp) if isinstance(kp, list) else type(kp).__name__
            raise FileFormatError(
                f"{where}: 'keypoints' has {count} values; COCO-17 needs 51 "
                f"(x, y, v for each of 17 keypoints){_alphapose_hint(count)}"
            )
        bad = next((k for k, x in enumerate(kp)
                    if isinstance(x, bool) or not isinstance(x, (int, float))), None)
        if bad is not None:
            raise FileFormatError(
                f"{where}: 'keypoints' value {bad} is {type(kp[bad]).__name__} "
                f"{str(kp[bad])[:20]!r}; keypoints must be numbers (non-numeric value)")
        try:
            coco[a] = np.asarray(kp, dtype=float).reshape(17, 3)
        except (TypeError, ValueError, OverflowError):
            raise FileFormatError(f"{where}: 'keypoints' holds non-numeric values") from None
        image_id = ann.get("image_id")
        if image_id is not None and (isinstance(image_id, bool)
                                     or not isinstance(image_id, (int, str))):
            raise FileFormatError(
                f"{where}: 'image_id' must be an integer or a string, got "
                f"{type(image_id).__name__}")
        ids.append("" if image_id is None else str(image_id))
        stored[a] = formats.read_extra(ann, where)  # the neck / head top / filled written here
    if not np.isfinite(coco).all():
        a = int(np.argwhere(~np.isfinite(coco))[0][0])
        raise FileFormatError(f"{path}: annotation {a}: non-finite keypoint value")

    xy, v = coco[..., :2], coco[..., 2]
    coco_missing = ~(v > 0)
    if threshold is not None:
        coco_missing |= v < threshold
    filled = np.zeros((n, N_JOINTS), dtype=bool)
    for a, (_, joints) in stored.items():
        filled[a, joints] = True
        for j in joints:  # flagged filled: present whatever its score
            if j in COCO_TO_14:
                coco_missing[a, COCO_TO_14[j]] = False
    poses, missing, conf = _coco_to_14(xy, v, coco_missing)
    for a, (points, _) in stored.items():
        for j, value in points.items():
            poses[a, j] = np.nan if value is None else value
            missing[a, j] = value is None
    if posetrack.uses_posetrack_order(doc):  # PoseTrack's own head_top keypoint
        top = posetrack.HEAD_TOP_INDEX
        poses[:, _HEAD_TOP] = np.where(coco_missing[:, top, None], np.nan, xy[:, top])
        missing[:, _HEAD_TOP] = coco_missing[:, top]
        conf[:, _HEAD_TOP] = v[:, top]
    tracks, frames = posetrack.tracks_and_frames(doc, anns, path)
    meta = {"coco_document": doc, "coco_missing": coco_missing}
    radii = _coco_radii_of(anns, missing, path)
    return KeypointSet(poses, missing, conf, np.asarray(ids, dtype=str).reshape(n), meta,
                       tracks=tracks, frames=frames, filled=filled if filled.any() else None,
                       uncertainty=radii)


def _alphapose_hint(count):
    """What a COCO results list of `count` keypoint values is when AlphaPose's
    other layouts have that many (Halpe-26: 78).

    >>> _alphapose_hint(78)[:45], _alphapose_hint(60)
    (' (26 keypoints: Halpe-26, as AlphaPose writes', '')
    """
    layout = formats.alphapose.LAYOUTS.get(count // 3) if isinstance(count, int) \
        and count % 3 == 0 else None
    if layout is None:
        return ""
    return (f" ({count // 3} keypoints: {layout.name}, as AlphaPose writes them; read it "
            "with format='alphapose', --input-format alphapose)")


def _coco_to_14(xy, v, coco_missing):
    """COCO-17 onto the 14 joints by the rule of the module docstring (its one home:
    :func:`sparseedm.formats.to_14`, which the detector formats share)."""
    poses, present, conf = formats.to_14(xy, v, ~coco_missing, formats.COCO_17)
    return poses, ~present, conf


# --------------------------------------------------------------------------
# writing


def write_keypoints(
    path,
    poses,
    missing=None,
    *,
    format=None,
    confidence=None,
    ids=None,
    extra_columns=None,
    meta=None,
    tracks=None,
    frames=None,
    filled=None,
    filled_score=formats.FILLED_SCORE,
    row_fields=None,
    uncertainty=None,
):
    """Write 2D keypoints atomically; the format comes from the extension.

    Parameters
    ----------
    path : str or path-like
    poses : array_like, shape (n, 14, 2), or KeypointSet
        Coordinates; NaN marks a missing joint. A :class:`KeypointSet` supplies
        the defaults of `missing`, `confidence`, `ids` and `meta`.
    missing : array_like of bool, shape (n, 14), optional
        Joints to write as missing whatever their coordinates.
    format : {"npz", "npy", "csv", "coco"}, optional
    confidence : array_like, shape (n, 14), optional
        Written to npz (``confidence``), npy (third column) and CSV
        (``<joint>_conf``); COCO keeps the original file's values.
    ids : sequence of str, shape (n,), optional
        Image / frame ids (npz ``ids``, CSV ``id``, COCO ``image_id`` when
        writing without COCO meta).
    extra_columns : dict of str -> sequence, optional
        CSV only: more per-row columns (e.g. ``{"status": [...]}``), written
        after the joint columns. Default: those kept in ``meta``.
    meta : dict, optional
        The ``meta`` of a :func:`read_keypoints` result: COCO output writes
        the original document back (see the module docstring).
    tracks, frames : array_like, shape (n,), optional
        OpenPose / MMPose / DeepLabCut: the person and frame of each pose
        (default: those of a KeypointSet).
    filled : array_like of bool, shape (n, 14), optional
        Joints to flag as filled by sparseedm. Default: those the ``meta`` of
        a read says were missing and that `poses` now holds, and those the
        read already flagged.
    filled_score : float, default 0.0
        The score a filled joint is written with (OpenPose, MMPose, DeepLabCut).
    row_fields : dict of str -> sequence, optional
        OpenPose / MMPose: per-pose results (status, ...) stored in each
        person's ``"sparseedm"`` object.
    uncertainty : array_like, shape (n, 14), optional
        The 90 % radius of each joint (``RecoveryResult.uncertainty``; >= 0,
        NaN unknown): npz ``uncertainty``, CSV ``<joint>_uncertainty``, COCO
        COCO / OpenPose / MMPose ``"sparseedm"."uncertainty"`` (see the
        module docstring); DeepLabCut: the filled joints' likelihood
        (:func:`sparseedm.formats._base.filled_likelihood`). Default: a
        KeypointSet's.

    Returns
    -------
    pathlib.Path
        The written path.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> poses = np.ones((1, 14, 2))
    >>> path = os.path.join(tempfile.mkdtemp(), "out.npz")
    >>> write_keypoints(path, poses, ids=["a"]).name
    'out.npz'
    >>> sorted(np.load(path).files)
    ['ids', 'missing', 'poses']
    """
    validate_params("write_keypoints", dict(path=path, filled_score=filled_score),
                    {"path": _READ_PARAMS["path"], "filled_score": SCORE})
    path = Path(path)
    if isinstance(poses, KeypointSet) and meta is None:
        meta = poses.meta
    fmt = output_format(path, format, (meta or {}).get("format"))
    if isinstance(poses, KeypointSet):
        kps = poses
        poses = kps.poses
        missing = kps.missing if missing is None else missing
        confidence = kps.confidence if confidence is None else confidence
        ids = kps.ids if ids is None else ids
        meta = kps.meta if meta is None else meta
        tracks = kps.tracks if tracks is None else tracks
        frames = kps.frames if frames is None else frames
        if filled is None and kps.filled is not None:
            filled = kps.filled | _newly_filled(kps.poses, meta)
        uncertainty = kps.uncertainty if uncertainty is None else uncertainty
    meta = meta or {}
    where = f"writing {path}"
    poses = check_poses(poses, "write_keypoints")
    if poses.ndim != 3 or poses.shape[-1] != 2:
        raise FileFormatError(f"{where}: poses must have shape (n, 14, 2), got {poses.shape}")
    if poses.shape[1] != N_JOINTS:
        raise _joint_count_error(f"{where}: poses", poses.shape[1])
    n = len(poses)
    mask = np.zeros((n, N_JOINTS), dtype=bool)
    if missing is not None:
        mask = _optional(missing, n, "missing", where, bool).copy()
    mask |= ~np.isfinite(poses).all(axis=-1)
    poses = np.where(mask[..., None], np.nan, poses)
    confidence = _optional(confidence, n, "confidence", where, float)
    if ids is not None:
        ids = _optional(np.asarray(ids).astype(str), n, "ids", where, str)
    uncertainty = _radii(uncertainty, n, where)

    if filled is None:
        filled = _newly_filled(poses, meta) | _read_filled(meta, n)
    filled = _optional(filled, n, "filled", where, bool) & ~mask
    if fmt in ("csv", "npz", "npy"):  # a .npy keeps no filled flags of its own
        _refuse_origin_joints(poses, mask, filled & (fmt != "npy"), where)
    frames = _fresh_frames(fmt, frames, n, where, meta, path)
    if fmt in formats.FORMATS:
        rows = formats.Rows(poses, filled, confidence, ids, tracks, frames, filled_score,
                            uncertainty=uncertainty)
        if fmt == "dlc" and uncertainty is not None:
            rows.likelihood = filled_likelihood(poses, uncertainty, filled_score)
        formats.write(fmt, path, rows, meta, filled_score=filled_score, row_fields=row_fields)
    elif fmt == "npz":
        arrays = dict(meta.get("npz_extra") or {})
        arrays.update(poses=poses, missing=mask)
        if confidence is not None:
            arrays["confidence"] = confidence
        if ids is not None:
            arrays["ids"] = ids
        arrays.update(_time_arrays(tracks, frames, meta, where))
        if filled.any():
            arrays["filled"] = filled
        if uncertainty is not None:
            arrays["uncertainty"] = uncertainty
        save_npz(path, arrays)
    elif fmt == "npy":
        arr = poses if confidence is None else np.concatenate(
            [poses, confidence[..., None]], axis=-1
        )
        if ids is not None:
            warnings.warn(f"{path}: .npy files cannot hold ids; they were not written",
                          stacklevel=2)
        save_npy(path, arr)
    elif fmt == "csv":
        if extra_columns is None:
            extra_columns = meta.get("extra_columns") or {}
        extra_columns = _time_columns(tracks, frames, extra_columns)
        _write_csv(path, poses, confidence, ids, extra_columns, where,
                   filled if filled.any() else None, uncertainty)
    else:
        _write_coco(path, poses, mask, ids, meta, where, filled, filled_score, tracks,
                    uncertainty, frames)
    return path


def check_output_fits(path, fmt, n, *, tracks=None, frames=None, ids=None, meta=None):
    """Refuse tracks and frames that :func:`write_keypoints` would refuse to write
    in `fmt`, by the writers' own checks, so a run can refuse them before it
    recovers anything: frame numbers that are not whole numbers up to 2**53
    (or negative where they go into file names: OpenPose, AlphaPose, MMPose
    folders), a fresh PoseTrack image given two frames, text an ``.npz``
    cannot hold as frames, tracks that are not OpenPose ``person_id`` values, a
    frame twice in one track or a track name with a line break in a fresh
    DeepLabCut table.

    Parameters
    ----------
    path : str or path-like
        The output, named in the message.
    fmt : str
        The output format (:func:`output_format`).
    n : int
        The number of poses.
    tracks, frames, ids : array_like (n,), optional
        What the output will be written with.
    meta : dict, optional
        The read's ``KeypointSet.meta`` (a document written back keeps its own
        tracks and frames).

    Raises
    ------
    FileFormatError
        Naming the first pose whose track or frame the format cannot hold.

    Examples
    --------
    >>> check_output_fits("out.json", "coco", 2, frames=[0, 1])
    >>> check_output_fits("out", "openpose", 1, frames=[-1])
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: writing out: pose 0: frame number -1 is negative; frame file names hold numbers >= 0
    """
    path, meta = Path(path), meta or {}
    where = f"writing {path}"
    ids = None if ids is None else np.asarray(ids).astype(str)
    frames = _fresh_frames(fmt, frames, n, where, meta, path)
    if fmt == "openpose" and meta.get("format") != fmt:
        formats.openpose.check_tracks(tracks, path)
    elif fmt == "npz" and frames is not None:
        _npz_frames(np.asarray(frames), where)
    elif fmt == "coco" and frames is not None and meta.get("coco_document") is None:
        _posetrack_images([{"image_id": _image_id(ids, r)} for r in range(n)], frames, where)
    elif fmt == "dlc" and meta.get("dlc_columns") is None:  # a fresh table
        formats.deeplabcut.check_fresh(path, n, tracks=tracks, frames=frames, ids=ids)


def _fresh_frames(fmt, frames, n, where, meta, path):
    """The frames of a fresh OpenPose / MMPose file or DeepLabCut table as the
    readers take them (:func:`_frame_numbers`); else `frames` (a read's documents
    and a DeepLabCut input's table go back as read)."""
    if frames is None:
        return None
    if fmt in ("openpose", "mmpose", "alphapose") and meta.get("format") != fmt:
        # files (OpenPose, MMPose folders) or images (AlphaPose) named by frame
        named = fmt in ("openpose", "alphapose") or path.suffix.lower() != ".json"
        return _frame_numbers(frames, n, where, named)
    if fmt == "dlc" and meta.get("dlc_columns") is None:
        return _frame_numbers(frames, n, where, False)  # the table's row index
    return frames


def _frame_numbers(frames, n, where, named):
    """`frames` as ints by the readers' rule (:func:`frame_value`), refused (naming
    the pose) when one is not a whole number, or is negative where frame numbers
    go into file names (OpenPose and MMPose frame folders)."""
    values = []
    for r, frame in enumerate(_optional(frames, n, "frames", where, None).tolist()):
        value, why = frame_value(frame)
        if not why and named and value < 0:
            why = f"frame number {value} is negative; frame file names hold numbers >= 0"
        if why:
            raise FileFormatError(f"{where}: pose {r}: {why}")
        values.append(value)
    return np.asarray(values, dtype=np.int64)


def _posetrack_images(anns, frames, where):
    """PoseTrack's ``images`` of fresh annotations: ``{"id", "frame_id"}`` per
    image id, each frame number checked by the readers' rule (refused when one
    is not a whole number, or one image is given two frames)."""
    frame_of = {}
    for r, (ann, frame) in enumerate(zip(anns, np.asarray(frames).tolist())):
        value, why = frame_value(frame)
        if why:
            raise FileFormatError(f"{where}: pose {r}: {why}")
        image = ann["image_id"]
        if frame_of.setdefault(repr(image), (image, value))[1] != value:
            raise FileFormatError(f"{where}: pose {r}: image {image!r} is given frames "
                                  f"{frame_of[repr(image)][1]} and {value}; give each "
                                  "image (id) one frame")
    return [{"id": image, "frame_id": value} for image, value in frame_of.values()]


def _newly_filled(poses, meta):
    """Joints the read (``meta["read_missing"]``) had missing that `poses` now holds."""
    read_missing = meta.get("read_missing")
    present = ~np.isnan(np.asarray(poses, dtype=float)).any(axis=-1)
    if read_missing is None or np.shape(read_missing) != present.shape:
        return np.zeros(present.shape, dtype=bool)
    return np.asarray(read_missing, dtype=bool) & present


def _read_filled(meta, n):
    flags = meta.get("read_filled")
    if flags is None or np.shape(flags) != (n, N_JOINTS):
        return np.zeros((n, N_JOINTS), dtype=bool)
    return np.asarray(flags, dtype=bool)


def _time_arrays(tracks, frames, meta, where):
    """npz arrays of a KeypointSet's tracks and frames (under the names read)."""
    out = {}
    if tracks is not None:
        out[meta.get("track_key", "tracks")] = np.asarray(tracks)
    if frames is not None:
        out["frames"] = _npz_frames(np.asarray(frames), where)
    return out


def _npz_frames(frames, where):
    """Frames as the .npz reader takes them (numbers): a CSV's text of whole
    numbers as int64 (blank cells NaN, the array then float); other text refused.

    >>> _npz_frames(np.array(["3", "-1"]), "x").tolist(), _npz_frames(np.array(["4", ""]), "x")
    ([3, -1], array([ 4., nan]))
    """
    if frames.dtype.kind in "fiu":
        return frames
    text = [str(v).strip() for v in frames.tolist()]
    blank = np.array([t.lower() in ("", "nan") for t in text])
    values = np.zeros(len(text), dtype=np.int64)
    for r, t in enumerate(text):
        if blank[r]:
            continue
        try:
            values[r] = int(t)
        except (ValueError, OverflowError):
            raise FileFormatError(f"{where}: pose {r}: frame {t!r} is not a whole number an "
                                  ".npz holds (int64); write a CSV, or fix the frame "
                                  "numbers") from None
    if not blank.any():
        return values
    if np.abs(values).max() > 2 ** 53:  # a float would round it
        raise FileFormatError(f"{where}: frame numbers over 2**53 with blank ones: an .npz "
                              "holds them as floats, which would round them; write a CSV")
    return np.where(blank, np.nan, values.astype(float))


def _time_columns(tracks, frames, extra_columns):
    """CSV `extra_columns` with ``track``/``frame`` added when not there already."""
    extra_columns = dict(extra_columns)
    for name, values in (("track", tracks), ("frame", frames)):
        if values is not None and name not in extra_columns:
            extra_columns[name] = [str(v) for v in np.asarray(values).tolist()]
    return extra_columns


def _write_csv(path, poses, confidence, ids, extra_columns, where, filled=None,
               uncertainty=None):
    n = len(poses)
    header = [] if ids is None else ["id"]
    header += [f"{name}_{a}" for name in JOINT_NAMES for a in "xy"]
    if confidence is not None:
        header += [f"{name}_conf" for name in JOINT_NAMES]
    if filled is not None:
        header += [f"{name}_filled" for name in JOINT_NAMES]
    if uncertainty is not None:
        header += [f"{name}_uncertainty" for name in JOINT_NAMES]
    extras = []
    for name, values in extra_columns.items():
        name = str(name)
        stem, _, suffix = name.rpartition("_")
        if name in header or name == "id" or (stem and suffix in _SUFFIXES) or \
                (stem in JOINT_NAMES and suffix in CONF_SYNONYMS):
            raise FileFormatError(
                f"{where}: extra column {name!r} clashes with the keypoint columns"
            )
        values = list(values)
        if len(values) != n:
            raise FileFormatError(
                f"{where}: extra column {name!r} has {len(values)} values for {n} poses"
            )
        header.append(name)
        extras.append(values)
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            flat = np.asarray(poses).reshape(n, 2 * N_JOINTS)
            for lo in range(0, n, CSV_BLOCK_ROWS):  # the cells of one block at a time
                hi = min(n, lo + CSV_BLOCK_ROWS)
                writer.writerows(_csv_out_rows(lo, hi, flat, confidence, ids, filled, extras,
                                               uncertainty))


def _csv_out_rows(lo, hi, flat, confidence, ids, filled, extras, uncertainty=None):
    """The CSV rows ``lo:hi`` of :func:`_write_csv`, as lists of cells."""
    xy = csv_cells(flat[lo:hi])
    conf = None if confidence is None else csv_cells(np.asarray(confidence)[lo:hi])
    radii = None if uncertainty is None else csv_cells(uncertainty[lo:hi])
    out = []
    for k, r in enumerate(range(lo, hi)):
        row = [] if ids is None else [ids[r]]
        row += xy[k]
        if conf is not None:
            row += conf[k]
        if filled is not None:
            row += ["1" if f else "0" for f in filled[r]]
        if radii is not None:
            row += radii[k]
        row += ["" if col[r] is None else str(col[r]) for col in extras]
        out.append(row)
    return out


def _xy_or_none(p):
    return None if np.isnan(p).any() else [float(p[0]), float(p[1])]


def _coco_radii_of(anns, missing, path):
    """(n, 14) radii of a COCO document's annotations, None when none has one."""
    radii = [read_radii(ann, f"{path}: annotation {a}") for a, ann in enumerate(anns)]
    if all(r is None for r in radii):
        return None
    return np.stack([np.full(N_JOINTS, np.nan) if r is None else r for r in radii])


def _image_id(ids, r):
    """A fresh COCO annotation's ``image_id``: pose r's id (an int when it is
    one), else r as text."""
    image_id = ids[r] if ids is not None else str(r)
    return int(image_id) if image_id.lstrip("-").isdigit() else image_id


def _write_coco(path, poses, mask, ids, meta, where, filled, filled_score, tracks=None,
                uncertainty=None, frames=None):
    n = len(poses)
    fresh = meta.get("coco_document") is None
    if not fresh:
        doc = copy.deepcopy(meta["coco_document"])
        anns = doc["annotations"] if isinstance(doc, dict) else doc
        if len(anns) != n:
            raise FileFormatError(
                f"{where}: {n} poses for {len(anns)} annotations in the COCO document"
            )
        coco_missing = meta.get("coco_missing")
        if coco_missing is None or np.shape(coco_missing) != (n, 17):
            coco_missing = [[not (ann["keypoints"][3 * k + 2] > 0) for k in range(17)]
                            for ann in anns]
        coco_missing = np.asarray(coco_missing, dtype=bool).reshape(n, 17)
    else:
        anns = []
        for r in range(n):
            anns.append({
                "image_id": _image_id(ids, r),
                "category_id": 1,
                "keypoints": [0.0] * 51,
            })
            if tracks is not None:  # PoseTrack's person over time
                anns[-1]["track_id"] = track_value(np.asarray(tracks)[r])
        doc = anns
        if frames is not None:  # PoseTrack: frames of the images (with tracks or not)
            doc = {"images": _posetrack_images(anns, frames, where), "annotations": anns}
        coco_missing = np.ones((n, 17), dtype=bool)
    for r, ann in enumerate(anns):
        kp = list(ann["keypoints"])
        for j, c in sorted(COCO_TO_14.items(), key=lambda item: item[1]):
            if coco_missing[r, c] and not mask[r, j]:
                # recovered: the filled score; a fresh file's plain keypoints: v = 2
                v = filled_score if filled[r, j] or not fresh else 2
                kp[3 * c: 3 * c + 3] = [float(poses[r, j, 0]), float(poses[r, j, 1]), v]
        ann["keypoints"] = kp
        if "num_keypoints" in ann:
            ann["num_keypoints"] = sum(1 for k in range(17) if kp[3 * k + 2] > 0)
        ann["sparseedm"] = {
            "neck": _xy_or_none(poses[r, _NECK]),
            "head_top": _xy_or_none(poses[r, _HEAD_TOP]),
            "filled": [JOINT_NAMES[j] for j in np.flatnonzero(filled[r])],
        }
        if uncertainty is not None:
            ann["sparseedm"]["uncertainty"] = radii_object(uncertainty[r])
        if tracks is not None and not fresh and ann.get("track_id") is None:
            ann["track_id"] = track_value(np.asarray(tracks)[r])  # linked, as read had none
    save_json(path, doc)
