"""Baselines the sparse recovery is measured against (see :mod:`sparseedm.evaluation`).

Every baseline takes poses ``(n, N, 2)`` in pixels with a boolean mask of
occluded joints ``(n, N)`` and returns a :class:`BaselineResult` shaped like
:class:`sparseedm.recovery.RecoveryResult`: completed EDM vectors in
normalised units (pixel distances are ``vectors * scale``) and filled poses in
pixels, observed joints exactly as given.

``mean-fill``
    The occlusion representation as is, no recovery. ``"average"``: occluded
    joints at the mean of the observed ones; its EDM is the filled pose's EDM.
    ``"zero"``: occluded joints at the origin of the normalised frame (the
    centre of the observed bounding box) and their EDM entries 0, as the
    paper's zero representation feeds them to a model.
``knn`` / ``iterative``
    scikit-learn's ``KNNImputer`` (5 neighbours, distance-weighted) and
    ``IterativeImputer`` (BayesianRidge, ``max_iter`` rounds) fitted on the
    training poses' normalised coordinates (2N-vectors, bounding box of all
    joints). At test time a pose is normalised by its observed joints, the
    occluded coordinates are imputed, and the result un-normalised. (When an
    extreme joint is occluded the observed box is smaller than the training
    poses' boxes: the same normalisation shift the sparse method suffers.)
``nearest``
    The nearest complete training pose on the observed part: for every
    training vector d, the observed EDM entries t of the test pose are compared
    after the best scale, ``min_s ||t - s d_obs||`` (the scale absorbs the shift
    of the normalisation when an extreme joint is occluded). The occluded EDM
    entries are taken from ``s * d`` of the neighbour (an Eq. 10-style merge)
    and the joints placed with :func:`sparseedm.placement.place_missing_joints`
    (unweighted residuals: the weights were chosen on the sparse method's answers).

The imputers and ``nearest`` read only the observed joints (through the mask),
so the ``"zero"``/``"average"`` choice does not change them.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np

from ._validation import check_pose_shape
from .edm import observed_entries, pose_to_vector, vector_to_edm
from .exceptions import SparseEDMError
from .learning import complete_pose_vectors
from .normalize import normalize, represent
from .placement import place_missing_joints

__all__ = ["BaselineResult", "mean_fill", "ImputerBaseline", "NearestNeighbourBaseline",
           "BASELINES", "fit_baseline"]

#: baseline name -> whether it needs training poses
BASELINES = {"mean-fill": False, "knn": True, "iterative": True, "nearest": True}


@dataclass
class BaselineResult:
    """What a baseline returns (the fields of RecoveryResult that evaluation reads).

    Attributes
    ----------
    poses : ndarray (n, N, 2)
        Filled poses in pixels; observed joints as given.
    vectors : ndarray (n, N(N-1)/2)
        Completed EDM vectors in normalised units.
    missing : ndarray of bool (n, N)
    center, scale : ndarray (n, 2), (n,)
        Normalisation by the observed joints: pixels = normalised * scale + center.
    status : ndarray of str (n,)
        "recovered" or "complete".
    seconds : float
    """

    poses: np.ndarray
    vectors: np.ndarray
    missing: np.ndarray
    center: np.ndarray
    scale: np.ndarray
    status: np.ndarray
    seconds: float = 0.0

    @property
    def ok(self) -> np.ndarray:
        return np.isin(self.status, ("recovered", "complete"))


def _status(missing):
    return np.where(missing.any(axis=1), "recovered", "complete")


def _observed_frame(poses, missing):
    """Poses and mask as arrays, and the poses normalised by their observed joints."""
    poses = np.asarray(poses, dtype=float)
    missing = np.asarray(missing, dtype=bool)
    clean = np.where(missing[..., None], np.nan, poses)
    normed, center, scale = normalize(clean, missing)
    return poses, missing, normed, center, scale


def mean_fill(poses, missing, representation="average"):
    """The occlusion representation itself, with no recovery.

    Examples
    --------
    >>> import numpy as np
    >>> pose = np.array([[0., 0.], [4., 0.], [0., 2.], [9., 9.]])
    >>> res = mean_fill(pose[None], np.array([[False, False, False, True]]))
    >>> res.poses[0, 3].round(4).tolist()
    [1.3333, 0.6667]
    """
    t0 = time.perf_counter()
    poses = np.asarray(poses, dtype=float)
    missing = np.asarray(missing, dtype=bool)
    vectors, center, scale = represent(np.where(missing[..., None], np.nan, poses),
                                       missing, representation)
    if representation == "average":
        n_obs = (~missing).sum(axis=1)
        mean = np.where(missing[..., None], 0.0, poses).sum(axis=1) / n_obs[:, None]
        filled = np.where(missing[..., None], mean[:, None, :], poses)
    else:  # the normalised origin: the centre of the observed bounding box
        filled = np.where(missing[..., None], center[:, None, :], poses)
    return BaselineResult(filled, vectors, missing, center, scale, _status(missing),
                          time.perf_counter() - t0)


def _complete_training(train_poses2d, max_train, random_state):
    train = np.asarray(train_poses2d, dtype=float)
    check_pose_shape(train, "training poses")
    _, ok = complete_pose_vectors(train)
    train = train[ok]
    if len(train) == 0:
        raise SparseEDMError("no complete training poses for the baselines")
    if max_train is not None and len(train) > max_train:
        rng = np.random.default_rng([0 if random_state is None else random_state, 11])
        train = train[np.sort(rng.choice(len(train), max_train, replace=False))]
    return train


class ImputerBaseline:
    """scikit-learn imputer on normalised joint coordinates.

    Parameters
    ----------
    kind : {"knn", "iterative"}
    max_train : int, default 20000
        Training poses kept (a seeded subsample beyond that).
    n_neighbors : int, default 5
        For "knn".
    max_iter : int, default 10
        For "iterative" (BayesianRidge rounds, run in full: ``tol=0``).
    random_state : int, default 0
    """

    def __init__(self, kind="knn", *, max_train=20000, n_neighbors=5, max_iter=10,
                 random_state=0):
        self.kind = kind
        self.max_train = max_train
        self.n_neighbors = n_neighbors
        self.max_iter = max_iter
        self.random_state = random_state

    def fit(self, train_poses2d):
        t0 = time.perf_counter()
        train = _complete_training(train_poses2d, self.max_train, self.random_state)
        normed, _, _ = normalize(train)
        X = normed.reshape(len(train), -1)
        if self.kind == "knn":
            from sklearn.impute import KNNImputer

            imp = KNNImputer(n_neighbors=min(self.n_neighbors, len(X)), weights="distance")
        elif self.kind == "iterative":
            from sklearn.experimental import enable_iterative_imputer  # noqa: F401
            from sklearn.impute import IterativeImputer
            from sklearn.linear_model import BayesianRidge

            # tol=0: all rounds are kept, so transform refines the occluded
            # joints max_iter times (training data are complete, so fitting
            # would otherwise stop after one round)
            imp = IterativeImputer(estimator=BayesianRidge(), max_iter=self.max_iter, tol=0,
                                   random_state=self.random_state)
        else:
            raise SparseEDMError(f"unknown imputer {self.kind!r}; use 'knn' or 'iterative'")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            imp.fit(X)
        self.imputer_ = imp
        self.n_train_ = len(X)
        self.n_joints_ = train.shape[1]
        self.fit_seconds_ = time.perf_counter() - t0
        return self

    def complete(self, poses, missing):
        t0 = time.perf_counter()
        poses, missing, normed, center, scale = _observed_frame(poses, missing)
        X = np.where(missing[..., None], np.nan, normed).reshape(len(poses), -1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            Xf = self.imputer_.transform(X) if len(X) else X
        filled_n = np.where(missing[..., None], Xf.reshape(normed.shape), normed)
        vectors = pose_to_vector(filled_n)
        filled = filled_n * scale[:, None, None] + center[:, None, :]
        filled = np.where(missing[..., None], filled, poses)
        return BaselineResult(filled, vectors, missing, center, scale, _status(missing),
                              time.perf_counter() - t0)


class NearestNeighbourBaseline:
    """Nearest complete training pose on the observed EDM entries (scale-invariant).

    Parameters
    ----------
    max_train : int, default 20000
    chunk_size : int, default 256
        Test poses compared at once (memory ~ chunk_size * max_train floats).
    random_state : int, default 0
    """

    def __init__(self, *, max_train=20000, chunk_size=256, random_state=0):
        self.max_train = max_train
        self.chunk_size = chunk_size
        self.random_state = random_state

    def fit(self, train_poses2d):
        t0 = time.perf_counter()
        train = _complete_training(train_poses2d, self.max_train, self.random_state)
        self.vectors_, _ = complete_pose_vectors(train)
        self.n_train_ = len(self.vectors_)
        self.fit_seconds_ = time.perf_counter() - t0
        return self

    def complete(self, poses, missing):
        t0 = time.perf_counter()
        poses, missing, normed, center, scale = _observed_frame(poses, missing)
        T = pose_to_vector(np.where(missing[..., None], 0.0, normed))
        vectors = T.copy()
        todo = np.flatnonzero(missing.any(axis=1))
        D = self.vectors_
        patterns, inverse = np.unique(missing[todo], axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        for p, pattern in enumerate(patterns):
            obs = observed_entries(pattern)
            D_obs = D[:, obs]
            dd = np.einsum("ij,ij->i", D_obs, D_obs)
            rows_all = todo[inverse == p]
            for start in range(0, len(rows_all), self.chunk_size):
                rows = rows_all[start:start + self.chunk_size]
                t = T[rows][:, obs]
                cross = t @ D_obs.T  # (b, n_train)
                # ||t - s d||^2 at the best s = <t,d>/<d,d>, up to the constant ||t||^2
                best = np.argmax(cross**2 / dd, axis=1)
                s = cross[np.arange(len(rows)), best] / dd[best]
                merged = s[:, None] * D[best]
                merged[:, obs] = T[rows][:, obs]  # Eq. 10-style merge
                vectors[rows] = merged
        filled = poses.copy()
        counts = missing.sum(axis=1)
        for c in np.unique(counts[todo]):
            rows = todo[counts[todo] == c]
            # unweighted, as when this baseline was set up: the residual weights
            # of sparseedm.placement were chosen on the sparse method's answers
            P = place_missing_joints(normed[rows], vector_to_edm(vectors[rows]), missing[rows],
                                     weight_power=0.0)
            out = filled[rows]
            out[missing[rows]] = (P * scale[rows, None, None] + center[rows, None, :]).reshape(-1, 2)
            filled[rows] = out
        return BaselineResult(filled, vectors, missing, center, scale, _status(missing),
                              time.perf_counter() - t0)


def fit_baseline(name, train_poses2d, *, max_train=20000, random_state=0):
    """A fitted baseline object with ``complete(poses, missing)`` for a trained baseline."""
    if name in ("knn", "iterative"):
        return ImputerBaseline(name, max_train=max_train,
                               random_state=random_state).fit(train_poses2d)
    if name == "nearest":
        return NearestNeighbourBaseline(max_train=max_train,
                                        random_state=random_state).fit(train_poses2d)
    raise SparseEDMError(
        f"unknown baseline {name!r}; trained baselines: knn, iterative, nearest"
    )
