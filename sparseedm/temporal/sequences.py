"""Video sequences from motion capture: clips seen through one fixed camera.

A :class:`Sequence` is one clip as a video would give it: consecutive frames
(about 30 per second), the 2D joints in pixels, the 3D joints they come from
and the one camera that saw them all (what Protocol B's self-occlusion rule
needs, :mod:`sparseedm.temporal.protocols`).

They are built from a dataset .npz written with one camera per clip
(``sparseedm dataset build --camera-per clip``, ``build_dataset(...,
camera="clip")``): :func:`sequences_from_dataset` groups its rows by clip,
orders them by frame and cuts clips longer than `max_frames` into equal
consecutive pieces (``"02_01#0"``, ``"02_01#1"``, ...); pieces shorter than
`min_frames` are dropped. Frame numbers become video frame numbers: the
source frame index divided by the clip's frame step, counted from the
clip's first kept frame.

:func:`body_height` is the body's pixel height the video evaluation divides
errors by: per frame, the distance from the head top to the midpoint of the
ankles; its median over the sequence.

Examples
--------
>>> from sparseedm.cameras import sample_cameras
>>> cams = sample_cameras(1, random_state=0)
>>> rows = 40
>>> data = {"poses2d": np.zeros((rows, 14, 2)), "poses3d": np.zeros((rows, 14, 3)),
...         "clips": np.array(["a"] * rows), "labels": np.array(["walk"] * rows),
...         "subjects": np.array([""] * rows), "frames": np.arange(rows) * 4,
...         **{k: np.repeat(v, rows, axis=0) for k, v in cams.as_dict().items()}}
>>> seqs = sequences_from_dataset(data, min_frames=10, max_frames=25)
>>> [(s.clip, len(s)) for s in seqs], seqs[1].frames[:3].tolist()
([('a#0', 20), ('a#1', 20)], [20, 21, 22])
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral

import numpy as np

from .._validation import Interval, validate_params
from ..cameras import Cameras
from ..dataset import load_dataset
from ..exceptions import FileFormatError
from ..real_protocol import body_size

__all__ = ["Sequence", "sequences_from_dataset", "load_sequences", "body_height",
           "MIN_FRAMES", "MAX_FRAMES"]

#: sequences are cut to at most MAX_FRAMES frames; shorter than MIN_FRAMES are dropped
MIN_FRAMES, MAX_FRAMES = 31, 300



@dataclass(frozen=True)
class Sequence:
    """One clip seen through one camera.

    Parameters
    ----------
    clip : str
        Clip id (``"#k"`` appended for the k-th piece of a cut clip).
    frames : ndarray of int (T,)
        Video frame numbers, increasing.
    poses2d : ndarray (T, 14, 2)
        Pixels.
    poses3d : ndarray (T, 14, 3)
        World metres.
    camera : Cameras
        One camera (``len(camera) == 1``).
    label : str
        The clip's label (its action or description), as in the dataset.
    subject : str
        The clip's subject, as in the dataset.
    """

    clip: str
    frames: np.ndarray
    poses2d: np.ndarray
    poses3d: np.ndarray
    camera: Cameras
    label: str = ""
    subject: str = ""

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    @property
    def height(self) -> float:
        """The body's pixel height (:func:`body_height`)."""
        return body_height(self.poses2d)


def body_height(poses2d) -> float:
    """Median over frames of the head-top to ankle-midpoint distance, pixels.

    Parameters
    ----------
    poses2d : array_like (T, 14, 2)
        The sequence's true 2D poses, pixels.

    Returns
    -------
    float
        The median distance, pixels.

    Examples
    --------
    >>> p = np.zeros((3, 14, 2)); p[:, 0] = [0, 0]; p[:, [10, 13]] = [[-10, 170], [10, 170]]
    >>> p[2, 0] = [0, 100]   # one crouched frame does not move the median
    >>> body_height(p)
    170.0
    """
    return float(np.median(body_size(poses2d)))


def sequences_from_dataset(data, *, min_frames=MIN_FRAMES, max_frames=MAX_FRAMES):
    """Cut a one-camera-per-clip dataset into sequences.

    Parameters
    ----------
    data : dict
        Arrays of a dataset (:func:`sparseedm.dataset.load_dataset`): at least
        poses2d, poses3d, clips, frames, camera_R, camera_t, camera_f,
        camera_c; labels and subjects are used when present.
    min_frames : int, default 31
        Shortest sequence kept; shorter clips (and pieces) are left out.
    max_frames : int, default 300
        Longest sequence: a longer clip is cut into near-equal pieces of at most this
        many frames (``"#k"`` appended to their clip id).

    Returns
    -------
    list of Sequence
        In sorted clip order.

    Raises
    ------
    FileFormatError
        If a clip was seen through more than one camera (a training set built
        with a camera per pose: build with ``--camera-per clip``) or has
        repeated frames (several cameras per pose).
    """
    validate_params("sequences_from_dataset", dict(min_frames=min_frames,
                                                   max_frames=max_frames), {
        "min_frames": [Interval(Integral, 1, None)], "max_frames": [Interval(Integral, 1, None)]})
    clips = np.asarray(data["clips"]).astype(str)
    out = []
    for clip in np.unique(clips):
        rows = np.flatnonzero(clips == clip)
        rows = rows[np.argsort(np.asarray(data["frames"])[rows], kind="stable")]
        camera = _one_camera(data, rows, clip)
        frames = _video_frames(np.asarray(data["frames"])[rows], clip)
        pieces = -(-len(rows) // int(max_frames))
        for k, part in enumerate(np.array_split(np.arange(len(rows)), pieces)):
            if part.size < min_frames:
                continue
            take = rows[part]
            out.append(Sequence(
                clip=clip if pieces == 1 else f"{clip}#{k}", frames=frames[part],
                poses2d=np.asarray(data["poses2d"], float)[take],
                poses3d=np.asarray(data["poses3d"], float)[take], camera=camera,
                label=str(data["labels"][take[0]]) if "labels" in data else "",
                subject=str(data["subjects"][take[0]]) if "subjects" in data else ""))
    return out


def _one_camera(data, rows, clip):
    keys = ("camera_R", "camera_t", "camera_f", "camera_c")
    arrays = [np.asarray(data[k], float)[rows] for k in keys]
    if any(not np.allclose(a, a[:1]) for a in arrays):
        raise FileFormatError(
            f"clip {clip}: its frames were seen through different cameras; video "
            "sequences need one camera per clip (sparseedm dataset build --camera-per clip)")
    return Cameras(*(a[:1] for a in arrays))


def _video_frames(frames, clip):
    steps = np.diff(frames)
    if np.any(steps <= 0):
        raise FileFormatError(f"clip {clip}: frame {frames[1:][steps <= 0][0]} repeats "
                              "(several cameras per pose?); build with --camera-per clip")
    step = int(np.gcd.reduce(steps)) if steps.size else 1
    return ((frames - frames[0]) // step).astype(np.int64)


def load_sequences(path, *, min_frames=MIN_FRAMES, max_frames=MAX_FRAMES):
    """:func:`sequences_from_dataset` of a dataset .npz file.

    Parameters
    ----------
    path : str or Path
        The dataset file (``sparseedm dataset`` writes them).
    min_frames : int, default 31
        Shortest sequence kept, as :func:`sequences_from_dataset`.
    max_frames : int, default 300
        Longest sequence, as :func:`sequences_from_dataset`.

    Returns
    -------
    list of Sequence
        In sorted clip order.

    Raises
    ------
    FileNotFoundError
        If `path` does not exist.
    FileFormatError
        If the file is not a dataset, or a clip has several cameras (the message
        names the file).

    Examples
    --------
    >>> load_sequences("/nonexistent.npz")
    Traceback (most recent call last):
    ...
    FileNotFoundError: no such dataset file: /nonexistent.npz
    """
    data = load_dataset(path)
    try:
        return sequences_from_dataset(data, min_frames=min_frames, max_frames=max_frames)
    except FileFormatError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
