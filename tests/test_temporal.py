"""Temporal recovery: the banded model, recover(frames=...), bad input."""

import warnings

from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import sparseedm
from sparseedm.exceptions import ParameterError
from sparseedm.temporal.model import (TemporalSettings, coupling, fill_segment, needs_prior,
                                      observation_weight, prior_frames,
                                      reference_trajectories)
from sparseedm.temporal.recover import SOURCES, TemporalResult, recover_temporal, recover_track
from sparseedm.temporal.smoothing import smooth_trajectory
from sparseedm.temporal.tracks import distance_to_observed, split_tracks

WRIST = 4


def _height(poses):
    return np.ptp(poses[..., 1], axis=1).mean()


def _error(filled, truth, mask):
    return np.linalg.norm(filled - truth, axis=-1)[mask].mean() / _height(truth)


# -- the banded core ------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(30))
def test_banded_solve_matches_dense_solve(seed):
    rng = np.random.default_rng(seed)
    T = int(rng.integers(3, 25))
    values, prior = rng.normal(size=(T, 2)), rng.normal(size=(T, 2))
    free = rng.random(T) < 0.6
    free[rng.integers(T)] = False  # at least one anchor
    weight = np.where(rng.random(T) < 0.5, rng.random(T), 0.0)
    lam = float(rng.random() + 0.1)
    x, residual = smooth_trajectory(values, free, prior, weight, lam)
    D2 = np.zeros((T - 2, T))
    for i in range(T - 2):
        D2[i, i:i + 3] = [1, -2, 1]
    w = np.where(free, weight, 0.0)
    H = lam * D2.T @ D2 + np.diag(w)
    f = np.flatnonzero(free)
    if (~free).sum() + (w > 0).sum() < 2:
        D1 = np.diff(np.eye(T), axis=0)
        H = H + 1e-6 * lam * D1.T @ D1
    x0 = np.where(free[:, None], 0.0, values)
    b = (w[:, None] * prior - H @ x0)[f]
    if len(f):
        np.testing.assert_allclose(x[f], np.linalg.solve(H[np.ix_(f, f)], b), atol=1e-8)
        assert residual < 1e-10
    np.testing.assert_array_equal(x[~free], values[~free])


def test_no_anchor_gives_nan_not_a_guess():
    x, residual = smooth_trajectory(np.zeros((5, 2)), np.ones(5, bool), np.zeros((5, 2)),
                                    np.zeros(5), 1.0)
    assert np.isnan(x).all() and np.isnan(residual)


def test_distance_and_weight_ramp():
    free = np.ones((12, 1), bool)
    free[0] = False
    d = distance_to_observed(free)[:, 0]
    assert d.tolist() == list(range(12))
    s = TemporalSettings(ramp_start=2, ramp_full=6)
    values = np.zeros((12, 1, 2))
    prior = np.full((12, 1, 2), 7.0)
    out, w, _ = fill_segment(values, free, prior, np.ones(12), s)
    assert w[:3, 0].tolist() == [0, 0, 0] and w[6:, 0].tolist() == [1.0] * 6
    # far from the observation the answer follows the prior
    assert abs(out[-1, 0, 0] - 7.0) < 1.0 and out[0, 0, 0] == 0.0


def _shaken(track, amplitude=0.15, period=23.0):
    """The track with the whole body swaying sideways (a camera pan, a sway):
    every joint shares a non-linear motion no single trajectory's spline sees."""
    t = np.arange(len(track), dtype=float)
    sway = amplitude * _height(track) * np.sin(2 * np.pi * t / period)
    return track + np.stack([sway, 0.5 * sway], axis=-1)[:, None, :]


def _no_prior(values):
    return np.full_like(values, np.nan), np.zeros(len(values))


def _gappy(track, wrist=12, knee=15):
    """Gaps every 40 frames: `wrist` frames of the right wrist, then from 15
    frames on `knee` frames of the left knee."""
    free = np.zeros(track.shape[:2], bool)
    for start in range(20, 220, 40):
        free[start:start + wrist, WRIST] = True
        free[start + 15:start + 15 + knee, 12] = True
    return free


def _two_gaps(track):
    """15 frames of the right wrist, 4 of the head top."""
    free = np.zeros(track.shape[:2], bool)
    free[30:45, WRIST] = free[60:64, 0] = True
    return free


def test_relative_smoothing_follows_the_body_between_observations(track):
    truth = _shaken(track)
    free = _gappy(truth, wrist=10, knee=10)
    values = np.where(free[..., None], 0.0, truth)
    prior, confidence = _no_prior(values)
    alone = fill_segment(values, free, prior, confidence, TemporalSettings(relative=False))[0]
    relative = fill_segment(values, free, prior, confidence)[0]
    err_alone, err_relative = _error(alone, truth, free), _error(relative, truth, free)
    assert err_relative < 0.5 * err_alone, (err_relative, err_alone)
    np.testing.assert_array_equal(relative[~free], truth[~free])  # bit for bit


def test_free_frames_may_hold_nan(track):
    free = _two_gaps(track)
    zeros = np.where(free[..., None], 0.0, track)
    prior, confidence = _no_prior(zeros)
    want = fill_segment(zeros, free, prior, confidence)[0]
    got = fill_segment(np.where(free[..., None], np.nan, track), free, prior, confidence)[0]
    np.testing.assert_array_equal(got, want)


def test_clean_observations_stay_exact_anchors(track):
    free = _gappy(track)
    values = np.where(free[..., None], 0.0, track)
    prior, confidence = _no_prior(values)
    assert observation_weight(values, free) is None
    out = fill_segment(values, free, prior, confidence)[0]
    exact = fill_segment(values, free, prior, confidence, TemporalSettings(denoise=False))[0]
    np.testing.assert_array_equal(out, exact)


def test_noisy_observations_do_not_bend_the_gaps(track):
    free = _gappy(track)
    rng = np.random.default_rng(0)
    noisy = track + rng.normal(scale=0.01 * _height(track), size=track.shape)
    values = np.where(free[..., None], 0.0, noisy)
    prior, confidence = _no_prior(values)
    assert observation_weight(values, free) is not None
    out = fill_segment(values, free, prior, confidence)[0]
    exact = fill_segment(values, free, prior, confidence, TemporalSettings(denoise=False))[0]
    ours, anchored = _error(out, track, free), _error(exact, track, free)
    assert ours < 0.6 * anchored, (ours, anchored)
    np.testing.assert_array_equal(out[~free], noisy[~free])  # observed: as given


def test_relative_false_is_each_trajectory_alone(track):
    free = _two_gaps(track)
    values = np.where(free[..., None], 0.0, track)
    prior, confidence = _no_prior(values)
    out = fill_segment(values, free, prior, confidence, TemporalSettings(relative=False))[0]
    s = TemporalSettings()
    for j in (WRIST, 0):
        alone, _ = smooth_trajectory(values[:, j], free[:, j], prior[:, j], np.zeros(len(values)),
                                     s.acceleration, s.jerk)
        np.testing.assert_array_equal(out[:, j], alone)


def test_coupling_is_zero_for_a_joint_that_ignores_its_parent():
    rng = np.random.default_rng(0)
    t = np.arange(200.0)
    ref = np.zeros((200, 2, 2))
    ref[:, 1, 0] = 5 * np.sin(t / 3)  # the parent of joint 1 shakes
    values = np.zeros((200, 2, 2))
    values[:, 1] = rng.normal(scale=0.01, size=(200, 2)) + 0.1 * t[:, None]  # joint 1 does not
    free = np.zeros((200, 2), bool)
    free[50:60, 1] = True
    beta = coupling(values, free, ref)
    assert beta[0] == 0.0 and beta[1] < 0.01  # joint 0: nothing free
    values[:, 1] += 0.7 * ref[:, 1]
    assert abs(coupling(values, free, ref)[1] - 0.7) < 0.01


def test_reference_of_a_joint_never_anchored_is_zero():
    filled = np.ones((5, 14, 2))
    filled[:, 3] = np.nan  # the right elbow: nothing anchors it
    ref = reference_trajectories(filled)
    assert (ref[:, 4] == 0).all() and (ref[:, 3] == 1).all()  # the wrist's parent is 3


# -- recover(frames=...) ---------------------------------------------------------------


def test_short_gap_within_spline_accuracy(track, small_dictionary):
    mask = np.zeros(track.shape[:2], bool)
    for start in (40, 100, 170):
        mask[start:start + 4, WRIST] = True
        mask[start + 20:start + 23, 12] = True
    res = sparseedm.recover(track, mask, frames=np.arange(len(track)),
                            dictionary=small_dictionary, adapt=False)
    assert isinstance(res, TemporalResult)
    spline = track.copy()
    for j in (WRIST, 12):
        obs = ~mask[:, j]
        spline[~obs, j] = CubicSpline(np.flatnonzero(obs), track[obs, j])(np.flatnonzero(~obs))
    ours, theirs = _error(res.poses, track, mask), _error(spline, track, mask)
    assert ours <= 1.5 * theirs + 1e-4, (ours, theirs)
    np.testing.assert_array_equal(res.poses[~mask], track[~mask])
    assert set(res.source[mask]) == {"temporal"} and set(res.source[~mask]) == {"observed"}


def test_long_gap_at_clip_end_no_worse_than_per_frame(track, small_dictionary):
    mask = np.zeros(track.shape[:2], bool)
    mask[-60:, WRIST] = True
    mask[:45, 13] = True
    per = sparseedm.recover(track, mask, dictionary=small_dictionary, adapt=False)
    res = sparseedm.recover(track, mask, frames=np.arange(len(track)),
                            dictionary=small_dictionary, adapt=False)
    ours, theirs = _error(res.poses, track, mask), _error(per.poses, track, mask)
    assert ours <= theirs, (ours, theirs)
    assert res.prior_weight[mask].max() == 1.0  # deep in the gap the pose model counts fully
    assert res.per_frame_poses < len(track)  # per-frame answers only where they weigh


def test_results_independent_of_row_order(track, small_dictionary):
    n = 120
    poses = np.concatenate([track[:n], track[n:2 * n] + 300.0])
    tracks = np.repeat(["left", "right"], n)
    frames = np.concatenate([np.arange(n), np.arange(n) + 7])
    mask = np.zeros(poses.shape[:2], bool)
    mask[30:45, WRIST] = True
    mask[n + 50:n + 80, 9] = True
    perm = np.random.default_rng(0).permutation(len(poses))
    a = sparseedm.recover(poses, mask, tracks=tracks, frames=frames,
                          dictionary=small_dictionary, adapt=False)
    b = sparseedm.recover(poses[perm], mask[perm], tracks=tracks[perm], frames=frames[perm],
                          dictionary=small_dictionary, adapt=False)
    np.testing.assert_allclose(b.poses, a.poses[perm], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(b.status, a.status[perm])
    assert a.segments == 2


def test_results_with_defaults_independent_of_row_order(track, small_dictionary):
    # with adaptation (the default) too: the clip adapts and self-trains (asked
    # for: a call this size does not by default) on samples of its rows, drawn
    # in track and frame order, not the rows' order
    n = 120
    poses = np.concatenate([track[:n], track[n:2 * n] + 300.0])
    tracks = np.repeat(["left", "right"], n)
    frames = np.concatenate([np.arange(n), np.arange(n)])
    mask = np.zeros(poses.shape[:2], bool)
    for j, start in ((WRIST, 5), (9, 40), (12, 70), (3, 130), (8, 170), (11, 200)):
        mask[start:start + 25, j] = True
    perm = np.random.default_rng(0).permutation(len(poses))
    a = sparseedm.recover(poses, mask, tracks=tracks, frames=frames,
                          dictionary=small_dictionary, self_training=3)
    b = sparseedm.recover(poses[perm], mask[perm], tracks=tracks[perm], frames=frames[perm],
                          dictionary=small_dictionary, self_training=3)
    assert a.adaptation.adapted and a.adaptation.self_training  # the sampling ran
    np.testing.assert_allclose(b.poses, a.poses[perm], rtol=0, atol=1e-9)


def test_temporal_false_is_todays_output_exactly(track, small_dictionary):
    mask = np.zeros(track.shape[:2], bool)
    mask[10:40, WRIST] = True
    mask[5, :12] = True  # refused per frame: too few observed
    kw = dict(dictionary=small_dictionary, adapt=False)
    today = sparseedm.recover(track, mask, **kw)
    off = sparseedm.recover(track, mask, frames=np.arange(len(track)), temporal=False, **kw)
    assert type(off) is type(today)
    for name in ("poses", "vectors", "center", "scale", "objective", "gap"):
        np.testing.assert_array_equal(getattr(off, name), getattr(today, name))
    np.testing.assert_array_equal(off.status, today.status)
    np.testing.assert_array_equal(off.reason, today.reason)


def test_recover_track_is_a_gap_filler(track, small_dictionary):
    mask = np.zeros(track.shape[:2], bool)
    mask[50:60, 7] = True
    filled = recover_track(track[:100], mask[:100], np.arange(100),
                           dictionary=small_dictionary, adapt=False)
    assert filled.shape == (100, 14, 2) and np.isfinite(filled).all()
    np.testing.assert_array_equal(filled[~mask[:100]], track[:100][~mask[:100]])


# -- bad input -------------------------------------------------------------------------


def test_bad_frames_and_tracks_per_row(track, small_dictionary):
    poses = track[:40].copy()
    mask = np.zeros(poses.shape[:2], bool)
    mask[:, WRIST] = True  # never observed in its track
    frames = np.arange(40).astype(object)
    frames[3], frames[4], frames[5] = np.nan, 2.5, "x"
    frames[8] = 6  # duplicate of row 6 (both of track "a")
    tracks = np.array(["a", "b"] * 20, dtype=object)  # interleaved tracks
    tracks[39] = "alone"  # one frame
    res = sparseedm.recover(poses, mask, tracks=tracks, frames=frames,
                            dictionary=small_dictionary, adapt=False)
    assert len(res.status) == 40 and res.ok.all()
    assert np.isfinite(res.poses).all()
    assert "NaN" in res.reason[3] or "nan" in res.reason[3]
    assert "not an integer" in res.reason[4] and "not a number" in res.reason[5]
    assert "more than once" in res.reason[6] and "more than once" in res.reason[8]
    assert "only frame" in res.reason[39]
    for i in (3, 4, 5, 6, 8, 39):
        assert res.source[i, WRIST] == "per_frame"
        assert res.reason[i].startswith("per frame because "), res.reason[i]
    assert set(res.source[9:38, WRIST]) == {"temporal"}
    assert set(np.unique(res.source)) <= set(SOURCES)


BIG_FRAMES = {  # 20 rows inside +-2**53 (one stretch of frames), 20 past it
    "uint64": np.concatenate([np.arange(20, dtype=np.uint64),
                              np.uint64(2**63) + np.arange(20, dtype=np.uint64)]),
    "int64 limits": np.concatenate([-2**63 + np.arange(10), 2**53 - 9 + np.arange(10),
                                    2**63 - 10 + np.arange(10)]),
    "float": np.concatenate([np.arange(20.0), 2.0**60 + 2.0**10 * np.arange(20)]),
    "csv text": np.array([str(i) for i in range(20)]
                         + [str(2**62 + i) for i in range(20)], dtype=object),
}


@pytest.mark.parametrize("kind", BIG_FRAMES)
def test_frame_numbers_past_2_53_are_too_large_per_row(track, small_dictionary, kind):
    frames = BIG_FRAMES[kind]
    big = np.array([abs(int(f)) > 2**53 for f in frames])
    poses = track[:len(frames)].copy()
    mask = np.zeros(poses.shape[:2], bool)
    mask[::3, WRIST] = True
    res = sparseedm.recover(poses, mask, frames=frames, dictionary=small_dictionary,
                            adapt=False)
    assert res.ok.all() and np.isfinite(res.poses).all()
    for i in np.flatnonzero(big):
        assert "is too large (over 2**53)" in res.reason[i], res.reason[i]
        assert res.source[i, WRIST] in ("per_frame", "observed")
    assert set(res.source[~big & mask[:, WRIST], WRIST]) == {"temporal"}


def test_a_row_with_nothing_observed_outside_time_warns_nothing(track, small_dictionary):
    # a NaN frame number and no joint observed: refused per frame, quietly
    poses, frames = track[:30].copy(), np.arange(30.0)
    poses[7], frames[7] = np.nan, np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        res = sparseedm.recover(poses, np.isnan(poses).any(-1), frames=frames,
                                dictionary=small_dictionary, adapt=False)
    assert res.status[7] == "too_few_observed" and res.ok[np.arange(30) != 7].all()


def test_rows_refused_per_frame_can_be_filled_in_time(track, small_dictionary):
    poses = track[:60].copy()
    mask = np.zeros(poses.shape[:2], bool)
    mask[30, 2:] = True  # two joints left: per frame refuses it
    poses[31, 0] = np.inf  # invalid: refused, and absent from time
    res = sparseedm.recover(poses, mask, frames=np.arange(60),
                            dictionary=small_dictionary, adapt=False)
    assert res.status[30] == "recovered" and res.source[30, 5] == "temporal"
    assert res.status[31] == "invalid_coordinates" and np.isnan(res.poses[31]).all()
    assert _error(res.poses[30:31], track[30:31], mask[30:31]) < 0.05


def test_wrong_shapes_are_argument_errors(small_dictionary):
    with pytest.raises(ParameterError, match="frames must have shape"):
        sparseedm.recover(np.zeros((3, 14, 2)), frames=[1, 2], dictionary=small_dictionary)
    with pytest.raises(ParameterError, match="tracks must have shape"):
        split_tracks(3, [1], [1, 2, 3])


# -- files and the CLI -----------------------------------------------------------------


def _video(track):
    """Two people's rows interleaved, shuffled, with gaps: (KeypointSet, truth, mask)."""
    from sparseedm.keypoints import KeypointSet

    n = 80
    truth = np.concatenate([track[:n], track[n:2 * n] + 250.0])
    tracks = np.repeat(np.array(["p1", "p2"]), n)
    frames = np.concatenate([np.arange(n), np.arange(n)])
    mask = np.zeros(truth.shape[:2], bool)
    mask[20:32, WRIST] = True
    mask[n + 40:n + 60, 10] = True
    perm = np.random.default_rng(1).permutation(2 * n)
    poses = np.where(mask[..., None], np.nan, truth)[perm]
    return (KeypointSet(poses, mask[perm], tracks=tracks[perm], frames=frames[perm]),
            truth[perm], mask[perm])


@pytest.mark.parametrize("ext", ["csv", "npz"])
def test_files_keep_tracks_and_frames(tmp_path, track, ext):
    from sparseedm.keypoints import read_keypoints, write_keypoints

    kps, _, _ = _video(track)
    path = write_keypoints(tmp_path / f"v.{ext}", kps)
    back = read_keypoints(path)
    np.testing.assert_array_equal(back.tracks.astype(str), kps.tracks)
    np.testing.assert_array_equal(back.frames, kps.frames)
    again = read_keypoints(write_keypoints(tmp_path / f"w.{ext}", back))
    np.testing.assert_array_equal(again.frames, kps.frames)


def test_npz_clips_as_dataset_build_writes_them(tmp_path, track):
    from sparseedm.keypoints import read_keypoints, write_keypoints

    path = tmp_path / "d.npz"
    np.savez(path, poses=track[:10], clips=np.array(["c1"] * 5 + ["c2"] * 5),
             frames=np.arange(10))
    kps = read_keypoints(path)
    assert kps.tracks.tolist() == ["c1"] * 5 + ["c2"] * 5 and kps.frames.tolist() == list(
        range(10))
    with np.load(write_keypoints(tmp_path / "o.npz", kps)) as out:
        assert "clips" in out.files and "tracks" not in out.files


def test_csv_frame_cells_that_are_not_integers_are_rows_not_errors(tmp_path, track,
                                                                    small_dictionary):
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    frames = np.array([str(i) for i in range(30)], dtype=object)
    frames[4], frames[9] = "", "7.5"
    poses = track[:30].copy()
    poses[10:20, WRIST] = np.nan
    kps = read_keypoints(write_keypoints(tmp_path / "f.csv", KeypointSet(
        poses, np.isnan(poses).any(-1), tracks=np.zeros(30, int), frames=frames)))
    res = sparseedm.recover(kps.poses, kps.missing, tracks=kps.tracks, frames=kps.frames,
                            dictionary=small_dictionary, adapt=False)
    assert res.ok.all()
    assert "not a number" in res.reason[4] and "not an integer" in res.reason[9]


@pytest.mark.parametrize("ext", ["csv", "npz"])
def test_cli_uses_time_and_no_temporal_turns_it_off(tmp_path, track, small_dictionary_path,
                                                    ext, capsys):
    from sparseedm.cli import main
    from sparseedm.keypoints import read_keypoints, write_keypoints

    kps, truth, mask = _video(track)
    inp = write_keypoints(tmp_path / f"v.{ext}", kps)
    args = ["recover", str(inp), "--dictionary", str(small_dictionary_path), "--no-adapt"]
    assert main(args + ["-o", str(tmp_path / f"t.{ext}")]) == 0
    assert "across time" in capsys.readouterr().err
    assert main(args + ["-o", str(tmp_path / f"p.{ext}"), "--no-temporal"]) == 0
    assert "across time" not in capsys.readouterr().err
    timed, per = read_keypoints(tmp_path / f"t.{ext}"), read_keypoints(tmp_path / f"p.{ext}")
    np.testing.assert_array_equal(timed.frames, kps.frames)  # written back
    np.testing.assert_array_equal(timed.tracks.astype(str), kps.tracks)
    api = sparseedm.recover(kps.poses, kps.missing, dictionary=str(small_dictionary_path),
                            adapt=False)
    np.testing.assert_array_equal(per.poses, api.poses)  # --no-temporal: per frame, exactly
    assert _error(timed.poses, truth, mask) < _error(per.poses, truth, mask)


def test_a_runaway_per_frame_answer_gets_no_weight():
    from sparseedm.temporal.recover import _runaway

    pose = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]])[None]
    mask = np.array([[False, False, False, True]])
    assert not _runaway(pose, mask)[0]
    far = pose.copy()
    far[0, 3] = [500.0, 500.0]  # 35 extents away
    assert _runaway(far, mask)[0]


# -- per-frame answers on every s-th frame (speed) -------------------------------------


def test_prior_frames_thin_each_run_and_keep_its_ends():
    rng = np.random.default_rng(0)
    free = rng.random((200, 3)) < 0.1
    free[20:130, 0] = True
    free[150:, 1] = True
    every = needs_prior(free)
    one = TemporalSettings(prior_stride=1)
    assert prior_frames(free, one).tolist() == every.tolist()  # every frame
    for stride in (2, 3, 5):
        some = prior_frames(free, TemporalSettings(prior_stride=stride))
        assert not (some & ~every).any()  # only frames whose answer weighs
        idx = np.flatnonzero(every)
        ends = np.concatenate([idx[np.diff(idx, prepend=-9) != 1],
                               idx[np.diff(idx, append=10**6) != 1]])
        assert some[ends].all()
        assert some.sum() <= every.sum() / stride + 2 * len(ends)


def test_strided_answers_interpolated_where_skipped():
    """A prior linear in time: the skipped frames' interpolated answers are the
    ones they would have had, so the filled trajectory is the stride-1 one."""
    T = 120
    values = np.zeros((T, 2, 2))
    values[:, :, 0] = np.arange(T)[:, None]
    free = np.zeros((T, 2), bool)
    free[10:100, 0] = True
    prior = values + np.array([0.0, 5.0])  # the answer is off by 5 px in y
    confidence = np.linspace(0.5, 1.0, T)
    full, w_full, _ = fill_segment(values, free, prior, confidence,
                                   TemporalSettings(prior_stride=1))
    s = TemporalSettings(prior_stride=4)
    asked = prior_frames(free, s)
    assert asked.sum() < needs_prior(free).sum() / 3
    thin = np.where(asked[:, None, None], prior, np.nan)
    out, w, _ = fill_segment(values, free, thin, np.where(asked, confidence, 0.0), s)
    np.testing.assert_allclose(out, full, atol=1e-9)
    np.testing.assert_allclose(w, w_full, atol=1e-12)
    # a skipped frame whose neighbour has no answer gets none (no extrapolation)
    thin[np.flatnonzero(asked)[-1]] = np.nan
    _, w_cut, _ = fill_segment(values, free, thin, np.where(asked, confidence, 0.0), s)
    assert (w_cut[np.flatnonzero(asked)[-2] + 1:, 0] == 0).all()


def test_recover_with_a_prior_stride_asks_fewer_frames(track, small_dictionary):
    mask = np.zeros(track.shape[:2], bool)
    mask[30:120, WRIST] = True
    mask[-50:, 13] = True
    frames = np.arange(len(track))
    one = recover_temporal(track, mask, frames=frames, dictionary=small_dictionary,
                           adapt=False, settings=TemporalSettings(prior_stride=1))
    three = recover_temporal(track, mask, frames=frames, dictionary=small_dictionary,
                             adapt=False, settings=TemporalSettings(prior_stride=3))
    assert three.per_frame_poses < one.per_frame_poses / 2
    near = distance_to_observed(mask) <= TemporalSettings().ramp_start
    np.testing.assert_array_equal(three.prior_weight[near], 0.0)
    np.testing.assert_array_equal(three.poses[~mask], track[~mask])
    assert _error(three.poses, track, mask) <= 1.2 * _error(one.poses, track, mask) + 1e-3


# -- one clip adapts --------------------------------------------------------------------


def _few_complete_frames(track):
    mask = np.zeros(track.shape[:2], bool)
    for j, start in ((WRIST, 0), (12, 3), (7, 5)):  # 10 of every 12 frames each
        for s in range(start, len(track), 12):
            mask[s:s + 10, j] = True
    return mask


def test_one_clip_adapts_on_its_complete_and_time_filled_frames(track, small_dictionary):
    """Under adapt="auto" a clip of ~240 frames with few complete frames still
    adapts: on the complete frames and those whose missing joints lie within
    CLIP_NEAR frames of an observation (filled by time); per frame it cannot."""
    from sparseedm.temporal.recover import CLIP_MIN_POSES, CLIP_NEAR

    mask = _few_complete_frames(track)
    complete = int((~mask.any(axis=1)).sum())
    assert complete < CLIP_MIN_POSES
    near = (np.where(mask, distance_to_observed(mask), 0) <= CLIP_NEAR).all(axis=1)
    assert near.sum() >= CLIP_MIN_POSES
    res = recover_temporal(track, mask, frames=np.arange(len(track)),
                           dictionary=small_dictionary, self_training=0)
    assert res.adaptation.n_given == near.sum()
    assert res.adaptation.n_complete >= CLIP_MIN_POSES  # learned and guarded, not refused
    assert res.adaptation.candidate is not None
    np.testing.assert_array_equal(res.poses[~mask], track[~mask])
    per = sparseedm.recover(track, mask, dictionary=small_dictionary, self_training=0)
    assert not per.adaptation.adapted and per.adaptation.candidate is None
    off = recover_temporal(track, mask, frames=np.arange(len(track)),
                           dictionary=small_dictionary, adapt=False)
    assert off.adaptation is None


def test_a_clip_solves_on_the_compiled_kernel(track, small_dictionary, monkeypatch):
    """A call in time takes the compiled LARS at any batch size, whether it
    adapts (its guard, its self-training rounds, its per-frame answers) or
    not: the numpy homotopy only when the caller asks for it, and the answers
    agree to round-off."""
    from sparseedm.solvers import fast

    sizes = []
    numpy_path = fast._lars_masked_numpy
    monkeypatch.setattr(fast, "_lars_masked_numpy",
                        lambda *a, **k: sizes.append(1) or numpy_path(*a, **k))
    mask = _few_complete_frames(track)
    frames = np.arange(len(track))
    res = recover_temporal(track, mask, frames=frames, dictionary=small_dictionary,
                           self_training=1)
    assert res.adaptation.candidate is not None and res.adaptation.self_training
    assert 0 < res.per_frame_poses < fast.NUMPY_MAX and sizes == []
    compiled = recover_temporal(track, mask, frames=frames, dictionary=small_dictionary,
                                adapt=False)
    assert sizes == [] and compiled.per_frame_poses > 0
    off = recover_temporal(track, mask, frames=frames, dictionary=small_dictionary,
                           adapt=False, solver=fast.FastSolver(numpy_max=10 ** 6))
    assert len(sizes) == off.per_frame_poses + off.probe_poses
    np.testing.assert_allclose(compiled.poses, off.poses, atol=1e-6)


def test_one_clip_file_adapts_as_the_api_does(tmp_path, track, small_dictionary_path):
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, write_keypoints

    mask = _few_complete_frames(track)
    frames = np.arange(len(track))
    path = write_keypoints(tmp_path / "clip.csv", KeypointSet(
        np.where(mask[..., None], np.nan, track), mask, frames=frames))
    summary = recover_file(path, tmp_path / "out.csv", dictionary=small_dictionary_path,
                           self_training=0)
    api = recover_temporal(track, mask, frames=frames, dictionary=small_dictionary_path,
                           self_training=0)
    assert summary["adaptation"]["poses_given"] == api.adaptation.n_given > 0
    assert summary["adaptation"]["adapted"] == api.adaptation.adapted
    per = recover_file(path, tmp_path / "per.csv", dictionary=small_dictionary_path,
                       self_training=0, temporal=False)
    assert per["adaptation"]["poses_given"] == len(track)  # the per-frame rule, unchanged
    # the same answers as the API's (both solve on the compiled kernel once adapted)
    from sparseedm.keypoints import read_keypoints
    np.testing.assert_array_equal(read_keypoints(tmp_path / "out.csv").poses, api.poses)


@pytest.mark.parametrize("interleaved", [False, True])
def test_file_streams_whole_tracks(tmp_path, track, small_dictionary_path, interleaved,
                                   monkeypatch):
    """Chunks of whole tracks give what one pass gives, every row back; with the
    tracks interleaved in the file (rows in frame order), the chunks gather
    each track's rows."""
    import sparseedm.batch as batch
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    mask = np.zeros(track.shape[:2], bool)
    mask[20:60, WRIST] = True
    mask[100:103, 12] = True
    mask[-40:, 13] = True
    names = np.array(["a"] * 80 + ["b"] * 80 + ["c"] * (len(track) - 160))
    frames = np.concatenate([np.arange(80), np.arange(80), np.arange(len(track) - 160)])
    order = np.argsort(frames, kind="stable") if interleaved else np.arange(len(track))
    path = write_keypoints(tmp_path / "v.csv", KeypointSet(
        np.where(mask[..., None], np.nan, track)[order], mask[order],
        tracks=names[order], frames=frames[order]))
    out, calls, recover = {}, [], batch.recover
    monkeypatch.setattr(batch, "recover", lambda p, *a, **k: calls.append(len(p)) or
                        recover(p, *a, **k))
    for size in (100, 50_000):
        s = recover_file(path, tmp_path / f"o{size}.csv", dictionary=small_dictionary_path,
                         adapt=False, chunk_size=size)
        out[size] = (read_keypoints(tmp_path / f"o{size}.csv").poses, s["temporal"])
    assert calls == [80, 80, len(track) - 160, len(track)]  # tracks a, b, c; then one pass
    np.testing.assert_array_equal(out[100][0], out[50_000][0])
    assert out[100][1] == out[50_000][1] and out[100][1]["segments"] == 3
    assert np.isfinite(out[100][0]).all()


def test_track_windows_keep_every_row_once():
    """A track longer than a chunk is cut by frame number into windows of about
    a chunk's rows; each is solved with `overlap` frames of context on either
    side and keeps its own rows: every row is kept exactly once."""
    from sparseedm.temporal.tracks import track_windows

    rng = np.random.default_rng(0)
    frames = np.concatenate([rng.permutation(1000), np.arange(50), [np.nan, 3.5]]).astype(object)
    tracks = np.array(["long"] * 1000 + ["short"] * 50 + ["long", "long"])
    kept = np.zeros(len(frames), int)
    windows = track_windows(tracks, frames, len(frames), 200, overlap=30)
    assert len(windows) == 6  # the short track whole, the long one in five windows
    for rows, keep in windows:
        rows = np.arange(*rows) if isinstance(rows, tuple) else rows
        if keep is None:
            kept[rows] += 1
            assert set(tracks[rows]) == {"short"}
            continue
        assert len(rows) == len(keep) and keep.sum() <= 202  # 200, the first 2 more
        kept[rows[keep]] += 1
        own = np.array([f for f in frames[rows[keep]] if f == f and f != 3.5], float)
        ctx = np.array([f for f in frames[rows] if f == f and f != 3.5], float)
        # the context: every frame within 30 of the window's own, nothing further
        want = np.arange(max(own.min() - 30, 0), min(own.max() + 30, 999) + 1)
        np.testing.assert_array_equal(np.sort(ctx), want)
    np.testing.assert_array_equal(kept, 1)
    # the rows without a usable frame number go with the first window
    first_rows, first_keep = windows[0] if windows[0][1] is not None else windows[1]
    assert {1050, 1051} <= set(first_rows[first_keep].tolist())


def test_file_recovers_a_long_track_in_windows(tmp_path, track, small_dictionary_path,
                                               monkeypatch):
    """A file's track longer than chunk_size is recovered in windows: no call
    holds much more than a chunk, every row comes back once, observed joints as
    given, and the answers are the one pass's but for what each window
    estimates on its own frames (the joints' coupling, the noise)."""
    import sparseedm.batch as batch
    import sparseedm.temporal.tracks as tracks_module
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    mask = np.zeros(track.shape[:2], bool)
    mask[20:60, WRIST] = True
    mask[50:75, 12] = True  # a gap across the first cut (frame 60)
    mask[-40:, 13] = True
    order = np.random.default_rng(1).permutation(len(track))  # rows in any order
    path = write_keypoints(tmp_path / "v.csv", KeypointSet(
        np.where(mask[..., None], np.nan, track)[order], mask[order],
        frames=np.arange(len(track))[order]))
    monkeypatch.setattr(tracks_module, "WINDOW_OVERLAP", 30)
    calls, recover = [], batch.recover
    monkeypatch.setattr(batch, "recover", lambda p, *a, **k: calls.append(len(p)) or
                        recover(p, *a, **k))
    out = {}
    for size in (80, 50_000):
        summary = recover_file(path, tmp_path / f"o{size}.csv",
                               dictionary=small_dictionary_path, adapt=False, chunk_size=size)
        out[size] = read_keypoints(tmp_path / f"o{size}.csv")
        assert summary["status"]["recovered"] == int(mask.any(axis=1).sum())
    # 241 rows in four windows of 60-61 own rows, 30 frames of context each side
    assert calls[:-1] == [60 + 30, 60 + 60, 60 + 60, 61 + 30] and calls[-1] == len(track)
    windows, whole = out[80].poses, out[50_000].poses
    given = ~mask[order]
    np.testing.assert_array_equal(windows[given], track[order][given])
    height = np.ptp(track[..., 1], axis=1).mean()
    assert np.abs(windows - whole).max() < 0.02 * height
    np.testing.assert_array_equal(out[80].ids, out[50_000].ids)


def test_adapt_from_a_video_uses_the_one_clip_rule(tmp_path, small_dictionary_path):
    """--adapt-from a video (a file with frames) adapts by the rule one clip
    adapts by (complete and time-completed frames, 30 of them), as the input
    itself would; the same poses without frames need 250 complete ones."""
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    example = Path(__file__).resolve().parents[1] / "examples" / "video_clip.csv"
    kps = read_keypoints(example)
    one = kps.tracks == np.unique(kps.tracks)[1]  # 150 frames, 56 complete
    clip = KeypointSet(kps.poses[one], kps.missing[one], tracks=kps.tracks[one],
                       frames=kps.frames[one])
    video = write_keypoints(tmp_path / "clip.csv", clip)
    still = write_keypoints(tmp_path / "still.csv", KeypointSet(kps.poses[one], kps.missing[one]))
    used = {}
    for name, src in (("video", video), ("still", still)):
        s = recover_file(example, tmp_path / f"out_{name}.csv",
                         dictionary=small_dictionary_path, adapt=src, self_training=0)
        used[name] = s["adaptation"]
    assert used["video"]["poses_used"] > 56  # the time-completed frames count too
    assert used["still"]["poses_used"] == 0 and "250" in used["still"]["reason"]


def test_the_size_rule_adapts_only_where_the_per_frame_model_is_asked(track,
                                                                      small_dictionary):
    """adapt="auto" adapts a call only when some row asks the per-frame model
    and the call has ADAPT_MIN_FRAMES rows; self-training rounds by default
    only from SELF_TRAINING_MIN_FRAMES rows; an explicit self_training runs."""
    from sparseedm.temporal.recover import (ADAPT_MIN_FRAMES, SELF_TRAINING_MIN_FRAMES,
                                            adapts)

    def call(poses, mask, **kw):
        return recover_temporal(poses, mask, frames=np.arange(len(poses)),
                                dictionary=small_dictionary, **kw)

    # short gaps only: time alone fills them, nothing to adapt for
    short_gaps = np.zeros(track.shape[:2], bool)
    for s in range(5, len(track) - 5, 20):
        short_gaps[s:s + 3, WRIST] = True
    res = call(track, short_gaps)
    assert res.per_frame_poses == 0 and res.probe_poses == 0 and res.adaptation is None
    np.testing.assert_array_equal(res.poses, call(track, short_gaps, adapt=False).poses)
    # a long gap in a clip one frame under the size: asks, does not adapt
    n = ADAPT_MIN_FRAMES - 1
    mask = np.zeros((n, track.shape[1]), bool)
    mask[10:45, WRIST] = True
    small = call(track[:n], mask)
    assert small.per_frame_poses > 0 and small.adaptation is None
    np.testing.assert_array_equal(small.poses, call(track[:n], mask, adapt=False).poses)
    # the same gap in a clip of the size adapts, without the rounds unless asked
    n = ADAPT_MIN_FRAMES
    assert n < SELF_TRAINING_MIN_FRAMES
    mask = np.zeros((n, track.shape[1]), bool)
    mask[10:45, WRIST] = True
    big = call(track[:n], mask)
    assert big.adaptation is not None and not big.adaptation.self_training
    assert adapts(SELF_TRAINING_MIN_FRAMES, True) == (True, True)
    assert adapts(SELF_TRAINING_MIN_FRAMES, False) == (False, False)


def test_a_long_call_adapts_on_an_even_stride_of_its_offered_poses(track, small_dictionary,
                                                                   monkeypatch):
    """Past OFFER_MAX offered poses, adaptation takes every k-th in frame order."""
    from sparseedm.temporal import recover as module

    mask = _few_complete_frames(track)
    frames = np.arange(len(track))
    offered = module.offered_poses(track, mask, frames=frames)
    monkeypatch.setattr(module, "OFFER_MAX", (len(offered) + 1) // 2)
    bounded = module.offered_poses(track, mask, frames=frames)
    np.testing.assert_array_equal(bounded, offered[::2])


@pytest.mark.parametrize("kwargs, word", [
    (dict(acceleration=-1.0), "acceleration"), (dict(jerk=float("nan")), "jerk"),
    (dict(prior_stride=0), "prior_stride"), (dict(prior_stride=2.5), "prior_stride"),
    (dict(relative="yes"), "relative"), (dict(fusion_share=1.5), "fusion_share"),
    (dict(ramp_start=10.0, ramp_full=5.0), "ramp_full"), (dict(inaccurate=True), "inaccurate"),
])
def test_temporal_settings_refuse_what_a_fill_cannot_use(kwargs, word):
    from sparseedm.exceptions import ParameterError

    with pytest.raises(ParameterError, match=word):
        TemporalSettings(**kwargs)
    TemporalSettings(**{k: v for k, v in kwargs.items() if k == "ramp_start"})  # alone: fine
