"""A file's own complete poses as extra atoms beside the shipped prior.

When a file holds too few complete poses to adapt the dictionary on (fewer
than :data:`sparseedm.adaptation.MIN_COMPLETE_POSES`), or its adaptation is
not adopted, its complete poses still say how *these* people are drawn: the
annotators' or the detector's joint conventions, the camera, the sport.
:func:`with_file_atoms` appends their normalised EDM vectors, scaled to unit
norm, to the dictionary's atoms (exact repeats dropped; at most
:data:`MAX_FILE_ATOMS`, a seeded sample). Adaptation's plausibility filters
(:func:`sparseedm.adaptation.filter_poses`, ``filter=True``) are off by
default: the poses they drop as outliers are the unusual ones an exemplar is
most needed for, and on the validation photos keeping them was better in 8 of
9 cases. The lasso then codes each occluded
pose over both: exemplars of the file where one fits, mocap atoms elsewhere.
Nothing is learned, so it costs a Gram matrix of the larger dictionary.

On the photo protocol of ``studies/real_prior`` (hand-annotated MPII and COCO
validation photos, too few complete poses per file to adapt on) it lowered
the error of hidden joints against the shipped prior alone by 16-26 % with 1-3
random joints hidden and by 6 % with MPII's real visibility masks (1 % worse
with COCO's) (``studies/real_prior/README.md``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from numbers import Integral

import numpy as np

from .adaptation import duplicate_rows, filter_poses, pose_vectors
from ._validation import BOOLEAN, Interval, check_pose_shape, validate_params
from .dictionary import Dictionary
from .normalize import usable_rows

__all__ = ["MAX_FILE_ATOMS", "FileAtoms", "with_file_atoms"]

#: at most this many of a file's complete poses become atoms (a seeded sample)
MAX_FILE_ATOMS = 1000

_PARAMS = {"dictionary": [Dictionary], "max_atoms": [Interval(Integral, 1, None)],
           "filter": BOOLEAN, "random_state": [Interval(Integral, 0, None)]}


@dataclass
class FileAtoms:
    """What :func:`with_file_atoms` returns.

    Parameters
    ----------
    dictionary : Dictionary
        The base atoms followed by the file's atoms (the base itself when
        there were none); its provenance records the atoms added.
    n_atoms : int
        File atoms appended.
    n_complete : int
        Complete usable poses offered (before the filter and the sample).
    """

    dictionary: Dictionary
    n_atoms: int
    n_complete: int


def with_file_atoms(dictionary, poses, missing=None, *, max_atoms=MAX_FILE_ATOMS,
                    filter=False, random_state=0):
    """`dictionary` with the complete rows of `poses` appended as unit-norm atoms.

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary; its atoms come first and are not changed.
    poses : ndarray (n, N, 2)
        Poses in pixels; only usable complete rows are used
        (:func:`sparseedm.normalize.usable_rows`, no `missing` joint).
    missing : ndarray of bool (n, N), optional
        True where a joint is missing: a row with one is not complete. Default:
        NaN coordinates mark the missing joints.
    max_atoms : int, default MAX_FILE_ATOMS
        At most this many poses become atoms (a seeded sample, order kept).
    filter : bool, default False
        Drop implausible poses first as adaptation does
        (:func:`sparseedm.adaptation.filter_poses`); else exact repeats only.
    random_state : int, default 0
        Seed of the sample when more than `max_atoms` poses are left.

    Returns
    -------
    FileAtoms
        The dictionary with the file's atoms, and how many were appended out of
        how many complete poses.

    Raises
    ------
    ParameterError
        `dictionary` is not a Dictionary, or `max_atoms` or `random_state` is
        out of range.
    PoseError
        `poses` is not shaped (n, N, 2) for the dictionary's N joints.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> base = load_dictionary()
    >>> rng = np.random.default_rng(0)
    >>> poses = rng.normal(size=(30, 14, 2))
    >>> out = with_file_atoms(base, poses)
    >>> out.n_complete, out.dictionary.n_components == base.n_components + out.n_atoms
    (30, True)
    """
    validate_params("with_file_atoms", dict(dictionary=dictionary, max_atoms=max_atoms,
                                           filter=filter, random_state=random_state), _PARAMS)
    poses = np.asarray(poses, dtype=float)
    check_pose_shape(poses, n_joints=dictionary.n_joints)
    complete = usable_rows(poses)  # finite, with an extent recover() accepts
    if missing is not None:
        complete &= ~np.asarray(missing, dtype=bool).any(axis=-1)
    poses = poses[complete]
    if len(poses) == 0:
        return FileAtoms(dictionary, 0, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        vectors = pose_vectors(poses)  # one vector per pose: the atoms are its rows
        keep = (filter_poses(poses, dictionary).keep if filter
                else ~duplicate_rows(vectors))
    rows = np.flatnonzero(keep)
    if len(rows) > max_atoms:
        rng = np.random.default_rng([int(random_state), 41])
        rows = np.sort(rng.choice(rows, int(max_atoms), replace=False))
    if len(rows) == 0:
        return FileAtoms(dictionary, 0, len(poses))
    X = vectors[rows]
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    prov = dict(dictionary.provenance or {})
    prov["file_atoms"] = {"atoms": int(len(rows)), "complete_poses": int(len(poses)),
                          "seed": int(random_state)}
    out = replace(dictionary, components=np.vstack([dictionary.components, X]),
                  provenance=prov)
    return FileAtoms(out, int(len(rows)), int(len(poses)))
