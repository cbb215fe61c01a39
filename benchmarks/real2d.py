"""Hand-annotated real people from ``../shared/data/real2d``, as 14-joint poses.

Four sets, each read into one :class:`RealSet`: the Bonn Multi-Person PoseTrack
videos (``bonn``: every frame annotated, tracks), the MPII Human Pose validation
split (``mpii``: photos), a subset of COCO val2017 (``coco``: photos) and FLIC
(``flic``: movie frames, upper body only). Unannotated joints are NaN;
``visible`` is False for an unannotated joint and for one annotated as occluded.

The joints keep their datasets' own definitions, so ``layout`` travels with
each set: MPII and Bonn give a head top and an upper neck; COCO and FLIC have
neither, and their neck is the shoulders' midpoint (lower than MPII's). COCO's
head top is derived from the face points (:func:`coco_head_top`) and
flagged in ``derived``; FLIC's head top, knees and ankles are missing.

Splits are by image or video, never by person, so that no two splits share a
frame: :func:`split` assigns each group to ``train`` / ``val`` / ``test`` by a
hash of its id (stable across machines and runs). Bonn's own ``train`` and
``test`` folders are kept: the ``test`` videos are all ``test``; the ``train``
videos are cut into ``train`` and ``val``.

These are research data: they are read from ``../shared`` and never written
into the repository (see ``../shared/data/real2d/README.md``).
"""

from __future__ import annotations

import gzip
import hashlib
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sparseedm import real_protocol

__all__ = ["RealSet", "REAL2D", "SOURCES", "load", "load_all", "split", "body_size",
           "coco_head_top", "available"]

#: where the data lie, from the project's root
REAL2D = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real2d"
SOURCES = ("bonn", "mpii", "coco", "flic")

# MPII numbering -> the 14 joints (head top, neck, R sho, R elb, R wri, L sho,
# L elb, L wri, R hip, R knee, R ank, L hip, L knee, L ank)
_MPII_TO_14 = (9, 8, 12, 11, 10, 13, 14, 15, 2, 1, 0, 3, 4, 5)
# COCO 17 -> the 14 joints (-1: derived)
_COCO_TO_14 = (-1, -1, 6, 8, 10, 5, 7, 9, 12, 14, 16, 11, 13, 15)
# FLIC 11 -> the 14 joints (-1: neck derived, -2: missing)
_FLIC_TO_14 = (-2, -1, 3, 4, 5, 0, 1, 2, 7, -2, -2, 6, -2, -2)


@dataclass(frozen=True)
class RealSet:
    """One annotated set as 14-joint poses.

    Attributes
    ----------
    source : str
        ``"bonn"``, ``"mpii"``, ``"coco"`` or ``"flic"``.
    layout : str
        ``"mpii"`` (head top and upper neck annotated) or ``"coco"`` / ``"flic"``
        (neck = shoulders' midpoint; head top derived or missing).
    poses : ndarray (n, 14, 2)
        Pixels; NaN where a joint is not annotated.
    visible : ndarray of bool (n, 14)
        Annotated and not flagged occluded.
    derived : ndarray of bool (n, 14)
        Joints computed from others (COCO's neck and head top, FLIC's neck).
    group : ndarray of str (n,)
        Image or video id: the unit of splitting.
    head_size : ndarray (n,)
        PCKh's normaliser in pixels (MPII's: 0.6 × the head box diagonal), NaN
        where the set has none.
    tracks, frames : ndarray of int (n,) or None
        Person and frame number, for video.
    part : ndarray of str (n,)
        The set's own split the pose came from (``"train"``, ``"test"``,
        ``"valid"``...).
    """

    source: str
    layout: str
    poses: np.ndarray
    visible: np.ndarray
    derived: np.ndarray
    group: np.ndarray
    head_size: np.ndarray
    tracks: np.ndarray | None = None
    frames: np.ndarray | None = None
    part: np.ndarray = field(default=None)

    def __len__(self):
        return int(self.poses.shape[0])

    @property
    def annotated(self):
        """(n, 14) bool: the joint has coordinates."""
        return np.isfinite(self.poses).all(axis=-1)

    @property
    def complete(self):
        """(n,) bool: all 14 joints annotated."""
        return self.annotated.all(axis=1)

    def take(self, rows):
        """The poses at ``rows`` (a boolean mask or indices) as a new RealSet."""
        pick = (lambda a: None if a is None else a[rows])
        return RealSet(self.source, self.layout, self.poses[rows], self.visible[rows],
                       self.derived[rows], self.group[rows], self.head_size[rows],
                       pick(self.tracks), pick(self.frames), pick(self.part))


def available(root=None):
    """Whether the real2d folder is there (tests skip without it)."""
    return Path(root or REAL2D).is_dir()


def _h5py():
    try:
        import h5py
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("reading MPII / FLIC annotations needs h5py "
                          "(pip install sparseedm[real])") from exc
    return h5py


def _load_bonn(root):
    import scipy.io as sio
    poses, vis, group, tracks, frames, head, part = [], [], [], [], [], [], []
    for folder in ("train", "test"):
        mat = sio.loadmat(root / "bonn-multiperson-posetrack" / folder / "annolist.mat",
                          squeeze_me=True, struct_as_record=False)
        for video in np.atleast_1d(mat["annolist"]):
            ap = np.asarray(video.annopoints, dtype=object)
            if ap.ndim == 1:
                ap = ap.reshape(1, -1)
            for person in range(ap.shape[0]):
                for frame in range(ap.shape[1]):
                    cell = ap[person, frame]
                    if not hasattr(cell, "point"):
                        continue
                    xy = np.full((16, 2), np.nan)
                    v = np.zeros(16, bool)
                    for pt in np.atleast_1d(cell.point):
                        j = int(pt.id)
                        xy[j] = (float(pt.x), float(pt.y))
                        v[j] = bool(np.asarray(pt.is_visible).size and int(pt.is_visible) == 1)
                    idx = list(_MPII_TO_14)
                    poses.append(xy[idx])
                    vis.append(v[idx] & np.isfinite(xy[idx]).all(-1))
                    r = np.asarray(cell.head_rect, float).ravel()
                    head.append(0.6 * np.hypot(r[2] - r[0], r[3] - r[1]) if r.size == 4 else np.nan)
                    group.append(f"bonn/{folder}/{video.name}")
                    tracks.append(person)
                    frames.append(frame)
                    part.append(folder)
    n = len(poses)
    return RealSet("bonn", "mpii", np.array(poses), np.array(vis), np.zeros((n, 14), bool),
                   np.array(group), np.array(head), np.array(tracks), np.array(frames),
                   np.array(part))


def _load_mpii(root):
    h5py = _h5py()
    with h5py.File(root / "mpii-valid-hg" / "valid.h5", "r") as f:
        part = f["part"][:].astype(float)
        visible = f["visible"][:].astype(bool)
        names = [b.decode() if isinstance(b, bytes) else str(b) for b in f["imgname"][:]]
        head = f["normalize"][:].astype(float)
    idx = list(_MPII_TO_14)
    xy = part[:, idx]
    unannotated = (xy == 0).all(axis=-1) | (xy < 0).all(axis=-1)
    xy[unannotated] = np.nan
    n = len(xy)
    return RealSet("mpii", "mpii", xy, visible[:, idx] & ~unannotated,
                   np.zeros((n, 14), bool), np.array([f"mpii/{s}" for s in names]), head,
                   part=np.full(n, "valid"))


def coco_head_top(kp, v):
    """A head top from COCO's face points: the centre of the annotated eyes and
    ears, moved away from the shoulders' midpoint by half their distance.

    Approximate by construction (COCO annotates no head top); NaN where no face
    point or no shoulder is annotated. ``kp`` is (n, 17, 2), ``v`` (n, 17).
    """
    face = np.where((v[:, 1:5] > 0)[..., None], kp[:, 1:5], np.nan)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # no face point: NaN
        centre = np.nanmean(face, axis=1)
    shoulders = np.where((v[:, 5:7] > 0).all(axis=1)[:, None], kp[:, 5:7].mean(axis=1), np.nan)
    return centre + 0.5 * (centre - shoulders)


def _load_coco(root):
    with gzip.open(root / "coco-val2017-subset" / "person_keypoints_val2017.json.gz", "rt") as f:
        doc = json.load(f)
    anns = [a for a in doc["annotations"]
            if not a.get("iscrowd") and a.get("num_keypoints", 0) > 0]
    kp = np.array([a["keypoints"] for a in anns], float).reshape(-1, 17, 3)
    xy, v = kp[..., :2].copy(), kp[..., 2]
    xy[v == 0] = np.nan
    n = len(anns)
    out = np.full((n, 14, 2), np.nan)
    vis = np.zeros((n, 14), bool)
    for j, c in enumerate(_COCO_TO_14):
        if c >= 0:
            out[:, j] = xy[:, c]
            vis[:, j] = v[:, c] == 2
    out[:, 1] = xy[:, 5:7].mean(axis=1)                     # neck: shoulders' midpoint
    vis[:, 1] = (v[:, 5:7] == 2).all(axis=1)
    out[:, 0] = coco_head_top(kp[..., :2], v)
    vis[:, 0] = np.isfinite(out[:, 0]).all(-1) & ((v[:, 1:5] == 2).sum(axis=1) >= 2)
    derived = np.zeros((n, 14), bool)
    derived[:, :2] = True
    return RealSet("coco", "coco", out, vis & np.isfinite(out).all(-1), derived,
                   np.array([f"coco/{a['image_id']}" for a in anns]), np.full(n, np.nan),
                   part=np.full(n, "val2017"))


def _load_flic(root):
    h5py = _h5py()
    blocks = []
    for name in ("train", "valid"):
        with h5py.File(root / "flic-hg" / f"{name}.h5", "r") as f:
            part = f["part"][:].astype(float)
            names = [b.decode() if isinstance(b, bytes) else str(b) for b in f["imgname"][:]]
        blocks.append((name, part, names))
    poses, group, parts = [], [], []
    for name, part, names in blocks:
        out = np.full((len(part), 14, 2), np.nan)
        for j, c in enumerate(_FLIC_TO_14):
            if c >= 0:
                out[:, j] = part[:, c]
        out[:, 1] = part[:, [0, 3]].mean(axis=1)
        poses.append(out)
        group += [f"flic/{s}" for s in names]
        parts += [name] * len(part)
    xy = np.concatenate(poses)
    n = len(xy)
    derived = np.zeros((n, 14), bool)
    derived[:, 1] = True
    return RealSet("flic", "flic", xy, np.isfinite(xy).all(-1), derived, np.array(group),
                   np.full(n, np.nan), part=np.array(parts))


_LOADERS = {"bonn": _load_bonn, "mpii": _load_mpii, "coco": _load_coco, "flic": _load_flic}


def load(source, root=None):
    """One set, by name (see :data:`SOURCES`)."""
    if source not in _LOADERS:
        raise ValueError(f"unknown real2d source {source!r}; one of {SOURCES}")
    return _LOADERS[source](Path(root or REAL2D))


def load_all(sources=SOURCES, root=None):
    """``{source: RealSet}`` for the sets named."""
    return {s: load(s, root) for s in sources}


def _bucket(text):
    """A number in [0, 1) from a group id, the same on every machine."""
    digest = hashlib.sha256(text.encode()).digest()
    return int.from_bytes(digest[:8], "little") / 2.0 ** 64


def split(realset, val=0.2, test=0.2):
    """``(n,)`` array of ``"train"`` / ``"val"`` / ``"test"`` per pose, by group.

    Bonn keeps its own folders: its ``test`` videos are ``test``, and its
    ``train`` videos are cut into ``train`` and ``val`` (``val`` of them, by the
    same hash). Other sets: ``test`` and ``val`` fractions of the groups.
    """
    u = np.array([_bucket(g) for g in realset.group])
    if realset.source == "bonn":
        return np.where(realset.part == "test", "test", np.where(u < val, "val", "train"))
    return np.where(u < test, "test", np.where(u < test + val, "val", "train"))


def body_size(poses):
    """Distance from the head top to the ankles' midpoint, (n,): the body size
    (:func:`sparseedm.real_protocol.body_size`)."""
    return real_protocol.body_size(poses)
