"""A file's own complete poses as extra atoms beside the shipped prior.

When a file holds too few complete poses to adapt the dictionary on (fewer
than :data:`sparseedm.adaptation.MIN_COMPLETE_POSES`), or its adaptation is
not adopted, its complete poses still say how *these* people are drawn: the
annotators' or the detector's joint conventions, the camera, the sport.
:func:`with_file_atoms` appends their normalised EDM vectors, scaled to unit
norm, to the dictionary's atoms (repeats dropped: exact, or within
:data:`~sparseedm.adaptation.REPEAT_TOLERANCE` of the pose's size; at most
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

import time
import warnings
from dataclasses import dataclass, replace
from numbers import Integral, Real

import numpy as np

from .adaptation import (MIN_COMPLETE_POSES, AdaptationResult, filter_poses, pose_vectors,
                         repeat_rows)
from ._validation import BOOLEAN, Interval, check_pose_shape, validate_params
from .dictionary import Dictionary
from .normalize import usable_rows
from .skeleton import SKELETON_14

__all__ = ["MAX_FILE_ATOMS", "MAX_FAST_ATOMS", "FAST_ALPHA", "ATOM_SPACING", "FileAtoms",
           "with_file_atoms", "file_dictionary", "resolve_fast", "complete_rows",
           "spaced_rows", "atoms_adaptation", "mirror_images", "body_axis"]

#: at most this many of a file's complete poses become atoms (a seeded sample)
MAX_FILE_ATOMS = 1000

#: :func:`file_dictionary`'s default cap on the complete poses that make the
#: file's dictionary, and its recovery alpha (chosen for the exact lasso on CMU
#: validation files: ``studies/fast/select_fast.py``; ``recover(preset="fast")``
#: now codes by a local ridge and passes its own cap,
#: :data:`sparseedm._recovery_kernel.FAST_MAX_ATOMS`)
MAX_FAST_ATOMS = 3000
FAST_ALPHA = 0.0005

#: :func:`file_dictionary` merges poses closer than this (unit-norm EDM
#: vectors, :func:`spaced_rows`) into one atom, their mean: near-copies of one
#: pose (neighbouring frames of a still person, a pose resampled with a pixel
#: of noise) are nearly collinear atoms, among which the lasso's working sets
#: converge slowly without coding any better. About half a percent of the pose's size at
#: every joint: below the closest distinct poses of the validation files
#: (Bandai-Namco frames 1.5e-2 at the 5th percentile of nearest neighbours, MPII
#: and COCO photos 4e-2), above a pixel's noise on a 200 px person
#: (``studies/bigfile/README.md``). Not REPEAT_TOLERANCE (1e-4: one pose given
#: twice, which adaptation must not count twice): near-copies a pixel apart are
#: distinct samples for learning but one atom for the lasso; what counts atoms
#: (the exemplar rule, resolve_fast) counts them at this spacing
ATOM_SPACING = 0.005

_PARAMS = {"dictionary": [Dictionary], "max_atoms": [Interval(Integral, 1, None)],
           "filter": BOOLEAN, "random_state": [Interval(Integral, 0, None)],
           "spacing": [Interval(Real, 0, None)]}


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
        (:func:`sparseedm.adaptation.filter_poses`); else repeats only
        (:func:`sparseedm.adaptation.repeat_rows`).
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
    atoms, n_complete = _file_vectors(dictionary, poses, missing, max_atoms, filter,
                                      random_state)
    if not len(atoms):
        return FileAtoms(dictionary, 0, n_complete)
    prov = dict(dictionary.provenance or {})
    prov["file_atoms"] = {"atoms": int(len(atoms)), "complete_poses": int(n_complete),
                          "seed": int(random_state)}
    out = replace(dictionary, components=np.vstack([dictionary.components, atoms]),
                  provenance=prov)
    return FileAtoms(out, int(len(atoms)), int(n_complete))


def file_dictionary(dictionary, poses, missing=None, *, max_atoms=MAX_FAST_ATOMS,
                    alpha_recover=FAST_ALPHA, spacing=ATOM_SPACING, random_state=0):
    """A dictionary of the complete rows of `poses` alone: ``recover(preset="fast")``'s.

    Each usable complete pose (repeats dropped,
    :func:`sparseedm.adaptation.repeat_rows`, and each group of near-copies
    within `spacing` of one another, :func:`spaced_rows`, merged into its
    mean; at most `max_atoms`, a seeded sample) becomes a unit-norm atom, as
    in :func:`with_file_atoms`, but without the base's atoms: the lasso then
    codes each occluded pose over exemplars of the same file only, which are
    in-domain, and nothing is learned. The result keeps `dictionary`'s settings (normalisation,
    representation, alpha scaling) and recommends `alpha_recover`.

    Parameters
    ----------
    dictionary : Dictionary
        Where the settings come from (its atoms are not used).
    poses : ndarray (n, N, 2)
        Poses in pixels; only usable complete rows are used.
    missing : ndarray of bool (n, N), optional
        True where a joint is missing; default the NaN coordinates.
    max_atoms : int, default MAX_FAST_ATOMS
        At most this many poses become atoms (a seeded sample, order kept).
    alpha_recover : float, default FAST_ALPHA
        The recovery alpha the dictionary recommends.
    spacing : float, default ATOM_SPACING
        Poses within this distance of a pose taken first (unit-norm EDM
        vectors) are merged into one atom, their mean; 0: repeats only are
        dropped.
    random_state : int, default 0
        Seed of the sample (and of the order :func:`spaced_rows` visits the poses in).

    Returns
    -------
    FileAtoms
        The file's dictionary (`dictionary` itself when no pose was usable),
        its atom count and the complete poses offered.

    Raises
    ------
    ParameterError
        `dictionary` is not a Dictionary, or `max_atoms`, `spacing` or
        `random_state` is out of range.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> poses = np.random.default_rng(0).normal(size=(30, 14, 2))
    >>> out = file_dictionary(load_dictionary(), poses)
    >>> out.n_atoms, out.dictionary.n_components, out.dictionary.alpha_recover
    (30, 30, 0.0005)
    """
    validate_params("file_dictionary", dict(dictionary=dictionary, max_atoms=max_atoms,
                                           spacing=spacing, random_state=random_state),
                    _PARAMS)
    atoms, n_complete = _file_vectors(dictionary, poses, missing, max_atoms, False,
                                      random_state, spacing)
    if not len(atoms):
        return FileAtoms(dictionary, 0, n_complete)
    prov = {"file_dictionary": {"atoms": int(len(atoms)), "complete_poses": int(n_complete),
                                "seed": int(random_state), "spacing": float(spacing),
                                "settings_from": (dictionary.provenance or {}).get("sha256", "")}}
    out = replace(dictionary, components=atoms, alpha_recover=float(alpha_recover),
                  provenance=prov)
    return FileAtoms(out, int(len(atoms)), int(n_complete))


def _file_vectors(dictionary, poses, missing, max_atoms, filter, random_state, spacing=0.0):
    """The unit-norm EDM vectors of the usable complete rows of `poses` (repeats or,
    with `filter`, implausible poses dropped; near-copies within `spacing`
    merged into their mean; a seeded sample of at most `max_atoms`), and how
    many complete rows were offered."""
    poses = np.asarray(poses, dtype=float)
    check_pose_shape(poses, n_joints=dictionary.n_joints)
    poses = poses[complete_rows(poses, missing)]
    if len(poses) == 0:
        return np.zeros((0, dictionary.n_features)), 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        vectors = pose_vectors(poses)  # one vector per pose: the atoms are its rows
        keep = (filter_poses(poses, dictionary).keep if filter
                else ~repeat_rows(vectors))
    unit = vectors[keep] / np.linalg.norm(vectors[keep], axis=1, keepdims=True)
    if spacing > 0 and len(unit) > 1:
        unit = _merged_atoms(unit, spacing, random_state)
    if len(unit) > max_atoms:
        rng = np.random.default_rng([int(random_state), 41])
        unit = unit[np.sort(rng.choice(len(unit), int(max_atoms), replace=False))]
    return unit, len(poses)


def spaced_rows(X, spacing, random_state=0):
    """Rows of `X` no two of which are closer than `spacing`, and whom each row joins.

    The rows are visited in a seeded random order; each is taken unless it lies
    within `spacing` of a row taken before it, and joins the first taken row
    it lies that close to. A group of near-copies so becomes one taken row and
    its members; rows farther apart than `spacing` are all taken.

    Parameters
    ----------
    X : ndarray (n, m)
        The rows (unit-norm EDM vectors).
    spacing : float
        Smallest distance between two rows taken.
    random_state : int, default 0
        Seed of the visiting order.

    Returns
    -------
    taken : ndarray of int
        Indices of the rows taken, ascending.
    group : ndarray of int (n,)
        For each row, the position in `taken` of the row it joined (its own
        for a taken row).

    Examples
    --------
    >>> import numpy as np
    >>> X = np.array([[0.0, 1.0], [0.0, 1.001], [1.0, 0.0], [0.0, 0.999]])
    >>> taken, group = spaced_rows(X, 0.01)        # three near-copies make one
    >>> taken.size, group[[0, 1, 3]].tolist() == [group[0]] * 3
    (2, True)
    >>> spaced_rows(X, 0.0001)[0].tolist()         # all farther apart than that
    [0, 1, 2, 3]
    """
    from scipy.spatial import cKDTree

    validate_params("spaced_rows", dict(spacing=spacing, random_state=random_state), _PARAMS)
    X = np.asarray(X, dtype=float)
    owner = np.full(len(X), -1)
    if len(X) < 2:
        return np.arange(len(X)), np.arange(len(X))
    tree = cKDTree(X)
    # a row with no other within `spacing` is taken whatever the order
    alone = ~np.isfinite(tree.query(X, k=2, distance_upper_bound=float(spacing))[0][:, 1])
    owner[alone] = np.flatnonzero(alone)
    for i in np.random.default_rng([int(random_state), 43]).permutation(len(X)):
        if owner[i] < 0:
            near = np.asarray(tree.query_ball_point(X[i], float(spacing)), dtype=int)
            owner[near[owner[near] < 0]] = i
            owner[i] = i
    taken = np.unique(owner)
    return taken, np.searchsorted(taken, owner)


def _merged_atoms(unit, spacing, random_state):
    """`unit`'s rows with each group of near-copies (:func:`spaced_rows`)
    replaced by its mean, scaled to unit norm: one denoised atom per pose."""
    _, group = spaced_rows(unit, spacing, random_state)
    sums = np.zeros((group.max() + 1, unit.shape[1]))
    np.add.at(sums, group, unit)
    return sums / np.linalg.norm(sums, axis=1, keepdims=True)


def resolve_fast(dictionary, poses, missing, adapt, *, min_poses=MIN_COMPLETE_POSES,
                 max_atoms=MAX_FAST_ATOMS):
    """The dictionary ``recover(preset="fast")`` codes with, and what was done.

    With at least `min_poses` usable complete poses offered (the file's own
    under ``adapt="auto"``, or the array `adapt`), those poses alone are the
    atoms (:func:`file_dictionary`); with fewer, they join `dictionary`'s
    atoms (:func:`with_file_atoms`), as the default path does when it cannot
    adapt. Nothing is learned either way.

    Parameters
    ----------
    dictionary : Dictionary
        The base dictionary (its settings in both cases, its atoms in the second).
    poses, missing : ndarray
        The poses to be recovered and their missing joints (None: the NaN ones).
    adapt : "auto", False, None or array_like (n_adapt, N, 2)
        Where the complete poses come from; False or None: `dictionary` as given.
    min_poses : int, default MIN_COMPLETE_POSES
        Fewest complete poses that make a dictionary on their own.
    max_atoms : int or None, default MAX_FAST_ATOMS
        At most this many complete poses become the atoms (a seeded sample);
        None: every one (``recover(preset="fast")`` passes its own cap,
        :data:`sparseedm._recovery_kernel.FAST_MAX_ATOMS`).

    Returns
    -------
    dictionary : Dictionary
        The dictionary to recover with.
    adaptation : AdaptationResult or None
        What was done (``adapted`` False, ``file_atoms`` the atoms taken from
        the poses); None when `adapt` is False or None.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.dictionary import load_dictionary
    >>> base = load_dictionary()
    >>> d, res = resolve_fast(base, np.random.default_rng(0).normal(size=(40, 14, 2)), None,
    ...                       "auto")
    >>> d.n_components == base.n_components + 40, res.file_atoms
    (True, 40)
    """
    if adapt is False or adapt is None:
        return dictionary, None
    t0 = time.perf_counter()
    source = (poses, missing) if isinstance(adapt, str) else (np.asarray(adapt, float), None)
    found = file_dictionary(dictionary, *source,
                            max_atoms=max(1, len(source[0])) if max_atoms is None else max_atoms)
    if found.n_atoms >= min_poses:
        reason = (f"preset 'fast': {found.n_atoms} complete poses are the dictionary's atoms "
                  "(nothing learned)")
    else:
        distinct, found = found.n_atoms, with_file_atoms(dictionary, *source)
        count = (f"{found.n_complete} complete poses"
                 + (f" ({distinct} distinct)" if distinct < found.n_complete else ""))
        reason = (f"preset 'fast': {count}, fewer than the {min_poses} a dictionary of "
                  "their own needs: the base dictionary"
                  + (" with them as extra atoms" if found.n_atoms else ""))
    res = atoms_adaptation(found, len(source[0]), reason, t0, {"preset": "fast"})
    return found.dictionary, res


def mirror_images(poses, skeleton=SKELETON_14):
    """`poses` followed by their mirror images: each pose reflected across the
    poses' mean body axis, each left joint swapped with its right one.

    A mirror image's distances are the pose's own with the left and right
    labels swapped: another plausible pose of the same people, for free (as
    extra atoms of :func:`file_dictionary`, and draws of the Gaussians of
    :mod:`sparseedm.gaussian_fill`). Each pose is reflected across the line
    through its centre (its joints' mean) along the mean over `poses` of the
    direction from the hips' midpoint to the neck: in a file of people upright
    in the image that is the image's vertical (a pose leaning one way gets a
    mirror image leaning the other), and a file rotated in the image has its
    mirror images rotated with it. (The image's vertical where a skeleton
    names no such joints or the directions cancel.)

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Poses of `skeleton`'s N joints.
    skeleton : Skeleton, default SKELETON_14
        Which joints are left and right.

    Returns
    -------
    ndarray (2 n, N, 2)

    Examples
    --------
    >>> import numpy as np
    >>> pose = np.zeros((1, 14, 2)); pose[0, 1] = [0.0, -1.0]   # neck above the hips
    >>> pose[0, 4] = [1.4, 0.0]                                 # the right wrist
    >>> both = mirror_images(pose)
    >>> both.shape, np.round(both[1, 7], 6).tolist()             # now the left wrist
    ((2, 14, 2), [-1.2, 0.0])
    >>> turn = np.array([[0.0, 1.0], [-1.0, 0.0]])                # a quarter turn
    >>> bool(np.allclose(mirror_images(pose @ turn)[1], both[1] @ turn))
    True
    """
    poses = np.asarray(poses, dtype=float)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a row of NaN: its mirror NaN
        centre = np.nanmean(poses, axis=1, keepdims=True)
    axis = body_axis(poses, skeleton)
    axis = np.array([0.0, 1.0]) if axis is None else axis
    d = poses - centre
    reflected = centre + 2 * (d @ axis)[..., None] * axis - d
    return np.concatenate([poses, reflected[:, skeleton.flip_permutation()]])


def body_axis(poses, skeleton=SKELETON_14):
    """The unit mean over `poses` of their directions from the hips' midpoint to
    the neck (poses missing one of those joints, NaN, left out).

    Parameters
    ----------
    poses : ndarray (n, N, 2)
    skeleton : Skeleton, default SKELETON_14

    Returns
    -------
    ndarray (2,) or None
        None where `skeleton` names no such joints, no pose has them or the
        directions cancel.

    Examples
    --------
    >>> import numpy as np
    >>> pose = np.zeros((1, 14, 2)); pose[0, 1] = [0.0, -3.0]   # neck above the hips
    >>> body_axis(pose).tolist()
    [0.0, -1.0]
    """
    names = skeleton.joint_names
    if not {"neck", "right_hip", "left_hip"} <= set(names) or not len(poses):
        return None
    hips = (poses[:, names.index("right_hip")] + poses[:, names.index("left_hip")]) / 2
    up = poses[:, names.index("neck")] - hips
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        up = up / np.hypot(up[:, 0], up[:, 1])[:, None]
        mean = np.nansum(np.where(np.isfinite(up), up, np.nan), axis=0)
        length = np.hypot(*mean)
    if not (np.isfinite(length) and length > 1e-9 * len(poses)):
        return None
    return mean / length


def complete_rows(poses, missing=None):
    """Rows of `poses` usable as atoms: finite, with an extent recover() accepts
    (:func:`sparseedm.normalize.usable_rows`) and no `missing` joint.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
    missing : ndarray of bool (n, N), optional
        Missing joints besides the NaN ones.

    Returns
    -------
    ndarray of bool (n,)

    Examples
    --------
    >>> import numpy as np
    >>> poses = np.ones((3, 14, 2)) * np.arange(14)[None, :, None]
    >>> poses[1, 0] = np.nan
    >>> complete_rows(poses).tolist()
    [True, False, True]
    """
    ok = usable_rows(poses)
    if missing is not None:
        ok &= ~np.asarray(missing, dtype=bool).any(axis=-1)
    return ok


def atoms_adaptation(found, n_given, reason, t0, settings):
    """The AdaptationResult of a path that codes over file atoms, nothing learned.

    Parameters
    ----------
    found : FileAtoms
        The dictionary made of (or with) the file's poses.
    n_given : int
        Poses offered.
    reason : str
        What was done, and why.
    t0 : float
        ``time.perf_counter()`` when the path began.
    settings : dict
        The path's settings, as recorded.

    Returns
    -------
    AdaptationResult
        ``adapted`` False, ``file_atoms`` the atoms taken from the poses.
    """
    return AdaptationResult(dictionary=found.dictionary, adapted=False, reason=reason,
                            n_given=n_given, n_complete=found.n_complete,
                            file_atoms=found.n_atoms, settings=settings,
                            seconds=time.perf_counter() - t0)
