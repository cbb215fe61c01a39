"""Online dictionary learning (Mairal, Bach, Ponce, Sapiro 2009) over EDM vectors.

The learner is split into small steps, as scikit-learn's
``MiniBatchDictionaryLearning`` is:

* :func:`sparse_code` codes a mini-batch on the current dictionary (the certified
  LARS-lasso path of :mod:`sparseedm.solvers.fast` on the Gram matrix);
* :func:`update_inner_stats` accumulates ``A = sum c c^T`` and ``B = sum x c^T``;
* :func:`update_dictionary` runs one block-coordinate pass over the atoms,
  each projected back to the unit sphere; atoms no sample uses are re-drawn
  from the mini-batch;
* :func:`minibatch_step` is the three together; :class:`OnlineDictionaryLearning`
  is the thin estimator shell (``fit`` / ``partial_fit``, learned state in
  attributes ending in ``_``), and :func:`fit_dictionary_stream` drives it over a
  pose file with progress, checkpoints and resume.

Why not scikit-learn's MiniBatchDictionaryLearning as the engine
------------------------------------------------------------------
It implements the same algorithm, but at k = 2000 its per-batch cost is
dominated by its coding step (LassoLars refits per sample in Python) and by a
Python loop over the 2000 atoms; measured on ~46k poses at k = 300 it took
213 s for one pass. The steps here are the same maths with the coding done by
the batched Gram-matrix homotopy and the atom loop compiled, see
the documentation's speed results for the measured fit times against SPAMS' trainDL.

Objective: ``0.5 ||x - D c||^2 + alpha ||c||_1`` per sample (scikit-learn's and
SPAMS' convention; the paper's lambda is ``2 * alpha``).
"""

from __future__ import annotations

import hashlib
import json
import numbers
import warnings
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
from scipy import sparse

from . import _progress
from ._atomic import check_paths, save_npz
from ._parallel import numba_threads
from ._safeio import available_memory, load_npz
from ._validation import ALPHA, N_JOBS, Interval, validate_params
from .dictionary import Dictionary
from .exceptions import (DictionaryError, FileFormatError, OutputPathError, ParameterError,
                         SparseEDMError)
from .edm import pose_to_vector
from .keypoints import default_errors_path, read_keypoints, write_errors
from .normalize import normalize, usable_rows
from .skeleton import JOINT_NAMES
from .solvers.fast import lars_lasso_gram
from .solvers.gram import gram_matrix

__all__ = [
    "sparse_code",
    "update_inner_stats",
    "update_dictionary",
    "minibatch_step",
    "init_dictionary",
    "OnlineDictionaryLearning",
]


def sparse_code(X, components, alpha, *, positive=False, gram=None):
    """Lasso codes of the rows of X on the atoms (rows of `components`).

    Parameters
    ----------
    X : ndarray, shape (n_samples, n_features)
    components : ndarray, shape (n_components, n_features)
    alpha : float > 0
    positive : bool, default False
    gram : ndarray, shape (n_components, n_components), optional
        ``components @ components.T`` if already known; by default the
        process's (:func:`sparseedm.solvers.gram.gram_matrix`).

    Returns
    -------
    code : ndarray, shape (n_samples, n_components)
    """
    if gram is None:
        gram = gram_matrix(components.T)
    code, _ = lars_lasso_gram(gram, X @ components.T, alpha, positive=positive,
                              rank=components.shape[1])
    return code


def update_inner_stats(A, B, X, code, beta=1.0):
    """``A <- beta A + C^T C``, ``B <- beta B + X^T C`` in place (Mairal's A_t, B_t).

    `beta` < 1 down-weights the first, poorly coded batches (Mairal 2009, sec. 3.4).

    Parameters
    ----------
    A, B : ndarray
        Statistics, shapes (k, k) and (d, k), updated in place.
    X : ndarray, shape (b, d)
        The mini-batch.
    code : ndarray, shape (b, k)
        Its codes.
    beta : float
        Forgetting factor.
    """
    A *= beta
    B *= beta
    if 8 * np.count_nonzero(code) < code.size:  # sparse codes: add the non-zero products only
        S = sparse.csr_matrix(code)
        M = (S.T @ S).tocoo()
        A[M.row, M.col] += M.data
        B += (S.T @ X).T
    else:
        A += code.T @ code
        B += X.T @ code


@numba.njit(cache=True)
def _bcd_pass(C, A, B, used):
    # C (k, n_features): atoms as contiguous rows; one block-coordinate pass.
    # B is (n_features, k) as Mairal's; A symmetric, so A[:, j] == A[j].
    k, m = C.shape
    for j in range(k):
        ajj = A[j, j]
        if ajj < 1e-12:
            used[j] = False
            continue
        Da = np.zeros(m)  # D a_j over the atoms co-used with atom j (A is sparse)
        for l in range(k):
            a = A[j, l]
            if a != 0.0:
                for i in range(m):
                    Da[i] += a * C[l, i]
        norm = 0.0
        for i in range(m):
            C[j, i] += (B[i, j] - Da[i]) / ajj
            norm += C[j, i] * C[j, i]
        norm = np.sqrt(norm)
        if norm < 1e-12:
            used[j] = False
            continue
        for i in range(m):
            C[j, i] /= norm
        used[j] = True


def update_dictionary(components, A, B, X=None, random_state=None):
    """One block-coordinate pass over the atoms, in place (Mairal's Algorithm 2).

    Each atom j moves to ``d_j + (b_j - D a_j) / A_jj`` and is projected onto the
    unit sphere (atoms are kept at exactly unit norm). Atoms no sample has used
    yet (``A_jj == 0``) are re-drawn from the rows of X, as scikit-learn does.

    Returns the number of re-drawn atoms.

    Parameters
    ----------
    components : ndarray, shape (k, d)
        Atoms, updated in place.
    A, B : ndarray
        Sufficient statistics, shapes (k, k) and (d, k).
    X : ndarray, shape (b, d), optional
        Vectors to re-draw an unused atom from.
    random_state : int, Generator or SeedSequence, optional
        Seed of that draw.

    Returns
    -------
    ndarray, shape (k, d)
        `components`, updated.
    """
    C = np.ascontiguousarray(components)
    used = np.ones(C.shape[0], dtype=np.bool_)
    _progress.jit(_bcd_pass, "dictionary learning")
    _bcd_pass(C, np.ascontiguousarray(A), np.ascontiguousarray(B), used)
    components[:] = C
    n_unused = int((~used).sum())
    if n_unused and X is not None and len(X):
        rng = np.random.default_rng(random_state)
        rows = X[rng.integers(0, len(X), n_unused)]
        rows = rows + 0.01 * rng.standard_normal(rows.shape) * np.abs(rows).mean()
        components[~used] = rows / np.linalg.norm(rows, axis=1, keepdims=True)
    return n_unused


def minibatch_step(X, components, A, B, alpha, *, positive=False, beta=1.0,
                   random_state=None, gram=None):
    """Code one mini-batch, update A and B, then the atoms (all in place).

    `gram`: ``components @ components.T`` when the caller has it (a learning
    continued from a known dictionary, on its first step). Returns the
    batch's mean lasso objective at the codes (before the atom update), the
    quantity whose running average monitors convergence.

    Parameters
    ----------
    X : ndarray, shape (b, d)
        The mini-batch.
    components : ndarray, shape (k, d)
        Atoms, updated in place.
    A, B : ndarray
        Mairal's sufficient statistics, shapes (k, k) and (d, k), updated in place.
    alpha : float
        Lasso penalty of the coding step.
    positive : bool
        Non-negative codes.
    beta : float
        Forgetting factor applied to A and B before adding the batch.
    random_state : int, Generator or SeedSequence, optional
        Seed for re-drawing unused atoms.
    gram : ndarray, shape (k, k), optional
        ``components @ components.T`` if already known.

    Returns
    -------
    ndarray, shape (b, k)
        The batch's codes.
    """
    if gram is None:
        gram = components @ components.T
    code = sparse_code(X, components, alpha, positive=positive, gram=gram)
    R = X - code @ components
    objective = 0.5 * np.einsum("ij,ij->i", R, R) + alpha * np.abs(code).sum(axis=1)
    update_inner_stats(A, B, X, code, beta)
    update_dictionary(components, A, B, X, random_state)
    return float(objective.mean())


def init_dictionary(X, n_components, random_state=None):
    """Initial atoms: distinct random rows of X, unit-normalised.

    Raises SparseEDMError when X has fewer rows than atoms.

    Parameters
    ----------
    X : ndarray, shape (n, d)
        Training vectors.
    n_components : int
        Number of atoms k (at most the number of distinct rows).
    random_state : int, Generator or SeedSequence, optional
        Seed of the draw.

    Returns
    -------
    ndarray, shape (k, d)
        Unit-norm initial atoms.
    """
    X = np.asarray(X, dtype=float)
    if len(X) < n_components:
        raise SparseEDMError(
            f"too few training samples: {len(X)} for {n_components} atoms; "
            "give at least as many complete poses as atoms"
        )
    rng = np.random.default_rng(random_state)
    rows = X[rng.choice(len(X), n_components, replace=False)].copy()
    norms = np.linalg.norm(rows, axis=1, keepdims=True)
    if (norms == 0).any():
        raise SparseEDMError("training data contains all-zero EDM vectors")
    return rows / norms


def check_params(n_components, alpha, batch_size=1, n_passes=1, caller="fit", *,
                 random_state=None, n_jobs=None):
    """Refuse bad hyper-parameters up front, not after an hour."""
    validate_params(caller, dict(n_components=n_components, alpha=alpha,
                                 batch_size=batch_size, n_passes=n_passes,
                                 random_state=random_state, n_jobs=n_jobs), {
        "n_components": [Interval(numbers.Integral, 1, None)],
        "alpha": ALPHA,
        "batch_size": [Interval(numbers.Integral, 1, None)],
        "n_passes": [Interval(numbers.Real, 0, None, closed="neither")],
        "random_state": [Interval(numbers.Integral, 0, None), None],
        "n_jobs": N_JOBS,
    })
    free = available_memory()
    need = 3 * 8 * int(n_components) ** 2  # A (k x k), its Gram and a working copy
    if free is not None and need > free:
        raise ParameterError(
            f"{caller}: n_components={n_components} needs about {need / 2**30:.1f} GiB for "
            f"the k x k statistics and {free / 2**30:.1f} GiB is available; the shipped "
            "dictionaries have 2000 atoms")


class OnlineDictionaryLearning:
    """Mairal-style online dictionary learning, scikit-learn style.

    Parameters
    ----------
    n_components : int, default 2000
        Number of atoms k (the paper's 2000; 100-4000 are supported).
    alpha : float, default 1.6
        Lasso penalty of the coding step (``0.5||x - Dc||^2 + alpha||c||_1``);
        the default was chosen on a validation split of CMU clips
        (``docs/explanation/settings.md``): very sparse training codes recover best.
    batch_size : int, default 512
    n_passes : float, default 1
        Passes over the training data in :meth:`fit`.
    positive_code : bool, default False
        Restrict codes to be non-negative.
    random_state : int or None, default None
        Same seed and data give the identical dictionary.
    n_jobs : int or None, default None
        Threads for the coding step (numba); None keeps numba's default.

    Attributes
    ----------
    components_ : ndarray, shape (n_components, n_features)
        Unit-norm atoms (rows).
    inner_stats_ : tuple (A, B)
        Mairal's accumulated statistics, kept for :meth:`partial_fit`.
    n_steps_ : int
        Mini-batches processed.
    objective_ : list of float
        Mean lasso objective of each mini-batch at coding time.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = np.abs(rng.standard_normal((300, 10)))
    >>> odl = OnlineDictionaryLearning(n_components=20, alpha=0.1, batch_size=50,
    ...                                random_state=0).fit(X)
    >>> odl.components_.shape
    (20, 10)
    >>> bool(np.allclose(np.linalg.norm(odl.components_, axis=1), 1))
    True
    """

    def __init__(self, n_components=2000, *, alpha=1.6, batch_size=512, n_passes=1,
                 positive_code=False, random_state=None, n_jobs=None):
        self.n_components = n_components
        self.alpha = alpha
        self.batch_size = batch_size
        self.n_passes = n_passes
        self.positive_code = positive_code
        self.random_state = random_state
        self.n_jobs = n_jobs

    def _check_X(self, X):
        X = np.asarray(X, dtype=float)
        if X.ndim != 2:
            raise SparseEDMError(f"X must be 2-D (n_samples, n_features), got {X.shape}")
        if not np.isfinite(X).all():
            raise SparseEDMError("X contains NaN or inf; drop incomplete poses first")
        if hasattr(self, "components_") and X.shape[1] != self.components_.shape[1]:
            raise SparseEDMError(
                f"X has {X.shape[1]} features, the dictionary {self.components_.shape[1]}"
            )
        return X

    def _beta(self):
        # Mairal 2009 sec. 3.4: forget the early, poorly coded batches; the
        # same schedule as scikit-learn's MiniBatchDictionaryLearning.
        t, b = self.n_steps_, self.batch_size
        theta = (t + 1) * b if t < b - 1 else b**2 + t + 1 - b
        return (theta + 1 - b) / (theta + 1)

    def _init_state(self, X=None, components=None):
        """Fresh learner state; initial atoms drawn from X unless given."""
        check_params(self.n_components, self.alpha, self.batch_size, self.n_passes,
                     random_state=self.random_state, n_jobs=self.n_jobs)
        if components is None:
            components = init_dictionary(X, self.n_components, self._seed(0))
        self.components_ = components
        k, m = self.components_.shape
        self.inner_stats_ = (np.zeros((k, k)), np.zeros((m, k)))
        self.n_steps_ = 0
        self.objective_ = []

    def _seed(self, step):
        # one child seed per step: a resumed run draws the same numbers
        base = 0 if self.random_state is None else int(self.random_state)
        return np.random.SeedSequence([base, step])

    def _step(self, X_batch, gram=None):
        A, B = self.inner_stats_
        with numba_threads(self.n_jobs):
            obj = minibatch_step(
                X_batch, self.components_, A, B, self.alpha,
                positive=self.positive_code, beta=self._beta(),
                random_state=self._seed(self.n_steps_ + 1), gram=gram,
            )
        self.n_steps_ += 1
        self.objective_.append(obj)
        return obj

    def partial_fit(self, X):
        """Update the dictionary with one mini-batch X (n_samples, n_features)."""
        X = self._check_X(X)
        if not hasattr(self, "components_"):
            self._init_state(X)
        self._step(X)
        return self

    def fit(self, X, y=None):
        """Learn the dictionary from X (n_samples, n_features) in `n_passes` passes."""
        X = self._check_X(X)
        self._init_state(X)
        total = int(np.ceil(self.n_passes * -(-len(X) // self.batch_size)))
        for batch in _progress.steps(
                iter_batches(len(X), self.batch_size, self.n_passes, self.random_state),
                f"learning {self.n_components:,} atoms from {len(X):,} samples "
                f"({total:,} mini-batches)", total=total, unit="batch"):
            self._step(X[batch])
        return self

    def transform(self, X):
        """Lasso codes of X on the learned atoms."""
        X = self._check_X(X)
        return sparse_code(X, self.components_, self.alpha, positive=self.positive_code)


def iter_batches(n_samples, batch_size, n_passes=1, random_state=None, start=0):
    """Index arrays of the mini-batches of a seeded multi-pass schedule.

    Pass p visits a permutation drawn from ``(random_state, p)``, so the
    schedule is a pure function of its arguments and ``start`` (batches to
    skip) resumes it exactly.

    Examples
    --------
    >>> [b.tolist() for b in iter_batches(5, 2, 1, random_state=0)]
    [[4, 2], [3, 1], [0]]
    """
    per_pass = -(-n_samples // batch_size)
    total = int(np.ceil(n_passes * per_pass))
    base = 0 if random_state is None else int(random_state)
    perm = None
    for b in range(start, total):
        p, i = divmod(b, per_pass)
        if perm is None or i == 0 or b == start:
            perm = np.random.default_rng([base, 1_000_003, p]).permutation(n_samples)
        yield perm[i * batch_size:(i + 1) * batch_size]


# --------------------------------------------------------------------------
# Streaming fit over a pose file, with checkpoints and resume
# --------------------------------------------------------------------------

def complete_pose_vectors(poses2d):
    """Normalised EDM vectors of complete 2D poses, and which rows were usable.

    Rows with NaN/inf coordinates or zero extent are left out (fitting needs
    complete poses); the boolean mask says which rows were kept.
    """
    poses2d = np.asarray(poses2d, dtype=float)
    ok = usable_rows(poses2d)
    normed, _, _ = normalize(poses2d[ok])
    return pose_to_vector(normed), ok


def poses_sha256(poses):
    """sha256 of the training poses' float64 values (C order): the same poses
    give the same hash however the file was zipped (zip headers hold times)."""
    return hashlib.sha256(np.ascontiguousarray(poses, dtype=np.float64).tobytes()).hexdigest()


class TrainingPoses(NamedTuple):
    """What :func:`load_training_poses` reads."""

    #: (n, N, 2) poses, NaN where a joint was not seen
    poses: np.ndarray
    #: (n,) each pose's id (image or frame) in a keypoint file; None for a training set
    ids: np.ndarray | None
    #: ``(file, reason)`` of each file of a folder of frames that could not be read
    skipped: list


def load_training_poses(path, input_format=None, joint_map=None):
    """The 2D poses a dictionary learns from, NaN where a joint was not seen.

    A training ``.npz`` holding ``poses2d`` (``sparseedm dataset build``), or
    any keypoint file or folder :func:`sparseedm.keypoints.read_keypoints`
    reads (COCO JSON, OpenPose, MMPose, AlphaPose, DeepLabCut, PoseTrack,
    CSV...): its missing joints, and any a previous recovery filled, are NaN,
    so only the complete poses are learned from.

    Parameters
    ----------
    path : str or path
    input_format : str, optional
        The keypoint format (``read_keypoints``' `format`); given, `path` is
        read as keypoints even when it is an ``.npz``, except ``"npz"``: a
        training set or a keypoint ``.npz``, whatever the name.
    joint_map : str or path, optional
        DeepLabCut only: the joints map file.

    Returns
    -------
    TrainingPoses
        The poses, their ids and the files of a folder of frames (OpenPose,
        MMPose) that could not be read (skipped with a warning).

    Raises
    ------
    FileFormatError
        An ``.npz`` that is neither a training set nor a keypoint file, or an
        unreadable keypoint file (the reader's message).
    """
    if input_format == "npz" or (input_format is None and Path(path).suffix.lower() == ".npz"):
        arrays, names = load_npz(path, ("poses2d",), what=f"{path}: cannot read training file:")
        if "poses2d" in arrays:
            poses = arrays["poses2d"]
            if poses.dtype.kind not in "fiu":
                raise FileFormatError(f"{path}: poses2d must hold real numbers, got "
                                      f"{poses.dtype}")
            if poses.ndim != 3 or poses.shape[-1] != 2:
                raise FileFormatError(f"{path}: poses2d must be (n, N, 2), got {poses.shape}")
            return TrainingPoses(poses, None, [])
        try:
            kps = read_keypoints(path, format=input_format, joint_map=joint_map)
        except FileFormatError as err:
            raise FileFormatError(
                f"{path}: neither a training set (no 'poses2d' array; has: "
                f"{', '.join(names)}; build one with `sparseedm dataset build`) nor a "
                f"keypoint file ({err})") from None
    else:
        kps = read_keypoints(path, format=input_format, joint_map=joint_map)
    unseen = kps.missing if kps.filled is None else kps.missing | kps.filled
    return TrainingPoses(np.where(unseen[..., None], np.nan, np.asarray(kps.poses, float)),
                         kps.ids, list((kps.meta or {}).get("skipped") or []))


def refused_training_rows(poses):
    """Each pose's refusal as training input (:data:`sparseedm.recovery.STATUSES`'
    names): ``invalid_coordinates`` (a seen joint with an infinite coordinate),
    ``degenerate`` or ``out_of_range`` (a complete pose that
    :func:`sparseedm.normalize.usable_rows` refuses); ``""`` for the other
    poses, incomplete ones included (not learned from, not refused).

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Poses as :func:`load_training_poses` gives them (NaN: not seen).

    Returns
    -------
    status, reason : ndarray of str (n,)

    Examples
    --------
    >>> p = np.random.default_rng(0).random((4, 14, 2))
    >>> p[1, 2, 0] = np.inf; p[2] = 0.5; p[3, 4] = np.nan
    >>> refused_training_rows(p)[0].tolist()
    ['', 'invalid_coordinates', 'degenerate', '']
    """
    n = len(poses)
    status, reason = np.full(n, "", dtype=object), np.full(n, "", dtype=object)
    bad = np.isinf(poses).any(axis=(1, 2))
    status[bad] = "invalid_coordinates"
    reason[bad] = "a seen joint has an infinite coordinate"
    whole = np.flatnonzero(~bad & ~np.isnan(poses).any(axis=(1, 2)))
    unusable = whole[~usable_rows(poses[whole])]
    flat = np.ptp(poses[unusable], axis=1).max(axis=-1) == 0
    status[unusable[flat]] = "degenerate"
    reason[unusable[flat]] = "all joints coincide"
    status[unusable[~flat]] = "out_of_range"
    reason[unusable[~flat]] = ("the joints' extent overflows float64 or is subnormal (rescale "
                               "them), or one joint lies so far from the others that their "
                               "distances vanish in float64 rounding (not a body)")
    return status.astype(str), reason.astype(str)


def training_errors(train, errors_path):
    """Write the errors file of a training file read by :func:`load_training_poses`
    (:func:`sparseedm.keypoints.write_errors`, as ``sparseedm recover``'s): its
    refused rows (:func:`refused_training_rows`) and unreadable frame files; and
    say them in a dictionary's provenance.

    Parameters
    ----------
    train : TrainingPoses
    errors_path : path
        Where the errors file goes (a stale one there is removed when there is
        nothing to list).

    Returns
    -------
    dict
        The provenance entries: ``skipped_files`` (the unreadable files' names)
        and ``refused_rows`` (how many rows were refused), each when there are any.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "d.errors.csv"
    >>> training_errors(TrainingPoses(np.ones((1, 14, 2)), None, [("f9.json", "bad")]), path)
    {'skipped_files': ['f9.json'], 'refused_rows': 1}
    """
    status, reason = refused_training_rows(train.poses)
    refused = status != ""
    write_errors(errors_path, refused, train.ids, status, reason, train.skipped)
    said = {"skipped_files": [str(name) for name, _ in train.skipped],
            "refused_rows": int(refused.sum())}
    return {key: value for key, value in said.items() if value}


def fit_dictionary_file(train_path, output, *, n_components=2000, alpha=1.6,
                        batch_size=512, n_passes=2.0, positive_code=False,
                        random_state=0, n_jobs=None, alpha_recover=0.002,
                        alpha_scaling="entries", checkpoint=None,
                        checkpoint_every=20, resume=False, progress=True,
                        joint_names=None, input_format=None, joint_map=None,
                        errors_path=None):
    """Learn a dictionary from the complete poses of a training .npz or keypoint file; save it.

    `train_path` is read by :func:`load_training_poses` (with `input_format`
    and `joint_map`): a training set's ``poses2d``, or the complete poses of
    a keypoint file of real people (a detector's output, an annotated set).
    Files of a folder of frames that cannot be read are skipped with a
    warning; they and the rows refused as bad input
    (:func:`refused_training_rows`: an infinite coordinate, a degenerate or
    out-of-range pose) are listed in an errors file, as ``sparseedm
    recover``'s (`errors_path`, default ``<output stem>.errors.csv``, written
    with the dictionary, only when there is something to list), and counted in
    the dictionary's provenance (``skipped_files``, ``refused_rows``).

    Two passes over the poses by default (``sparseedm fit``'s and every
    shipped dictionary's setting: a lower held-out error than one,
    ``benchmarks/README.md``).

    Only one mini-batch of EDM vectors exists at a time beyond the input
    array itself. Every `checkpoint_every` batches the learner's whole state
    is written atomically to `checkpoint` (default ``OUTPUT.ckpt.npz``);
    ``resume=True`` continues from it and ends in the same dictionary as an
    uninterrupted run with the same seed; a checkpoint made with other
    settings or on other training poses (their sha256 is stored in it) is
    refused.

    Returns
    -------
    Dictionary
    """
    check_params(n_components, alpha, batch_size, n_passes, caller="fit_dictionary_file",
                 random_state=random_state, n_jobs=n_jobs)
    validate_params("fit_dictionary_file", dict(train_path=train_path, output=output,
                                                checkpoint=checkpoint,
                                                alpha_recover=alpha_recover,
                                                errors_path=errors_path),
                    {"train_path": ["path"], "output": ["path"],
                     "checkpoint": ["path", None], "alpha_recover": ALPHA,
                     "errors_path": ["path", None]})
    output = Path(output)
    if output.suffix != ".npz":
        raise DictionaryError(f"{output}: a dictionary file must end in .npz")
    checkpoint = Path(checkpoint) if checkpoint else output.with_suffix(".ckpt.npz")
    if checkpoint.suffix != ".npz":
        raise OutputPathError(f"checkpoint {checkpoint}: a checkpoint file must end in .npz")
    errors_path = default_errors_path(output) if errors_path is None else Path(errors_path)
    check_paths([("training file", train_path)],
                [("output", output), ("checkpoint", checkpoint), ("errors file", errors_path)])
    train = load_training_poses(train_path, input_format, joint_map)
    poses = train.poses
    ok = usable_rows(poses)
    if (~ok).any():
        warnings.warn(
            f"{train_path}: skipped {int((~ok).sum())} of {len(poses)} poses that are "
            "incomplete (a joint missing, NaN/inf or filled by a recovery) or degenerate "
            "(no extent, or too large to measure); "
            "fitting needs complete poses",
            stacklevel=2,
        )
    index = np.flatnonzero(ok)
    if len(index) < n_components:
        raise SparseEDMError(_too_few(train_path, len(index), n_components))
    params = dict(n_components=n_components, alpha=alpha, batch_size=batch_size,
                  n_passes=n_passes, positive_code=positive_code,
                  random_state=random_state, n_samples=len(index),
                  sha256=poses_sha256(poses))  # a resume continues on the same poses
    est = OnlineDictionaryLearning(
        n_components, alpha=alpha, batch_size=batch_size, n_passes=n_passes,
        positive_code=positive_code, random_state=random_state, n_jobs=n_jobs)
    start = 0
    if resume and checkpoint.is_file():
        start = _load_checkpoint(checkpoint, est, params)
    else:
        # initial atoms: random complete poses, drawn from a fixed seed
        rng = np.random.default_rng([0 if random_state is None else random_state, 7])
        pick = np.sort(rng.choice(index, n_components, replace=False))
        X0, _ = complete_pose_vectors(poses[pick])
        est._init_state(components=X0 / np.linalg.norm(X0, axis=1, keepdims=True))
    _fit_batches_inplace(est, poses, index, start, checkpoint, checkpoint_every, params, progress)
    provenance = {
        "files": [Path(train_path).name],
        "n_poses": int(len(index)),
        "sha256": params["sha256"],
        "sha256_of": "poses2d float64 values",
        "seed": random_state,
        "passes": n_passes,
        "batch_size": batch_size,
        "n_steps": est.n_steps_,
        **training_errors(train, errors_path),  # the errors file, written with the dictionary
    }
    dictionary = Dictionary(
        components=est.components_,
        joint_names=tuple(joint_names or JOINT_NAMES),
        alpha_recover=alpha_recover,
        alpha_train=alpha,
        alpha_scaling=alpha_scaling,
        positive_code=positive_code,
        provenance=provenance,
    )
    dictionary.save(output)
    if checkpoint.is_file():
        checkpoint.unlink()
    return dictionary


def _too_few(train_path, n_complete, n_components):
    """What :func:`fit_dictionary_file` says when `train_path` has fewer complete poses
    than atoms: what is missing, and what to do instead."""
    if n_complete == 0:
        return (f"{train_path}: no complete pose to learn from (every pose has a joint "
                "missing, out of range or filled by a recovery); a dictionary is learned "
                "only from poses with all their joints seen")
    return (f"{train_path}: {n_complete} complete poses are too few for {n_components} "
            f"atoms (one pose per atom at least): learn {n_complete} atoms or fewer "
            f"(n_components= / --atoms {n_complete}), or fine-tune an existing dictionary "
            "on them (fine_tune_file / --init default)")


def _fit_batches_inplace(est, poses, index, start, checkpoint, checkpoint_every, params, progress):
    """The mini-batch steps of :func:`fit_dictionary_file` over ``poses[index]``
    from batch `start`, taken by the learner `est` in place; its state is
    checkpointed every `checkpoint_every` batches."""
    from tqdm.auto import tqdm

    batch_size, n_passes = params["batch_size"], params["n_passes"]
    per_pass = -(-len(index) // batch_size)
    total = int(np.ceil(n_passes * per_pass))
    if not progress:  # else the bar says it
        _progress.say(f"learning {est.n_components:,} atoms from {len(index):,} poses: "
                      f"{total - start:,} mini-batches of {batch_size}")
    bar = tqdm(total=total, initial=start, disable=not progress, unit="batch",
               desc="fit", dynamic_ncols=True)
    try:
        for b, batch in enumerate(iter_batches(len(index), batch_size, n_passes,
                                               params["random_state"], start=start),
                                 start=start):
            X, _ = complete_pose_vectors(poses[index[np.sort(batch)]])
            obj = est._step(X)
            bar.update(1)
            bar.set_postfix(objective=f"{obj:.4g}", refresh=False)
            if (b + 1) % checkpoint_every == 0 and b + 1 < total:
                _save_checkpoint(checkpoint, est, params)
    finally:
        bar.close()


def _save_checkpoint(path, est, params):
    A, B = est.inner_stats_
    save_npz(path, dict(components=est.components_, A=A, B=B,
                        n_steps=np.array(est.n_steps_), objective=np.array(est.objective_),
                        params=np.array(json.dumps(params, sort_keys=True))))


def _load_checkpoint(path, est, params):
    try:
        ck, _ = load_npz(path, ("components", "A", "B", "n_steps", "objective", "params"))
        saved = json.loads(str(ck["params"]))
        sha = saved.get("sha256") if isinstance(saved, dict) else None
        if sha != params["sha256"]:
            raise SparseEDMError(
                f"{path}: checkpoint was made on other training poses (sha256 "
                f"{str(sha)[:12]}..., "
                f"this file's {params['sha256'][:12]}...); rerun without --resume")
        if saved != json.loads(json.dumps(params)):
            raise SparseEDMError(
                f"{path}: checkpoint was made with other settings {saved}; "
                "rerun without --resume or with the same settings"
            )
        est.components_ = ck["components"].copy()
        est.inner_stats_ = (ck["A"].copy(), ck["B"].copy())
        est.n_steps_ = int(ck["n_steps"])
        est.objective_ = ck["objective"].tolist()
    except SparseEDMError:
        raise
    except Exception as exc:  # corrupt checkpoint: say so, do not guess
        raise SparseEDMError(f"{path}: unreadable checkpoint ({exc})") from None
    return est.n_steps_
