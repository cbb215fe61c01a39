"""The shipped pose bank: a linear answer that ``recover(adapt=False)`` stacks with its codes.

Without a dictionary, ``recover(adapt=False)`` codes each pose over
``cmu-coco-k2932`` (:func:`sparseedm._recovery_base.cold_prior`) and learns
nothing from the file. Beside the codes it sets the answer of a per-pose local
Gaussian (:func:`sparseedm.gaussian_fill.local_gaussian_fill`) whose draws are
a shipped bank of complete 2D poses, :data:`COLD_BANK` (COCO's people of the
training images in two neck conventions and CMU motion capture seen by
virtual cameras, each with its mirror image: ``dictionaries/README.md``): a
pose's hidden joints come from the bank poses nearest it on its observed
joints. A pose nearer the photographed people than the motion capture (its
:data:`COLD_BANK_GATE_NEIGHBOURS` nearest of each, mean distance, their
ratio below :data:`COLD_BANK_GATE`) takes its Gaussian from the photographed
people alone, any other from the whole bank. The two answers are averaged,
the bank's weighted by :data:`COLD_BANK_WEIGHTS` for the pose's count of
hidden joints (chosen on validation photos with motion capture held out from
both answers as the check, ``studies/real_prior/select_cold_bank.py``), and
``RecoveryResult.averaged`` says :data:`AVERAGED_BANK` on those poses.

The default path (``recover()``'s defaults on a file whose answers are
blended, :func:`sparseedm.exemplars.finish_blend`) takes the bank as a
candidate of its own: :func:`bank_step` averages every occluded pose's answer
with :func:`bank_fill`'s at a weight chosen per file on probes of the
file's occluded rows (:func:`sparseedm.exemplars.probe_weight`: one more
observed joint hidden, the weight taken only when its gain beats one paired
standard error), 0 unless the bank pays. A file whose own poses say more
than the bank (from :data:`BANK_STEP_MAX_COMPLETE` complete poses) skips the
step. Over three draws of the validation photo files it lowered the hidden
joints' error on the COCO file of 28 complete poses by 0.75 / 0.56 % of body
size (1-3 random hidden joints / real masks; 0.80x -> 0.71x
IterativeImputer's under random masks) and on MPII files of 28-100 by 0 to
0.27, and left the Bonn video frames (whose neighbouring frames the path
finds) unchanged (weight 0); the CMU and Daz mocap files moved by -0.06 to 0.
It adds 0.2-2.6 s to such a file (``studies/fast/README.md``).
"""

from __future__ import annotations

import time
from dataclasses import replace
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from ._safeio import load_npz_file
from ._shipped import resolve_shipped
from .exceptions import DictionaryError
from .exemplars import probe_weight, remembered, stack_fill
from .file_atoms import body_axis, complete_rows
from .gaussian_fill import LOCAL_NEIGHBOURS, gated_local_fill

__all__ = ["COLD_BANK", "COLD_BANK_WEIGHTS", "COLD_BANK_NEIGHBOURS", "COLD_BANK_GATE",
           "COLD_BANK_GATE_NEIGHBOURS", "AVERAGED_BANK", "PoseBank", "load_pose_bank",
           "bank_fill", "cold_bank_stack", "BANK_STEP_MAX_COMPLETE", "bank_step"]

#: the shipped bank's name (``dictionaries/cold-bank.npz``)
COLD_BANK = "cold-bank"

#: the bank's weight in the average by the pose's count of hidden joints
#: (index: the count; 0 unused)
COLD_BANK_WEIGHTS = (0.0, 0.25, 0.5, 0.25, 0.9, 0.9, 0.8, 0.8, 0.8, 0.8, 0.8, 0.8, 0.8,
                     0.8, 0.8)

#: the bank poses nearest a pose that set its Gaussian
COLD_BANK_NEIGHBOURS = LOCAL_NEIGHBOURS

#: a pose whose mean distance to its COLD_BANK_GATE_NEIGHBOURS nearest
#: photographed bank poses is below COLD_BANK_GATE times that to the nearest
#: motion-capture ones takes its Gaussian from the photographed ones alone
COLD_BANK_GATE, COLD_BANK_GATE_NEIGHBOURS = 1.5, 20

#: RecoveryResult.averaged of a pose whose answer was averaged with the bank's
AVERAGED_BANK = "Gaussian of the shipped pose bank"

#: the default path's bank step (:func:`bank_step`) runs on files (or
#: recover_file's chunks) with fewer usable complete poses than this; from it
#: the file's own poses are the better draws and the step is skipped
BANK_STEP_MAX_COMPLETE = 200


class PoseBank(NamedTuple):
    """A pose bank: complete poses (n, N, 2) and which of them are photographed
    people (n,) bool (the others motion capture seen by virtual cameras)."""

    poses: np.ndarray
    photographed: np.ndarray


@lru_cache(maxsize=2)
def load_pose_bank(name_or_path=COLD_BANK):
    """A pose bank file, by shipped name or path.

    A pose bank is an ``.npz`` (read with ``allow_pickle=False``) holding
    ``poses``, finite (n, N, 2) with n >= 2, ``photographed`` (n,) bool and
    ``joint_names`` (N,).

    Parameters
    ----------
    name_or_path : str or path-like, default COLD_BANK

    Returns
    -------
    PoseBank
        Its arrays read-only (shared by every call).

    Examples
    --------
    >>> bank = load_pose_bank()
    >>> bank.poses.shape[1:], bool(np.isfinite(bank.poses).all()), bool(bank.photographed.any())
    ((14, 2), True, True)
    """
    path = resolve_shipped(name_or_path, "sparseedm.dictionaries", COLD_BANK,
                           DictionaryError, "pose bank")
    arrays, _ = load_npz_file(path, ("poses", "photographed", "joint_names"),
                              error=DictionaryError, kind="pose bank")
    if "poses" not in arrays or "photographed" not in arrays:
        raise DictionaryError(f"{path}: not a pose bank (no 'poses' or 'photographed' array)")
    poses, photographed = arrays["poses"], arrays["photographed"]
    if poses.ndim != 3 or poses.shape[2] != 2 or len(poses) < 2 or \
            not np.isfinite(poses).all():
        raise DictionaryError(f"{path}: a pose bank's 'poses' must be finite (n >= 2, N, 2), "
                              f"got shape {poses.shape}")
    if photographed.dtype != bool or photographed.shape != poses.shape[:1]:
        raise DictionaryError(f"{path}: a pose bank's 'photographed' must be bool, one per "
                              f"pose ({len(poses)}), got {photographed.dtype} {photographed.shape}")
    poses = poses.astype(float)
    for a in (poses, photographed):
        a.flags.writeable = False
    return PoseBank(poses, photographed)


def bank_fill(bank, poses, missing, neighbours=COLD_BANK_NEIGHBOURS, gate=COLD_BANK_GATE,
              axis=None):
    """The poses' missing joints by the local Gaussian of a pose bank turned to the poses.

    The bank's poses are turned about the origin so that their mean body axis
    (:func:`sparseedm.file_atoms.body_axis`, hips' midpoint to neck) is that
    of `poses` (left as they are where either has none). A pose whose mean
    distance to its :data:`COLD_BANK_GATE_NEIGHBOURS` nearest photographed bank
    poses is below `gate` times that to the nearest motion-capture ones
    (:func:`~sparseedm.gaussian_fill.nearest_distances`) is filled by
    :func:`~sparseedm.gaussian_fill.local_gaussian_fill` over the photographed
    ones, any other over the whole bank
    (:func:`~sparseedm.gaussian_fill.gated_local_fill`: the distances computed
    once for both): a file turned in the image gets its joints turned with it.

    Parameters
    ----------
    bank : PoseBank
    poses : ndarray (n, N, 2)
        Poses to fill (values at missing joints ignored).
    missing : ndarray of bool (n, N)
    neighbours : int, default COLD_BANK_NEIGHBOURS
        The draws that set each pose's Gaussian.
    gate : float, default COLD_BANK_GATE
        0: the whole bank for every pose; inf: the photographed poses alone.
    axis : ndarray (2,), optional
        The body axis to turn the bank to; default that of `poses` (every
        pose's answer then depends on that pose alone).

    Returns
    -------
    ndarray (n, N, 2)
        `poses` with the missing joints filled (NaN where a pose's observed
        joints have no spread).

    Examples
    --------
    >>> bank = load_pose_bank()
    >>> pose = bank.poses[:1] * 100 + 300
    >>> missing = np.zeros((1, 14), bool); missing[0, 4] = True
    >>> turn = np.array([[0.0, -1.0], [1.0, 0.0]])              # a quarter turn
    >>> a, b = bank_fill(bank, pose, missing), bank_fill(bank, pose @ turn.T, missing)
    >>> bool(np.allclose(b, a @ turn.T))
    True
    """
    missing = np.asarray(missing, bool)
    given = np.where(missing[..., None], np.nan, np.asarray(poses, float))
    draws, photo = bank.poses, bank.photographed
    own, theirs = body_axis(draws), body_axis(given) if axis is None else axis
    if own is not None and theirs is not None:
        c, s = own @ theirs, own[0] * theirs[1] - own[1] * theirs[0]
        draws = draws @ np.array([[c, -s], [s, c]]).T
    if photo.sum() < 2 or not (~photo).any():
        gate = 0.0  # no two parts to choose between: the whole bank
    # neighbours chosen once (the bank's weights were chosen so); each missing
    # pattern's distances to the bank computed once, for the gate and the fill
    return gated_local_fill(draws, given, missing, photo, gate, COLD_BANK_GATE_NEIGHBOURS,
                            neighbours=neighbours)


def cold_bank_stack(res, poses, missing, bank=None):
    """`res` with each occluded pose's answer averaged with the bank's local Gaussian's.

    Parameters
    ----------
    res : RecoveryResult
        The codes' answer to `poses`.
    poses : ndarray (n, N, 2)
        The poses given (values at missing joints ignored).
    missing : ndarray of bool (n, N)
    bank : PoseBank, optional
        Default :func:`load_pose_bank` of :data:`COLD_BANK`.

    Returns
    -------
    RecoveryResult
        `res` with the poses whose count of hidden joints has a weight in
        :data:`COLD_BANK_WEIGHTS` averaged (``averaged`` names
        :data:`AVERAGED_BANK`); the others as they were.

    Examples
    --------
    >>> import sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)[None]
    >>> pose[0, 4] = np.nan
    >>> res = sparseedm.recover(pose, adapt=False)
    >>> res.averaged.tolist() == [AVERAGED_BANK]
    True
    """
    t0 = time.perf_counter()
    missing = np.asarray(missing, bool)
    weight = np.asarray(COLD_BANK_WEIGHTS)[missing.sum(axis=1)]
    rows = np.flatnonzero((weight > 0) & res.ok)
    if not len(rows):
        return res
    draws = load_pose_bank() if bank is None else bank
    # every pose sets the file's body axis; the complete ones have nothing to fill
    fill = bank_fill(draws, poses, missing)[rows]
    out = stack_fill(res, rows, fill, weight[rows], AVERAGED_BANK)
    out.seconds = res.seconds + time.perf_counter() - t0
    return out


def bank_step(res, poses, missing, answer, random_state=0, bank=None):
    """The default path's bank step: `res` averaged with the bank's answer
    (:func:`bank_fill`) at a weight chosen per file on probes of its occluded rows.

    The weight is :func:`sparseedm.exemplars.probe_weight`'s: each probe (an
    occluded row with one more observed joint hidden) is answered by the path
    (`answer`) and by :func:`bank_fill`, and the weight of
    :data:`~sparseedm.exemplars.LINEAR_WEIGHTS` with the lowest probe error
    is taken when its gain over the path alone exceeds one paired standard
    error; else 0 (the bank's poses are not the file's people). Skipped on files
    of :data:`BANK_STEP_MAX_COMPLETE` usable complete poses or more, and on
    files whose poses are not the bank's joints.

    Parameters
    ----------
    res : RecoveryResult
        The default path's recovery of `poses` (blended).
    poses : ndarray (n, N, 2)
        The poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    answer : callable
        ``answer(poses, missing)`` -> RecoveryResult: the path's answer for other
        rows of the file (the probes).
    random_state : int, default 0
        Seed of the probes.
    bank : PoseBank, optional
        Default :func:`load_pose_bank` of :data:`COLD_BANK`.

    Returns
    -------
    res : RecoveryResult
        With ``adaptation.settings["bank"]`` recording the weight, the probes
        and their errors (or why the step was skipped); for a weight above 0 the
        occluded poses' answers averaged (``averaged`` names :data:`AVERAGED_BANK`).
    answer : callable
        `answer` with the bank so averaged at that weight (the probes the step
        answered reused): the later steps' probes see what they change.
    """
    draws = load_pose_bank() if bank is None else bank
    n_complete = int(complete_rows(poses, missing).sum())
    if missing.shape[1] != draws.poses.shape[1] or n_complete >= BANK_STEP_MAX_COMPLETE:
        why = (f"{n_complete} complete poses, at least {BANK_STEP_MAX_COMPLETE}"
               if missing.shape[1] == draws.poses.shape[1] else "not the bank's joints")
        return _bank_noted(res, {"weight": 0.0, "probes": 0, "skipped": why}), answer
    axis = body_axis(poses)  # the file's: each pose's bank answer its own alone
    answer = remembered(answer)
    fill = remembered(lambda p, m: bank_fill(draws, p, m, axis=axis), lambda f, k: f[:k])
    choice = probe_weight(poses, missing, answer, lambda rows, joints, p, m: fill(p, m),
                          random_state)
    res = _bank_noted(res, {"weight": choice.weight, "probes": choice.probes,
                            "probe_err_default": round(choice.err_default, 4),
                            "probe_err_chosen": round(choice.err_chosen, 4)})
    if not choice.weight > 0:
        return res, answer
    return (_bank_stacked(res, poses, missing, bank_fill(draws, poses, missing, axis=axis),
                          choice.weight),
            lambda p, m: _bank_stacked(answer(p, m), p, m, fill(p, m), choice.weight))


def _bank_stacked(res, poses, missing, filled, weight):
    """`res` with its occluded poses' answers averaged with the bank's `filled`
    (bank_fill's) at `weight`."""
    t0 = time.perf_counter()
    rows = np.flatnonzero(np.asarray(missing, bool).any(axis=1) & res.ok)
    if not len(rows):
        return res
    fill = filled[rows]
    out = stack_fill(res, rows, fill, weight, AVERAGED_BANK)
    out.seconds = res.seconds + time.perf_counter() - t0
    return out


def _bank_noted(res, record):
    """`res` with `record` as its adaptation's settings' ``bank`` (none: `res`)."""
    if res.adaptation is None:
        return res
    return replace(res, adaptation=replace(res.adaptation, settings=dict(
        res.adaptation.settings, bank=record)))
