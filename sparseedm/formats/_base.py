"""Pieces the detector/tracker format modules share (private to :mod:`sparseedm.formats`).

A :class:`Layout` names a format's keypoints and says how the 14 joints of
:data:`~sparseedm.skeleton.SKELETON_14` come from them; :func:`to_14` applies it
and :func:`from_14` goes back. :class:`Parsed` is what every format reader
returns (plain arrays; :mod:`sparseedm.keypoints` turns it into a
``KeypointSet`` and applies the confidence threshold). The JSON helpers read a
person's scores and the ``"sparseedm"`` object this package writes.

The rules of :func:`to_14` (the same as COCO-17's in :mod:`sparseedm.keypoints`):

* shoulders, elbows, wrists, hips, knees, ankles: copied by name;
* ``neck``: the layout's own neck keypoint where it has one that sits at the
  base of the neck (OpenPose ``Neck``, Halpe ``neck``); otherwise the midpoint
  of the two shoulders (missing if either is), confidence the smaller;
* ``head_top``: the layout's own head-top keypoint where it has one (Halpe
  ``head``, OpenPose BODY_135 ``HeadTop``, PoseTrack ``head_top``); otherwise
  ``H + HEAD_TOP_FACTOR * (H - neck)`` with ``H`` the mean of the present face
  keypoints (nose, eyes, ears), missing without a face keypoint or a neck,
  confidence the smallest used.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from pathlib import Path
from dataclasses import dataclass, field
from numbers import Real

import numpy as np

from .._atomic import atomic_folder, json_text, save_json
from ..exceptions import FileFormatError
from ..skeleton import JOINT_NAMES, SKELETON_14

N_JOINTS = SKELETON_14.num_joints
NECK = SKELETON_14.index("neck")
HEAD_TOP = SKELETON_14.index("head_top")
#: head_top = H + HEAD_TOP_FACTOR * (H - neck) (as sparseedm.keypoints.HEAD_TOP_FACTOR)
HEAD_TOP_FACTOR = 0.8
#: the 12 limb joints every layout has by name
LIMBS = tuple(n for n in JOINT_NAMES if n not in ("neck", "head_top"))
FACE = ("nose", "left_eye", "right_eye", "left_ear", "right_ear")
#: the key of the object this package adds to a person / instance / annotation
EXTRA_KEY = "sparseedm"


@dataclass(frozen=True)
class Layout:
    """A keypoint layout: its names in file order and where its 14 joints come from.

    Parameters
    ----------
    name : str
    keypoints : tuple of str
        Keypoint names in file order, in sparseedm's spelling (``left_wrist``).
    neck, head_top : str or None
        The keypoint that is the neck / head top itself, or None (derived).
    """

    name: str
    keypoints: tuple
    neck: str | None = None
    head_top: str | None = None

    def __len__(self):
        return len(self.keypoints)

    def index(self, name):
        return self.keypoints.index(name)

    def sources(self):
        """14-joint index -> keypoint index, for the joints stored as keypoints."""
        out = {SKELETON_14.index(n): self.index(n) for n in LIMBS}
        if self.neck is not None:
            out[NECK] = self.index(self.neck)
        if self.head_top is not None:
            out[HEAD_TOP] = self.index(self.head_top)
        return out


COCO17 = ("nose", "left_eye", "right_eye", "left_ear", "right_ear",
          "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
          "left_wrist", "right_wrist", "left_hip", "right_hip",
          "left_knee", "right_knee", "left_ankle", "right_ankle")
#: the COCO-17 layout (COCO results / ground truth, MMPose's and AlphaPose's COCO models)
COCO_17 = Layout("COCO-17", COCO17)
_HALPE_EXTRA = ("head", "neck", "hip", "left_big_toe", "right_big_toe", "left_small_toe",
                "right_small_toe", "left_heel", "right_heel")
#: Halpe-26 (MMPose's and AlphaPose's Halpe models): COCO-17, then head (its top), neck,
#: hip, big toes, small toes, heels
HALPE_26 = Layout("Halpe-26", COCO17 + _HALPE_EXTRA, neck="neck", head_top="head")
#: Halpe-136: Halpe-26, then 68 face and 2 x 21 hand keypoints
HALPE_136 = Layout("Halpe-136", HALPE_26.keypoints + tuple(f"face_or_hand_{i}"
                                                           for i in range(110)),
                   neck="neck", head_top="head")
#: COCO-WholeBody: COCO-17, then 6 foot, 68 face and 2 x 21 hand keypoints
COCO_WHOLEBODY = Layout("COCO-WholeBody", COCO17 + tuple(f"foot_face_or_hand_{i}"
                                                         for i in range(116)))
#: the COCO and Halpe layouts by their number of keypoints (MMPose, AlphaPose)
BODY_LAYOUTS = {len(lay): lay for lay in (COCO_17, HALPE_26, HALPE_136, COCO_WHOLEBODY)}


@dataclass
class Parsed:
    """What a format reader returns: keypoints already in the 14-joint layout.

    ``poses`` hold the file's coordinates (not yet blanked by the threshold),
    ``present`` says which joints the file gives at all, ``filled`` which ones
    the file flags as filled by sparseedm (read as present whatever their
    score), ``stored`` the neck / head top sparseedm wrote in its own object
    (present whatever the score of the keypoints they would be derived from,
    as in COCO files). ``meta`` holds what the writer needs to write the file back.

    Parameters
    ----------
    poses : ndarray, shape (n, 14, 2)
        Coordinates as the file gives them.
    present : ndarray of bool, shape (n, 14)
        Joints the file gives.
    confidence : ndarray, shape (n, 14), or None
        Scores read.
    ids, tracks, frames : ndarray, shape (n,), optional
        Each pose's id, track and frame number.
    filled : ndarray of bool, shape (n, 14), optional
        Joints the file flags as filled.
    meta : dict
        What the writer needs to write the file back.
    stored : ndarray of bool, shape (n, 14), optional
        The neck / head top sparseedm wrote in its own object.
    uncertainty : ndarray, shape (n, 14), optional
        The 90 % radii sparseedm wrote in its own object (NaN: none).
    """

    poses: np.ndarray
    present: np.ndarray
    confidence: np.ndarray | None
    ids: np.ndarray | None = None
    tracks: np.ndarray | None = None
    frames: np.ndarray | None = None
    filled: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    stored: np.ndarray | None = None
    uncertainty: np.ndarray | None = None


def csv_cells(values):
    """Rows of CSV cells of a 2-D float array: the shortest repr that reads back
    exactly, blank for NaN (the keypoint CSV and DeepLabCut's CSV writers).

    Examples
    --------
    >>> csv_cells([[0.1, float("nan")], [2.0, -3.5]])
    [['0.1', ''], ['2.0', '-3.5']]
    """
    return [["" if v != v else repr(v) for v in row] for row in np.asarray(
        values, dtype=float).tolist()]


def to_14(xy, score, present, layout):
    """Map (n, K, 2) keypoints with (n, K) scores onto the 14 joints.

    Returns ``(poses, present, confidence)`` of shapes (n, 14, 2), (n, 14),
    (n, 14); ``poses`` is NaN where a joint is not present.

    Parameters
    ----------
    xy : ndarray, shape (n, K, 2)
        Keypoints in the file's layout.
    score : ndarray, shape (n, K)
        Their scores.
    present : ndarray of bool, shape (n, K)
        Keypoints the file gives.
    layout : Layout
        The file's keypoint layout and its rules for neck and head top.

    Returns
    -------
    poses, present, confidence : ndarray
        Shapes (n, 14, 2), (n, 14) and (n, 14).

    Examples
    --------
    >>> lay = Layout("demo", COCO17)
    >>> xy = np.zeros((1, 17, 2)); xy[0, 5] = (0, 10); xy[0, 6] = (4, 10)
    >>> poses, present, conf = to_14(xy, np.ones((1, 17)), np.ones((1, 17), bool), lay)
    >>> poses[0, NECK].tolist(), bool(present[0, NECK])
    ([2.0, 10.0], True)
    """
    n = len(xy)
    poses = np.full((n, N_JOINTS, 2), np.nan)
    conf = np.zeros((n, N_JOINTS))
    ok = np.zeros((n, N_JOINTS), dtype=bool)
    for j, k in layout.sources().items():
        poses[:, j], conf[:, j], ok[:, j] = xy[:, k], score[:, k], present[:, k]
    ls, rs = layout.index("left_shoulder"), layout.index("right_shoulder")
    if layout.neck is None:
        ok[:, NECK] = present[:, ls] & present[:, rs]
        poses[:, NECK] = xy[:, ls] / 2 + xy[:, rs] / 2  # no overflow near 1.8e308
        conf[:, NECK] = np.minimum(score[:, ls], score[:, rs])
    if layout.head_top is None:
        face = [layout.index(f) for f in FACE if f in layout.keypoints]
        seen = present[:, face]
        count = seen.sum(axis=1)
        total = np.where(seen[..., None], xy[:, face], 0.0).sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            centre = total / count[:, None]  # past the float range: inf, a bad row
            poses[:, HEAD_TOP] = centre + HEAD_TOP_FACTOR * (centre - poses[:, NECK])
        low = np.where(seen, score[:, face], np.inf).min(axis=1)
        conf[:, HEAD_TOP] = np.where(count > 0, np.minimum(low, conf[:, NECK]), 0.0)
        ok[:, HEAD_TOP] = ok[:, NECK] & (count > 0)
    poses = np.where(ok[..., None], poses, np.nan)
    return poses, ok, conf


# --------------------------------------------------------------------------
# checks


def check_scores(scores, where, field_name, *, upper=None):
    """Scores must be finite numbers >= 0 (and <= `upper` when given)."""
    scores = np.asarray(scores, dtype=float)
    bad = ~np.isfinite(scores) | (scores < 0)
    if upper is not None:
        bad |= scores > upper
    if bad.any():
        k = tuple(int(i) for i in np.argwhere(bad)[0])
        value = float(scores[k])
        rule = f"in [0, {upper}]" if upper is not None else "finite and >= 0"
        raise FileFormatError(
            f"{where}: '{field_name}' value {k[-1]} is {value!r}; scores must be {rule}")
    return scores


def numbers(values, where, field_name, count=None):
    """A JSON list of plain numbers (no strings, booleans, null) as a float array."""
    if not isinstance(values, list):
        raise FileFormatError(f"{where}: '{field_name}' must be a list, got "
                              f"{type(values).__name__}")
    flat = values
    if flat and isinstance(flat[0], list):  # pairs [[x, y], ...]
        if not all(isinstance(v, list) for v in flat):
            raise FileFormatError(f"{where}: '{field_name}' mixes pairs and numbers")
        flat = [x for v in flat for x in v]
    bad = next((i for i, x in enumerate(flat)
                if isinstance(x, bool) or not isinstance(x, Real)), None)
    if bad is not None:
        raise FileFormatError(
            f"{where}: '{field_name}' value {bad} is {type(flat[bad]).__name__} "
            f"{str(flat[bad])[:20]!r}; keypoints must be numbers")
    arr = np.asarray(flat, dtype=float)
    if not np.isfinite(arr).all():
        raise FileFormatError(f"{where}: '{field_name}' holds a non-finite value")
    if count is not None and arr.size != count:
        raise FileFormatError(f"{where}: '{field_name}' has {arr.size} values, "
                              f"expected {count}")
    return arr


def keypoint_rows(obj, where, key, width, layouts, described):
    """``obj[key]`` as a (K, width) array, K one of `layouts`' sizes; `obj` an object."""
    if not isinstance(obj, dict):
        raise FileFormatError(f"{where} is not an object")
    if key not in obj:
        keys = ", ".join(repr(k) for k in list(obj)[:8]) or "none"
        raise FileFormatError(f"{where} has no '{key}' (its keys: {keys})")
    values = numbers(obj[key], where, key)
    if values.size % width or values.size // width not in layouts:
        raise FileFormatError(f"{where}: '{key}' has {values.size} values; {described}")
    return values.reshape(-1, width)


def read_extra(person, where):
    """The ``"sparseedm"`` object of a person: {joint index: (x, y)} overrides for
    neck / head top (None: written missing, not derived again), and the 14-joint
    indices flagged filled.

    Parameters
    ----------
    person : dict
        One person (instance) of a JSON format.
    where : str
        What to name in an error message.

    Returns
    -------
    points : dict
        {joint index: (x, y) or None (missing)}.
    filled : list of int
        Joint indices flagged filled.
    """
    extra = person.get(EXTRA_KEY)
    if not isinstance(extra, dict):
        return {}, []
    points = {}
    for j, key in ((NECK, "neck"), (HEAD_TOP, "head_top")):
        if key not in extra:
            continue
        value = extra[key]
        if value is None:  # written missing: not derived from the keypoints again
            points[j] = None
            continue
        if (not isinstance(value, list) or len(value) != 2
                or not all(isinstance(x, Real) and not isinstance(x, bool)
                           and math.isfinite(x) for x in value)):
            raise FileFormatError(f"{where}: '{EXTRA_KEY}.{key}' must be [x, y] "
                                  "(two finite numbers) or null")
        points[j] = value
    filled = extra.get("filled", [])
    if not isinstance(filled, list) or not all(f in JOINT_NAMES for f in filled):
        raise FileFormatError(f"{where}: '{EXTRA_KEY}.filled' must list joint names "
                              f"({', '.join(JOINT_NAMES)})")
    return points, [JOINT_NAMES.index(f) for f in filled]


def radii_object(row):
    """A pose's ``"uncertainty"`` in its ``"sparseedm"`` object: {joint name:
    radius} of the joints whose radius is known (0 observed); None when none is
    (a refused pose)."""
    row = np.asarray(row, float)
    if np.isnan(row).all():
        return None
    return {JOINT_NAMES[j]: float(row[j]) for j in np.flatnonzero(~np.isnan(row))}


def read_radii(person, where):
    """(14,) radii of a person's ``"sparseedm"."uncertainty"`` (NaN for a joint
    not listed, all NaN for null), or None without one."""
    extra = person.get(EXTRA_KEY)
    if not isinstance(extra, dict) or "uncertainty" not in extra:
        return None
    value = extra["uncertainty"]
    out = np.full(N_JOINTS, np.nan)
    if value is None:
        return out
    if not isinstance(value, dict) or not all(
            k in JOINT_NAMES and isinstance(v, Real) and not isinstance(v, bool)
            and math.isfinite(v) and v >= 0 for k, v in value.items()):
        raise FileFormatError(f"{where}: '{EXTRA_KEY}.uncertainty' must map joint names to "
                              "radii >= 0, or be null")
    for k, v in value.items():
        out[JOINT_NAMES.index(k)] = v
    return out


def write_extra(pose, filled_row, status=None, radii=None):
    """The ``"sparseedm"`` object written with a person: neck, head top, filled
    joints, and the joints' 90 % radii when given (:func:`radii_object`)."""
    def xy(p):
        return None if np.isnan(p).any() else [float(p[0]), float(p[1])]

    out = {"neck": xy(pose[NECK]), "head_top": xy(pose[HEAD_TOP]),
           "filled": [JOINT_NAMES[j] for j in np.flatnonzero(filled_row)]}
    if status:
        out.update(status)
    if radii is not None:
        out["uncertainty"] = radii_object(radii)
    return out


def folder_files(path, max_files):
    """``([(frame, name), ...] in frame order, [ignored names])`` of a folder of
    per-frame ``.json`` files: the frame number in each name
    (:func:`frame_number`), or name order when some name has none; hidden
    files are skipped, other files ignored.

    One file stem (the name without its frame number, :func:`file_stem`) is
    one video: a folder whose numbered names have two stems
    (``camA_000000000001_keypoints.json``, ``camB_000000000001_keypoints.json``)
    holds two videos and is refused, naming the stems (split it, one video per
    folder), rather than read as one video whose people are linked across both.
    """
    names, ignored = [], []
    with os.scandir(path) as it:
        for entry in it:
            if len(names) + len(ignored) >= max_files:
                raise FileFormatError(f"{path}: more than {max_files} files; split the folder")
            if entry.name.startswith("."):
                continue
            (names if entry.name.lower().endswith(".json") and entry.is_file()
             else ignored).append(entry.name)
    numbered = [(frame_number(n), n) for n in names]
    _one_video(path, names)
    if any(f is None for f, _ in numbered):  # no numbers in some names: name order
        numbered = [(i, n) for i, n in enumerate(sorted(names))]
    return sorted(numbered), sorted(ignored)


def _one_video(path, names):
    """Refuse a folder whose numbered file names have more than one stem."""
    stems = sorted({s for s in map(file_stem, names) if s is not None})
    if len(stems) > 1:
        shown = ", ".join(repr(s) for s in stems[:4]) + (", ..." if len(stems) > 4 else "")
        raise FileFormatError(
            f"{path}: files of {len(stems)} videos (file stems {shown}); one file stem "
            "(the name without its frame number) is one video: split the folder, one "
            "video per folder")


def read_frame_folder(path, read_file, what, max_files):
    """The people of a folder of per-frame files, ``(people, files, skipped, ignored)``.

    ``read_file(file path, frame) -> (people, document)`` reads one file; a bad
    file (a :class:`FileFormatError`) is skipped with a warning naming it and
    listed in `skipped` ``[(name, message)]``; `files` are ``{"name", "doc",
    "rows"}`` of the good ones, in frame order. A folder with no good file is a
    FileFormatError saying it holds no readable `what` (and the first problem).
    """
    numbered, ignored = folder_files(path, max_files)
    people, files, skipped = [], [], []
    for frame, name in numbered:
        try:
            got, doc = read_file(Path(path) / name, frame)
        except FileFormatError as exc:
            skipped.append((name, str(exc)))
            continue
        people += got
        files.append({"name": name, "doc": doc, "rows": len(got)})
    if not files:
        why = f"; first: {skipped[0][1]}" if skipped else ""
        raise FileFormatError(f"{path}: no readable {what} (*.json){why}")
    for name, msg in skipped:  # sparseedm recover lists them in its summary too
        warnings.warn(f"skipped {msg}", stacklevel=4)
    return people, files, skipped, ignored


#: ASCII digits only (a full-width "１２" is no frame number, as in a CSV cell)
_FRAME_NUMBER = re.compile(r"(\d+)(?=_keypoints\.json$)|(\d+)(?=\.json$)", re.ASCII)


def frame_number(name):
    """The frame number in a per-frame file name, or None (a Python int of any
    size: one past 2**53 is refused per row, as any frame number, by
    :func:`sparseedm._validation.frame_value`).

    >>> frame_number("video_000000000012_keypoints.json")
    12
    >>> frame_number("notes.json") is None
    True
    """
    m = _FRAME_NUMBER.search(name)
    return None if m is None else int(m.group(1) or m.group(2))


def file_stem(name):
    """A per-frame file name with its frame number replaced by ``*``, or None
    when it has none: files of one video share it.

    >>> file_stem("camA_000000000012_keypoints.json")
    'camA_*_keypoints.json'
    >>> file_stem("notes.json") is None
    True
    """
    m = _FRAME_NUMBER.search(name)
    return None if m is None else f"{name[:m.start()]}*{name[m.end():]}"


# --------------------------------------------------------------------------
# people: one detected person per row, from the JSON formats


@dataclass
class Person:
    """One person of a JSON format, in its own layout (K keypoints)."""

    xy: np.ndarray
    score: np.ndarray
    id: str
    frame: int | None = None
    track: object = None
    points: dict = field(default_factory=dict)
    filled: list = field(default_factory=list)
    radii: np.ndarray | None = None


def assemble(people, layout, meta, *, tracks=None, frames=None):
    """Stack `people` (all in `layout`) into a :class:`Parsed`.

    A keypoint is present when its score is positive; the ``"sparseedm"``
    neck / head top of a person replace the derived ones, and its filled
    joints are present whatever their score.
    """
    n, k = len(people), len(layout)
    xy = np.zeros((n, k, 2))
    score = np.zeros((n, k))
    seen = np.zeros((n, k), dtype=bool)
    sources = layout.sources()
    for r, p in enumerate(people):
        xy[r], score[r] = p.xy, p.score
        seen[r] = p.score > 0
        seen[r, [sources[j] for j in p.filled if j in sources]] = True  # flagged: present
    poses, present, conf = to_14(xy, score, seen, layout)
    filled = np.zeros((n, N_JOINTS), dtype=bool)
    stored = np.zeros((n, N_JOINTS), dtype=bool)
    for r, p in enumerate(people):
        for j, value in p.points.items():
            poses[r, j] = np.nan if value is None else value
            present[r, j] = stored[r, j] = value is not None
        filled[r, p.filled] = True
    filled &= ~np.isnan(poses).any(axis=-1)
    present |= filled
    ids = np.asarray([p.id for p in people], dtype=str).reshape(n)
    radii = None
    if any(p.radii is not None for p in people):
        radii = np.stack([np.full(N_JOINTS, np.nan) if p.radii is None else p.radii
                          for p in people])
    return Parsed(poses, present, conf, ids, tracks, frames, filled if filled.any() else None,
                  meta, stored if stored.any() else None, radii)


def update_person(xy, score, pose, filled_row, layout, filled_score):
    """Write the filled joints of a 14-joint `pose` into a person's keypoints (in place)."""
    for j, k in layout.sources().items():
        if filled_row[j] and not np.isnan(pose[j]).any():
            xy[k] = pose[j]
            score[k] = filled_score


def person_tracks(people):
    """Tracks for the people of a file or folder: their ids where every person has
    one (>= 0); else one track (0) when no frame holds more than one person;
    else None (persons cannot be told apart)."""
    if not people:
        return None
    if all(p.track is not None for p in people):
        return np.asarray([p.track for p in people])
    frames = [p.frame for p in people]
    if all(p.track is None for p in people) and len(set(frames)) == len(frames):
        return np.zeros(len(people), dtype=np.int64)
    return None


def track_value(track):
    """A track id as JSON writes it: an int for integer ids, else text.

    Examples
    --------
    >>> track_value(np.int64(3)), track_value("p1")
    (3, 'p1')
    """
    return int(track) if np.asarray(track).dtype.kind in "iu" else str(track)


def linked_id(rows, r, present):
    """The track id to write into row `r`'s document where it has none
    (`present` False): the tracks :func:`sparseedm.temporal.linking.link_tracks`
    gave a file without ids. None: leave the document as read."""
    if present or rows.tracks is None:
        return None
    return track_value(rows.tracks[r])


def frame_rows(frames, n):
    """Row index of each pose's frame group, for writers without a document."""
    if frames is None:
        return [[r] for r in range(n)], list(range(n))
    order = {}
    for r, f in enumerate(frames):
        order.setdefault(int(f), []).append(r)
    keys = sorted(order)
    return [order[f] for f in keys], keys


# --------------------------------------------------------------------------
# writing


@dataclass
class Rows:
    """What a format writer gets: n poses in the 14-joint layout.

    ``poses`` NaN where missing; ``filled`` the joints sparseedm filled;
    ``confidence`` the scores read (or None); ``filled_score`` the score a
    filled joint is written with.

    Parameters
    ----------
    poses : ndarray, shape (n, 14, 2)
        Coordinates, NaN where missing.
    filled : ndarray of bool, shape (n, 14)
        Joints sparseedm filled.
    confidence : ndarray, shape (n, 14), optional
        Scores read.
    ids, tracks, frames : ndarray, shape (n,), optional
        Each pose's id, track and frame number.
    filled_score : float
        Score a filled joint is written with.
    likelihood : ndarray, shape (n, 14), optional
        DeepLabCut: the likelihood each filled joint is written with instead
        (:func:`filled_likelihood`).
    uncertainty : ndarray, shape (n, 14), optional
        The 90 % radii, written in each person's ``"sparseedm"`` object
        (OpenPose, MMPose).
    """

    poses: np.ndarray
    filled: np.ndarray
    confidence: np.ndarray | None = None
    ids: np.ndarray | None = None
    tracks: np.ndarray | None = None
    frames: np.ndarray | None = None
    filled_score: float = 0.0
    likelihood: np.ndarray | None = None
    uncertainty: np.ndarray | None = None

    def radii(self, r):
        """Pose r's radii for :func:`write_extra` (None without any)."""
        return None if self.uncertainty is None else self.uncertainty[r]

    def score(self, r, j):
        """The score written for joint j of pose r (present joints only)."""
        if self.filled[r, j]:
            return float(self.filled_score)
        if self.confidence is not None and np.isfinite(self.confidence[r, j]):
            return float(self.confidence[r, j])
        return 1.0


#: the highest likelihood a filled joint gets in a DeepLabCut table: below
#: DeepLabCut's default ``pcutoff`` (0.6), so a filled joint never passes for a detection
FILLED_LIKELIHOOD_CAP = 0.5


def filled_likelihood(poses, uncertainty, filled_score=0.0):
    """DeepLabCut's likelihood of filled joints from their 90 % radius:
    ``max(filled_score, FILLED_LIKELIHOOD_CAP * exp(-radius / size))``, ``size``
    the pose's root-mean-square distance of its joints to their centroid;
    `filled_score` where the radius is unknown (NaN).

    Parameters
    ----------
    poses : ndarray (n, 14, 2)
        The filled poses (NaN where missing).
    uncertainty : ndarray (n, 14)
        The 90 % radii, the poses' units.
    filled_score : float, default 0.0

    Returns
    -------
    ndarray (n, 14)

    Examples
    --------
    >>> pose = np.array([[[0.0, 0.0], [2.0, 0.0]]])
    >>> filled_likelihood(pose, np.array([[0.0, 1.0]])).round(3).tolist()
    [[0.5, 0.184]]
    """
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a pose with no joint: NaN
        centred = poses - np.nanmean(poses, axis=1, keepdims=True)
        size = np.sqrt(np.nanmean((centred ** 2).sum(axis=-1), axis=1))[:, None]
        like = FILLED_LIKELIHOOD_CAP * np.exp(-np.asarray(uncertainty, float) / size)
    return np.where(np.isfinite(like), np.maximum(like, filled_score), filled_score)


def row_status(row_fields, r):
    """Row r of per-row result fields (status, reason, ...) as JSON values."""
    if not row_fields:
        return None
    out = {}
    for key, values in row_fields.items():
        v = values[r]
        if isinstance(v, (np.integer, int)) and not isinstance(v, bool):
            out[key] = int(v)
        elif isinstance(v, (np.floating, float)):
            out[key] = None if math.isnan(v) else float(v)
        else:
            out[key] = str(v)
    return out


def write_json(path, doc):
    """One JSON document, atomically, strict (NaN and infinities as ``null``)."""
    save_json(path, doc)


def write_json_folder(path, docs):
    """A folder of JSON files ``[(name, doc), ...]``, in place at once.

    The files are written to a new folder beside `path`, which then takes
    its name (:func:`sparseedm._atomic.atomic_folder`): a folder already at
    `path` is replaced only if sparseedm wrote it, else it is refused.
    """
    with atomic_folder(path) as tmp:
        for name, doc in docs:
            (tmp / name).write_text(json_text(doc), encoding="utf-8")
