"""Donors: a hidden joint taken from the file's other rows that show it, when probes say so.

The default path codes an occluded pose over atoms made of the file's complete
poses (and the shipped dictionary). When the file holds frames of a few videos
given as photos, the best evidence for a hidden joint is often another
*incomplete* row: a neighbouring frame of the same person, occluded elsewhere,
that shows the joint. :func:`donor_estimates` takes, for each hidden joint, the
:data:`DONOR_K` nearest other rows observing it, by the RMS residual of their
similarity alignment (translation, rotation, scale) onto the pose over the
joints both observe (at least :data:`DONOR_MIN_SHARED`), and averages their
aligned joints. On files of distinct people such donors are poor, so
:func:`donor_step` decides per file from evidence on the occluded rows
themselves: it hides one more observed joint of a seeded subset of them
(:data:`DONOR_PROBES` at most), answers those probes with the default path
and with the donors, and moves the hidden joints a weight of
:data:`DONOR_WEIGHTS` of the way to the donors' estimate (where the nearest
donor's residual is below a gate of :data:`DONOR_GATES`), the pair with the
lowest probe error, unless its gain over the default answer is within one
paired standard error. On validation files of Bonn video frames with 1,000
complete poses of other videos it lowered the hidden joints' error from 6.4
to 2.0 % of body size under random masks and from 9.6 to 5.1 under real
visibility masks (KNNImputer: 3.6 and 5.5); on the MPII, COCO, CMU and Daz
files it chose small weights or none and moved them by -0.5 to +0.01
(``studies/fast/README.md``, "Donors").

Then donors *in place* (:func:`in_place_estimates`): the rows observing the
hidden joint whose shared observed joints lie nearest in the image itself,
without alignment, as KNNImputer finds a video's neighbouring frames, even
for a pose showing too few joints to align a donor (under real occlusion, a
frame keeping 3-5 joints). Their weight and gate are chosen on probes too,
one pair for the joints without an aligned donor and one for those with
one. On the Bonn frames with real masks they lowered the error per pose by
0.36 (val) and 1.29 (with 1,000 complete poses of other videos); elsewhere
the probes gave them no weight that moved a file by more than 0.01
(``studies/fast/README.md``, "Donors in place").
"""

from __future__ import annotations

import numpy as np

from dataclasses import replace
from typing import NamedTuple

from ._recovery_base import put_rows
from .edm import observed_entries, pose_to_vector
from .normalize import rms_radius

__all__ = ["DONOR_BLOCK", "DONOR_K", "DONOR_MIN_SHARED", "DONOR_PROBES", "DONOR_MIN_PROBES",
           "DONOR_WEIGHTS", "DONOR_GATES", "DONOR_CANDIDATES", "PROBES_PER_ROW",
           "IN_PLACE_MIN_SHARED", "donor_estimates", "in_place_estimates", "donor_mix",
           "donor_step", "probes", "probe_rounds", "paired_gain"]

#: donors per hidden joint
DONOR_K = 5
#: joints a donor and the pose must both observe
DONOR_MIN_SHARED = 6
#: probes (occluded rows with one more joint hidden) per file, and the fewest
#: that decide anything
DONOR_PROBES, DONOR_MIN_PROBES = 300, 30
#: a file of fewer than DONOR_PROBES occluded rows to probe may have each
#: probed up to this many times (another observed joint each) until
#: DONOR_PROBES probes, their standard errors clustered by row; on the small
#: validation photo files more such probes chose worse weights, hence one
PROBES_PER_ROW = 1
#: the per-file choice's weights of the donors' estimate and gates (the nearest
#: donor's residual, % of the pose's RMS radius)
DONOR_WEIGHTS = (0.0, 0.25, 0.5, 0.75, 1.0)
DONOR_GATES = (np.inf, 10.0, 5.0, 2.5)
#: rows aligned exactly per pose: the nearest by their filled poses (centred,
#: divided by their RMS radius)
DONOR_CANDIDATES = 64
#: joints a donor in place and the pose must both observe (a pose showing
#: fewer than DONOR_MIN_SHARED joints has no aligned donor)
IN_PLACE_MIN_SHARED = 3

# rows per block of the candidates' alignment, and pairs per block of their search
_CHUNK, _PAIRS = 2048, 4_000_000


def _shape_vectors(filled):
    """Each filled pose centred and divided by its RMS radius, flat; NaN rows 0."""
    ok = np.isfinite(filled).all(axis=(1, 2))
    p = np.where(ok[:, None, None], filled, 0.0)
    c, r = rms_radius(p, np.zeros(p.shape[:2], bool))
    v = ((p - c[:, None, :]) / np.where(r > 0, r, 1)[:, None, None]).reshape(len(p), -1)
    return v, ok


def _candidates(filled, rows, usable, m):
    """(len(rows), m) indices of the rows nearest each of `rows` by shape (not itself)."""
    v, ok = _shape_vectors(filled)
    ok &= usable
    pool = np.flatnonzero(ok)
    m = min(m, len(pool) - 1)
    out = np.empty((len(rows), max(m, 0)), int)
    sq = (v[pool] ** 2).sum(1)
    chunk = max(1, _PAIRS // max(len(pool), 1))
    for s in range(0, len(rows), chunk):
        t = rows[s:s + chunk]
        d = sq[None, :] - 2 * v[t] @ v[pool].T
        d[t[:, None] == pool[None, :]] = np.inf
        idx = np.argpartition(d, m - 1, axis=1)[:, :m] if m > 0 else d[:, :0].astype(int)
        out[s:s + chunk] = pool[idx]
    return out


def donor_estimates(poses, missing, rows, filled, *, k=DONOR_K, min_shared=DONOR_MIN_SHARED,
                    candidates=DONOR_CANDIDATES):
    """Each hidden joint of `rows` estimated from the file's other rows that observe it.

    A donor is aligned onto the pose by the similarity transform (translation,
    rotation, scale) that best matches the joints both observe, in closed form
    (complex numbers in 2D); its distance is the RMS residual in % of the
    pose's RMS radius. The `k` nearest donors observing the joint (among the
    `candidates` rows nearest by `filled`, and sharing at least `min_shared`
    observed joints) give the mean of their aligned joints weighted by
    ``1 / (1 + distance)``.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        The file's poses, NaN at missing joints (validated).
    missing : ndarray of bool (n, N)
    rows : ndarray of int
        The rows to estimate.
    filled : ndarray (n, N, 2)
        An answer for every row (the default path's), used only to pre-select
        candidates.
    k, min_shared, candidates : int
        Donors per joint, shared observed joints, candidates per row.

    Returns
    -------
    estimates : ndarray (len(rows), N, 2)
        NaN where a joint is observed or has no donor.
    nearest : ndarray (len(rows), N)
        The nearest donor's distance (inf: none).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> P = rng.normal(size=(20, 14, 2))
    >>> P[1] = 2 * P[0] @ np.array([[0.0, -1.0], [1.0, 0.0]]) + 3  # a twin, turned
    >>> missing = np.zeros((20, 14), bool)
    >>> missing[0, 4] = missing[1, 7] = True
    >>> X = np.where(missing[..., None], np.nan, P)
    >>> est, near = donor_estimates(X, missing, np.array([0, 1]), np.nan_to_num(X), k=1)
    >>> bool(np.allclose(est[0, 4], P[0, 4])), bool(np.allclose(est[1, 7], P[1, 7]))
    (True, True)
    """
    obs = ~missing
    z = np.where(obs, np.nan_to_num(poses[..., 0] + 1j * poses[..., 1]), 0)
    cand = _candidates(filled, rows, obs.sum(1) >= min_shared, candidates)
    _, size = rms_radius(poses[rows], missing[rows])
    est = np.full((len(rows), missing.shape[1]), complex(np.nan, np.nan))
    nearest = np.full((len(rows), missing.shape[1]), np.inf)
    if cand.shape[1] == 0:
        return np.stack([est.real, est.imag], -1), nearest
    for s in range(0, len(rows), _CHUNK):
        at = slice(s, s + _CHUNK)
        with np.errstate(all="ignore"):  # rows out of range (1e300) align to no donor
            est[at], nearest[at] = _from_candidates(z, obs, rows[at], cand[at], size[at], k,
                                                    min_shared)
    return np.stack([est.real, est.imag], -1), nearest


def _from_candidates(z, obs, rows, cand, size, k, min_shared):
    """donor_estimates on complex poses `z` for `rows` and their candidates."""
    W = obs[rows][:, None, :] & obs[cand]                     # (r, m, N)
    n = np.maximum(W.sum(-1), 1)
    x = np.where(W, z[rows][:, None, :], 0)
    y = np.where(W, z[cand], 0)
    cx, cy = x.sum(-1) / n, y.sum(-1) / n
    xc, yc = np.where(W, x - cx[..., None], 0), np.where(W, y - cy[..., None], 0)
    sxx, syy = (np.abs(xc) ** 2).sum(-1), (np.abs(yc) ** 2).sum(-1)
    sxy = (xc * yc.conj()).sum(-1)
    good = (W.sum(-1) >= min_shared) & (syy > 1e-12 * np.maximum(sxx, 1e-300))
    syy = np.where(good, syy, 1.0)
    dist = np.sqrt(np.maximum(sxx - np.abs(sxy) ** 2 / syy, 0) / n) / size[:, None] * 100
    dist = np.where(good & np.isfinite(dist), dist, np.inf)
    aligned = cx[..., None] + (sxy / syy)[..., None] * (z[cand] - cy[..., None])  # (r, m, N)
    return _nearest_mean(aligned, dist, obs[cand], ~obs[rows], k)


def _nearest_mean(placed, dist, shows, hidden, k):
    """Per row and hidden joint, the mean of the `k` nearest candidates showing
    it (`placed` (r, m, N) complex, `dist` (r, m)) weighted by ``1 / (1 + d)``;
    and the nearest one's distance (NaN and inf where none)."""
    dj = np.where(shows, dist[..., None], np.inf)              # (r, m, N)
    kk = min(k, dj.shape[1])
    idx = np.argpartition(dj, kk - 1, axis=1)[:, :kk]          # (r, kk, N)
    dk = np.take_along_axis(dj, idx, 1)
    w = np.where(np.isfinite(dk), 1 / (1 + dk), 0)
    wsum = w.sum(1)
    est = (w * np.take_along_axis(placed, idx, 1)).sum(1) / np.where(wsum > 0, wsum, 1)
    return np.where(hidden & (wsum > 0), est, complex(np.nan, np.nan)), np.where(hidden, dk.min(1), np.inf)


def in_place_estimates(poses, missing, rows, filled, *, k=DONOR_K, min_shared=None,
                       candidates=DONOR_CANDIDATES):
    """Each hidden joint of `rows` from the file's other rows observing it whose
    joints lie nearest in the image, without alignment.

    A donor's distance is the root-mean-square distance, over the joints both
    observe (at least `min_shared`), between its joints and the pose's, in %
    of the RMS radius of the pose's `filled` answer; the `k` nearest donors
    observing the joint (among the `candidates` nearest rows) give the mean of
    their own joint weighted by ``1 / (1 + distance)``. On a video's frames
    given as photos these are the same person's neighbouring frames, found
    even when the pose shows too few joints for :func:`donor_estimates`.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        The file's poses, NaN at missing joints (validated).
    missing : ndarray of bool (n, N)
    rows : ndarray of int
        The rows to estimate.
    filled : ndarray (n, N, 2)
        An answer for every row: its size scales the distances.
    k, candidates : int
        Donors per joint, candidates per row.
    min_shared : int, optional
        Shared observed joints; default :data:`IN_PLACE_MIN_SHARED`.

    Returns
    -------
    estimates : ndarray (len(rows), N, 2)
        NaN where a joint is observed or has no donor.
    nearest : ndarray (len(rows), N)
        The nearest donor's distance (inf: none).

    Examples
    --------
    >>> import numpy as np
    >>> P = np.random.default_rng(0).normal(size=(20, 14, 2))
    >>> P[1] = P[0] + 0.01  # the next frame
    >>> missing = np.zeros((20, 14), bool)
    >>> missing[0, 3:] = True  # three joints seen
    >>> X = np.where(missing[..., None], np.nan, P)
    >>> est, near = in_place_estimates(X, missing, np.array([0]), np.nan_to_num(X), k=1)
    >>> bool(np.allclose(est[0, 3:], P[1, 3:])), bool(np.isnan(est[0, :3]).all())
    (True, True)
    """
    min_shared = IN_PLACE_MIN_SHARED if min_shared is None else min_shared
    obs = ~missing
    z = np.where(obs, np.nan_to_num(poses[..., 0] + 1j * poses[..., 1]), 0)
    _, size = rms_radius(filled[rows], np.zeros((len(rows), missing.shape[1]), bool))
    est = np.full((len(rows), missing.shape[1]), complex(np.nan, np.nan))
    nearest = np.full((len(rows), missing.shape[1]), np.inf)
    o = obs.astype(float)
    chunk = max(1, _PAIRS // max(len(poses), 1))
    with np.errstate(all="ignore"):  # rows out of range (1e300) find no donor
        sq = np.abs(z) ** 2
        for s in range(0, len(rows), chunk):
            r = rows[s:s + chunk]
            shared = o[r] @ o.T                                   # (c, n)
            d2 = ((o[r] * sq[r]) @ o.T + o[r] @ (o * sq).T
                  - 2 * (z[r] @ z.conj().T).real) / np.maximum(shared, 1)
            d2 = np.where((shared >= min_shared) & np.isfinite(d2), np.maximum(d2, 0), np.inf)
            d2[np.arange(len(r)), r] = np.inf
            m = min(candidates, len(poses) - 1)
            if m < 1:
                break
            cand = np.argpartition(d2, m - 1, axis=1)[:, :m]
            dist = np.sqrt(np.take_along_axis(d2, cand, 1)) / size[s:s + chunk, None] * 100
            dist = np.where(np.isfinite(dist), dist, np.inf)
            est[s:s + chunk], nearest[s:s + chunk] = _nearest_mean(
                z[cand], dist, obs[cand], ~obs[r], k)
    return np.stack([est.real, est.imag], -1), nearest


def donor_mix(answer, estimates, nearest, missing, weight, gate):
    """`answer`'s hidden joints moved `weight` of the way to `estimates` where
    one exists and its nearest donor is closer than `gate`.

    Parameters
    ----------
    answer, estimates : ndarray (n, N, 2)
    nearest : ndarray (n, N)
    missing : ndarray of bool (n, N)
    weight, gate : float

    Returns
    -------
    ndarray (n, N, 2)
    """
    use = missing & np.isfinite(estimates[..., 0]) & (nearest < gate)
    return np.where(use[..., None], (1 - weight) * answer + weight * np.nan_to_num(estimates),
                    answer)


def probes(missing, random_state, per_row=None, observed=None):
    """(rows, joints): a seeded subset of the occluded rows with more than
    :data:`DONOR_MIN_SHARED` observed joints (:data:`DONOR_PROBES` at most), one
    observed joint of each: the rows to answer again with that joint hidden too
    (:func:`donor_step`, :func:`sparseedm.exemplars.probe_weight`). With fewer
    rows than :data:`DONOR_PROBES`, each row is probed up to `per_row` times
    (another observed joint each) until :data:`DONOR_PROBES` probes.

    Parameters
    ----------
    missing : ndarray of bool (n, N)
    random_state : int
        Seed of the rows and joints.
    per_row : int, optional
        Probes per row at most; default :data:`PROBES_PER_ROW`.
    observed : (int, int), optional
        Rows with more than the first and at most the second number of
        observed joints; default ``(DONOR_MIN_SHARED, N)``.

    Returns
    -------
    rows, joints : ndarray of int
        The probes' rows and each one's joint to hide, in rounds: each row once
        (ascending), then again with another joint, and so on; a row appears
        at most once per round.

    Examples
    --------
    >>> import numpy as np
    >>> missing = np.zeros((3, 14), bool); missing[1:, 0] = True
    >>> rows, joints = probes(missing, 0, per_row=1)
    >>> rows.tolist(), bool(missing[rows, joints].any())
    ([1, 2], False)
    >>> rows, joints = probes(missing, 0, per_row=3)
    >>> rows.tolist(), len(set(zip(rows.tolist(), joints.tolist())))
    ([1, 2, 1, 2, 1, 2], 6)
    """
    per_row = PROBES_PER_ROW if per_row is None else per_row
    rng = np.random.default_rng([random_state, 91])
    low, high = (DONOR_MIN_SHARED, missing.shape[1]) if observed is None else observed
    seen = (~missing).sum(1)
    cand = np.flatnonzero(missing.any(1) & (seen > low) & (seen <= high))
    rows = np.sort(rng.permutation(cand)[:DONOR_PROBES])
    joints = np.array([rng.choice(np.flatnonzero(~missing[r])) for r in rows], int)
    k = min(per_row, -(-DONOR_PROBES // max(len(rows), 1)))
    if k <= 1:
        return rows, joints
    more = [rng.permutation(np.setdiff1d(np.flatnonzero(~missing[r]), [j]))[:k - 1]
            for r, j in zip(rows, joints)]
    taken = [(rows, joints)]
    for i in range(k - 1):
        has = np.array([len(m) > i for m in more], bool)
        taken.append((rows[has], np.array([m[i] for m in more if len(m) > i], int)))
    return tuple(np.concatenate(t) for t in zip(*taken))


def probe_rounds(rows):
    """The round of each probe of :func:`probes` (0 at a row's first)."""
    seen = {}
    out = np.empty(len(rows), int)
    for i, r in enumerate(np.asarray(rows).tolist()):
        out[i] = seen[r] = seen.get(r, -1) + 1
    return out


def paired_gain(gain, clusters=None):
    """(mean, standard error) of a paired gain; with `clusters`, the gains of one
    cluster (several probes of one pose: not independent) averaged first, the mean
    and its standard error then over the clusters.

    Parameters
    ----------
    gain : ndarray (n,)
        One paired difference per probe (or pose).
    clusters : array_like (n,), optional
        Each probe's cluster (its pose's row); None: every probe its own.

    Returns
    -------
    mean, se : float
        NaN standard error with fewer than two clusters.

    Examples
    --------
    >>> import numpy as np
    >>> gain = np.array([1.0, 1.0, 1.0, 3.0, 3.0, 3.0])
    >>> [round(v, 3) for v in paired_gain(gain)]
    [2.0, 0.447]
    >>> [round(v, 3) for v in paired_gain(gain, clusters=[0, 0, 0, 1, 1, 1])]
    [2.0, 1.0]
    """
    gain = np.asarray(gain, dtype=float)
    if clusters is not None:
        _, which = np.unique(np.asarray(clusters), return_inverse=True)
        gain = np.bincount(which, weights=gain) / np.bincount(which)
    if len(gain) < 2:
        return float(gain.mean()) if len(gain) else float("nan"), float("nan")
    return float(gain.mean()), float(gain.std(ddof=1) / np.sqrt(len(gain)))


def _choose(answer, estimates, nearest, truth, joints, rows):
    """((weight, gate), probe errors of the default and of the choice), on the
    probes the default answered (the default unless DONOR_MIN_PROBES of them),
    the gain's standard error clustered by `rows` (:func:`paired_gain`)."""
    pm = np.zeros(truth.shape[:2], bool)
    pm[np.arange(len(truth)), joints] = True
    _, size = rms_radius(truth, pm | np.isnan(truth[..., 0]))
    at = np.arange(len(truth)), joints

    def err(key):
        f = donor_mix(answer, estimates, nearest, pm, *key)
        return np.linalg.norm(f[at] - truth[at], axis=-1) / size * 100

    with np.errstate(all="ignore"):  # a row out of range (a joint at 1e300) overflows
        errs = {(w, g): err((w, g)) for g in DONOR_GATES for w in DONOR_WEIGHTS}
    # a refused probe judges nothing, nor one whose error is not a number
    ok = np.isfinite(answer[at]).all(-1) & np.isfinite(list(errs.values())).all(axis=0)
    if ok.sum() < DONOR_MIN_PROBES:
        return (0.0, np.inf), float("nan"), float("nan")
    errs = {key: e[ok] for key, e in errs.items()}
    base = errs[(0.0, np.inf)]
    best = min(errs, key=lambda key: errs[key].mean())
    mean, se = paired_gain(base - errs[best], rows[ok])
    if not mean > se:
        best = (0.0, np.inf)
    return best, float(base.mean()), float(errs[best].mean())


#: The donors of a row are looked for within its block of this many consecutive
#: rows (``recover_file``'s default ``chunk_size``; it takes them within each
#: chunk): the search grows with the square of a block's rows
DONOR_BLOCK = 50_000


def donor_step(res, poses, missing, answer, random_state=0, block=DONOR_BLOCK):
    """`res` with its hidden joints moved toward the donors' estimates when
    probes on the file's occluded rows say so; a file of more than `block`
    rows block by block of consecutive rows, each with its own probes.

    Two kinds of donors: aligned ones (:func:`donor_estimates`), whose weight
    and gate are chosen on probes of rows showing more than
    :data:`DONOR_MIN_SHARED` joints (:func:`probes`); then, over the answer
    so moved, donors in place (:func:`in_place_estimates`), with a weight and
    gate of their own for the hidden joints without an aligned donor (chosen
    on the probes of those joints and of rows showing more than
    :data:`IN_PLACE_MIN_SHARED` joints and at most :data:`DONOR_MIN_SHARED`)
    and another for those with one.

    Parameters
    ----------
    res : RecoveryResult
        The default path's recovery of `poses`.
    poses : ndarray (n, N, 2)
        The poses (validated), NaN at missing joints.
    missing : ndarray of bool (n, N)
    answer : callable
        ``answer(poses, missing)`` -> RecoveryResult: the default path's
        answer for other rows of the same file (the probes).
    random_state : int, default 0
        Seed of the probes.
    block : int, default :data:`DONOR_BLOCK`
        Rows per block.

    Returns
    -------
    RecoveryResult
        `res` itself when the probes keep the default (or there are fewer than
        :data:`DONOR_MIN_PROBES`); else a copy with the occluded rows' hidden
        joints (and their distances) moved. Either way, with enough probes and
        an ``adaptation``, its ``settings["donors"]`` records the weight, gate,
        probes and their errors; those of the donors in place under
        ``["in_place"]["bare"]`` and ``["in_place"]["aligned"]``, each when
        there were enough such probes.
    """
    if len(poses) > block:
        for s in range(0, len(poses), block):
            rows = np.arange(s, min(s + block, len(poses)))
            part = donor_step(res.take(rows), poses[rows], missing[rows], answer,
                              random_state, block)
            res = replace(put_rows(res, rows, part), adaptation=part.adaptation)
        return res
    drawn = probes(missing, random_state)
    if len(drawn[0]) < DONOR_MIN_PROBES:
        return res
    few = probes(missing, random_state, observed=(IN_PLACE_MIN_SHARED, DONOR_MIN_SHARED))
    record = _choices(res.poses, poses, missing, answer, drawn, few)
    if res.adaptation is not None:
        res = replace(res, adaptation=_noted(res.adaptation, record))
    placed = record.get("in_place", {})
    keys = [_key(record)] + [_key(placed[name]) if name in placed else (0.0, np.inf)
                             for name in ("bare", "aligned")]
    if not any(w > 0 for w, _ in keys):
        return res
    occ = np.flatnonzero(missing.any(1))
    part = res.take(occ)
    est, near = donor_estimates(poses, missing, occ, res.poses)
    moved = donor_mix(part.poses, est, near, missing[occ], *keys[0])
    if keys[1][0] > 0 or keys[2][0] > 0:
        bare = missing[occ] & ~np.isfinite(est[..., 0])  # joints without an aligned donor
        placed = in_place_estimates(poses, missing, occ, res.poses)
        for key, which in zip(keys[1:], (bare, missing[occ] & ~bare)):
            moved = donor_mix(moved, *placed, which, *key)
    shift = (pose_to_vector(moved) - pose_to_vector(part.poses)) / part.scale[:, None]
    hidden = ~observed_entries(missing[occ])
    vectors = np.where(hidden & np.isfinite(shift), part.vectors + shift, part.vectors)
    return put_rows(res, occ, replace(part, poses=moved, vectors=vectors))


def _key(record):
    """(weight, gate) of a choice's record (gate None: none)."""
    return record["weight"], np.inf if record["gate"] is None else record["gate"]


def _record(choice, probes_):
    (w, g), e0, e1 = choice
    return {"weight": w, "gate": None if np.isinf(g) else g, "probes": int(probes_),
            "probe_err_default": round(e0, 4), "probe_err_chosen": round(e1, 4)}


def _choices(filled, poses, missing, answer, drawn, few):
    """The donors' records, each chosen on probes (:func:`_choose`): the aligned
    donors' on the probes `drawn`; then, over the answer so moved, the donors
    in place for the joints without an aligned donor (``"bare"``: the probes
    `few` and the probed joints of `drawn` with none) and for those with one
    (``"aligned"``), each when it has :data:`DONOR_MIN_PROBES` probes."""
    a = _answered(filled, poses, missing, answer, *drawn)
    aligned = _choose(a.answer, a.aligned[0], a.aligned[1], poses[drawn[0]], drawn[1], drawn[0])
    record = _record(aligned, len(drawn[0]))
    base = donor_mix(a.answer, *a.aligned, a.probed, *_key(record))
    parts = [(base, a.placed, np.isfinite(a.aligned[0][a.probed][:, 0]), drawn)]
    if len(few[0]):
        b = _answered(filled, poses, missing, answer, *few, aligned=False)
        parts.append((b.answer, b.placed, np.zeros(len(few[0]), bool), few))
    base, est, near, has, rows, joints = (
        np.concatenate(x) for x in zip(*[(p[0], p[1][0], p[1][1], p[2], *p[3]) for p in parts]))
    in_place = {}
    for name, which in (("bare", ~has), ("aligned", has)):
        if which.sum() >= DONOR_MIN_PROBES:
            got = _choose(base[which], est[which], near[which], poses[rows[which]],
                          joints[which], rows[which])
            in_place[name] = _record(got, which.sum())
    if in_place:
        record["in_place"] = in_place
    return record


class _Answered(NamedTuple):
    """Probes answered: the path's answer, the aligned and in-place donors'
    (estimates, nearest), and the mask of the probed joints."""

    answer: np.ndarray
    aligned: tuple
    placed: tuple
    probed: np.ndarray


def _answered(filled, poses, missing, answer, rows, joints, aligned=True):
    """The probes (`rows`, each with its joint of `joints` hidden too) answered
    by `answer` and by the donors (the aligned ones only with `aligned`)."""
    pmiss = missing[rows].copy()
    pmiss[np.arange(len(rows)), joints] = True
    pposes = np.where(pmiss[..., None], np.nan, poses[rows])
    probe = answer(pposes, pmiss).poses
    none = np.full(pposes.shape, np.nan), np.full(pmiss.shape, np.inf)
    got = [_probe_estimates(filled, poses, missing, rows, pposes, pmiss, probe, estimate)
           if aligned or estimate is in_place_estimates else none
           for estimate in (donor_estimates, in_place_estimates)]
    probed = np.zeros(pmiss.shape, bool)
    probed[np.arange(len(rows)), joints] = True
    return _Answered(probe, *got, probed)


def _probe_estimates(filled, poses, missing, rows, pposes, pmiss, probe, estimate):
    """`estimate` (:func:`donor_estimates` or :func:`in_place_estimates`) for
    each probe, round by round of :func:`probe_rounds` (a row once per round):
    the file with that round's probed joints hidden."""
    est = np.full(pposes.shape, np.nan)
    near = np.full(pmiss.shape, np.inf)
    rounds = probe_rounds(rows)
    for r in range(rounds.max() + 1 if len(rows) else 0):
        at = np.flatnonzero(rounds == r)
        allp, allm, fill = poses.copy(), missing.copy(), filled.copy()
        allp[rows[at]], allm[rows[at]], fill[rows[at]] = pposes[at], pmiss[at], probe[at]
        est[at], near[at] = estimate(allp, allm, rows[at], fill)
    return est, near


def _noted(adaptation, record):
    """`adaptation` with `record` as its settings' ``donors``."""
    return replace(adaptation, settings=dict(adaptation.settings, donors=record))
