"""Where the default video path's time goes, and what the prior stride saves.

    nice python -m benchmarks.video_speed [--frames 10000] [--out results.json]

The file is :func:`benchmarks.temporal.build_video`'s (CMU clips at 30 frames/s
as tracks, one seeded camera each, contiguous gaps of 3-90 frames). Rows, all
in one run and one process, the machine and its load recorded before and
after:

* ``sparseedm recover video.csv`` with defaults (:func:`sparseedm.batch.recover_file`:
  time, adaptation "auto", reading and writing included) and with
  ``--no-temporal`` (the per-frame path);
* :func:`sparseedm.recover` on the poses in memory, time used, with adaptation
  "auto" and ``adapt=False``, at the default ``prior_stride`` and at stride 1
  (every frame whose answer weighs asks the per-frame model: the path before
  the stride), each split into its stages (adaptation, per-frame answers,
  the rest) from the result;
* per-frame :func:`sparseedm.recover` ``adapt=False``.

Ratios are against the per-frame path and against ``adapt=False`` of the same
run. The CMU clips are ones the default dictionary learned from, so there
adaptation is rejected by its guard; users' poses are not. When the data
folder has them, the same file built from another lab's clips
(:data:`OTHER_LAB`, ``other_lab`` in the JSON) is timed too: with defaults,
with ``--self-training 1`` and ``0``, the temporal path with
``adapt=False`` (its ratios are against that row), and its first 12 tracks
given one clip per call, with defaults and with ``adapt=False`` (the way most
users meet the video path), and a file three times as long with defaults
(the self-training rounds cost the same on any file). Speed is measured
here, never in tests.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import sparseedm
from sparseedm.batch import recover_file
from sparseedm.keypoints import KeypointSet, write_keypoints
from sparseedm.temporal.model import DEFAULT_SETTINGS
from sparseedm.temporal.recover import recover_temporal
from sparseedm._atomic import json_text, save_json

try:
    from .temporal import build_video
except ImportError:  # run as a script
    from temporal import build_video


#: another lab's clips (Bandai-Namco-1, CC BY-NC: read from the data folder,
#: only timings written), which no shipped dictionary saw
OTHER_LAB = "bandai-namco-1/data"


def _row(n, seconds, **extra):
    return dict(seconds=round(seconds, 2), frames_per_second=round(n / seconds, 1), **extra)


def _api_row(poses, missing, tracks, frames, adapt, stride):
    settings = replace(DEFAULT_SETTINGS, prior_stride=stride)
    t0 = time.perf_counter()
    res = recover_temporal(poses, missing, tracks=tracks, frames=frames, adapt=adapt,
                           settings=settings)
    sec = time.perf_counter() - t0
    adapt_sec = res.adaptation.seconds if res.adaptation is not None else 0.0
    return _row(len(poses), sec, per_frame_poses=res.per_frame_poses,
                adaptation_seconds=round(adapt_sec, 2),
                adapted=None if res.adaptation is None else bool(res.adaptation.adapted))


def _file_rows(poses, missing, tracks, frames, variants):
    """`recover_file` on the poses written as a CSV, once per (name, kwargs)."""
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        inp = write_keypoints(Path(tmp) / "video.csv", KeypointSet(
            poses, missing, tracks=tracks, frames=frames))
        for name, kw in variants:
            t0 = time.perf_counter()
            s = recover_file(inp, Path(tmp) / "out.csv", **kw)
            rows[name] = _row(len(poses), time.perf_counter() - t0,
                              adapted=(s["adaptation"] or {}).get("adapted"))
    return rows


def _clip_rows(poses, missing, tracks, frames, n_clips=12):
    """Users with one video at a time: the first `n_clips` tracks, one
    :func:`recover_temporal` call each (defaults, then ``adapt=False``)."""
    rows = {}
    picked = [tracks == t for t in list(dict.fromkeys(tracks.tolist()))[:n_clips]]
    for name, kw in (("api: one clip per call, defaults", {}),
                     ("api: one clip per call, adapt=False", dict(adapt=False))):
        t0 = time.perf_counter()
        for sel in picked:
            recover_temporal(poses[sel], missing[sel], frames=frames[sel], **kw)
        rows[name] = _row(int(sum(s.sum() for s in picked)), time.perf_counter() - t0,
                          clips=len(picked))
    return rows


def _other_lab(data_dir, n_frames, stride):
    """The default path on another lab's clips (OTHER_LAB, read from the data
    folder, never written): there adaptation is adopted and self-trains."""
    poses, missing, tracks, frames = build_video(data_dir, n_frames, folder=OTHER_LAB)
    rows = _file_rows(poses, missing, tracks, frames, (
        ("file: default video path (time, adapt auto)", {}),
        ("file: --self-training 1", dict(self_training=1)),
        ("file: --self-training 0", dict(self_training=0))))
    rows[f"api: temporal, adapt=False, prior_stride={stride}"] = _api_row(
        poses, missing, tracks, frames, False, stride)
    rows.update(_clip_rows(poses, missing, tracks, frames))
    # the self-training rounds are a fixed cost (2,000 sampled poses a round):
    # the same kind of file, three times as long, with defaults
    big = build_video(data_dir, 3 * n_frames, folder=OTHER_LAB)
    rows.update({f"{name} ({len(big[0])} frames)": r for name, r in _file_rows(
        *big, (("file: default video path (time, adapt auto)", {}),)).items()})
    off = rows[f"api: temporal, adapt=False, prior_stride={stride}"]["seconds"]
    for r in rows.values():
        r["speed_vs_temporal_adapt_off"] = round(off / r["seconds"], 2)
    return dict(folder=OTHER_LAB, frames=len(poses), tracks=int(len(set(tracks))),
                missing_fraction=round(float(missing.mean()), 3), rows=rows)


def run(data_dir, n_frames):
    poses, missing, tracks, frames = build_video(data_dir, n_frames)
    n = len(poses)
    load_before = [round(x, 2) for x in os.getloadavg()]
    sparseedm.recover(poses[:200], missing[:200], adapt=False)  # numba kernels loaded
    rows = _file_rows(poses, missing, tracks, frames, (
        ("file: default video path (time, adapt auto)", {}),
        ("file: --no-temporal (per frame, adapt auto)", dict(temporal=False))))
    stride = DEFAULT_SETTINGS.prior_stride
    for adapt in ("auto", False):
        for s in sorted({stride, 1}, reverse=True):
            rows[f"api: temporal, adapt={adapt}, prior_stride={s}"] = _api_row(
                poses, missing, tracks, frames, adapt, s)
    t0 = time.perf_counter()
    sparseedm.recover(poses, missing, adapt=False)
    rows["api: per-frame recover(adapt=False)"] = _row(n, time.perf_counter() - t0)
    per_frame = rows["api: per-frame recover(adapt=False)"]["seconds"]
    off = rows[f"api: temporal, adapt=False, prior_stride={stride}"]["seconds"]
    for r in rows.values():
        r["speed_vs_per_frame_adapt_off"] = round(per_frame / r["seconds"], 2)
        r["speed_vs_temporal_adapt_off"] = round(off / r["seconds"], 2)
    other = (_other_lab(data_dir, n_frames, stride)
             if (Path(data_dir) / OTHER_LAB).is_dir() else None)
    return dict(frames=n, tracks=int(len(set(tracks))),
                missing_fraction=round(float(missing.mean()), 3), default_prior_stride=stride,
                machine=f"{platform.platform()}, {os.cpu_count()} cores",
                load_average_before=load_before,
                load_average_after=[round(x, 2) for x in os.getloadavg()], rows=rows,
                other_lab=other)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default="../shared/data")
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--out", default="benchmarks/results-video-speed.json",
                    help="the JSON written (default: the tracked one)")
    args = ap.parse_args(argv)
    text = json_text(run(args.data_dir, args.frames), indent=1)
    print(text)
    save_json(args.out, json.loads(text), indent=1)


if __name__ == "__main__":
    main()
