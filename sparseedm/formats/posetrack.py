"""PoseTrack: COCO keypoint JSON with ``track_id`` (results or ground truth).

PoseTrack 2018/21 files are COCO documents whose annotations carry a
``track_id`` (the person over time) and whose ``images`` carry a
``frame_id`` (and ``vid_id``); results files are COCO results lists with
``track_id``. :mod:`sparseedm.keypoints` reads and writes them as COCO (the
document is written back whole, ``track_id`` included); this module adds:

* ``tracks``: each annotation's ``track_id``;
* ``frames``: the ``frame_id`` of its image when the document lists
  ``images``, else its ``image_id`` when that is an integer, else the
  annotation's position; without any ``track_id``, the ``frame_id`` of each
  annotation's image when every one has one (frames not yet tracked, as the
  writer gives poses with frames and no tracks), else none;
* PoseTrack's own keypoint order, used when the document's category names
  its keypoints with ``head_bottom`` and ``head_top`` (PoseTrack's 17:
  nose, head_bottom, head_top, ears, then COCO's limbs): ``head_top`` is then
  the file's own keypoint; the neck stays the shoulders' midpoint (PoseTrack's
  head_bottom is the chin, not the neck's base).

A ``track_id`` that is not an integer or a string, or present on some
annotations and not others, is an error naming the annotation.

One file is one video: PoseTrack numbers tracks and frames per video, so
annotations on the images of two ``vid_id`` values would link one video's
people to the other's; such a file is refused, naming the ``vid_id`` values
(split it, one file per ``vid_id``).
"""

from __future__ import annotations

import numpy as np

from .._validation import frame_array
from ..exceptions import FileFormatError

__all__ = ["POSETRACK_KEYPOINTS", "tracks_and_frames", "uses_posetrack_order",
           "HEAD_TOP_INDEX"]

POSETRACK_KEYPOINTS = (
    "nose", "head_bottom", "head_top", "left_ear", "right_ear",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
    "left_wrist", "right_wrist", "left_hip", "right_hip",
    "left_knee", "right_knee", "left_ankle", "right_ankle")
#: index of head_top among PoseTrack's keypoints
HEAD_TOP_INDEX = 2


def uses_posetrack_order(doc):
    """Whether a COCO document's category names PoseTrack's keypoints."""
    if not isinstance(doc, dict):
        return False
    for cat in doc.get("categories") or []:
        if isinstance(cat, dict) and isinstance(cat.get("keypoints"), list):
            return "head_top" in cat["keypoints"] and "head_bottom" in cat["keypoints"]
    return False


def tracks_and_frames(doc, anns, path):
    """``(tracks, frames)`` of a COCO document's annotations: ``(None, frames)``
    when no annotation has a ``track_id`` but every one's image has a
    ``frame_id`` (frames not yet tracked), ``(None, None)`` when neither.

    Examples
    --------
    >>> doc = {"images": [{"id": 10, "frame_id": 3}],
    ...        "annotations": [{"image_id": 10, "track_id": 1, "keypoints": []}]}
    >>> tracks_and_frames(doc, doc["annotations"], "x.json")
    (array([1]), array([3]))
    >>> del doc["annotations"][0]["track_id"]
    >>> tracks_and_frames(doc, doc["annotations"], "x.json")
    (None, array([3]))
    """
    have = [isinstance(a, dict) and "track_id" in a for a in anns]
    if not any(have):
        return None, _untracked_frames(doc, anns, path)
    if not all(have):
        a = have.index(False)
        raise FileFormatError(f"{path}: annotation {a} has no 'track_id' while others do")
    tracks = []
    for a, ann in enumerate(anns):
        t = ann["track_id"]
        if isinstance(t, bool) or not isinstance(t, (int, str)):
            raise FileFormatError(f"{path}: annotation {a}: 'track_id' must be an integer "
                                  "or a string")
        tracks.append(t)
    frame_of, video_of = _images(doc)
    _one_video(anns, video_of, path)
    frames = []
    for a, ann in enumerate(anns):
        image = ann.get("image_id")
        if image in frame_of:
            frames.append(frame_of[image])
        elif isinstance(image, int) and not isinstance(image, bool):
            frames.append(image)
        else:
            frames.append(a)
    kinds = {type(t) for t in tracks}
    tracks = np.asarray(tracks if len(kinds) == 1 else [str(t) for t in tracks])
    return tracks, frame_array(frames)  # huge numbers: refused per row


def _images(doc):
    """``{image id: frame_id}`` and ``{image key: vid_id}`` of a document's ``images``."""
    frame_of, video_of = {}, {}
    if isinstance(doc, dict) and isinstance(doc.get("images"), list):
        for img in doc["images"]:
            if isinstance(img, dict) and isinstance(img.get("frame_id"), int):
                frame_of[img.get("id")] = img["frame_id"]
            if isinstance(img, dict) and "vid_id" in img:
                video_of[_key(img.get("id"))] = img["vid_id"]
    return frame_of, video_of


def _untracked_frames(doc, anns, path):
    """The frames of annotations without ``track_id`` when every one's image has a
    ``frame_id`` (what the writer gives frames without tracks); else None (a
    plain COCO file: its ``image_id`` values are no frame numbers)."""
    frame_of, video_of = _images(doc)
    if not anns or not frame_of:
        return None
    images = [a.get("image_id") if isinstance(a, dict) else None for a in anns]
    if not all(isinstance(i, (int, str)) and not isinstance(i, bool) and i in frame_of
               for i in images):
        return None
    _one_video(anns, video_of, path)
    return frame_array([frame_of[i] for i in images])


def _key(value):
    """A hashable stand-in for an image id (ids of a hostile file may be lists)."""
    return repr(value)


def _one_video(anns, video_of, path):
    """Refuse annotations on the images of more than one ``vid_id``."""
    videos = {}
    for ann in anns:
        vid = video_of.get(_key(ann.get("image_id")))
        if vid is not None:
            videos.setdefault(repr(vid), vid)
    if len(videos) > 1:
        shown = sorted(videos)
        raise FileFormatError(
            f"{path}: annotations of {len(shown)} videos (vid_id "
            f"{', '.join(shown[:4])}{', ...' if len(shown) > 4 else ''}); PoseTrack "
            "numbers tracks and frames per video, so one file is one video: split "
            "the file, one per vid_id")
