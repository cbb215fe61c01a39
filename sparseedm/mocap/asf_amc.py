"""CMU ASF/AMC motion capture -> 3D positions of the 14 joints, in metres.

The ASF file holds the skeleton (units, root, one ``begin ... end`` block per
bone with ``direction``, ``length``, ``axis``, ``dof``, ``limits``, then the
``:hierarchy``); the AMC file holds one block per frame: the frame number,
then one line per bone with its DOF values.

Forward kinematics (the standard Acclaim one, as in the CMU viewer)
-------------------------------------------------------------------
For a bone ``b`` with parent ``p``::

    C_b  = Rz(az) Ry(ay) Rx(ax)            from ``axis ax ay az XYZ``
    M_b  = product of the dof rotations, the first listed dof applied first
           (``dof rx ry rz`` -> Rz Ry Rx)
    G_b  = G_p C_b M_b C_b^-1              (G_root = C_root M_root C_root^-1)
    end_b = start_b + G_b (length_b * direction_b),  start_b = end_p

The root's start is its AMC translation. Lengths are converted to metres by
``scale = 0.0254 / length_unit`` (the ASF ``:units length``), i.e. the CMU
FAQ's ``(1.0 / 0.45) * 2.54 / 100`` for CMU's ``length 0.45``. The world frame
is the ASF's: Y-up, right-handed.

Mapping onto :data:`sparseedm.skeleton.SKELETON_14` (CMU's ``l``/``r`` are
the subject's left/right):

=============== ==========================================
head_top        end of ``head``
neck            end of ``lowerneck`` (= start of ``upperneck``)
shoulder        end of ``lclavicle`` / ``rclavicle``
elbow           end of ``lhumerus`` / ``rhumerus``
wrist           end of ``lradius`` / ``rradius``
hip             end of ``lhipjoint`` / ``rhipjoint``
knee            end of ``lfemur`` / ``rfemur``
ankle           end of ``ltibia`` / ``rtibia``
=============== ==========================================
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from ..exceptions import FileFormatError
from ..skeleton import JOINT_NAMES
from ._text import read_text
from . import rigs
from .bvh import rotation_matrices
from .rigs import read_joint_map

__all__ = [
    "ASFBone",
    "ASFSkeleton",
    "JOINT_BONES",
    "parse_asf",
    "parse_amc",
    "asf_forward_kinematics",
    "load_asf_amc",
    "asf_joint_bones",
    "find_asf",
    "write_cmu_bvh",
]

#: 14-joint name -> ASF bone whose *end* is that joint
JOINT_BONES = {
    "head_top": "head",
    "neck": "lowerneck",
    "right_shoulder": "rclavicle",
    "right_elbow": "rhumerus",
    "right_wrist": "rradius",
    "left_shoulder": "lclavicle",
    "left_elbow": "lhumerus",
    "left_wrist": "lradius",
    "right_hip": "rhipjoint",
    "right_knee": "rfemur",
    "right_ankle": "rtibia",
    "left_hip": "lhipjoint",
    "left_knee": "lfemur",
    "left_ankle": "ltibia",
}

CMU_FRAME_RATE = 120.0


@dataclass
class ASFBone:
    """One ``begin ... end`` block of an ASF ``:bonedata`` section."""

    name: str
    direction: np.ndarray
    length: float
    axis: np.ndarray
    axis_order: str = "XYZ"
    dof: tuple[str, ...] = ()
    limits: list = field(default_factory=list)


@dataclass
class ASFSkeleton:
    """A parsed ASF file.

    Parameters
    ----------
    bones : dict of str to ASFBone
        The ``:bonedata`` blocks by bone name.
    parents : dict of str to str
        A bone's parent bone name (``"root"`` for the root's children).
    order : list of str
        The bones parents-first.
    root_order : tuple of str, default ("TX", "TY", "TZ", "RX", "RY", "RZ")
        The root's motion channels, in the order an AMC frame lists them.
    root_axis : str, default "XYZ"
        The axis order of `root_orientation` (the ASF root's ``axis``).
    root_orientation : ndarray (3,), default zeros
        The root's rest orientation: Euler angles in degrees, in `root_axis` order.
    root_position : ndarray (3,), default zeros
        The root's rest position (file length units); channels absent from
        `root_order` keep it.
    length_unit : float, default 1.0
        The ASF ``:units length``: file units are inches divided by it.
    angle_unit : {"deg", "rad"}, default "deg"
        The ASF ``:units angle``: the unit of the AMC motion's angles.
    path : str, default "<string>"
        The file parsed, for messages.
    """

    bones: dict
    parents: dict
    order: list
    root_order: tuple[str, ...] = ("TX", "TY", "TZ", "RX", "RY", "RZ")
    root_axis: str = "XYZ"
    root_orientation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    root_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    length_unit: float = 1.0
    angle_unit: str = "deg"
    path: str = "<string>"

    @property
    def scale(self) -> float:
        """File length units -> metres (``0.0254 / length_unit``)."""
        return 0.0254 / self.length_unit


def _floats(tokens, path, lineno, what):
    try:
        values = np.array([float(t) for t in tokens])
    except ValueError:
        raise FileFormatError(
            f"{path}, line {lineno}: {what} values are not numbers: {' '.join(tokens)!r}"
        ) from None
    if not np.all(np.isfinite(values)):
        raise FileFormatError(f"{path}, line {lineno}: {what} values must be finite numbers")
    return values


def parse_asf(source, *, name=None) -> ASFSkeleton:
    """Parse an ASF skeleton file (a path, or the text itself).

    Parameters
    ----------
    source : str or path-like
        An ASF file, or its text.
    name : str, optional
        What to call the source in error messages.

    Returns
    -------
    ASFSkeleton
        Its bones, units and root.

    Raises
    ------
    FileFormatError
        Naming the file and line: missing ``:bonedata`` or ``:hierarchy``,
        a bone without ``name``/``direction``/``length``, an unknown bone in
        the hierarchy, a bad number ...

    Examples
    --------
    >>> text = '''
    ... :units
    ...   length 0.45
    ...   angle deg
    ... :root
    ...   order TX TY TZ RX RY RZ
    ...   axis XYZ
    ...   position 0 0 0
    ...   orientation 0 0 0
    ... :bonedata
    ...   begin
    ...     id 1
    ...     name lfemur
    ...     direction 0 -1 0
    ...     length 7.5
    ...     axis 0 0 20 XYZ
    ...     dof rx ry rz
    ...     limits (-160.0 20.0)
    ...            (-70.0 70.0)
    ...            (-60.0 70.0)
    ...   end
    ... :hierarchy
    ...   begin
    ...     root lfemur
    ...   end
    ... '''
    >>> skel = parse_asf(text)
    >>> skel.order, skel.bones["lfemur"].dof, round(skel.scale, 5)
    (['lfemur'], ('rx', 'ry', 'rz'), 0.05644)
    """
    lines, path = read_text(source, name)

    def fail(lineno, msg):
        raise FileFormatError(f"{path}, line {lineno}: {msg}")

    sections: dict[str, int] = {}
    bones: dict[str, ASFBone] = {}
    bone_lines: dict[str, int] = {}
    parents: dict[str, str] = {}
    skel = ASFSkeleton(bones=bones, parents=parents, order=[], path=path)
    section = None
    bone = None  # dict being filled inside begin/end of :bonedata
    in_begin = False
    for idx, raw in enumerate(lines):
        lineno = idx + 1
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        tokens = line.split()
        if tokens[0].startswith(":"):
            if bone is not None:
                fail(lineno, f"bone block not closed with 'end' before {tokens[0]}")
            section = tokens[0].lower()
            if section == ":hierarchy" and ":bonedata" not in sections:
                fail(lineno, "no :bonedata section before :hierarchy")
            sections[section] = lineno
            in_begin = False
            continue
        key = tokens[0].lower()
        if section == ":units":
            _read_units_into(skel, key, tokens, lineno, fail)
        elif section == ":root":
            _read_root_into(skel, key, tokens, path, lineno, fail)
        elif section == ":bonedata":
            if key == "begin":
                if bone is not None:
                    fail(lineno, "'begin' inside a bone block")
                bone = {"line": lineno, "limits": []}
            elif key == "end":
                if bone is None:
                    fail(lineno, "'end' without 'begin'")
                closed = _closed_bone(bone, bones, lineno, fail)
                bones[closed.name], bone_lines[closed.name] = closed, bone["line"]
                bone = None
            elif bone is None:
                fail(lineno, f"{tokens[0]!r} outside a 'begin ... end' bone block")
            else:
                _read_bone_line_into(bone, key, tokens, line, path, lineno, fail)
        elif section == ":hierarchy":
            if key == "begin":
                in_begin = True
            elif key == "end":
                in_begin = False
            elif in_begin:
                parent = tokens[0]
                if parent != "root" and parent not in bones:
                    fail(lineno, f"unknown bone {parent!r} in :hierarchy")
                for child in tokens[1:]:
                    if child not in bones:
                        fail(lineno, f"unknown bone {child!r} in :hierarchy")
                    if child in parents:
                        fail(lineno, f"bone {child!r} has two parents")
                    parents[child] = parent
        # other sections (:version, :name, :documentation ...) are ignored
    end = len(lines)
    if bone is not None:
        fail(end, f"bone block starting at line {bone['line']} is not closed (file truncated?)")
    if ":bonedata" not in sections:
        fail(end, "no :bonedata section")
    if ":hierarchy" not in sections:
        fail(end, "no :hierarchy section (file truncated?)")
    skel.order = _bone_order(bones, parents, bone_lines, fail)
    return skel


def _read_units_into(skel, key, tokens, lineno, fail):
    """A line of the :units section, into `skel`."""
    if key == "length":
        try:
            skel.length_unit = float(tokens[1])
        except (IndexError, ValueError):
            fail(lineno, "':units length' needs a number")
        if skel.length_unit <= 0:
            fail(lineno, "':units length' must be positive")
    elif key == "angle":
        unit = tokens[1].lower() if len(tokens) > 1 else ""
        if unit not in ("deg", "rad"):
            fail(lineno, f"unknown angle unit {unit!r} (expected deg or rad)")
        skel.angle_unit = unit


def _read_root_into(skel, key, tokens, path, lineno, fail):
    """A line of the :root section, into `skel`."""
    if key == "order":
        skel.root_order = tuple(t.upper() for t in tokens[1:])
        bad = [t for t in skel.root_order if t not in {"TX", "TY", "TZ", "RX", "RY", "RZ"}]
        if bad:
            fail(lineno, f"unknown root channel {bad[0]!r}")
    elif key == "axis":
        if len(tokens) < 2 or not re.fullmatch("[XYZ]{3}", tokens[1].upper()):
            fail(lineno, "root 'axis' needs an order like XYZ")
        skel.root_axis = tokens[1].upper()
    elif key in ("position", "orientation"):
        vals = _floats(tokens[1:], path, lineno, f"root {key}")
        if vals.shape != (3,):
            fail(lineno, f"root {key} needs 3 numbers")
        setattr(skel, f"root_{key}", vals)


def _read_bone_line_into(bone, key, tokens, line, path, lineno, fail):
    """A line inside a bone's ``begin ... end`` block, into `bone` (a dict)."""
    if key == "id":
        pass
    elif key == "name":
        if len(tokens) < 2:
            fail(lineno, "'name' needs a bone name")
        bone["name"] = tokens[1]
    elif key == "direction":
        d = _floats(tokens[1:], path, lineno, "direction")
        if d.shape != (3,):
            fail(lineno, "direction needs 3 numbers")
        bone["direction"] = d
    elif key == "length":
        v = _floats(tokens[1:], path, lineno, "length")
        if v.shape != (1,) or v[0] < 0:
            fail(lineno, "length needs one non-negative number")
        bone["length"] = float(v[0])
    elif key == "axis":
        if len(tokens) != 5 or not re.fullmatch("[XYZ]{3}", tokens[4].upper()):
            fail(lineno, "axis needs 3 angles and an order like XYZ")
        bone["axis"] = _floats(tokens[1:4], path, lineno, "axis")
        bone["axis_order"] = tokens[4].upper()
    elif key == "dof":
        dof = tuple(t.lower() for t in tokens[1:])
        bad = [t for t in dof if t not in ("rx", "ry", "rz", "tx", "ty", "tz", "l")]
        if bad:
            fail(lineno, f"unknown dof {bad[0]!r}")
        bone["dof"] = dof
    elif key in ("limits", "bodymass", "cofmass") or key.startswith("("):
        if key == "limits" or key.startswith("("):
            bone["limits"].append(line)
    else:
        fail(lineno, f"unexpected {tokens[0]!r} in a bone block")


def _closed_bone(bone, bones, lineno, fail):
    """A bone block's ``end``: the bone (a dict of its lines) checked against
    `bones` (those closed before it) and returned as an :class:`ASFBone`."""
    for need in ("name", "direction", "length"):
        if need not in bone:
            fail(lineno, f"bone block starting at line {bone['line']} has no {need!r}")
    if bone["name"] in bones:
        fail(bone["line"], f"bone {bone['name']!r} defined twice")
    if len(bone["limits"]) not in (0, len(bone.get("dof", ()))):
        fail(lineno, f"bone {bone['name']!r} has {len(bone['limits'])} limits for "
             f"{len(bone.get('dof', ()))} dofs")
    return ASFBone(
        name=bone["name"], direction=bone["direction"], length=bone["length"],
        axis=bone.get("axis", np.zeros(3)), axis_order=bone.get("axis_order", "XYZ"),
        dof=bone.get("dof", ()), limits=bone["limits"],
    )


def _bone_order(bones, parents, bone_lines, fail):
    """The bones parents-first from the root; a bone not reached fails."""
    children: dict[str, list] = {}
    for child, parent in parents.items():
        children.setdefault(parent, []).append(child)
    order, todo = [], list(children.get("root", []))
    while todo:
        b = todo.pop(0)
        order.append(b)
        todo.extend(children.get(b, []))
    unreached = [b for b in bones if b not in order]
    if unreached:
        fail(bone_lines[unreached[0]], f"bone {unreached[0]!r} is not connected to the root in :hierarchy")
    return order


def parse_amc(source, skeleton: ASFSkeleton, *, name=None):
    """Parse an AMC motion file against its skeleton.

    Parameters
    ----------
    source : str or path-like
        An AMC file, or its text.
    skeleton : ASFSkeleton
        The skeleton it moves (:func:`parse_asf`).
    name : str, optional
        What to call the source in error messages.

    Returns
    -------
    motion : dict
        ``"root"`` -> (n_frames, len(root_order)) and each bone with dofs ->
        (n_frames, len(dof)) arrays of the raw values (degrees for CMU).
    degrees : bool
        Whether the angles are in degrees (``:DEGREES``/ASF ``angle deg``).

    Raises
    ------
    FileFormatError
        Naming the file and line: an unknown bone, a wrong number of values,
        a frame missing a bone (truncated file), no frames at all.
    """
    lines, path = read_text(source, name)
    degrees = skeleton.angle_unit == "deg"
    expected = {b.name: len(b.dof) for b in skeleton.bones.values()}
    expected["root"] = len(skeleton.root_order)
    values: dict[str, list] = {k: [] for k, v in expected.items() if v > 0}
    lines_of: dict[str, list] = {k: [] for k in values}
    frame_start = []  # line number of each frame's number
    n_frames = 0
    for idx, raw in enumerate(lines):
        line = raw.strip()
        if not line or line[0] == "#":
            continue
        if line[0] == ":":
            key = line.split()[0].upper()
            if key == ":RADIANS":
                degrees = False
            elif key == ":DEGREES":
                degrees = True
            continue
        tokens = line.split()
        head = tokens[0]
        if head.isdigit():
            if n_frames:
                _check_frame(values, n_frames, path, idx, frame_start[-1])
            n_frames += 1
            frame_start.append(idx + 1)
            continue
        lineno = idx + 1
        if not n_frames:
            raise FileFormatError(f"{path}, line {lineno}: bone values before the first frame number")
        want = expected.get(head)
        if want is None:
            raise FileFormatError(f"{path}, line {lineno}: unknown bone {head!r} (not in {skeleton.path})")
        if len(tokens) - 1 != want:
            raise FileFormatError(
                f"{path}, line {lineno}: bone {head!r} has {len(tokens) - 1} values, expected {want}"
            )
        if want == 0:
            continue
        vals = values[head]
        if len(vals) >= n_frames:
            raise FileFormatError(f"{path}, line {lineno}: bone {head!r} given twice in frame {n_frames}")
        vals.append(tokens)
        lines_of[head].append(lineno)
    if not n_frames:
        raise FileFormatError(f"{path}, line {len(lines)}: no frames")
    _check_frame(values, n_frames, path, len(lines), frame_start[-1])
    motion = {}
    for k, v in values.items():
        try:  # one C-level conversion; find the culprit only on failure
            arr = np.array(v, dtype=object)[:, 1:].astype(float)
        except ValueError:
            for tokens, lineno in zip(v, lines_of[k]):
                try:
                    [float(t) for t in tokens[1:]]
                except ValueError:
                    raise FileFormatError(
                        f"{path}, line {lineno}: values of {k!r} are not numbers"
                    ) from None
            raise  # pragma: no cover
        if not np.all(np.isfinite(arr)):
            row = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
            raise FileFormatError(f"{path}, line {lines_of[k][row]}: non-finite value for "
                                  f"bone {k!r}")
        motion[k] = arr
    return motion, degrees


def _check_frame(values, n_frames, path, idx, start):
    for k, v in values.items():
        if len(v) < n_frames:
            raise FileFormatError(
                f"{path}, line {idx}: frame {n_frames} (from line {start}) has no values "
                f"for bone {k!r} (file truncated?)"
            )


def asf_forward_kinematics(skeleton: ASFSkeleton, motion, *, degrees=True):
    """Start and end of every bone over all frames, in file units.

    Returns
    -------
    ends : dict
        bone name -> (n_frames, 3) position of the bone's end (``"root"`` ->
        the root translation).
    rotations : dict
        bone name -> (n_frames, 3, 3) global rotation G_b.
    """
    root = motion["root"]
    n = root.shape[0]
    to_deg = 1.0 if degrees else 180.0 / np.pi
    order = skeleton.root_order
    trans = np.tile(skeleton.root_position, (n, 1)).astype(float)
    for k, ch in enumerate(order):
        if ch[0] == "T":
            trans[:, "XYZ".index(ch[1])] = root[:, k]
    rot_cols = [k for k, ch in enumerate(order) if ch[0] == "R"]
    root_m = _extrinsic(root[:, rot_cols] * to_deg, "".join(order[k][1] for k in rot_cols))
    c_root = _extrinsic(skeleton.root_orientation[None], skeleton.root_axis)[0]
    ends = {"root": trans}
    rots = {"root": c_root @ root_m @ c_root.T}
    for name in skeleton.order:
        bone = skeleton.bones[name]
        parent = skeleton.parents[name]
        c = _extrinsic(bone.axis[None], bone.axis_order)[0]
        rot_dofs = [k for k, d in enumerate(bone.dof) if d[0] == "r"]
        if rot_dofs:
            vals = motion[name][:, rot_dofs] * to_deg
            m = _extrinsic(vals, "".join(bone.dof[k][1].upper() for k in rot_dofs))
            g = rots[parent] @ (c @ m @ c.T)
        else:
            g = rots[parent] @ (c @ c.T)
        rots[name] = g
        ends[name] = ends[parent] + g @ (bone.length * bone.direction)
    return ends, rots


def _extrinsic(angles_deg, axes):
    """Rotation applying the listed axes first-to-last (``XYZ`` -> Rz Ry Rx)."""
    angles_deg = np.asarray(angles_deg, dtype=float)
    return rotation_matrices(angles_deg[:, ::-1], axes[::-1])


def find_asf(amc_path) -> Path:
    """The ASF skeleton of a CMU AMC file: ``NN.asf`` beside ``NN_MM.amc``.

    Falls back to the only ``.asf`` in the folder.

    Parameters
    ----------
    amc_path : str or path-like
        The AMC file.

    Returns
    -------
    Path
        Its ASF file.

    Examples
    --------
    >>> find_asf("/nonexistent/02_01.amc")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: .../02_01.amc: no skeleton file 02.asf beside it
    """
    amc_path = Path(amc_path)
    subject = amc_path.stem.split("_")[0]
    candidate = amc_path.with_name(f"{subject}.asf")
    if candidate.is_file():
        return candidate
    others = sorted(amc_path.parent.glob("*.asf")) if amc_path.parent.is_dir() else []
    if len(others) == 1:
        return others[0]
    raise FileFormatError(f"{amc_path}: no skeleton file {subject}.asf beside it")


def asf_joint_bones(skeleton: ASFSkeleton, joint_map=None) -> dict:
    """14-joint name -> the ASF bone whose end it is (case-insensitive names).

    The Acclaim names of :data:`JOINT_BONES` (CMU's and HDM05's ASF use them)
    by default; a joint map (:func:`sparseedm.mocap.rigs.read_joint_map`)
    may name other bones (``"neck": "upperneck"`` or ``{"end_site":
    "upperneck"}``: the end of that bone).

    Raises
    ------
    FileFormatError
        A bone that is missing, or a joint-map rule other than a bone name.
    """
    lower = {b.lower(): b for b in skeleton.bones}
    wanted = dict(JOINT_BONES)
    if joint_map is not None:
        jmap = read_joint_map(joint_map)
        for joint, src in jmap["joints"].items():
            if src.kind not in ("joint", "end"):
                raise FileFormatError(
                    f"{skeleton.path}: an ASF joint is the end of a bone; the joint map "
                    f"({jmap['path']}) gives {joint} as {src.describe()!r}")
            wanted[joint] = src.joint
    out, missing = {}, []
    for joint in JOINT_NAMES:
        bone = lower.get(wanted[joint].lower())
        if bone is None:
            missing.append(wanted[joint])
        else:
            out[joint] = bone
    if missing:
        raise FileFormatError(f"{skeleton.path}: the skeleton has no bone(s) {', '.join(missing)} "
                              "needed for the 14 joints (name others with --joint-map)")
    return out


def load_asf_amc(asf, amc, *, scale=None, units="auto", joint_map=None, return_info=False):
    """3D positions of the 14 joints over the frames of a CMU AMC file, in metres.

    Parameters
    ----------
    asf : str, os.PathLike or ASFSkeleton
        The skeleton (``None`` finds ``NN.asf`` beside ``NN_MM.amc``).
    amc : str or os.PathLike
        The motion.
    scale : float, optional
        File length units -> metres; overrides `units`.
    units : {"auto", "m", "cm", "mm", "inch", "cmu"}
        ``"auto"``: the ASF's own ``:units length`` (``0.0254 / length``,
        the CMU FAQ's ``(1.0/0.45)*2.54/100`` for CMU) if the skeleton's
        standing height is then plausible, else the unit that makes it so,
        else :class:`sparseedm.mocap.rigs.UnitsError` (see
        :func:`sparseedm.mocap.rigs.choose_units`).
    joint_map : dict or path, optional
        Other bones for some of the 14 joints (:func:`asf_joint_bones`).
    return_info : bool
        Also return a dict with ``rig`` (``"acclaim-asf"``), ``units``,
        ``scale``, ``height``, ``frame_rate`` (120, CMU's), ``sources``,
        ``tpose_frames``.

    Returns
    -------
    poses : ndarray, shape (n_frames, 14, 3)
        Joint order of :data:`sparseedm.skeleton.SKELETON_14`, Y-up world
        frame, metres.

    Examples
    --------
    >>> poses = load_asf_amc("tests/fixtures/cmu_02.asf",
    ...                      "tests/fixtures/cmu_02_01_short.amc")  # doctest: +SKIP
    >>> poses.shape  # doctest: +SKIP
    (20, 14, 3)

    An AMC file needs its ASF skeleton (``NN.asf`` for ``NN_MM.amc``):

    >>> load_asf_amc(None, "/nonexistent/07_01.amc")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: .../07_01.amc: no skeleton file 07.asf beside it
    """
    if units is None or units == "auto":
        units = (rigs.read_joint_map(joint_map)["units"] if joint_map is not None else None) \
            or "auto"
    rigs.check_units(units)  # before the kinematics, as load_bvh
    if asf is None:
        asf = find_asf(amc)
    skel = asf if isinstance(asf, ASFSkeleton) else parse_asf(asf)
    bones = asf_joint_bones(skel, joint_map)
    motion, degrees = parse_amc(amc, skel)
    ends, _ = asf_forward_kinematics(skel, motion, degrees=degrees)
    raw = np.stack([ends[bones[j]] for j in JOINT_NAMES], axis=1)
    rest_motion = {k: np.zeros((1, v.shape[1])) for k, v in motion.items()}
    rest_ends, _ = asf_forward_kinematics(skel, rest_motion, degrees=degrees)
    rest = np.stack([rest_ends[bones[j]] for j in JOINT_NAMES], axis=1)
    sample = raw[np.unique(np.linspace(0, len(raw) - 1, min(len(raw), 200)).astype(int))]
    raw_height = max(float(rigs.standing_height(rest)[0]),
                     float(np.percentile(rigs.standing_height(sample), 95)))
    unit_name, scale = rigs.resolve_units(lambda s: raw_height * s, scale=scale, units=units,
                                          default="asf", path=str(amc),
                                          extra={"asf": skel.scale})
    poses = raw * scale
    if return_info:
        return poses, {"rig": "acclaim-asf", "units": unit_name, "scale": scale,
                       "height": raw_height * scale, "frame_rate": CMU_FRAME_RATE,
                       "sources": {j: f"end of bone {bones[j]}" for j in JOINT_NAMES},
                       "tpose_frames": rigs.tpose_frames(poses)}
    return poses


#: ASF bone -> joint name of the CMU BVH conversion (the joint at the bone's start)
CMU_BVH_NAMES = {
    "lhipjoint": "LHipJoint", "lfemur": "LeftUpLeg", "ltibia": "LeftLeg",
    "lfoot": "LeftFoot", "ltoes": "LeftToeBase",
    "rhipjoint": "RHipJoint", "rfemur": "RightUpLeg", "rtibia": "RightLeg",
    "rfoot": "RightFoot", "rtoes": "RightToeBase",
    "lowerback": "LowerBack", "upperback": "Spine", "thorax": "Spine1",
    "lowerneck": "Neck", "upperneck": "Neck1", "head": "Head",
    "lclavicle": "LeftShoulder", "lhumerus": "LeftArm", "lradius": "LeftForeArm",
    "lwrist": "LeftHand", "lhand": "LeftFingerBase", "lfingers": "LeftHandIndex1",
    "lthumb": "LThumb",
    "rclavicle": "RightShoulder", "rhumerus": "RightArm", "rradius": "RightForeArm",
    "rwrist": "RightHand", "rhand": "RightFingerBase", "rfingers": "RightHandIndex1",
    "rthumb": "RThumb",
}


def _check_bvh_motion(skeleton, motion, n, path):
    """Refuse what a BVH cannot hold: a channel value that is not finite, a joint
    name that is not printable text without tabs, line breaks, runs of spaces
    or spaces at its ends (the reader joins a JOINT line's words with one space)."""
    for name, values in motion.items():
        bad = ~np.isfinite(np.asarray(values, dtype=float)).reshape(n, -1).all(axis=1)
        if bad.any():
            raise FileFormatError(f"{path}: frame {int(np.flatnonzero(bad)[0])} of the motion "
                                  f"has a {name} channel value that is not a finite number "
                                  "(NaN or infinite); a BVH holds numbers")
    for bone in skeleton.order:
        name = CMU_BVH_NAMES.get(bone, bone)
        if not (isinstance(name, str) and name.isprintable() and name
                and name == " ".join(name.split())):
            raise FileFormatError(f"{path}: joint name {name!r} cannot be written: a BVH "
                                  "joint name is printable text, without tabs, line breaks, "
                                  "runs of spaces or spaces at its ends")


def _frame_time_text(frame_time, n):
    """A BVH's ``Frame Time`` as written (8 decimals, or every digit when 8 would
    read as 0), refused unless finite and > 0, and `n` frames refused unless >= 1."""
    if n < 1:
        raise FileFormatError("a BVH needs at least one motion frame; the motion has none")
    try:
        frame_time = float(frame_time)
    except (TypeError, ValueError):
        raise FileFormatError(f"frame_time must be a number of seconds, got {frame_time!r}") \
            from None
    if not 0 < frame_time < np.inf:
        raise FileFormatError(f"frame_time must be a finite number of seconds > 0, got "
                              f"{frame_time}")
    text = f"{frame_time:.8f}"
    return text if float(text) > 0 else repr(frame_time)


def write_cmu_bvh(skeleton: ASFSkeleton, motion, path, *, degrees=True, frame_time=1 / 120):
    """Write ASF/AMC motion as a BVH file with the CMU BVH conversion's names.

    Each BVH joint sits at the start of its ASF bone, carries the bone's
    local rotation ``C M C^-1`` as ``Zrotation Yrotation Xrotation`` and has
    the parent bone's ``length * direction`` as OFFSET (file units kept).
    Loading the result with :func:`sparseedm.mocap.bvh.load_bvh` gives the
    same 14 joints as :func:`load_asf_amc`.

    It writes only what :func:`~sparseedm.mocap.bvh.load_bvh` reads: at least
    one frame, a `frame_time` that is a finite number of seconds > 0 (written
    with 8 decimals, or every digit when 8 would read as 0), finite channel
    values and joint names it reads back as written; anything else raises
    :class:`~sparseedm.exceptions.FileFormatError` before the file is made.

    Parameters
    ----------
    skeleton : ASFSkeleton
        The ASF skeleton.
    motion : dict
        Its AMC motion (:func:`parse_amc`).
    path : str or path-like
        The BVH file to write.
    degrees : bool
        Whether the AMC angles are in degrees.
    frame_time : float
        Seconds per frame.
    """
    from scipy.spatial.transform import Rotation

    root = motion["root"]
    n = root.shape[0]
    time_text = _frame_time_text(frame_time, n)
    _check_bvh_motion(skeleton, motion, n, path)
    to_deg = 1.0 if degrees else 180.0 / np.pi
    order = skeleton.root_order
    trans = np.zeros((n, 3))
    for k, ch in enumerate(order):
        if ch[0] == "T":
            trans[:, "XYZ".index(ch[1])] = root[:, k]
    rot_cols = [k for k, ch in enumerate(order) if ch[0] == "R"]
    c_root = _extrinsic(skeleton.root_orientation[None], skeleton.root_axis)[0]
    m = _extrinsic(root[:, rot_cols] * to_deg, "".join(order[k][1] for k in rot_cols))
    local = {"root": c_root @ m @ c_root.T}
    for name in skeleton.order:
        bone = skeleton.bones[name]
        c = _extrinsic(bone.axis[None], bone.axis_order)[0]
        rot_dofs = [k for k, d in enumerate(bone.dof) if d[0] == "r"]
        if rot_dofs:
            mm = _extrinsic(motion[name][:, rot_dofs] * to_deg,
                            "".join(bone.dof[k][1].upper() for k in rot_dofs))
        else:
            mm = np.broadcast_to(np.eye(3), (n, 3, 3))
        local[name] = c @ mm @ c.T
    children: dict[str, list] = {}
    for b in skeleton.order:
        children.setdefault(skeleton.parents[b], []).append(b)

    def euler(mats):  # intrinsic Z, Y, X in degrees
        return Rotation.from_matrix(mats).as_euler("ZYX", degrees=True)

    out = ["HIERARCHY"]
    columns = [trans, euler(local["root"])]

    def fmt(v):
        return " ".join(f"{x:.6f}" for x in v)

    def emit(bone, depth, offset):
        ind = "  " * depth
        out.append(f"{ind}JOINT {CMU_BVH_NAMES.get(bone, bone)}")
        out.append(f"{ind}{{")
        out.append(f"{ind}  OFFSET {fmt(offset)}")
        out.append(f"{ind}  CHANNELS 3 Zrotation Yrotation Xrotation")
        columns.append(euler(local[bone]))
        b = skeleton.bones[bone]
        vec = b.length * b.direction
        kids = children.get(bone, [])
        for kid in kids:
            emit(kid, depth + 1, vec)
        if not kids:
            out.append(f"{ind}  End Site")
            out.append(f"{ind}  {{")
            out.append(f"{ind}    OFFSET {fmt(vec)}")
            out.append(f"{ind}  }}")
        out.append(f"{ind}}}")

    out += ["ROOT Hips", "{", "  OFFSET 0.000000 0.000000 0.000000",
            "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation"]
    for kid in children.get("root", []):
        emit(kid, 1, np.zeros(3))
    out.append("}")
    out += ["MOTION", f"Frames: {n}", f"Frame Time: {time_text}"]
    data = np.concatenate(columns, axis=1)
    if not np.isfinite(data).all():  # e.g. a root translation of 1e308 turned
        raise FileFormatError(f"{path}: the motion gives channel values that are not "
                              "finite numbers; a BVH holds numbers")
    out += [fmt(row) for row in data]
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(out) + "\n", encoding="utf-8")
