"""A segment's own frames as the prior of a hidden joint: the joint carried by its neighbours.

A joint hidden at frame ``t`` and observed at frames ``s`` of the same segment
is placed, from each such ``s``, where its nearest observed neighbours in the
skeleton (the fewest bones away among the joints observed at both frames)
carry it: its position at ``s`` moved by their mean displacement from ``s``
to ``t``. The placements are averaged with weights ``exp(-|t - s| / tau)``,
so the nearest observations decide. It is the person's own geometry (limb
lengths, how the head sits on the neck), held over the run, where the
per-frame pose model knows only the frame's observed joints and what its
dictionary's people look like.

:func:`carried_prior` is what :func:`sparseedm.temporal.model.fill_segment`
uses as the prior of the joints observed somewhere in a segment when
``TemporalSettings.carry`` is on; a joint never observed keeps the per-frame
answer.
"""

from __future__ import annotations

import numpy as np

from ..skeleton import skeleton_hops

__all__ = ["carried_prior", "CARRY_FRAMES"]

#: observed frames on each side of a hidden frame that carry it (the nearest;
#: with ``tau`` of a few frames the further ones weigh nothing)
CARRY_FRAMES = 6


def _nearest_observed(obs_frames, t, k):
    """(len(t), 2k) indices into `obs_frames` of the k nearest observed frames on
    each side of every frame `t`, and whether each exists."""
    pos = np.searchsorted(obs_frames, t)
    idx = pos[:, None] + np.arange(-k, k)[None, :]
    ok = (idx >= 0) & (idx < len(obs_frames))
    return np.clip(idx, 0, len(obs_frames) - 1), ok


def carried_prior(values, free, parents, tau, frames=None):
    """Each hidden joint carried from its observed frames by its nearest observed neighbours.

    Parameters
    ----------
    values : ndarray (T, N, 2)
        A segment's coordinates (read where not free).
    free : ndarray of bool (T, N)
        Its unknown joints.
    parents : sequence of int
        The skeleton's parents (:func:`~sparseedm.skeleton.skeleton_hops`).
    tau : float
        Frames over which an observation's weight falls by e.
    frames : ndarray of bool (T,), optional
        Only these frames (default all).

    Returns
    -------
    ndarray (T, N, 2)
        The carried placement at the free joint-frames of joints observed in
        the segment, where some neighbour is observed at both frames; NaN
        elsewhere.

    Examples
    --------
    A wrist hidden for three frames while its elbow moves right by 1 px a
    frame follows the elbow:

    >>> from sparseedm.skeleton import SKELETON_14
    >>> values = np.zeros((6, 14, 2)); values[:, :, 0] = np.arange(6.0)[:, None]
    >>> values[:, 4, 1] = 5.0                      # the wrist 5 px below the others
    >>> free = np.zeros((6, 14), bool); free[2:5, 4] = True
    >>> out = carried_prior(values, free, SKELETON_14.parents, 3.0)
    >>> out[2:5, 4].round(6).tolist()
    [[2.0, 5.0], [3.0, 5.0], [4.0, 5.0]]
    """
    hops = skeleton_hops(parents)
    T, N = free.shape
    obs = ~free
    out = np.full(values.shape, np.nan)
    want = free if frames is None else free & np.asarray(frames, bool)[:, None]
    for j in np.flatnonzero(want.any(axis=0) & obs.any(axis=0)):
        seen = np.flatnonzero(obs[:, j])
        t = np.flatnonzero(want[:, j])
        idx, ok = _nearest_observed(seen, t, CARRY_FRAMES)
        s = seen[idx]                                   # (h, 2k)
        both = obs[t][:, None, :] & obs[s]              # (h, 2k, N)
        both[..., j] = False
        hop = np.where(both, hops[j], N + 1)
        level = hop.min(axis=-1)
        near = both & (hop == level[..., None])
        count = near.sum(axis=-1)
        ok &= count > 0
        if not ok.any():
            continue
        moved = ((values[t][:, None] - values[s]) * near[..., None]).sum(axis=-2)
        moved /= np.maximum(count, 1)[..., None]
        weight = np.where(ok, np.exp(-np.abs(t[:, None] - s) / tau), 0.0)
        total = weight.sum(axis=1)
        placed = ((values[s, j] + moved) * weight[..., None]).sum(axis=1)
        has = total > 0
        out[t[has], j] = placed[has] / total[has, None]
    return out
