"""OpenPose JSON (``--write_json``): one file per frame, or a folder of them.

Each file is ``{"version": ..., "people": [{"person_id": [-1],
"pose_keypoints_2d": [x1, y1, c1, ...], "face_keypoints_2d": [...], ...}]}``
(OpenPose ``doc/02_output.md``; files of OpenPose before 1.2 name it
``pose_keypoints``, read and written back under that name); its frame number is the one in its name
(``video_000000000012_keypoints.json``; files without one are numbered in name
order). A folder is one video: one file stem (the name without its frame
number) is one video, and a folder whose files have two stems
(``camA_..._keypoints.json``, ``camB_..._keypoints.json``) is refused, naming
them (split it, one video per folder). Each person is one pose, its id the
file's name without ``_keypoints.json``. ``c`` is OpenPose's confidence in [0, 1]; undetected
keypoints are written ``0, 0, 0`` and read as missing (``c = 0``).

Body models, told apart by the length of ``pose_keypoints_2d``:

``BODY_25`` (75 values): Nose, Neck, RShoulder, RElbow, RWrist, LShoulder,
    LElbow, LWrist, MidHip, RHip, RKnee, RAnkle, LHip, LKnee, LAnkle, REye,
    LEye, REar, LEar, 6 foot points;
``COCO`` (18 keypoints, 54 values): the first 8 of BODY_25, then RHip ...
    LAnkle, REye, LEye, REar, LEar;
``BODY_135`` (405 values): its body part is BODY_25B (the COCO-17 keypoints in
    COCO order, UpperNeck, HeadTop, 6 foot points); hands and face follow and
    are not used.

Mapping onto the 14 joints: limbs by name; ``neck`` = OpenPose's ``Neck``
(BODY_25, COCO-18: trained on the shoulders' midpoint, the base of the neck),
for BODY_135 the midpoint of the shoulders (its UpperNeck sits higher);
``head_top`` = BODY_135's ``HeadTop``, for BODY_25 / COCO-18 the COCO rule
from the face (nose, eyes, ears; :mod:`sparseedm.formats._base`).

Tracks: ``person_id`` (a number or OpenPose's one-element list) where every
person has one >= 0 (``--tracking``); without ids, one track when no frame
holds more than one person; otherwise none (persons cannot be told apart).

A file with no people is a frame with no poses (kept, and written back as it
was). A bad file of a folder (truncated JSON, not an OpenPose frame, a
keypoint that is not a number, a score outside [0, 1]) is skipped with a
warning naming the file and field, the good frames are kept
(``meta["skipped"]``); a folder with no good frame, or a bad single file,
raises :class:`~sparseedm.exceptions.FileFormatError`. Files that are not
``.json`` are ignored (listed in ``meta["ignored"]``).

Writing back: every file of the input, with the filled keypoints of each
person set to ``[x, y, filled_score]`` and a ``"sparseedm"`` object per
person (``neck``, ``head_top``, ``filled``: the 14-joint names filled,
``frame``, which a file renamed without the frame number is read with, plus
per-row status and ``uncertainty``, the joints' 90 % radii by name, when
written by ``sparseedm recover``). A folder input is
written as a folder (the same file names), a file as a file. Without an
OpenPose input, BODY_25 files are written (one per frame; ``person_id`` the
track, an integer >= 0: other tracks are refused before anything is written).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .._safeio import load_json
from .._validation import frame_array
from ..exceptions import FileFormatError
from . import _base, alphapose
from ._base import COCO17, EXTRA_KEY, Layout, Person

__all__ = ["BODY_25", "COCO_18", "BODY_135", "LAYOUTS", "read", "write", "is_openpose",
           "body_key", "check_tracks"]

_SIDES = ("shoulder", "elbow", "wrist")
_LEGS = ("hip", "knee", "ankle")
_FEET = ("big_toe", "small_toe", "heel")

BODY_25 = Layout("BODY_25", (
    "nose", "neck", *(f"right_{s}" for s in _SIDES), *(f"left_{s}" for s in _SIDES),
    "mid_hip", *(f"right_{s}" for s in _LEGS), *(f"left_{s}" for s in _LEGS),
    "right_eye", "left_eye", "right_ear", "left_ear",
    *(f"left_{s}" for s in _FEET), *(f"right_{s}" for s in _FEET)), neck="neck")
COCO_18 = Layout("COCO-18", (
    "nose", "neck", *(f"right_{s}" for s in _SIDES), *(f"left_{s}" for s in _SIDES),
    *(f"right_{s}" for s in _LEGS), *(f"left_{s}" for s in _LEGS),
    "right_eye", "left_eye", "right_ear", "left_ear"), neck="neck")
BODY_135 = Layout("BODY_135", (
    *COCO17, "upper_neck", "head_top", *(f"left_{s}" for s in _FEET),
    *(f"right_{s}" for s in _FEET), *(f"hand_or_face_{i}" for i in range(110))),
    head_top="head_top")
#: layouts by the number of keypoints in ``pose_keypoints_2d``
LAYOUTS = {len(lay): lay for lay in (BODY_25, COCO_18, BODY_135)}
#: most files a folder may hold (a 9-hour video at 30 fps)
MAX_FILES = 1_000_000
_SUFFIX = "_keypoints.json"


def is_openpose(doc):
    """Whether a JSON document is an OpenPose frame."""
    return isinstance(doc, dict) and isinstance(doc.get("people"), list) \
        and "annotations" not in doc


def _stem(name):
    return name[: -len(_SUFFIX)] if name.endswith(_SUFFIX) else Path(name).stem


def body_key(person):
    """The key of a person's body keypoints: ``pose_keypoints_2d``, or
    ``pose_keypoints`` in files of OpenPose before version 1.2.

    >>> body_key({"pose_keypoints": []}), body_key({"pose_keypoints_2d": []})
    ('pose_keypoints', 'pose_keypoints_2d')
    """
    old = "pose_keypoints"
    return old if isinstance(person, dict) and old in person \
        and "pose_keypoints_2d" not in person else "pose_keypoints_2d"


def _person(person, path, p, frame):
    where = f"{path}: people[{p}]"
    key = body_key(person)
    kp = _base.keypoint_rows(person, where, key, 3, LAYOUTS,
                             "OpenPose body models have 75 (BODY_25), 54 (COCO) or "
                             "405 (BODY_135): x, y, c per keypoint")
    _base.check_scores(kp[:, 2], where, f"{key} confidence", upper=1.0)
    pid = person.get("person_id", -1)
    if isinstance(pid, list) and len(pid) == 1:
        pid = pid[0]
    if isinstance(pid, bool) or not isinstance(pid, int):
        raise FileFormatError(f"{where}: 'person_id' must be an integer (or [integer])")
    points, filled = _base.read_extra(person, where)
    stored = person.get(EXTRA_KEY, {}).get("frame") if isinstance(person.get(EXTRA_KEY),
                                                                   dict) else None
    if frame is None and isinstance(stored, int) and not isinstance(stored, bool):
        frame = stored  # a file written here under a name without the frame number
    return Person(kp[:, :2], kp[:, 2], _stem(Path(path).name), frame,
                  pid if pid >= 0 else None, points, filled, _base.read_radii(person, where))


def _frame_file(path, frame):
    """The people of one frame file and its document."""
    doc = load_json(path)
    if not is_openpose(doc):
        raise FileFormatError(f"{path}: not an OpenPose frame (no 'people' list)"
                              + (_by_image_hint(doc) or alphapose.cmu_hint(doc)))
    return [_person(person, path, p, frame) for p, person in enumerate(doc["people"])], doc


def _by_image_hint(doc):
    """What to read instead of AlphaPose's ``--format open`` results file (OpenPose
    frames by image name, ``{"0.jpg": {"people": [...]}, ...}``).

    >>> _by_image_hint({"0.jpg": {"version": "AlphaPose v0.3", "people": []}})[:40]
    '; it looks like AlphaPose --format open '
    """
    first = next(iter(doc.values()), None) if isinstance(doc, dict) and doc else None
    if not is_openpose(first):
        return ""
    return ("; it looks like AlphaPose --format open results (OpenPose frames by image "
            "name): read its sep-json folder (one OpenPose file per image), or run "
            "AlphaPose without --format (its results list, which sparseedm reads)")


def read(path):
    """Read an OpenPose frame file or a folder of them into a :class:`_base.Parsed`."""
    path = Path(path)
    if not path.is_dir():
        frame = _base.frame_number(path.name)
        people, doc = _frame_file(path, frame)
        files = [{"name": path.name, "doc": doc, "rows": len(people)}]
        return _parsed(people, files, {"openpose_folder": False, "skipped": [],
                                       "ignored": []}, path)
    people, files, skipped, ignored = _base.read_frame_folder(
        path, _frame_file, "OpenPose frame files", MAX_FILES)
    return _parsed(people, files, {"openpose_folder": True, "skipped": skipped,
                                   "ignored": ignored}, path)


def _parsed(people, files, meta, path):
    sizes = {len(p.xy) for p in people}
    if len(sizes) > 1:
        raise FileFormatError(f"{path}: people of different body models "
                              f"({', '.join(LAYOUTS[s].name for s in sorted(sizes))})")
    layout = LAYOUTS[sizes.pop()] if sizes else BODY_25
    meta.update(openpose_files=files, layout=layout.name)
    frames = None
    if all(p.frame is not None for p in people):
        frames = frame_array([p.frame for p in people])  # huge numbers: refused per row
    return _base.assemble(people, layout, meta, tracks=_base.person_tracks(people),
                          frames=frames)


# --------------------------------------------------------------------------
# writing


def write(path, rows, meta, filled_score, row_fields=None):
    """Write OpenPose JSON: the input's files with the filled joints, or BODY_25 files."""
    path = Path(path)
    files = meta.get("openpose_files")
    if files is None:
        docs, folder = _fresh(rows, path)
    else:
        docs, folder = _updated(files, rows, meta, filled_score, row_fields, path), \
            meta.get("openpose_folder", False)
    if not folder:
        if len(docs) != 1:
            raise FileFormatError(f"writing {path}: {len(docs)} frames need a folder "
                                  "(give an output path without .json)")
        named = _base.frame_number(path.name)
        if files is None and rows.frames is not None and named not in (None, int(
                rows.frames[0])):  # the reader takes the frame from the name
            raise FileFormatError(f"writing {path}: the name says frame {named}, the poses "
                                  f"are of frame {int(rows.frames[0])}; rename the output")
        _base.write_json(path, docs[0][1])
        return
    _base.write_json_folder(path, docs)


def _updated(files, rows, meta, filled_score, row_fields, path):
    layout = LAYOUTS[{lay.name: n for n, lay in LAYOUTS.items()}[meta["layout"]]]
    total = sum(f["rows"] for f in files)
    if total != len(rows.poses):
        raise FileFormatError(f"{len(rows.poses)} poses for the {total} people read")
    docs, r = [], 0
    for f in files:
        doc = json.loads(json.dumps(f["doc"]))
        for person in doc["people"]:
            key = body_key(person)
            kp = np.asarray(person[key], dtype=float).reshape(-1, 3)
            _base.update_person(kp[:, :2], kp[:, 2], rows.poses[r], rows.filled[r], layout,
                                filled_score)
            person[key] = [float(v) for v in kp.ravel()]
            person[EXTRA_KEY] = _base.write_extra(rows.poses[r], rows.filled[r],
                                                  _base.row_status(row_fields, r),
                                                  rows.radii(r))
            if rows.frames is not None:
                person[EXTRA_KEY]["frame"] = int(rows.frames[r])
            track = _base.linked_id(rows, r, _has_id(person))
            if track is not None:
                person["person_id"] = [_person_id(track, r, path)]
            r += 1
        docs.append((f["name"], doc))
    return docs


def _fresh(rows, path):
    groups, frames = _base.frame_rows(rows.frames, len(rows.poses))
    layout = BODY_25
    docs = []
    for members, frame in zip(groups, frames):
        people = []
        for r in members:
            kp = np.zeros((len(layout), 3))
            for j, k in layout.sources().items():
                if not np.isnan(rows.poses[r, j]).any():
                    kp[k] = (*rows.poses[r, j], rows.score(r, j))
            track = -1 if rows.tracks is None else _person_id(rows.tracks[r], r, path)
            extra = _base.write_extra(rows.poses[r], rows.filled[r], radii=rows.radii(r))
            if rows.frames is not None:  # read back where the file name has none
                extra["frame"] = int(frame)
            people.append({"person_id": [track],
                           "pose_keypoints_2d": [float(v) for v in kp.ravel()],
                           EXTRA_KEY: extra})
        docs.append((f"{path.stem}_{frame:012d}{_SUFFIX}", {"version": 1.3, "people": people}))
    return docs, path.suffix.lower() != ".json"


def check_tracks(tracks, path):
    """Refuse `tracks` a fresh OpenPose output cannot hold as ``person_id``
    (the writer's own rule, :func:`_person_id`, on every pose), so a run can
    refuse them before it recovers anything.

    Parameters
    ----------
    tracks : array_like (n,) or None
        Each pose's track.
    path : str or path-like
        The output, named in the message.

    Raises
    ------
    FileFormatError
        Naming the first pose whose track is not an integer from 0 to 2**63 - 1.

    Examples
    --------
    >>> check_tracks([0, 3], "out")
    >>> check_tracks(["a"], "out")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: writing out: pose 0: track 'a' cannot be ...
    """
    if tracks is not None:
        for r, track in enumerate(np.asarray(tracks).tolist()):
            _person_id(track, r, path)


def _person_id(track, r, path):
    """Pose r's track as an OpenPose ``person_id``: an integer >= 0 (-1 is "no
    id"), else refused before any file is written (it would read back lost)."""
    if (isinstance(track, (bool, np.bool_)) or not _is_int(track)
            or not 0 <= int(track) < 2**63):
        raise FileFormatError(f"writing {path}: pose {r}: track {track!r} cannot be an OpenPose "
                              "'person_id' (an integer from 0 to 2**63 - 1); give tracks as such "
                              "integers, or write another format")
    return int(track)


def _has_id(person):
    """Whether an OpenPose person carries a tracking id (``person_id`` >= 0)."""
    pid = person.get("person_id", -1)
    pid = pid[0] if isinstance(pid, list) and len(pid) == 1 else pid
    return _is_int(pid) and not isinstance(pid, bool) and int(pid) >= 0


def _is_int(value):
    try:
        return float(value) == int(value)
    except (TypeError, ValueError, OverflowError):
        return False
