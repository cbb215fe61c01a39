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
* World frame: as in the file (the known rigs are Y-up, right-handed).
* Rigs mapped onto :data:`sparseedm.skeleton.SKELETON_14` are detected by
  joint names (case-insensitive, prefixes ignored) from the families of
  :data:`sparseedm.mocap.rigs.FAMILIES`, or named by a user joint map; the
  unit is chosen by :func:`sparseedm.mocap.rigs.choose_units`. Head-top
  conventions per family:

  - ``"bandai"`` (Bandai-Namco-Research-Motiondataset, centimetres): its
    ``Head`` End Site has a zero offset, so **head_top is the point 0.2 m from
    the Head joint along the Head joint's local axis that points from Neck to
    Head** (the direction of Head's OFFSET, rotated by Head's global rotation).
  - ``"cmu"`` (the CMU Graphics Lab "cgspeed" BVH conversion: Hips,
    LHipJoint, LeftUpLeg, ..., Neck, Neck1, Head; CMU's 1/0.45-inch unit,
    ``(1.0 / 0.45) * 2.54 / 100`` m): head_top is the Head End Site, neck is
    ``Neck1`` (the top of CMU's ``lowerneck`` bone, as in
    :mod:`sparseedm.mocap.asf_amc`).
  - ``"daz"``: the head has only eye children, so head_top is 0.18 m beyond
    ``head`` along the neck -> head bone, as for Bandai.
  - the others: see :mod:`sparseedm.mocap.rigs`.

  A ``scale`` argument overrides the unit.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ..exceptions import FileFormatError
from ..skeleton import JOINT_NAMES
from . import rigs as _rigs
from ._text import read_text
from .rigs import CMU_SCALE, check_units, read_joint_map, resolve_units

__all__ = [
    "BVHJoint",
    "BVHData",
    "resolve_sources",
    "rest_pose_kinematics",
    "CMU_SCALE",
    "parse_bvh",
    "bvh_forward_kinematics",
    "detect_rig",
    "load_bvh",
    "rotation_matrices",
]

#: distance from the Bandai Head joint to the defined head top, in metres
BANDAI_HEAD_TOP = 0.2

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
    """A parsed BVH file: joints in file order, motion (n_frames, n_channels).

    Parameters
    ----------
    joints : list of BVHJoint
        The hierarchy's joints in file order (a joint's parent comes first).
    motion : ndarray (n_frames, n_channels)
        The MOTION section: one row per frame, the joints' channels in file
        order.
    frame_time : float
        Seconds per frame (the ``Frame Time`` line).
    path : str, default "<string>"
        The file parsed, for messages.
    """

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

    Returns
    -------
    BVHData
        The joints (names, parents, offsets, channels) and the motion.

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
    lines, path = read_text(source, name)
    joints, n_channels, i = _parse_hierarchy(lines, path)
    motion, frame_time = _parse_motion(lines, i, n_channels, path)
    return BVHData(joints=joints, motion=motion, frame_time=frame_time, path=path)


def _parse_hierarchy(lines, path):
    """The HIERARCHY section: ``(joints, n_channels, index of the line after MOTION)``."""

    def fail(lineno, msg):
        raise FileFormatError(f"{path}, line {lineno}: {msg}")

    i = _after_hierarchy_keyword(lines, fail)
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
            _check_offset_given(joints, stack, top, lambda msg: fail(lineno, msg))
        elif key == "OFFSET":
            if not stack:
                fail(lineno, "OFFSET outside a joint block")
            offset = _offset(tokens, lambda msg: fail(lineno, msg))
            if stack[-1] == -2:
                joints[_last_joint(stack)].end_sites[-1] = offset
            else:
                joints[stack[-1]].offset = offset
        elif key == "CHANNELS":
            if not stack or stack[-1] < 0:
                fail(lineno, "CHANNELS outside a joint block")
            chans = _channels(tokens, lambda msg: fail(lineno, msg))
            count = len(chans)
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
    return joints, n_channels, i


def _after_hierarchy_keyword(lines, fail):
    """Index of the line after the leading ``HIERARCHY`` (blank lines skipped)."""
    i = 0
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines) or lines[i].split()[0].upper() != "HIERARCHY":
        fail(i + 1, "expected 'HIERARCHY' at the start of a BVH file")
    return i + 1


def _check_offset_given(joints, stack, top, fail):
    """A closed block (`top`: a joint index, or -2 for an End Site inside the joint
    on `stack`) had its OFFSET; `fail(msg)` raises naming the line."""
    if top >= 0 and joints[top].offset is None:
        fail(f"joint {joints[top].name!r} has no OFFSET")
    if top == -2 and joints[_last_joint(stack)].end_sites[-1] is None:
        fail("End Site has no OFFSET")


def _offset(tokens, fail):
    """An OFFSET line's three finite numbers; `fail(msg)` raises naming the line."""
    try:
        offset = np.array([float(v) for v in tokens[1:]])
    except ValueError:
        fail(f"OFFSET values are not numbers: {' '.join(tokens[1:])!r}")
    if offset.shape != (3,):
        fail(f"OFFSET needs 3 numbers, got {len(tokens) - 1}")
    if not np.all(np.isfinite(offset)):
        fail("OFFSET values must be finite numbers")
    return offset


def _channels(tokens, fail):
    """A CHANNELS line's channel names (as written); `fail(msg)` raises naming the line."""
    try:
        count = int(tokens[1])
    except (IndexError, ValueError):
        fail("CHANNELS needs a channel count")
    chans = tuple(tokens[2:])
    if len(chans) != count:
        fail(f"CHANNELS says {count} channels but lists {len(chans)}")
    for ch in chans:
        if ch.capitalize() not in _VALID_CHANNELS:
            fail(f"unknown channel {ch!r}")
    return chans


def _parse_motion(lines, i, n_channels, path):
    """The MOTION section from line index `i`: ``(motion (frames, channels), frame_time)``."""

    def fail(lineno, msg):
        raise FileFormatError(f"{path}, line {lineno}: {msg}")

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
    if n_frames < 1:
        fail(i, f"'Frames: {value}': the file has no motion frames")
    value = header("Frame Time")
    try:
        frame_time = float(value)
    except ValueError:
        fail(i, f"the frame time {value!r} is not a number")
    if not (np.isfinite(frame_time) and frame_time > 0):
        fail(i, f"the frame time {value!r} must be a positive number of seconds")

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
    return motion, frame_time


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


def detect_rig(joint_names, end_sites=None) -> str:
    """Name of the first rig family (:data:`sparseedm.mocap.rigs.FAMILIES`) that fits.

    `end_sites` names the joints with an End Site (all of them if not given).

    Parameters
    ----------
    joint_names : sequence of str
        The file's joint names.
    end_sites : sequence of str, optional
        Joints that end in an End Site.

    Returns
    -------
    str
        The family's name.

    Raises
    ------
    FileFormatError
        If no family fits; the message lists, per family, what is missing.

    Examples
    --------
    >>> detect_rig(["mixamorig:Hips", "mixamorig:Neck", "mixamorig:HeadTop_End"]
    ...            + [f"mixamorig:{s}{j}" for s in ("Left", "Right")
    ...               for j in ("Arm", "ForeArm", "Hand", "UpLeg", "Leg", "Foot")])
    'mixamo'
    >>> detect_rig(["Hips", "Neck1", "Head", "LeftArm"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: unknown BVH rig: ...
    """
    names = list(joint_names)
    rig, _ = _rigs.detect_family(names, names if end_sites is None else end_sites)
    return rig.name


def resolve_sources(bvh: BVHData, *, rig=None, joint_map=None):
    """The rig of a parsed BVH file and the source of each of the 14 joints.

    Parameters
    ----------
    bvh : BVHData
    rig : str, optional
        A family name of :data:`sparseedm.mocap.rigs.FAMILIES`; detected from
        the joint names by default.
    joint_map : dict or path, optional
        A user joint map (:func:`sparseedm.mocap.rigs.read_joint_map`); its
        joints override the family's, its ``rig``/``units`` are used when
        given.

    Returns
    -------
    rig_name : str
        The family's name, or ``"joint-map"`` when the map alone names all 14.
    default_units : str or None
        The family's (or the map's) unit.
    sources : dict
        14-joint name -> :class:`sparseedm.mocap.rigs.Source` (file's names).
    """
    names = bvh.joint_names
    ends = [j.name for j in bvh.joints if j.end_sites]
    jmap = None
    if joint_map is not None:
        jmap = read_joint_map(joint_map)
        rig = rig or jmap["rig"]
    overrides = {}
    if jmap is not None:
        for joint, src in jmap["joints"].items():
            found = _rigs.match_names(src.names(), names)
            lost = [n for n in src.names() if n not in found]
            if lost:
                raise FileFormatError(
                    f"{bvh.path}: the joint map ({jmap['path']}) names {', '.join(lost)} for "
                    f"{joint}, but the file has no such joint (its joints: "
                    f"{', '.join(names[:40])}{' ...' if len(names) > 40 else ''})")
            src = src.renamed(found)
            if src.kind == "end" and src.joint not in ends:
                raise FileFormatError(f"{bvh.path}: joint {src.joint!r} has no End Site "
                                      f"(joint map {jmap['path']}, {joint})")
            overrides[joint] = src
    if rig is not None:
        family = _rigs.family(rig)
        resolved, missing = _rigs.resolve_rig(family, names, ends)
        left = [j for j in JOINT_NAMES if j not in resolved and j not in overrides]
        if left:
            raise FileFormatError(f"{bvh.path}: the {rig} rig cannot place "
                                  f"{', '.join(left)} in this file; name them in a joint map")
        name, units = family.name, family.units
    elif len(overrides) == len(JOINT_NAMES):
        resolved, name, units = {}, "joint-map", None
    else:
        try:
            family, resolved = _rigs.detect_family(names, ends)
        except FileFormatError as exc:
            if overrides:
                left = [j for j in JOINT_NAMES if j not in overrides]
                raise FileFormatError(
                    f"{bvh.path}: the joint map names {len(overrides)} of the 14 joints and "
                    f"no known rig fits the rest ({', '.join(left)}): {exc}") from None
            raise FileFormatError(f"{bvh.path}: {exc}") from None
        name, units = family.name, family.units
    if jmap is not None and jmap["units"] is not None:
        units = jmap["units"]
    return name, units, {**resolved, **overrides}


def _place(bvh: BVHData, pos, rot, sources, scale, path) -> np.ndarray:
    """(n, 14, 3) metres from FK positions/rotations (file units)."""
    index = {j.name: k for k, j in enumerate(bvh.joints)}
    out = np.empty((pos.shape[0], len(JOINT_NAMES), 3))
    for k, jname in enumerate(JOINT_NAMES):
        src = sources[jname]
        j = index[src.joint]
        if src.kind == "joint":
            out[:, k] = pos[:, j]
        elif src.kind == "end":
            out[:, k] = pos[:, j] + rot[:, j] @ bvh.joints[j].end_sites[0]
        elif src.kind == "along":
            direction = bvh.joints[j].offset
            norm = np.linalg.norm(direction)
            if norm == 0:
                raise FileFormatError(f"{path}: joint {src.joint!r} has a zero OFFSET; "
                                      f"cannot place {jname} along its bone")
            out[:, k] = pos[:, j] + rot[:, j] @ (direction / norm * (src.distance / scale))
        elif src.kind == "offset":
            out[:, k] = pos[:, j] + rot[:, j] @ (np.asarray(src.vector) / scale)
        else:  # extrapolate
            o = index[src.other]
            out[:, k] = pos[:, j] + src.factor * (pos[:, j] - pos[:, o])
    return out * scale


def rest_pose_kinematics(bvh: BVHData):
    """FK of the rest pose (OFFSETs only, no channel values), one frame."""
    rest = BVHData(
        joints=[BVHJoint(j.name, j.parent, j.offset, (), 0, j.end_sites) for j in bvh.joints],
        motion=np.zeros((1, 0)), frame_time=bvh.frame_time, path=bvh.path,
    )
    return bvh_forward_kinematics(rest)


def load_bvh(path, *, rig=None, scale=None, units="auto", joint_map=None, return_info=False):
    r"""3D positions of the 14 joints over the frames of a BVH file, in metres.

    Parameters
    ----------
    path : str, os.PathLike or BVHData
        The ``.bvh`` file (or BVH text).
    rig : str, optional
        A rig family (:data:`sparseedm.mocap.rigs.FAMILIES`: ``"cmu"``,
        ``"mixamo"``, ``"daz"``, ...); detected from the joint names by
        default (case-insensitive, namespace prefixes ignored).
    scale : float, optional
        File units -> metres; overrides `units`.
    units : {"auto", "m", "cm", "mm", "inch", "cmu"}
        The file's length unit. ``"auto"`` takes the rig family's usual unit
        if it gives a plausible standing height for the rest pose, else the
        unit that does, and raises :class:`sparseedm.mocap.rigs.UnitsError`
        (naming the file, the height and the fix) if none does.
    joint_map : dict or path, optional
        A user joint map (:func:`sparseedm.mocap.rigs.read_joint_map`).
    return_info : bool
        Also return a dict: ``rig``, ``units``, ``scale``, ``height``
        (standing height in metres, see :mod:`sparseedm.mocap.rigs`), ``frame_rate``, ``sources`` (14-joint name -> source
        description), ``tpose_frames`` (indices of T-pose frames).

    Returns
    -------
    poses : ndarray, shape (n_frames, 14, 3)
        In the order of :data:`sparseedm.skeleton.SKELETON_14`, world frame of
        the file, metres.

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
    sparseedm.exceptions.FileFormatError: <string>: unknown BVH rig: mixamo rig misses ...
    """
    bvh = path if isinstance(path, BVHData) else parse_bvh(path)
    if joint_map is not None:
        joint_map = read_joint_map(joint_map)
    rig_name, default_units, sources = resolve_sources(bvh, rig=rig, joint_map=joint_map)
    if units is None or units == "auto":
        units = (joint_map or {}).get("units") or "auto"
    check_units(units)  # before the kinematics
    pos, rot = bvh_forward_kinematics(bvh)
    rpos, rrot = rest_pose_kinematics(bvh)
    sample = np.unique(np.linspace(0, max(len(pos) - 1, 0), min(len(pos), 200)).astype(int))

    def height(s):
        return max(
            float(_rigs.standing_height(_place(bvh, rpos, rrot, sources, s, bvh.path))[0]),
            float(np.percentile(_rigs.standing_height(
                _place(bvh, pos[sample], rot[sample], sources, s, bvh.path)), 95)),
        )

    unit_name, scale = resolve_units(height, scale=scale, units=units, default=default_units,
                                     path=bvh.path)
    out = _place(bvh, pos, rot, sources, scale, bvh.path)
    if return_info:
        return out, {
            "rig": rig_name, "units": unit_name, "scale": scale, "height": height(scale),
            "frame_rate": bvh.frame_rate,
            "sources": {j: sources[j].describe() for j in JOINT_NAMES},
            "joint_map": {j: sources[j] for j in JOINT_NAMES},
            "tpose_frames": _rigs.tpose_frames(out),
        }
    return out
