"""Video evaluation: gap fillers scored on mocap sequences under the video protocols.

:func:`evaluate_video` hides joints of each :class:`~sparseedm.temporal.sequences.Sequence`
by a protocol of :mod:`sparseedm.temporal.protocols`, asks every method (a gap
filler, :mod:`sparseedm.temporal.fillers`) to fill them, track by track, and
scores the 2D error of each filled joint-frame as a percentage of the body's
pixel height (:func:`~sparseedm.temporal.sequences.body_height`, the median
head-top to ankle-midpoint distance of the sequence's true poses).

Protocols:

``"gaps"`` (A)
    For each gap length of `gap_lengths` separately, a seeded
    :func:`~sparseedm.temporal.protocols.gap_mask`; results are grouped by
    gap length (``"gap 10"``).
``"self-occlusion"`` (B)
    :func:`~sparseedm.temporal.protocols.self_occlusion_mask` from the
    sequence's 3D joints and camera, or-ed with seeded short dropouts;
    results grouped by run length (:data:`~sparseedm.temporal.protocols.RUN_BINS`).

Each group is also split by whether the run touches a clip end (``"end"``,
``"inside"``, ``"all"``), and an ``"overall"`` group pools every hidden
joint-frame. Masks are seeded by `random_state` and the clip's id, so a
sequence gets the same mask whatever else is evaluated with it.

A filler may return NaN where it has nothing to go on (a joint never observed
in the track): such joint-frames are counted as the method's ``unfilled``, and
every method's ``error`` is taken over the joint-frames that all the methods
evaluated together filled (``scored``), so that the rows compare the same
joint-frames; ``error_own`` is each method's error over all it filled.

A fill can be close to the truth on average and still jump where the joint
reappears: ``edge_jump`` is the mean *excess jump* at the gaps' edges
(:func:`edge_jumps`), in the same % of body height.

Examples
--------
>>> from sparseedm.temporal.fillers import fill_linear
>>> from sparseedm.temporal.sequences import Sequence
>>> from sparseedm.cameras import sample_cameras
>>> T = 60
>>> p = np.zeros((T, 14, 2)); p[:, :, 0] = np.arange(T)[:, None]; p[:, 13, 1] = 100.0
>>> seq = Sequence("c", np.arange(T), p, np.zeros((T, 14, 3)), sample_cameras(1))
>>> report = evaluate_video([seq], {"linear": fill_linear}, "gaps", gap_lengths=(10,))
>>> row = report.row("linear", "gap 10", "inside")
>>> row["error"]  # a straight-line motion: linear interpolation is exact inside
0.0
"""

from __future__ import annotations

import csv
import importlib
import io
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _progress
from .._atomic import atomic_path, json_text
from ..dictionary import Dictionary, load_dictionary
from ..exceptions import ParameterError
from ..skeleton import SKELETON_14
from .fillers import FILLERS, sparse_filler
from .protocols import (GAP_LENGTHS, RUN_BINS, dropout_mask, gap_mask, run_bin, run_lengths,
                        self_occlusion_mask)
from .sequences import Sequence, load_sequences

__all__ = ["evaluate_video", "VideoReport", "protocol_masks", "detector_jitter", "edge_jumps",
           "resolve_methods", "ratio_interval", "plot_fill", "PROTOCOLS", "DEFAULT_METHODS"]

PROTOCOLS = ("gaps", "self-occlusion")
#: methods evaluated when none are named
DEFAULT_METHODS = ("linear", "cubic", "akima", "pca", "kalman", "sparse")
_ENDS = ("all", "end", "inside")


def resolve_methods(methods, dictionary=None):
    """``{name: filler}`` from names of :data:`~sparseedm.temporal.fillers.FILLERS`,
    a dict of fillers, or a mix of names and ``(name, filler)`` pairs.

    ``"sparse"`` uses `dictionary` (None: the shipped default). A name
    ``"module:function"`` imports that filler (e.g. a temporal model under
    test: ``sparseedm.temporal.recover:recover_track``); its row is named
    after the function.

    Parameters
    ----------
    methods : sequence or dict
        Filler names, ``"module:function"`` names and ``(name, filler)`` pairs,
        or a ``{name: filler}`` dict.
    dictionary : Dictionary or str, optional
        The dictionary of the ``"sparse"`` filler; None: the shipped default.

    Returns
    -------
    dict of str to callable
        Each method's filler, ``filler(poses, missing, frames)``, in the order given.

    Raises
    ------
    ParameterError
        If a name is unknown or cannot be imported.

    Examples
    --------
    >>> list(resolve_methods(["linear", ("mine", lambda p, m, f: p)]))
    ['linear', 'mine']
    >>> list(resolve_methods(["sparseedm.temporal.fillers:fill_akima"]))
    ['fill_akima']
    >>> resolve_methods(["spline"])
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: evaluate_video: unknown method 'spline'; known: linear, cubic, akima, pca, kalman, sparse, module:function, or a (name, filler) pair
    """
    items = methods.items() if isinstance(methods, dict) else methods
    out = {}
    for item in items:
        if isinstance(item, str) and ":" in item:
            name, fill = _import_filler(item)
        elif isinstance(item, str):
            if item not in FILLERS:
                raise ParameterError(f"evaluate_video: unknown method {item!r}; known: "
                                     f"{', '.join(FILLERS)}, module:function, or a (name, "
                                     "filler) pair")
            name, fill = item, FILLERS[item]
            if item == "sparse" and dictionary is not None:
                fill = sparse_filler(dictionary if isinstance(dictionary, Dictionary)
                                     else load_dictionary(dictionary))
        else:
            name, fill = item
        out[str(name)] = fill
    return out


def _import_filler(text):
    module, _, attr = text.partition(":")
    try:
        fill = getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError, ValueError) as exc:
        raise ParameterError(f"evaluate_video: method {text!r}: cannot import it ({exc})") \
            from None
    if not callable(fill):
        raise ParameterError(f"evaluate_video: method {text!r} is not a function")
    return attr, fill


def _seed(random_state, clip, *extra):
    return np.random.default_rng([int(random_state), zlib.crc32(clip.encode()), *extra])


def protocol_masks(sequence, protocol, *, gap_lengths=GAP_LENGTHS, random_state=0):
    """``{condition: missing (T, 14)}`` of one sequence under a protocol.

    Conditions are ``"gap L"`` per gap length (``"gaps"``) or the one
    ``"self-occlusion"`` mask. Seeded by `random_state` and the clip id. A
    callable `protocol` is your own: ``protocol(sequence)`` returns the dict.

    Parameters
    ----------
    sequence : Sequence
        The clip whose joints are hidden.
    protocol : {"gaps", "self-occlusion"} or callable
        The protocol; a callable returns the ``{condition: missing}`` dict itself.
    gap_lengths : sequence of int, optional
        The gap lengths of the ``"gaps"`` protocol (one mask each).
    random_state : int, default 0
        Seed, combined with the clip id.

    Returns
    -------
    dict of str to ndarray of bool (T, 14)
        The missing joints of each condition.

    Raises
    ------
    ParameterError
        If `protocol` is neither a callable nor one of :data:`PROTOCOLS`.

    Examples
    --------
    >>> from sparseedm.cameras import sample_cameras
    >>> seq = Sequence("c", np.arange(50), np.zeros((50, 14, 2)), np.zeros((50, 14, 3)),
    ...                sample_cameras(1))
    >>> sorted(protocol_masks(seq, "gaps", gap_lengths=(3, 10)))
    ['gap 10', 'gap 3']
    """
    if callable(protocol):
        return {str(k): np.asarray(v, dtype=bool) for k, v in protocol(sequence).items()}
    if protocol not in PROTOCOLS:
        raise ParameterError(f"evaluate_video: protocol must be one of {', '.join(PROTOCOLS)}; "
                             f"got {protocol!r}")
    T = len(sequence)
    if protocol == "gaps":
        return {f"gap {L}": gap_mask(T, L, random_state=_seed(random_state, sequence.clip, L))
                for L in gap_lengths}
    cam = sequence.camera
    hidden = self_occlusion_mask(sequence.poses3d, cam.R[0], cam.t[0], cam.f[0], cam.c[0])
    drops = dropout_mask(T, random_state=_seed(random_state, sequence.clip))
    return {"self-occlusion": hidden | drops}


@dataclass
class VideoReport:
    """What :func:`evaluate_video` returns.

    Parameters
    ----------
    protocol : str
        The protocol the sequences were evaluated under: ``"gaps"``,
        ``"self-occlusion"``, or a callable protocol's name.
    rows : list of dict
        One per (method, group, end): ``method``, ``group`` (``"gap 10"``, a
        run-length bin such as ``"6-15"``, or ``"overall"``), ``end``
        (``"all"``, ``"end"``, ``"inside"``), ``n`` (hidden joint-frames),
        ``error`` (mean 2D error of the filled ones, % of body height; NaN
        when none), ``median``, ``unfilled`` (joint-frames the method left NaN),
        ``sequence_sums`` and ``sequence_counts`` (the scored errors' sum and
        count per sequence, in the order given: what :func:`ratio_interval`
        resamples), ``edges`` (gap edges with an observed neighbour, the
        runs' starts and ends; those every method filled) and ``edge_jump``
        (their mean excess jump, :func:`edge_jumps`, % of body height; NaN
        when none).
    seconds : dict
        Each method's total fill time.
    settings : dict
        The protocol's settings: sequences, frames, clips, seed, conditions,
        gap lengths, hidden fraction, filled_frames (frames each method
        filled: frames times conditions).
    """

    protocol: str
    rows: list
    seconds: dict
    settings: dict = field(default_factory=dict)

    def row(self, method, group, end="all"):
        """The row of `method`, `group` and `end` (KeyError if absent).

        Parameters
        ----------
        method : str
            The method's name, as given to :func:`evaluate_video`.
        group : str
            ``"gap L"``, a run-length bin such as ``"6-15"``, or ``"overall"``.
        end : {"all", "end", "inside"}, default "all"
            Which runs: all of them, those touching a clip end, or the others.

        Returns
        -------
        dict
            The row (see the class's `rows`).

        Raises
        ------
        KeyError
            If the report has no such row.
        """
        for r in self.rows:
            if (r["method"], r["group"], r["end"]) == (method, group, end):
                return r
        raise KeyError((method, group, end))

    def ratio_interval(self, method, peers, group, end="all", **kwargs):
        """:func:`ratio_interval` on this report's rows.

        Parameters
        ----------
        method : str
            The method whose error is the numerator.
        peers : sequence of str
            The methods compared to; the best of them is the denominator.
        group : str
            The group, as in :meth:`row`.
        end : str, default "all"
            Which runs, as in :meth:`row`.
        **kwargs
            `level`, `n_resamples` and `random_state` of :func:`ratio_interval`.

        Returns
        -------
        dict
            As :func:`ratio_interval`.
        """
        return ratio_interval(self.rows, method, peers, group, end, **kwargs)

    @property
    def methods(self):
        """The methods of the report, in the order they were evaluated.

        Returns
        -------
        list of str
            One name per method.
        """
        return list(dict.fromkeys(r["method"] for r in self.rows))

    @property
    def groups(self):
        """The groups of the report, in the order they appear in its rows.

        Returns
        -------
        list of str
            One label per group.
        """
        return list(dict.fromkeys(r["group"] for r in self.rows))

    def table(self, end="all"):
        """A Markdown table: one row per method, one column per group (error %), the
        excess jump at the gap edges (all groups, %) and the frames filled per second.

        Parameters
        ----------
        end : {"all", "end", "inside"}, default "all"
            Which runs the error columns pool.

        Returns
        -------
        str
            The Markdown table, with a last row of hidden (scored) joint-frames;
            a cell without a scored joint-frame (or an edge jump without an
            edge) is blank.
        """
        groups = self.groups
        lines = ["| method | " + " | ".join(groups) + " | edge jump | frames/s |",
                 "|---|" + "---|" * (len(groups) + 2)]
        frames = self.settings.get("filled_frames", 0)
        for m in self.methods:
            cells = []
            for g in groups:
                try:
                    r = self.row(m, g, end)
                except KeyError:
                    cells.append("")
                    continue
                # blank without a scored joint-frame, as evaluation_real's cells
                cell = "" if r["scored"] == 0 else f"{r['error']:.2f}"
                if r["unfilled"]:
                    cell += f" ({r['unfilled'] / r['n']:.0%} unfilled)"
                elif r["scored"] < r["n"]:
                    cell += f" [{r['error_own']:.2f} on all {r['n']}]"
                cells.append(cell.strip())
            speed = frames / self.seconds[m] if self.seconds.get(m) else float("nan")
            overall = self.row(m, "overall", end)
            jump = f"{overall['edge_jump']:.2f}" if overall.get("edges") else ""  # none: blank
            lines.append(f"| {m} | " + " | ".join(cells) + f" | {jump} | {speed:,.0f} |")
        counts = [self.row(self.methods[0], g, end) for g in groups] if self.methods else []
        edges = counts[-1].get("edges", 0) if counts else 0
        lines.append("| hidden (scored) joint-frames; edges | " + " | ".join(
            f"{r['n']}" + (f" ({r['scored']})" if r["scored"] < r["n"] else "")
            for r in counts) + f" | {edges} | |")
        return "\n".join(lines)

    def to_json(self):
        """The report as JSON text: protocol, settings, seconds and rows.

        Returns
        -------
        str
            Indented strict JSON: a value that is not a number (NaN, where
            there is no edge or no scored joint) is ``null``.
        """
        return json_text({"protocol": self.protocol, "settings": self.settings,
                          "seconds": self.seconds, "rows": self.rows}, indent=1)

    def to_csv(self):
        """The report's rows as CSV text, one line per (method, group, end).

        Returns
        -------
        str
            CSV with a header row; the per-sequence sums are left out.
        """
        buf = io.StringIO()
        keys = ("method", "group", "end", "n", "scored", "error", "median", "error_own",
                "unfilled", "edges", "edge_jump")
        writer = csv.DictWriter(buf, fieldnames=keys, lineterminator="\n")
        writer.writeheader()
        for r in self.rows:
            writer.writerow({k: r[k] for k in keys})
        return buf.getvalue()

    def write(self, json_path=None, csv_path=None):
        """Write the report as JSON and/or CSV, atomically.

        Parameters
        ----------
        json_path : str or Path, optional
            Where to write :meth:`to_json`; None: not written.
        csv_path : str or Path, optional
            Where to write :meth:`to_csv`; None: not written.
        """
        for path, text in ((json_path, self.to_json), (csv_path, self.to_csv)):
            if path is not None:
                with atomic_path(path) as tmp:
                    Path(tmp).write_text(text(), encoding="utf-8")


def detector_jitter(sequence, level, random_state=0):
    """Seeded white noise (T, N, 2) of `level` x the body's pixel height.

    What :func:`evaluate_video` adds to the observed coordinates with
    ``noise=level`` (a detector's jitter; motion capture projected by a
    camera has none). Seeded by `random_state` and the clip id, so every
    method, and every protocol condition, sees the same noise. (The temporal
    model's :func:`sparseedm.temporal.model.observation_noise` estimates such
    noise from a track.)

    Parameters
    ----------
    sequence : Sequence
        The clip (its true 2D poses give the body's height).
    level : float
        The noise's standard deviation per coordinate, as a fraction of the
        body's pixel height.
    random_state : int, default 0
        Seed, combined with the clip id.

    Returns
    -------
    ndarray (T, N, 2)
        The noise, pixels.

    Examples
    --------
    >>> from sparseedm.cameras import sample_cameras
    >>> p = np.zeros((400, 14, 2)); p[:, 0, 1] = -170.0    # head top 170 px above the ankles
    >>> seq = Sequence("c", np.arange(400), p, np.zeros((400, 14, 3)), sample_cameras(1))
    >>> e = detector_jitter(seq, 0.01)
    >>> e.shape, round(float(e.std()), 1)
    ((400, 14, 2), 1.7)
    """
    rng = _seed(random_state, sequence.clip, 31)
    return rng.normal(scale=float(level) * sequence.height, size=sequence.poses2d.shape)


def edge_jumps(truth, filled, missing, frames):
    """The excess jump of a fill at the edges of its gaps, on one track: (T, N, 2).

    A gap is a run of missing frames of one joint. Where it starts at row
    ``s`` after an observed row ``s - 1`` one frame earlier, the filled joint
    moves ``|filled[s] - filled[s - 1]|`` (from the observed position: fillers
    keep observed joints as given) where the truth moves
    ``|truth[s] - truth[s - 1]|``; the excess jump is the difference, positive
    when the fill jumps more than the body did. At the gap's last row ``e``
    before an observed row ``e + 1`` the same with ``e`` and ``e + 1``.

    Parameters
    ----------
    truth, filled : array_like (T, N, 2)
    missing : array_like of bool (T, N)
    frames : array_like of int (T,)
        Sorted frame numbers: an edge counts only where its observed
        neighbour is one frame away (not across a skipped frame).

    Returns
    -------
    ndarray (T, N, 2)
        ``[..., 0]``: the excess at a gap's first row, ``[..., 1]``: at its
        last (a one-frame gap has both on its row), in the units of `truth`;
        NaN elsewhere and at an edge with no observed neighbour (a clip end).

    Examples
    --------
    Frames 2-3 of a joint moving 1 px a frame are hidden and filled 3 px
    off in x: it jumps 4 px into the gap where the truth moves 1 (excess 3),
    and 2 px back out of it (excess 1):

    >>> truth = np.zeros((6, 1, 2)); truth[:, 0, 0] = np.arange(6)
    >>> missing = np.zeros((6, 1), bool); missing[2:4] = True
    >>> filled = truth.copy(); filled[2:4, 0, 0] += 3
    >>> edge_jumps(truth, filled, missing, np.arange(6))[:, 0]
    array([[nan, nan],
           [nan, nan],
           [ 3., nan],
           [nan,  1.],
           [nan, nan],
           [nan, nan]])
    """
    truth, filled = np.asarray(truth, float), np.asarray(filled, float)
    missing = np.asarray(missing, bool)
    adjacent = (np.diff(np.asarray(frames)) == 1)[:, None]
    excess = np.linalg.norm(np.diff(filled, axis=0), axis=-1) \
        - np.linalg.norm(np.diff(truth, axis=0), axis=-1)          # between rows k, k + 1
    out = np.full(missing.shape + (2,), np.nan)
    out[1:, :, 0] = np.where(missing[1:] & ~missing[:-1] & adjacent, excess, np.nan)
    out[:-1, :, 1] = np.where(missing[:-1] & ~missing[1:] & adjacent, excess, np.nan)
    return out


def evaluate_video(sequences, methods=DEFAULT_METHODS, protocol="gaps", *,
                   gap_lengths=GAP_LENGTHS, random_state=0, dictionary=None, noise=0.0):
    """Score gap fillers on sequences under a video protocol.

    Parameters
    ----------
    sequences : list of Sequence, or path
        Sequences (:mod:`sparseedm.temporal.sequences`), or a dataset .npz
        built with one camera per clip.
    methods : sequence of str or (name, filler), or dict
        Names of :data:`~sparseedm.temporal.fillers.FILLERS` (default
        linear, cubic, akima, pca, kalman, sparse) and/or your own fillers.
    protocol : {"gaps", "self-occlusion"} or callable
        A callable ``protocol(sequence) -> {condition: missing (T, 14)}`` is
        your own protocol; its results are grouped by run length, as
        ``"self-occlusion"``'s.
    gap_lengths : tuple of int, default (3, 10, 30, 90)
        Protocol A's gap lengths.
    random_state : int, default 0
        Seed of the masks (with each clip's id).
    dictionary : Dictionary, str or path, optional
        The ``"sparse"`` method's dictionary (None: the shipped default).
    noise : float, default 0
        Seeded white noise of this times the body's pixel height added to
        every observed coordinate (:func:`detector_jitter`: a detector's
        jitter, the same for every method); errors are still taken against
        the clean truth. 0.01 is a good detector's level.

    Returns
    -------
    VideoReport
    """
    try:
        noise = float(noise)
    except (TypeError, ValueError):
        noise = float("nan")
    if not (np.isfinite(noise) and 0 <= noise < 1):
        raise ParameterError(f"evaluate_video: noise must be in [0, 1) (a fraction of the "
                             f"body height), got {noise!r}")
    if isinstance(sequences, (str, Path)):
        sequences = load_sequences(sequences)
    sequences = list(sequences)
    if not sequences:
        raise ParameterError("evaluate_video: no sequences to evaluate (a sequence file "
                             "keeps clips of 31 to 300 frames; are its clips shorter?)")
    fillers = resolve_methods(methods, dictionary)
    records = {m: [] for m in fillers}  # (group, at_end, error, sequence, edge jumps)
    seconds = dict.fromkeys(fillers, 0.0)
    hidden = total = filled_frames = 0
    conditions = []
    told = _progress.steps(sequences, f"evaluating {', '.join(fillers)} on the sequences "
                           f"(protocol {protocol!r})", unit="sequence")
    for index, seq in enumerate(told):
        truth, height = seq.poses2d, seq.height
        observed = truth + detector_jitter(seq, noise, random_state) if noise else truth
        for condition, missing in protocol_masks(seq, protocol, gap_lengths=gap_lengths,
                                                 random_state=random_state).items():
            conditions.append(condition)
            lengths, at_end = run_lengths(missing)
            groups = np.full(lengths.shape, condition) if protocol == "gaps" \
                else run_bin(lengths)
            given = np.where(missing[..., None], np.nan, observed)
            hidden += int(missing.sum())
            total += missing.size
            filled_frames += len(seq)
            for name, fill in fillers.items():
                start = time.perf_counter()
                filled = fill(given, missing, seq.frames)
                seconds[name] += time.perf_counter() - start
                err = np.linalg.norm(filled - truth, axis=-1) / height * 100.0
                jump = edge_jumps(truth, filled, missing, seq.frames) / height * 100.0
                records[name].append((groups[missing], at_end[missing], err[missing],
                                      np.full(int(missing.sum()), index), jump[missing]))
    rows = _rows(records, protocol, gap_lengths, len(sequences))
    settings = {"sequences": len(sequences), "frames": int(sum(len(s) for s in sequences)),
                "clips": sorted({s.clip.split("#")[0] for s in sequences}),
                "random_state": int(random_state), "conditions": sorted(set(conditions)),
                "hidden_fraction": hidden / total if total else 0.0,
                "filled_frames": filled_frames, "noise": float(noise)}
    if protocol == "gaps":
        settings["gap_lengths"] = [int(L) for L in gap_lengths]
    name = protocol if isinstance(protocol, str) else getattr(protocol, "__name__", "custom")
    return VideoReport(name, rows, seconds, settings)


def _rows(records, protocol, gap_lengths, n_sequences):
    order = [f"gap {L}" for L in gap_lengths] if protocol == "gaps" else \
        [label for _, _, label in RUN_BINS]
    first = next(iter(records.values()), [])
    groups = np.concatenate([p[0] for p in first]) if first else np.array([], str)
    ends = np.concatenate([p[1] for p in first]) if first else np.array([], bool)
    seq = np.concatenate([p[3] for p in first]) if first else np.array([], int)
    errs = {name: np.concatenate([p[2] for p in parts]) if parts else np.array([])
            for name, parts in records.items()}
    jumps = {name: np.concatenate([p[4] for p in parts]) if parts else np.zeros((0, 2))
             for name, parts in records.items()}
    common = np.logical_and.reduce([np.isfinite(e) for e in errs.values()]) if errs else \
        np.array([], bool)
    # gap edges every method filled: each row's mean jump is over the same edges
    edges = np.logical_and.reduce([np.isfinite(j) for j in jumps.values()]) if jumps else \
        np.zeros((0, 2), bool)
    rows = []
    for name, err in errs.items():
        for group in order + ["overall"]:
            in_group = np.ones(err.shape, bool) if group == "overall" else groups == group
            for end in _ENDS:
                sel = in_group & {"all": True, "end": ends, "inside": ~ends}[end]
                row = _summary(name, group, end, err[sel], common[sel], seq[sel], n_sequences)
                jump = jumps[name][sel][edges[sel]]
                rows.append(dict(row, edges=int(jump.size), edge_jump=_mean(jump)))
    return rows


def _mean(e):
    return float(e.mean()) if e.size else float("nan")


def _summary(method, group, end, errs, common, seq, n_sequences):
    own = errs[np.isfinite(errs)]
    scored = errs[common]
    return {"method": method, "group": group, "end": end, "n": int(errs.size),
            "scored": int(scored.size), "error": _mean(scored),
            "median": float(np.median(scored)) if scored.size else float("nan"),
            "error_own": _mean(own), "unfilled": int(errs.size - own.size),
            # what ratio_interval resamples: the scored errors per sequence
            "sequence_sums": np.bincount(seq[common], scored, minlength=n_sequences).tolist(),
            "sequence_counts": np.bincount(seq[common], minlength=n_sequences).tolist()}


def ratio_interval(rows, method, peers, group, end="all", *, level=0.9, n_resamples=2000,
                   random_state=0):
    """`method`'s error over the best of `peers` in one group, with a bootstrap interval.

    The ratio the video goals are stated in (e.g. the temporal model's error
    over the best of linear, cubic, Akima and PCA gap filling in a run-length
    bin), and how far it can be trusted: the sequences are resampled with
    replacement `n_resamples` times (a joint-frame's error depends on its
    clip, so clips, not joint-frames, are the independent draws), each
    method's error is re-pooled over the resampled sequences' scored
    joint-frames, and the best peer is taken anew in each resample.

    Parameters
    ----------
    rows : list of dict
        :attr:`VideoReport.rows` (or the rows of its JSON), with their
        ``sequence_sums`` and ``sequence_counts``.
    method : str
        The method whose error is the numerator.
    peers : sequence of str
        The methods it is compared to; the best of them is the denominator.
    group : str
        The group, as in :meth:`VideoReport.row`.
    end : str, default "all"
        Which runs, as in :meth:`VideoReport.row`.
    level : float, default 0.9
        Coverage of the percentile interval.
    n_resamples : int, default 2000
        Bootstrap resamples of the sequences.
    random_state : int, default 0
        Seed of the resampling.

    Returns
    -------
    dict
        ``ratio`` (on all the sequences), ``low`` and ``high`` (the
        interval), ``best`` (the best peer on all the sequences) and
        ``sequences`` (how many have scored joint-frames in the group);
        NaN ratios where the group has none.

    Examples
    --------
    Two sequences where the method is half the peer's error, one where it is
    equal:

    >>> rows = [dict(method="m", group="g", end="all", sequence_sums=[1.0, 1.0, 4.0],
    ...              sequence_counts=[1, 1, 2]),
    ...         dict(method="p", group="g", end="all", sequence_sums=[2.0, 2.0, 4.0],
    ...              sequence_counts=[1, 1, 2])]
    >>> r = ratio_interval(rows, "m", ["p"], "g")
    >>> r["ratio"], r["best"], r["sequences"], r["low"] < r["ratio"] < r["high"]
    (0.75, 'p', 3, True)
    """
    if not 0 < level < 1:
        raise ParameterError(f"ratio_interval: level must be in (0, 1), got {level!r}")
    if int(n_resamples) < 1:
        raise ParameterError(f"ratio_interval: n_resamples must be >= 1, got {n_resamples!r}")
    names = [method] + [p for p in peers if p != method]
    if len(names) < 2:
        raise ParameterError("ratio_interval: needs at least one peer other than the method")
    found = {}
    for r in rows:
        if r["method"] in names and (r["group"], r["end"]) == (group, end):
            if "sequence_sums" not in r:
                raise ParameterError("ratio_interval: the rows have no per-sequence sums "
                                     "(a report written before they were kept)")
            found[r["method"]] = (np.asarray(r["sequence_sums"], float),
                                  np.asarray(r["sequence_counts"], float))
    missing = [n for n in names if n not in found]
    if missing:
        raise KeyError((missing, group, end))
    sums = np.stack([found[n][0] for n in names])
    counts = found[method][1]
    keep = counts > 0
    out = {"sequences": int(keep.sum())}
    if not keep.any():
        return dict(out, ratio=float("nan"), low=float("nan"), high=float("nan"), best=None)
    sums, counts = sums[:, keep], counts[keep]
    errors = sums.sum(axis=1) / counts.sum()
    best = 1 + int(np.argmin(errors[1:]))
    rng = np.random.default_rng(random_state)
    draws = rng.integers(0, counts.size, size=(int(n_resamples), counts.size))
    with np.errstate(divide="ignore", invalid="ignore"):
        boot = sums[:, draws].sum(axis=2) / counts[draws].sum(axis=1)
        ratios = boot[0] / boot[1:].min(axis=0)
    tail = 100 * (1 - level) / 2
    low, high = np.nanpercentile(ratios, [tail, 100 - tail])
    return dict(out, ratio=float(errors[0] / errors[best]), low=float(low), high=float(high),
                best=names[best])


def plot_fill(sequence, methods=DEFAULT_METHODS, protocol="gaps", joint="left_wrist", *,
              condition=None, gap_lengths=GAP_LENGTHS, random_state=0, dictionary=None,
              path=None):
    """One joint's filled trajectory against the truth over time, per method.

    Two panels (image x and y against the frame number): the true
    trajectory, the hidden frames shaded, and each method's values in them.
    Needs matplotlib (``pip install sparseedm[plot]``), imported here.

    Parameters
    ----------
    sequence : Sequence
    methods, protocol, gap_lengths, random_state, dictionary
        As :func:`evaluate_video` (the same masks).
    joint : str or int, default "left_wrist"
    condition : str, optional
        Which mask of the protocol (``"gap 30"``); default the last one.
    path : path, optional
        Save the figure there (PNG, atomically).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    j = SKELETON_14.index(joint) if isinstance(joint, str) else int(joint)
    masks = protocol_masks(sequence, protocol, gap_lengths=gap_lengths, random_state=random_state)
    missing = masks[condition if condition is not None else list(masks)[-1]]
    given = np.where(missing[..., None], np.nan, sequence.poses2d)
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9, 5))
    t = sequence.frames
    for k, ax in enumerate(axes):
        ax.plot(t, sequence.poses2d[:, j, k], color="black", lw=2, label="truth")
        for name, fill in resolve_methods(methods, dictionary).items():
            values = fill(given, missing, t)[:, j, k]
            ax.plot(t, np.where(missing[:, j], values, np.nan), lw=1.2, marker=".",
                    markersize=4, label=name)
        for start, stop in _spans(missing[:, j]):
            ax.axvspan(t[start] - 0.5, t[stop - 1] + 0.5, color="0.9", zorder=0)
        ax.set_ylabel(("x", "y")[k] + " (px)")
    axes[0].set_title(f"{sequence.clip}: {SKELETON_14.joint_names[j]}, hidden frames shaded")
    axes[0].legend(fontsize=8, ncol=3)
    axes[1].set_xlabel("frame")
    fig.tight_layout()
    if path is not None:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=110)
    return fig


def _spans(flags):
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))
