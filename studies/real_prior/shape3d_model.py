"""A view-aware 3D shape-model fill of hidden 2D joints (study code).

    python studies/real_prior/shape3d_model.py --k 16

A 3D shape model of the 14 joints (:data:`sparseedm.skeleton.SKELETON_14`) is
learned from CMU motion capture: every pose root-centred (the hips' midpoint),
turned about the vertical so that its hip line lies along x, scaled to unit
RMS radius, and mirrored (x negated, left and right swapped); the model is
the mean and the first K principal components with their variances.

A 2D pose (image coordinates, y down) is fitted through a scaled orthographic
camera, ``x_j = s R2 (mu_j + B_j a) + t`` on its observed joints: for each view
of a grid (azimuth about the vertical, elevation), the in-plane roll comes
from a similarity fit of the projected shape, and the rest is a ridge least
squares in ``(s, s a, t)`` whose penalty is the Gaussian prior of the
coefficients (variance ``s0^2 lambda_k``, ``s0`` the scale of the similarity
fit) relative to the noise variance `noise` (the 2D pose normalised to unit
RMS radius of its observed joints). The view with the lowest penalised
residual wins (or a soft-min average over views, `temperature`); the hidden
joints are read from its projection.
"""

from __future__ import annotations

import glob
from dataclasses import dataclass
from pathlib import Path

import numpy as np

CMU = Path(__file__).resolve().parents[3] / "shared" / "data" / "cmu-mocap" / "subjects"
#: left/right joint pairs of SKELETON_14 (swapped by a mirror image)
SWAP = np.array([0, 1, 5, 6, 7, 2, 3, 4, 11, 12, 13, 8, 9, 10])
R_HIP, L_HIP = 8, 11


@dataclass
class ShapeModel:
    mean: np.ndarray      # (14, 3)
    basis: np.ndarray     # (14, 3, K)
    variances: np.ndarray  # (K,)


def cmu_poses(subjects=None, step=8):
    """Every `step`-th frame of the CMU ASF/AMC clips of `subjects` (None: all)."""
    from sparseedm.mocap import load_mocap

    out = []
    for path in sorted(glob.glob(str(CMU / "*" / "*.amc"))):
        if subjects is not None and Path(path).parent.name not in subjects:
            continue
        out.append(load_mocap(path)[::step])
    return np.concatenate(out)


def canonical(poses):
    """Root-centred, hip line along +x (turned about y), unit RMS radius."""
    p = poses - 0.5 * (poses[:, R_HIP] + poses[:, L_HIP])[:, None]
    hip = p[:, L_HIP] - p[:, R_HIP]
    ang = np.arctan2(hip[:, 2], hip[:, 0])
    c, s = np.cos(ang), np.sin(ang)
    x = c[:, None] * p[..., 0] + s[:, None] * p[..., 2]
    z = -s[:, None] * p[..., 0] + c[:, None] * p[..., 2]
    p = np.stack([x, p[..., 1], z], axis=-1)
    p = p - p.mean(axis=1, keepdims=True)
    return p / np.sqrt((p ** 2).sum(axis=-1).mean(axis=1))[:, None, None]


def mirrored(poses):
    m = poses[:, SWAP].copy()
    m[..., 0] *= -1
    return m


def build_model(poses3d, k=16):
    """Mean + k principal components of canonical poses and their mirror images."""
    p = canonical(poses3d)
    p = np.concatenate([p, mirrored(p)])
    mean = p.mean(axis=0)
    X = (p - mean).reshape(len(p), -1)
    _, sv, vt = np.linalg.svd(X, full_matrices=False)
    var = sv[:k] ** 2 / (len(p) - 1)
    return ShapeModel(mean, vt[:k].T.reshape(14, 3, k), var)


def views(azimuth_step=15, elevations=(-30, -15, 0, 15, 30, 45, 60)):
    """(G, 2, 3) projections: the first two rows of Rx(el) @ Ry(az)."""
    return np.array([camera(az, el) for el in np.radians(elevations)
                     for az in np.radians(np.arange(0, 360, azimuth_step))])


def camera(azimuth, elevation, roll=0.0):
    """(2, 3) projection (radians): the roll in the image of the first two rows of
    Rx(elevation) @ Ry(azimuth)."""
    ce, se, ca, sa = np.cos(elevation), np.sin(elevation), np.cos(azimuth), np.sin(azimuth)
    rx = np.array([[1, 0, 0], [0, ce, -se], [0, se, ce]])
    ry = np.array([[ca, 0, sa], [0, 1, 0], [-sa, 0, ca]])
    rz = np.array([[np.cos(roll), -np.sin(roll)], [np.sin(roll), np.cos(roll)]])
    return rz @ (rx @ ry)[:2]


def _similarity(y, x, w):
    """(a, b) of the 2D similarity x ~ [[a,-b],[b,a]] y, both centred on w's joints.
    y: (n, G, 14, 2) or (G, 14, 2), x: (n, 14, 2) centred, w: (n, 14)."""
    wsum = w.sum(axis=1)
    if y.ndim == 3:
        yc = y[None] - np.einsum("nj,gjc->ngc", w, y)[:, :, None] / wsum[:, None, None, None]
    else:
        yc = y - np.einsum("nj,ngjc->ngc", w, y)[:, :, None] / wsum[:, None, None, None]
    den = np.einsum("nj,ngjc,ngjc->ng", w, yc, yc)
    a = np.einsum("nj,ngjc,njc->ng", w, yc, x) / den
    b = np.einsum("nj,ngj->ng", w, yc[..., 0] * x[:, None, :, 1] - yc[..., 1] * x[:, None, :, 0]) / den
    return a, b


def fit_chunk(model, proj, x, w, noise, temperature, iters=2, want_view=False):
    """Fill of n normalised y-up poses x (n, 14, 2), observed weights w (n, 14)."""
    n, G = len(x), len(proj)
    K = model.basis.shape[-1]
    # design per view: columns [mean (s), basis (d), t_x, t_y]
    D = np.zeros((G, 14, 2, K + 3))
    D[..., 0] = np.einsum("gcd,jd->gjc", proj, model.mean)
    D[..., 1:K + 1] = np.einsum("gcd,jdk->gjck", proj, model.basis)
    D[:, :, 0, K + 1] = 1
    D[:, :, 1, K + 2] = 1
    O = np.einsum("gjcp,gjcq->gjpq", D, D)
    A0 = np.einsum("nj,gjpq->ngpq", w, O)
    shape2d = D[..., 0]  # (G, 14, 2) projected mean
    a, b = _similarity(shape2d, x, w)
    theta = None
    for it in range(iters):
        s0 = np.sqrt(a ** 2 + b ** 2)
        cos, sin = a / s0, b / s0
        # observations turned by -roll
        xr = np.stack([cos[..., None] * x[:, None, :, 0] + sin[..., None] * x[:, None, :, 1],
                       -sin[..., None] * x[:, None, :, 0] + cos[..., None] * x[:, None, :, 1]],
                      axis=-1)  # (n, G, 14, 2)
        A = A0.copy()
        pen = noise / (s0[..., None] ** 2 * model.variances)  # (n, G, K)
        idx = np.arange(1, K + 1)
        A[..., idx, idx] += pen
        A[..., 0, 0] += 1e-9
        rhs = np.einsum("nj,gjcp,ngjc->ngp", w, D, xr)
        theta = np.linalg.solve(A, rhs[..., None])[..., 0]
        pred = np.einsum("gjcp,ngp->ngjc", D, theta)
        if it + 1 < iters:  # re-estimate the roll with the fitted shape
            shape = pred - theta[..., None, K + 1:]  # (n, G, 14, 2) in the turned frame
            # shape in the turned frame; turn back to the image frame's roll estimate
            back = np.stack([cos[..., None] * shape[..., 0] - sin[..., None] * shape[..., 1],
                             sin[..., None] * shape[..., 0] + cos[..., None] * shape[..., 1]], -1)
            da, db = _similarity(back, x, w)
            # compose: new roll = old roll + correction
            ang = np.arctan2(b, a) + np.arctan2(db, da)
            a, b = s0 * np.cos(ang), s0 * np.sin(ang)
    res = ((pred - xr) ** 2).sum(axis=-1)
    score = (w[:, None] * res).sum(axis=-1) + (pen * theta[..., 1:K + 1] ** 2).sum(axis=-1)
    img = np.stack([cos[..., None] * pred[..., 0] - sin[..., None] * pred[..., 1],
                    sin[..., None] * pred[..., 0] + cos[..., None] * pred[..., 1]], -1)
    best = np.argmin(score, axis=1)
    if want_view:
        at = np.arange(n), best
        return img[at], proj[best], cos[at], sin[at], theta[at][:, 0], theta[at][:, 1:K + 1]
    if temperature > 0:
        z = -(score - score.min(axis=1, keepdims=True)) / temperature
        p = np.exp(z)
        p /= p.sum(axis=1, keepdims=True)
        return np.einsum("ng,ngjc->njc", p, img)
    return img[np.arange(n), best]


def shape_fill(model, poses, missing, *, noise=0.01, temperature=0.0, proj=None, chunk=64,
               iters=2):
    """Poses (n, 14, 2) in image coordinates (y down) with hidden joints filled."""
    proj = views() if proj is None else proj
    poses = np.asarray(poses, float)
    missing = np.asarray(missing, bool)
    out = np.array(poses, float)
    rows = np.flatnonzero(missing.any(axis=1) & ((~missing).sum(axis=1) >= 2))
    w = (~missing).astype(float)
    x = np.where(missing[..., None], 0.0, poses) * np.array([1.0, -1.0])
    cen = (w[..., None] * x).sum(axis=1) / w.sum(axis=1)[:, None]
    xc = (x - cen[:, None]) * w[..., None]
    rad = np.sqrt((xc ** 2).sum(axis=(1, 2)) / np.maximum(w.sum(axis=1), 1))
    for i in range(0, len(rows), chunk):
        r = rows[i:i + chunk]
        fill = fit_chunk(model, proj, xc[r] / rad[r, None, None], w[r], noise, temperature,
                         iters)
        fill = fill * rad[r, None, None] + cen[r, None]
        fill[..., 1] *= -1
        out[r] = np.where(missing[r, :, None], fill, poses[r])
    return out


def _normalised(poses, missing):
    w = (~missing).astype(float)
    x = np.where(missing[..., None], 0.0, poses) * np.array([1.0, -1.0])
    cen = (w[..., None] * x).sum(axis=1) / w.sum(axis=1)[:, None]
    xc = (x - cen[:, None]) * w[..., None]
    rad = np.sqrt((xc ** 2).sum(axis=(1, 2)) / np.maximum(w.sum(axis=1), 1))
    return xc / rad[:, None, None], w


def calibrate(model, complete, *, noise=0.01, rounds=3, proj=None, chunk=64, shrink=0.0):
    """The model with its mean moved so that it explains the complete 2D poses
    `complete` (n, 14, 2): per joint the 3D offset whose projections through each
    pose's fitted camera best match the residuals (least squares), `rounds` times."""
    from dataclasses import replace
    proj = views() if proj is None else proj
    x, w = _normalised(complete, np.zeros(complete.shape[:2], bool))
    for _ in range(rounds):
        AtA = np.zeros((14, 3, 3)) + shrink * np.eye(3)
        Atb = np.zeros((14, 3))
        for i in range(0, len(x), chunk):
            img, pr, cos, sin, s, d = fit_chunk(model, proj, x[i:i + chunk], w[i:i + chunk],
                                                noise, 0.0, want_view=True)
            r = x[i:i + chunk] - img  # residual in the image frame
            rot = np.stack([np.stack([cos, -sin], -1), np.stack([sin, cos], -1)], -2)
            M = s[:, None, None] * rot @ pr  # (n, 2, 3): image = M @ X + t
            AtA += np.einsum("ncd,nce->de", M, M)[None]
            Atb += np.einsum("ncd,njc->jd", M, r)
        delta = np.linalg.solve(AtA, Atb[..., None])[..., 0]
        model = replace(model, mean=model.mean + delta)
    return model


def local_fill(model, bank3d, poses, missing, *, noise=0.02, proj=None, chunk=64, **local):
    """The local 3D model: each pose's camera from the global model's fit (best
    view, roll), then the local Gaussian (:func:`sparseedm.gaussian_fill.local_gaussian_fill`)
    over the canonical 3D poses `bank3d` seen through that camera."""
    from sparseedm.gaussian_fill import local_gaussian_fill
    proj = views() if proj is None else proj
    poses = np.asarray(poses, float)
    missing = np.asarray(missing, bool)
    out = np.array(poses, float)
    rows = np.flatnonzero(missing.any(axis=1) & ((~missing).sum(axis=1) >= 2))
    x, w = _normalised(poses, missing)
    for i in range(0, len(rows), chunk):
        r = rows[i:i + chunk]
        _, pr, cos, sin, _, _ = fit_chunk(model, proj, x[r], w[r], noise, 0.0, want_view=True)
        rot = np.stack([np.stack([cos, -sin], -1), np.stack([sin, cos], -1)], -2)
        M = rot @ pr * np.array([1.0, -1.0])[:, None]  # to y down
        for k, row in enumerate(r):
            draws = bank3d @ M[k].T
            out[row] = local_gaussian_fill(draws, poses[row][None], missing[row][None],
                                           **local)[0]
    return out


def main(argv=None):
    """Build the model and print its components' share of the variance."""
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--k", type=int, default=16)
    ap.add_argument("--step", type=int, default=8, help="every step-th mocap frame")
    ap.add_argument("--subjects", help="CMU subjects, comma-separated (default: all)")
    a = ap.parse_args(argv)
    poses = cmu_poses(None if a.subjects is None else a.subjects.split(","), a.step)
    model = build_model(poses, a.k)
    total = build_model(poses, 42).variances.sum()
    print(f"{len(poses)} poses; the {a.k} components explain "
          f"{model.variances.sum() / total:.3f} of the variance")
    print("hidden-joint error, % of body size, of 200 of these poses seen from random views "
          "(azimuth 0-360, elevation -17..46, roll -17..17 degrees), 2 random joints hidden:",
          round(random_view_check(model, poses), 2))


def random_view_check(model, poses3d, n=200, hidden=2, seed=0, **fill):
    """Mean hidden-joint error (% of body size) of `n` of the poses through random
    scaled orthographic cameras, `hidden` random joints hidden, filled by the model."""
    rng = np.random.default_rng(seed)
    X = canonical(poses3d[rng.choice(len(poses3d), n, replace=False)])
    az, el, ro = rng.uniform(0, 2 * np.pi, n), rng.uniform(-0.3, 0.8, n), rng.uniform(-0.3, 0.3, n)
    cams = np.array([camera(a, e, r) for a, e, r in zip(az, el, ro)])
    x2 = np.einsum("ncd,njd->njc", cams, X) * np.array([1.0, -1.0]) * 100 + 300
    missing = np.zeros((n, 14), bool)
    for i in range(n):
        missing[i, rng.choice(14, hidden, replace=False)] = True
    out = shape_fill(model, np.where(missing[..., None], np.nan, x2), missing,
                     **({"noise": 0.02, "temperature": 0.1} | fill))
    head_top, ankles = x2[:, 0], 0.5 * (x2[:, 10] + x2[:, 13])
    size = np.linalg.norm(head_top - ankles, axis=-1)
    return float((np.linalg.norm(out - x2, axis=-1) / size[:, None] * 100)[missing].mean())


if __name__ == "__main__":
    main()
