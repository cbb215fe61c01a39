"""Lifting a video (sparseedm.lift with frames): 2D filled across time first,
depth reflections chosen per track together (sparseedm.lifting.mds.reflection_path)."""

import csv
import itertools
from pathlib import Path

import numpy as np
import pytest

import sparseedm
from sparseedm.cli import main
from sparseedm.exceptions import SparseEDMError
from sparseedm.keypoints import read_keypoints
from sparseedm.lifting.metrics import mpjpe
from sparseedm.lifting import video as video_module
from sparseedm.lifting.mds import reflection_path
from sparseedm.lifting.video import smooth_tracks
from sparseedm.temporal.tracks import split_tracks
from sparseedm.skeleton import JOINT_NAMES

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _path_cost(path, front, back, score, frames, smoothness):
    P = np.where(path[:, None, None], back, front)
    unary = np.where(path, np.logaddexp(0, score), np.logaddexp(0, -score)).sum()
    dt = np.diff(frames)
    return unary + smoothness * (((P[1:] - P[:-1]) ** 2).sum(axis=(1, 2)) / dt).sum()


@pytest.mark.parametrize("seed", range(4))
def test_reflection_path_is_the_exact_optimum(seed):
    rng = np.random.default_rng(seed)
    T = 9
    front = np.cumsum(0.05 * rng.standard_normal((T, 14, 3)), axis=0) \
        + rng.standard_normal((1, 14, 3)) * [0.3, 0.8, 0.3]
    back = front * [1.0, 1.0, -1.0]
    score = 2.0 * rng.standard_normal(T)
    frames = np.cumsum(rng.integers(1, 4, T))
    got = reflection_path(front, back, score, frames, smoothness=3.0)
    best = min(itertools.product([False, True], repeat=T),
               key=lambda p: _path_cost(np.array(p), front, back, score, frames, 3.0))
    assert _path_cost(got, front, back, score, frames, 3.0) == pytest.approx(
        _path_cost(np.array(best), front, back, score, frames, 3.0), rel=1e-12)
    # smoothness 0 is the prior's sign, frame by frame
    np.testing.assert_array_equal(reflection_path(front, back, score, frames, 0.0), score < 0)


def test_a_misjudged_frame_of_a_moving_person_follows_its_neighbours():
    rng = np.random.default_rng(1)
    base = rng.standard_normal((14, 3)) * [0.3, 0.8, 0.3]
    front = np.stack([base + 0.01 * t for t in range(7)])
    back = front * [1.0, 1.0, -1.0]
    score = np.array([1.5, 2.0, 1.0, -0.8, 1.2, 2.2, 1.7])
    assert not reflection_path(front, back, score, np.arange(7)).any()
    # far apart in time, the frame is judged on its own again
    frames = np.array([0, 1, 2, 500, 1000, 1001, 1002])
    np.testing.assert_array_equal(reflection_path(front, back, score, frames), score < 0)


@pytest.fixture(scope="module")
def video():
    kps = read_keypoints(EXAMPLES / "video_clip.csv")
    with np.load(EXAMPLES / "video_clip_truth.npz") as z:
        truth = z["poses2d"]
    return kps, truth


@pytest.fixture(scope="module")
def lifted(video):
    """(complete truth lifted frame by frame, the same as a video, the occluded
    clip lifted frame by frame, the same as a video)."""
    kps, truth = video
    when = dict(tracks=kps.tracks, frames=kps.frames)
    return (sparseedm.lift(truth).poses3d, sparseedm.lift(truth, **when).poses3d,
            sparseedm.lift(kps.poses, kps.missing),
            sparseedm.lift(kps.poses, kps.missing, **when))


def test_video_lift_fills_2d_across_time_first(video, lifted):
    kps, truth = video
    complete3d, complete_video, per_frame, in_time = lifted
    hidden = kps.missing.any(axis=1)
    np.testing.assert_array_equal(in_time.filled, kps.missing)  # every hidden joint filled
    np.testing.assert_array_equal(in_time.missing, kps.missing)
    assert set(in_time.status[hidden]) == {"lifted_filled"}
    assert set(per_frame.status[hidden]) == {"lifted_occluded"}
    assert in_time.summary()["filled_across_time"] == int(hidden.sum())
    # observed 2D joints are lifted as given; filled ones near the truth
    obs = ~kps.missing
    np.testing.assert_array_equal(in_time.poses2d[obs], kps.poses[obs])
    # the 2D radius travels with the lift: 0 observed, positive filled, NaN per frame
    assert (in_time.uncertainty2d[obs] == 0).all()
    assert (in_time.uncertainty2d[kps.missing] > 0).all()
    assert np.isnan(per_frame.uncertainty2d[kps.missing]).all()
    body = np.ptp(truth[..., 1], axis=1).mean()
    assert np.linalg.norm(in_time.poses2d - truth, axis=-1)[kps.missing].mean() < 0.03 * body
    # the 3D of the hidden frames lands much nearer what the complete 2D lifts to
    near_time = mpjpe(in_time.poses3d, complete_video)[hidden].mean()
    near_frame = mpjpe(per_frame.poses3d, complete3d)[hidden].mean()
    assert near_time < 0.6 * near_frame, (near_time, near_frame)


def test_complete_frames_lift_as_alone_but_for_the_smoothing(video, lifted, monkeypatch):
    kps, truth = video
    complete3d, complete_video = lifted[:2]
    # smoothing moves them (the per-frame lasso's jitter), by little
    moved = mpjpe(complete_video, complete3d)
    assert 0 < moved.mean() < 15  # mm
    monkeypatch.setattr(video_module, "TRAJECTORY_SMOOTHNESS", 0.0)
    alone = sparseedm.lift(truth, tracks=kps.tracks, frames=kps.frames).poses3d
    np.testing.assert_array_equal(alone, complete3d)  # every reflection here is clear


def _layout(frames):
    return split_tracks(len(frames), None, frames)


def test_smoothing_keeps_steady_motion_and_refused_rows():
    rng = np.random.default_rng(3)
    frames = np.r_[0:10, 12:20]  # two skipped frames
    start, step = rng.standard_normal((1, 14, 3)), 0.01 * rng.standard_normal((1, 14, 3))
    steady = start + frames[:, None, None] * step
    steady[4] = np.nan  # a refused row
    out = smooth_tracks(steady.copy(), _layout(frames), 30.0)
    assert np.isnan(out[4]).all()
    np.testing.assert_allclose(out[np.arange(18) != 4], steady[np.arange(18) != 4],
                               rtol=0, atol=1e-9)
    # jitter around the steady motion is pulled back towards it
    noisy = steady + 0.02 * rng.standard_normal(steady.shape)
    out = smooth_tracks(noisy.copy(), _layout(frames), 30.0)
    keep = np.arange(18) != 4
    assert np.abs(out - steady)[keep].mean() < 0.6 * np.abs(noisy - steady)[keep].mean()
    np.testing.assert_array_equal(smooth_tracks(noisy.copy(), _layout(frames), 0.0), noisy)


def test_video_lift_does_not_depend_on_row_order(video, lifted):
    kps, _ = video
    order = np.random.default_rng(0).permutation(len(kps.poses))
    res = sparseedm.lift(kps.poses[order], kps.missing[order], tracks=kps.tracks[order],
                         frames=kps.frames[order])
    np.testing.assert_allclose(res.poses3d, lifted[3].poses3d[order], rtol=0, atol=1e-9)


def test_rows_time_cannot_use_are_lifted_alone_and_nothing_is_lost(video):
    kps, _ = video
    rows = slice(0, 60)
    poses, missing = kps.poses[rows].copy(), kps.missing[rows].copy()
    frames = kps.frames[rows].astype(float)
    frames[5] = np.nan  # no frame number
    frames[7] = frames[6]  # a duplicate (track, frame)
    poses[9, 0] = np.inf  # a bad coordinate
    res = sparseedm.lift(poses, missing, tracks=np.full(60, "a"), frames=frames)
    assert res.status[9] == "invalid_coordinates" and res.reason[9]
    for r in (5, 6, 7):
        assert not res.filled[r].any()
        assert res.status[r] == ("lifted_occluded" if missing[r].any() else "lifted")
    assert res.reason[5] == "lifted on its own, not across time: frame number is nan"
    assert res.reason[6] == res.reason[7] == ("lifted on its own, not across time: its "
                                              "(track, frame) pair is given more than once")
    assert not any("on its own" in r for r in np.delete(res.reason, [5, 6, 7]))
    assert res.ok.sum() == len(poses) - 1
    assert np.isfinite(res.poses3d[res.ok]).all()


def test_a_frame_with_every_joint_missing_is_lifted_from_its_fill(cmu_poses):
    """A detector's empty frame in a track of poses that move a lot between
    frames (every joint below the threshold): filled across time with wide
    radii, then lifted from the filled joints alone (their weights say how they
    compare; all far below 1, the lasso coded no pose and the image alignment
    met a singular matrix: an internal error)."""
    poses = cmu_poses[:40].copy()
    poses[[10, 25]] = np.nan
    res = sparseedm.lift(poses, frames=np.arange(40))
    assert res.ok.all() and res.filled[[10, 25]].all()
    assert np.isfinite(res.poses3d).all() and (np.ptp(res.poses3d[[10, 25]], axis=1) > 0).all()
    height = np.ptp(res.poses3d[:, :, 1], axis=1)
    assert np.all(np.abs(height[[10, 25]] / np.median(height) - 1) < 0.3)
