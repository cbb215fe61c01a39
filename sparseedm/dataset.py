"""Training sets from motion capture: 3D poses, their 2D views, labels, cameras.

:func:`build_dataset` reads .bvh and CMU .amc files (files or folders,
recursively), keeps every ``frame_step``-th frame, views each kept pose
through ``cameras_per_pose`` seeded virtual cameras
(:func:`sparseedm.cameras.sample_cameras`, looking at the pose's mean joint)
and returns -- or writes, atomically -- an .npz with this schema (``n`` poses):

================ ============= ===============================================
key              shape / dtype meaning
================ ============= ===============================================
poses2d          (n, 14, 2) f8 pixel coordinates (u right, v down)
poses3d          (n, 14, 3) f8 world coordinates, metres, Y-up
labels           (n,) str      action: Bandai content label (``"walk"``);
                               CMU clip name (``"02_01"``); else file stem
clips            (n,) str      clip id: the file's stem
styles           (n,) str      Bandai style label (``"happy"``), ``""`` else
subjects         (n,) str      CMU subject (``"02"``); ``""`` when unknown
                               (Bandai does not say which actor)
frames           (n,) i8       frame index in the clip
camera_R         (n, 3, 3) f8  world -> camera rotation
camera_t         (n, 3) f8     world -> camera translation
camera_f         (n,) f8       focal length, pixels
camera_c         (n, 2) f8     principal point, pixels
joint_names      (14,) str     :data:`sparseedm.skeleton.JOINT_NAMES`
================ ============= ===============================================

Strings are numpy unicode arrays, so ``numpy.load(path, allow_pickle=False)``
reads the file. Joint order is :data:`sparseedm.skeleton.SKELETON_14`.

Frame subsampling: ``frame_step=None`` keeps about 40 frames per second of
motion (``round(frame_rate / 40)``, at least 1): every 3rd frame of CMU's
120 fps, every frame of Bandai-Namco's 30 fps. With the shared data this
gives 34,434 CMU ASF/AMC poses (25,926 from subjects 01-03), 17,711 CMU Daz
BVH poses and 31,914 Bandai-Namco poses per camera. T-pose frames at the start
or end of a clip (:func:`sparseedm.mocap.rigs.tpose_frames`) are dropped
first unless ``keep_tpose``.

Video sequences: ``camera="clip"`` views a whole clip through ONE seeded
camera (a tripod: its target is the clip's mean joint, its horizontal
distance the sampled one plus the farthest any joint of the clip gets from
that target, so the performer never walks into it) and, with
``frame_step=None``, keeps about :data:`VIDEO_FPS` frames per second (every
4th frame of CMU's 120 fps); :mod:`sparseedm.temporal.sequences` cuts such a
file into sequences.
"""

from __future__ import annotations

import json
import os
import re
import sys
import warnings
from numbers import Integral
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ._atomic import check_paths, save_npz
from ._safeio import load_npz
from ._validation import Interval, Options, validate_params
from .cameras import project, sample_cameras
from .exceptions import FileFormatError, OutputPathError, ParameterError, SparseEDMError
from .mocap import MOCAP_SUFFIXES, load_mocap, plausibility, read_joint_map
from .mocap.rigs import UNITS
from .skeleton import JOINT_NAMES

__all__ = ["build_dataset", "load_dataset", "find_mocap_files", "clip_metadata",
           "SCHEMA", "TARGET_FPS", "VIDEO_FPS"]

#: frame_step=None keeps about this many frames per second
TARGET_FPS = 40.0
#: most virtual cameras per pose build_dataset takes (bounds the arrays it allocates)
MAX_CAMERAS_PER_POSE = 1000
#: ... and this many with camera="clip" (video sequences)
VIDEO_FPS = 30.0

#: key -> (dtype kind, shape with "n" for the pose axis)
SCHEMA = {
    "poses2d": ("f", ("n", 14, 2)),
    "poses3d": ("f", ("n", 14, 3)),
    "labels": ("U", ("n",)),
    "clips": ("U", ("n",)),
    "styles": ("U", ("n",)),
    "subjects": ("U", ("n",)),
    "frames": ("i", ("n",)),
    "camera_R": ("f", ("n", 3, 3)),
    "camera_t": ("f", ("n", 3)),
    "camera_f": ("f", ("n",)),
    "camera_c": ("f", ("n", 2)),
    "joint_names": ("U", (14,)),
}


def find_mocap_files(paths) -> list[Path]:
    """The .bvh and .amc files among `paths`, folders searched recursively.

    Files are returned sorted within each folder; a path that does not exist
    raises :class:`FileNotFoundError`.

    Parameters
    ----------
    paths : sequence of str or path-like
        Files and folders.

    Returns
    -------
    list of Path
        Sorted, without duplicates.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    found = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            found.extend(sorted(q for q in p.rglob("*")
                                if q.is_file() and q.suffix.lower() in MOCAP_SUFFIXES))
        elif p.is_file():
            found.append(p)
        elif os.path.lexists(p):
            raise FileFormatError(f"{p} is not a regular file or a folder (a device, pipe "
                                  "or socket, or a broken link)")
        else:
            raise FileNotFoundError(f"no such file or folder: {p}")
    seen, out = set(), []
    for f in found:
        key = f.resolve()
        if key not in seen:
            seen.add(key)
            out.append(f)
    return out


def _bandai_labels(path: Path):
    """(content, style) of a Bandai-Namco clip from its JSON and cfg/ files."""
    meta = path.with_suffix(".json")
    if not meta.is_file():
        return None
    cfg = None
    for parent in path.parents:
        if (parent / "cfg" / "content_label.txt").is_file():
            cfg = parent / "cfg"
            break
    if cfg is None:
        return None
    try:
        info = json.loads(meta.read_text(encoding="utf-8"))
        contents = (cfg / "content_label.txt").read_text(encoding="utf-8").split()
        styles_path = cfg / "style_label.txt"
        styles = styles_path.read_text(encoding="utf-8").split() if styles_path.is_file() else []
        content = contents[int(info["content"])]
        style = styles[int(info["style"])] if "style" in info and styles else ""
    except (ValueError, KeyError, IndexError, TypeError) as exc:
        raise FileFormatError(f"{meta}: cannot read its content/style labels ({exc})") from None

    def strip(label):  # "dataset-1_walk" -> "walk"
        return label.split("_", 1)[1] if "_" in label else label

    return strip(content), strip(style)


def clip_metadata(path) -> dict:
    """``label``, ``clip``, ``style``, ``subject`` of a motion file.

    A CMU-numbered file (``NN_MM``) is its own clip; another file's clip is
    ``folder/stem``, so that numbered files of different folders (the Daz BVH's
    ``salsa/01.bvh`` and ``martial/01.bvh``) stay different clips, and a purely
    numeric stem takes its folder's name as the action label.

    Parameters
    ----------
    path : str or path-like
        A .bvh or .amc file.

    Returns
    -------
    dict
        Those four fields, each a str.

    Examples
    --------
    >>> clip_metadata("subjects/02/02_01.amc")
    {'label': '02_01', 'clip': '02_01', 'style': '', 'subject': '02'}
    >>> clip_metadata("cmu-bvh-daz/salsa/01.bvh")
    {'label': 'salsa', 'clip': 'salsa/01', 'style': '', 'subject': ''}
    """
    path = Path(path)
    stem = path.stem
    if path.suffix.lower() == ".amc" or re.fullmatch(r"\d+_\d+", stem):
        return {"label": stem, "clip": stem, "style": "", "subject": stem.split("_")[0]}
    bandai = _bandai_labels(path)
    if bandai is not None:
        return {"label": bandai[0], "clip": stem, "style": bandai[1], "subject": ""}
    folder = path.parent.name
    label = folder if stem.isdigit() and folder else stem
    return {"label": label, "clip": f"{folder}/{stem}" if folder else stem, "style": "",
            "subject": ""}


def _progress(iterable, total, enabled, desc):
    if not enabled or not sys.stderr.isatty():
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc=desc, unit="file")


def build_dataset(
    paths,
    output=None,
    *,
    cameras_per_pose=1,
    frame_step=None,
    random_state=0,
    progress=True,
    camera_options=None,
    return_report=False,
    units="auto",
    joint_map=None,
    keep_tpose=False,
    camera="pose",
):
    """Build a training set of 2D/3D poses from motion-capture files.

    Parameters
    ----------
    paths : path or list of paths
        .bvh and .amc files, or folders searched recursively (an
        ``NN_MM.amc`` uses the ``NN.asf`` beside it).
    output : path, optional
        Where to write the .npz (atomically); nothing is written if None.
    cameras_per_pose : int
        Virtual cameras (2D views) per kept 3D pose.
    frame_step : int, optional
        Keep every `frame_step`-th frame; ``None`` keeps about 40 frames per
        second of motion (3 for CMU's 120 fps, 1 for Bandai's 30 fps).
    random_state : int or numpy.random.Generator
        Seed of the cameras.
    progress : bool
        Show a tqdm bar (only when stderr is a terminal).
    camera_options : dict, optional
        Extra arguments for :func:`sparseedm.cameras.sample_cameras`
        (``distance``, ``height``, ``focal``, ``principal_point``, ``up``).
    return_report : bool
        Also return a dict: ``files`` read, ``skipped`` [(path, reason)],
        ``poses``, ``tpose_frames`` (T-pose frames dropped), ``warnings``
        [(path, problem)] from the plausibility check.
    units : {"auto", "m", "cm", "mm", "inch", "cmu"}
        Length unit of the files (see :mod:`sparseedm.mocap.rigs`).
    joint_map : dict or path, optional
        A joint map for rigs not recognised by name
        (:func:`sparseedm.mocap.rigs.read_joint_map`).
    keep_tpose : bool
        Keep T-pose frames (:func:`sparseedm.mocap.rigs.tpose_frames`);
        by default they are dropped before subsampling.
    camera : {"pose", "clip"}
        ``"pose"``: every kept pose gets its own `cameras_per_pose` cameras
        (a training set). ``"clip"``: one fixed camera per clip, frames at
        about :data:`VIDEO_FPS` (video sequences, see the module docstring);
        `cameras_per_pose` must then be 1.

    Returns
    -------
    data : dict
        The arrays of the schema in the module docstring.

    Warns
    -----
    UserWarning
        For each file that cannot be read (named with the reason); it is
        skipped and the rest are built. Also, one per clip, for a clip that
        fails the plausibility check (:func:`sparseedm.mocap.rigs.plausibility`:
        height, bone rigidity, left/right symmetry); such clips are kept.

    Raises
    ------
    SparseEDMError
        If no file gives any pose.
    """
    _check_build_params(output=output, cameras_per_pose=cameras_per_pose,
                        frame_step=frame_step, progress=progress, return_report=return_report,
                        camera_options=camera_options, units=units, keep_tpose=keep_tpose,
                        camera=camera, random_state=random_state)
    cameras_per_pose = int(cameras_per_pose)
    if output is not None:
        _check_build_paths(paths, output, joint_map)
    files = find_mocap_files(paths)
    rng = np.random.default_rng(random_state)
    cam_opts = dict(camera_options or {})
    if joint_map is not None:
        joint_map = read_joint_map(joint_map)
    parts, skipped, read, n_tpose, problems, chosen = [], [], 0, 0, [], []
    for path in _progress(files, len(files), progress, "dataset"):
        try:
            poses, info = load_mocap(path, units=units, joint_map=joint_map, return_info=True)
            meta = clip_metadata(path)
        except (SparseEDMError, OSError, UnicodeDecodeError) as exc:
            warnings.warn(f"skipping {path}: {_skip_reason(path, exc)}", stacklevel=2)
            skipped.append((str(path), _skip_reason(path, exc)))
            continue
        chosen.append({"path": str(path), "rig": info.get("rig"), "units": info.get("units"),
                       "height": info.get("height"), "frames": int(poses.shape[0])})
        for problem in plausibility(poses, height=info.get("height"), name=str(path)):
            warnings.warn(problem, stacklevel=2)
            problems.append((str(path), problem))
        idx, dropped = _kept_frames(poses.shape[0], info, frame_step, camera, keep_tpose)
        n_tpose += dropped
        read += 1
        if idx.size == 0:
            continue
        try:  # a clip far off (root at 1e200) puts a camera along the up axis
            parts.append(_view_clip(poses, idx, meta, cameras_per_pose, camera, rng, cam_opts))
        except (SparseEDMError, ValueError, FloatingPointError) as exc:
            warnings.warn(f"skipping {path}: {_skip_reason(path, exc)}", stacklevel=2)
            skipped.append((str(path), _skip_reason(path, exc)))
            read -= 1
    if not parts:
        raise SparseEDMError(
            f"no poses built: {len(files)} motion file(s) found, {len(skipped)} skipped"
            + "".join(f"; skipped {p}: {r}" for p, r in skipped[:3])
            + (f"; and {len(skipped) - 3} more" if len(skipped) > 3 else "")
            + (f", {n_tpose} T-pose frame(s) dropped (a clip's first or last frames with "
               "both arms straight and level are its calibration pose; --keep-tpose keeps "
               "them)"
               if n_tpose else ""))
    data = _concatenate(parts)
    if output is not None:
        save_dataset(output, data)
    if return_report:
        report = {"files": read, "skipped": skipped, "poses": int(data["poses3d"].shape[0]),
                  "tpose_frames": n_tpose, "warnings": problems, "chosen": chosen}
        return data, report
    return data


def _check_build_params(*, output, cameras_per_pose, frame_step, progress, return_report,
                        camera_options, units, keep_tpose, camera, random_state):
    """:func:`build_dataset`'s argument constraints (a ParameterError naming one)."""
    validate_params("build_dataset", dict(
        output=output, cameras_per_pose=cameras_per_pose, frame_step=frame_step,
        progress=progress, return_report=return_report, camera_options=camera_options), {
        "output": ["path", None],
        "cameras_per_pose": [Interval(Integral, 1, MAX_CAMERAS_PER_POSE)],
        "frame_step": [Interval(Integral, 1, None), None],
        "progress": ["boolean"], "return_report": ["boolean"],
        "camera_options": [dict, None]})
    validate_params("build_dataset", dict(units=units, keep_tpose=keep_tpose, camera=camera), {
        "units": [Options(("auto", *UNITS))], "keep_tpose": ["boolean"],
        "camera": [Options(("pose", "clip"))]})
    if camera == "clip" and cameras_per_pose != 1:
        raise ParameterError("build_dataset: camera='clip' views each clip through one "
                             f"camera; cameras_per_pose must be 1, got {cameras_per_pose}")
    validate_params("build_dataset", dict(random_state=random_state), {
        "random_state": [Interval(Integral, 0, None), np.random.Generator, None]})


def _check_build_paths(paths, output, joint_map):
    """The output is a usable .npz path that overwrites no file the build reads."""
    _check_output(output)
    # every file the build reads is an input, whatever its name (a joint map x.npz)
    inputs = [("motion path", p) for p in
              ([paths] if isinstance(paths, (str, os.PathLike)) else list(paths))]
    if isinstance(joint_map, (str, os.PathLike)):
        inputs.append(("joint map", joint_map))
    check_paths(inputs, [("output", output)])


def _kept_frames(n_frames, info, frame_step, camera, keep_tpose):
    """The frame indices a clip keeps (T-pose frames dropped unless `keep_tpose`,
    then every `frame_step`-th), and how many T-pose frames were dropped."""
    step = int(frame_step) if frame_step is not None else _auto_step(
        info.get("frame_rate"), VIDEO_FPS if camera == "clip" else TARGET_FPS)
    keep = np.arange(n_frames)
    if not keep_tpose and len(info.get("tpose_frames", ())):
        keep = np.setdiff1d(keep, info["tpose_frames"])
    return keep[::step], n_frames - keep.size


class _ClipPart(NamedTuple):
    """One clip's share of the dataset: its kept 3D poses (repeated per camera),
    their 2D views, frame indices, cameras and :func:`clip_metadata`."""

    poses3d: np.ndarray
    poses2d: np.ndarray
    frames: np.ndarray
    cameras: object
    meta: dict


def _view_clip(poses, idx, meta, cameras_per_pose, camera, rng, cam_opts):
    """A clip's frames `idx` seen through its virtual cameras, as a :class:`_ClipPart`."""
    kept = np.repeat(poses[idx], cameras_per_pose, axis=0)
    frames = np.repeat(idx, cameras_per_pose)
    if camera == "clip":
        cams = _clip_camera(kept, rng, cam_opts)
    else:
        cams = sample_cameras(targets=kept.mean(axis=1), random_state=rng, **cam_opts)
    return _ClipPart(kept, project(kept, cams), frames, cams, meta)


def _concatenate(parts):
    """The dataset's arrays from each clip's :class:`_ClipPart`."""
    n_each = [p.poses3d.shape[0] for p in parts]

    def strings(key):
        return np.repeat(np.array([p.meta[key] for p in parts], dtype=str), n_each)

    return {
        "poses2d": np.concatenate([p.poses2d for p in parts]),
        "poses3d": np.concatenate([p.poses3d for p in parts]),
        "labels": strings("label"),
        "clips": strings("clip"),
        "styles": strings("style"),
        "subjects": strings("subject"),
        "frames": np.concatenate([p.frames for p in parts]).astype(np.int64),
        "camera_R": np.concatenate([p.cameras.R for p in parts]),
        "camera_t": np.concatenate([p.cameras.t for p in parts]),
        "camera_f": np.concatenate([p.cameras.f for p in parts]),
        "camera_c": np.concatenate([p.cameras.c for p in parts]),
        "joint_names": np.array(JOINT_NAMES, dtype=str),
    }


def _skip_reason(path, exc):
    """The error's message without the leading path (it is reported beside it)."""
    reason = str(exc)
    if reason.startswith(str(path)):
        reason = reason[len(str(path)):].lstrip(":, ")
    return reason


def _auto_step(frame_rate, fps=TARGET_FPS):
    if frame_rate is None or not np.isfinite(frame_rate) or frame_rate <= 0:
        return 1
    return max(1, int(round(frame_rate / fps)))


def _clip_camera(poses, rng, options):
    """One camera for a whole clip (n, 14, 3), repeated n times: aimed at the clip's
    mean joint, its distance range pushed out by the clip's horizontal reach."""
    target = poses.reshape(-1, 3).mean(axis=0)
    up = {"x": 0, "y": 1, "z": 2}.get(str(options.get("up", "y")).lower(), 1)
    flat = np.delete(poses.reshape(-1, 3) - target, up, axis=1)
    reach = float(np.linalg.norm(flat, axis=1).max())
    opts = dict(options)
    opts["distance"] = np.asarray(opts.get("distance", (3.0, 6.0)), dtype=float) + reach
    cam = sample_cameras(1, targets=target, random_state=rng, **opts)
    return cam[np.zeros(poses.shape[0], int)]


def _check_output(path):
    """A dataset is an .npz: refuse other names (numpy would add ".npz" to them)."""
    if Path(path).suffix != ".npz":  # ".NPZ" too: the rule every other output follows
        raise OutputPathError(
            f"{path}: a dataset is written as an .npz archive; give an output name "
            "ending in .npz")


def save_dataset(path, data) -> None:
    """Validate `data` against the schema and write it as an .npz, atomically."""
    _check_output(path)
    _validate(data, str(path))
    save_npz(path, {k: np.asarray(data[k]) for k in SCHEMA}, compressed=True)


def _validate(data, name):
    missing = [k for k in SCHEMA if k not in data]
    if missing:
        raise FileFormatError(f"{name}: not a sparseedm dataset, missing {', '.join(missing)}")
    n = None
    for key, (kind, shape) in SCHEMA.items():
        arr = np.asarray(data[key])
        if arr.dtype.kind != kind and not (kind == "i" and arr.dtype.kind == "u"):
            raise FileFormatError(f"{name}: {key} has dtype {arr.dtype}, expected kind {kind!r}")
        if arr.ndim != len(shape):
            raise FileFormatError(f"{name}: {key} has shape {arr.shape}, expected {shape}")
        for dim, want in zip(arr.shape, shape):
            if want == "n":
                if n is None:
                    n = dim
                elif dim != n:
                    raise FileFormatError(
                        f"{name}: {key} has {dim} rows, but poses2d has {n}"
                    )
            elif dim != want:
                raise FileFormatError(f"{name}: {key} has shape {arr.shape}, expected {shape}")
        if kind == "f" and not np.all(np.isfinite(arr)):
            raise FileFormatError(f"{name}: {key} has NaN or infinite values")
    if tuple(np.asarray(data["joint_names"]).tolist()) != JOINT_NAMES:
        raise FileFormatError(f"{name}: joint_names are not the SKELETON_14 order")


def load_dataset(path) -> dict:
    """Load and validate a dataset .npz written by :func:`build_dataset`.

    Parameters
    ----------
    path : str or path-like
        A dataset ``.npz``.

    Returns
    -------
    dict
        Every key of the schema (see the module docstring).

    Raises
    ------
    FileFormatError
        A missing key, a wrong shape or dtype, NaN values, object arrays
        (pickles are refused) or a file that is not an .npz, named.

    Examples
    --------
    >>> load_dataset("/nonexistent.npz")
    Traceback (most recent call last):
    ...
    FileNotFoundError: no such dataset file: /nonexistent.npz
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such dataset file: {path}")
    data, _ = load_npz(path, SCHEMA, what=f"{path}: not a valid dataset .npz:")
    _validate(data, str(path))
    return data
