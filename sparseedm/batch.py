"""Recover the occluded joints of a whole keypoint file: chunked, atomic, with an errors file.

:func:`recover_file` is what ``sparseedm recover`` runs. It

1. reads the keypoints with :mod:`sparseedm.keypoints` (a ``.npy`` input is
   memory-mapped and streamed chunk by chunk, never loaded whole);
2. runs :func:`sparseedm.recovery.recover` on chunks of ``chunk_size`` poses,
   keeping only the filled poses and the per-row status, so memory stays
   bounded for millions of poses (the completed EDM vectors are kept only with
   ``save_edm=True``);
3. writes the filled poses in the input's format (or the one asked for) with
   the per-row status, through :func:`sparseedm._atomic.atomic_path`: a crash,
   Ctrl-C or bad input never leaves a half-written output;
4. writes an errors file listing the refused rows, if any.

Paths
-----
The output is written at exactly the path given: its format is
``output_format`` if given, else its extension's (``.csv``, ``.npz``, ``.npy``,
``.json``), else the input's, whatever the name. Before any work,
:func:`sparseedm._atomic.check_paths` refuses an output, errors file or sidecar
that is the input, the dictionary file or another output.

Output per format
-----------------
Every output holds, per row, ``status`` (one of
:data:`sparseedm.recovery.STATUSES`), ``reason``, ``objective`` and ``gap``
(of the lasso; empty/NaN where none was solved) and ``n_active`` (atoms used):

``.csv``
    the joint columns plus the columns ``status, reason, objective, gap,
    n_active`` (after any extra columns the input had);
``.npz``
    ``poses``, ``missing``, ``ids`` plus arrays ``status``, ``reason``,
    ``objective``, ``gap``, ``n_active`` (and any extra arrays the input had);
``.json``
    COCO: the input document (or a results list) with the recovered
    keypoints filled in (see :mod:`sparseedm.keypoints`) and the status
    fields added to each annotation's ``"sparseedm"`` object;
``.npy``
    a plain (n, 14, 2) array cannot hold them: they go to a sidecar
    ``<output stem>.status.npz`` (with ``ids`` when the input had them).

When the run may average some poses' answers with another's (the default
path over the file's complete poses:
:func:`sparseedm.exemplars.blend_many_hidden`), one more per-row field,
``averaged``, says what each pose's answer was averaged with
(:attr:`sparseedm.recovery.RecoveryResult.averaged`; empty: nothing), in
every format as ``outliers`` is below, and ``summary["averaged"]`` counts the
poses per kind. An input that is an earlier run's output keeps its own
columns, not that run's results (:data:`sparseedm.keypoints.RESULT_FIELDS`):
each output says what its own run did.

Refused rows are written back as they were read (observed joints kept, the
missing ones NaN / missing), so row i of the output is always row i of the
input. Detector confidences are not written to csv/npz/npy outputs. Every
output flags the joints this run filled (and those the input already flagged):
``<joint>_filled`` columns in CSV, a ``filled`` (n, 14) array in ``.npz`` (and
in the ``.status.npz`` sidecar of ``.npy`` and DeepLabCut outputs), the
``"sparseedm"`` object's ``filled`` list in the JSON formats (a DeepLabCut
table keeps DeepLabCut's own x, y, likelihood layout, so its flags are only in
the sidecar, which :func:`sparseedm.keypoints.read_keypoints` reads them back
from, as for ``.npy``); where the format keeps scores (COCO
``v``, OpenPose ``c``, MMPose ``keypoint_scores``, DeepLabCut ``likelihood``)
a filled joint's score is ``filled_score`` (default 0: below every threshold,
never a detection's), and COCO's ``num_keypoints`` counts the keypoints with
``v > 0`` again. Readers read flagged joints as present.

When the input has scores, the outlier check (:mod:`sparseedm.outliers`,
``outliers=True``) adds one more per-row field, ``outliers``: the names of the
joints it treated as missing, separated by spaces (a CSV column, an ``.npz``
or status-sidecar array, a field of the ``"sparseedm"`` object in the JSON
formats); those joints are flagged as filled too.

``save_edm=True`` also stores the completed EDM vectors (normalised units,
``edm_vectors`` (n, 91)) with their normalisation ``center`` (n, 2) and
``scale`` (n,): inside an ``.npz`` output, else in a sidecar
``<output stem>.edm.npz`` (for ``.npy`` output, in the ``.status.npz`` sidecar).

Errors file
-----------
A CSV with header ``row,id,status,reason``: ``row`` is the 0-based pose
index in the input (for a CSV input, line ``row + 2`` of the file), ``id``
the pose's id ("" when the input has none). It is written only when some rows
were refused; a stale errors file of an earlier run at the same path is
removed otherwise.
"""

from __future__ import annotations

import contextlib
import os
import json
import math
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from numbers import Integral, Real

from . import _progress
from ._atomic import atomic_path, check_folder, check_paths, json_text
from ._extras import require as require_extra
from ._parallel import one_client
from ._validation import (ALPHA, BOOLEAN, CHUNK_SIZE, ENSEMBLE, N_JOBS, PATH, SCORE,
                          Interval, Options, check_adapt, frame_numbers, read_frames,
                          validate_params)
from .adaptation import MIN_COMPLETE_POSES, sample_stream
from .dictionary import Dictionary, dictionary_path, check_gram_memory, load_dictionary
from ._safeio import resolved
from .ensemble import adapt_members
from .exemplars import EXEMPLAR_OPTIONS, blend_many_hidden, blend_parts, blends, finish_blend
from .exceptions import FileFormatError, OutputPathError, ParameterError, SparseEDMError
from .fconv.model import load_model
from .formats import FILLED_SCORE, count_below, default_threshold, threshold_line
from .formats import FORMATS as FOLDER_OR_TABLE_FORMATS
from .formats.deeplabcut import H5_SUFFIXES, check_h5_extra, read_joint_map
from .keypoints import (FLAGS_IN_SIDECAR, N_JOINTS, EXTENSIONS, RESULT_FIELDS, beside,
                        default_errors_path, write_errors,
                        check_joint_map, check_output_fits,
                        finish_missing, format_of, load_single_npy, npy_confidence,
                        origin_joints, read_keypoints, status_sidecar, write_keypoints)
from .keypoints import output_format as keypoint_output_format
from .cold_bank import bank_step, cold_bank_stack
from ._recovery_base import (OK_STATUSES, averaged_summary, cold_prior, combine,
                             mirror_weights, recovery_summary)
from ._recovery_kernel import PRESETS, compiled_solver, preset_solver
from .normalize import REPRESENTATIONS, representation_for
from .outliers import mark_outliers, outlier_names
from .recovery import STATUSES, check_options_apply, recover
from .uncertainty import joint_uncertainty
from .skeleton import JOINT_NAMES
from .temporal.recover import CLIP_MIN_POSES, adapt_in_time, linked_tracks, offered_poses
from .temporal.tracks import MAX_SKIP, add_summaries, has_time, split_tracks, track_windows
from .solvers import get_solver

__all__ = ["recover_file", "default_errors_path", "STATUS_FIELDS"]

#: Per-row fields every output carries (see the module docstring).
STATUS_FIELDS = ("status", "reason", "objective", "gap", "n_active")
_SUFFIX = {"npz": ".npz", "npy": ".npy", "csv": ".csv", "coco": ".json"}


def _sidecar(output, what) -> Path:
    return beside(output, f".{what}.npz")


# --------------------------------------------------------------------------
# input: one chunk iterator per source


class _MemorySource:
    """Keypoints read whole by :func:`read_keypoints` (csv, npz, COCO json)."""

    def __init__(self, path, fmt, threshold, joint_map=None):
        self.kps = read_keypoints(path, format=fmt, confidence_threshold=threshold,
                                  joint_map=joint_map)
        self.n = len(self.kps)
        self.ids = self.kps.ids
        self.meta = self.kps.meta
        # the frame numbers read once here, not again by each step's rule: the
        # writers keep the file's own (kps.frames)
        self.tracks, self.frames = self.kps.tracks, read_frames(self.kps.frames)
        self.linked = None
        self.outliers = None  # (n, 14): points the outlier check made missing

    def mark_outliers(self, dictionary, in_time, alpha, representation, solver, n_jobs):
        """Run the outlier check (:func:`sparseedm.outliers.mark_outliers`, the
        pose model `dictionary` with the run's settings, time when `in_time`)
        when the file has scores: its outliers made missing here, kept in
        ``outliers``."""
        if self.kps.confidence is None:
            return
        scores = self.kps.confidence if self.kps.filled is None else np.where(
            self.kps.filled, np.nan, self.kps.confidence)  # joints sparseedm filled: not checked
        self.kps.poses, self.kps.missing, self.outliers = mark_outliers(
            self.kps.poses, self.kps.missing, scores, dictionary,
            tracks=self.tracks, frames=self.frames if in_time else None, alpha=alpha,
            representation=representation, solver=solver, n_jobs=n_jobs)

    def link(self):
        """Track ids linked by pose, as :func:`recover` links them (:func:`linked_tracks`),
        for a file with frames, no tracks and several poses in some frame; the
        file is recovered and written with them."""
        self.linked = linked_tracks(self.kps.poses, self.kps.missing, self.tracks,
                                    self.frames)
        if self.linked is not None:
            self.tracks = self.linked

    def chunk(self, start, stop):
        return self.select(slice(start, stop))

    def select(self, rows):
        """Poses and missing mask of `rows` (a slice or an index array)."""
        return self.kps.poses[rows], self.kps.missing[rows]

    def below(self, threshold):
        """Joints scored below `threshold` (None: the file has no scores)."""
        return count_below(self.kps.confidence, threshold)

    def close(self):
        pass


class _NpySource:
    """A ``.npy`` file memory-mapped and read chunk by chunk.

    The same rules as :func:`read_keypoints` apply (shape (n, 14, 2) or
    (n, 14, 3) with a confidence column; a row with an infinite coordinate is
    refused by the recovery, as a bad row).
    """

    def __init__(self, path, threshold):
        self.path = path
        self.threshold = threshold
        arr = load_single_npy(path, mmap_mode="r")
        if isinstance(arr, np.lib.npyio.NpzFile):
            arr.close()
            raise FileFormatError(f"{path}: expected a single .npy array, found an .npz archive")
        if arr.dtype.kind not in "fiu":
            raise FileFormatError(f"{path}: the array must be numeric, got dtype {arr.dtype}")
        if arr.ndim == 2:
            arr = arr[None]
        if arr.ndim != 3 or arr.shape[-1] not in (2, 3):
            raise FileFormatError(f"{path}: poses must have shape (n, 14, 2), got {arr.shape}")
        if arr.shape[1] != N_JOINTS:
            raise FileFormatError(
                f"{path} has {arr.shape[1]} joints; sparseedm uses the 14-joint layout "
                f"({', '.join(JOINT_NAMES)})"
            )
        self.arr = arr
        self.n = len(arr)
        self.ids = None
        self.meta = {}
        self.tracks = self.frames = self.linked = None  # a .npy holds poses only
        self.outliers = None  # streamed: no outlier check
        self.origin_told = False  # joints at (0, 0) read as missing: said once

    def mark_outliers(self, *settings):
        """A streamed .npy is not checked for outliers (the check needs the
        whole file's tracks)."""

    def below(self, threshold, chunk_size=1 << 20):
        """Joints scored below `threshold` (None: no confidence column), chunk by chunk."""
        if self.arr.shape[-1] != 3:
            return None
        return sum(count_below(np.asarray(self.arr[s:s + chunk_size, :, 2], dtype=float),
                               threshold) for s in range(0, self.n, chunk_size))

    def select(self, rows):
        """Poses and missing mask of `rows` (a slice: a .npy is never interleaved)."""
        return self.chunk(rows.start, rows.stop)

    def chunk(self, start, stop):
        block = np.asarray(self.arr[start:stop], dtype=float)
        poses = block[..., :2]
        conf = npy_confidence(block, str(self.path), start) if block.shape[-1] == 3 else None
        missing = np.zeros(poses.shape[:2], dtype=bool)
        # the first chunk with joints at (0, 0) says so, once (chunks are read twice)
        where = None if self.origin_told else str(self.path) if len(poses) == self.n else (
            f"{self.path} (poses {start}-{start + len(poses) - 1}; later chunks alike, not "
            "counted)")
        self.origin_told |= bool(origin_joints(poses, np.isnan(poses).any(axis=-1)).any())
        return finish_missing(poses, missing, conf, self.threshold, where=where, origin=True)

    def close(self):
        mm = getattr(self.arr, "base", None)
        with contextlib.suppress(Exception):
            if hasattr(mm, "close"):
                mm.close()
        self.arr = None


def _output_format(out_path, in_fmt, output_format):
    ext = out_path.suffix.lower()
    named = ext in EXTENSIONS or ext in H5_SUFFIXES
    if output_format is None:
        return keypoint_output_format(out_path, None, in_fmt) if named else in_fmt
    fmt = format_of(out_path, output_format)
    by_name = keypoint_output_format(out_path, None, fmt) if named else None
    if by_name is not None and by_name != fmt:
        raise OutputPathError(
            f"{out_path}: its extension says {by_name}, the format asked for is "
            f"{output_format}; give a name that ends in {_SUFFIX.get(fmt, 'its extension')} "
            "(or drop the format)")
    return fmt


def _is_folder(out_path, out_fmt):
    """An OpenPose or MMPose output without ``.json`` is a folder of frame files."""
    return out_fmt in ("openpose", "mmpose") and out_path.suffix.lower() != ".json"


# --------------------------------------------------------------------------
# the batch


def recover_file(input, output, *, dictionary=None, alpha=None, representation=None,
                 solver="fast", n_jobs=1, chunk_size=50_000, output_format=None,
                 errors_path=None, progress=False, save_edm=False,
                 confidence_threshold=None, backend=None, scheduler=None,
                 method="sparse", model=None, adapt="auto", save_dictionary=None,
                 self_training=None, ensemble=1, joint_map=None,
                 filled_score=FILLED_SCORE, temporal=True, input_format=None,
                 preset="default", outliers=True, exemplars="auto", mirror=None):
    """Recover every pose of a keypoint file and write the filled poses.

    Parameters
    ----------
    input : str or path-like
        Keypoints in any format :func:`sparseedm.keypoints.read_keypoints`
        reads (``.csv``, ``.npz``, ``.npy``, COCO ``.json``).
    output : str or path-like
        Where to write the filled poses; written atomically.
    dictionary : Dictionary, str or path, optional
        Default: the shipped default dictionary; with ``adapt=False`` on poses
        coded one by one (no frames, or ``temporal=False``; sparse method),
        ``cmu-coco-k2932`` with ``mirror="auto"``, as :func:`sparseedm.recover`.
    alpha : float, optional
        Lasso penalty; default the dictionary's ``alpha_recover``.
    representation : {"average", "zero"}, optional
        Default: an FConv `model`'s own (another one is refused), else
        ``"average"`` (see :func:`sparseedm.recover`).
    solver : {"fast", "clarabel", "cvxpy-naive"} or a BaseSolver
    n_jobs : int, default 1
        joblib workers (see :func:`sparseedm.recover`).
    chunk_size : int, default 50_000
        Poses recovered per call of :func:`sparseedm.recover`; bounds memory.
    backend : {"loky", "threading", "dask"}, optional
        joblib backend of the parallel recovery; ``"dask"`` sends the work to a
        Dask cluster (``dask`` extra).
    scheduler : str, optional
        The Dask scheduler's address (``tcp://HOST:8786``) with ``backend="dask"``.
    output_format : {"csv", "npz", "npy", "coco"}, optional
        Default: from the output's extension, else the input's format.
    errors_path : str or path-like, optional
        Default ``<output stem>.errors.csv`` beside the output (a long stem
        shortened, :func:`default_errors_path`).
    progress : bool, default False
        A tqdm progress bar over poses.
    save_edm : bool, default False
        Also store the completed EDM vectors (see the module docstring).
    confidence_threshold : float, optional
        Joints whose confidence is below it count as missing (and are
        recovered). Default: the input format's
        (:data:`sparseedm.formats.DEFAULT_THRESHOLDS`). The summary gives the
        threshold and how many scored joints fell below it.
    method, model
        ``method="fconv"`` with an FConv ``model`` file (see
        :func:`sparseedm.recover`); the model is loaded and checked first.
    adapt : "auto", False, path or array_like (n, N, 2)
        ``"auto"``: adapt the dictionary on a bounded, seeded sample of the
        file's complete poses (gathered in a first pass; see
        :mod:`sparseedm.adaptation`) before recovering (the sparse method
        only); ``False``: do not; a keypoint file or an array: adapt on those
        poses instead. Either way the first pass also samples the file's
        incomplete poses for self-training.
    save_dictionary : str or path-like, optional
        Write the dictionary the poses were recovered with (.npz) there.
    self_training : int, optional
        Self-training rounds after an adopted adaptation, on a bounded seeded
        sample of the file's incomplete poses (see :func:`sparseedm.recover`);
        default :data:`sparseedm.adaptation.SELF_TRAINING_ROUNDS`.
    ensemble : int, default 1
        Adapted dictionaries to average (seeds 0, 1, ...; see
        :mod:`sparseedm.ensemble`): every chunk is recovered with each.
        ``save_dictionary`` writes the first.
    joint_map : str or path-like, optional
        DeepLabCut input: the joints map file (:mod:`sparseedm.formats.deeplabcut`).
    filled_score : float, default 0.0
        The score filled joints are written with (OpenPose, MMPose, DeepLabCut).
    temporal : bool, default True
        When the file gives each pose a frame (CSV column ``frame``, .npz
        ``frames``; with ``track``/``tracks``/``clips`` for several people),
        recover across time (:mod:`sparseedm.temporal`), whole tracks per call
        (chunks of about `chunk_size` poses; a longer track in windows of about
        `chunk_size` rows with context either side,
        :func:`~sparseedm.temporal.tracks.track_windows`); False: every pose on
        its own, as for a file without frames. A file whose poses mostly
        have no other frame of their track within
        :data:`~sparseedm.temporal.tracks.MAX_SKIP` frame numbers (photos
        whose names hold numbers) is recovered pose by pose
        (:data:`TIME_MIN_SHARE`; ``summary["frames_unused"]``: the poses alone,
        of ``poses``). ``summary["temporal"]`` says which was used.
    input_format : str, optional
        The input's keypoint format when its name does not tell (a pipe such
        as ``/dev/stdin``): as :func:`~sparseedm.keypoints.read_keypoints`'
        `format`; default told from the input.
    preset : {"default", "fast"}, default "default"
        As :func:`sparseedm.recover`'s: ``"fast"`` takes the sampled complete
        poses of the file (or of `adapt`) as the atoms, nothing learned
        (refused with self-training rounds, an ensemble, FConv, and on a
        file with frames unless ``temporal=False``).
    exemplars : {"auto", False}, default "auto"
        As :func:`sparseedm.recover`'s: under ``adapt="auto"``, per pose, the
        file's (sampled) complete poses are the only atoms (or their answers
        are averaged with two other codes of them), nothing learned, when
        :mod:`sparseedm.exemplars`'s rule finds them better than adapting;
        False: adapt as before (``--no-exemplars``).
    mirror : {False, True, "auto"}, optional
        Default ``"auto"`` with ``adapt=False`` and no `dictionary` (poses coded
        one by one), else False.
        As :func:`sparseedm.recover`'s: also code each pose's mirror image and
        average the two answers (``--mirror``), or weigh them by their lasso
        objectives (``"auto"``, ``--mirror-auto``); per pose: refused on a file
        with frames unless ``temporal=False``, and with FConv.
    outliers : bool, default True
        When the file has per-joint scores (not a ``.npy``, streamed): the
        outlier check (:mod:`sparseedm.outliers`): a point kept by the
        threshold but scored below 0.3 that the pose model and its track both
        contradict is treated as missing and filled; the output names such
        joints per row (``outliers``: joint names separated by spaces, a CSV
        column, an ``.npz`` / status-sidecar array, a field of each person's
        ``"sparseedm"`` object in JSON formats) and ``summary["outliers"]``
        counts them (None: not checked). False turns it off.

    Returns
    -------
    dict
        ``poses``, ``recovered_joints``, ``refused``, ``fallbacks``,
        ``seconds``, ``poses_per_second``, ``status`` (counts per status),
        ``output``, ``format``, ``errors`` (the errors file, or None),
        ``sidecars`` (other files written), ``adaptation`` (what adaptation
        did, :meth:`AdaptationResult.summary`, or None), ``averaged`` (what
        was averaged: the path's own averaged ``answers`` and, ``with`` each
        kind, its ``poses``, :func:`~sparseedm._recovery_base.averaged_summary`;
        {} nothing), ``ensemble`` (the dictionaries of an ensemble, 1 when
        none was asked for: the path's own averaged answers are not one),
        ``adaptation_line``,
        ``confidence_threshold`` (the one used), ``below_threshold`` (scored
        joints below it; None when the file has no scores), ``threshold_line``
        ``skipped_files`` ((file, reason) of the bad frame files an
        OpenPose folder skipped), ``frame_range`` (the first and last frame
        number read, None without) and ``frames_unused`` (see `temporal`;
        None when the frames were used or there were none).

    Raises
    ------
    SparseEDMError
        Whole-file problems (unreadable or malformed input, a dictionary that
        does not fit, alpha <= 0, unknown representation); nothing is written.
    """
    t0 = time.perf_counter()
    validate_params("recover_file", dict(
        input=input, output=output, dictionary=dictionary, alpha=alpha,
        representation=representation, n_jobs=n_jobs, chunk_size=chunk_size,
        errors_path=errors_path, progress=progress,
        save_edm=save_edm, confidence_threshold=confidence_threshold, backend=backend,
        scheduler=scheduler, method=method, save_dictionary=save_dictionary,
        self_training=self_training, ensemble=ensemble, joint_map=joint_map,
        filled_score=filled_score, temporal=temporal, input_format=input_format,
        preset=preset, outliers=outliers, exemplars=exemplars, mirror=mirror), _PARAMS)
    check_options_apply("recover_file", method=method, model=model, backend=backend,
                        scheduler=scheduler, adapt=adapt, ensemble=ensemble, preset=preset,
                        self_training=self_training, exemplars=exemplars)
    if method == "fconv" and ensemble > 1:
        raise SparseEDMError("ensemble averages adapted dictionaries: it needs "
                             "method='sparse'")
    _check_extras(backend, method, input, output)
    in_path, out_path = Path(input), Path(output)
    errors_path = default_errors_path(out_path) if errors_path is None else Path(errors_path)
    in_fmt = _input_format(in_path, joint_map, input_format)
    outputs = _Outputs(in_fmt, out_path, _output_format(out_path, in_fmt, output_format),
                       errors_path, save_edm, filled_score)
    _check_run_paths(outputs, in_path, dictionary, adapt, model, save_dictionary, joint_map)
    given, dictionary = dictionary, _loaded(dictionary)
    if method == "sparse" and not isinstance(adapt, (str, os.PathLike)):  # a path is read
        adapt = check_adapt(adapt, "recover_file", dictionary.n_joints)
    requested, solver = solver, _one_solver(solver)
    if method == "fconv":  # checked before anything is read or written
        model = load_model(model, representation=representation, kind="recover")
    representation = representation_for(  # None: the model's own, else the default
        representation, model.representation if method == "fconv" else None)

    threshold = default_threshold(in_fmt) if confidence_threshold is None else \
        confidence_threshold
    source = _NpySource(in_path, threshold) if in_fmt == "npy" else \
        _MemorySource(in_path, in_fmt, threshold, joint_map)
    below = source.below(threshold)
    if outputs.out_fmt == "openpose" and not _is_folder(out_path, outputs.out_fmt) and \
            source.meta.get("openpose_folder"):
        source.close()
        raise FileFormatError(f"{out_path}: a folder of OpenPose frames is written as a "
                              "folder; give an output path without .json")
    try:
        in_time = _in_time(source, temporal and method == "sparse")  # links, if it will
        _check_output_fits(source, outputs)
        cold, mirror = cold_prior(given, adapt, mirror, method == "sparse" and not in_time)
        dictionary, bank = (dictionary, False) if cold is given else (_loaded(cold), True)
        if outliers:  # scored points its track and the pose model contradict: missing
            source.mark_outliers(dictionary, in_time, alpha, representation, solver, n_jobs)
        if method == "sparse":
            with one_client(backend, scheduler) as dist:  # the adaptation's recoveries
                members, adaptation, blend = _adapt(
                    source, dictionary, adapt, chunk_size, confidence_threshold, n_jobs,
                    self_training, ensemble, in_time, preset, dist, exemplars,
                    blends(adapt, exemplars, preset, mirror, requested))
            dictionary = members[0]
        else:
            members, adaptation, blend = [dictionary], None, None
        solver = _solver_after(requested, solver, adaptation, preset)
        summary_members = len(members)
        members = _with_mirrors(members, mirror, in_time, method)
        recovery = _Recovery(members, alpha, representation, solver, n_jobs, backend,
                             scheduler, method, model, (source.tracks, source.frames)
                             if in_time else None, mirror == "auto", blend, adaptation, bank)
        summary = _run(source, outputs, recovery, chunk_size, progress, t0)
    finally:
        source.close()
    summary["confidence_threshold"] = threshold
    summary["skipped_files"] = list(source.meta.get("skipped") or [])
    summary["below_threshold"] = below
    summary["threshold_line"] = threshold_line(threshold, confidence_threshold is not None,
                                               in_fmt, summary["below_threshold"])
    summary["adaptation"] = adaptation.summary() if adaptation is not None else None
    _say_averaged(summary, adaptation, summary_members)
    summary["mirror"] = mirror
    summary.update(_time_summary(source))
    summary["adaptation_line"] = adaptation.line() if adaptation is not None else None
    if save_dictionary is not None:
        summary["dictionary"] = str(dictionary.save(save_dictionary))
    return summary


def _time_summary(source):
    """What became of `source`'s frames: ``frame_range`` (the first and last usable
    frame number read, or None), ``linked_tracks`` (the tracks linked for a file
    without any, or None) and ``frames_unused`` (see :func:`_in_time`)."""
    values, reason = (None, None) if source.frames is None else \
        frame_numbers(source.frames, source.n)
    usable = None if values is None else values[reason == ""]
    return dict(frame_range=None if usable is None or not len(usable) else
                [int(usable.min()), int(usable.max())],
                linked_tracks=None if source.linked is None else
                int(len(np.unique(source.linked))),
                frames_unused=None if source.frames_unused is None else dict(
                    zip(("alone", "poses"), source.frames_unused), max_skip=MAX_SKIP))


def _say_averaged(summary, adaptation, n_members):
    """`summary`'s ``averaged`` with the path's own averaged answers, and its
    ``ensemble``: 1 when the `n_members` dictionaries are those answers (nothing
    learned) and no ensemble was asked for."""
    own = adaptation.averaged_answers if adaptation is not None and n_members > 1 else ()
    if own:
        summary["averaged"] = {"answers": list(own), **summary["averaged"]}
    summary["ensemble"] = 1 if own and "ensemble" not in adaptation.settings else n_members
def _loaded(dictionary):
    """`dictionary` loaded (a name or path) and its Gram matrix's memory checked."""
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    check_gram_memory(dictionary)
    return dictionary


def _with_mirrors(members, mirror, in_time, method):
    """`members` and, with `mirror`, their mirrored dictionaries (each pose's answer
    averaged with its mirror image's); refused where poses are not recovered one
    by one by the lasso."""
    if not mirror:
        return members
    if method != "sparse" or in_time:
        raise ParameterError("recover_file: mirror averages each pose's sparse answer with "
                             "its mirror image's: it needs method='sparse' and, on a file "
                             "with frames, --no-temporal (temporal=False)")
    return [*members, *(m.mirrored() for m in members)]


def _one_solver(solver):
    """One solver instance for the whole file: its per-pattern caches serve every
    chunk (a SparseEDMError when the name is unknown or its backend missing)."""
    try:
        return get_solver(solver)
    except ImportError as exc:
        raise SparseEDMError(f"solver {solver!r} is not available ({exc})") from None
    except ValueError as exc:
        raise SparseEDMError(str(exc)) from None


def _input_format(in_path, joint_map, input_format=None):
    """The input's format (`input_format`, else told from the input), once the
    input is known to exist and to suit `joint_map`."""
    if not in_path.exists():
        raise FileNotFoundError(f"{in_path}: no such file")
    fmt = format_of(in_path, input_format)
    check_joint_map(in_path, fmt, joint_map)
    if joint_map is not None:  # a map that could never work: said before any work
        read_joint_map(joint_map)
    return fmt


def _check_extras(backend, method, input, output):
    """The extras the run will need, checked before the adaptation's minutes."""
    if backend == "dask":
        require_extra("dask", "backend='dask'")
    if method == "fconv":
        require_extra("torch", "method='fconv'")
    check_h5_extra(input, output)


#: a file with frames is recovered across time when at least this share of its
#: poses have another frame of their track within MAX_SKIP frame numbers; else
#: as photos (names holding numbers, frames far apart: the path across time
#: would answer every pose on its own, and worse than the photo path does)
TIME_MIN_SHARE = 0.5


def _in_time(source, temporal):
    """Whether `source` is recovered across time (`temporal`, and it has at
    least two distinct frames: :func:`has_time`, and most poses have a
    neighbouring frame of their track: :data:`TIME_MIN_SHARE`); a file without
    tracks whose frames hold several poses is linked first. A file whose frames
    are not used says so in ``source.frames_unused`` (poses alone, poses)."""
    source.frames_unused = None
    if not temporal or not has_time(source.frames):
        return False
    tracks = source.tracks
    source.link()
    alone = split_tracks(source.n, source.tracks, source.frames).alone
    if alone.mean() <= 1 - TIME_MIN_SHARE:
        return True
    source.linked, source.tracks = None, tracks  # photos: no tracks made up for them
    source.frames_unused = (int(alone.sum()), source.n)
    return False


def _check_run_paths(outputs, in_path, dictionary, adapt, model, save_dictionary,
                     joint_map=None):
    """Nothing the run reads (the joint map too) is ever written, and no output
    overwrites another."""
    out_path = outputs.out_path
    inputs = [("input", in_path)]
    if joint_map is not None:
        inputs.append(("joint map", Path(joint_map)))
    if not isinstance(dictionary, Dictionary):
        with contextlib.suppress(SparseEDMError):
            inputs.append(("dictionary", dictionary_path(dictionary)))
    if isinstance(adapt, (str, os.PathLike)) and adapt != "auto":
        inputs.append(("adaptation poses", Path(adapt)))
    if isinstance(model, (str, os.PathLike)):
        inputs.append(("model", Path(model)))
    written = [("output", out_path), ("errors file", outputs.errors_path),
               ("saved dictionary", save_dictionary)]
    written += [(f"{name} sidecar", path) for name, path in outputs.sidecars().items()]
    if save_dictionary is not None and Path(save_dictionary).suffix != ".npz":
        raise OutputPathError(f"saved dictionary {save_dictionary}: a dictionary file must "
                              "end in .npz")
    if _is_folder(out_path, outputs.out_fmt):  # a folder output may exist (an earlier run)
        for label, path in inputs:
            if resolved(path) == resolved(out_path):
                raise OutputPathError(f"output {out_path} is the {label} {path}: refusing "
                                      "to overwrite it")
        check_paths(inputs, [("output", out_path / "frame.json")] + written[1:])
        check_folder(out_path)  # replaces only a folder sparseedm wrote
    else:
        check_paths(inputs, written)


def _solver_after(requested, solver, adaptation, preset="default"):
    """The run's solver once it has adapted: the preset's coder
    (:func:`preset_solver`), or the fast one on its compiled kernel at any chunk
    size, as recover() does (:func:`compiled_solver`), when the solver was asked
    for by name (an instance the user gave is left as it is)."""
    chosen = preset_solver(requested, preset, adaptation)
    if chosen is not requested:
        return get_solver(chosen)
    if isinstance(requested, str) and adaptation is not None:
        return get_solver(compiled_solver(requested, [adaptation]))
    return solver


def _adapt(source, dictionary, adapt, chunk_size, threshold, n_jobs, self_training,
           ensemble=1, in_time=False, preset="default", dist=None, exemplars=False,
           blend=False):
    """The dictionaries to recover with (one unless an ensemble is asked for) and
    the first one's AdaptationResult: adapted on the file's complete poses or
    on other poses, then self-trained on the file's incomplete poses (bounded
    seeded samples of both, one pass over the source), or as given; `in_time`
    under "auto": as recover(frames=...) adapts (the whole file, read once);
    `preset` "fast": the sampled complete poses as atoms, nothing learned; `dist`
    the adaptation's recovery backend (:func:`~sparseedm._parallel.one_client`'s);
    `exemplars` as :func:`~sparseedm.ensemble.adapt_members`' (per pose, "auto" only);
    third, with `blend` (:func:`~sparseedm.exemplars.blends`), the atoms of the
    blend of poses with many hidden joints and of the mean on every occluded pose
    and the Gaussian of the stacked mean (:func:`~sparseedm.exemplars.blend_atoms`,
    :func:`~sparseedm.exemplars.ridge_mean_atoms`,
    :func:`~sparseedm.exemplars.linear_stack`; None: no blend)."""
    if in_time and preset == "fast":
        raise ParameterError("recover_file: preset 'fast' recovers each pose on its own: "
                             "the file has frames, add --no-temporal (temporal=False)")
    if adapt is False or adapt is None:
        return [dictionary], None, None
    if in_time and isinstance(adapt, str) and adapt == "auto":
        members, results = adapt_in_time(
            dictionary, *source.chunk(0, source.n), tracks=source.tracks,
            frames=source.frames, ensemble=ensemble, n_jobs=n_jobs,
            self_training=self_training, check_input=False)  # as the reader checked them
        # no result when the call's size or gaps ask for no adaptation (adapts())
        return members, results[0] if results else None, None
    chunks = (source.chunk(s, min(s + chunk_size, source.n))
              for s in range(0, source.n, chunk_size))
    complete, partial, partial_missing = sample_stream(chunks)
    n_joints = dictionary.n_joints
    if complete.size == 0:
        complete = np.zeros((0, n_joints, 2))
    if partial.size == 0:
        partial, partial_missing = np.zeros((0, n_joints, 2)), np.zeros((0, n_joints), bool)
    poses = np.concatenate([complete, partial])
    missing = np.concatenate([np.zeros(complete.shape[:2], bool), partial_missing])
    kw = dict(n_jobs=n_jobs, warn=False, self_training=self_training, file_atoms=True,
              preset=preset, exemplars=exemplars, **(dist or {}))
    if isinstance(adapt, str) and adapt == "auto":
        members, results = adapt_members(dictionary, poses, missing, "auto", ensemble, **kw)
        blend = blend_parts(dictionary, poses, missing, results[0]) if blend else None
        return members, results[0], blend
    if isinstance(adapt, (str, Path)):
        adapt, kw["min_poses"] = _adaptation_poses(adapt, threshold)
    members, results = adapt_members(dictionary, partial, partial_missing, adapt,
                                     ensemble, **kw)
    return members, results[0], None


def _adaptation_poses(path, threshold):
    """The poses an --adapt-from file offers (NaN where missing) and how many
    adaptation needs: a video's (it has frames) by the rule one clip adapts by
    (:func:`~sparseedm.temporal.recover.offered_poses`, CLIP_MIN_POSES), other
    files' complete poses by the per-frame rule."""
    kps = read_keypoints(path, confidence_threshold=threshold)
    if kps.frames is None:
        return kps.poses, MIN_COMPLETE_POSES
    return offered_poses(kps.poses, kps.missing, tracks=kps.tracks,
                         frames=kps.frames), CLIP_MIN_POSES


#: constraints of recover_file()'s arguments (see sparseedm._validation)
_PARAMS = {
    "input": PATH, "output": PATH, "dictionary": [Dictionary, "path", None],
    "alpha": ALPHA + [None], "representation": [Options(REPRESENTATIONS), None],
    "n_jobs": N_JOBS, "chunk_size": CHUNK_SIZE,
    "errors_path": PATH + [None], "progress": BOOLEAN, "save_edm": BOOLEAN,
    "confidence_threshold": [Interval(Real, None, None), None],
    "joint_map": PATH + [None],
    "filled_score": SCORE,
    "backend": [Options(("loky", "threading", "multiprocessing", "dask")), None],
    "scheduler": PATH + [None],
    "method": [Options(("sparse", "fconv"))],
    "save_dictionary": PATH + [None],
    "self_training": [Interval(Integral, 0, None), None],
    "ensemble": ENSEMBLE,
    "temporal": BOOLEAN,
    "input_format": [str, None],
    "preset": [Options(PRESETS)],
    "exemplars": [Options(EXEMPLAR_OPTIONS)],
    "outliers": BOOLEAN,
    "mirror": BOOLEAN + [Options(("auto",)), None],
}


@dataclass
class _Recovery:
    """How every chunk is recovered: the members (one dictionary unless an
    ensemble) and :func:`recover`'s settings; `time_axis` (tracks, frames) sends
    the poses to temporal recovery, whole tracks per chunk (:meth:`bounds`); `blend`
    the atoms of :func:`~sparseedm.exemplars.blend_many_hidden` (its `atoms`,
    `mean_atoms` and `linear`; None: none), as recover() blends; `adaptation` what
    the run's adaptation did: per pose, each chunk's radii are then rated as
    recover() rates that path's answers (:func:`~sparseedm.uncertainty.coding_way`),
    not as the members' own, recovered without it."""

    members: list
    alpha: object
    representation: str
    solver: object
    n_jobs: object
    backend: object
    scheduler: object
    method: str
    model: object
    time_axis: tuple = None
    mirror_gate: bool = False
    blend: object = None
    adaptation: object = None
    cold_bank: bool = False

    def bounds(self, n, chunk_size):
        """(rows, keep) of each chunk: `chunk_size` rows (a slice), or in time
        whole tracks of about that many rows, a longer track in windows whose
        own rows are `keep` (:func:`track_windows`; keep None: every row)."""
        if self.time_axis is None:
            return [(slice(s, min(s + chunk_size, n)), None) for s in range(0, n, chunk_size)]
        return [(slice(*b) if isinstance(b, tuple) else b, keep)
                for b, keep in track_windows(*self.time_axis, n, chunk_size)]

    def __call__(self, poses, missing, rows=slice(None)):
        """One chunk's RecoveryResult (the members' answers combined); with `blend`,
        then recover()'s donor step over the chunk's rows
        (:func:`~sparseedm.donors.donor_step`)."""
        res = self.answer(poses, missing, rows)
        if self.blend is not None:
            given = np.where(res.missing[..., None], np.nan, np.asarray(poses, float))
            res = finish_blend(res, given, res.missing,
                               lambda blend: replace(self, blend=blend).answer, self.blend,
                               bank=bank_step)
        if self.adaptation is not None and self.time_axis is None:
            res.uncertainty = joint_uncertainty(res)  # of the final joints, as recover()'s
        return res

    def answer(self, poses, missing, rows=slice(None)):
        """One chunk's RecoveryResult before the donor step (and its radii)."""
        in_time = {} if self.time_axis is None else dict(  # the chunk's rows
            tracks=None if self.time_axis[0] is None else np.asarray(self.time_axis[0])[rows],
            frames=np.asarray(self.time_axis[1])[rows])
        results = [recover(poses, missing, dictionary=d, alpha=self.alpha,
                           representation=self.representation, solver=self.solver,
                           n_jobs=self.n_jobs, backend=self.backend, scheduler=self.scheduler,
                           method=self.method, model=self.model, adapt=False, **in_time)
                   for d in self.members]
        res = combine(results, mirror_weights(results) if self.mirror_gate else None)
        if self.cold_bank:  # the cold prior's codes with the shipped pose bank's answer
            res = cold_bank_stack(res, poses, res.missing)
        if self.blend is not None:
            # the poses as recover() read them: its mask (validated) says what is missing;
            # the few blended rows are coded here, without a cluster's client
            res = blend_many_hidden(
                res, np.where(res.missing[..., None], np.nan, np.asarray(poses, float)),
                res.missing, *self.blend, representation=self.representation,
                n_jobs=self.n_jobs)
        if self.adaptation is not None and self.time_axis is None:
            res = replace(res, adaptation=self.adaptation)
        return res


@dataclass
class _Outputs:
    """Where a run writes and in which formats."""

    in_fmt: str
    out_path: Path
    out_fmt: str
    errors_path: Path
    save_edm: bool
    filled_score: float = FILLED_SCORE

    def sidecars(self):
        """name -> path of the sidecar file this output format needs (if any)."""
        if self.out_fmt in FLAGS_IN_SIDECAR:  # its filled flags live there
            return {"status": status_sidecar(self.out_path)}
        if self.save_edm and self.out_fmt != "npz":
            return {"edm": _sidecar(self.out_path, "edm")}
        return {}


class _Columns:
    """The per-row results of every chunk, gathered for the outputs."""

    def __init__(self, n, n_features, save_edm):
        self.status = np.empty(n, dtype=f"<U{max(map(len, STATUSES))}")
        self.reason = np.empty(n, dtype=object)
        self.objective = np.full(n, np.nan)
        self.gap = np.full(n, np.nan)
        self.n_active = np.zeros(n, dtype=np.int64)
        self.fallback = np.zeros(n, dtype=bool)
        self.flags = np.zeros((n, N_JOINTS), dtype=bool)  # joints filled by this run
        self.uncertainty = np.full((n, N_JOINTS), np.nan)  # the 90 % radius per joint
        self.averaged = None  # what each pose's answer was averaged with (blends only)
        self.recovered_joints = 0
        self.edm = None
        if save_edm:
            self.edm = {"edm_vectors": np.full((n, n_features), np.nan),
                        "center": np.full((n, 2), np.nan), "scale": np.full(n, np.nan)}

    def put(self, rows, res, missing):
        """Keep what `res` (a RecoveryResult of the poses whose `missing` mask is
        given) says of `rows` (a slice or an index array)."""
        self.status[rows] = res.status
        self.reason[rows] = res.reason
        self.objective[rows] = res.objective
        self.gap[rows] = res.gap
        self.n_active[rows] = res.n_active
        self.fallback[rows] = res.fallback
        self.flags[rows] = missing & res.ok[:, None] & np.isfinite(res.poses).all(axis=-1)
        if res.uncertainty is not None:
            self.uncertainty[rows] = res.uncertainty
        if res.averaged is not None:
            if self.averaged is None:
                self.averaged = np.full(len(self.status), "", dtype=object)
            self.averaged[rows] = res.averaged
        self.recovered_joints += int(
            res.missing[np.isin(res.status, ("recovered", "inaccurate"))].sum())
        if self.edm is not None:
            self.edm["edm_vectors"][rows] = res.vectors
            self.edm["center"][rows] = res.center
            self.edm["scale"][rows] = res.scale

    def fields(self, averaged=False):
        """The :data:`STATUS_FIELDS` columns, reasons as strings; with `averaged`
        (the run may blend) also ``averaged``, what each pose's answer was averaged
        with (:attr:`~sparseedm.recovery.RecoveryResult.averaged`, "" nothing)."""
        reason = self.reason.astype(str) if len(self.reason) else np.zeros(0, dtype="<U1")
        out = {"status": self.status, "reason": reason, "objective": self.objective,
               "gap": self.gap, "n_active": self.n_active}
        if averaged:
            out["averaged"] = np.full(len(self.status), "", dtype="<U1") \
                if self.averaged is None else self.averaged.astype(str)
        return out


def _run(source, outputs, recovery, chunk_size, progress, t0):
    """Recover `source` chunk by chunk into `outputs`, atomically; the summary."""
    n, out_path, out_fmt = source.n, outputs.out_path, outputs.out_fmt
    columns = _Columns(n, recovery.members[0].n_features, outputs.save_edm)
    sidecars = outputs.sidecars()
    with contextlib.ExitStack() as stack:
        # the temporary file gets the format's extension whatever the output's
        # name: numpy would otherwise append ".npz" / ".npy" to it
        out_tmp = out_path if _is_folder(out_path, out_fmt) else stack.enter_context(
            atomic_path(out_path, suffix=_SUFFIX.get(out_fmt, out_path.suffix or ".tmp")))
        side_tmp = {k: stack.enter_context(atomic_path(p, suffix=".npz"))
                    for k, p in sidecars.items()}
        if out_fmt == "npy" and n > 0:  # streamed straight to disk
            filled = np.lib.format.open_memmap(out_tmp, mode="w+", dtype=np.float64,
                                               shape=(n, N_JOINTS, 2))
        else:
            filled = np.empty((n, N_JOINTS, 2))
        temporal_summary = _recover_chunks_into(filled, columns, source, recovery,
                                                chunk_size, progress)
        fields = columns.fields(averaged=recovery.blend is not None)
        if source.outliers is not None:  # named per row, in every format
            fields["outliers"] = outlier_names(source.outliers, JOINT_NAMES)
        flags = columns.flags
        kps = getattr(source, "kps", None)
        if kps is not None and kps.filled is not None:
            flags |= kps.filled & np.isfinite(filled).all(axis=-1)  # flagged in the input
        with _said_as(out_tmp, out_path):
            _write_output(out_tmp, out_fmt, filled, source.ids, source.meta, outputs.in_fmt,
                          fields, columns.edm, outputs.filled_score, kps, flags, source.linked,
                          columns.uncertainty)
        _write_sidecars(side_tmp, dict(fields, filled=flags, uncertainty=columns.uncertainty,
                                       **_table_keys(out_fmt, source, kps)),
                        source.ids, columns.edm)
        if isinstance(filled, np.memmap):
            filled.flush()
            del filled
        refused = ~np.isin(columns.status, OK_STATUSES)
        skipped = list(source.meta.get("skipped") or [])
        write_errors(outputs.errors_path, refused, source.ids, columns.status,
                     fields["reason"], skipped)
    summary = recovery_summary(columns.status, columns.recovered_joints, columns.fallback,
                               time.perf_counter() - t0)
    return dict(summary, output=str(out_path), format=out_fmt,
                errors=str(outputs.errors_path) if refused.any() or skipped else None,
                sidecars=[str(p) for p in sidecars.values()], temporal=temporal_summary,
                outliers=None if source.outliers is None else int(source.outliers.sum()),
                averaged=averaged_summary(columns.averaged, rows=False))


@contextlib.contextmanager
def _said_as(tmp, path):
    """A writer's refusal names the output `path`, not its temporary file `tmp`."""
    try:
        yield
    except SparseEDMError as exc:
        raise type(exc)(str(exc).replace(str(tmp), str(path))) from None


def _recover_chunks_into(filled, columns, source, recovery, chunk_size, progress):
    """Each chunk of `source` recovered, written into `filled` (the poses) and
    `columns` (the rest); the chunks' temporal summaries added (None without)."""
    from tqdm.auto import tqdm

    n = source.n
    if not progress:  # else the bar says it
        _progress.say(f"recovering {n:,} poses" + (
            f", each coded over {len(recovery.members)} dictionaries and the answers averaged"
            if len(recovery.members) > 1 else ""))
    temporal_summary = None
    bar = tqdm(total=n, disable=not progress, unit="pose", desc="recover", dynamic_ncols=True)
    with bar:
        for rows, keep in recovery.bounds(n, chunk_size):
            poses, missing = source.select(rows)
            res = recovery(poses, missing, rows)
            if keep is not None:  # a window of a long track: its own rows only
                rows, poses, missing, res = rows[keep], poses[keep], missing[keep], res.take(keep)
            temporal_summary = add_summaries(temporal_summary, res.summary().get("temporal"))
            # refused rows are written back as read, a joint with an infinite
            # coordinate as missing (as the CSV writer does: no format gets an inf)
            bad = ~np.isfinite(poses).all(axis=-1, keepdims=True)
            filled[rows] = np.where(res.ok[:, None, None], res.poses,
                                    np.where(bad, np.nan, poses))
            columns.put(rows, res, missing)
            del res
            bar.update(len(poses))
    return temporal_summary


def _table_keys(out_fmt, source, kps):
    """The tracks and frames of the poses, for the status sidecar of a new
    DeepLabCut table (its rows are frames, not the poses in order: the flags are
    matched to its rows by track and frame when read back); else nothing."""
    if out_fmt != "dlc" or source.meta.get("dlc_columns") is not None or kps is None \
            or kps.frames is None:
        return {}
    tracks = source.linked if source.linked is not None else kps.tracks
    return {"frames": kps.frames} if tracks is None else {"frames": kps.frames,
                                                           "tracks": tracks}


def _write_sidecars(side_tmp, fields, ids, edm):
    """The status sidecar (a .npy / DeepLabCut output's fields, ids, EDMs) or the
    EDM sidecar, into the temporary paths `side_tmp` (name -> path)."""
    if "status" in side_tmp:
        extra = dict(fields)
        if ids is not None:
            extra["ids"] = ids
        if edm is not None:
            extra.update(edm)
        with open(side_tmp["status"], "wb") as f:
            np.savez(f, **extra)
    if "edm" in side_tmp:
        with open(side_tmp["edm"], "wb") as f:
            np.savez(f, **edm)


def _write_output(tmp, fmt, filled, ids, meta, in_fmt, fields, edm,
                  filled_score=FILLED_SCORE, kps=None, flags=None, linked=None,
                  uncertainty=None):
    """The output file; `linked` (the tracks :func:`link_tracks` gave a file
    without any) is written as its tracks (a ``track`` column, ``tracks`` array);
    `uncertainty` (the 90 % radii) where the format holds it."""
    flagged = dict(filled=flags, filled_score=filled_score)
    if fmt != "npy":  # .npy: in the status sidecar
        flagged["uncertainty"] = uncertainty
    if fmt in FOLDER_OR_TABLE_FORMATS:  # status in each person's "sparseedm" object
        write_keypoints(tmp, filled, format=fmt, ids=ids, meta=meta, row_fields=fields,
                        **flagged, **_output_time(fmt, kps, linked, in_fmt))
        return
    if fmt == "npy":
        if len(filled) == 0:
            with open(tmp, "wb") as f:
                np.save(f, np.zeros((0, N_JOINTS, 2)))
        return  # already streamed into the memmap
    if fmt == "npz":
        extra = _carried(meta.get("npz_extra")) if in_fmt == "npz" else {}
        extra.update(fields)
        if edm is not None:
            extra.update(edm)
        write_keypoints(tmp, filled, format="npz", ids=ids, meta={"npz_extra": extra},
                        **_output_time(fmt, kps, linked, in_fmt), **flagged)
    elif fmt == "csv":
        extra = _carried(meta.get("extra_columns")) if in_fmt == "csv" else {}
        extra.update({
            "status": fields["status"],
            "reason": fields["reason"],
            "objective": [_num(v) for v in fields["objective"]],
            "gap": [_num(v) for v in fields["gap"]],
            "n_active": fields["n_active"],
        })
        for key in ("outliers", "averaged"):
            if key in fields:
                extra[key] = fields[key]
        write_keypoints(tmp, filled, format="csv", ids=ids, extra_columns=extra,
                        **_output_time(fmt, kps, linked, in_fmt), **flagged)
    else:  # coco: the original document (or a results list), status in "sparseedm"
        write_keypoints(tmp, filled, format="coco", ids=ids,
                        **_output_time(fmt, kps, linked, in_fmt),
                        meta=meta if in_fmt == "coco" else None, **flagged)
        with open(tmp, encoding="utf-8") as f:
            doc = json.load(f)
        anns = doc["annotations"] if isinstance(doc, dict) else doc
        for r, ann in enumerate(anns):
            ann.setdefault("sparseedm", {}).update({
                "status": str(fields["status"][r]),
                "reason": str(fields["reason"][r]),
                "objective": float(fields["objective"][r]),   # NaN: null (json_text)
                "gap": float(fields["gap"][r]),
                "n_active": int(fields["n_active"][r]),
            })
            for key in ("outliers", "averaged"):
                if key in fields:
                    ann["sparseedm"][key] = str(fields[key][r])
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(json_text(doc))


def _carried(columns):
    """The input's own columns an output carries: not the results of an
    earlier run (:data:`~sparseedm.keypoints.RESULT_FIELDS`), which would say
    what that run did (this run writes its own, or none: no ``averaged`` when
    it blends nothing, no EDMs unless asked)."""
    return {k: v for k, v in (columns or {}).items() if k not in RESULT_FIELDS}


def _check_output_fits(source, outputs):
    """Refuse, before anything is recovered, the tracks and frames of `source`
    (the tracks linked for it, if any) that the output's writer would refuse
    (:func:`check_output_fits`)."""
    kps = getattr(source, "kps", None)
    if kps is not None:  # a .npy holds no tracks or frames
        check_output_fits(outputs.out_path, outputs.out_fmt, source.n, ids=source.ids,
                          meta=source.meta, **_output_time(outputs.out_fmt, kps,
                                                           source.linked, outputs.in_fmt))


def _output_time(fmt, kps, linked, in_fmt):
    """The tracks and frames an output in `fmt` is written with: the linked
    tracks if any; a folder or table format (or an output in another format
    than the input's) also the input's own tracks and frames (a CSV, ``.npz``
    or COCO input in its own format gets them back with the rest of its
    columns)."""
    if kps is None or (in_fmt == fmt and fmt not in FOLDER_OR_TABLE_FORMATS):
        return dict(tracks=linked)
    return dict(tracks=kps.tracks if linked is None else linked, frames=kps.frames)


def _num(v):
    return "" if math.isnan(v) else repr(float(v))
