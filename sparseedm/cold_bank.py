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
"""

from __future__ import annotations

import time
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from ._safeio import load_npz_file
from ._shipped import resolve_shipped
from .exceptions import DictionaryError
from .exemplars import stack_fill
from .file_atoms import body_axis
from .gaussian_fill import LOCAL_NEIGHBOURS, gated_local_fill

__all__ = ["COLD_BANK", "COLD_BANK_WEIGHTS", "COLD_BANK_NEIGHBOURS", "COLD_BANK_GATE",
           "COLD_BANK_GATE_NEIGHBOURS", "AVERAGED_BANK", "PoseBank", "load_pose_bank",
           "bank_fill", "cold_bank_stack"]

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


def bank_fill(bank, poses, missing, neighbours=COLD_BANK_NEIGHBOURS, gate=COLD_BANK_GATE):
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
    own, theirs = body_axis(draws), body_axis(given)
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
