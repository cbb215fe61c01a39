"""BVH motion files -> 3D positions of the 14 joints, in metres.

The parser reads the ``HIERARCHY`` (joints with ``OFFSET``, ``CHANNELS`` of any
order and count, ``End Site`` blocks) and the ``MOTION`` section, and forward
kinematics runs over all frames at once (one Python step per joint).

Conventions
-----------
* Rotations: the rotation channels of a joint, in the order they are listed,
  are *intrinsic* rotations (BVH's meaning): ``Zrotation Xrotation Yrotation``
  gives the local matrix ``Rz @ Rx @ Ry`` acting on column vectors.
* Translations: a joint's local translation is its ``OFFSET``; any position
  channel *replaces* the offset's component on that axis (the Bandai-Namco
  files give every joint 6 channels whose positions equal the offsets, and a
  root's position channels are absolute). Translation is applied before
  rotation, whatever the channel order.
* World frame: as in the file (both supported rigs are Y-up, right-handed).
* Rigs mapped onto :data:`sparseedm.skeleton.SKELETON_14`, detected by joint
  names (see :data:`RIGS`):

  - ``"bandai"`` (Bandai-Namco-Research-Motiondataset): units are centimetres
    (default ``scale=0.01``). Its ``Head`` End Site has a zero offset, so
    **head_top is defined as the point 0.2 m from the Head joint along the
    Head joint's local axis that points from Neck to Head** (the direction of
    Head's OFFSET, rotated by Head's global rotation).
  - ``"cmu"`` (the CMU Graphics Lab BVH conversion: Hips, LHipJoint,
    LeftUpLeg, ..., Neck, Neck1, Head): units are the ASF's length units
    (1/0.45 inch), so the default scale is the CMU FAQ's
    ``(1.0 / 0.45) * 2.54 / 100``; head_top is the Head End Site, neck is
    ``Neck1`` (the top of CMU's ``lowerneck`` bone, as in
    :mod:`sparseedm.mocap.asf_amc`).

  A ``scale`` argument overrides the rig's unit.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

import numpy as np

from ..exceptions import FileFormatError
from ..skeleton import JOINT_NAMES

__all__ = [
    "BVHJoint",
    "BVHData",
    "RIGS",
    "parse_bvh",
    "bvh_forward_kinematics",
    "detect_rig",
    "load_bvh",
    "rotation_matrices",
]

#: CMU's length unit (ASF ``length 0.45``) in metres: (1.0/0.45) * 2.54 / 100
CMU_SCALE = (1.0 / 0.45) * 2.54 / 100
#: Bandai-Namco files are in centimetres
BANDAI_SCALE = 0.01
#: distance from the Bandai Head joint to the defined head top, in metres
BANDAI_HEAD_TOP = 0.2

#: Rig name -> (default scale to metres, {14-joint name: source}). A source is
#: ``("joint", name)`` (the joint's position), ``("end", name)`` (the joint's
#: first End Site) or ``("extend", name, metres)`` (a point `metres` beyond the
#: joint along its own bone direction).
RIGS = {
    "bandai": (
        BANDAI_SCALE,
        {
            "head_top": ("extend", "Head", BANDAI_HEAD_TOP),
            "neck": ("joint", "Neck"),
            "right_shoulder": ("joint", "UpperArm_R"),
            "right_elbow": ("joint", "LowerArm_R"),
            "right_wrist": ("joint", "Hand_R"),
            "left_shoulder": ("joint", "UpperArm_L"),
            "left_elbow": ("joint", "LowerArm_L"),
            "left_wrist": ("joint", "Hand_L"),
            "right_hip": ("joint", "UpperLeg_R"),
            "right_knee": ("joint", "LowerLeg_R"),
            "right_ankle": ("joint", "Foot_R"),
            "left_hip": ("joint", "UpperLeg_L"),
            "left_knee": ("joint", "LowerLeg_L"),
            "left_ankle": ("joint", "Foot_L"),
        },
    ),
    "cmu": (
        CMU_SCALE,
        {
            "head_top": ("end", "Head"),
            "neck": ("joint", "Neck1"),
            "right_shoulder": ("joint", "RightArm"),
            "right_elbow": ("joint", "RightForeArm"),
            "right_wrist": ("joint", "RightHand"),
            "left_shoulder": ("joint", "LeftArm"),
            "left_elbow": ("joint", "LeftForeArm"),
            "left_wrist": ("joint", "LeftHand"),
            "right_hip": ("joint", "RightUpLeg"),
            "right_knee": ("joint", "RightLeg"),
            "right_ankle": ("joint", "RightFoot"),
            "left_hip": ("joint", "LeftUpLeg"),
            "left_knee": ("joint", "LeftLeg"),
            "left_ankle": ("joint", "LeftFoot"),
        },
    ),
}

_AXIS = {"X": 0, "Y": 1, "Z": 2}


def rotation_matrices(angles_deg, axes: str) -> np.ndarray:
    """Rotation matrices of intrinsic Euler angles, batched.

    Parameters
    ----------
    angles_deg : array_like, shape (n, len(axes))
        Angles in degrees, one column per axis letter.
    axes : str
        Axis letters, e.g. ``"ZXY"``: the result is ``Rz @ Rx @ Ry``.

    Returns
    -------
    ndarray, shape (n, 3, 3)

    Examples
    --------
    >>> R = rotation_matrices([[90.0]], "Z")
    >>> np.round(R[0] @ [1.0, 0.0, 0.0], 6) + 0.0
    array([0., 1., 0.])
    """
    angles = np.radians(np.asarray(angles_deg, dtype=float))
    if angles.ndim != 2 or angles.shape[1] != len(axes):
        raise ValueError(f"angles must have shape (n, {len(axes)}), got {angles.shape}")
    n = angles.shape[0]
    out = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    for k, letter in enumerate(axes.upper()):
        a = _AXIS[letter]
        b, c = (a + 1) % 3, (a + 2) % 3
        cos, sin = np.cos(angles[:, k]), np.sin(angles[:, k])
        r = np.zeros((n, 3, 3))
        r[:, a, a] = 1.0
        r[:, b, b] = cos
        r[:, c, c] = cos
        r[:, b, c] = -sin
        r[:, c, b] = sin
        out = out @ r
    return out


@dataclass
class BVHJoint:
    """One joint of a BVH hierarchy.

    ``channel_index`` is the column of this joint's first channel in the
    motion array; ``end_sites`` holds the offsets of its End Site children.
    """

    name: str
    parent: int
    offset: np.ndarray
    channels: tuple[str, ...] = ()
    channel_index: int = 0
    end_sites: list = field(default_factory=list)


@dataclass
class BVHData:
    """A parsed BVH file: joints in file order, motion (n_frames, n_channels)."""

    joints: list
    motion: np.ndarray
    frame_time: float
    path: str = "<string>"

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def frame_rate(self) -> float:
        return 1.0 / self.frame_time if self.frame_time > 0 else float("nan")


_VALID_CHANNELS = {
    f"{a}{kind}" for a in "XYZ" for kind in ("position", "rotation")
}


def parse_bvh(source, *, name=None) -> BVHData:
    """Parse BVH text (or a path) into joints and a motion array.

    Parameters
    ----------
    source : str or os.PathLike
        A path to a ``.bvh`` file, or BVH text itself (anything containing
        ``HIERARCHY``).
    name : str, optional
        Name used in error messages when `source` is text.

    Raises
    ------
    FileFormatError
        Naming the file, the line and the problem, for a malformed or
        truncated file.

    Examples
    --------
    >>> text = '''HIERARCHY
    ... ROOT Hips
    ... {
    ...   OFFSET 0 0 0
    ...   CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
    ...   End Site
    ...   {
    ...     OFFSET 0 1 0
    ...   }
    ... }
    ... MOTION
    ... Frames: 2
    ... Frame Time: 0.5
    ... 0 0 0 0 0 0
    ... 1 2 3 90 0 0
    ... '''
    >>> bvh = parse_bvh(text)
    >>> bvh.joint_names, bvh.motion.shape, bvh.frame_rate
    (['Hips'], (2, 6), 2.0)
    """
    if isinstance(source, os.PathLike) or (isinstance(source, str) and "\n" not in source):
        path = os.fspath(source)
        with open(path, encoding="utf-8", errors="replace") as fh:
            text = fh.read()
    else:
        text = str(source)
        path = name or "<string>"
    lines = text.splitlines()

    def fail(lineno, msg):
        raise FileFormatError(f"{path}, line {lineno}: {msg}")

    # --- tokenise the hierarchy, keeping line numbers ---------------------
    i = 0
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines) or lines[i].split()[0].upper() != "HIERARCHY":
        fail(i + 1, "expected 'HIERARCHY' at the start of a BVH file")
    i += 1
    joints: list[BVHJoint] = []
    stack: list[int] = []  # joint indices; -2 marks an End Site block
    pending = None  # ("joint", name) or ("end",) waiting for "{"
    n_channels = 0
    seen_root = False
    motion_line = None
    while i < len(lines):
        lineno = i + 1
        tokens = lines[i].split()
        i += 1
        if not tokens:
            continue
        key = tokens[0].upper()
        if key in ("ROOT", "JOINT"):
            if len(tokens) < 2:
                fail(lineno, f"{tokens[0]} needs a joint name")
            if key == "ROOT":
                if stack or seen_root:
                    fail(lineno, "a second ROOT (only one skeleton per file is supported)")
                seen_root = True
            elif not stack or stack[-1] < 0:
                fail(lineno, "JOINT outside a joint block")
            pending = ("joint", " ".join(tokens[1:]))
        elif key == "END":
            if not stack or stack[-1] < 0:
                fail(lineno, "End Site outside a joint block")
            pending = ("end",)
        elif key == "{":
            if pending is None:
                fail(lineno, "'{' without a ROOT, JOINT or End Site before it")
            if pending[0] == "joint":
                parent = stack[-1] if stack else -1
                joints.append(BVHJoint(pending[1], parent, None))
                stack.append(len(joints) - 1)
            else:
                stack.append(-2)
                joints[_last_joint(stack)].end_sites.append(None)
            pending = None
        elif key == "}":
            if not stack:
                fail(lineno, "unbalanced '}'")
            top = stack.pop()
            if top >= 0 and joints[top].offset is None:
                fail(lineno, f"joint {joints[top].name!r} has no OFFSET")
            if top == -2 and joints[_last_joint(stack)].end_sites[-1] is None:
                fail(lineno, "End Site has no OFFSET")
        elif key == "OFFSET":
            if not stack:
                fail(lineno, "OFFSET outside a joint block")
            try:
                offset = np.array([float(v) for v in tokens[1:]])
            except ValueError:
                fail(lineno, f"OFFSET values are not numbers: {' '.join(tokens[1:])!r}")
            if offset.shape != (3,):
                fail(lineno, f"OFFSET needs 3 numbers, got {len(tokens) - 1}")
            if stack[-1] == -2:
                joints[_last_joint(stack)].end_sites[-1] = offset
            else:
                joints[stack[-1]].offset = offset
        elif key == "CHANNELS":
            if not stack or stack[-1] < 0:
                fail(lineno, "CHANNELS outside a joint block")
            try:
                count = int(tokens[1])
            except (IndexError, ValueError):
                fail(lineno, "CHANNELS needs a channel count")
            chans = tuple(tokens[2:])
            if len(chans) != count:
                fail(lineno, f"CHANNELS says {count} channels but lists {len(chans)}")
            for ch in chans:
                if ch.capitalize() not in _VALID_CHANNELS:
                    fail(lineno, f"unknown channel {ch!r}")
            joint = joints[stack[-1]]
            joint.channels = tuple(ch.capitalize() for ch in chans)
            joint.channel_index = n_channels
            n_channels += count
        elif key == "MOTION":
            if stack:
                fail(lineno, f"MOTION before the hierarchy is closed ({len(stack)} '{{' still open)")
            motion_line = lineno
            break
        else:
            fail(lineno, f"unexpected {tokens[0]!r} in the HIERARCHY section")
    if motion_line is None:
        fail(len(lines), "no MOTION section (file truncated?)")
    if not joints:
        fail(motion_line, "no joints in the HIERARCHY section")

    # --- MOTION header ------------------------------------------------------
    def header(prefix):
        nonlocal i
        while i < len(lines) and not lines[i].strip():
            i += 1
        if i >= len(lines):
            fail(len(lines), f"missing '{prefix}' line after MOTION (file truncated?)")
        line = lines[i].strip()
        i += 1
        m = re.match(rf"{prefix}\s*:?\s*(\S+)\s*$", line, flags=re.IGNORECASE)
        if not m:
            fail(i, f"expected '{prefix}: <number>', got {line!r}")
        return m.group(1)

    value = header("Frames")
    try:
        n_frames = int(value)
    except ValueError:
        fail(i, f"the frame count {value!r} is not an integer")
    value = header("Frame Time")
    try:
        frame_time = float(value)
    except ValueError:
        fail(i, f"the frame time {value!r} is not a number")

    first = i
    rows = lines[first:]
    while rows and not rows[-1].strip():
        rows.pop()
    counts = [len(r.split()) for r in rows]
    for k, c in enumerate(counts):
        if c != n_channels:
            fail(first + k + 1, f"{c} channel values on a MOTION line, expected {n_channels}")
    if len(rows) != n_frames:
        if len(rows) < n_frames:
            fail(first + len(rows), f"'Frames: {n_frames}' but only {len(rows)} frame lines (file truncated?)")
        fail(first + n_frames + 1, f"'Frames: {n_frames}' but {len(rows)} frame lines")
    try:
        motion = np.array(" ".join(rows).split(), dtype=float)
    except ValueError:
        for k, r in enumerate(rows):
            try:
                [float(v) for v in r.split()]
            except ValueError:
                fail(first + k + 1, "a channel value is not a number")
        raise  # pragma: no cover
    motion = motion.reshape(n_frames, n_channels)
    if not np.all(np.isfinite(motion)):
        k = int(np.flatnonzero(~np.isfinite(motion).all(axis=1))[0])
        fail(first + k + 1, "non-finite channel value")
    return BVHData(joints=joints, motion=motion, frame_time=frame_time, path=path)


def _last_joint(stack):
    for s in reversed(stack):
        if s >= 0:
            return s
    raise AssertionError("End Site without a joint")  # pragma: no cover


def bvh_forward_kinematics(bvh: BVHData):
    """Global positions and rotations of every joint over all frames.

    Returns
    -------
    positions : ndarray, shape (n_frames, n_joints, 3)
        In file units.
    rotations : ndarray, shape (n_frames, n_joints, 3, 3)
        Global rotation of each joint's frame.
    """
    n = bvh.motion.shape[0]
    nj = len(bvh.joints)
    pos = np.zeros((n, nj, 3))
    rot = np.zeros((n, nj, 3, 3))
    for j, joint in enumerate(bvh.joints):
        trans = np.broadcast_to(joint.offset, (n, 3)).copy()
        rot_axes, rot_cols = "", []
        for k, ch in enumerate(joint.channels):
            col = joint.channel_index + k
            if ch.endswith("position"):
                trans[:, _AXIS[ch[0]]] = bvh.motion[:, col]
            else:
                rot_axes += ch[0]
                rot_cols.append(col)
        local = (
            rotation_matrices(bvh.motion[:, rot_cols], rot_axes)
            if rot_axes else np.broadcast_to(np.eye(3), (n, 3, 3))
        )
        if joint.parent < 0:
            pos[:, j] = trans
            rot[:, j] = local
        else:
            p = joint.parent
            pos[:, j] = pos[:, p] + np.einsum("nij,nj->ni", rot[:, p], trans)
            rot[:, j] = rot[:, p] @ local
    return pos, rot


def detect_rig(joint_names) -> str:
    """Name of the rig in :data:`RIGS` whose joints are all present.

    Raises
    ------
    FileFormatError
        If no rig fits; the message lists, per rig, the joints missing.

    Examples
    --------
    >>> detect_rig(["Hips", "Neck1", "Head", "LeftArm"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: unknown BVH rig: ...
    """
    names = set(joint_names)
    missing = {}
    for rig, (_, mapping) in RIGS.items():
        need = {src[1] for src in mapping.values()}
        miss = sorted(need - names)
        if not miss:
            return rig
        missing[rig] = miss
    detail = "; ".join(f"{rig} rig misses {', '.join(m)}" for rig, m in missing.items())
    raise FileFormatError(f"unknown BVH rig: {detail}")


def load_bvh(path, *, rig=None, scale=None, return_info=False):
    r"""3D positions of the 14 joints over the frames of a BVH file, in metres.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.bvh`` file (or BVH text).
    rig : {"bandai", "cmu"}, optional
        Joint-name mapping; detected from the joint names by default.
    scale : float, optional
        File units -> metres; the rig's default (Bandai 0.01, CMU
        (1/0.45)*2.54/100) when not given.
    return_info : bool
        Also return a dict with ``rig``, ``scale``, ``frame_rate``.

    Returns
    -------
    poses : ndarray, shape (n_frames, 14, 3)
        In the order of :data:`sparseedm.skeleton.SKELETON_14`, world frame of
        the file (Y-up for both rigs), metres.

    Examples
    --------
    >>> poses = load_bvh("tests/fixtures/cmu_02_01_short.bvh")  # doctest: +SKIP
    >>> poses.shape  # doctest: +SKIP
    (20, 14, 3)

    A file whose joints fit no rig is refused with the names it misses:

    >>> text = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 1 Xposition\n}\n"
    >>> load_bvh(text + "MOTION\nFrames: 1\nFrame Time: 0.01\n0\n")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: <string>: unknown BVH rig: bandai rig misses Foot_L, ...
    """
    bvh = path if isinstance(path, BVHData) else parse_bvh(path)
    if rig is None:
        try:
            rig = detect_rig(bvh.joint_names)
        except FileFormatError as exc:
            raise FileFormatError(f"{bvh.path}: {exc}") from None
    if rig not in RIGS:
        raise ValueError(f"unknown rig {rig!r}; known: {', '.join(RIGS)}")
    default_scale, mapping = RIGS[rig]
    scale = default_scale if scale is None else float(scale)
    names = bvh.joint_names
    missing = sorted({src[1] for src in mapping.values()} - set(names))
    if missing:
        raise FileFormatError(f"{bvh.path}: the {rig} rig needs joints {', '.join(missing)}")
    pos, rot = bvh_forward_kinematics(bvh)
    out = np.empty((pos.shape[0], len(JOINT_NAMES), 3))
    for k, jname in enumerate(JOINT_NAMES):
        src = mapping[jname]
        j = names.index(src[1])
        if src[0] == "joint":
            out[:, k] = pos[:, j]
        elif src[0] == "end":
            if not bvh.joints[j].end_sites:
                raise FileFormatError(f"{bvh.path}: joint {src[1]!r} has no End Site for {jname}")
            out[:, k] = pos[:, j] + rot[:, j] @ bvh.joints[j].end_sites[0]
        else:  # extend along the joint's own bone direction
            direction = bvh.joints[j].offset
            norm = np.linalg.norm(direction)
            if norm == 0:
                raise FileFormatError(f"{bvh.path}: joint {src[1]!r} has a zero OFFSET; cannot place {jname}")
            out[:, k] = pos[:, j] + rot[:, j] @ (direction / norm * (src[2] / scale))
    out *= scale
    if return_info:
        return out, {"rig": rig, "scale": scale, "frame_rate": bvh.frame_rate}
    return out
