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
from ..exceptions import FileFormatError
from ..skeleton import JOINT_NAMES

__all__ = ["write_trc", "read_trc", "CAMERA_TO_TRC"]

#: camera axes (x right, y down, z away) -> TRC's y-up frame: a half turn about x
CAMERA_TO_TRC = np.array([1.0, -1.0, -1.0])

_HEADER = ("DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
           "OrigDataStartFrame", "OrigNumFrames")


def _num(v):
    return "" if not np.isfinite(v) else f"{v:.6f}"


def write_trc(path, poses3d, *, rate=30.0, joint_names=JOINT_NAMES, frames=None):
    """Write poses (n, N, 3) in camera axes, metres, as a TRC file (atomically).

    Parameters
    ----------
    path : str or path-like
    poses3d : array_like (n, N, 3)
        NaN rows (refused poses) become empty fields.
    rate : float > 0
        Frames per second (``DataRate`` and ``CameraRate``; frame r is at r / rate s).
    joint_names : sequence of str
        Marker names, one per joint.
    frames : array_like of int (n,), optional
        The rows' video frame numbers (increasing): row r is written as
        ``Frame#`` ``frames[r] + 1`` at ``frames[r] / rate`` s; default the
        row number.

    Returns
    -------
    Path
    """
    path = Path(path)
    P = np.asarray(poses3d, dtype=float) * CAMERA_TO_TRC
    n, n_markers = P.shape[:2]
    rate = float(rate)
    if not rate > 0:
        raise FileFormatError(f"{path}: a TRC frame rate must be > 0, got {rate}")
    frames = np.arange(n) if frames is None else np.asarray(frames, dtype=np.int64)
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "\t".join(_HEADER),
        "\t".join([f"{rate:g}", f"{rate:g}", str(n), str(n_markers), "m", f"{rate:g}",
                   str(int(frames[0]) + 1 if n else 1), str(n)]),
        "\t".join(["Frame#", "Time"] + [f"{name}\t\t" for name in joint_names]).rstrip("\t"),
        "\t\t" + "\t".join(f"{a}{i + 1}" for i in range(n_markers) for a in "XYZ"),
        "",
    ]
    for r in range(n):
        lines.append("\t".join([str(int(frames[r]) + 1), f"{frames[r] / rate:.6f}"]
                               + [_num(v) for v in P[r].ravel()]))
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def read_trc(path):
    """Read a TRC file as :func:`write_trc` writes it (bounded reader).

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
