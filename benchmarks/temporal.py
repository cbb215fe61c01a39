"""Speed of the default video path: frames/s on a 10,000-frame file.

    python -m benchmarks.temporal [--frames 10000] [--out benchmarks/results-temporal.json]

The file: CMU ASF/AMC clips of the data folder at 30 frames/s, one fixed seeded
camera per clip, the clips one after another as tracks (``track`` = clip),
until --frames rows; 1-3 joints per clip lose contiguous runs of 3-90 frames
(about a sixth of the joint-frames missing, protocol A's mix). Written as a
CSV with ``track`` and ``frame`` columns and read back, so the timed rows are
what a user runs end to end:

* ``sparseedm recover video.csv`` defaults: time used, adaptation "auto"
  (:func:`sparseedm.batch.recover_file`, reading and writing included);
* the same with ``--no-temporal``: per-frame recovery with the default
  adaptation;
* per-frame :func:`sparseedm.recover` with ``adapt=False`` on the poses in memory;
* the temporal model on the poses in memory, with defaults and with ``adapt=False``;
* a cubic spline (:func:`sparseedm.temporal.fillers.fill_cubic`) per track;
* the constant-velocity Kalman smoother, its noise fitted per track
  (:func:`sparseedm.temporal.fillers.fill_kalman`).

and one clip of 150 frames given alone (``--clip-frames``), the way most users
call the video path: the first 150 frames of the file's first track (CMU,
which the default dictionary learned from: its adaptation runs and is
rejected by the guard) and, when the data folder has them, of another lab's
clip (Bandai-Namco-1, which it never saw: adapted), each timed as the median of
``--repeats`` calls after a first, untimed one, for ``recover(frames=...)``
with defaults and ``adapt=False``, and for the Kalman smoother on the same clip.

Every row in the same run, single process; the machine and its load are recorded.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

import sparseedm
from sparseedm.batch import recover_file
from sparseedm.cameras import Cameras, project, sample_cameras
from sparseedm.dataset import find_mocap_files
from sparseedm.keypoints import KeypointSet, write_keypoints
from sparseedm.mocap import load_mocap
from sparseedm.temporal.fillers import fill_cubic, fill_kalman
from sparseedm._atomic import save_json


def build_video(data_dir, n_frames, seed=0, folder="cmu-mocap", return_truth=False):
    """(poses with NaN, missing, tracks, frames) of about `n_frames` rows from
    the motion files under ``data_dir / folder``, in sorted order (and the
    poses before the NaN with `return_truth`)."""
    rng = np.random.default_rng(seed)
    files = sorted(find_mocap_files([Path(data_dir) / folder]))
    chunks, tracks, frames, total = [], [], [], 0
    for i, path in enumerate(files):
        poses3d, info = load_mocap(path, return_info=True)
        poses3d = poses3d[::max(1, round(info["frame_rate"] / 30))][:n_frames - total]
        cam = sample_cameras(1, targets=poses3d.reshape(-1, 3).mean(0), distance=(6, 9),
                             random_state=i)
        many = Cameras(*(np.repeat(a, len(poses3d), 0) for a in (cam.R, cam.t, cam.f, cam.c)))
        try:
            chunks.append(project(poses3d, many))
        except sparseedm.exceptions.PoseError:
            continue
        tracks += [path.stem] * len(poses3d)
        frames += list(range(len(poses3d)))
        total += len(poses3d)
        if total >= n_frames:
            break
    poses = np.concatenate(chunks)
    missing = np.zeros(poses.shape[:2], bool)
    tracks = np.array(tracks)
    for clip in np.unique(tracks):
        rows = np.flatnonzero(tracks == clip)
        for j in rng.choice(14, rng.integers(1, 4), replace=False):
            t = int(rng.integers(0, 30))
            while t < len(rows):
                gap = int(rng.choice([3, 10, 30, 90]))
                missing[rows[t:t + gap], j] = True
                t += gap + int(rng.integers(gap, 4 * gap + 1))
    truth = poses.copy()
    poses[missing] = np.nan
    if return_truth:
        return poses, missing, tracks, np.array(frames), truth
    return poses, missing, tracks, np.array(frames)


def timed(func):
    t0 = time.perf_counter()
    out = func()
    return out, time.perf_counter() - t0


#: another lab's clips (read from the data folder; only timings written)
OTHER_LAB = "bandai-namco-1/data"


def _median_seconds(func, repeats):
    func()  # the first call: numba's kernels loaded, the dictionary's Gram cached
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def one_clip(data_dir, n_frames=150, repeats=5):
    """Seconds of one clip of `n_frames` given alone, after a first call: the
    default video path, ``adapt=False`` and the Kalman smoother (module docstring)."""
    rows = {}
    for name, folder in (("cmu", "cmu-mocap"), ("other lab", OTHER_LAB)):
        if not (Path(data_dir) / folder).is_dir():
            continue
        poses, missing, tracks, frames = build_video(data_dir, 20 * n_frames, folder=folder)
        firsts = [t for t in dict.fromkeys(tracks.tolist()) if (tracks == t).sum() >= n_frames]
        sel = np.flatnonzero(tracks == firsts[0])[:n_frames]
        p, m, f = poses[sel], missing[sel], frames[sel]
        res = sparseedm.recover(p, m, frames=f)
        for label, kw in (("defaults", {}), ("adapt=False", dict(adapt=False))):
            sec = _median_seconds(lambda kw=kw: sparseedm.recover(p, m, frames=f, **kw),
                                  repeats)
            rows[f"{name} clip: recover(frames=...), {label}"] = dict(
                seconds=round(sec, 3), frames_per_second=round(len(p) / sec, 1))
        rows[f"{name} clip: recover(frames=...), defaults"].update(
            adapted=None if res.adaptation is None else bool(res.adaptation.adapted),
            per_frame_poses=res.per_frame_poses, probe_poses=res.probe_poses)
        sec = _median_seconds(lambda: fill_kalman(p, m, f), repeats)
        rows[f"{name} clip: Kalman smoother (fill_kalman)"] = dict(
            seconds=round(sec, 3), frames_per_second=round(len(p) / sec, 1))
    return dict(frames=n_frames, repeats=repeats, rows=rows)


def run(data_dir, n_frames):
    poses, missing, tracks, frames = build_video(data_dir, n_frames)
    n = len(poses)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        inp = write_keypoints(Path(tmp) / "video.csv", KeypointSet(
            poses, missing, tracks=tracks, frames=frames))
        sparseedm.recover(poses[:50], missing[:50], adapt=False)  # JIT warm-up
        for name, kw in (("file: default video path (time, adapt auto)", {}),
                         ("file: time, adapt auto, --self-training 0",
                          dict(self_training=0)),
                         ("file: --no-temporal (per frame, adapt auto)",
                          dict(temporal=False))):
            s, sec = timed(lambda: recover_file(inp, Path(tmp) / "out.csv", **kw))
            rows[name] = dict(seconds=round(sec, 2), frames_per_second=round(n / sec, 1),
                              adapted=(s["adaptation"] or {}).get("adapted"),
                              temporal=s.get("temporal"))
    res, sec = timed(lambda: sparseedm.recover(poses, missing, adapt=False))
    rows["api: per-frame recover(adapt=False)"] = dict(seconds=round(sec, 2),
                                                       frames_per_second=round(n / sec, 1))
    res, sec = timed(lambda: sparseedm.recover(poses, missing, tracks=tracks, frames=frames))
    rows["api: temporal recover(frames=...), defaults"] = dict(
        seconds=round(sec, 2), frames_per_second=round(n / sec, 1),
        per_frame_poses=res.per_frame_poses,
        adaptation_seconds=round(res.adaptation.seconds, 2) if res.adaptation else 0.0,
        adapted=None if res.adaptation is None else bool(res.adaptation.adapted))
    res, sec = timed(lambda: sparseedm.recover(poses, missing, tracks=tracks, frames=frames,
                                               adapt=False))
    rows["api: temporal recover(frames=..., adapt=False)"] = dict(
        seconds=round(sec, 2), frames_per_second=round(n / sec, 1),
        per_frame_poses=res.per_frame_poses)

    def per_track(fill):
        for clip in np.unique(tracks):
            r = tracks == clip
            fill(poses[r], missing[r], frames[r])

    for name, fill in (("cubic spline per track (fill_cubic)", fill_cubic),
                       ("Kalman smoother per track (fill_kalman)", fill_kalman)):
        _, sec = timed(lambda: per_track(fill))
        rows[name] = dict(seconds=round(sec, 2), frames_per_second=round(n / sec, 1))
    return dict(frames=n, tracks=int(len(np.unique(tracks))),
                missing_fraction=round(float(missing.mean()), 3),
                machine=f"{platform.platform()}, {os.cpu_count()} cores",
                load_average=[round(x, 2) for x in os.getloadavg()], rows=rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default="../shared/data")
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--out", default=None)
    ap.add_argument("--clip-frames", type=int, default=150)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    load = [round(x, 2) for x in os.getloadavg()]
    clip = one_clip(args.data_dir, args.clip_frames, args.repeats)
    out = run(args.data_dir, args.frames)
    out["one_clip"] = dict(clip, load_average_before=load)
    print(json.dumps(out, indent=1))
    if args.out:
        save_json(args.out, out, indent=1)


if __name__ == "__main__":
    main()
