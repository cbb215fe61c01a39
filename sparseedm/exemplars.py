"""The default path's choice: a file's own complete poses as the only atoms, or adaptation.

``recover()`` with its defaults can code the occluded poses of a file two ways:

* over the file's own complete poses as the only atoms (exemplars, nothing
  learned: :func:`sparseedm.file_atoms.file_dictionary`, what
  ``preset="fast"`` does), or
* over the shipped dictionary adapted on those poses and self-trained on the
  incomplete ones (:mod:`sparseedm.adaptation`; when its guard keeps the
  base, the base with the complete poses as extra atoms).

Which one is better depends on the file (``studies/fast/README.md``). On the
validation files the exemplars won on every file with at least
:data:`EXEMPLAR_MIN_POSES` complete poses and took a fraction of the time;
below that it depended on the source. So :func:`choose_exemplars` decides:

1. fewer than :data:`~sparseedm.adaptation.MIN_COMPLETE_POSES` usable
   complete poses (repeats, which make one atom, counted once: exact, or
   within :data:`~sparseedm.adaptation.REPEAT_TOLERANCE` of the pose's size,
   as adaptation counts them): too few to be a dictionary on their own; no adaptation, the
   complete poses join the base's atoms. From :data:`FEW_MIN_POSES` of them
   (14 joints), a check on held-back complete poses (held back and hidden as
   in 3.) compares that with the mean of its answers and of the base with
   the poses and their mirror images as extra atoms
   (:data:`~sparseedm.adaptation.MIRRORED_ATOMS_PATH`), taken when its error
   is lower. On validation files of 60-240 complete poses it lowered the
   error on real photos (MPII, Bonn: up to 0.7 % of body size) and moved
   mocap files (CMU, Daz) by -0.05 to +0.01 (``studies/fast/README.md``);
2. at least :data:`EXEMPLAR_MIN_POSES` atoms as
   :func:`~sparseedm.file_atoms.file_dictionary` makes them (near-copies
   within :data:`~sparseedm.file_atoms.ATOM_SPACING` merged: a still
   person's noisy frames are one): the exemplars, no adaptation and no
   self-training;
3. in between, an evidence check on held-back complete poses (a seeded
   20 % of them, at most 300; each hidden as one of the file's own
   incomplete poses is, :func:`held_masks`, or by the guard's Mix masks of
   1-3 joints when none keeps 3 joints), scored on the hidden joints themselves (their distance to the
   truth in % of the pose's size, the RMS distance of its joints to their
   centroid), not on the EDM: the exemplars made of the other complete
   poses against the base dictionary with those poses as extra atoms (what
   the default path recovers with when its guard keeps the base), and the
   mean of three answers (:func:`averaged_members`: the exemplars, the
   exemplars with their mirror images, the base with the exemplars as extra
   atoms). None learns, so the check costs three small recoveries. The
   better of the exemplars and the mean (ties go to the exemplars, which are
   faster) is taken, nothing learned, unless the base-with-atoms' error is
   below it by more than :data:`EXEMPLAR_MARGIN` (relative); otherwise the
   file adapts and self-trains as before. The mean codes every occluded pose
   three times, each with its own lasso and certificate; the statuses are
   combined as an ensemble's members' are (``recover(..., ensemble=K)``).

   The held-back poses are single rows, not the guard's contiguous blocks:
   an occluded pose of a video keeps its neighbouring complete frames in the
   file, and so does a held-back pose here (with blocks, the check judged
   the exemplars on poses whose neighbours were gone, and preferred the base
   on CMU files where the two were equal). A check after adapting, against
   the adapted dictionary on the guard's own held-back poses, was measured
   and dropped: the guard had chosen the adapted dictionary on those very
   poses, so it looked better there than it was
   (``studies/fast/README.md``). The file's own missing patterns, rather
   than Mix masks, kept the mean from files where it was worse (Bonn frames
   under real masks: the exemplars alone find the neighbouring frames).

On each of these paths that learns nothing and codes over the file's
poses, a pose with at least :data:`BLEND_MIN_HIDDEN` hidden joints then gets
the mean of that answer and the local ridge's over the file's complete poses
as the only atoms (:func:`blend_many_hidden`: ``preset="fast"``'s coder,
which spreads each code over the pose's 48 nearest exemplars): such joints
are poorly determined by what is seen, and an average of nearby exemplars
errs less than one committed code. From :data:`BLEND_MIN_POSES` usable
complete poses; on validation photos under real visibility masks it lowered
the hidden joints' error on every file; Mix masks (1-3 joints) never hide
four (``studies/fast/README.md``).

The check (1. and 3.) then also scores, on its held-back poses, the chosen
path's answer (with that blend) against its mean with the local ridge's over
the base dictionary with the other complete poses as extra atoms; when the
mean's error is lower, every occluded pose gets that mean
(:func:`ridge_mean_atoms`). Over three draws of the validation files it
lowered the error of photos under Mix masks by 0 to 0.29 % of body size
(never taken on the MPII file where the mean on every file lost 0.21) and
of the CMU and Daz mocap files by 0.23-0.37 (``studies/fast/README.md``).

Last, the check weighs the answer so far (with the blends and that mean)
against a Gaussian one: the conditional mean of the hidden joints given the
observed ones, each pose in the frame of its observed joints, under the
Gaussian of the file's draws nearest the pose on those joints shrunk toward
the Gaussian of every draw (:func:`~sparseedm.gaussian_fill.local_gaussian_fill`);
the draws are the file's poses, the incomplete ones as one Gaussian refitted
on them filled them (:func:`~sparseedm.gaussian_fill.file_gaussian`, what an
iterative imputer approximates), and their mirror images
(:func:`~sparseedm.file_atoms.mirror_images`).
On the held-back poses (the Gaussians fitted without them, hidden as above,
and with the file's incomplete poses) it tries the weights
:data:`LINEAR_WEIGHTS` of the Gaussian's answer in the mean
``(1 - w) * path + w * Gaussian`` and keeps the lowest error (ties: the
smaller weight, :func:`linear_weight`), taken when its gain over the path's
answer alone exceeds its standard error (:data:`LINEAR_MIN_SE`); every
occluded pose then gets that mean (:func:`linear_stack`). Sparse codes over
nearby exemplars and a regression err differently. Over three draws of the
validation photo files the check chose w = 0.5-1 on MPII and COCO and w = 0
on the Bonn frames (whose neighbouring frames the exemplars find); against
the mean with one Gaussian of the file's poses alone (no neighbours, no
mirror images) the hidden joints' error under random masks fell by 0.44 ± 0.08 % of body size
on MPII val (0.83x IterativeImputer's, was 0.88x), 0.38 ± 0.05 with 1,000
train poses (0.85x, was 0.90x), 0.17 ± 0.12 on COCO + 233; under real
visibility masks by 0.63 ± 0.08 (0.77x, was 0.81x), 0.64 ± 0.06 and
0.26 ± 0.23. Bonn is unchanged, the Daz mocap files within
+0.01 ± 0.01 and the CMU subjects a dictionary learned on others did not
see 0.04-0.15 lower (``studies/fast/README.md``). Below :data:`FEW_MIN_POSES`
complete poses (no check) the weight is chosen on probes of the occluded rows
instead (:func:`probe_stack`, the donor step's probes): over three draws the
COCO val file (28 complete poses) fell from 0.92x to 0.80x IterativeImputer's
error under random masks, MPII and Bonn val files of 28-40 complete poses by
0.3-1.7 % of body size, the mocap files by 0.08-0.63.

``res.adaptation.summary()["path"]`` says which ran (``"file atoms"``,
:data:`~sparseedm.adaptation.AVERAGED_PATH`, ``"adapted"``, ``"base + file
atoms"``, :data:`~sparseedm.adaptation.MIRRORED_ATOMS_PATH`, ``"base"``),
``reason`` why, and ``settings`` the check's errors and the Gaussian's
weight (``linear_weight``, ``held_err_stacked``). ``recover(..., exemplars=False)``
(``--no-exemplars``) adapts whatever the check would say.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from ._recovery_base import combine, put_rows
from ._recovery_kernel import FAST_RIDGE, compiled_solver, recover_members
from .adaptation import (AVERAGED_PATH, GUARD_POSES_PER_PATTERN, MIN_COMPLETE_POSES,
                         MIRRORED_ATOMS_PATH, AdaptationResult, guard_masks,
                         pose_vectors, repeat_rows)
from .donors import DONOR_MIN_PROBES, DONOR_PROBES, donor_step, paired_gain, probes
from .edm import observed_entries, pose_to_vector
from .file_atoms import (atoms_adaptation, complete_rows, file_dictionary, mirror_images,
                         with_file_atoms)
from .gaussian_fill import file_gaussian, local_gaussian_fill
from .normalize import rms_radius
from .real_protocol import usable_patterns
from .skeleton import SKELETON_14
from .solvers.local_ridge import LocalRidgeSolver

__all__ = ["EXEMPLAR_MIN_POSES", "EXEMPLAR_MARGIN", "EXEMPLAR_OPTIONS", "ExemplarCheck",
           "hidden_joint_error", "choose_exemplars", "averaged_members", "held_masks",
           "HELD_FRACTION", "MAX_HELD", "FEW_MIN_POSES", "BLEND_MIN_HIDDEN", "BLEND_MIN_POSES",
           "blend_rows", "blend_atoms", "blend_parts", "blend_many_hidden", "ridge_mean_atoms", "blends",
           "AVERAGED_MANY_HIDDEN", "AVERAGED_RIDGE_MEAN", "AVERAGED_GAUSSIAN", "LINEAR_WEIGHTS", "LINEAR_MIN_SE",
           "MAX_LINEAR_FIT", "LINEAR_PROBE_ROUNDS", "LinearStack", "linear_weight", "linear_stack",
           "probe_stack", "finish_blend", "paired_gain", "stack_fill", "ProbeChoice",
           "probe_weight", "remembered"]

#: From this many usable complete poses the file's own poses are the atoms,
#: no check, no adaptation (chosen on validation files: studies/fast/README.md)
EXEMPLAR_MIN_POSES = 2000

#: Below EXEMPLAR_MIN_POSES: the exemplars (or the mean) are taken unless their
#: held-back hidden-joint error is above (1 + EXEMPLAR_MARGIN) times the
#: base-with-file-atoms'
EXEMPLAR_MARGIN = 0.05

#: The check's held-back share of the complete poses, and its cap
HELD_FRACTION, MAX_HELD = 0.2, 300

#: Below MIN_COMPLETE_POSES, from this many usable complete poses the check
#: may average the base-with-file-atoms' answers with those of the base with
#: the poses and their mirror images as atoms (fewer: too few held-back poses to judge)
FEW_MIN_POSES = 50

#: A pose with at least this many hidden joints has its answer averaged with
#: the local ridge's over the file's complete poses (:func:`blend_many_hidden`),
#: from BLEND_MIN_POSES usable complete poses
BLEND_MIN_HIDDEN = 4
BLEND_MIN_POSES = 50

#: RecoveryResult.averaged of a pose whose answer was averaged with the local
#: ridge's over the file's complete poses (:func:`blend_many_hidden`'s `atoms`)
AVERAGED_MANY_HIDDEN = "local ridge over file atoms"
#: ... and over the base with them as extra atoms (its `mean_atoms`)
AVERAGED_RIDGE_MEAN = "local ridge over base + file atoms"
#: ... and with one Gaussian's of the file's poses, at the check's weight
#: (:func:`linear_stack`)
AVERAGED_GAUSSIAN = "Gaussian of the file's poses"

#: The weights the check tries for the Gaussian's answer (:func:`linear_weight`)
#: in its mean with the path's, the path's answer weighted by one minus it
LINEAR_WEIGHTS = (0.0, 0.25, 0.5, 0.75, 1.0)

#: A weight is taken only when its held-back gain over the path's answer alone
#: exceeds this many of its standard errors (paired over the held-back poses; over
#: the probed rows for :func:`probe_stack`, a row's probes averaged first)
LINEAR_MIN_SE = 1.0

#: The Gaussian (:func:`~sparseedm.gaussian_fill.file_gaussian`) is refitted on
#: the file's complete poses and at most this many of its incomplete ones (a
#: seeded sample)
MAX_LINEAR_FIT = 2000

#: Below FEW_MIN_POSES complete poses (no check) the weight is chosen on probes
#: of the occluded rows (:func:`probe_stack`): rounds of the donor step's probes
#: (:func:`~sparseedm.donors.probes`, another joint each) until
#: :data:`~sparseedm.donors.DONOR_PROBES` of them, at most this many rounds
LINEAR_PROBE_ROUNDS = 4

#: recover()'s ``exemplars`` values: "auto" applies the rule, False never
#: takes the exemplars instead of adapting
EXEMPLAR_OPTIONS = ("auto", False)


@dataclass
class ExemplarCheck:
    """What :func:`choose_exemplars` found.

    Parameters
    ----------
    result : AdaptationResult or None
        What was done when the exemplars were chosen (its ``dictionary`` the
        file's complete poses as the only atoms); None: the default path adapts.
    n_complete : int
        The file's usable complete poses.
    err_atoms, err_base, err_both : float
        The held-back poses' hidden-joint error (% of pose size) of the
        exemplars, of the base with file atoms and of the mean of the
        :func:`averaged_members`' answers (NaN: not checked); below
        MIN_COMPLETE_POSES ``err_atoms`` is NaN and ``err_both`` the mean of
        the base with file atoms and with them and their mirror images.
    seconds : float
        Time spent choosing.
    partners : list of Dictionary
        The other :func:`averaged_members` when their answers are averaged
        with the exemplars' (the check preferred the mean); empty: the
        exemplars alone.
    err_path, err_ridge_mean : float
        The held-back error of the chosen path's answer (with the blend of
        poses with many hidden joints) and of its mean with the local ridge's
        over the base with file atoms (NaN: not checked, the file adapts).
    linear_weight, err_stacked : float
        The weight of the Gaussian's answer (:func:`linear_weight`) in its mean
        with the path's (after the ridge mean when taken), and that mean's
        held-back error (NaN: not checked).
    """

    result: AdaptationResult | None
    n_complete: int
    err_atoms: float = float("nan")
    err_base: float = float("nan")
    err_both: float = float("nan")
    seconds: float = 0.0
    partners: list = field(default_factory=list)
    err_path: float = float("nan")
    err_ridge_mean: float = float("nan")
    linear_weight: float = float("nan")
    err_stacked: float = float("nan")

    @property
    def dictionary(self):
        """The exemplars' dictionary when they were chosen; None: the default path
        adapts."""
        return None if self.result is None else self.result.dictionary

    @property
    def members(self):
        """The dictionaries recover() averages: the exemplars', then the partners;
        empty when the default path adapts."""
        return [] if self.result is None else [self.result.dictionary, *self.partners]

    def errors(self):
        """The check's errors as recorded in an AdaptationResult's ``settings``."""
        return {"held_err_atoms": self.err_atoms, "held_err_base": self.err_base,
                "held_err_both": self.err_both, "held_err_path": self.err_path,
                "held_err_ridge_mean": self.err_ridge_mean, "linear_weight": self.linear_weight,
                "held_err_stacked": self.err_stacked}

    def note(self, result):
        """`result` (the adaptation that ran instead) with the check's errors in its
        ``settings`` and time in its ``seconds``; `result` itself when nothing was checked."""
        if not np.isfinite(self.err_base):
            return result
        return replace(result, settings=dict(result.settings, **self.errors()),
                       seconds=result.seconds + self.seconds,
                       step_seconds=dict(result.step_seconds, exemplar_check=self.seconds))


def hidden_joint_error(dictionary, poses, mask, *, alpha=None, n_jobs=1, backend=None,
                       scheduler=None):
    """Mean error of the hidden joints when `dictionary` recovers `poses` under `mask`.

    Parameters
    ----------
    dictionary : Dictionary
        The dictionary (recovered with as given: no adaptation).
    poses : ndarray (n, N, 2)
        Complete poses, the truth.
    mask : ndarray of bool (n, N)
        The joints to hide (at least one per pose).
    alpha : float, optional
        Recovery alpha; default the dictionary's ``alpha_recover``.
    n_jobs : int or None, default 1
        Workers of the recovery.
    backend, scheduler : optional
        As :func:`sparseedm.recover`'s (``"dask"``: on the cluster).

    Returns
    -------
    float
        Mean over the poses recovered of their hidden joints' mean distance to
        the truth, in % of the pose's size (the RMS distance of its joints to
        their centroid); NaN when none was recovered.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> from sparseedm.adaptation import guard_masks
    >>> poses = np.random.default_rng(0).normal(size=(6, 14, 2))
    >>> e = hidden_joint_error(load_dictionary(), poses, guard_masks(6, 14))
    >>> bool(e > 0)
    True
    """
    return _error(_held_recovery(dictionary, poses, mask, alpha=alpha, n_jobs=n_jobs,
                                 backend=backend, scheduler=scheduler), poses, mask)


def _held_recovery(dictionary, poses, mask, **kw):
    """`dictionary`'s recovery of `poses` with the `mask` joints hidden (the file's
    usable complete poses, validated with it: not again)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return recover_members(np.where(mask[..., None], np.nan, poses), mask, [dictionary],
                               [], solver=compiled_solver(), check_input=False, **kw)


def _error(res, poses, mask):
    """hidden_joint_error's score of the recovery `res` of `poses` under `mask`."""
    per_pose = _pose_errors(res, poses, mask)
    per_pose = per_pose[np.isfinite(per_pose)]
    return float(per_pose.mean()) if len(per_pose) else float("nan")


def _pose_errors(res, poses, mask):
    """Per pose of `poses`: its hidden joints' mean error in `res`, % of its size
    (NaN where not recovered)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, size = rms_radius(poses, np.zeros(mask.shape, bool))
        # scaled before the norm, whose squares overflow from about 1e154 pixels
        err = np.linalg.norm((res.poses - poses) / size[:, None, None], axis=-1) * 100
        per_pose = np.nanmean(np.where(mask, err, np.nan), axis=1)
    return np.where(res.ok, per_pose, np.nan)


def averaged_members(dictionary, complete):
    """The dictionaries whose answers the default path averages, made of the file's
    complete poses `complete`: the exemplars, the exemplars with their mirror images
    (:func:`~sparseedm.file_atoms.mirror_images`; 14-joint dictionaries only), and
    `dictionary` with the exemplars as extra atoms.

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary.
    complete : ndarray (n, N, 2)
        Usable complete poses.

    Returns
    -------
    list of Dictionary
        The exemplars' first (nothing learned in any).

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> base = load_dictionary()
    >>> poses = np.random.default_rng(0).normal(size=(30, 14, 2))
    >>> [d.n_components for d in averaged_members(base, poses)] == [30, 60, base.n_components + 30]
    True
    """
    return [file_dictionary(dictionary, complete).dictionary, *_partners(dictionary, complete)]


def _partners(dictionary, complete):
    """:func:`averaged_members` after the exemplars' own dictionary."""
    mirrored = ([file_dictionary(dictionary, mirror_images(complete)).dictionary]
                if dictionary.n_joints == SKELETON_14.num_joints else [])
    return [*mirrored, with_file_atoms(dictionary, complete).dictionary]


def held_masks(poses, missing, n_held, random_state=0):
    """The check's masks: the missing patterns of the file's own incomplete poses.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        The file's poses, NaN at missing joints.
    missing : ndarray of bool (n, N) or None
        Missing joints besides the NaN ones.
    n_held : int
        Held-back poses to mask.
    random_state : int, default 0

    Returns
    -------
    ndarray of bool (n_held, N)
        Each a seeded draw among the file's patterns that hide a joint and
        keep 3 (:func:`sparseedm.real_protocol.transplant_masks`); without
        one, the guard's Mix masks of 1-3 joints.

    Examples
    --------
    >>> import numpy as np
    >>> poses = np.ones((4, 14, 2)); poses[3, [2, 5]] = np.nan
    >>> held_masks(poses, None, 2).sum(axis=1).tolist()  # the file's one pattern
    [2, 2]
    """
    hidden = np.isnan(poses).any(axis=-1)
    if missing is not None:
        hidden |= np.asarray(missing, dtype=bool)
    usable = usable_patterns(hidden)
    if usable.size:  # transplant_masks' draw, on a mask validated with the file
        rng = np.random.default_rng([int(random_state), 44])
        return hidden[usable[rng.integers(0, usable.size, int(n_held))]]
    return guard_masks(n_held, poses.shape[1], max(1, n_held // GUARD_POSES_PER_PATTERN),
                       random_state)


def _scores(dictionary, complete, held, mask, kw):
    """Hidden-joint errors on ``complete[held]`` under `mask` of the exemplars made of
    the other complete poses, of the base with those as extra atoms, and of the mean
    of the answers of :func:`averaged_members` (each dictionary recovers once), the
    answers of the exemplars and of the mean, and those members."""
    truth, rest = complete[held], complete[~held]
    members = averaged_members(dictionary, rest)
    results = [_held_recovery(d, truth, mask, **kw) for d in members]
    answers = (results[0], results[-1], combine(results))
    return tuple(_error(r, truth, mask) for r in answers), answers[::2], members


def _ridge_mean_errors(dictionary, complete, held, mask, res, kw, exemplars, base_atoms,
                       file_poses):
    """Held-back errors of the path's answer `res` on ``complete[held]`` (after
    the blend of poses with many hidden joints) and of its mean with the local
    ridge's over `dictionary` with the other complete poses as extra atoms
    (`base_atoms`, built by the caller's check; `exemplars`: those poses as the only
    atoms, None: made here when the blend needs them); then the Gaussian's
    weight and the stacked error (:func:`linear_weight`; `file_poses` the file's
    poses and missing joints)."""
    truth, rest = complete[held], complete[~held]
    hidden = np.where(mask[..., None], np.nan, truth)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if len(rest) >= BLEND_MIN_POSES:
            if exemplars is None:
                exemplars = file_dictionary(dictionary, rest).dictionary
            res = blend_many_hidden(res, hidden, mask, _enough_atoms(exemplars), **kw)
        ridge = _local_ridge(base_atoms, hidden, mask, kw)
    both = combine([res, ridge])
    errors = _error(res, truth, mask), _error(both, truth, mask)
    answer = both if errors[1] < errors[0] else res
    return (*errors, *linear_weight(answer, truth, mask, rest, *file_poses))


def choose_exemplars(dictionary, poses, missing, *, n_jobs=1, random_state=0,
                     min_poses=EXEMPLAR_MIN_POSES, margin=EXEMPLAR_MARGIN, backend=None,
                     scheduler=None):
    """The exemplars when the size rule or the check on held-back poses picks them.

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary (its settings for the exemplars).
    poses, missing : ndarray
        The file's poses and their missing joints (None: the NaN ones).
    n_jobs : int or None, default 1
        Workers of the check's recoveries.
    random_state : int, default 0
        Seed of the held-back blocks and their masks.
    min_poses : int, default EXEMPLAR_MIN_POSES
        Complete poses from which the exemplars are taken unchecked.
    margin : float, default EXEMPLAR_MARGIN
        Below `min_poses`: the exemplars, or the mean of the answers of
        :func:`averaged_members` when its held-back error is lower, are taken
        unless that error is above ``1 + margin`` times the
        base-with-file-atoms'.
    backend, scheduler : optional
        As :func:`sparseedm.recover`'s: where the check's recoveries run.

    Returns
    -------
    ExemplarCheck
        ``dictionary`` and ``result`` set when the exemplars were chosen
        (``partners`` too when their answers are averaged with others).

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> few = np.random.default_rng(0).normal(size=(40, 14, 2))
    >>> choose_exemplars(load_dictionary(), few, None).dictionary is None  # too few
    True
    """
    t0 = time.perf_counter()
    poses = np.asarray(poses, dtype=float)
    complete = poses[complete_rows(poses, missing)]
    n = len(complete)
    # repeats count once (adaptation drops them: REPEAT_TOLERANCE); the rule
    # below counts the atoms file_dictionary makes (near-copies within
    # ATOM_SPACING merged: a still person's noisy frames are one atom)
    distinct = n - int(repeat_rows(pose_vectors(complete)).sum()) if n else 0
    count = f"{n} complete poses" + (f" ({distinct} distinct)" if distinct < n else "")
    kw = dict(n_jobs=n_jobs, backend=backend, scheduler=scheduler)
    if distinct < MIN_COMPLETE_POSES:
        if distinct < FEW_MIN_POSES or dictionary.n_joints != SKELETON_14.num_joints:
            return ExemplarCheck(None, n, seconds=time.perf_counter() - t0)
        return _few_poses(dictionary, poses, missing, complete, count, t0, random_state, kw)
    found = file_dictionary(dictionary, complete) if distinct >= min_poses else None
    if found is not None and found.n_atoms < min_poses:
        count, found = f"{count}, {found.n_atoms} atoms once near-copies are merged", None
    if found is not None:
        reason = (f"{count}, at least {min_poses}: they are the dictionary's "
                  "atoms, nothing learned")
        return ExemplarCheck(atoms_adaptation(found, len(poses), reason, t0,
                                              {"path": "file atoms"}), n,
                             seconds=time.perf_counter() - t0)
    held, mask = _held_back(poses, missing, n, random_state)
    want = int(held.sum())
    errors, answers, members = _scores(dictionary, complete, held, mask, kw)
    out = ExemplarCheck(None, n, *errors)
    own = min(out.err_atoms, out.err_both)
    if own <= (1 + margin) * out.err_base:
        both = out.err_both < out.err_atoms
        (out.err_path, out.err_ridge_mean, out.linear_weight,
         out.err_stacked) = _ridge_mean_errors(dictionary, complete, held, mask,
                                               answers[int(both)], kw, members[0],
                                               members[-1], (poses, missing))
        what = ("as atoms, alone and with their mirror images, averaged with the base "
                "dictionary with them as extra atoms, they " if both else
                "as the only atoms they ")
        reason = (f"{count}: {what}recovered {want} held-back poses' hidden "
                  f"joints as well as the base dictionary with them or better "
                  f"({own:.2f} vs {out.err_base:.2f} % of the poses' RMS radius), nothing learned")
        out.result = atoms_adaptation(
            file_dictionary(dictionary, complete), len(poses), reason, t0,
            {"path": AVERAGED_PATH if both else "file atoms", **out.errors()})
        if both:  # the exemplars' dictionary is the result's, made once
            out.partners = _partners(dictionary, complete)
    out.seconds = time.perf_counter() - t0
    return out


def _held_back(poses, missing, n, random_state):
    """The check's held-back rows among the `n` complete poses and their masks."""
    held = np.zeros(n, bool)
    want = min(int(round(HELD_FRACTION * n)), MAX_HELD)
    held[np.random.default_rng([int(random_state), 43]).choice(n, want, replace=False)] = True
    return held, held_masks(poses, missing, want, random_state)


def _mirrored_atoms(dictionary, complete):
    """The two dictionaries whose answers the default path may average below
    MIN_COMPLETE_POSES: `dictionary` with the complete poses `complete` as extra
    atoms, and with them and their mirror images
    (:func:`~sparseedm.file_atoms.mirror_images`) as extra atoms."""
    return [with_file_atoms(dictionary, complete), with_file_atoms(dictionary,
                                                                   mirror_images(complete))]


def _few_poses(dictionary, poses, missing, complete, count, t0, random_state, kw):
    """choose_exemplars below MIN_COMPLETE_POSES: base + file atoms (result None:
    the default path as it was) or the mean with base + them and their mirror images."""
    held, mask = _held_back(poses, missing, len(complete), random_state)
    truth = complete[held]
    members = [f.dictionary for f in _mirrored_atoms(dictionary, complete[~held])]
    results = [_held_recovery(d, truth, mask, **kw) for d in members]
    out = ExemplarCheck(None, len(complete), err_base=_error(results[0], truth, mask),
                        err_both=_error(combine(results), truth, mask))
    (out.err_path, out.err_ridge_mean, out.linear_weight,
     out.err_stacked) = _ridge_mean_errors(
        dictionary, complete, held, mask,
        combine(results) if out.err_both < out.err_base else results[0], kw, None, members[0],
        (poses, missing))
    if out.err_both < out.err_base:
        found, mirror = _mirrored_atoms(dictionary, complete)
        reason = (f"{count}: too few to adapt on; the base dictionary with them as extra "
                  "atoms, averaged with the base with them and their mirror images as "
                  f"extra atoms, recovered {int(held.sum())} held-back poses' hidden joints "
                  f"better than without the mirror images ({out.err_both:.2f} vs "
                  f"{out.err_base:.2f} % of the poses' RMS radius), nothing learned")
        out.result = atoms_adaptation(found, len(poses), reason, t0,
                                      {"path": MIRRORED_ATOMS_PATH, **out.errors()})
        out.partners = [mirror.dictionary]
    out.seconds = time.perf_counter() - t0
    return out


def blend_rows(missing):
    """The poses with at least :data:`BLEND_MIN_HIDDEN` hidden joints.

    Parameters
    ----------
    missing : ndarray of bool (n, N)

    Returns
    -------
    ndarray of int
        Their rows.

    Examples
    --------
    >>> import numpy as np
    >>> missing = np.zeros((3, 14), bool); missing[1, [9, 10, 12, 13]] = True
    >>> missing[2, [9, 10, 12]] = True
    >>> blend_rows(missing).tolist()
    [1]
    """
    return np.flatnonzero(np.asarray(missing, bool).sum(axis=1) >= BLEND_MIN_HIDDEN)


def blends(adapt, exemplars, preset, mirror, solver, positive=False):
    """Whether recover()'s and recover_file()'s default path blends (:func:`blend_atoms`,
    :func:`ridge_mean_atoms`): `adapt` and `exemplars` "auto", the default preset,
    no `mirror`, the default solver asked for by name, signed codes.

    Examples
    --------
    >>> blends("auto", "auto", "default", False, "fast")
    True
    >>> blends("auto", "auto", "fast", False, "fast")       # preset="fast"
    False
    """
    return (isinstance(adapt, str) and adapt == "auto" and isinstance(exemplars, str)
            and exemplars == "auto" and preset == "default" and not mirror and not positive
            and isinstance(solver, str) and solver == "fast")


def blend_atoms(dictionary, poses, missing, adaptation):
    """The atoms :func:`blend_many_hidden` codes over: the file's complete poses as
    the only atoms, when the default path learned nothing and coded over them.

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary.
    poses : ndarray (n, N, 2)
        The file's poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    adaptation : AdaptationResult or None
        What the default path did: the blend follows the paths that learn
        nothing and code over the file's poses (``adapted`` False,
        ``file_atoms`` > 0); an adapted dictionary's answers stay as they are.

    Returns
    -------
    Dictionary or None
        None: no blend (adapted, fewer than :data:`BLEND_MIN_POSES` usable
        complete poses or atoms made of them, not 14 joints, non-negative codes).
    """
    complete = _blend_complete(dictionary, poses, missing, adaptation)
    if complete is None:
        return None
    # the path's own dictionary when it is made of them: the same atoms
    return _enough_atoms(adaptation.dictionary if adaptation.over_file_atoms
                         else file_dictionary(dictionary, poses[complete]).dictionary)


def _enough_atoms(atoms):
    """`atoms` (the file's complete poses as the only atoms) when they are at least
    :data:`BLEND_MIN_POSES`, else None: copies of a few poses merge into as few
    atoms (:func:`~sparseedm.file_atoms.file_dictionary`), too few to average over."""
    return atoms if atoms.n_components >= BLEND_MIN_POSES else None


def _blend_complete(dictionary, poses, missing, adaptation):
    """The file's usable complete rows (mask) when the blends follow the default
    path's `adaptation` (:func:`blend_atoms`), else None."""
    if (adaptation is None or adaptation.adapted or adaptation.file_atoms == 0
            or dictionary.n_joints != SKELETON_14.num_joints or dictionary.positive_code):
        return None
    complete = complete_rows(poses, missing)
    return complete if complete.sum() >= BLEND_MIN_POSES else None


def blend_parts(dictionary, poses, missing, adaptation):
    """What :func:`blend_many_hidden` averages with, after the default path's
    `adaptation` of `poses`: ``(atoms, mean_atoms, linear)``
    (:func:`blend_atoms`, :func:`ridge_mean_atoms`, :func:`linear_stack`; each
    None where it does not apply), its arguments after ``res, poses, missing``.
    """
    return (blend_atoms(dictionary, poses, missing, adaptation),
            ridge_mean_atoms(dictionary, poses, missing, adaptation),
            linear_stack(dictionary, poses, missing, adaptation))


def blend_many_hidden(res, poses, missing, atoms, mean_atoms=None, linear=None, **kernel):
    """`res` with each pose of at least :data:`BLEND_MIN_HIDDEN` hidden joints
    averaged with the local ridge's answer over `atoms` (:func:`blend_atoms`: the
    file's complete poses as the only atoms).

    Such a pose's hidden joints are poorly determined by what is seen: the
    lasso commits to one code of a few atoms where an average over the many
    nearby exemplars errs less. The local ridge
    (:class:`~sparseedm.solvers.local_ridge.LocalRidgeSolver` with
    :data:`~sparseedm._recovery_kernel.FAST_RIDGE`, ``preset="fast"``'s coder)
    spreads the code over each pose's 48 nearest exemplars; its answer and the
    default path's are averaged as an ensemble's members are
    (:func:`~sparseedm._recovery_base.combine`). On validation photos under real
    visibility masks (MPII, COCO, Bonn; 200-1,000 complete poses) it lowered the
    hidden joints' error on every file, by 0.2-2.2 % of body size; Mix masks
    (1-3 joints) never hide four, so files under them, and the CMU and Daz
    mocap files, are unchanged (``studies/fast/README.md``).

    Parameters
    ----------
    res : RecoveryResult
        The default path's recovery of `poses`.
    poses : ndarray (n, N, 2)
        The poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    atoms : Dictionary or None
        The local ridge's atoms; None: `res` as it is.
    mean_atoms : Dictionary, optional
        :func:`ridge_mean_atoms`: then every occluded pose's answer (after the
        blend) is averaged with the local ridge's over these atoms.
    linear : LinearStack, optional
        :func:`linear_stack`: then every occluded pose's answer (after those
        means) is averaged with the Gaussian's
        (:func:`~sparseedm.gaussian_fill.gaussian_fill`), with its weight.
    **kernel
        Recovery settings of :func:`~sparseedm._recovery_kernel.recover_members`
        (``n_jobs``, ``representation``, ``backend``...).

    Returns
    -------
    RecoveryResult
        `res` itself when nothing is blended; else a copy with those poses' rows
        averaged, ``seconds`` including the local ridge's, and the record of
        what was averaged: ``averaged`` (per pose, :data:`AVERAGED_MANY_HIDDEN`,
        :data:`AVERAGED_RIDGE_MEAN` and/or :data:`AVERAGED_GAUSSIAN`) and
        ``spread`` (per filled joint, the distance between the two answers
        averaged).
    """
    out = res
    for rows, dictionary, kind in (
            (blend_rows(missing), atoms, AVERAGED_MANY_HIDDEN),
            (np.flatnonzero(np.asarray(missing, bool).any(axis=1)), mean_atoms,
             AVERAGED_RIDGE_MEAN)):
        if dictionary is None or not len(rows):
            continue
        ridge = _local_ridge(dictionary, poses[rows], missing[rows], kernel)
        seconds = out.seconds + ridge.seconds
        before = out
        out = put_rows(out, rows, combine([out.take(rows), ridge]))
        out = _averaged_record(out, before, rows, ridge, kind)
        out.seconds = seconds
    return out if linear is None else _stacked(out, poses, missing, linear)


def _stacked(res, poses, missing, linear):
    """`res` with every occluded pose's answer averaged with the Gaussian's of
    `linear` (a :class:`LinearStack`), weighted by its ``weight``."""
    t0 = time.perf_counter()
    rows = np.flatnonzero(np.asarray(missing, bool).any(axis=1))
    if not len(rows):
        return res
    fill = local_gaussian_fill(linear.train, poses[rows], missing[rows])
    out = stack_fill(res, rows, fill, linear.weight, AVERAGED_GAUSSIAN)
    out.seconds = res.seconds + time.perf_counter() - t0
    return out


def stack_fill(res, rows, fill, weight, kind):
    """`res` with the answers of `rows` averaged with the joints `fill` (one per
    row; NaN rows keep the answer) placed by a linear estimate, `fill` weighted by
    `weight` (a number or one per row), and ``averaged`` saying `kind` there.

    The estimate places joints, it recovers no distances: its hidden distances
    are the answer's moved as its joints move, so the disagreement between the
    recovered distances and the placed joints (an uncertainty feature) stays
    the answer's (as :func:`~sparseedm.donors.donor_step` moves them).
    """
    part = res.take(rows)
    fill = np.where(np.isfinite(fill), fill, part.poses)
    weight = np.broadcast_to(np.asarray(weight, float), (len(rows),))
    weights = np.stack([1 - weight, weight])
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = (pose_to_vector(fill) - pose_to_vector(part.poses)) / part.scale[:, None]
    hidden = ~observed_entries(part.missing)
    linear = replace(part, poses=fill, vectors=np.where(
        hidden & np.isfinite(shift), part.vectors + shift, part.vectors))
    out = put_rows(res, rows, combine([part, linear], weights))
    return _averaged_record(out, res, rows, linear, kind)


def _averaged_record(out, before, rows, ridge, kind):
    """`out` (`before` with `rows` averaged with `ridge`) with ``averaged`` saying
    `kind` on those rows (usable in both) and ``spread`` the two answers' distance
    per filled joint."""
    n, N = out.missing.shape
    averaged = np.full(n, "", object) if before.averaged is None else \
        before.averaged.astype(object)
    spread = np.zeros((n, N)) if before.spread is None else before.spread.copy()
    both = out.ok[rows] & before.ok[rows]
    with np.errstate(invalid="ignore", over="ignore"):  # a joint at 1e300: no spread
        gap = np.linalg.norm(before.poses[rows] - ridge.poses, axis=-1)
    gap = np.where(out.missing[rows] & both[:, None] & np.isfinite(gap), gap, 0.0)
    spread[rows] = np.maximum(spread[rows], gap)
    text = averaged[rows]  # a refused pose's answer is no mean
    averaged[rows] = np.where(~both, text, np.where(text == "", kind, text + "; " + kind))
    return replace(out, averaged=averaged.astype(str), spread=spread)


def _local_ridge(dictionary, poses, missing, kernel):
    """The local ridge's (``preset="fast"``'s coder) recovery of `poses` over
    `dictionary` (validated inputs)."""
    return recover_members(poses, missing, [dictionary], [], check_input=False,
                           solver=LocalRidgeSolver(**FAST_RIDGE), **kernel)


def ridge_mean_atoms(dictionary, poses, missing, adaptation):
    """The atoms of the local ridge whose answers :func:`blend_many_hidden` averages
    with every occluded pose's: the base with the file's complete poses as extra
    atoms, when the check's held-back poses said the mean recovers better.

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary.
    poses : ndarray (n, N, 2)
        The file's poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    adaptation : AdaptationResult or None
        What the default path did; its ``settings`` hold the check's
        ``held_err_path`` and ``held_err_ridge_mean``.

    Returns
    -------
    Dictionary or None
        None: the path's answers stay (no check, the mean's held-back error not
        lower, or a path :func:`blend_atoms` does not blend).
    """
    complete = _blend_complete(dictionary, poses, missing, adaptation)
    if complete is None:
        return None
    settings = adaptation.settings
    if not (settings.get("held_err_ridge_mean", np.nan)
            < settings.get("held_err_path", np.nan)):
        return None
    return with_file_atoms(dictionary, poses[complete]).dictionary


def _incomplete_sample(poses, missing, random_state=0):
    """The file's poses with some joints missing and some observed, at most
    :data:`MAX_LINEAR_FIT` of them (a seeded sample): (poses, missing)."""
    missing = np.isnan(poses).any(axis=-1) if missing is None else np.asarray(missing, bool)
    rows = np.flatnonzero(missing.any(axis=1) & ~missing.all(axis=1))
    if len(rows) > MAX_LINEAR_FIT:
        rows = np.sort(np.random.default_rng([int(random_state), 47]).choice(
            rows, MAX_LINEAR_FIT, replace=False))
    return poses[rows], missing[rows]


def linear_weight(answer, truth, mask, complete, poses, missing):
    """The check's weight of the Gaussian's answer in its mean with the path's.

    On the held-back poses `truth` (hidden under `mask`), the local Gaussians
    (:func:`~sparseedm.gaussian_fill.local_gaussian_fill`) over the other
    complete poses `complete`, the held-back poses and the file's incomplete
    ones as :func:`~sparseedm.gaussian_fill.file_gaussian` filled them, and
    their mirror images (as :func:`linear_stack`'s) fill the hidden joints;
    each weight of
    :data:`LINEAR_WEIGHTS` gives the mean ``(1 - w) * path + w * Gaussian``,
    scored as the check scores (:func:`hidden_joint_error`). The lowest error
    wins (ties: the smaller weight) when its gain over the path's answer alone
    exceeds :data:`LINEAR_MIN_SE` of its standard errors (paired over the
    held-back poses); else 0.

    Parameters
    ----------
    answer : RecoveryResult
        The path's answer on the held-back poses.
    truth : ndarray (h, N, 2)
    mask : ndarray of bool (h, N)
    complete : ndarray (n, N, 2)
        The complete poses not held back.
    poses : ndarray (m, N, 2)
        The file's poses (NaN at missing joints).
    missing : ndarray of bool (m, N) or None
        Their missing joints (None: the NaN ones).

    Returns
    -------
    weight : float
    error : float
        The held-back error of that mean (% of pose size; NaN: fewer than two
        poses scored).
    """
    part, part_missing = _incomplete_sample(poses, missing)
    hidden = np.where(mask[..., None], np.nan, truth)
    fill = local_gaussian_fill(_linear_draws(complete, part, part_missing, hidden, mask),
                               hidden, mask)
    fill = np.where(np.isfinite(fill), fill, answer.poses)
    per_pose = np.array([_pose_errors(replace(answer, poses=(1 - w) * answer.poses + w * fill),
                                      truth, mask) for w in LINEAR_WEIGHTS])
    return _best_weight(per_pose, 2)


def _best_weight(per_pose, fewest, clusters=None):
    """(weight, error): the weight of LINEAR_WEIGHTS whose scored poses' (columns of
    `per_pose`, one row per weight) mean error is lowest, when its gain over weight
    0 exceeds LINEAR_MIN_SE standard errors (:func:`paired_gain`, by `clusters`: the
    pose each column probes); 0 then, and with fewer than `fewest`."""
    ok = np.isfinite(per_pose).all(axis=0)
    per_pose = per_pose[:, ok]
    if per_pose.shape[1] < max(fewest, 2):
        return 0.0, float("nan")
    errors = per_pose.mean(axis=1)
    best = int(np.argmin(errors))
    mean, se = paired_gain(per_pose[0] - per_pose[best],
                           None if clusters is None else np.asarray(clusters)[ok])
    if not mean > LINEAR_MIN_SE * se:
        best = 0
    return float(LINEAR_WEIGHTS[best]), float(errors[best])


def _linear_draws(complete, *given):
    """The draws of the Gaussians :func:`linear_stack` fills with: `complete` and the
    poses of `given` (pairs of poses, missing joints) as
    :func:`~sparseedm.gaussian_fill.file_gaussian` filled them over the poses
    and their mirror images, all with their mirror images
    (:func:`~sparseedm.file_atoms.mirror_images`)."""
    poses = np.concatenate(given[::2])
    missing = np.concatenate(given[1::2])
    _, train = file_gaussian(complete, poses, missing, augment=mirror_images)
    return mirror_images(train)


@dataclass
class LinearStack:
    """The Gaussian's part in the default path's answer (:func:`linear_stack`).

    Parameters
    ----------
    weight : float
        Its weight in the mean with the path's answer (in (0, 1]).
    train : ndarray (n, N, 2)
        The draws of the Gaussians (:func:`~sparseedm.gaussian_fill.local_gaussian_fill`):
        the file's poses as :func:`~sparseedm.gaussian_fill.file_gaussian` filled
        them, and their mirror images.
    """

    weight: float
    train: np.ndarray


def linear_stack(dictionary, poses, missing, adaptation):
    """The Gaussian :func:`blend_many_hidden` averages every occluded pose's answer
    with, when the check's held-back poses gave it weight (:func:`linear_weight`).

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary.
    poses : ndarray (n, N, 2)
        The file's poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    adaptation : AdaptationResult or None
        What the default path did; its ``settings`` hold the check's
        ``linear_weight``.

    Returns
    -------
    LinearStack or None
        None: the path's answers stay (no check, weight 0, or a path
        :func:`blend_atoms` does not blend).

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> poses = np.random.default_rng(0).normal(size=(4, 14, 2))
    >>> linear_stack(load_dictionary(), poses, np.zeros((4, 14), bool), None) is None
    True
    """
    complete = _blend_complete(dictionary, poses, missing, adaptation)
    weight = np.nan if complete is None else adaptation.settings.get("linear_weight", np.nan)
    if not weight > 0:
        return None
    part, part_missing = _incomplete_sample(poses, missing)
    return LinearStack(float(weight), _linear_draws(poses[complete], part, part_missing))


def probe_stack(res, poses, missing, answer, blend, random_state=0):
    """Below :data:`FEW_MIN_POSES` complete poses (no check, so no weight): `res`
    averaged with the Gaussian's answer (:func:`linear_stack`'s) at the weight
    chosen on probes of the file's occluded rows.

    The probes are rounds of :func:`~sparseedm.donors.probes` (one more observed
    joint hidden, :data:`LINEAR_PROBE_ROUNDS` at most), answered by `answer` and
    by the local Gaussians over the complete poses and the incomplete ones so
    hidden; the weight of :data:`LINEAR_WEIGHTS` is chosen on the probed joints'
    errors as :func:`linear_weight` chooses it, from
    :data:`~sparseedm.donors.DONOR_MIN_PROBES` probes.

    Parameters
    ----------
    res : RecoveryResult
        The default path's recovery of `poses` (with its ``adaptation``).
    poses : ndarray (n, N, 2)
        The poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    answer : callable
        ``answer(poses, missing)`` -> RecoveryResult: the default path's answer
        for other rows of the same file (the probes).
    blend : tuple or None
        :func:`blend_parts`' ``(atoms, mean_atoms, linear)``.
    random_state : int, default 0
        Seed of the probes.

    Returns
    -------
    res : RecoveryResult
        `res` itself where this does not apply (a weight from the check, an
        adapted dictionary, :data:`FEW_MIN_POSES` file atoms or more, fewer than
        two complete poses in `poses`); else
        with ``settings["linear_weight"]`` and ``["linear_probes"]`` noted and,
        for a weight above 0, the occluded poses' answers so averaged.
    blend : tuple or None
        `blend` with that :class:`LinearStack` as its ``linear``.
    """
    adaptation = res.adaptation
    if (blend is None or blend[2] is not None or adaptation is None or adaptation.adapted
            or not 0 < adaptation.file_atoms < FEW_MIN_POSES
            or "linear_weight" in adaptation.settings
            or missing.shape[1] != SKELETON_14.num_joints):
        return res, blend
    complete = complete_rows(poses, missing)  # (recover_file: the chunk's)
    if complete.sum() < 2:
        return res, blend
    weight, count, *_ = probe_weight(poses, missing, answer,
                                     _gaussian_probe_fill(poses, missing, complete), random_state)
    res = replace(res, adaptation=replace(adaptation, settings=dict(
        adaptation.settings, linear_weight=weight, linear_probes=count)))
    if not weight > 0:
        return res, blend
    part, part_missing = _incomplete_sample(poses, missing)
    linear = LinearStack(weight, _linear_draws(poses[complete], part, part_missing))
    return _stacked(res, poses, missing, linear), (*blend[:2], linear)


def finish_blend(res, poses, missing, answer_for, blend, bank=None):
    """The default path's last steps on a file whose answers are blended
    (recover() and recover_file()'s chunks alike): :func:`probe_stack`, then
    `bank` (the shipped pose bank's candidate), then
    :func:`~sparseedm.donors.donor_step`, each answering its probes with
    ``answer_for(blend)`` for the blend as it then is (so the later steps'
    probes see the Gaussian the first step stacked, and the bank as `bank`
    stacked it). The steps' probes begin with the same rows: their answers
    are computed once (:func:`remembered`).

    Parameters
    ----------
    res : RecoveryResult
        The default path's recovery of `poses`, blended (:func:`blend_many_hidden`).
    poses : ndarray (n, N, 2)
        The poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    answer_for : callable
        ``answer_for(blend)`` -> ``answer(poses, missing)`` -> RecoveryResult:
        the path's answer for other rows of the file with that blend.
    blend : tuple
        :func:`blend_parts`' ``(atoms, mean_atoms, linear)``.
    bank : callable, optional
        ``bank(res, poses, missing, answer)`` -> ``(res, answer)``:
        :func:`sparseedm.cold_bank.bank_step` (passed by the dispatchers, which
        sit above both modules); None: no such step.

    Returns
    -------
    RecoveryResult
    """
    first = remembered(answer_for(blend))
    res, stacked = probe_stack(res, poses, missing, first, blend)
    # the later probes are probe_stack's: its answers reused, with the Gaussian it stacked
    answer = first if stacked is blend else \
        (lambda p, m: _stacked(first(p, m), p, m, stacked[2]))
    if bank is not None:
        res, answer = bank(res, poses, missing, answer)
    return donor_step(res, poses, missing, answer)


def remembered(compute, head=None):
    """`compute(poses, missing)` remembering its last question: asked it again,
    or its first k rows, it answers from the last answer without computing.

    The default path's probes repeat: :func:`probe_stack`'s,
    :func:`sparseedm.cold_bank.bank_step`'s and
    :func:`~sparseedm.donors.donor_step`'s begin with the same rows, each
    answered row by row.

    Parameters
    ----------
    compute : callable
        ``compute(poses, missing)``, row by row.
    head : callable, optional
        ``head(answer, k)``: the answer's first k rows; default
        ``answer.take(range(k))`` (a RecoveryResult).

    Returns
    -------
    callable

    Examples
    --------
    >>> import numpy as np
    >>> calls = []
    >>> double = remembered(lambda p, m: calls.append(len(p)) or 2 * p, lambda a, k: a[:k])
    >>> p, m = np.ones((3, 14, 2)), np.zeros((3, 14), bool)
    >>> double(p, m)[:2].sum(), double(p[:2], m[:2]).sum(), calls
    (np.float64(112.0), np.float64(112.0), [3])
    """
    if head is None:
        def head(answer, k):
            return answer.take(np.arange(k))
    last = []

    def again(poses, missing):
        k = len(poses)
        if last and k <= len(last[0]) and np.array_equal(
                last[0][:k], poses, equal_nan=True) and np.array_equal(last[1][:k], missing):
            return last[2] if k == len(last[0]) else head(last[2], k)
        out = compute(poses, missing)
        last[:] = [np.array(poses), np.array(missing), out]
        return out
    return again


class ProbeChoice(NamedTuple):
    """What :func:`probe_weight` chose: the weight, the probes it judged on, and
    their mean error (% of pose size) at weight 0 and at the weight chosen (NaN:
    too few probes)."""

    weight: float
    probes: int
    err_default: float
    err_chosen: float


def probe_weight(poses, missing, answer, fill, random_state=0):
    """The weight of a candidate's answer in its mean with the path's, chosen on
    probes of the file's occluded rows.

    The probes are rounds of :func:`~sparseedm.donors.probes` (one more observed
    joint hidden, :data:`LINEAR_PROBE_ROUNDS` at most, until
    :data:`~sparseedm.donors.DONOR_PROBES`), answered by `answer` and by `fill`;
    of :data:`LINEAR_WEIGHTS` the mean ``(1 - w) * path + w * candidate`` with
    the lowest probe error wins when its gain over the path's answer alone
    exceeds :data:`LINEAR_MIN_SE` of its standard errors (paired, a row probed
    in several rounds one cluster: :func:`~sparseedm.donors.paired_gain`); else
    0, and 0 with fewer than :data:`~sparseedm.donors.DONOR_MIN_PROBES` probes.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        The poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    answer : callable
        ``answer(poses, missing)`` -> RecoveryResult: the path's answer for
        other rows of the file (the probes).
    fill : callable
        ``fill(rows, joints, probe_poses, probe_missing)`` -> ndarray (p, N, 2):
        the candidate's answer to the probes (the row of `poses` each probes and
        its joint hidden; NaN: no answer, the path's then).
    random_state : int, default 0
        Seed of the probes.

    Returns
    -------
    ProbeChoice
    """
    drawn = []
    for r in range(LINEAR_PROBE_ROUNDS):
        drawn.append(probes(missing, random_state + r))
        if sum(len(d[0]) for d in drawn) >= DONOR_PROBES:
            break
    rows, joints = (np.concatenate(d) for d in zip(*drawn))
    if len(rows) < DONOR_MIN_PROBES:
        return ProbeChoice(0.0, int(len(rows)), float("nan"), float("nan"))
    pmiss = missing[rows].copy()
    pmiss[np.arange(len(rows)), joints] = True
    pposes = np.where(pmiss[..., None], np.nan, poses[rows])
    path = answer(pposes, pmiss).poses
    other = fill(rows, joints, pposes, pmiss)
    other = np.where(np.isfinite(other), other, path)
    at = np.arange(len(rows)), joints
    _, size = rms_radius(poses[rows], pmiss)
    with np.errstate(all="ignore"):  # a refused probe (NaN) judges nothing
        per_pose = np.array([np.linalg.norm(((1 - w) * path + w * other)[at] - poses[rows][at],
                                            axis=-1) / size * 100 for w in LINEAR_WEIGHTS])
    weight, error = _best_weight(per_pose, DONOR_MIN_PROBES, clusters=rows)
    ok = np.isfinite(per_pose).all(axis=0)
    base = float(per_pose[0, ok].mean()) if ok.any() else float("nan")
    return ProbeChoice(weight, int(len(rows)), base, error if weight > 0 else base)


def _gaussian_probe_fill(poses, missing, complete):
    """probe_weight's `fill` for probe_stack: the local Gaussians over the complete
    poses and the incomplete ones with the probed joints hidden too."""
    def fill(rows, joints, pposes, pmiss):
        hidden = missing.copy()
        hidden[rows, joints] = True  # the Gaussians see no probed joint
        part, part_missing = _incomplete_sample(np.where(hidden[..., None], np.nan, poses),
                                                hidden)
        return local_gaussian_fill(_linear_draws(poses[complete], part, part_missing),
                                   pposes, pmiss)
    return fill
