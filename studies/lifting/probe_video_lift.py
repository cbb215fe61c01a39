"""Lifting a video: each frame alone, or across time? Measured on validation sequences.

    nice python studies/lifting/probe_video_lift.py [--data-dir ../shared/data] [--sequences 10]

The video protocols' validation sequences (``benchmarks/video_protocols.py``:
Bandai-Namco-1's validation clips and CMU subjects 05, 07, 10, 32, 38, 43, 55,
one fixed camera per clip), lifted by the shipped lifter (``cmu-lift``, learned
on CMU only, so Bandai-Namco is another lab's data to it):

* ``per frame``: ``lift(poses)``, each frame from its observed joints, its
  depth reflection by the chirality prior's sign (the path before);
* ``time``: ``lift(poses, frames=)``, the default for a video: the missing 2D
  joints filled across time first (:mod:`sparseedm.temporal`, its defaults,
  the 2D dictionary of the video protocols: the shipped one on Bandai-Namco,
  ``cmu-k2000``, subjects 01-03 only, on CMU), then each clip's depth
  reflections chosen together (:func:`sparseedm.lifting.mds.reflection_path`);
* the settings of :mod:`sparseedm.lifting.video`, chosen in this order, each
  with the later ones off, each as the least MPJPE summed over both sources:

  1. on complete sequences, the reflection path at smoothness 0, 1, 3, 10,
     30, 100 (:data:`sparseedm.lifting.mds.REFLECTION_SMOOTHNESS`);
  2. on the hidden joints' frames (both protocols), ``time, fill up to
     weight w``: only the joints whose fill leaned on the per-frame 2D model
     with weight at most w (0: the joints time alone fills, near an
     observation) are filled before lifting, the rest left to the lifter's
     lasso (:data:`~sparseedm.lifting.video.TIME_FILL_MAX_WEIGHT`; 1, every
     joint time filled, is ``time, trajectories unsmoothed``);
  3. in every condition, the 3D trajectories smoothed at 0, 1, 3, 10, 30,
     100, 300 (:data:`~sparseedm.lifting.video.TRAJECTORY_SMOOTHNESS`);

  and ``time, reflection per frame`` (the fill alone, smoothing off).

Conditions: complete (nothing hidden), Protocol B (self-occlusion + dropouts)
and Protocol A (gaps of 3 / 10 / 30 / 90 frames, pooled). Scores per
condition: MPJPE and PA-MPJPE (mm; pelvis-centred, at the lifter's size
prior, against the camera-frame truth) and the share of frames whose depth
reflection is the closer one to the truth, over the frames with a hidden
joint (all frames when complete). Only scores are written (Bandai-Namco is CC
BY-NC): ``studies/lifting/selection_video.json``.

Once the settings were chosen, the held-out split was measured once, the
defaults against each frame alone (no grid)::

    nice python studies/lifting/probe_video_lift.py --split test --out studies/lifting/test_video.json
"""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from unittest import mock

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import video_protocols as vp  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.lifting import lift, load_lifter  # noqa: E402
from sparseedm.lifting import video  # noqa: E402
from sparseedm.lifting.mds import reflection_path  # noqa: E402
from sparseedm.lifting.video import smooth_tracks  # noqa: E402
from sparseedm.lifting.metrics import mpjpe, pa_mpjpe, pelvis  # noqa: E402
from sparseedm.temporal.evaluation import protocol_masks  # noqa: E402
from sparseedm.temporal.tracks import split_tracks  # noqa: E402

SMOOTHNESS_GRID = (0.0, 1.0, 3.0, 10.0, 30.0, 100.0)
#: TIME_FILL_MAX_WEIGHT's grid besides 1 (every joint time filled)
FILL_GRID = (0.0, 0.5)
TRAJECTORY_GRID = (0.0, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0)


def _patched(name, value):
    """lift() with a setting of :mod:`sparseedm.lifting.video` changed (the probe's grids)."""
    return mock.patch.object(video, name, value)


def _with_smoothness(value):
    """lift() with the reflection path at another smoothness (the probe's grid)."""
    path = functools.partial(reflection_path, smoothness=value)
    return mock.patch.object(video, "reflection_path", path)


def _scores(P, cam, rows):
    truth = cam - pelvis(cam)[:, None]
    mirror = P * np.array([1.0, 1.0, -1.0])
    mirror = mirror - pelvis(mirror)[:, None]
    keep = np.linalg.norm(P - truth, axis=-1).mean(1) <= np.linalg.norm(mirror - truth,
                                                                         axis=-1).mean(1)
    ok = rows & np.isfinite(P).all(axis=(1, 2))
    return dict(mpjpe=mpjpe(P[ok], cam[ok]), pa=pa_mpjpe(P[ok], cam[ok]), right=keep[ok],
                unlifted=int((rows & ~ok).sum()))


def _methods(given, missing, frames, dictionary, lifter, complete, grids=True):
    """Every method's poses3d. The settings were chosen in this order, each with
    the ones after it off: the reflection smoothness (complete input), the fill
    weight (hidden joints), then the trajectory smoothness (all conditions)."""
    kw = dict(frames=frames, lifter=lifter, dictionary=dictionary)
    out = {"per frame": lift(given, missing, lifter=lifter).poses3d,
           "time": lift(given, missing, **kw).poses3d}
    if not grids:
        return out
    with _patched("TRAJECTORY_SMOOTHNESS", 0.0):
        unsmoothed = lift(given, missing, **kw).poses3d
        out["time, trajectories unsmoothed"] = unsmoothed
        if complete:
            for value in SMOOTHNESS_GRID:
                with _with_smoothness(value):
                    out[f"smoothness {value:g}"] = lift(given, missing, **kw).poses3d
        else:
            with _with_smoothness(0.0):
                out["time, reflection per frame"] = lift(given, missing, **kw).poses3d
            for w in FILL_GRID:
                with _patched("TIME_FILL_MAX_WEIGHT", w):
                    out[f"time, fill up to weight {w:g}"] = lift(given, missing, **kw).poses3d
    layout = split_tracks(len(frames), None, frames)
    for value in TRAJECTORY_GRID:  # smoothing is lift's last step
        out[f"trajectory smoothness {value:g}"] = smooth_tracks(unsmoothed.copy(), layout,
                                                                value)
    return out


def rows_of(source, n_sequences, split="validation"):
    dictionary = load_dictionary(vp.DICTIONARY[source])
    lifter = load_lifter(None)
    acc = {}
    for seq in vp.sequences(source, split, n_sequences, 0):
        cam = np.einsum("ij,nkj->nki", seq.camera.R[0], seq.poses3d) + seq.camera.t[0]
        masks = {"complete": np.zeros(seq.poses2d.shape[:2], bool)}
        masks["self-occlusion"] = protocol_masks(seq, "self-occlusion")["self-occlusion"]
        for cond, m in protocol_masks(seq, "gaps").items():
            masks[f"gaps: {cond}"] = m
        for cond, missing in masks.items():
            groups = ["gaps", cond] if cond.startswith("gaps") else [cond]
            given = np.where(missing[..., None], np.nan, seq.poses2d)
            rows = missing.any(axis=1) if cond != "complete" else np.ones(len(seq), bool)
            for name, P in _methods(given, missing, seq.frames, dictionary, lifter,
                                    cond == "complete", split == "validation").items():
                s = _scores(P, cam, rows)
                for group in groups:
                    a = acc.setdefault((group, name), dict(mpjpe=[], pa=[], right=[],
                                                           unlifted=0))
                    for k in ("mpjpe", "pa", "right"):
                        a[k].append(s[k])
                    a["unlifted"] += s["unlifted"]
    for (group, name), a in acc.items():
        yield dict(source=source, condition=group, method=name,
                   frames=int(sum(len(v) for v in a["mpjpe"])),
                   mpjpe=round(float(np.concatenate(a["mpjpe"]).mean()), 2),
                   pa_mpjpe=round(float(np.concatenate(a["pa"]).mean()), 2),
                   reflection_ok=round(float(np.concatenate(a["right"]).mean()), 4),
                   unlifted=a["unlifted"])


def summarise(rows):
    """The smoothness grid's MPJPE summed over the sources (complete input), and
    per condition the gain of lifting across time over each frame alone."""
    grid = {}
    for r in rows:
        if r["condition"] == "complete" and r["method"].startswith("smoothness"):
            grid[r["method"]] = round(grid.get(r["method"], 0.0) + r["mpjpe"], 2)
    fill = {}
    for r in rows:
        if r["condition"] in ("gaps", "self-occlusion") and r["method"].startswith("time"):
            if r["method"] in ("time, trajectories unsmoothed", "time, fill up to weight 0",
                               "time, fill up to weight 0.5"):
                fill[r["method"]] = round(fill.get(r["method"], 0.0) + r["mpjpe"], 2)
    traj = {}
    for r in rows:
        if r["condition"] in ("complete", "gaps", "self-occlusion") \
                and r["method"].startswith("trajectory smoothness"):
            traj[r["method"]] = round(traj.get(r["method"], 0.0) + r["mpjpe"], 2)
    out = [{"smoothness (complete, MPJPE summed over sources)": grid,
            "chosen": min(grid, key=grid.get) if grid else None},
           {"fill (gaps and self-occlusion, MPJPE summed over sources)": fill,
            "chosen": min(fill, key=fill.get) if fill else None},
           {"trajectory smoothness (every condition, MPJPE summed over sources)": traj,
            "chosen": min(traj, key=traj.get) if traj else None}]
    by = {(r["source"], r["condition"], r["method"]): r for r in rows}
    for (source, cond, method), r in by.items():
        if method == "time":
            base = by[(source, cond, "per frame")]
            out.append(dict(source=source, condition=cond,
                            mpjpe=[base["mpjpe"], r["mpjpe"]],
                            pa_mpjpe=[base["pa_mpjpe"], r["pa_mpjpe"]],
                            reflection_ok=[base["reflection_ok"], r["reflection_ok"]],
                            ratio=round(r["mpjpe"] / base["mpjpe"], 3)))
    return out


if __name__ == "__main__":
    vp.probe_main(__doc__, rows_of, summarise, count="sequences", default=10,
                  out=str(ROOT / "lifters" / "selection_video.json"), test_split=True)
