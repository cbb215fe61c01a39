"""3D joint coordinates from a 3D EDM: classical MDS, SMACOF, camera alignment, reflection.

A predicted 3D EDM fixes a pose only up to rotation, translation and
reflection. :func:`reconstruct` turns a batch of predicted EDMs into poses in
the camera's axes (x right, y down as the image, z away from the camera):

1. :func:`classical_mds` -- double centring of the squared EDM and the top
   three eigenvectors (Torgerson); exact when the EDM is Euclidean;
2. :func:`smacof` -- stress majorisation (Guttman transforms, unit weights)
   started from the MDS answer, so the coordinates fit the *predicted
   distances* (not their squares) in least squares; a predicted EDM is
   rarely exactly Euclidean. Batched over poses in numpy (scikit-learn's
   ``smacof`` is one pose per call);
3. :func:`align_to_image` -- the rotation that best agrees with the 2D input
   under a weak-perspective camera: the affine map from the centred 3D pose
   to the observed 2D joints, projected to a scaled orthonormal pair of axes
   (polar decomposition); the third axis is their cross product, up to sign;
4. the depth reflection: both signs project to the same 2D pose (the
   Necker ambiguity of weak perspective), so the 2D input cannot decide.
   :class:`ChiralityPrior` decides: a linear classifier on the signed volumes
   of the C(N, 4) joint tetrahedra (odd under reflection), trained on real
   poses against their mirror images; the sign it scores higher wins. Its
   margin says how sure the choice is (``|margin| < 1`` is counted as
   ambiguous). In a video, :func:`reflection_path` chooses the reflections of
   one person's frames together: the prior's odds per frame against how far
   each choice moves the joints from the frame before (a two-state Viterbi).

Examples
--------
>>> import numpy as np
>>> from sparseedm.edm import pose_to_edm
>>> X = np.random.default_rng(0).standard_normal((1, 6, 3))
>>> Y = classical_mds(pose_to_edm(X))
>>> bool(np.allclose(pose_to_edm(Y), pose_to_edm(X)))
True
"""

from __future__ import annotations

from functools import lru_cache
from itertools import combinations

import numba
import numpy as np

from .. import _progress

__all__ = ["classical_mds", "smacof", "align_to_image", "tetra_volumes",
           "ChiralityPrior", "reflections", "reconstruct", "reflection_path",
           "REFLECTION_SMOOTHNESS"]

#: weight of the motion between consecutive frames against the chirality
#: prior's log-odds in :func:`reflection_path`, per square metre of summed
#: squared joint displacement per frame; chosen on validation sequences of
#: two sources (docs/explanation/settings.md)
REFLECTION_SMOOTHNESS = 3.0


def classical_mds(edm, dim=3):
    """Coordinates (n, N, dim) whose distances best match `edm` (n, N, N) (Torgerson).

    Negative eigenvalues of the double-centred matrix (a non-Euclidean EDM)
    are clipped to 0.
    """
    edm = np.asarray(edm, dtype=float)
    squeeze = edm.ndim == 2
    if squeeze:
        edm = edm[None]
    N = edm.shape[-1]
    D2 = edm ** 2
    J = np.eye(N) - 1.0 / N
    B = -0.5 * J @ D2 @ J
    w, V = np.linalg.eigh(B)  # ascending
    w = np.clip(w[:, ::-1][:, :dim], 0, None)
    Y = V[:, :, ::-1][:, :, :dim] * np.sqrt(w)[:, None, :]
    return Y[0] if squeeze else Y


@numba.njit(cache=True, nogil=True)
def _smacof_one(E, Y, max_iter, tol):
    N = E.shape[0]
    D = np.empty((N, N))
    Z = np.empty_like(Y)
    old = -1.0
    for _ in range(max_iter):
        stress = 0.0
        for i in range(N):
            D[i, i] = 0.0
            for j in range(i + 1, N):
                s = 0.0
                for k in range(3):
                    t = Y[i, k] - Y[j, k]
                    s += t * t
                d = np.sqrt(s)
                D[i, j] = d
                D[j, i] = d
                stress += (d - E[i, j]) ** 2
        if old >= 0.0 and old - stress <= tol * old:
            break
        old = stress
        # Guttman transform: Z = B(Y) Y / N, B_ij = -E_ij / D_ij, B_ii = -sum_j B_ij
        for i in range(N):
            for k in range(3):
                Z[i, k] = 0.0
            for j in range(N):
                if j == i or D[i, j] <= 1e-12:
                    continue
                r = E[i, j] / D[i, j]
                for k in range(3):
                    Z[i, k] += r * (Y[i, k] - Y[j, k])
            for k in range(3):
                Z[i, k] /= N
        Y[:] = Z
    return Y


@numba.njit(cache=True, nogil=True)
def _smacof_batch(E, Y, max_iter, tol):
    for n in range(E.shape[0]):
        _smacof_one(E[n], Y[n], max_iter, tol)


#: Batches of fewer poses run the numpy forms of the compiled loops below (the
#: same arithmetic, to round-off), chosen by size only: a first ``lift`` of a
#: few poses then never waits for numba to compile (about 10-25 s on 2 cores).
NUMPY_MAX = 256


def _smacof_numpy(E, Y, max_iter, tol):
    """`_smacof_batch` written with numpy: every pose's Guttman transform at once,
    each pose stopping by the same rule."""
    N = Y.shape[1]
    iu, ju = np.triu_indices(N, 1)
    old = np.full(len(Y), -1.0)
    live = np.arange(len(Y))
    for _ in range(max_iter):
        diff = Y[live, :, None, :] - Y[live, None, :, :]  # (n, N, N, 3)
        D = np.sqrt((diff * diff).sum(axis=-1))
        stress = ((D[:, iu, ju] - E[live][:, iu, ju]) ** 2).sum(axis=1)
        prev = old[live]
        go = ~((prev >= 0.0) & (prev - stress <= tol * prev))
        old[live] = stress
        live, D, diff = live[go], D[go], diff[go]
        if not len(live):
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            R = np.where(D > 1e-12, E[live] / D, 0.0)
        Y[live] = (R[..., None] * diff).sum(axis=2) / N
    return Y


def smacof(edm, init, *, max_iter=30, tol=1e-4):
    """Stress majorisation from `init` (n, N, 3) towards the distances `edm` (n, N, N).

    Minimises ``sum_{i<j} (||y_i - y_j|| - edm_ij)^2`` per pose by Guttman
    transforms (unit weights: ``y_i <- sum_j edm_ij / d_ij (y_i - y_j) / N``,
    which never increases the stress); a pose stops when its relative stress
    decrease falls below `tol`. Compiled with numba (14 joints: tiny per-pose
    loops numpy cannot batch well) from :data:`NUMPY_MAX` poses up; smaller
    batches run the same steps in numpy. Returns the coordinates, centred.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.edm import pose_to_edm
    >>> X = np.random.default_rng(0).standard_normal((2, 14, 3))
    >>> Y = smacof(pose_to_edm(X), X + 0.1)
    >>> bool(np.abs(pose_to_edm(Y) - pose_to_edm(X)).max() < 0.05)
    True
    """
    edm = np.ascontiguousarray(edm, dtype=float)
    Y = np.array(init, dtype=float)
    Y -= Y.mean(axis=-2, keepdims=True)
    if len(Y) < NUMPY_MAX:  # by size only: an answer must not depend on cache state
        _smacof_numpy(edm, Y, int(max_iter), float(tol))
    else:
        _progress.jit(_smacof_batch, "3D lifting")
        _smacof_batch(edm, Y, int(max_iter), float(tol))
    return Y - Y.mean(axis=-2, keepdims=True)


def align_to_image(Y, P, observed):
    """Rotate centred 3D poses so their x, y agree with the 2D poses (weak perspective).

    Parameters
    ----------
    Y : ndarray (n, N, 3)
        3D poses (any rotation / reflection).
    P : ndarray (n, N, 2)
        2D poses (normalised image coordinates); only observed joints are read.
    observed : ndarray of bool (n, N)
        At least 3 observed joints per pose.

    Returns
    -------
    front, back : ndarray (n, N, 3)
        The two depth reflections of the aligned pose (``back`` is ``front``
        with z negated): x, y fit the observed 2D joints after translation,
        z centred.
    scale : ndarray (n,)
        The weak-perspective scale s with ``P ~ s * (x, y) + t``.
    """
    Y = np.asarray(Y, float)
    P = np.asarray(P, float)
    w = np.asarray(observed, float)[..., None]
    cnt = w.sum(axis=1, keepdims=True)
    Yc = Y - (w * Y).sum(axis=1, keepdims=True) / cnt
    Pc = np.where(w > 0, P - (w * np.nan_to_num(P)).sum(axis=1, keepdims=True) / cnt, 0.0)
    A = np.einsum("nji,njk->nik", w * Yc, Yc)  # Y^T W Y  (n,3,3)
    A += 1e-9 * np.trace(A, axis1=1, axis2=2)[:, None, None] * np.eye(3)
    Bm = np.einsum("nji,njk->nik", w * Yc, Pc)  # Y^T W P  (n,3,2)
    M = np.linalg.solve(A, Bm)  # (n,3,2) least-squares affine map
    U, S, Vt = np.linalg.svd(M, full_matrices=False)
    Q = U @ Vt  # nearest orthonormal pair of columns
    r3 = np.cross(Q[:, :, 0], Q[:, :, 1])
    R = np.concatenate([Q, r3[:, :, None]], axis=2)
    front = Y @ R
    front = front - front.mean(axis=1, keepdims=True)
    back = front * np.array([1.0, 1.0, -1.0])
    scale = S.mean(axis=1)
    return front, back, scale


@lru_cache(maxsize=8)
def _quads(n_joints):
    return np.array(list(combinations(range(n_joints), 4)), dtype=np.int64)


@numba.njit(cache=True, nogil=True)
def _volumes(X, quads, out):
    for n in range(X.shape[0]):
        for q in range(quads.shape[0]):
            a, b, c, d = quads[q, 0], quads[q, 1], quads[q, 2], quads[q, 3]
            u0, u1, u2 = X[n, b, 0] - X[n, a, 0], X[n, b, 1] - X[n, a, 1], X[n, b, 2] - X[n, a, 2]
            v0, v1, v2 = X[n, c, 0] - X[n, a, 0], X[n, c, 1] - X[n, a, 1], X[n, c, 2] - X[n, a, 2]
            w0, w1, w2 = X[n, d, 0] - X[n, a, 0], X[n, d, 1] - X[n, a, 1], X[n, d, 2] - X[n, a, 2]
            out[n, q] = u0 * (v1 * w2 - v2 * w1) - u1 * (v0 * w2 - v2 * w0) + u2 * (v0 * w1 - v1 * w0)


def tetra_volumes(poses):
    """Signed volumes of all C(N, 4) joint tetrahedra, size-normalised (n, C(N,4)).

    Odd under reflection (a mirrored pose has every sign flipped), invariant
    under rotation, translation and scale.
    """
    X = np.asarray(poses, float)
    lead = X.shape[:-2]
    X = X.reshape((-1,) + X.shape[-2:])
    X = X - X.mean(axis=-2, keepdims=True)
    size = np.sqrt((X ** 2).sum(axis=(-1, -2)) / X.shape[-2])
    X = np.ascontiguousarray(X / np.where(size > 0, size, 1.0)[:, None, None])
    q = _quads(X.shape[-2])
    if len(X) < NUMPY_MAX:  # the triple products u . (v x w) in numpy (no compile)
        a = X[:, q[:, 0]]
        u, v, w = X[:, q[:, 1]] - a, X[:, q[:, 2]] - a, X[:, q[:, 3]] - a
        out = np.einsum("nqk,nqk->nq", u, np.cross(v, w))
    else:
        out = np.empty((len(X), len(q)))
        _volumes(X, q, out)
    return out.reshape(lead + (len(q),))


class ChiralityPrior:
    """Which of a pose and its mirror image is a real human pose (linear, odd features).

    ``score(X) = coef . tetra_volumes(X)``; a mirrored pose scores ``-score``.
    Fitted by logistic regression (no intercept) on real 3D poses against
    their mirror images.

    Attributes
    ----------
    coef_ : ndarray (C(N, 4),)
    """

    def __init__(self, C=1.0):
        self.C = C

    def fit(self, poses3d, max_samples=20000, random_state=0):
        from sklearn.linear_model import LogisticRegression

        X = np.asarray(poses3d, float)
        if len(X) > max_samples:
            X = X[np.random.default_rng(random_state).choice(len(X), max_samples, replace=False)]
        V = tetra_volumes(X)
        clf = LogisticRegression(C=self.C, fit_intercept=False, max_iter=1000)
        clf.fit(np.concatenate([V, -V]), np.r_[np.ones(len(V)), np.zeros(len(V))])
        self.coef_ = clf.coef_[0].copy()
        return self

    def score(self, poses3d):
        """Decision value per pose: > 0 means 'real', < 0 'mirrored'."""
        return tetra_volumes(poses3d) @ self.coef_


def reflections(edm3, P, observed, chirality, *, smacof_iter=30):
    """Both depth reflections of the poses of predicted 3D EDMs, and the prior's score.

    Steps 1-3 of :func:`reconstruct`; arguments as there.

    Returns
    -------
    front, back : ndarray (n, N, 3)
        The two reflections (:func:`align_to_image`).
    score : ndarray (n,)
        The chirality prior's decision value of ``front`` (``back`` scores
        its negative); NaN without a prior.
    scale : ndarray (n,)
        Weak-perspective scale from the alignment.
    """
    edm3 = np.clip(np.asarray(edm3, float), 0, None)
    Y = smacof(edm3, classical_mds(edm3), max_iter=smacof_iter)
    front, back, scale = align_to_image(Y, P, observed)
    if chirality is None:
        return front, back, np.full(len(front), np.nan), scale
    coef = chirality.coef_ if isinstance(chirality, ChiralityPrior) else np.asarray(chirality)
    return front, back, tetra_volumes(front) @ coef, scale


def reconstruct(edm3, P, observed, chirality=None, *, smacof_iter=30):
    """3D poses in camera axes from predicted 3D EDMs and the 2D input.

    Parameters
    ----------
    edm3 : ndarray (n, N, N)
        Predicted 3D EDMs (negative entries are clipped to 0).
    P : ndarray (n, N, 2)
        The 2D poses (normalised coordinates), NaN allowed at unobserved joints.
    observed : ndarray of bool (n, N)
    chirality : ChiralityPrior or ndarray of coefficients, optional
        Decides the depth reflection; without it the ``front`` candidate of
        :func:`align_to_image` is kept.
    smacof_iter : int, default 30
        Most stress-majorisation iterations (:func:`smacof`) refining the
        classical-MDS embedding of each EDM.

    Returns
    -------
    poses : ndarray (n, N, 3)
        Centred, in the units of `edm3`, x/y along the image axes.
    margin : ndarray (n,)
        The chirality score of the chosen reflection (>= 0; NaN without a prior).
    scale : ndarray (n,)
        Weak-perspective scale from the alignment.
    """
    front, back, s, scale = reflections(edm3, P, observed, chirality, smacof_iter=smacof_iter)
    if chirality is None:
        return front, s, scale
    poses = np.where((s >= 0)[:, None, None], front, back)
    return poses, np.abs(s), scale


def reflection_path(front, back, score, frames, smoothness=REFLECTION_SMOOTHNESS):
    """The depth reflections of one person's frames, chosen together (Viterbi).

    Each frame has two candidate poses, mirror images in depth, and the
    chirality prior's log-odds `score` that ``front`` is the real one. Chosen
    frame by frame, a pose the prior misjudges flips in depth for a frame
    while the person barely moved. Here the whole path is chosen at once: it
    minimises the sum over frames of ``log(1 + exp(-/+score))`` (the prior's
    negative log-likelihood of the chosen side) plus, between consecutive
    frames, ``smoothness * sum_j ||p_j(t) - p_j(t-1)||^2 / (f(t) - f(t-1))``
    (a random walk of the joints: a flip moves every joint off the depth
    axis at once). Two states per frame, so the optimum is exact in O(T).

    Parameters
    ----------
    front, back : ndarray (T, N, 3)
        Candidates in metres (pelvis-centred), in frame order.
    score : ndarray (T,)
        Log-odds that ``front`` is the real pose.
    frames : ndarray of int (T,)
        Increasing frame numbers (a skipped frame weakens the link).
    smoothness : float, default REFLECTION_SMOOTHNESS
        0 chooses every frame by the sign of its score alone.

    Returns
    -------
    ndarray of bool (T,)
        True where ``back`` is chosen.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> front = rng.standard_normal((5, 14, 3)) * [0.3, 0.8, 0.2]
    >>> front = front[:1] + 0.01 * (front - front[:1])      # a person standing still
    >>> back = front * [1.0, 1.0, -1.0]
    >>> score = np.array([2.0, 1.5, -0.5, 2.5, 1.0])       # frame 2 misjudged
    >>> (score < 0).tolist(), reflection_path(front, back, score, np.arange(5)).tolist()
    ([False, False, True, False, False], [False, False, False, False, False])
    """
    score = np.asarray(score, float)
    T = len(score)
    if T == 0:
        return np.zeros(0, bool)
    unary = np.stack([np.logaddexp(0.0, -score), np.logaddexp(0.0, score)], axis=1)
    if smoothness <= 0 or T == 1:
        return unary[:, 1] < unary[:, 0]
    dt = np.maximum(np.diff(np.asarray(frames, float)), 1.0)
    # mirroring is an isometry: back->back moves as far as front->front, and
    # front->back as far as back->front
    same = ((front[1:] - front[:-1]) ** 2).sum(axis=(1, 2))
    cross = ((front[1:] - back[:-1]) ** 2).sum(axis=(1, 2))
    same, cross = smoothness * same / dt, smoothness * cross / dt
    cost = unary[0].copy()
    came = np.zeros((T, 2), dtype=np.int8)
    for t in range(1, T):
        stay0, switch0 = cost[0] + same[t - 1], cost[1] + cross[t - 1]
        stay1, switch1 = cost[1] + same[t - 1], cost[0] + cross[t - 1]
        came[t, 0], came[t, 1] = switch0 < stay0, switch1 < stay1
        cost = np.array([min(stay0, switch0) + unary[t, 0], min(stay1, switch1) + unary[t, 1]])
    path = np.zeros(T, bool)
    state = int(cost[1] < cost[0])
    for t in range(T - 1, -1, -1):
        path[t] = bool(state)
        if t and came[t, state]:
            state = 1 - state
    return path
