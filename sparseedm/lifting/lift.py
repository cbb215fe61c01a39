"""lift(): 2D poses (occluded or not) -> 3D poses, with a status per pose.

1. Each pose is normalised by its observed joints (:mod:`sparseedm.normalize`)
   and becomes its 2D EDM vector (the ``"average"`` representation; a
   dictionary lifter reads only the observed entries, an MLP the whole vector).
2. The lifter predicts the 3D EDM vector (:mod:`.dictionary`, :mod:`.mlp`, :mod:`.fconv`);
   the dictionary lifter's lasso down-weights the 2D entries touching a joint
   filled across time by its 2D radius
   (:func:`~sparseedm.lifting.uncertainty3d.filled_weights`).
3. :func:`sparseedm.lifting.mds.reconstruct` turns it into coordinates:
   MDS + SMACOF, rotated to agree with the 2D input (weak perspective), the
   depth reflection chosen by the lifter's chirality prior.
4. The pose is scaled to metres by the lifter's size prior and centred on the
   pelvis; axes are the camera's (x right, y down, z away from the camera).

Given ``frames`` (a video), :mod:`.video` uses time: the missing 2D joints
are filled across time before step 1, each person's depth reflections are
chosen together in step 3, and each joint's 3D trajectory is smoothed after
step 4 (measured: docs/explanation/settings.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..edm import vector_to_edm
from .._recovery_base import STATUSES as RECOVERY_STATUSES
from .._recovery_base import (SCREENING_REFUSALS, poses_per_second, screen_poses, take_rows,
                              status_counts, validate_poses)
from .._validation import N_JOBS, Options, check_frames, validate_params
from ..normalize import REPRESENTATIONS, normalize, represent, representation_for
from .adaptation import adapt_lifter
from .base import Lifter, load_lifter, rms
from .mds import reflections
from .metrics import pelvis
from .uncertainty3d import base_radius, combine_radius, filled_weights, spread3d
from .video import choose_reflections, fill_in_time, smooth_tracks

__all__ = ["lift", "LiftResult", "STATUSES", "poses_from_vectors", "lift_reflections"]

#: Per-pose statuses and what they mean: lifting's own, then the refusals it shares
#: with recovery (:data:`sparseedm.recovery.STATUSES`), every screening refusal
#: included: derived, so a new one is counted here too.
STATUSES = {
    "lifted": "lifted from a complete 2D pose",
    "lifted_occluded": "lifted from the observed joints of an occluded 2D pose",
    "lifted_filled": "lifted after its missing 2D joints were filled across time "
                     "(sparseedm.temporal)",
    "inaccurate": "lifted, but the lasso optimum is not certified (gap above tolerance)",
    **{k: RECOVERY_STATUSES[k] for k in ("solver_failed",) + SCREENING_REFUSALS},
}
_OK = ("lifted", "lifted_occluded", "lifted_filled", "inaccurate")


@dataclass
class LiftResult:
    """What :func:`lift` returns; arrays have the poses' leading axis n.

    Parameters
    ----------
    poses3d : ndarray (n, N, 3)
        Metres, pelvis at the origin, camera axes (x right, y down, z away
        from the camera); NaN for refused poses.
    vectors3d : ndarray (n, M)
        3D EDM vectors in the lifter's normalisation (its prediction per
        frame: a video's smoothing moves only `poses3d`).
    scale_metric : ndarray (n,)
        Metres per normalised unit used for `poses3d`.
    missing : ndarray of bool (n, N)
        True where a 2D joint was missing in the input.
    status, reason : ndarray of str (n,)
        One of :data:`STATUSES` per pose, and why a pose was refused.
    chirality_margin : ndarray (n,)
        How clearly the chirality prior decided the depth reflection (< 1
        counts as ambiguous; with frames the reflections of a person's
        frames are chosen together).
    seconds : float
        Wall time of the call.
    poses2d : ndarray (n, N, 2)
        The 2D poses lifted: the input with the joints filled across time
        (NaN where a joint was still missing).
    filled : ndarray of bool (n, N)
        Joints filled across time before lifting (all False without frames).
    linked_tracks : ndarray of int (n,) or None
        The track ids the rows were linked into when frames came without
        tracks and some frame holds several poses (as ``linked_tracks`` of
        :func:`sparseedm.recover` with frames); None otherwise.
    uncertainty2d : ndarray (n, N)
        Pixels, how sure each 2D joint lifted is: 0 for an observed joint,
        the 90 % radius (:attr:`RecoveryResult.uncertainty`) of a joint filled
        across time, NaN for a joint still missing (the lifter places it from
        the others).
    uncertainty3d : ndarray (n, N) or None
        Metres, with ``lift(..., uncertainty3d=True)``: the radius of a
        sphere centred on each joint of `poses3d` meant to hold the true
        joint 9 times in 10 (:mod:`sparseedm.lifting.uncertainty3d`): the
        lifter's own per-joint validation error (depth ambiguity and size
        included, so never 0, larger for a joint missing in 2D) and, for rows
        with joints filled across time, their 2D radius carried through the
        lift by seeded re-lifts; NaN for refused poses. Not covered: the
        smoothing of a video's trajectories, a wrong depth reflection.

    Examples
    --------
    >>> import numpy as np, sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> res = sparseedm.lift(np.stack([pose, np.full_like(pose, np.nan)]))
    >>> res.ok.tolist(), res.summary()["status"]
    ([True, False], {'lifted': 1, 'too_few_observed': 1})
    >>> res.take(res.ok).poses3d.shape
    (1, 14, 3)
    """

    poses3d: np.ndarray
    vectors3d: np.ndarray
    scale_metric: np.ndarray
    missing: np.ndarray
    status: np.ndarray
    reason: np.ndarray
    chirality_margin: np.ndarray
    seconds: float = 0.0
    poses2d: np.ndarray = None
    filled: np.ndarray = None
    linked_tracks: np.ndarray = None
    uncertainty2d: np.ndarray = None
    uncertainty3d: np.ndarray = None

    @property
    def edms3d(self):
        """3D EDMs (n, N, N) in metres (at the size prior)."""
        return vector_to_edm(self.vectors3d * self.scale_metric[:, None])

    @property
    def ok(self):
        """True for poses that came back lifted (refused ones are NaN)."""
        return np.isin(self.status, _OK)

    def take(self, rows):
        """The result of the poses `rows` only (:func:`~sparseedm._recovery_base.take_rows`).

        Parameters
        ----------
        rows : array_like of int, slice or array_like of bool (n,)
            The poses to keep: indices, a slice or a mask.

        Returns
        -------
        LiftResult
            Every per-pose array indexed by `rows`; ``seconds`` as it is.
        """
        return take_rows(self, rows)

    def summary(self):
        """Counts a person reads at the end of a batch (as ``sparseedm lift`` prints).

        Returns
        -------
        dict
            ``poses``, ``refused``, ``ambiguous_reflection`` (lifted poses
            whose depth reflection was a close call), ``filled_across_time``
            (poses with 2D joints filled from their track's other frames),
            ``seconds``, ``poses_per_second`` and ``status`` (the count of
            each status present).
        """
        return {
            "poses": int(len(self.status)),
            "refused": int((~self.ok).sum()),
            "ambiguous_reflection": int((self.chirality_margin[self.ok] < 1).sum()),
            "filled_across_time": 0 if self.filled is None else int(self.filled.any(axis=1).sum()),
            "seconds": round(self.seconds, 3),
            "poses_per_second": poses_per_second(len(self.status), self.seconds),
            "status": status_counts(self.status, STATUSES),
        }


def lift(poses, missing=None, *, tracks=None, frames=None, lifter=None, n_jobs=1,
         representation=None, adapt=None, dictionary=None, fill_adapt="auto",
         uncertainty3d=False, progress=False):
    """Lift 2D poses to 3D.

    Parameters
    ----------
    poses : array_like (n, N, 2) or (N, 2)
        Pixels (any frame: each pose is normalised); NaN marks missing joints.
    missing : array_like of bool (n, N), optional
        More missing joints (combined with NaN by "or").
    tracks, frames : array_like (n,), optional
        A video: `frames` (integers) turns on lifting across time, `tracks`
        says whose pose each row is (as :func:`sparseedm.recover`). The
        missing 2D joints are first filled across time, each track's depth
        reflections are chosen together and its 3D trajectories smoothed
        (:mod:`sparseedm.lifting.video`). Rows time cannot use (a bad frame
        number, a lone frame) are lifted alone from their observed joints.
    lifter : Lifter, str or path, optional
        A loaded lifter, a shipped name, or a lifter .npz; default the
        shipped ``"default"``.
    n_jobs : int, default 1
        Threads for the dictionary lifter's lasso.
    representation : {"average", "zero"}, optional
        How occluded joints are fed to a lifter that reads whole vectors
        (MLP, FConv); the dictionary lifter reads observed entries only.
        Default: the one the lifter was trained on where its file records one
        (FConv; another one is refused), else ``"average"``.
    adapt : array_like (m, N, 2), optional
        Complete 2D poses of the same domain, without 3D: the (dictionary)
        lifter is first adapted on them by
        :func:`sparseedm.lifting.adaptation.adapt_lifter` with its defaults
        (measured: docs/explanation/settings.md). Default None: no adaptation.
    dictionary : Dictionary, str or path, optional
        With `frames`: the 2D dictionary of the fill across time (default the
        shipped one).
    fill_adapt : "auto", False or array_like, default "auto"
        With `frames`: how that dictionary adapts to the poses first (as
        :func:`sparseedm.recover`'s `adapt`; ``sparseedm lift`` adapts once
        per file and passes False for its chunks).
    uncertainty3d : bool, default False
        Also derive :attr:`LiftResult.uncertainty3d`. Cheap without frames
        (a table lookup); with frames, rows holding filled joints are lifted
        again a few times (:data:`~sparseedm.lifting.uncertainty3d.N_PERTURBATIONS`),
        hence opt-in.
    progress : bool, default False
        Show a progress bar over the chunks of the dictionary lifter's lasso
        (the long step; an MLP or FConv lifter predicts in one go) and, with
        `frames`, over those of the fill across time (as
        :func:`sparseedm.recover`'s `progress`).

    Returns
    -------
    LiftResult
        The 3D poses in metres, a status per pose and, on request, each
        joint's 3D radius.

    Examples
    --------
    >>> import numpy as np, sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> pose[4] = np.nan                      # right wrist occluded
    >>> res = sparseedm.lift(pose)
    >>> res.status.tolist(), res.poses3d.shape
    (['lifted_occluded'], (1, 14, 3))
    >>> 1.2 < float(np.ptp(res.poses3d[0, :, 1])) < 2.2     # height in metres
    True
    """
    t0 = time.perf_counter()
    validate_params("lift", dict(representation=representation, n_jobs=n_jobs, lifter=lifter,
                                 uncertainty3d=uncertainty3d, progress=progress),
                    {"representation": [Options(REPRESENTATIONS), None], "n_jobs": N_JOBS,
                     "lifter": [Lifter, "path", None], "uncertainty3d": ["boolean"],
                     "progress": ["boolean"]})
    lifter = load_lifter(lifter)
    representation = representation_for(representation, lifter.representation,
                                        f"the {lifter.method} lifter")
    if adapt is not None:
        lifter = adapt_lifter(lifter, adapt, n_jobs=n_jobs)
    N = lifter.n_joints
    poses, mask, bad = validate_poses(poses, missing, N, caller="lift", model="lifter")
    filled, layout, radius = np.zeros(mask.shape, bool), None, np.where(mask, np.nan, 0.0)
    if frames is not None:
        check_frames(frames, "lift")
        poses, filled, layout, radius = fill_in_time(poses, mask, tracks, frames,
                                                     dictionary=dictionary, n_jobs=n_jobs,
                                                     adapt=fill_adapt, progress=progress)
        mask = mask & ~filled
    weights = filled_weights(poses, mask, filled, radius) if filled.any() else None
    out = _lift_rows(lifter, poses, mask, bad, representation, n_jobs, layout, weights,
                     progress=progress)
    if layout is not None:
        smooth_tracks(out["poses3d"], layout)
    lifted = np.isin(out["status"], ("lifted", "lifted_occluded")) & filled.any(axis=1)
    out["status"][lifted] = "lifted_filled"
    out["status"] = out["status"].astype(str)
    if layout is not None:  # say why a row of a video was lifted on its own
        alone = np.flatnonzero((layout.reason != "") & np.isin(out["status"], _OK))
        reason = out["reason"].astype(object)
        for r in alone:
            why = f"lifted on its own, not across time: {layout.reason[r]}"
            reason[r] = f"{reason[r]}; {why}" if reason[r] else why
        out["reason"] = reason.astype(str)
    if uncertainty3d:
        out["uncertainty3d"] = _radius3d(lifter, poses, mask, filled, radius, out["status"],
                                         representation, n_jobs, weights)
    return LiftResult(**out, missing=mask | filled, seconds=time.perf_counter() - t0,
                      poses2d=np.where(mask[..., None], np.nan, poses), filled=filled,
                      linked_tracks=None if layout is None else layout.linked,
                      uncertainty2d=radius)


def _radius3d(lifter, poses, mask, filled, radius2d, status, representation, n_jobs, weights):
    """LiftResult.uncertainty3d: the base table, plus the filled joints' spread."""
    ok = np.isin(status, _OK)
    base = base_radius(lifter.size_prior_, mask, ok)
    spread = np.zeros(mask.shape)
    rows = np.flatnonzero(ok & filled.any(axis=1))
    if len(rows):
        kept = np.where(mask[rows, :, None], np.nan, poses[rows])

        def relift(p):
            return lift_reflections(lifter, p, representation=representation, n_jobs=n_jobs,
                                    weights=weights[rows])

        spread[rows] = spread3d(relift, kept, filled[rows], radius2d[rows])
    return combine_radius(base, spread)


def lift_reflections(lifter, poses, *, representation="average", n_jobs=1, weights=None):
    """Both metric reflections (n, N, 3) of each 2D pose lifted on its own.

    Parameters
    ----------
    lifter : Lifter
    poses : ndarray (n, N, 2)
        Validated poses, NaN at missing joints.
    representation, n_jobs
        As :func:`lift`.
    weights : ndarray (n, N), optional
        Per-joint weights of a dictionary lifter's lasso (other lifters
        ignore them).

    Returns
    -------
    (front, back) : ndarrays (n, N, 3), pelvis at the origin, NaN where refused
    """
    mask = ~np.isfinite(poses).all(axis=-1)
    out = _lift_rows(lifter, np.nan_to_num(poses), mask, np.zeros(len(poses), bool),
                     representation, n_jobs, None, weights, both=True)
    return out["front"], out["back"]


def _lift_rows(lifter, poses, mask, bad, representation, n_jobs, layout, weights=None,
               both=False, progress=False):
    """Screen, predict and reconstruct every row: the LiftResult's per-row fields
    (`weights`: per-joint weights a dictionary lifter's lasso applies; `both`: the
    two reflections instead, as ``front`` and ``back``; `progress`: a dictionary
    lifter's bar over its chunks)."""
    N = lifter.n_joints
    n = len(poses)
    m = N * (N - 1) // 2
    status, reason, n_obs, clean = screen_poses(poses, mask, bad)
    status[status == ""] = "lifted"
    status[(status == "lifted") & (n_obs < N)] = "lifted_occluded"
    out = np.full((n, N, 3), np.nan)
    vec3 = np.full((n, m), np.nan)
    scale_metric = np.full(n, np.nan)
    margin = np.full(n, np.nan)
    pair = np.full((2, n, N, 3), np.nan)
    rows = np.flatnonzero(np.isin(status, ("lifted", "lifted_occluded")))
    if len(rows):
        X2, _, _ = represent(clean[rows], mask[rows], representation)
        weighted = {} if not lifter.codes_observed_only else dict(
            progress=progress, **({} if weights is None else {"weights": weights[rows]}))
        Y, info = lifter.predict(X2, mask[rows], n_jobs=n_jobs, **weighted)
        st = info["status"]
        status[rows[st == "inaccurate"]] = "inaccurate"
        reason[rows[st == "inaccurate"]] = "duality gap above tolerance"
        failed = (st == "failed") | ~np.isfinite(Y).all(axis=1) | ~(np.abs(Y) > 0).any(axis=1)
        status[rows[failed]] = "solver_failed"
        reason[rows[failed]] = "the lifter gave no finite answer (or no pose: every distance 0)"
        rows, Y = rows[~failed], Y[~failed]
        if len(rows):
            front, back, score, scale_metric[rows] = _candidates(lifter, Y, poses[rows],
                                                                 mask[rows])
            flip = score < 0 if layout is None else choose_reflections(front, back, score,
                                                                       rows, layout)
            out[rows] = np.where(flip[:, None, None], back, front)
            margin[rows] = np.abs(score)
            vec3[rows] = Y
            pair[0, rows], pair[1, rows] = front, back
    if both:
        return {"front": pair[0], "back": pair[1]}
    return dict(poses3d=out, vectors3d=vec3, scale_metric=scale_metric,
                status=status.astype(object), reason=reason.astype(str),
                chirality_margin=margin)


def _candidates(lifter, vectors3d, poses2d, missing):
    """Both metric reflections (pelvis at the origin), the prior's score of
    ``front``, and metres per lifter unit."""
    normed, _, _ = normalize(np.where(missing[..., None], np.nan, poses2d), missing)
    front, back, score, _ = reflections(vector_to_edm(vectors3d), normed, ~missing,
                                        lifter.chirality_)
    k = lifter.size_prior_ / np.maximum(rms(vectors3d), 1e-12)

    def metric(P):
        return (P - pelvis(P)[:, None, :]) * k[:, None, None]

    return metric(front), metric(back), score, k


def poses_from_vectors(lifter, vectors3d, poses2d, missing):
    """Metric 3D poses from predicted 3D EDM vectors and the 2D input (steps 3-4 above),
    each frame's reflection by the chirality prior's sign.

    Returns ``(poses3d, chirality_margin, scale_metric)``.
    """
    front, back, score, k = _candidates(lifter, vectors3d, poses2d, missing)
    return np.where((score < 0)[:, None, None], back, front), np.abs(score), k
