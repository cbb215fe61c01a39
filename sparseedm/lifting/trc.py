"""TRC files: 3D joint trajectories in OpenSim's marker-trajectory format.

A ``.trc`` is tab-separated text: three header lines, two lines naming the
markers and their X/Y/Z columns, then one row per frame::

    PathFileType  4  (X/Y/Z)  poses.trc
    DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  OrigDataStartFrame  OrigNumFrames
    30  30  2  14  m  30  1  2
    Frame#  Time  head_top  <tab>  <tab>  neck ...
            X1  Y1  Z1  X2  Y2  Z2 ...
    (blank)
    1  0.0  x  y  z ...

Each pose is one frame (row r -> frame r + 1, time r / rate) and each of the
14 joints a marker, in metres. Coordinates are turned from sparseedm's camera
axes (x right, y down, z away from the camera) into OpenSim's y-up
convention by a half turn about x: (x, -y, -z), so y is up and z points
towards the camera (a right-handed frame, no mirror). A refused pose (NaN)
is written as empty fields, as OpenSim reads a missing marker.

>>> import numpy as np, tempfile, os
>>> poses = np.arange(2 * 14 * 3, dtype=float).reshape(2, 14, 3) / 100
>>> with tempfile.TemporaryDirectory() as d:
...     path = write_trc(os.path.join(d, "p.trc"), poses, rate=25)
...     back = read_trc(path)
>>> back["rate"], back["units"], back["markers"][:2]
(25.0, 'm', ['head_top', 'neck'])
>>> bool(np.allclose(back["poses"], poses))
True
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from .._safeio import text_lines
from .._validation import MAX_FRAME, check_pose_shape
from ..exceptions import FileFormatError, PoseError
from ..skeleton import JOINT_NAMES

__all__ = ["write_trc", "read_trc", "trc_times", "CAMERA_TO_TRC"]

#: camera axes (x right, y down, z away) -> TRC's y-up frame: a half turn about x
CAMERA_TO_TRC = np.array([1.0, -1.0, -1.0])

_HEADER = ("DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
           "OrigDataStartFrame", "OrigNumFrames")


def _num(v):
    return "" if not np.isfinite(v) else f"{v:.6f}"


def _text_of_rate(rate):
    """DataRate as written: ``%g`` (``30``) when that reads back as `rate`, else
    every digit (``29.97002997``)."""
    short = f"{rate:g}"
    return short if float(short) == rate else repr(rate)


def trc_times(frames, rate, n):
    """The Frame# and Time fields of a .trc's n rows, checked: what :func:`write_trc`
    writes and :func:`read_trc` reads back as the same frames and times.

    The rule: `rate` a finite number > 0; `frames` (default ``0 .. n-1``)
    whole numbers, strictly increasing (one row per frame, in time order);
    each time ``frame / rate`` finite. Times are written with 6 decimals, or
    with every digit (``repr``) when 6 decimals would make two times equal.

    Raises
    ------
    FileFormatError
        Naming the rate or the first frame that breaks the rule.

    Examples
    --------
    >>> trc_times([0, 10, 20], 30, 3)
    (['1', '11', '21'], ['0.000000', '0.333333', '0.666667'])
    >>> trc_times(None, 1e7, 2)[1]
    ['0.0', '1e-07']
    >>> trc_times([5, 2, 2], 30, 3)
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: frames must be strictly increasing (one row per frame, in time order): row 1 has frame 2 after 5
    """
    rate = float(rate)
    if not 0 < rate < np.inf:
        raise FileFormatError(f"the .trc frame rate must be a finite number > 0, got {rate}")
    frames = np.arange(n) if frames is None else _frame_numbers(frames, n)
    if n and (np.abs(frames) > MAX_FRAME - 1).any():
        r = int(np.flatnonzero(np.abs(frames) > MAX_FRAME - 1)[0])
        raise FileFormatError(f"frames: row {r} has frame {frames[r]}, too large (over 2**53)")
    bad = np.flatnonzero(np.diff(frames) <= 0)
    if len(bad):
        r = int(bad[0]) + 1
        raise FileFormatError("frames must be strictly increasing (one row per frame, in "
                              f"time order): row {r} has frame {frames[r]} after {frames[r - 1]}")
    with np.errstate(over="ignore"):
        times = frames / rate
    if not np.isfinite(times).all() or (np.diff(times) <= 0).any():
        raise FileFormatError(
            f"the .trc frame rate {rate!r} with frames {frames[0]} .. {frames[-1]} gives "
            "times (frame / rate seconds) that are not finite or not increasing; give a "
            "rate nearer the video's frames per second")
    text = [f"{t:.6f}" for t in times]
    if (np.diff([float(t) for t in text]) <= 0).any():  # too close for 6 decimals (or
        # "-0.000000" beside "0.000000"): every digit
        text = [repr(float(t)) for t in times]
    return [str(int(f) + 1) for f in frames], text


def _frame_numbers(frames, n):
    """`frames` as int64 (n,): whole numbers only."""
    arr = np.asarray(frames)
    if arr.shape != (n,):
        raise FileFormatError(f"frames must have shape ({n},) (one per pose), got {arr.shape}")
    if n and arr.dtype.kind not in "iu" and not (
            arr.dtype.kind == "f" and np.isfinite(arr).all() and (arr == np.round(arr)).all()):
        raise FileFormatError(f"frames must be whole numbers, got {arr.dtype} values")
    return arr.astype(np.int64) if n else np.zeros(0, dtype=np.int64)


def _check_names(names, n_markers):
    """Marker names as written: one per joint, printable text (a space is fine;
    tabs separate a TRC's fields and lines its rows), not empty, no two alike."""
    names = list(names)
    if len(names) != n_markers:
        raise FileFormatError(f"joint_names: {len(names)} marker names for {n_markers} joints")
    for name in names:
        if not isinstance(name, str) or not name.strip() or not name.isprintable():
            raise FileFormatError(
                f"joint_names: marker name {name!r} cannot be written: a TRC marker name is "
                "printable text, not blank (no tab, line break or other control character)")
    if len(set(names)) < len(names):
        raise FileFormatError("joint_names: two markers have the same name")
    return names


def _printable(name):
    """`name` with each tab, line break or other unprintable character as ``_``
    (a file name on a TRC's first line, which is one tab-separated line)."""
    return "".join(c if c.isprintable() else "_" for c in name)


def write_trc(path, poses3d, *, rate=30.0, joint_names=JOINT_NAMES, frames=None):
    """Write poses (n, N, 3) in camera axes, metres, as a TRC file (atomically).

    Whatever it writes, :func:`read_trc` reads back (the same poses to the 6
    decimals written, frames, times and names); anything else is refused.

    Parameters
    ----------
    path : str or path-like
        Its name is written on the first line, each tab or line break as ``_``.
    poses3d : array_like (n, N, 3)
        NaN rows (refused poses) become empty fields; infinities are refused.
    rate : float > 0
        Frames per second (``DataRate`` and ``CameraRate``; frame r is at r / rate s).
    joint_names : sequence of str
        Marker names, one per joint: printable, not blank, no two alike.
    frames : array_like of int (n,), optional
        The rows' video frame numbers (strictly increasing): row r is written
        as ``Frame#`` ``frames[r] + 1`` at ``frames[r] / rate`` s; default the
        row number. See :func:`trc_times` for the rule.

    Returns
    -------
    Path

    Raises
    ------
    PoseError
        `poses3d` not (n, N, 3), or holding infinities.
    FileFormatError
        A rate, frames or names the file cannot hold (:func:`trc_times`).
    """
    path = Path(path)
    P = np.asarray(poses3d, dtype=float)
    check_pose_shape(P, "poses3d", dim=3)
    if np.isinf(P).any():
        raise PoseError("poses3d hold infinite coordinates; a TRC holds numbers or empty "
                        "fields (NaN)")
    P = P * CAMERA_TO_TRC
    n, n_markers = P.shape[:2]
    names = _check_names(joint_names, n_markers)
    numbers, times = trc_times(frames, rate, n)
    rate_text = _text_of_rate(float(rate))
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{_printable(path.name)}",
        "\t".join(_HEADER),
        "\t".join([rate_text, rate_text, str(n), str(n_markers), "m", rate_text,
                   numbers[0] if n else "1", str(n)]),
        "\t".join(["Frame#", "Time"] + [f"{name}\t\t" for name in names]).rstrip("\t"),
        "\t\t" + "\t".join(f"{a}{i + 1}" for i in range(n_markers) for a in "XYZ"),
        "",
    ]
    for r in range(n):
        lines.append("\t".join([numbers[r], times[r]] + [_num(v) for v in P[r].ravel()]))
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def read_trc(path):
    """Read a TRC file as :func:`write_trc` writes it (bounded reader).

    Parameters
    ----------
    path : str or path-like
        The .trc file.

    Returns
    -------
    dict
        ``poses`` (n, N, 3) in camera axes (the inverse of :func:`write_trc`'s
        turn; NaN for empty fields), ``markers`` (names), ``rate`` (DataRate),
        ``units``, ``frames`` (n,) and ``times`` (n,).
    """
    lines = [line.rstrip("\r\n") for _, line in text_lines(path)]
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise FileFormatError(f"{path}: not a TRC file (no PathFileType header line)")
    head = dict(zip(lines[1].split("\t"), lines[2].split("\t")))
    try:
        rate, n_markers = float(head["DataRate"]), int(head["NumMarkers"])
    except (KeyError, ValueError):
        raise FileFormatError(f"{path}: line 3: no readable DataRate / NumMarkers") from None
    markers = [m for m in lines[3].split("\t")[2:] if m]
    if len(markers) != n_markers:
        raise FileFormatError(f"{path}: line 4 names {len(markers)} markers, NumMarkers "
                              f"says {n_markers}")
    frames, times, rows = [], [], []
    for k, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        fields = line.split("\t")
        fields += [""] * (2 + 3 * n_markers - len(fields))
        try:
            frames.append(int(fields[0]))
            times.append(float(fields[1]))
            rows.append([float(v) if v.strip() else np.nan for v in fields[2:2 + 3 * n_markers]])
        except ValueError:
            raise FileFormatError(f"{path}: line {k}: not a frame row of numbers") from None
    poses = np.array(rows, dtype=float).reshape(len(rows), n_markers, 3) * CAMERA_TO_TRC
    return {"poses": poses, "markers": markers, "rate": rate, "units": head.get("Units", ""),
            "frames": np.array(frames, dtype=np.int64), "times": np.array(times)}
