"""Place occluded joints from their recovered distances (beyond the paper).

Given the observed joints' coordinates and a completed EDM, each occluded
joint is put where its distances to the observed joints (and to the other
occluded joints) best match the EDM, by least squares:

1. a closed-form start per joint: linearised trilateration, subtracting the
   mean of the equations ``||p - q_i||^2 = d_i^2`` to cancel ``||p||^2``;
2. a few damped Gauss-Newton steps on all occluded joints of the pose together,
   over the residuals ``||p_j - q_i|| - d_ij`` and ``||p_j - p_l|| - d_jl``,
   each weighted by its target distance ``d`` to the power ``weight_power``.
   A step is taken only where it lowers that cost (else halved, or not
   taken), and a start is first pulled into the disc the joint can reach from
   the anchors: nearly collinear observed joints make the linearisation
   ill-posed, and without these guards a joint could land hundreds of body
   sizes away while its pose read as recovered.

The weight (default ``d``: long distances count more) was chosen on
validation poses; the sparse method (:func:`sparseedm.recover`) places with
these weights, while the ``nearest`` baseline and the FConv recovery, whose
answers they were not chosen on, pass ``weight_power=0``. The figures are in
the documentation, ``docs/explanation/settings.md`` ("Placement weighting").

Everything is batched over poses that share a missing pattern.
"""

from __future__ import annotations

import numpy as np

__all__ = ["place_missing_joints"]


def _trilaterate(anchors, dist):
    # anchors (n, a, 2), dist (n, a) -> (n, 2)
    q_bar = anchors.mean(axis=1, keepdims=True)
    Q = anchors - q_bar
    sq = (anchors**2).sum(-1)
    rhs = -0.5 * ((dist**2 - (dist**2).mean(axis=1, keepdims=True))
                  - (sq - sq.mean(axis=1, keepdims=True)))
    M = np.einsum("nai,naj->nij", Q, Q) + 1e-9 * np.eye(2)
    b = np.einsum("nai,na->ni", Q, rhs)
    return np.linalg.solve(M, b[..., None])[..., 0]


#: residual weight = target distance ** WEIGHT_POWER (see the module docstring)
WEIGHT_POWER = 1.0


def place_missing_joints(poses, edm, missing, n_iter=10, weight_power=WEIGHT_POWER):
    """Coordinates of the missing joints that best fit the distances in `edm`.

    Parameters
    ----------
    poses : ndarray, shape (n, N, 2)
        Observed joints' coordinates (values at missing joints are ignored).
    edm : ndarray, shape (n, N, N)
        Completed distance matrices, in the same units as `poses`.
    missing : ndarray of bool, shape (n, N)
        The joints to place; every pose must miss the same *number* of
        joints (patterns may differ), at least one, leaving at least 3.
    n_iter : int, default 10
        Gauss-Newton steps.
    weight_power : float, default :data:`WEIGHT_POWER`
        Each residual is weighted by its target distance to this power
        (0: unweighted least squares).

    Returns
    -------
    placed : ndarray, shape (n, M, 2)
        The M missing joints of each pose, in joint order.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.edm import pose_to_edm
    >>> pose = np.array([[[0., 0.], [4., 0.], [0., 3.], [1., 1.]]])
    >>> placed = place_missing_joints(pose, pose_to_edm(pose), [[False, False, False, True]])
    >>> placed.round(6).tolist()
    [[[1.0, 1.0]]]
    """
    if not (np.isfinite(weight_power) and weight_power >= 0):
        raise ValueError(f"weight_power must be a finite number >= 0, got {weight_power!r}")
    poses = np.asarray(poses, dtype=float)
    missing = np.asarray(missing, dtype=bool)
    n, N, _ = poses.shape
    counts = missing.sum(axis=1)
    M = int(counts[0]) if n else 0
    if n == 0 or M == 0:
        return np.zeros((n, M, 2))
    if (counts != M).any():
        raise ValueError("every pose of a placement batch must miss the same number of joints")
    miss, anchors, d_mo, d_mm = _gather(poses, edm, missing)
    P = np.stack([_trilaterate(anchors, d_mo[:, j]) for j in range(M)], axis=1)
    P = _within_reach(P, anchors, d_mo)
    iu, ju = np.triu_indices(M, 1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        w_mo = np.maximum(d_mo, 1e-12) ** weight_power
        w_mm = np.maximum(d_mm[:, iu, ju], 1e-12) ** weight_power
    return _refine(P, anchors, d_mo, d_mm, w_mo, w_mm, n_iter, relative_damping=weight_power != 0)


def _gather(poses, edm, missing):
    """A placement batch's pieces: each pose's missing joints (n, M) in joint order,
    its observed joints' coordinates (n, a, 2), the target distances from the
    missing joints to the observed ones (n, M, a) and among themselves (n, M, M)."""
    M = int(missing[0].sum())
    order = np.argsort(~missing, axis=1, kind="stable")  # missing joints first, in order
    miss, obs = order[:, :M], order[:, M:]
    rows = np.arange(len(poses))[:, None]
    anchors = poses[rows, obs]  # (n, a, 2)
    d_mo = edm[rows[:, :, None], miss[:, :, None], obs[:, None, :]]  # (n, M, a)
    d_mm = edm[rows[:, :, None], miss[:, :, None], miss[:, None, :]]  # (n, M, M)
    return miss, anchors, d_mo, d_mm


def _refine(P, anchors, d_mo, d_mm, w_mo, w_mm, n_iter, relative_damping=True):
    """`n_iter` guarded Gauss-Newton steps from the missing joints `P` (n, M, 2).

    The cost is the weighted squared residual of the distances to the observed
    joints (weights `w_mo`, (n, M, a)) and among the missing ones (`w_mm`, (n,
    M(M-1)/2), the upper triangle row by row); `relative_damping` scales the
    damping to the weighted curvature, else it is a fixed 1e-6.
    """
    n, M = P.shape[:2]
    iu, ju = np.triu_indices(M, 1)
    eye = np.arange(M)

    def cost(P):
        r_mo = np.linalg.norm(P[:, :, None, :] - anchors[:, None, :, :], axis=-1) - d_mo
        c = (w_mo * r_mo**2).sum(axis=(1, 2))
        if M > 1:
            dd = np.linalg.norm(P[:, iu] - P[:, ju], axis=-1)
            c = c + (w_mm * (dd - d_mm[:, iu, ju]) ** 2).sum(axis=1)
        return c

    current = cost(P)
    for _ in range(n_iter):
        diff = P[:, :, None, :] - anchors[:, None, :, :]  # (n, M, a, 2)
        dist = np.linalg.norm(diff, axis=-1)
        unit = diff / np.maximum(dist, 1e-12)[..., None]
        r_mo = dist - d_mo
        H = np.zeros((n, M, 2, M, 2))
        H[:, eye, :, eye, :] = np.einsum("nmai,nmaj,nma->mnij", unit, unit, w_mo)
        g = np.einsum("nmai,nma->nmi", unit, r_mo * w_mo)
        if M > 1:
            dpp = P[:, iu] - P[:, ju]  # (n, p, 2)
            dd = np.linalg.norm(dpp, axis=-1)
            u = dpp / np.maximum(dd, 1e-12)[..., None]
            r = (dd - d_mm[:, iu, ju]) * w_mm
            uu = np.einsum("npi,npj->npij", u, u) * w_mm[..., None, None]
            for p_, (a, b) in enumerate(zip(iu, ju)):
                H[:, a, :, a, :] += uu[:, p_]
                H[:, b, :, b, :] += uu[:, p_]
                H[:, a, :, b, :] -= uu[:, p_]
                H[:, b, :, a, :] -= uu[:, p_]
                g[:, a] += u[:, p_] * r[:, p_, None]
                g[:, b] -= u[:, p_] * r[:, p_, None]
        H = H.reshape(n, 2 * M, 2 * M)
        if not relative_damping:  # unweighted: the fixed damping it always had
            damp = np.full(n, 1e-6)
        else:  # relative to the weighted curvature, so the weights' scale cancels
            damp = 1e-6 * np.trace(H, axis1=1, axis2=2) / (2 * M) + 1e-12
        H = H + damp[:, None, None] * np.eye(2 * M)
        step = np.linalg.solve(H, g.reshape(n, 2 * M, 1))[..., 0]
        P, current = _descend(P, step.reshape(n, M, 2), current, cost)
    return P


def _within_reach(P, anchors, d_mo):
    """Starts pulled into the disc a joint can reach from every anchor.

    A joint at distance d_i from anchor q_i lies within d_i + ||q_i - c|| of
    the anchors' centroid c. Nearly collinear anchors make the linearised
    trilateration ill-posed across their line, and its start can land
    anywhere; such a start is moved back onto that disc's edge.
    """
    c = anchors.mean(axis=1)  # (n, 2)
    spread = np.linalg.norm(anchors - c[:, None], axis=-1)  # (n, a)
    reach = (d_mo + spread[:, None, :]).max(axis=-1)  # (n, M)
    off = P - c[:, None, :]
    dist = np.linalg.norm(off, axis=-1)
    bad = ~np.isfinite(dist) | (dist > reach)
    if not bad.any():
        return P
    with np.errstate(divide="ignore", invalid="ignore"):
        scaled = c[:, None, :] + off * (reach / dist)[..., None]
    scaled = np.where(np.isfinite(scaled), scaled, c[:, None, :])
    return np.where(bad[..., None], scaled, P)


def _descend(P, step, current, cost, halvings=6):
    """Take the Gauss-Newton `step` where it lowers the cost, else a fraction.

    A pose whose full step raises its weighted residual (a near-singular
    system, as from nearly collinear anchors) backtracks by halving, and stays
    where it is if no fraction helps; the others take the full step, as plain
    Gauss-Newton does.
    """
    t = np.ones(len(P))
    todo = np.ones(len(P), bool)
    new_P, new_cost = P.copy(), current.copy()
    for _ in range(halvings + 1):
        with np.errstate(invalid="ignore", over="ignore"):
            trial = P - t[:, None, None] * step
            c = cost(trial)
        ok = todo & np.isfinite(c) & (c <= current * (1 + 1e-9) + 1e-300)
        new_P[ok], new_cost[ok] = trial[ok], c[ok]
        todo &= ~ok
        if not todo.any():
            break
        t[todo] *= 0.5
    return new_P, new_cost
