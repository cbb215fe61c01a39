"""MMPose prediction JSON (and files shaped like it).

Three shapes are read, all made of *instances* ``{"keypoints": [[x, y], ...],
"keypoint_scores": [s, ...], "bbox": ..., "bbox_score": ..., ["track_id": t]}``:

* the demos' ``--save-predictions`` file (``demo/topdown_demo_with_mmdet.py``,
  ``demo/bottomup_demo.py``): ``{"meta_info": {...}, "instance_info":
  [{"frame_id": f, "instances": [...]}, ...]}``;
* the ``instance_info`` list alone: ``[{"frame_id": f, "instances": [...]}, ...]``;
* an ``MMPoseInferencer`` ``pred_out_dir`` file for one image: ``[instance, ...]``;
* a folder of those, one file per image or frame (what ``pred_out_dir``
  holds after a folder of images): each file's frame number is the one in its
  name (``000012.json``, ``frame_12.json``; name order when a name has none),
  as for OpenPose folders, and as there one file stem (the name without its
  frame number) is one video: a folder of two stems is refused, naming them;
  a file with no instances (``[]``) is a frame with
  no poses. A bad file is skipped with a warning naming it, the good frames
  kept (``meta["skipped"]``); a folder with no good file is an error.

Each instance is one pose; its id and frame are the ``frame_id`` (``0`` for
the one-image shape; in a folder, the id is the file's name without
``.json``); tracks are the ``track_id`` where every instance has
one, else one track when no frame holds more than one instance, else none.
``keypoint_scores`` are the model's scores: heatmap or SimCC maxima, which
are not probabilities and can exceed 1 (RTMPose gives 1.0-1.1 for clear
joints: open-mmlab/mmpose GitHub threads 2755 and 3122), so any finite score >= 0 is
accepted; a score <= 0 is a missing keypoint. A missing ``keypoint_scores``
reads as 1 for every keypoint.

Layouts, told apart by the number of keypoints:

``COCO-17`` (17): neck = shoulders' midpoint, head top from the face (the
    COCO rule, :mod:`sparseedm.formats._base`);
``Halpe-26`` (26) and ``Halpe-136`` (136, whose first 26 are Halpe-26):
    Halpe's own ``head`` (the top of the head) and ``neck`` keypoints;
``COCO-WholeBody`` (133): its body subset (the first 17, COCO order), as COCO-17.

Writing back: the input document with, per instance, the filled keypoints
set to their recovered ``[x, y]`` and score ``filled_score``, and a
``"sparseedm"`` object (``neck``, ``head_top``, ``filled``: the 14-joint
names filled; per-row status and ``uncertainty``, the joints' 90 % radii by
name, when written by ``sparseedm recover``).
Without an MMPose input: the demos' shape, COCO-17 instances grouped by frame.
A path without ``.json`` is a folder of per-image files: a folder input's
files under the same names, else one ``<frame>.json`` per frame (written as
a whole, :func:`sparseedm.formats._base.write_json_folder`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .._safeio import load_json
from .._validation import frame_array
from ..exceptions import FileFormatError
from . import _base
from ._base import (BODY_LAYOUTS, COCO_17, COCO_WHOLEBODY, EXTRA_KEY, HALPE_26, HALPE_136,
                    Person)

__all__ = ["COCO_17", "HALPE_26", "HALPE_136", "COCO_WHOLEBODY", "LAYOUTS", "read",
           "read_folder", "write", "is_mmpose", "is_image_file", "MAX_FILES"]

#: layouts by their number of keypoints (:data:`sparseedm.formats._base.BODY_LAYOUTS`)
LAYOUTS = BODY_LAYOUTS
#: most files a folder may hold (a 9-hour video at 30 fps)
MAX_FILES = 1_000_000


def _is_instance(x):
    return isinstance(x, dict) and isinstance(x.get("keypoints"), list) and (
        not x["keypoints"] or isinstance(x["keypoints"][0], list))


def is_mmpose(doc):
    """Whether a JSON document has one of the MMPose shapes."""
    if isinstance(doc, dict):
        return isinstance(doc.get("instance_info"), list)
    if isinstance(doc, list) and doc:
        first = doc[0]
        return (isinstance(first, dict) and isinstance(first.get("instances"), list)) \
            or _is_instance(first)
    return False


def is_image_file(doc):
    """Whether a JSON document is one image's instances (``pred_out_dir``; maybe none).

    >>> is_image_file([]), is_image_file([{"keypoints": [[1, 2]]}]), is_image_file({})
    (True, True, False)
    """
    return isinstance(doc, list) and (not doc or _is_instance(doc[0]))


def _frames_of(doc, path):
    """[(frame_id, instances list)] of any of the three shapes."""
    if isinstance(doc, dict):
        doc = doc["instance_info"]
    if doc and _is_instance(doc[0]):
        return [(0, doc)]
    out = []
    for f, entry in enumerate(doc):
        where = f"{path}: instance_info[{f}]"
        if not isinstance(entry, dict) or not isinstance(entry.get("instances"), list):
            raise FileFormatError(f"{where} has no 'instances' list")
        fid = entry.get("frame_id", f)
        if isinstance(fid, bool) or not isinstance(fid, int):
            raise FileFormatError(f"{where}: 'frame_id' must be an integer")
        out.append((fid, entry["instances"]))
    return out


def _instance(inst, where, frame, pose_id=None):
    xy = _base.keypoint_rows(inst, where, "keypoints", 2, LAYOUTS,
                             "MMPose layouts read: 17 (COCO), 26 (Halpe), 133 "
                             "(COCO-WholeBody), 136 (Halpe-136) [x, y] pairs")
    k = len(xy)
    if "keypoint_scores" in inst:
        scores = _base.numbers(inst["keypoint_scores"], where, "keypoint_scores", k)
        _base.check_scores(scores, where, "keypoint_scores")
    else:
        scores = np.ones(k)
    track = inst.get("track_id")
    if track is not None and (isinstance(track, bool) or not isinstance(track, (int, str))):
        raise FileFormatError(f"{where}: 'track_id' must be an integer or a string")
    points, filled = _base.read_extra(inst, where)
    return Person(xy, scores, str(frame) if pose_id is None else pose_id, frame, track,
                  points, filled, _base.read_radii(inst, where))


def read(path, doc):
    """Read an MMPose document (already loaded by the bounded reader)."""
    people = []
    for fid, instances in _frames_of(doc, path):
        for i, inst in enumerate(instances):
            people.append(_instance(inst, f"{path}: frame {fid}, instance {i}", fid))
    return _assembled(people, path, {"mmpose_document": doc})


def read_folder(path):
    """Read a folder of per-image MMPose files (see the module docstring)."""
    people, files, skipped, ignored = _base.read_frame_folder(
        path, _image_file, "MMPose per-image files", MAX_FILES)
    return _assembled(people, path, {"mmpose_files": files, "skipped": skipped,
                                     "ignored": ignored})


def _image_file(path, frame):
    """The instances of one per-image file (its frame from its name) and its document."""
    doc = load_json(path)
    if not is_image_file(doc):
        raise FileFormatError(f"{path}: not an MMPose per-image file (a list of instances "
                              "with [x, y] keypoints)")
    return [_instance(inst, f"{path}: instance {i}", frame, path.stem)
            for i, inst in enumerate(doc)], doc


def _assembled(people, path, meta):
    """The :class:`_base.Parsed` of the instances of a file or folder."""
    sizes = {len(p.xy) for p in people}
    if len(sizes) > 1:
        raise FileFormatError(f"{path}: instances of different layouts "
                              f"({', '.join(LAYOUTS[s].name for s in sorted(sizes))})")
    layout = LAYOUTS[sizes.pop()] if sizes else COCO_17
    meta["layout"] = layout.name
    frames = frame_array([p.frame for p in people])  # huge numbers: refused per row
    return _base.assemble(people, layout, meta, tracks=_base.person_tracks(people),
                          frames=frames)


def write(path, rows, meta, filled_score, row_fields=None):
    """Write MMPose JSON: the input's document with the filled joints, or a fresh one;
    a path without ``.json``: a folder of per-image files."""
    if Path(path).suffix.lower() != ".json":
        files = meta.get("mmpose_files")
        _base.write_json_folder(path, _fresh_files(rows) if files is None else
                                _updated_files(files, rows, meta, filled_score, row_fields))
        return
    doc = meta.get("mmpose_document")
    if doc is None:
        doc = _fresh(rows)
    else:
        doc = json.loads(json.dumps(doc))
        layout = next(lay for lay in LAYOUTS.values() if lay.name == meta["layout"])
        r = 0
        for _, instances in _frames_of(doc, Path(path)):
            for inst in instances:
                if r >= len(rows.poses):
                    raise FileFormatError(f"writing {path}: fewer poses than instances")
                _update(inst, rows, r, layout, filled_score, row_fields)
                r += 1
        if r != len(rows.poses):
            raise FileFormatError(f"writing {path}: {len(rows.poses)} poses for {r} instances")
    _base.write_json(path, doc)


def _update(inst, rows, r, layout, filled_score, row_fields):
    xy = np.asarray(inst["keypoints"], dtype=float).reshape(-1, 2)
    k = len(xy)
    scores = np.asarray(inst.get("keypoint_scores", [1.0] * k), dtype=float)
    _base.update_person(xy, scores, rows.poses[r], rows.filled[r], layout, filled_score)
    inst["keypoints"] = xy.tolist()
    inst["keypoint_scores"] = scores.tolist()
    inst[EXTRA_KEY] = _base.write_extra(rows.poses[r], rows.filled[r],
                                        _base.row_status(row_fields, r), rows.radii(r))
    track = _base.linked_id(rows, r, inst.get("track_id") is not None)
    if track is not None:
        inst["track_id"] = track


def _updated_files(files, rows, meta, filled_score, row_fields):
    """[(name, document)] of a folder input's files with the filled joints."""
    total = sum(f["rows"] for f in files)
    if total != len(rows.poses):
        raise FileFormatError(f"{len(rows.poses)} poses for the {total} instances read")
    layout = next(lay for lay in LAYOUTS.values() if lay.name == meta["layout"])
    docs, r = [], 0
    for f in files:
        doc = json.loads(json.dumps(f["doc"]))
        for inst in doc:
            _update(inst, rows, r, layout, filled_score, row_fields)
            r += 1
        docs.append((f["name"], doc))
    return docs


def _fresh_instance(rows, r):
    """Row r as a COCO-17 instance."""
    xy, scores = np.zeros((17, 2)), np.zeros(17)
    for j, k in COCO_17.sources().items():
        if not np.isnan(rows.poses[r, j]).any():
            xy[k], scores[k] = rows.poses[r, j], rows.score(r, j)
    inst = {"keypoints": xy.tolist(), "keypoint_scores": scores.tolist(),
            EXTRA_KEY: _base.write_extra(rows.poses[r], rows.filled[r],
                                         radii=rows.radii(r))}
    if rows.tracks is not None:
        inst["track_id"] = _base.track_value(rows.tracks[r])
    return inst


def _fresh(rows):
    groups, frames = _base.frame_rows(rows.frames, len(rows.poses))
    info = [{"frame_id": int(frame), "instances": [_fresh_instance(rows, r) for r in members]}
            for members, frame in zip(groups, frames)]
    return {"meta_info": {"dataset_name": "coco"}, "instance_info": info}


def _fresh_files(rows):
    """[(name, instances)]: one per-image file per frame, named by its number."""
    groups, frames = _base.frame_rows(rows.frames, len(rows.poses))
    return [(f"{int(frame):012d}.json", [_fresh_instance(rows, r) for r in members])
            for members, frame in zip(groups, frames)]
