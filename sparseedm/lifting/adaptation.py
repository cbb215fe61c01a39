"""Adapt a coupled dictionary lifter's 2D half on complete 2D poses without 3D.

A user's keypoint file holds complete 2D poses but no 3D: only the 2D half of
the coupled atoms ``d_j = [a_j ; b_j]`` (:mod:`.dictionary`) can learn from
them. :func:`adapt_lifter` offers two ways.

``method="reweight"`` (the default, :func:`reweight_atoms`) moves no atom: it
codes the poses on the 2D halves and scales each whole atom by
``r ** gamma`` (clipped to [0.1, 10]), ``r = (u + mean u) / (2 mean u)``
with u an atom's mean absolute code (smoothed: an unused atom counts as half
an average one). A scaled atom costs less (or more) in the lifting lasso's
L1 penalty, so the poses' typical atoms are preferred, while every atom's
2D : 3D pairing stays exactly as learned.

``method="2d-half"`` (:func:`adapt_vectors_2d`) continues the online learning
of :func:`sparseedm.adaptation.adapt_vectors` on the 2D halves alone and
keeps every atom's 3D half ``b_j`` as it was:

1. the usable, distinct poses (the filters of :mod:`sparseedm.adaptation`)
   are turned into normalised 2D EDM vectors;
2. the 2D halves are scaled to unit norm and adapted with
   ``adapt_vectors(..., stats="carried")``: Mairal's statistics start as
   ``memory`` pseudo-observations of each base atom, so an atom moves towards
   the new poses in proportion to how much they use it and an unused atom
   stays where it was (``"fresh"`` statistics would re-draw unused atoms from
   2D poses, cutting them loose from their 3D halves, so it is not offered);
3. each adapted 2D half is scaled back to its base norm, so the 2D : 3D
   balance of every atom, and hence the lasso ``alpha_lift``, stay as they
   were.

Here the 3D half cannot follow: an atom whose 2D half drifts far pairs the new 2D
shape with the old 3D shape, which can lift worse. ``memory`` bounds the
drift. Whether each helps was measured across sources by
``studies/lifting/select_lift_adaptation.py`` (``lifters/README.md``): read that before
relying on it.

Examples
--------
>>> import numpy as np
>>> from sparseedm.lifting.dictionary import DictionaryLifter
>>> rng = np.random.default_rng(0)
>>> X3 = np.abs(rng.standard_normal((200, 6)))
>>> lf = DictionaryLifter(n_components=20, alpha=0.05, batch_size=50).fit(X3 * 0.8, X3)
>>> new = adapt_vectors_2d(lf, X3[:50] * 0.7, alpha=0.05, batch_size=25)
>>> new.components_.shape, bool(np.allclose(new.components_[:, 6:], lf.components_[:, 6:]))
((20, 12), True)
"""

from __future__ import annotations

import copy

import numpy as np

from ..adaptation import adapt_vectors, duplicate_rows, pose_vectors
from ..edm import pose_to_vector
from ..exceptions import PoseError
from ..learning import sparse_code
from ..metrics import err_ave, occlusion_masks
from ..normalize import normalize, represent, usable_rows
from .base import LifterError, load_lifter

__all__ = ["adapt_lifter", "adapt_vectors_2d", "reweight_atoms", "masked_error_2d", "METHODS",
           "DEFAULT_LIFT_ADAPT"]

#: what :func:`adapt_lifter` can do
METHODS = ("reweight", "2d-half", "both")

#: settings of :func:`adapt_lifter` (see lifters/README.md for how they were chosen)
DEFAULT_LIFT_ADAPT = dict(method="reweight", gamma=0.5, alpha=None, passes=1.0, memory=100.0,
                          batch_size=256)
#: coding penalty of :func:`reweight_atoms` (chosen on the validation clips)
REWEIGHT_ALPHA = 1.0


def adapt_vectors_2d(lifter, X2, *, passes=1.0, memory=1.0, alpha=None, batch_size=256,
                     random_state=0, n_jobs=1):
    """A copy of a dictionary lifter whose atoms' 2D halves are adapted on X2.

    Parameters
    ----------
    lifter : DictionaryLifter
    X2 : ndarray (n, M)
        Normalised 2D EDM vectors of complete poses.
    passes, memory, batch_size, random_state, n_jobs
        As :func:`sparseedm.adaptation.adapt_vectors` (``stats="carried"``).
    alpha : float, optional
        Lasso penalty of the coding step; default the lifter's training
        ``alpha`` times the median 2D-half norm (the penalty its 2D codes saw).

    Returns
    -------
    DictionaryLifter
        A new lifter; the 3D halves and everything else are the base's.
    """
    C, m, X2 = _check(lifter, X2)
    norms = np.maximum(np.linalg.norm(C[:, :m], axis=1, keepdims=True), 1e-12)
    if alpha is None:
        alpha = float(lifter.alpha * np.median(norms))
    D2 = adapt_vectors(C[:, :m] / norms, X2, alpha, passes=passes, stats="carried",
                       memory=memory, batch_size=batch_size, random_state=random_state,
                       n_jobs=n_jobs)
    out = copy.deepcopy(lifter)
    out.components_ = np.hstack([D2 * norms, C[:, m:]])
    return out


def reweight_atoms(lifter, X2, *, gamma=0.5, alpha=REWEIGHT_ALPHA, clip=(0.1, 10.0)):
    """A copy of a dictionary lifter whose atoms are scaled by their usage on X2.

    Parameters
    ----------
    lifter : DictionaryLifter
    X2 : ndarray (n, M)
        Normalised 2D EDM vectors of complete poses.
    gamma : float
        Exponent of the relative usage (0: nothing changes).
    alpha : float, default REWEIGHT_ALPHA
        Lasso penalty of the usage codes (on unit-scale 2D EDM vectors; None:
        the lifter's ``alpha_lift``). Sparse codes (a large penalty) pick the
        poses' dominant atoms; measured best on the validation clips.
    clip : (low, high)
        Bounds of the scale factors.

    Returns
    -------
    DictionaryLifter
        Each atom ``[a_j ; b_j]`` scaled as a whole: its 2D : 3D pairing is kept.
    """
    C, m, X2 = _check(lifter, X2)
    a = lifter.alpha_lift if alpha is None else alpha
    usage = np.abs(sparse_code(X2, C[:, :m], a)).mean(axis=0)
    # smoothed: an unused atom counts as half an average one
    rel = (usage + usage.mean()) / max(2 * usage.mean(), 1e-12)
    g = np.clip(rel ** gamma, *clip)
    out = copy.deepcopy(lifter)
    out.components_ = C * g[:, None]
    return out


def masked_error_2d(lifter, poses2d, *, random_state=0, n_jobs=1):
    """Mean Mix Err_ave (%) of the 2D EDMs a dictionary lifter completes from occluded poses.

    The only score 3D-free poses allow: the protocol's seeded Mix masks
    (:func:`sparseedm.metrics.occlusion_masks`) occlude complete 2D poses,
    the lifter codes the observed entries and its 2D half (``vectors2d``) is
    compared with the true 2D EDM in the same normalisation. It says how well
    the 2D half fits the poses, not how well they lift.
    """
    poses2d = np.asarray(poses2d, float)
    mask = occlusion_masks(len(poses2d), poses2d.shape[1], ("mix",), random_state)["mix"]
    X2, _, _ = represent(poses2d, mask, "average")
    truth = pose_to_vector(normalize(poses2d, mask)[0])
    _, info = lifter.predict(X2, mask, n_jobs=n_jobs)
    e = err_ave(info["vectors2d"], truth)
    return float(np.nanmean(e))


def _check(lifter, X2):
    if getattr(lifter, "method", None) != "dictionary":
        raise LifterError(f"only a 'dictionary' lifter can be adapted on 2D poses, got "
                          f"{getattr(lifter, 'method', type(lifter).__name__)!r}")
    C = np.asarray(lifter.components_, float)
    m = C.shape[1] // 2
    X2 = np.asarray(X2, float)
    if X2.ndim != 2 or X2.shape[1] != m:
        raise PoseError(f"X2 must be (n, {m}) 2D EDM vectors, got {X2.shape}")
    return C, m, X2


def adapt_lifter(lifter, complete_poses2d, *, method=DEFAULT_LIFT_ADAPT["method"],
                 gamma=DEFAULT_LIFT_ADAPT["gamma"], passes=DEFAULT_LIFT_ADAPT["passes"],
                 memory=DEFAULT_LIFT_ADAPT["memory"], alpha=DEFAULT_LIFT_ADAPT["alpha"],
                 batch_size=DEFAULT_LIFT_ADAPT["batch_size"], max_poses=3000, random_state=0,
                 n_jobs=1):
    """A new dictionary lifter whose 2D half is adapted on complete 2D poses.

    Parameters
    ----------
    lifter : DictionaryLifter, shipped name or path
        The coupled-dictionary lifter to start from (``"default"``: the
        shipped one); it is not changed.
    complete_poses2d : array_like (n, N, 2)
        Pixels; rows with NaN, zero extent or exact repeats are ignored.
    method : {"reweight", "2d-half", "both"}
        :func:`reweight_atoms`, :func:`adapt_vectors_2d`, or the second then
        the first (``alpha`` is then the re-weighting's). ``"reweight"``
        lifted best on the validation clips of other sources than the
        lifter's, but most of its gain does not depend on the poses, and on
        poses from the lifter's own source it costs ~8 % (``"2d-half"``: ~1 %);
        see lifters/README.md.
    gamma : float
        See :func:`reweight_atoms` (``alpha`` is its coding penalty then,
        default ``REWEIGHT_ALPHA``).
    passes, memory, alpha, batch_size : float, int, float or None, int
        See :func:`adapt_vectors_2d`.
    max_poses : int, default 3000
        At most this many poses (a seeded sample) are used.
    random_state : int, default 0
        Seed of that sample and of the 2D half's learning.
    n_jobs : int, default 1
        Threads of the 2D half's coding step.

    Returns
    -------
    DictionaryLifter
        Saves and loads like any lifter; ``provenance_["adaptation"]`` says
        what was done.

    Raises
    ------
    LifterError
        A lifter that is not a coupled dictionary.
    PoseError
        Poses of another joint count, or no usable pose.

    Examples
    --------
    >>> import numpy as np, sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> poses = pose + np.random.default_rng(0).normal(0, 2, (200, 14, 2))
    >>> lifter = sparseedm.adapt_lifter("default", poses)
    >>> lifter.provenance_["adaptation"]["poses"]
    200
    >>> sparseedm.lift(poses[:3], lifter=lifter).status.tolist()
    ['lifted', 'lifted', 'lifted']
    """
    if method not in METHODS:
        raise LifterError(f"method must be one of {METHODS}, got {method!r}")
    lifter = load_lifter(lifter)
    poses = np.asarray(complete_poses2d, float)
    if poses.ndim != 3 or poses.shape[1:] != (lifter.n_joints, 2):
        raise PoseError(f"complete_poses2d must be (n, {lifter.n_joints}, 2), got {poses.shape}")
    poses = poses[usable_rows(poses)]
    X2 = pose_vectors(poses) if len(poses) else np.zeros((0, lifter.components_.shape[1] // 2))
    X2 = X2[~duplicate_rows(X2)]
    if len(X2) == 0:
        raise PoseError("complete_poses2d: no usable complete pose to adapt on")
    if len(X2) > max_poses:
        rng = np.random.default_rng([int(random_state or 0), 17])
        X2 = X2[np.sort(rng.choice(len(X2), max_poses, replace=False))]
    out, done = lifter, {}
    if method in ("2d-half", "both"):
        out = adapt_vectors_2d(out, X2, passes=passes, memory=memory,
                               alpha=None if method == "both" else alpha,
                               batch_size=batch_size, random_state=random_state,
                               n_jobs=n_jobs)
        done.update(passes=passes, memory=memory, seed=random_state)
    if method in ("reweight", "both"):
        out = reweight_atoms(out, X2, gamma=gamma,
                             alpha=REWEIGHT_ALPHA if alpha is None else alpha)
        done.update(gamma=gamma)
    out.provenance_ = dict(lifter.provenance_ or {})
    out.provenance_["adaptation"] = dict(done, method=method, poses=int(len(X2)), alpha=alpha)
    return out
