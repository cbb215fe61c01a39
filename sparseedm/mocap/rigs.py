"""Rig families, user joint maps and units: how a mocap skeleton maps onto the 14 joints.

A *rig* says, for each joint of :data:`sparseedm.skeleton.SKELETON_14`, where
in the source skeleton it is (a :class:`Source`), and which length unit the
family usually writes. The families known out of the box are data
(:data:`FAMILIES`); a user's own rig is a small JSON (or TOML) *joint map*
read by :func:`read_joint_map`.

Name matching
-------------
Joint names are compared case-insensitively, and a namespace or character
prefix is ignored: a family's ``LeftArm`` matches ``LeftArm``, ``leftarm``,
``mixamorig:LeftArm``, ``Character1_LeftArm`` or ``Armature|LeftArm`` (a
source name that *ends* with the wanted one after a ``:``, ``|``, ``_`` or
``.`` separator), as long as exactly one joint matches. An exact match wins.

Sources (the head-top rules included)
-------------------------------------
=============================== ===============================================
JSON form                       point
=============================== ===============================================
``"Name"``/``{"joint": "Name"}`` the joint's position
``{"end_site": "Name"}``        the end of the joint's bone: its first End Site
``{"joint": "Name",             the joint plus `along_bone` metres along its own
"along_bone": 0.18}``           bone (the direction of its OFFSET, rotated by
                                its global rotation: neck -> head for a head)
``{"joint": "Name",             the joint plus a vector in metres given in the
"offset": [0, 0.18, 0]}``       joint's local frame
``{"extrapolate": ["Neck",      ``Head + factor * (Head - Neck)`` (global
"Head"], "factor": 1.0}``       positions): the neck -> head line extended
=============================== ===============================================

Units
-----
:data:`UNITS` maps ``m``, ``cm``, ``mm``, ``inch`` and ``cmu`` (CMU's
1/0.45-inch ASF unit) to metres. ``auto`` (the default everywhere) decides
from the standing height (head top to the ankles' midpoint) of the skeleton:
the larger of its *rest pose*'s (offsets only, no motion) and the 95th
percentile over the clip's frames (some rigs, Bandai's for one, have a rest
pose that is not standing: every offset along a local x axis). It takes the
family's usual unit if it gives a height within :data:`HEIGHT_RANGE`, else
the one unit that does (no two units can: the range is narrower than their
ratios); with none a :class:`UnitsError` names the file, the height per unit
and the fix (``--units`` or ``--joint-map``). An explicit unit is taken as
given (the per-clip plausibility check of :func:`plausibility` still warns).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._safeio import regular_file
from ..exceptions import FileFormatError, SparseEDMError

_MAX_MAP_BYTES = 16 << 20  # a joint map is a few kB
from ..skeleton import JOINT_NAMES, SKELETON_14

__all__ = [
    "Source",
    "Rig",
    "FAMILIES",
    "UNITS",
    "HEIGHT_RANGE",
    "UnitsError",
    "match_names",
    "resolve_rig",
    "detect_family",
    "read_joint_map",
    "joint_map_to_json",
    "choose_units",
    "standing_height",
    "tpose_frames",
    "plausibility",
    "chirality",
    "family",
    "RIGID_BONES",
]

#: CMU's length unit (ASF ``length 0.45``) in metres: (1.0/0.45) * 2.54 / 100
CMU_SCALE = (1.0 / 0.45) * 2.54 / 100

#: unit name -> metres per file unit
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "inch": 0.0254, "cmu": CMU_SCALE}

#: plausible standing height of a person (head top to ankles), metres. The
#: ratio of its ends (2.2) is below that of any two units of :data:`UNITS`
#: (inch/cmu 2.22, cm/inch 2.54, ...), so at most one unit is plausible.
HEIGHT_RANGE = (1.0, 2.2)

#: the height ``auto`` prefers when several units are plausible, metres
TYPICAL_HEIGHT = 1.7


class UnitsError(SparseEDMError):
    """No length unit gives the skeleton a plausible human height."""


@dataclass(frozen=True)
class Source:
    """Where one of the 14 joints is in a source skeleton.

    ``kind`` is ``"joint"``, ``"end"`` (End Site), ``"along"`` (``distance``
    metres along the joint's own bone), ``"offset"`` (``vector`` metres in the
    joint's local frame) or ``"extrapolate"`` (``joint + factor * (joint -
    other)``).

    Examples
    --------
    >>> Source("along", "Head", distance=0.2).describe()
    'Head + 0.2 m along its bone'
    >>> Source.from_json({"extrapolate": ["Neck", "Head"], "factor": 1.0}, "map.json").to_json()
    {'extrapolate': ['Neck', 'Head'], 'factor': 1.0}
    """

    kind: str
    joint: str
    other: str = ""
    distance: float = 0.0
    vector: tuple = (0.0, 0.0, 0.0)
    factor: float = 1.0

    def names(self) -> tuple[str, ...]:
        """Source joint names this rule needs."""
        return (self.other, self.joint) if self.kind == "extrapolate" else (self.joint,)

    def renamed(self, lookup) -> "Source":
        """The same rule with names passed through `lookup` (a dict)."""
        return Source(self.kind, lookup[self.joint], lookup.get(self.other, self.other),
                      self.distance, self.vector, self.factor)

    def describe(self) -> str:
        if self.kind == "joint":
            return self.joint
        if self.kind == "end":
            return f"End Site of {self.joint}"
        if self.kind == "along":
            return f"{self.joint} + {self.distance:g} m along its bone"
        if self.kind == "offset":
            return f"{self.joint} + ({', '.join(f'{v:g}' for v in self.vector)}) m in its frame"
        return f"{self.joint} + {self.factor:g} x ({self.other} -> {self.joint})"

    def to_json(self):
        if self.kind == "joint":
            return self.joint
        if self.kind == "end":
            return {"end_site": self.joint}
        if self.kind == "along":
            return {"joint": self.joint, "along_bone": self.distance}
        if self.kind == "offset":
            return {"joint": self.joint, "offset": list(self.vector)}
        return {"extrapolate": [self.other, self.joint], "factor": self.factor}

    @classmethod
    def from_json(cls, value, where: str) -> "Source":
        """Parse one joint-map entry; `where` names it in errors."""
        def bad(msg):
            raise FileFormatError(f"{where}: {msg}")

        if isinstance(value, str):
            return cls("joint", value)
        if not isinstance(value, dict):
            bad(f"expected a joint name or an object, got {value!r}")
        keys = set(value)
        try:
            if keys == {"joint"}:
                return cls("joint", str(value["joint"]))
            if keys == {"end_site"}:
                return cls("end", str(value["end_site"]))
            if keys == {"joint", "along_bone"}:
                return cls("along", str(value["joint"]), distance=_number(value["along_bone"]))
            if keys == {"joint", "offset"}:
                vec = tuple(_number(v) for v in value["offset"])
                if len(vec) != 3:
                    bad("'offset' needs 3 numbers (metres, in the joint's local frame)")
                return cls("offset", str(value["joint"]), vector=vec)
            if keys in ({"extrapolate"}, {"extrapolate", "factor"}):
                pair = value["extrapolate"]
                if not isinstance(pair, list) or len(pair) != 2:
                    bad("'extrapolate' needs [from_joint, to_joint], e.g. [\"Neck\", \"Head\"]")
                return cls("extrapolate", str(pair[1]), other=str(pair[0]),
                           factor=_number(value.get("factor", 1.0)))
        except (TypeError, ValueError) as exc:
            bad(f"bad value in {value!r} ({exc})")
        bad(f"unknown rule {value!r}; use a name, {{'joint': ...}}, {{'end_site': ...}}, "
            "{'joint': ..., 'along_bone': metres}, {'joint': ..., 'offset': [x, y, z]} "
            "or {'extrapolate': [from, to], 'factor': f}")


def _number(v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise ValueError(f"{v!r} is not a finite number")
    return float(v)


def _j(name):
    return Source("joint", name)


def _end(name):
    return Source("end", name)


def _along(name, metres):
    return Source("along", name, distance=metres)


@dataclass(frozen=True)
class Rig:
    """A rig family: per 14-joint name, alternative sources (first present wins).

    Parameters
    ----------
    name : str
        The family's short name (``"mixamo"``, ``"cmu"``, ...).
    title : str
        A line describing the family and the joint names that tell it.
    units : str or None
        The family's usual length unit (a key of :data:`UNITS`), or ``None``
        when the family is written in several (``auto`` then decides from
        the height alone).
    joints : dict of str to tuple of Source
        For each of the 14 joint names, the sources to try in order; exactly
        the 14 joints or ValueError.
    """

    name: str
    title: str
    units: str | None
    joints: dict = field(default_factory=dict)

    def __post_init__(self):
        if set(self.joints) != set(JOINT_NAMES):
            raise ValueError(f"rig {self.name!r} must map exactly the 14 joints")


def _limbs(sides, **names):
    """{14-joint: (Source, ...)} for the limb joints, from name templates."""
    out = {}
    for side, tag in sides.items():
        for joint, templates in names.items():
            out[f"{side}_{joint}"] = tuple(_j(t.format(s=tag)) for t in templates)
    return out


_LR = {"right": "Right", "left": "Left"}
#: the families recognised without a joint map, tried in this order
FAMILIES: tuple[Rig, ...] = (
    Rig("mixamo", "Mixamo (HeadTop_End; usually a mixamorig: prefix)", "cm", {
        "head_top": (_j("HeadTop_End"),),
        "neck": (_j("Neck"),),
        **_limbs(_LR, shoulder=["{s}Arm"], elbow=["{s}ForeArm"], wrist=["{s}Hand"],
                 hip=["{s}UpLeg"], knee=["{s}Leg"], ankle=["{s}Foot"]),
    }),
    Rig("cmu", "CMU cgspeed / MotionBuilder (Neck1, LeftUpLeg, LeftArm)", "cmu", {
        "head_top": (_end("Head"), _along("Head", 0.18)),
        "neck": (_j("Neck1"),),
        **_limbs(_LR, shoulder=["{s}Arm"], elbow=["{s}ForeArm"], wrist=["{s}Hand"],
                 hip=["{s}UpLeg"], knee=["{s}Leg"], ankle=["{s}Foot"]),
    }),
    Rig("motionbuilder", "MotionBuilder / HumanIK (Neck, LeftUpLeg, LeftArm)", None, {
        "head_top": (_end("Head"), _j("HeadEnd"), _j("Head_End"), _along("Head", 0.18)),
        "neck": (_j("Neck"),),
        **_limbs(_LR, shoulder=["{s}Arm"], elbow=["{s}ForeArm"], wrist=["{s}Hand"],
                 hip=["{s}UpLeg"], knee=["{s}Leg"], ankle=["{s}Foot"]),
    }),
    Rig("cmu-3dsmax", "CMU 3ds Max / MocapBank (LeftHip, LeftKnee, LeftCollar, LeftShoulder)",
        None, {
        "head_top": (_end("Head"), _along("Head", 0.18)),
        "neck": (_j("Neck"),),
        **_limbs(_LR, shoulder=["{s}Shoulder"], elbow=["{s}Elbow"], wrist=["{s}Wrist"],
                 hip=["{s}Hip"], knee=["{s}Knee"], ankle=["{s}Ankle"]),
    }),
    Rig("daz", "Daz (hip, abdomen, rShldr, rThigh; Genesis bend/twist names too)", "cm", {
        "head_top": (_along("head", 0.18),),
        "neck": (_j("neck"), _j("neckLower")),
        **_limbs({"right": "r", "left": "l"},
                 shoulder=["{s}Shldr", "{s}ShldrBend"], elbow=["{s}ForeArm", "{s}ForearmBend"],
                 wrist=["{s}Hand"], hip=["{s}Thigh", "{s}ThighBend"], knee=["{s}Shin"],
                 ankle=["{s}Foot"]),
    }),
    Rig("reallusion", "Reallusion Character Creator (CC_Base_L_Thigh ...)", "cm", {
        "head_top": (_end("CC_Base_Head"), _along("CC_Base_Head", 0.18)),
        "neck": (_j("CC_Base_NeckTwist02"), _j("CC_Base_NeckTwist01")),
        **_limbs({"right": "R", "left": "L"}, shoulder=["CC_Base_{s}_Upperarm"],
                 elbow=["CC_Base_{s}_Forearm"], wrist=["CC_Base_{s}_Hand"],
                 hip=["CC_Base_{s}_Thigh"], knee=["CC_Base_{s}_Calf"],
                 ankle=["CC_Base_{s}_Foot"]),
    }),
    Rig("bandai", "Bandai-Namco research (UpperArm_L, UpperLeg_L)", "cm", {
        # the Head End Site has a zero offset: a point 0.2 m beyond Head, along Neck -> Head
        "head_top": (_along("Head", 0.2),),
        "neck": (_j("Neck"),),
        **_limbs({"right": "R", "left": "L"}, shoulder=["UpperArm_{s}"],
                 elbow=["LowerArm_{s}"], wrist=["Hand_{s}"], hip=["UpperLeg_{s}"],
                 knee=["LowerLeg_{s}"], ankle=["Foot_{s}"]),
    }),
)

_FAMILY = {r.name: r for r in FAMILIES}

_SEPARATORS = ":|_."


def match_names(wanted, names) -> dict:
    """Map each wanted joint name onto one of `names` (case-insensitive, prefix-tolerant).

    Returns ``{wanted: source name}`` for the names found; a wanted name with
    no match, or with several prefixed matches and no exact one, is left out.

    Examples
    --------
    >>> match_names(["LeftArm", "Head"], ["mixamorig:LeftArm", "mixamorig:Head",
    ...                                  "mixamorig:HeadTop_End"])
    {'LeftArm': 'mixamorig:LeftArm', 'Head': 'mixamorig:Head'}
    >>> match_names(["L_Thigh"], ["CC_Base_L_Thigh"])
    {'L_Thigh': 'CC_Base_L_Thigh'}
    """
    lower = {}
    for n in names:
        lower.setdefault(n.lower(), n)
    out = {}
    for w in wanted:
        key = w.lower()
        if key in lower:
            out[w] = lower[key]
            continue
        hits = [n for k, n in lower.items()
                if k.endswith(key) and k[-len(key) - 1] in _SEPARATORS]
        if len(hits) == 1:
            out[w] = hits[0]
    return out


def resolve_rig(rig: Rig, names, end_sites=()) -> tuple[dict, list]:
    """Sources of the 14 joints in a skeleton with joints `names`.

    Parameters
    ----------
    rig : Rig
    names : list of str
        The source skeleton's joint names.
    end_sites : collection of str
        The names of joints that have an End Site.

    Returns
    -------
    resolved : dict
        14-joint name -> :class:`Source` with the skeleton's own names, for
        every joint whose first usable alternative was found.
    missing : list of str
        The (first choice) source name of each unresolved joint.
    """
    end_sites = set(end_sites)
    resolved, missing = {}, []
    for joint in JOINT_NAMES:
        alts = rig.joints[joint]
        for src in alts:
            found = match_names(src.names(), names)
            if len(found) < len(src.names()):
                continue
            if src.kind == "end" and found[src.joint] not in end_sites:
                continue
            resolved[joint] = src.renamed(found)
            break
        else:
            missing.append(alts[0].joint)
    return resolved, missing


def detect_family(names, end_sites=()) -> tuple[Rig, dict]:
    """The first family of :data:`FAMILIES` that resolves all 14 joints.

    Raises
    ------
    FileFormatError
        Naming, per family, what is missing (and pointing to ``--joint-map``).

    Examples
    --------
    >>> rig, src = detect_family(["hip", "abdomen", "chest", "neck", "head", "rCollar",
    ...     "rShldr", "rForeArm", "rHand", "lCollar", "lShldr", "lForeArm", "lHand",
    ...     "rButtock", "rThigh", "rShin", "rFoot", "lButtock", "lThigh", "lShin", "lFoot"])
    >>> rig.name, src["right_shoulder"].describe(), src["head_top"].describe()
    ('daz', 'rShldr', 'head + 0.18 m along its bone')
    """
    report = []
    for rig in FAMILIES:
        resolved, missing = resolve_rig(rig, names, end_sites)
        if not missing:
            return rig, resolved
        report.append((len(missing), f"{rig.name} rig misses {', '.join(missing[:4])}"
                       + (f" (+{len(missing) - 4} more)" if len(missing) > 4 else "")))
    report.sort(key=lambda r: r[0])  # the closest families first
    raise FileFormatError(
        "unknown BVH rig: " + "; ".join(r[1] for r in report)
        + ". Name the 14 joints with a joint map (--joint-map map.json, see README)"
    )


def family(name: str) -> Rig:
    """The family called `name` (a clear error listing the known ones)."""
    try:
        return _FAMILY[name]
    except KeyError:
        raise ValueError(f"unknown rig {name!r}; known: {', '.join(_FAMILY)}") from None


def read_joint_map(source) -> dict:
    """A user joint map from a .json/.toml file or a dict.

    Format (JSON; TOML the same keys)::

        {"rig": "mixamo",          # optional: a family to start from
         "units": "cm",            # optional: m, cm, mm, inch, cmu or auto
         "joints": {"neck": "Neck", "head_top": {"end_site": "Head"}, ...}}

    ``joints`` may name only some of the 14 joints: the others come from
    ``rig`` or, without it, from the family detected in each file.

    Parameters
    ----------
    source : str, path-like or dict
        A ``.json`` / ``.toml`` file, or the map itself.

    Returns
    -------
    dict
        ``{"rig": str or None, "units": str or None, "joints": {joint: Source},
        "path": str}``.

    Examples
    --------
    >>> m = read_joint_map({"units": "cm", "joints": {"head_top": {"end_site": "Head"}}})
    >>> m["units"], m["joints"]["head_top"].describe()
    ('cm', 'End Site of Head')
    """
    if isinstance(source, dict) and "path" in source and all(
            isinstance(v, Source) for v in source.get("joints", {}).values()):
        return source  # already read
    if isinstance(source, dict):
        raw, where = source, "joint map"
    else:
        path = Path(source)
        where = str(path)
        try:
            if regular_file(path, f"joint map {where}") > _MAX_MAP_BYTES:
                raise FileFormatError(f"{where}: over {_MAX_MAP_BYTES >> 20} MiB; not a joint map")
            data = path.read_bytes()
        except FileNotFoundError:
            raise FileFormatError(f"{where}: no such joint map file") from None
        except OSError as exc:
            raise FileFormatError(f"{where}: cannot read the joint map ({exc.strerror})") from None
        try:
            if path.suffix.lower() == ".toml":
                try:
                    import tomllib
                except ImportError:  # Python 3.10
                    raise FileFormatError(f"{where}: TOML joint maps need Python >= 3.11; "
                                          "write the same keys as JSON") from None
                raw = tomllib.loads(data.decode("utf-8"))
            else:
                raw = json.loads(data.decode("utf-8"))
        except UnicodeDecodeError:
            raise FileFormatError(f"{where}: not UTF-8 text") from None
        except ValueError as exc:  # JSONDecodeError, TOMLDecodeError
            raise FileFormatError(f"{where}: not a valid joint map ({exc})") from None
    if not isinstance(raw, dict):
        raise FileFormatError(f"{where}: a joint map is an object with a 'joints' table")
    unknown = set(raw) - {"rig", "units", "joints", "name", "description"}
    if unknown:
        raise FileFormatError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
    rig = raw.get("rig")
    if rig is not None and rig not in _FAMILY:
        raise FileFormatError(f"{where}: unknown rig {rig!r}; known: {', '.join(_FAMILY)}")
    units = raw.get("units")
    if units is not None and units != "auto" and units not in UNITS:
        raise FileFormatError(f"{where}: unknown units {units!r}; use one of "
                              f"{', '.join(UNITS)} or auto")
    joints = raw.get("joints", {})
    if not isinstance(joints, dict):
        raise FileFormatError(f"{where}: 'joints' must map joint names to sources")
    bad = sorted(set(joints) - set(JOINT_NAMES))
    if bad:
        raise FileFormatError(f"{where}: unknown joint(s) {', '.join(bad)}; the 14 joints are "
                              + ", ".join(JOINT_NAMES))
    parsed = {j: Source.from_json(v, f"{where}: joints.{j}") for j, v in joints.items()}
    return {"rig": rig, "units": None if units == "auto" else units, "joints": parsed,
            "path": where}


def joint_map_to_json(sources: dict, units=None, rig=None) -> dict:
    """A joint-map dict (JSON-ready) from resolved sources: the inverse of
    :func:`read_joint_map`.

    Examples
    --------
    >>> out = joint_map_to_json({"neck": Source("joint", "Neck")}, units="cm")
    >>> read_joint_map(out)["joints"]["neck"] == Source("joint", "Neck")
    True
    """
    out = {}
    if rig is not None:
        out["rig"] = rig
    if units is not None:
        out["units"] = units
    out["joints"] = {j: sources[j].to_json() for j in JOINT_NAMES if j in sources}
    return out


# ------------------------------------------------------------------ units
def standing_height(poses) -> np.ndarray:
    """Head top to the ankles' midpoint, per pose (in the poses' units).

    Orientation-free (a Z-up or lying rest pose measures the same).

    Examples
    --------
    >>> p = np.zeros((1, 14, 3)); p[0, 0] = [0, 1.7, 0]
    >>> standing_height(p)
    array([1.7])
    """
    poses = np.asarray(poses, dtype=float)
    i = SKELETON_14.index
    ankles = poses[:, [i("left_ankle"), i("right_ankle")]].mean(axis=1)
    return np.linalg.norm(poses[:, i("head_top")] - ankles, axis=-1)


def choose_units(height_for, default=None, *, path="<string>", extra=None) -> tuple[str, float]:
    """The unit ``auto`` picks: `default` if plausible, else the plausible one.

    Parameters
    ----------
    height_for : callable
        metres per file unit -> standing height in metres.
    default : str, optional
        The rig family's usual unit.
    extra : dict, optional
        More candidate units (name -> metres per file unit), e.g. an ASF
        file's own ``:units length``; `height_for` is asked about them too.

    Returns
    -------
    (unit name, height in metres)

    Raises
    ------
    UnitsError
        No unit gives a height within :data:`HEIGHT_RANGE`; names the file,
        the heights and the fix.

    Examples
    --------
    >>> choose_units(lambda s: 170 * s, "cmu")   # a cgspeed rig written in cm
    ('cm', 1.7)
    """
    lo, hi = HEIGHT_RANGE
    heights = {u: float(height_for(s)) for u, s in {**UNITS, **(extra or {})}.items()}
    if default is not None and lo <= heights[default] <= hi:
        return default, heights[default]
    ok = [u for u, h in heights.items() if lo <= h <= hi]
    if ok:
        best = min(ok, key=lambda u: abs(np.log(heights[u] / TYPICAL_HEIGHT)))
        return best, heights[best]
    raw = heights["m"]
    raise UnitsError(
        f"{path}: the rest pose is {raw:.4g} file units tall (head top to ankles), which is "
        f"no plausible human height ({lo:g}-{hi:g} m) in any unit "
        f"({', '.join(f'{u}: {h:.3g} m' for u, h in heights.items())}). "
        "Fix: pass the unit with --units (m, cm, mm, inch, cmu), or check the joint map "
        "(--joint-map) if the head top or ankles are the wrong joints"
    )


def check_units(units):
    """`units` itself when it is ``"auto"`` or a name in :data:`UNITS`, else a
    ValueError naming the choices."""
    if units != "auto" and units not in UNITS:
        raise ValueError(f"unknown units {units!r}; use one of {', '.join(UNITS)} or auto")
    return units


def resolve_units(height_for, *, scale=None, units="auto", default=None, path="<string>",
                  extra=None) -> tuple[str, float]:
    """The unit a loader uses and its metres per file unit.

    An explicit `scale` wins (named ``"scale"``); then `units` unless it is
    ``"auto"``; then :func:`choose_units` (`height_for`, `default`, `path` and
    `extra` are its).

    Examples
    --------
    >>> resolve_units(lambda s: 170 * s, units="auto", default="cmu")
    ('cm', 0.01)
    >>> resolve_units(lambda s: 170 * s, scale=0.5)
    ('scale', 0.5)
    >>> resolve_units(lambda s: 1.7 * s, default="asf", extra={"asf": 1.0})
    ('asf', 1.0)
    """
    if scale is not None:
        return "scale", float(scale)
    if check_units(units) != "auto":
        return units, UNITS[units]
    name, _ = choose_units(height_for, default, path=path, extra=extra)
    return name, {**UNITS, **(extra or {})}[name]


# ------------------------------------------------------------------ T-pose
def tpose_frames(poses, *, tol=0.9, edges_only=True) -> np.ndarray:
    """Indices of T-pose frames: both arms straight, level and opposite.

    A frame is a T-pose when each arm is straight (shoulder -> wrist at least
    `tol` of upper arm + forearm), both arms point in opposite directions
    (cosine below ``-tol``) and are perpendicular to the trunk (the absolute cosine
    with neck -> hips midpoint below ``1 - tol``), and both legs are straight.
    With `edges_only` (the default) only the runs of such frames that start
    the clip or end it count: calibration T-poses come first or last, while a
    dancer or a waving person spreads the arms level mid-clip (Bandai-Namco
    has 67 such frames, none a calibration pose).

    Parameters
    ----------
    poses : ndarray, shape (n, 14, 3)
        A clip's joints.
    tol : float
        How straight, level and opposite the arms must be.
    edges_only : bool
        Only the runs that start or end the clip.

    Returns
    -------
    ndarray of int
        Frame indices.

    Examples
    --------
    >>> t = np.zeros((2, 14, 3))
    >>> t[:, :, 1] = [1.8, 1.5, 1.5, 1.5, 1.5, 1.5, 1.5, 1.5, 1, .5, 0, 1, .5, 0]
    >>> t[:, :, 0] = [0, 0, -.2, -.5, -.8, .2, .5, .8, -.1, -.1, -.1, .1, .1, .1]
    >>> t[1, [4, 7], 1] = 1.0   # second frame: wrists dropped
    >>> tpose_frames(t)
    array([0])
    >>> tpose_frames(t[[1, 0, 1]]), tpose_frames(t[[1, 0, 1]], edges_only=False)
    (array([], dtype=int64), array([1]))
    """
    p = np.asarray(poses, dtype=float)
    i = SKELETON_14.index
    hips = p[:, [i("left_hip"), i("right_hip")]].mean(axis=1)
    trunk = _unit(hips - p[:, i("neck")])
    ok = np.ones(len(p), dtype=bool)
    arms = []
    for side in ("left", "right"):
        s, e, w = (p[:, i(f"{side}_{j}")] for j in ("shoulder", "elbow", "wrist"))
        reach = np.linalg.norm(w - s, axis=-1)
        limb = np.linalg.norm(e - s, axis=-1) + np.linalg.norm(w - e, axis=-1)
        arm = _unit(w - s)
        ok &= reach >= tol * limb
        ok &= np.abs(np.einsum("ni,ni->n", arm, trunk)) <= 1 - tol
        arms.append(arm)
        h, k, a = (p[:, i(f"{side}_{j}")] for j in ("hip", "knee", "ankle"))
        leg = np.linalg.norm(k - h, axis=-1) + np.linalg.norm(a - k, axis=-1)
        ok &= np.linalg.norm(a - h, axis=-1) >= tol * leg
    ok &= np.einsum("ni,ni->n", arms[0], arms[1]) <= -tol
    if edges_only and ok.size:
        first = ok.size if ok.all() else int(np.argmin(ok))  # leading run length
        last = ok.size if ok.all() else int(np.argmin(ok[::-1]))  # trailing run length
        edge = np.zeros_like(ok)
        edge[:first] = True
        edge[ok.size - last:] = True
        ok &= edge
    return np.flatnonzero(ok)


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


# ------------------------------------------------------------------ plausibility
#: (a, b) joint pairs that are one rigid bone in every supported rig
RIGID_BONES = (("right_shoulder", "right_elbow"), ("right_elbow", "right_wrist"),
               ("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"),
               ("right_hip", "right_knee"), ("right_knee", "right_ankle"),
               ("left_hip", "left_knee"), ("left_knee", "left_ankle"))


def chirality(poses, *, min_bend=0.02):
    """+1 if left is the subject's left, -1 for a mirror image, None if unknown.

    Knees bend forwards: with ``b`` the knee's offset from the hip-ankle
    midpoint (frames where it exceeds `min_bend`), ``up`` the hips -> neck
    direction and ``lr`` the right hip -> left hip vector, a person has
    ``(lr x up) . b > 0`` -- whatever the world's axes.

    Parameters
    ----------
    poses : array_like (n, 14, 3)
        3D poses of one clip in any axes and units.
    min_bend : float, default 0.02
        Knee offsets at most this long (in the poses' units) do not vote.

    Returns
    -------
    float or None
        The bend-weighted mean sign of the knees' votes, in [-1, 1] (+1: left
        is the subject's left), or None when no knee is bent enough.

    Examples
    --------
    >>> p = np.zeros((1, 14, 3))
    >>> p[0, :, 1] = [1.8, 1.5, 1.5, 1.2, .9, 1.5, 1.2, .9, 1, .5, 0, 1, .5, 0]
    >>> p[0, :, 0] = [0, 0, -.2, -.2, -.2, .2, .2, .2, -.1, -.1, -.1, .1, .1, .1]
    >>> p[0, [9, 12], 2] = 0.1            # knees forward (+z); left is +x
    >>> chirality(p), chirality(p * [-1, 1, 1])
    (1.0, -1.0)
    """
    p = np.asarray(poses, dtype=float)
    i = SKELETON_14.index
    hips = p[:, [i("left_hip"), i("right_hip")]].mean(axis=1)
    up = _unit(p[:, i("neck")] - hips)
    lr = p[:, i("left_hip")] - p[:, i("right_hip")]
    forward = _unit(np.cross(lr, up))
    votes, weights = [], []
    for side in ("left", "right"):
        h, k, a = (p[:, i(f"{side}_{j}")] for j in ("hip", "knee", "ankle"))
        bend = k - (h + a) / 2
        size = np.linalg.norm(bend, axis=-1)
        use = size > min_bend
        votes.append(np.sign(np.einsum("ni,ni->n", forward[use], bend[use])))
        weights.append(size[use])
    w = np.concatenate(weights)
    if w.sum() == 0:
        return None
    return float(np.sum(np.concatenate(votes) * w) / w.sum())


def plausibility(poses, *, height=None, name="clip", rigidity_tol=0.05,
                 symmetry_tol=0.15) -> list[str]:
    """Problems that make a clip an implausible person (empty if none).

    Checks, on poses in metres: the standing height (`height`, e.g. of the
    rest pose, else the 95th percentile over frames) within
    :data:`HEIGHT_RANGE`; each limb bone rigid (max - min within
    `rigidity_tol` of its mean length); left and right limb bones of equal
    mean length within `symmetry_tol`; left on the subject's left
    (:func:`chirality` not below -0.5: knees bending backwards means a mirror
    image, e.g. left and right joints swapped).

    Parameters
    ----------
    poses : ndarray, shape (n, 14, 3)
        A clip's joints in metres.
    height : float, optional
        Its standing height, if already measured.
    name : str
        What to call the clip in the messages.
    rigidity_tol : float
        Allowed relative spread of a limb bone's length over the clip.
    symmetry_tol : float
        Allowed relative difference of left and right limbs.

    Returns
    -------
    list of str
        One message per problem.

    Examples
    --------
    >>> p = np.zeros((3, 14, 3)); p[:, :, 1] = np.linspace(17, 0, 14)
    >>> plausibility(p, name="giant")  # doctest: +ELLIPSIS
    ['giant: standing height 15 m is outside the plausible 1-2.2 m (wrong units? ...)']
    """
    poses = np.asarray(poses, dtype=float)
    problems = []
    if len(poses) == 0:
        return problems
    i = SKELETON_14.index
    h = float(height) if height is not None else float(np.percentile(standing_height(poses), 95))
    lo, hi = HEIGHT_RANGE
    if not lo <= h <= hi:
        problems.append(f"{name}: standing height {h:.3g} m is outside the plausible "
                        f"{lo:g}-{hi:g} m (wrong units? pass --units)")
    lengths = np.stack([np.linalg.norm(poses[:, i(a)] - poses[:, i(b)], axis=-1)
                        for a, b in RIGID_BONES], axis=1)
    mean = lengths.mean(axis=0)
    spread = (lengths.max(axis=0) - lengths.min(axis=0)) / np.where(mean > 0, mean, 1.0)
    for (a, b), s in zip(RIGID_BONES, spread):
        if s > rigidity_tol:
            problems.append(f"{name}: bone {a}-{b} changes length by {100 * s:.0f}% "
                            "over the clip (wrong joint mapped?)")
    for k, (a, b) in enumerate(RIGID_BONES):
        if not a.startswith("right"):
            continue
        m = RIGID_BONES.index((a.replace("right", "left"), b.replace("right", "left")))
        r, l_ = mean[k], mean[m]
        if max(r, l_) > 0 and abs(r - l_) / max(r, l_) > symmetry_tol:
            problems.append(f"{name}: {a.replace('right_', '')}-{b.replace('right_', '')} "
                            f"is {r:.3f} m on the right but {l_:.3f} m on the left "
                            "(a limb mapped to the wrong joint?)")
    hand = chirality(poses)
    if hand is not None and hand < -0.5:
        problems.append(f"{name}: the knees bend backwards, so left and right look swapped "
                        "(a mirror image: check the left/right joints of the rig or joint map)")
    return problems
