"""DeepLabCut output tables (``.csv`` and ``.h5``) and their joints map.

DeepLabCut writes one row per video frame under a header of three rows
(``scorer``, ``bodyparts``, ``coords``), four for multi-animal projects
(``scorer``, ``individuals``, ``bodyparts``, ``coords``); ``coords`` are
``x``, ``y`` and ``likelihood`` per body part (a probability in [0, 1]). The
``.h5`` holds the same table as a pandas DataFrame with those column levels;
it is read with pandas and PyTables (``pip install 'sparseedm[dlc]'``).
PyTables unpickles the metadata pandas stores in ``.h5`` files, so read
``.h5`` only from sources you trust; the ``.csv`` is plain text.

Joints map
----------
DeepLabCut's body part names are the project's own, so a JSON file says which
body part is which joint::

    {"joints": {"head_top": "head", "neck": null, "right_shoulder": "r_shoulder",
                "left_wrist": "l_wrist", ...}}

Keys are the 14 joint names of :data:`~sparseedm.skeleton.JOINT_NAMES`; a
value is a body part of the table's header or null (not tracked: the joint
is always missing, except a null ``neck``, which is the midpoint of the two
shoulders, as in the COCO rule). A joint left out counts as null. Without a
map, the table's body parts must be the 14 joint names themselves (else an
error names the file, its first body parts and ``--joint-map``). A map
naming a body part the header lacks, or a key that is not a joint, is an
error naming the map file and the key; a header naming a body part twice
(for one individual) is an error naming the body part; body parts of the
header the map does not name (a tail, a nose) are not read, and are written
back unchanged.

Rows: one pose per frame (per frame and individual, frame-major, for
multi-animal tables); ``ids`` are the table's index (the frame number, or an
image path), ``frames`` the index when every row's index is a distinct whole
number (a video's frame numbers), else the row number, ``tracks`` the
individual (``0`` for single-animal tables). An individual whose mapped body parts are all absent
in a frame is still a row (all missing). ``likelihood`` is the confidence;
NaN coordinates or a NaN likelihood mark a missing body part; a likelihood
outside [0, 1] is an error naming the file, row and body part.

Labelled data (``CollectedData_<scorer>.csv``): its rows carry three index
columns (``labeled-data``, the video's folder, the image name), told from the
header rows' blank cells after ``scorer`` / ``bodyparts`` / ``coords``; the
id of a row is its index cells joined by ``/``
(``labeled-data/vid1/img001.png``, as the ``.h5`` index reads), and the file
is written back with the same index columns. Labels have no ``likelihood``:
every labelled body part is present.

Writing back: DeepLabCut's own layout, so that its tools (``create_labeled_video``,
``filterpredictions``, which take the values as ``(frames, -1, 3)``: x, y,
likelihood per body part) read the file: the same header rows (column levels
in ``.h5``), the same columns in the same order, with each filled joint's
``x``, ``y`` set and its ``likelihood`` set to ``filled_score``, or, when
the radius of the joint's uncertainty is given, to
:func:`~sparseedm.formats._base.filled_likelihood` (at most 0.5, below
DeepLabCut's default ``pcutoff``; higher for a surer joint). The table
has no room for the filled flags: ``sparseedm recover`` writes them to its
``<output stem>.status.npz`` sidecar (``filled``, (n, 14)), which
:func:`sparseedm.keypoints.read_keypoints` reads them back from. A ``filled``
coords column of a file an earlier sparseedm wrote is still read (its flagged
body parts as present) and is left out when the table is written back.
Without a DeepLabCut input, a new table is written whose body parts are the 14
joint names (scorer ``sparseedm``): multi-animal (as maDLC writes it) with one
individual per track (named by the track as text) when the poses have tracks
other than the single track 0, else single-animal. With frame numbers, its
rows are the frames (sorted, the index their numbers; an individual absent
from a frame is a row of NaN, read back as a pose with every joint missing);
a frame that is not a whole number, or given twice to one track, is refused
naming the pose, and tracks without frame numbers are refused. Without frame
numbers, the rows are the poses in order and the index their ids.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from .._extras import EXTRAS
from .._extras import require as require_extra
from .._safeio import load_json, require_file, text_lines
from .._validation import MAX_FRAME
from ..exceptions import FileFormatError
from ..normalize import MIN_OBSERVED_JOINTS
from ..skeleton import JOINT_NAMES
from . import _base
from ._base import N_JOINTS, NECK

__all__ = ["read", "write", "check_fresh", "read_joint_map", "check_h5_extra", "H5_KEY",
           "H5_SUFFIXES", "EXTRA", "H5_WORK"]

#: the key DeepLabCut stores its table under in ``.h5`` files
H5_KEY = "df_with_missing"
#: the optional dependency and the extra that installs it
EXTRA = EXTRAS["dlc"][1]
#: what needs it, as its errors say
H5_WORK = "reading/writing DeepLabCut .h5 files"
#: the extensions of DeepLabCut .h5 tables
H5_SUFFIXES = (".h5", ".hdf5", ".hdf")
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_COORDS = ("x", "y", "likelihood", "filled")
#: the shoulders, whose midpoint is the neck when a map leaves the neck out
_LS, _RS = JOINT_NAMES.index("left_shoulder"), JOINT_NAMES.index("right_shoulder")
#: largest table read (cells), checked before pandas loads it
MAX_CELLS = 200_000_000


def check_h5_extra(*paths):
    """Refuse at once, before any work, a DeepLabCut ``.h5`` among `paths` (an
    input or an output; None skipped) when pandas or PyTables is not installed.

    >>> check_h5_extra("video1DLC.csv", None)   # a .csv needs neither
    """
    if any(p is not None and Path(p).suffix.lower() in H5_SUFFIXES for p in paths):
        require_extra("dlc", H5_WORK)


def _pandas():
    try:
        import pandas as pd
        import tables  # noqa: F401  (pandas needs it for .h5)
    except ImportError as exc:
        raise FileFormatError(f"{H5_WORK} needs pandas and PyTables: {EXTRA} ({exc})") \
            from None
    return pd


# --------------------------------------------------------------------------
# the joints map


def read_joint_map(path):
    """A joints map file as {joint index: body part or None}.

    Examples
    --------
    >>> import json, os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "map.json")
    >>> with open(p, "w") as f:
    ...     json.dump({"joints": {"left_wrist": "wristL", "left_elbow": "elbowL",
    ...                           "left_shoulder": "shoulderL", "neck": None}}, f)
    >>> read_joint_map(p)[7]
    'wristL'

    A map that can never give 3 observed joints (the fewest a pose is recovered
    from), or gives one body part to two joints, is refused:

    >>> with open(p, "w") as f:
    ...     json.dump({"head_top": "Head"}, f)
    >>> read_joint_map(p)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: ...: the map gives 1 joint (head_top); ...
    """
    require_file(path, "joints map", FileFormatError)
    doc = load_json(path)
    joints = doc.get("joints", doc) if isinstance(doc, dict) else None
    if not isinstance(joints, dict):
        raise FileFormatError(f"{path}: a joints map is a JSON object "
                              '{"joints": {"<joint>": "<body part>" or null, ...}}')
    out = {j: None for j in range(N_JOINTS)}
    for key, part in joints.items():
        if key not in JOINT_NAMES:
            raise FileFormatError(f"{path}: 'joints.{key}' is not a joint; joints: "
                                  f"{', '.join(JOINT_NAMES)}")
        if part is not None and not isinstance(part, str):
            raise FileFormatError(f"{path}: 'joints.{key}' must be a body part name or null")
        out[JOINT_NAMES.index(key)] = part
    _check_map(out, path, wrapped=isinstance(doc, dict) and "joints" in doc)
    return out


def _check_map(mapping, path, wrapped):
    """Refuse a map giving one body part to two joints, or fewer joints than a
    pose is ever recovered from (a null neck counts when both shoulders are mapped)."""
    owner = {}
    for j, part in mapping.items():
        if part is not None and part in owner:
            raise FileFormatError(f"{path}: body part {part!r} is given to both "
                                  f"'{JOINT_NAMES[owner[part]]}' and '{JOINT_NAMES[j]}'; "
                                  "each joint needs its own body part")
        owner.setdefault(part, j)
    given = [JOINT_NAMES[j] for j, part in mapping.items() if part is not None]
    if _neck_from_map(mapping):
        given.append("neck")  # the shoulders' midpoint
    if len(given) < MIN_OBSERVED_JOINTS:
        raise FileFormatError(
            f"{path}: the map gives {len(given)} joint{'' if len(given) == 1 else 's'}"
            f"{' (' + ', '.join(given) + ')' if given else ''}; a pose needs at least "
            f"{MIN_OBSERVED_JOINTS} observed joints to be recovered, so this map could "
            "recover nothing" + ("" if wrapped else '; a joints map is {"joints": '
                                 '{"head_top": "<body part>", "neck": ..., ...}}'))


def _resolve_map(joint_map, parts, path):
    if joint_map is None:
        if set(JOINT_NAMES) <= set(parts):
            return {j: name for j, name in enumerate(JOINT_NAMES)}, None
        raise FileFormatError(
            f"{path}: DeepLabCut body parts ({', '.join(parts[:6])}"
            f"{', ...' if len(parts) > 6 else ''}) are the project's own names; give a "
            "joints map (joint_map= / --joint-map FILE): "
            '{"joints": {"head_top": "<body part>", "neck": ..., ...}}')
    mapping = read_joint_map(joint_map)
    unknown = [(JOINT_NAMES[j], p) for j, p in mapping.items()
               if p is not None and p not in parts]
    if unknown:
        key, part = unknown[0]
        raise FileFormatError(
            f"{joint_map}: 'joints.{key}' names body part {part!r}, which {path} does not "
            f"have; its body parts: {', '.join(parts)}")
    return mapping, str(joint_map)


# --------------------------------------------------------------------------
# the table: header levels per column, index, values


def _read_csv_table(path):
    lines = (text for _, text in text_lines(path))
    reader = csv.reader(lines)
    header = []
    try:
        for row in reader:
            header.append(row)
            if row and row[0].strip() == "coords":
                break
            if len(header) == 4:
                break
        body = [(reader.line_num, row) for row in reader if row]
    except csv.Error as exc:
        raise FileFormatError(f"{path}, line {reader.line_num}: {exc}") from None
    names = [h[0].strip() if h else "" for h in header]
    if names not in (["scorer", "bodyparts", "coords"],
                     ["scorer", "individuals", "bodyparts", "coords"]):
        raise FileFormatError(
            f"{path}: not a DeepLabCut table; its first column must start with the header "
            f"rows scorer, bodyparts, coords (or scorer, individuals, bodyparts, coords), "
            f"found {', '.join(names) or 'nothing'}")
    width = len(header[0])
    for level, row in zip(names, header):
        if len(row) != width:
            raise FileFormatError(f"{path}: header row {level!r} has {len(row)} fields, "
                                  f"'scorer' has {width}")
    keys = _index_columns(header, width)
    # names as written (a body part may start or end with a space); coords trimmed
    columns = [tuple(h[c] for h in header[:-1]) + (header[-1][c].strip(),)
               for c in range(keys, width)]
    index, values = [], np.empty((len(body), width - keys))
    for r, (line, row) in enumerate(body):
        if len(row) != width:
            raise FileFormatError(f"{path}, line {line}: {len(row)} fields, the header "
                                  f"has {width}")
        index.append("/".join(row[:keys]))  # ids as written (spaces kept)
        for c, text in enumerate(row[keys:]):
            values[r, c] = _number(text, path, line, columns[c])
    return names, columns, index, values, keys


def _index_columns(header, width):
    """How many index columns lead the table: 1, or up to 3 when the header rows
    leave the columns after their level names blank (labelled data:
    ``labeled-data``, the video's folder, the image name)."""
    keys = 1
    while keys < min(3, width - 1) and all(not h[keys].strip() for h in header):
        keys += 1
    return keys


def _number(text, path, line, column):
    text = text.strip()
    if text == "" or text.lower() == "nan":
        return math.nan
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    else:
        if math.isfinite(value):
            return value
    raise FileFormatError(f"{path}, line {line}, column {'/'.join(column[1:])}: "
                          f"{text[:20]!r} is not a finite number")


def _read_h5_table(path):
    with open(path, "rb") as f:
        if f.read(8) != _HDF5_MAGIC:
            raise FileFormatError(f"{path}: not an HDF5 file")
    pd = _pandas()
    try:
        with pd.HDFStore(path, mode="r") as store:
            keys = store.keys()
            key = f"/{H5_KEY}" if f"/{H5_KEY}" in keys else (keys[0] if len(keys) == 1
                                                            else None)
            if key is None:
                raise FileFormatError(f"{path}: no '{H5_KEY}' table (found "
                                      f"{', '.join(keys) or 'nothing'})")
            storer = store.get_storer(key)
            rows = getattr(storer, "nrows", None) or (storer.shape or (0,))[0]
            if rows * max(1, len(getattr(storer, "non_index_axes", [[0, [0]]])[0][1])) \
                    > MAX_CELLS:
                raise FileFormatError(f"{path}: a table of {rows} rows is too large")
            df = store.select(key)
    except FileFormatError:
        raise
    except Exception as exc:  # noqa: BLE001 - PyTables / pandas raise many kinds
        raise FileFormatError(f"{path}: not a readable DeepLabCut .h5 ({exc})") from None
    if not isinstance(df, pd.DataFrame):
        raise FileFormatError(f"{path}: '{key}' is not a table")
    names = [str(n) for n in df.columns.names]
    if names not in (["scorer", "bodyparts", "coords"],
                     ["scorer", "individuals", "bodyparts", "coords"]):
        raise FileFormatError(f"{path}: column levels {names}; a DeepLabCut table has "
                              "scorer, bodyparts, coords (and individuals)")
    try:
        values = df.to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise FileFormatError(f"{path}: the table holds values that are not numbers") \
            from None
    if np.isinf(values).any():
        raise FileFormatError(f"{path}: the table holds an infinite value")
    columns = [tuple(str(x) for x in c) for c in df.columns]
    index = ["/".join(map(str, i)) if isinstance(i, tuple) else str(i) for i in df.index]
    return names, columns, index, values, 1


# --------------------------------------------------------------------------
# reading


def read(path, joint_map=None):
    """Read a DeepLabCut ``.csv`` or ``.h5`` table into a :class:`_base.Parsed`."""
    path = Path(path)
    h5 = path.suffix.lower() in H5_SUFFIXES
    names, columns, index, values, keys = (_read_h5_table if h5 else _read_csv_table)(path)
    multi = len(names) == 4
    where = {}  # (individual, part, coord) -> column
    for c, col in enumerate(columns):
        ind, part, coord = (col[1], col[2], col[3]) if multi else ("", col[1], col[2])
        if coord not in _COORDS:
            raise FileFormatError(f"{path}: column {c + 1} has coords {coord!r}; "
                                  f"expected one of {', '.join(_COORDS)}")
        if (ind, part, coord) in where:
            raise FileFormatError(
                f"{path}: body part {part!r}{f' of individual {ind!r}' if ind else ''} is "
                f"named twice (two {coord!r} columns: {where[(ind, part, coord)] + 1} and "
                f"{c + 1}); each body part once per individual")
        where[(ind, part, coord)] = c
    parts = list(dict.fromkeys(p for _, p, _ in where))
    mapping, map_path = _resolve_map(joint_map, parts, path)
    used = [p for p in mapping.values() if p is not None]
    individuals = [i for i in dict.fromkeys(i for i, _, _ in where)
                   if all((i, p, "x") in where and (i, p, "y") in where for p in used)]
    if not individuals:
        raise FileFormatError(f"{path}: no individual has x and y for every mapped body "
                              f"part ({', '.join(used)})")
    n = len(index) * len(individuals)
    poses = np.full((n, N_JOINTS, 2), np.nan)
    conf = np.full((n, N_JOINTS), np.nan)
    filled = np.zeros((n, N_JOINTS), dtype=bool)
    has_conf = False
    for i, ind in enumerate(individuals):
        rows = slice(i, n, len(individuals))
        for j, part in mapping.items():
            if part is None:
                continue
            poses[rows, j, 0] = values[:, where[(ind, part, "x")]]
            poses[rows, j, 1] = values[:, where[(ind, part, "y")]]
            lc = where.get((ind, part, "likelihood"))
            if lc is not None:
                has_conf = True
                conf[rows, j] = _likelihood(values[:, lc], path, index, part)
            fc = where.get((ind, part, "filled"))
            if fc is not None:
                filled[rows, j] = values[:, fc] == 1
    present = ~np.isnan(poses).any(axis=-1)
    if has_conf:
        present &= ~np.isnan(conf)
    present |= filled & ~np.isnan(poses).any(axis=-1)
    _neck_from_shoulders(poses, present, conf, mapping)
    poses = np.where(present[..., None], poses, np.nan)
    frames = np.repeat(_row_frames(index, keys), len(individuals))
    tracks = np.tile(np.asarray(individuals if multi else [0]), len(index))
    ids = np.repeat(np.asarray(index, dtype=str), len(individuals))
    meta = {"dlc_names": names, "dlc_columns": columns, "dlc_index": index,
            "dlc_values": values, "dlc_map": {JOINT_NAMES[j]: p for j, p in mapping.items()},
            "dlc_individuals": individuals, "dlc_h5": h5, "joint_map": map_path,
            "dlc_index_columns": keys}
    return _base.Parsed(poses, present, conf if has_conf else None, ids, tracks, frames,
                        filled if filled.any() else None, meta)


def _row_frames(index, keys):
    """Each row's frame: its index when every index is a distinct whole number
    (a video's frame numbers, as DeepLabCut writes them), else its row number
    (labelled data's image paths, ids)."""
    if keys == 1 and index and all(_canonical_int(i) and abs(int(i)) <= MAX_FRAME
                                   for i in index):
        frames = np.asarray([int(i) for i in index], dtype=np.int64)
        if len(np.unique(frames)) == len(frames):
            return frames
    return np.arange(len(index))


def _likelihood(column, path, index, part):
    bad = np.flatnonzero(~np.isnan(column) & ((column < 0) | (column > 1)))
    if bad.size:
        r = int(bad[0])
        raise FileFormatError(f"{path}: row {index[r]!r}, body part {part!r}: likelihood "
                              f"{float(column[r])!r} is outside [0, 1]")
    return column


def _neck_from_map(mapping):
    """Whether the map leaves the neck out and gives both shoulders: the neck is
    then their midpoint (:func:`_neck_from_shoulders`)."""
    return mapping[NECK] is None and mapping[_LS] is not None and mapping[_RS] is not None


def _neck_from_shoulders(poses, present, conf, mapping):
    ls, rs = _LS, _RS
    if not _neck_from_map(mapping):
        return
    both = present[:, ls] & present[:, rs]
    poses[:, NECK] = (poses[:, ls] + poses[:, rs]) / 2
    conf[:, NECK] = np.fmin(conf[:, ls], conf[:, rs])
    present[:, NECK] = both


# --------------------------------------------------------------------------
# writing


def write(path, rows, meta, filled_score, row_fields=None):
    """Write a DeepLabCut table (``.h5`` by the path's extension, else ``.csv``)."""
    path = Path(path)
    if meta.get("dlc_columns") is None:
        names, columns, index, values = _fresh(rows, path)
    else:
        names, columns, index, values = (meta["dlc_names"], list(meta["dlc_columns"]),
                                         meta["dlc_index"], meta["dlc_values"])
        columns, values = _with_filled(names, columns, values, rows, meta["dlc_map"],
                                       meta["dlc_individuals"], filled_score)
    if path.suffix.lower() in H5_SUFFIXES:
        _write_h5(path, names, columns, index, values)
    else:
        _write_csv(path, names, columns, index, values, meta.get("dlc_index_columns", 1))


def _fresh(rows, path):
    """A new table of `rows`: body parts the 14 joint names (scorer ``sparseedm``);
    one individual per track (multi-animal) unless every track is 0 or there are
    none; rows the frames (sorted; the index their numbers), else the poses in
    order (the index their ids)."""
    individuals = _individuals(rows.tracks, path)
    cells, index = _cells(len(rows.poses), rows.tracks, rows.frames, rows.ids, individuals,
                          path)
    width = 3 * N_JOINTS
    values = np.full((len(index), width * len(individuals or [""])), np.nan)
    for r, (k, i) in enumerate(cells):
        values[k, i * width:(i + 1) * width] = _pose_values(rows, r)
    coords = [(name, coord) for name in JOINT_NAMES for coord in ("x", "y", "likelihood")]
    if individuals is None:
        return (["scorer", "bodyparts", "coords"],
                [("sparseedm",) + c for c in coords], index, values)
    return (["scorer", "individuals", "bodyparts", "coords"],
            [("sparseedm", ind) + c for ind in individuals for c in coords], index, values)


def _individuals(tracks, path):
    """The individuals' names (the tracks as text, in order of appearance), or
    None for a single-animal table (no tracks, or every track the integer 0)."""
    if tracks is None:
        return None
    tracks = np.asarray(tracks)
    if tracks.dtype.kind in "iu" and not tracks.any():
        return None
    names = list(dict.fromkeys(str(t) for t in tracks.tolist()))
    bad = [t for t in names if "\n" in t or "\r" in t]
    if bad:
        raise FileFormatError(f"{path}: track {bad[0]!r} holds a line break; a "
                              "DeepLabCut individual's name cannot")
    return names


def check_fresh(path, n, tracks=None, frames=None, ids=None):
    """Refuse the tracks and frames a new table of `n` poses cannot hold, as
    :func:`write` refuses them (a track name with a line break; tracks without
    frames; a frame twice in one track), so a run can refuse them before it
    recovers anything.

    Parameters
    ----------
    path : str or path-like
        The table, named in the message.
    n : int
        The number of poses.
    tracks, frames, ids : array_like (n,), optional
        What the table will be written with (frames as whole numbers).

    Raises
    ------
    FileFormatError
        Naming the track, or the pose and the earlier pose of its frame.

    Examples
    --------
    >>> check_fresh("t.csv", 2, tracks=["a", "b"], frames=[0, 0])
    >>> try:
    ...     check_fresh("t.csv", 2, frames=[3, 3])
    ... except FileFormatError as e:
    ...     print(str(e).split(";")[0])
    t.csv: pose 1: frame 3 is already pose 0's
    """
    _cells(n, tracks, frames, ids, _individuals(tracks, path), path)


def _cells(n, tracks, frames, ids, individuals, path):
    """Each pose's (table row, individual) and the table's index: one row per
    frame (sorted), or per pose without frames; a frame twice in one track is
    refused, naming the poses."""
    ind = [0] * n if individuals is None else \
        [individuals.index(str(t)) for t in np.asarray(tracks).tolist()]
    if frames is None:
        if individuals is not None:
            raise FileFormatError(
                f"{path}: poses with tracks need frame numbers (frames=) to be written as "
                "a multi-animal DeepLabCut table, whose rows are frames")
        ids = ids if ids is not None else range(n)
        return [(r, 0) for r in range(n)], [str(i) for i in ids]
    frames = [int(f) for f in np.asarray(frames).tolist()]
    row_of = {f: k for k, f in enumerate(sorted(set(frames)))}
    seen = {}
    for r, (f, i) in enumerate(zip(frames, ind)):
        q = seen.setdefault((f, i), r)
        if q != r:
            track = "" if individuals is None else f" of track {individuals[i]!r}"
            raise FileFormatError(
                f"{path}: pose {r}: frame {f}{track} is already pose {q}'s; a DeepLabCut "
                "table holds one pose per frame and individual")
    return [(row_of[f], i) for f, i in zip(frames, ind)], [str(f) for f in row_of]


def _pose_values(rows, r):
    """Pose r's x, y, likelihood per joint: NaN where missing; a filled joint's
    likelihood ``rows.likelihood`` (from its radius) or the filled score."""
    out = np.full((N_JOINTS, 3), np.nan)
    out[:, :2] = rows.poses[r]
    for j in np.flatnonzero(~np.isnan(rows.poses[r]).any(axis=-1)):
        filled_here = rows.filled[r, j] and rows.likelihood is not None
        out[j, 2] = rows.likelihood[r, j] if filled_here else rows.score(r, j)
    return out.ravel()


def _with_filled(names, columns, values, rows, mapping, individuals, filled_score):
    """The table's columns and values with the filled joints written in:
    DeepLabCut's x, y, likelihood per body part (a ``filled`` column of an older
    file left out)."""
    multi = len(names) == 4
    key = {((c[1], c[2], c[3]) if multi else ("", c[1], c[2])): k
           for k, c in enumerate(columns)}
    values = values.copy()
    n_ind = len(individuals)
    for i, ind in enumerate(individuals):
        sl = slice(i, len(rows.poses), n_ind)
        for name, part in mapping.items():
            if part is None:
                continue
            j = JOINT_NAMES.index(name)
            fill = rows.filled[sl, j]
            for a, coord in enumerate(("x", "y")):
                c = key[(ind, part, coord)]
                values[:, c] = np.where(fill, rows.poses[sl, j, a], values[:, c])
            if (ind, part, "likelihood") in key:
                c = key[(ind, part, "likelihood")]
                score = filled_score if rows.likelihood is None else rows.likelihood[sl, j]
                values[:, c] = np.where(fill, score, values[:, c])
    keep = [k for k, col in enumerate(columns) if col[-1] != "filled"]
    return [columns[k] for k in keep], values[:, keep]


def _write_csv(path, names, columns, index, values, keys=1):
    """The table as DeepLabCut's CSV; `keys` index columns (the index split at
    its first ``keys - 1`` slashes)."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            for level, name in enumerate(names):
                w.writerow([name] + [""] * (keys - 1) + [c[level] for c in columns])
            for idx, cells in zip(index, _base.csv_cells(values)):
                cells_of_index = idx.split("/", keys - 1)
                w.writerow(cells_of_index + [""] * (keys - len(cells_of_index)) + cells)


def _canonical_int(text):
    """Whether `text` is an int64 that ``str`` writes back as `text`."""
    try:
        return str(int(text)) == text and -2**63 <= int(text) < 2**63
    except ValueError:
        return False


def _write_h5(path, names, columns, index, values):
    pd = _pandas()
    cols = pd.MultiIndex.from_tuples(columns, names=names)
    # frame numbers as DeepLabCut writes them (ints) when every id is one, as
    # written back by str(); else all text (PyTables stores no mixed index)
    as_int = all(_canonical_int(i) for i in index)
    idx = [int(i) if as_int else i for i in index]
    df = pd.DataFrame(values, columns=cols, index=idx)
    with atomic_path(path, suffix=".h5") as tmp:
        df.to_hdf(tmp, key=H5_KEY, format="table", mode="w")
