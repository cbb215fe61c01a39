"""AlphaPose results JSON (``alphapose-results.json``).

AlphaPose's default output is a COCO-style results list, one entry per
detected person::

    [{"image_id": "12.jpg", "category_id": 1,
      "keypoints": [x1, y1, s1, x2, y2, s2, ...], "score": 2.9,
      "box": [x, y, w, h], "idx": 3}, ...]

``keypoints`` are flat ``x, y, score`` triples; the layout comes from their
number, as for MMPose (:data:`sparseedm.formats._base.BODY_LAYOUTS`):

``COCO-17`` (51 values): the COCO rule for neck and head top (the shoulders'
    midpoint; the head top placed from the face), as COCO files are read;
``Halpe-26`` (78) and ``Halpe-136`` (408, whose first 26 are Halpe-26):
    Halpe's own ``head`` (17, the top of the head) and ``neck`` (18);
``COCO-WholeBody`` (399): its body part (the first 17), as COCO-17.

A keypoint score is AlphaPose's heatmap confidence, which older models give
above 1, so any finite score >= 0 is accepted; a score <= 0 is a missing
keypoint, and the confidence threshold (``DEFAULT_THRESHOLDS["alphapose"]``)
reads the low ones as missing.

Each entry is one pose, its id the ``image_id`` (as text). Frames: the
number AlphaPose itself reads from an image name (the digits after the
stem's last ``_``, or the whole stem: ``12.jpg``, ``frame_000012.png``; a
video's frames are ``0.jpg``, ``1.jpg``, ...), or an integer ``image_id``
(AlphaPose's ``--eval`` output); none when some name holds no number
(photos). As for frame folders, one name stem (the name without its number)
is one video: a file whose names have two stems is refused, naming them.
Tracks: ``idx`` where every entry's is an integer (``--pose_track`` or
``--pose_flow``; a string is read as a track id too); untracked runs write the pose NMS's box ids there (a list,
``[0.0]``), which are no tracks: then one track when no frame holds more
than one pose, else none (``sparseedm recover`` links them); photos have
tracks only from ``idx``.

Writing back: the input document with the filled keypoints set to their
recovered ``x, y`` and score ``filled_score``, and a ``"sparseedm"`` object
per entry (``neck``, ``head_top``, ``filled``, ``frame``; per-row status and
``uncertainty`` when written by ``sparseedm recover``); linked tracks go
into ``idx``. Without an AlphaPose input: COCO-17 entries, ``image_id``
``<frame>.jpg`` (or the pose's id without frames), ``box`` the present
joints' bounding box, ``score`` the mean of their scores, ``idx`` the track.
The reader takes a pose's frame from ``"sparseedm".frame`` where it is
written (an integer, or null: no frame), so what is written reads back as it was.
"""

from __future__ import annotations

import copy
import re

import numpy as np

from .._validation import frame_array
from ..exceptions import FileFormatError
from . import _base
from ._base import BODY_LAYOUTS, COCO_17, EXTRA_KEY, Person

__all__ = ["LAYOUTS", "read", "write", "is_alphapose", "image_frame", "cmu_hint"]

#: layouts by their number of keypoints
LAYOUTS = BODY_LAYOUTS
_DESCRIBED = ("AlphaPose layouts read: 51 (COCO-17), 78 (Halpe-26), 399 (COCO-WholeBody), "
              "408 (Halpe-136) values: x, y, score per keypoint")
#: an image name's stem and frame number: the digits after its last "_", or all of it
_IMAGE_NUMBER = re.compile(r"^(?:(.*)_)?(\d+)$", re.ASCII)


def _flat_entry(x):
    return isinstance(x, dict) and isinstance(x.get("keypoints"), list) and (
        not x["keypoints"] or not isinstance(x["keypoints"][0], list))


def is_alphapose(doc):
    """Whether a JSON document is an AlphaPose results list: entries with flat
    ``keypoints`` and AlphaPose's ``idx`` or ``box``, or as many keypoints as a
    Halpe or COCO-WholeBody layout has (a COCO-17 list without either is a COCO
    results file, read as COCO).

    >>> is_alphapose([{"image_id": "0.jpg", "keypoints": [0.0] * 51, "idx": [0.0]}])
    True
    >>> is_alphapose([{"image_id": 1, "keypoints": [0.0] * 51, "score": 0.9}])
    False
    >>> is_alphapose([{"image_id": 1, "keypoints": [0.0] * 78}])
    True
    """
    if not isinstance(doc, list) or not doc or not _flat_entry(doc[0]):
        return False
    first = doc[0]
    return "idx" in first or "box" in first or (
        len(first["keypoints"]) % 3 == 0 and len(first["keypoints"]) // 3 in
        set(LAYOUTS) - {len(COCO_17)})


def cmu_hint(doc):
    """What to do with AlphaPose's ``--format cmu`` output (CMU-Pose ``bodies``
    by image name, ``{"0.jpg": {"version": ..., "bodies": [{"joints": [...]}]}}``,
    or one image's object from its ``sep-json`` folder), which is not read.

    Parameters
    ----------
    doc : object
        A loaded JSON document.

    Returns
    -------
    str
        A message tail (``"; it looks like ..."``) naming it, else "".

    Examples
    --------
    >>> cmu_hint({"0.jpg": {"version": "AlphaPose v0.3", "bodies": []}})[:42]
    '; it looks like AlphaPose --format cmu out'
    >>> cmu_hint({"version": "AlphaPose v0.3", "bodies": [{"joints": []}]})[:42]
    '; it looks like AlphaPose --format cmu out'
    >>> cmu_hint({"annotations": []})
    ''
    """
    if not isinstance(doc, dict) or not doc:
        return ""
    first = doc if "bodies" in doc else next(iter(doc.values()))
    if not (isinstance(first, dict) and isinstance(first.get("bodies"), list)):
        return ""
    return ("; it looks like AlphaPose --format cmu output (CMU-Pose 'bodies' by image), "
            "which sparseedm does not read: run AlphaPose without --format (its results "
            "list, alphapose-results.json) or with --format open and read its sep-json "
            "folder (one OpenPose file per image)")


def image_frame(image_id):
    """``(stem, frame)`` of an ``image_id``: the number AlphaPose reads from an image
    name (the digits after the stem's last ``_``, or the whole stem) and the name
    with it replaced by ``*``; an integer id is its own frame (no stem); ``(None,
    None)`` for a name without one.

    >>> image_frame("12.jpg"), image_frame("cam_A_000012.png"), image_frame(7)
    (('*.jpg', 12), ('cam_A_*.png', 12), (None, 7))
    >>> image_frame("img12.jpg")
    (None, None)
    """
    if isinstance(image_id, int):
        return None, image_id
    name = str(image_id).replace("\\", "/").rsplit("/", 1)[-1]
    stem, dot, ext = name.rpartition(".")
    if not dot:
        stem, ext = name, ""
    m = _IMAGE_NUMBER.match(stem)
    if m is None:
        return None, None
    head = "" if m.group(1) is None else m.group(1) + "_"
    return f"{head}*{dot}{ext}", int(m.group(2))


def _entry(entry, where):
    """One result as a :class:`_base.Person` (frame from its name, or its own)."""
    kp = _base.keypoint_rows(entry, where, "keypoints", 3, LAYOUTS, _DESCRIBED)
    _base.check_scores(kp[:, 2], where, "keypoints score")
    image = entry.get("image_id", "")
    if isinstance(image, bool) or not isinstance(image, (int, str)):
        raise FileFormatError(f"{where}: 'image_id' must be an image name or an integer")
    idx = entry.get("idx")
    if isinstance(idx, bool) or not (idx is None or isinstance(idx, (int, str, list))):
        raise FileFormatError(f"{where}: 'idx' must be an integer or a string (a track id) "
                              "or a list (the box ids of an untracked run)")
    points, filled = _base.read_extra(entry, where)
    return Person(kp[:, :2], kp[:, 2], str(image), None,
                  idx if isinstance(idx, (int, str)) else None, points, filled,
                  _base.read_radii(entry, where))


def _written_frame(entry, where):
    """``(True, frame or None)`` when the entry's ``"sparseedm"`` object holds its
    frame, else ``(False, None)``."""
    extra = entry.get(EXTRA_KEY)
    if not isinstance(extra, dict) or "frame" not in extra:
        return False, None
    frame = extra["frame"]
    if frame is not None and (isinstance(frame, bool) or not isinstance(frame, int)):
        raise FileFormatError(f"{where}: '{EXTRA_KEY}.frame' must be an integer or null")
    return True, frame


def _frames(doc, path):
    """Each entry's frame (None without one) by the module docstring's rule,
    refusing names of two stems."""
    frames, stems = [], {}
    for i, entry in enumerate(doc):
        written, frame = _written_frame(entry, f"{path}: result {i}")
        if not written:
            stem, frame = image_frame(entry.get("image_id", ""))
            if stem is not None:
                stems.setdefault(stem, i)
        frames.append(frame)
    if len(stems) > 1:
        shown = ", ".join(repr(s) for s in sorted(stems)[:4]) + (
            ", ..." if len(stems) > 4 else "")
        raise FileFormatError(
            f"{path}: images of {len(stems)} videos (name stems {shown}); one name stem "
            "(the image name without its number) is one video: split the file, one "
            "video per file")
    return frames


def read(path, doc):
    """Read an AlphaPose results list (already loaded by the bounded reader)."""
    people = [_entry(entry, f"{path}: result {i}") for i, entry in enumerate(doc)]
    sizes = {len(p.xy) for p in people}
    if len(sizes) > 1:
        raise FileFormatError(f"{path}: results of different layouts "
                              f"({', '.join(LAYOUTS[s].name for s in sorted(sizes))})")
    layout = LAYOUTS[sizes.pop()] if sizes else COCO_17
    frames = _frames(doc, path)
    meta = {"alphapose_document": doc, "layout": layout.name}
    if not people or any(f is None for f in frames):  # photos: no frames
        tracked = people and all(p.track is not None for p in people)
        return _base.assemble(people, layout, meta, tracks=_base.person_tracks(people)
                              if tracked else None)
    for p, frame in zip(people, frames):
        p.frame = frame
    return _base.assemble(people, layout, meta, tracks=_base.person_tracks(people),
                          frames=frame_array(frames))  # huge numbers: refused per row


def write(path, rows, meta, filled_score, row_fields=None):
    """Write an AlphaPose results list: the input's with the filled joints, or a fresh one."""
    doc = meta.get("alphapose_document")
    if doc is None:
        _base.write_json(path, [_fresh_entry(rows, r) for r in range(len(rows.poses))])
        return
    doc = copy.deepcopy(doc)
    if len(doc) != len(rows.poses):
        raise FileFormatError(f"writing {path}: {len(rows.poses)} poses for {len(doc)} results")
    layout = next(lay for lay in LAYOUTS.values() if lay.name == meta["layout"])
    for r, entry in enumerate(doc):
        kp = np.asarray(entry["keypoints"], dtype=float).reshape(-1, 3)
        xy, scores = kp[:, :2].copy(), kp[:, 2].copy()
        _base.update_person(xy, scores, rows.poses[r], rows.filled[r], layout, filled_score)
        entry["keypoints"] = np.column_stack([xy, scores]).ravel().tolist()
        entry[EXTRA_KEY] = _extra(rows, r, _base.row_status(row_fields, r))
        track = _base.linked_id(rows, r, isinstance(entry.get("idx"), (int, str))
                                and not isinstance(entry.get("idx"), bool))
        if track is not None:
            entry["idx"] = track
    _base.write_json(path, doc)


def _extra(rows, r, status=None):
    """Row r's ``"sparseedm"`` object, with its frame (null without frames)."""
    out = _base.write_extra(rows.poses[r], rows.filled[r], status, rows.radii(r))
    out["frame"] = None if rows.frames is None else int(rows.frames[r])
    return out


def _fresh_entry(rows, r):
    """Row r as a COCO-17 AlphaPose result."""
    kp = np.zeros((len(COCO_17), 3))
    for j, k in COCO_17.sources().items():
        if not np.isnan(rows.poses[r, j]).any():
            kp[k] = [*rows.poses[r, j], rows.score(r, j)]
    seen = kp[:, 2] > 0
    box = [0.0, 0.0, 0.0, 0.0]
    if seen.any():
        lo, hi = kp[seen, :2].min(axis=0), kp[seen, :2].max(axis=0)
        with np.errstate(over="ignore"):  # coordinates near 1.8e308: the largest float
            size = np.minimum(hi - lo, np.finfo(float).max)
        box = [float(lo[0]), float(lo[1]), float(size[0]), float(size[1])]
    if rows.frames is not None:
        image = f"{int(rows.frames[r])}.jpg"
    else:
        image = str(rows.ids[r]) if rows.ids is not None else str(r)
    entry = {"image_id": image, "category_id": 1, "keypoints": kp.ravel().tolist(),
             "score": float(kp[seen, 2].mean()) if seen.any() else 0.0, "box": box,
             EXTRA_KEY: _extra(rows, r)}
    if rows.tracks is not None:
        entry["idx"] = _base.track_value(rows.tracks[r])
    return entry
