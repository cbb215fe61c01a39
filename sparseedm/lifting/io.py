"""lift_file(): lift a keypoint file to 3D; write x, y, z per joint, statuses and errors.

Input: any keypoint file :func:`sparseedm.keypoints.read_keypoints` reads
(.csv, .npz, .npy, COCO .json). Output (written atomically), by extension or
``output_format``:

``.csv``   one pose per row: ``id`` (then ``track``, ``frame`` when the input had
           them), ``<joint>_x, <joint>_y, <joint>_z`` for the 14
           joints (metres, pelvis at the origin, camera axes: x right, y down,
           z away from the camera; empty for refused rows), then ``status``,
           ``reason``, ``chirality_margin`` and, when the result has them,
           ``<joint>_uncertainty3d`` (the 3D 90 % radius, metres; empty when NaN);
``.npz``   ``poses3d`` (n, 14, 3), ``vectors3d`` (n, 91) in the lifter's
           normalisation, ``scale_metric`` (n,), ``missing`` (n, 14),
           ``status``, ``reason``, ``chirality_margin``, ``joint_names`` and
           ``ids`` (``tracks``, ``frames`` when the input had them), and
           ``uncertainty2d`` / ``uncertainty3d`` (n, 14): each lifted joint's
           2D 90 % radius (pixels) and 3D 90 % radius (metres,
           :attr:`LiftResult.uncertainty3d`: ``lift_file`` derives it for every
           output but .trc, which has no field for it);
``.json``  a list of ``{"id", "status", "reason", "joints": {name: [x, y, z] or
           null}}`` (with ``"track"`` (text) and ``"frame"`` (a number when it is
           an integer, else text) when the input had them, and
           ``"uncertainty3d": {name: radius or null}`` when the result has it);
``.trc``   OpenSim's marker-trajectory format (:mod:`sparseedm.lifting.trc`): one
           frame per pose at ``rate`` frames per second, one marker per joint,
           metres, turned to y up; refused poses as empty fields. With frame
           numbers the rows go in frame order at their own frame and time; a
           file of several people (tracks) is refused before any work.

With ``plot``, a PNG of a few lifted poses from two viewpoints
(:func:`sparseedm.lifting.plotting.plot_lifted`; needs the ``plot`` extra,
checked before any work).

An input with frames (a CSV ``frame`` column, an ``.npz`` ``frames`` array,
with ``track`` / ``tracks`` for several people) is lifted across time
(:func:`sparseedm.lifting.lift`'s `frames`): its missing 2D joints are filled
across time first and each person's depth reflections are chosen together;
``temporal=False`` (``--no-temporal``) lifts every row on its own.

Rows are lifted ``chunk_size`` at a time (whole tracks at a time with
frames), so memory stays bounded on files of millions of poses; with frames
the 2D dictionary is adapted once on the whole file first, as ``sparseedm
recover`` does, and several people in a frame without track ids are linked
once (the ids are written in the ``track`` column).

Refused rows (see :data:`sparseedm.lifting.STATUSES`) are listed in an errors
file ``<output stem>.errors.csv`` (``row,id,status,reason``), as
``sparseedm recover`` does.
"""

from __future__ import annotations

import csv
import os
from numbers import Integral
from pathlib import Path

import numpy as np

from .. import _progress
from .._atomic import atomic_path, check_paths, save_json, save_npz
from .._extras import require as require_extra
from .._validation import (BOOLEAN, CHUNK_SIZE, N_JOBS, Interval, read_frames,
                           validate_params)
from ..keypoints import write_errors, default_errors_path
from ..dictionary import load_dictionary
from ..exceptions import FileFormatError, ParameterError, SparseEDMError
from ..formats.deeplabcut import check_h5_extra
from ..keypoints import KeypointSet, read_keypoints
from ..plotting import select_values
from ..skeleton import JOINT_NAMES
from ..temporal.recover import adapt_in_time, linked_tracks
from ..temporal.linking import needs_linking
from ..temporal.tracks import frame_numbers, has_time, track_windows
from .base import load_lifter
from .lift import LiftResult, lift
from .plotting import plot_lifted
from .trc import trc_times, write_trc

__all__ = ["lift_file", "write_poses3d", "OUTPUT_FORMATS"]

OUTPUT_FORMATS = {".csv": "csv", ".npz": "npz", ".json": "json", ".trc": "trc"}


def _num(v):
    return "" if not np.isfinite(v) else repr(float(v))


def _output_format(path, output_format):
    by_name = OUTPUT_FORMATS.get(Path(path).suffix.lower())
    if output_format and by_name and output_format != by_name:
        raise FileFormatError(f"{path}: its extension says {by_name}, the format asked for "
                              f"is {output_format}; give a name that ends in .{output_format} "
                              "(or drop the format)")
    fmt = output_format or by_name
    if fmt not in OUTPUT_FORMATS.values():
        raise FileFormatError(f"{path}: cannot tell the output format; use .csv, .npz, "
                              ".json or .trc or pass --format")
    return fmt


def _trc_order(frames, n, output, rate=30.0):
    """The rows of a .trc in frame order and their frame numbers (None without
    frames: the rows are frames 0, 1, 2 ...), checked before any work.

    Each row keeps its own frame number, never a renumbering: a row without a
    usable one (the one frame-number rule,
    :func:`~sparseedm.temporal.tracks.frame_numbers`) or two rows of one frame
    refuse the .trc output (FileFormatError naming them), as does a `rate`
    whose times cannot be written (:func:`~sparseedm.lifting.trc.trc_times`).
    """
    if frames is None:
        trc_times(None, rate, n)
        return np.arange(n), None
    values, reason = frame_numbers(frames, n)
    fix = ("a .trc places each row at its frame's time (frame / rate); fix the frame "
           "numbers, or write .csv, .npz or .json, which keep the rows as given")
    bad = np.flatnonzero(reason != "")
    if len(bad):
        more = f" (and {len(bad) - 1} more rows)" if len(bad) > 1 else ""
        raise FileFormatError(f"{output}: row {bad[0]} has no usable frame number "
                              f"({reason[bad[0]]}){more}: {fix}")
    order = np.argsort(values, kind="stable")
    twice = np.flatnonzero(np.diff(values[order]) == 0)
    if len(twice):
        a, b = sorted(order[twice[0]:twice[0] + 2])
        raise FileFormatError(f"{output}: rows {a} and {b} are both frame "
                              f"{values[order[twice[0]]]}: {fix}")
    trc_times(values[order], rate, n)
    return order, values[order]


def _one_person(tracks, frames, input, output, fmt):
    """Refuse, before any work, a .trc output of a file with several people."""
    if fmt != "trc":
        return
    several = None
    people = 0 if tracks is None else len(np.unique(np.asarray(tracks).astype(str)))
    if people > 1:
        several = f"{people} tracks ({_track_list(tracks)})"
    elif needs_linking(tracks, frames):
        several = "several poses in one frame"
    if several:
        how = "pick one with --track (track=)" if people > 1 else (
            "`sparseedm recover` links them into tracks and writes the track ids back, "
            "then lift one with --track (track=)")
        raise FileFormatError(
            f"{output}: a .trc file holds one person's markers, and {input} has {several}; "
            f"{how}, or write .csv, .npz or .json (they keep a track column)")


def _track_list(tracks, at_most=10):
    """A file's track ids as text for a message, the first `at_most` of them.

    >>> _track_list(np.array([2, 1, 2, 10]))
    "'1', '10', '2'"
    """
    names = np.unique(np.asarray(tracks).astype(str))
    shown = ", ".join(repr(str(t)) for t in names[:at_most])
    return shown + (f", ... ({len(names)} tracks)" if len(names) > at_most else "")


def _track_rows(kps, track, input):
    """The KeypointSet of `track`'s rows and their input row numbers; `kps` and
    None without `track`. Refused before any work: an input without track ids,
    or a track it does not hold (the message names the ones it has)."""
    if track is None:
        return kps, None
    if kps.tracks is None:
        link = (" (it has several poses in a frame: `sparseedm recover` links them into "
                "tracks and writes the ids back)" if needs_linking(None, kps.frames) else "")
        raise ParameterError(f"track={track!r} (--track): {input} has no track ids{link}")
    rows = np.flatnonzero(np.asarray(kps.tracks).astype(str) == str(track))
    if not len(rows):
        raise ParameterError(f"track={track!r} (--track): {input} has no track {str(track)!r}; "
                             f"its tracks: {_track_list(kps.tracks)}")

    def take(a):
        return None if a is None else np.asarray(a)[rows]

    return KeypointSet(kps.poses[rows], kps.missing[rows], take(kps.confidence),
                       take(kps.ids), kps.meta, tracks=take(kps.tracks),
                       frames=take(kps.frames), filled=take(kps.filled),
                       uncertainty=take(kps.uncertainty)), rows


def _when(tracks, frames):
    """The (name, values) of the track and frame columns given."""
    return [(name, np.asarray(v)) for name, v in (("track", tracks), ("frame", frames))
            if v is not None]


def _json_when(name, value):
    """A track or frame value in a JSON output: a frame number that is an
    integer as a JSON number, anything else as text.

    >>> _json_when("frame", np.int64(12)), _json_when("frame", 3.0), _json_when("track", 1)
    (12, 3, '1')
    >>> _json_when("frame", "12a")
    '12a'
    """
    if name == "frame" and not isinstance(value, (bool, np.bool_)):
        if isinstance(value, (int, np.integer)):
            return int(value)
        if isinstance(value, (float, np.floating)) and float(value).is_integer():
            return int(value)
    return str(value)


def write_poses3d(path, result, ids=None, output_format=None, rate=30.0, *, tracks=None,
                  frames=None):
    """Write a :class:`~sparseedm.lifting.LiftResult` atomically (format from the extension).

    Parameters
    ----------
    path : str or path-like
        The output file: .csv, .npz, .json or .trc (see the module's
        description).
    result : LiftResult
        The lifted poses, their statuses and reasons; its ``uncertainty3d``,
        when derived, goes into every format but .trc (no field for it).
    ids : array_like (n,), optional
        Each row's id; default the row numbers.
    output_format : {"csv", "npz", "json", "trc"}, optional
        The format when the extension does not say; one that contradicts the
        extension is refused.
    rate : float, default 30.0
        Frames per second of a .trc.
    tracks, frames : array_like (n,), optional
        The input's tracks and frame numbers, written beside each row's id
        (a .trc places each row at its frame's time instead).

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    fmt = _output_format(path, output_format)
    n = len(result.status)
    ids = np.array([str(i) for i in range(n)]) if ids is None else np.asarray(ids, str)
    when = _when(tracks, frames)
    P = result.poses3d
    if fmt == "npz":  # at exactly `path`, whatever its extension
        save_npz(path, dict(poses3d=P, vectors3d=result.vectors3d,
                            scale_metric=result.scale_metric, missing=result.missing,
                            status=result.status.astype(str),
                            reason=result.reason.astype(str),
                            chirality_margin=result.chirality_margin, ids=ids,
                            joint_names=np.array(JOINT_NAMES),
                            **{k: v for k in ("uncertainty2d", "uncertainty3d")
                               if (v := getattr(result, k)) is not None},
                            **{f"{k}s": v for k, v in when}))
    elif fmt == "trc":
        order, numbers = _trc_order(frames, n, path, rate)
        write_trc(path, P[order], rate=rate, frames=numbers)
    elif fmt == "csv":
        radius = result.uncertainty3d
        with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(["id"] + [k for k, _ in when]
                       + [f"{j}_{a}" for j in JOINT_NAMES for a in "xyz"]
                       + ["status", "reason", "chirality_margin"]
                       + ([] if radius is None else [f"{j}_uncertainty3d" for j in JOINT_NAMES]))
            for r in range(n):
                w.writerow([ids[r]] + [str(v[r]) for _, v in when]
                           + [_num(v) for v in P[r].ravel()]
                           + [result.status[r], result.reason[r],
                              _num(result.chirality_margin[r])]
                           + ([] if radius is None else [_num(v) for v in radius[r]]))
    else:
        doc = []
        for r in range(n):
            ok = np.isfinite(P[r]).all()
            doc.append({"id": str(ids[r]), **{k: _json_when(k, v[r]) for k, v in when},
                        "status": str(result.status[r]),
                        "reason": str(result.reason[r]),
                        "joints": {j: ([float(v) for v in P[r, i]] if ok else None)
                                   for i, j in enumerate(JOINT_NAMES)}})
            if result.uncertainty3d is not None:
                doc[-1]["uncertainty3d"] = dict(zip(JOINT_NAMES, result.uncertainty3d[r]))
        save_json(path, doc)
    return path


def lift_file(input, output, *, lifter=None, n_jobs=1, output_format=None, errors_path=None,
              confidence_threshold=None, representation=None, rate=30.0, plot=None,
              temporal=True, chunk_size=50_000, joint_map=None, dictionary=None, adapt=True,
              self_training=None, plot_frames=None, input_format=None, progress=False,
              track=None):
    """Read 2D keypoints, lift them, write 3D poses and an errors file; return a summary.

    Nothing the run reads is ever written, and no output overwrites another:
    the paths are checked (:func:`sparseedm._atomic.check_paths`) before any work.

    Parameters
    ----------
    input : str or path-like
        A keypoint file :func:`sparseedm.keypoints.read_keypoints` reads.
    output : str or path-like
        The 3D poses' file: .csv, .npz, .json or .trc (see the module's
        description).
    lifter : Lifter, str or path, optional
        A loaded lifter, a shipped name or a lifter .npz; default the shipped
        ``"default"``.
    n_jobs : int, default 1
        Workers of the lifting (and of the 2D dictionary's adaptation with
        time).
    output_format : {"csv", "npz", "json", "trc"}, optional
        The output's format when its extension does not say; one that
        contradicts the extension is refused.
    errors_path : str or path-like, optional
        The errors file (a row per refused pose); default
        ``<output stem>.errors.csv`` beside `output`. Written only when a pose
        was refused or an input file skipped.
    confidence_threshold : float, optional
        Joints scored below it are missing; default the input format's
        (:data:`sparseedm.formats.DEFAULT_THRESHOLDS`).
    representation : {"average", "zero"}, optional
        How missing joints are fed to a lifter that reads whole vectors, as
        :func:`sparseedm.lifting.lift`'s `representation`.
    rate : float, default 30.0
        A .trc output's frames per second (finite, > 0).
    plot : str or path-like, optional
        A PNG of a few lifted poses (the ``plot`` extra, checked first): the
        first 4 lifted, or those of `plot_frames`.
    temporal : bool, default True
        Lift across time when the input has frames; False lifts every row on
        its own.
    chunk_size : int, default 50000
        Rows lifted at a time (whole tracks at a time with time).
    joint_map : str or path-like, optional
        A DeepLabCut input's JSON naming the body part of each joint (as
        ``sparseedm recover --joint-map``).
    dictionary : Dictionary, str or path, optional
        With time only: the 2D dictionary that fills a video's missing joints
        across time first (a shipped name, a path or a Dictionary; default the
        shipped default).
    adapt : bool, default True
        With time only: whether that dictionary is first adapted to the input
        (as ``sparseedm recover`` adapts); False is refused without time.
    self_training : int, optional
        With time only: that adaptation's self-training rounds; default
        :data:`sparseedm.adaptation.SELF_TRAINING_ROUNDS`, 0 turns it off.
    plot_frames : str, optional
        The poses to plot: frames, or rows of an input without frames, as
        :func:`sparseedm.plotting.select_values` reads them (``"10:40"``,
        ``"3,7"``); at most :data:`PLOT_MAX` spread over them; an unknown one
        is refused before any work.
    input_format : str, optional
        The input's keypoint format when its name does not tell (as
        :func:`~sparseedm.keypoints.read_keypoints`' `format`).
    progress : bool, default False
        A progress bar over each chunk's lifting (:func:`lift`'s `progress`);
        ``sparseedm lift`` shows it on a terminal unless ``--quiet``, as
        ``sparseedm recover`` does.
    track : str or int, optional
        Lift only this person's rows: the input's track id (a CSV ``track``
        cell, an ``.npz`` ``tracks`` value, a detector's track / person id),
        compared as text, so ``1`` and ``"1"`` are one track. What a .trc
        (one person) needs from a file of several people. An input without
        track ids, or a track it does not hold, is refused before any work,
        naming the tracks it has. The errors file keeps the input's row
        numbers.

    Returns
    -------
    dict
        The counts of ``LiftResult.summary()`` (poses, refused, statuses...)
        plus ``output``, ``skipped_files`` (input files that could not
        be read), ``errors`` (the errors file, or None when nothing was
        refused), ``temporal`` (whether time was used: `temporal` and the
        input has frames) and ``plot`` (the figure written, or None).

    Raises
    ------
    SparseEDMError
        Bad arguments, a path the run would both read and write, an
        unreadable input; the dictionary options given for an input lifted
        row by row.
    """
    validate_params("lift_file", dict(n_jobs=n_jobs, chunk_size=chunk_size, adapt=adapt,
                                      self_training=self_training, progress=progress,
                                      track=track), _PARAMS)  # before adapting
    errors = Path(errors_path) if errors_path else default_errors_path(output)
    _output_format(output, output_format)
    if not 0 < float(rate) < np.inf:  # inf: every .trc time would be 0
        raise SparseEDMError(f"the .trc frame rate must be a finite number > 0, got {rate}")
    if plot is not None:
        require_extra("plot", "--plot")
    check_h5_extra(input)
    inputs = [("input", input)] + [(what, v) for what, v in (
        ("lifter", lifter), ("joint map", joint_map), ("dictionary", dictionary))
        if v is not None and (what == "joint map" or _names_a_file(v))]
    check_paths(inputs, [("output", output), ("errors file", errors), ("plot", plot)])
    kps = read_keypoints(input, format=input_format, confidence_threshold=confidence_threshold,
                         joint_map=joint_map)
    kps, input_rows = _track_rows(kps, track, input)
    # the frame numbers read once here, not again by each step's rule; the
    # outputs keep the file's own (kps.frames)
    frames = read_frames(kps.frames)
    plot_rows = _plot_rows(kps, frames, plot, plot_frames)
    fmt = _output_format(output, output_format)
    _one_person(kps.tracks, frames, input, output, fmt)
    if fmt == "trc":  # its time, before any work
        _trc_order(frames, len(kps.poses), output, rate)
    in_time = bool(temporal) and has_time(frames)  # (no poses: no time)
    fill = _fill_options(in_time, dictionary, adapt, self_training)
    _progress.say(f"lifting {len(kps.poses):,} poses to 3D"
                  + (" across time (the input has frames: missing 2D joints filled across "
                     "time first; --no-temporal lifts each row alone)" if in_time else ""))
    result, tracks = _lift_chunks(kps, frames, in_time, chunk_size, fill,
                                  lifter=load_lifter(lifter), n_jobs=n_jobs,
                                  representation=representation, progress=progress,
                                  uncertainty3d=fmt != "trc")
    write_poses3d(output, result, kps.ids, output_format, rate=rate, tracks=tracks,
                  frames=kps.frames)
    refused = ~result.ok
    skipped = list((kps.meta or {}).get("skipped") or [])
    write_errors(errors, refused, kps.ids, result.status, result.reason, skipped,
                 rows=input_rows)
    summary = result.summary()
    summary.update(output=str(output), skipped_files=skipped,
                   errors=str(errors) if refused.any() or skipped else None,
                   temporal=in_time,
                   plot=str(_plot(plot, result, kps, plot_rows)) if plot is not None else None)
    return summary


#: constraints of lift_file()'s arguments (see sparseedm._validation)
_PARAMS = {"n_jobs": N_JOBS, "chunk_size": CHUNK_SIZE, "adapt": BOOLEAN,
           "self_training": [Interval(Integral, 0, None), None], "progress": BOOLEAN,
           "track": [str, Interval(Integral, None, None), None]}


def _names_a_file(value):
    """Whether a lifter or dictionary argument names a file the run reads (a
    path, or any name ending in .npz), not a shipped name or a loaded object."""
    return isinstance(value, (str, os.PathLike)) and (
        Path(value).suffix == ".npz" or os.path.lexists(value))


def _fill_options(in_time, dictionary, adapt, self_training):
    """The 2D fill's settings (dictionary loaded, adapt, self_training), checked:
    given without time (where nothing is filled) or contradictory, refused."""
    given = [name for name, v in (("dictionary (--dictionary)", dictionary),
                                  ("self_training (--self-training)", self_training))
             if v is not None] + ([] if adapt else ["adapt=False (--no-adapt)"])
    if given and not in_time:
        raise ParameterError(f"{', '.join(given)}: the 2D dictionary only fills a video's "
                             "missing joints across time, and this input is lifted row by "
                             "row (no frames, or --no-temporal)")
    if not adapt and self_training is not None:
        raise ParameterError("self_training (--self-training) needs adaptation: it cannot "
                             "go with adapt=False (--no-adapt)")
    return dict(dictionary=load_dictionary(dictionary) if in_time else None, adapt=adapt,
                self_training=self_training)


def _lift_chunks(kps, frames, in_time, chunk_size, fill, **kw):
    """:func:`lift` over a file's rows, `chunk_size` at a time; the whole LiftResult
    and the tracks (linked ones when the input had none and needed them).

    With time the chunks are whole tracks, a longer track in windows
    (:func:`~sparseedm.temporal.tracks.track_windows`), and the fill's 2D
    dictionary is adapted once, on every row, first."""
    n, tracks = len(kps.poses), kps.tracks
    if not in_time:  # no rows: one empty chunk (an empty output, as recover writes)
        bounds = [(slice(s, min(s + chunk_size, n)), None)
                  for s in range(0, max(n, 1), chunk_size)]
    else:
        linked = linked_tracks(kps.poses, kps.missing, tracks, frames)
        tracks = tracks if linked is None else linked
        base = fill["dictionary"]
        if fill["adapt"]:
            base = adapt_in_time(base, kps.poses, kps.missing, tracks=tracks, frames=frames,
                                 n_jobs=kw["n_jobs"], self_training=fill["self_training"])[0][0]
        kw.update(dictionary=base, fill_adapt=False)
        bounds = [(slice(*b) if isinstance(b, tuple) else b, keep)
                  for b, keep in track_windows(tracks, frames, n, chunk_size)]
    if len(bounds) > 1:
        bounds = _progress.steps(bounds, f"lifting in {len(bounds)} chunks",
                                 total=len(bounds), unit="chunk")
    parts = []
    for rows, keep in bounds:
        when = {} if not in_time else dict(
            frames=np.asarray(frames)[rows],
            tracks=None if tracks is None else np.asarray(tracks)[rows])
        part = lift(kps.poses[rows], kps.missing[rows], **kw, **when)
        if keep is not None:  # a window of a long track: its own rows only
            rows, part = rows[keep], part.take(keep)
        parts.append((rows, part))
    return _joined(parts, n), tracks


def _joined(parts, n):
    """One LiftResult of n rows from (rows, LiftResult) parts."""
    if len(parts) == 1 and len(parts[0][1].status) == n:  # every row, in order
        return parts[0][1]
    first = parts[0][1]
    out = {}
    for name in ("poses3d", "vectors3d", "scale_metric", "missing", "status", "reason",
                 "chirality_margin", "poses2d", "filled", "uncertainty2d", "uncertainty3d"):
        a = getattr(first, name)
        if a is None:
            continue
        fill = np.nan if a.dtype.kind == "f" else ("" if a.dtype.kind == "U" else False)
        out[name] = np.full((n,) + a.shape[1:], fill, dtype=object if a.dtype.kind == "U"
                            else a.dtype)
        for rows, part in parts:
            out[name][rows] = getattr(part, name)
    for name in ("status", "reason"):
        out[name] = out[name].astype(str)
    return LiftResult(**out, seconds=sum(part.seconds for _, part in parts))


#: most poses a lift figure draws
PLOT_MAX = 8


def _plot_rows(kps, frames, plot, spec):
    """The rows `spec` chooses to draw (`frames`, or rows without frames), in frame
    order; None: the first lifted. Refused without a figure, or naming an unknown one."""
    if spec is None:
        return None
    if plot is None:
        raise ParameterError("plot_frames (--frames) chooses what the figure draws: it "
                             "needs plot (--plot FIG)")
    timed = frames is not None
    values = np.asarray(frames) if timed else np.arange(len(kps.poses))
    rows = np.flatnonzero(select_values(spec, values, "frame" if timed else "row"))
    return rows[np.argsort(values[rows], kind="stable")]


def _plot(path, result, kps, rows, k=4):
    """Lifted poses drawn to `path` (front and side views): the first `k`, or
    those of `rows` (at most :data:`PLOT_MAX`, spread over them)."""
    if rows is None:
        rows = np.flatnonzero(result.ok)[:k]
    else:
        rows = rows[result.ok[rows]]
        if len(rows) > PLOT_MAX:
            rows = rows[np.linspace(0, len(rows) - 1, PLOT_MAX).round().astype(int)]
    n = len(result.status)
    ids = np.arange(n).astype(str) if kps.ids is None else np.asarray(kps.ids, str)
    titles = [str(ids[r]) + ("" if kps.frames is None else f", frame {kps.frames[r]}")
              for r in rows]
    return plot_lifted(result.poses3d[rows], path, titles=titles, missing=result.missing[rows])
