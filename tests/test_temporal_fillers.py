"""Gap fillers (sparseedm.temporal.fillers): exact where they should be, observed
joints kept, clip ends held, never-observed joints NaN, bad tracks refused."""

import numpy as np
import pytest

from sparseedm.exceptions import PoseError
from sparseedm.temporal.fillers import (FILLERS, check_track, fill_akima, fill_cubic,
                                        fill_linear, fill_pca, sparse_filler)

SPLINES = [fill_linear, fill_cubic, fill_akima]


def track(values, frames):
    """A (T, 14, 2) track whose every coordinate follows `values` (T,) scaled per joint."""
    T = len(frames)
    poses = np.empty((T, 14, 2))
    poses[:, :, 0] = values[:, None] * np.arange(1, 15)
    poses[:, :, 1] = -2 * values[:, None] + np.arange(14)
    return poses


def gappy_mask(T, rng):
    missing = np.zeros((T, 14), bool)
    missing[3:9, 4] = True     # interior gap
    missing[12:13, 7] = True   # one frame
    missing[5:15, 10] = True   # a long one
    missing[rng.choice(T, 3, replace=False), 0] = True
    missing[[0, T - 1], 0] = False  # joint 0's ends observed
    return missing


@pytest.mark.parametrize("fill", SPLINES)
def test_exact_on_a_linear_track_with_skipping_frames(fill):
    frames = np.array([0, 1, 2, 4, 5, 9, 10, 11, 12, 15, 16, 17, 18, 20, 21, 22, 30, 31])
    truth = track(0.5 * frames - 3.0, frames)
    missing = gappy_mask(len(frames), np.random.default_rng(0))
    given = truth.copy()
    given[missing] = np.nan
    out = fill(given, missing, frames)
    np.testing.assert_allclose(out, truth, atol=1e-9)


def test_cubic_is_exact_on_a_cubic_track():
    frames = np.arange(0, 40, 2)
    t = frames / 10.0
    truth = track(t ** 3 - 4 * t ** 2 + t, frames)
    missing = gappy_mask(len(frames), np.random.default_rng(1))
    out = fill_cubic(np.where(missing[..., None], 0.0, truth), missing, frames)
    np.testing.assert_allclose(out, truth, atol=1e-8)
    # a linear fill is not exact there: the test can tell
    assert np.abs(fill_linear(truth, missing, frames) - truth).max() > 0.1


@pytest.mark.parametrize("fill", SPLINES + [fill_pca])
def test_observed_joints_are_kept_bit_for_bit(fill):
    rng = np.random.default_rng(2)
    poses = rng.normal(size=(30, 14, 2)) * 50 + 300
    missing = rng.random((30, 14)) < 0.3
    out = fill(poses, missing, np.arange(30) * 3)
    assert np.array_equal(out[~missing], poses[~missing])
    assert np.all(np.isfinite(out))
    assert poses.shape == out.shape


@pytest.mark.parametrize("fill", SPLINES)
def test_clip_ends_hold_the_nearest_observed_value(fill):
    rng = np.random.default_rng(3)
    poses = rng.normal(size=(20, 14, 2))
    missing = np.zeros((20, 14), bool)
    missing[:4, 3] = True
    missing[15:, 3] = True
    out = fill(poses, missing, np.arange(20))
    np.testing.assert_array_equal(out[:4, 3], np.repeat(poses[4:5, 3], 4, axis=0))
    np.testing.assert_array_equal(out[15:, 3], np.repeat(poses[14:15, 3], 5, axis=0))


@pytest.mark.parametrize("fill", SPLINES + [fill_pca])
def test_a_joint_never_observed_is_nan_and_the_rest_filled(fill):
    rng = np.random.default_rng(4)
    poses = rng.normal(size=(12, 14, 2))
    missing = np.zeros((12, 14), bool)
    missing[:, 6] = True
    missing[4:6, 2] = True
    out = fill(poses, missing, np.arange(12))
    assert np.all(np.isnan(out[:, 6]))
    assert np.all(np.isfinite(np.delete(out, 6, axis=1)))


@pytest.mark.parametrize("fill", SPLINES)
def test_one_or_two_observed_frames(fill):
    poses = np.zeros((6, 14, 2))
    poses[2, 5] = [10, 20]
    poses[4, 8] = [1, 1]
    poses[5, 8] = [2, 3]
    missing = np.ones((6, 14), bool)
    missing[2, 5] = missing[4, 8] = missing[5, 8] = False
    missing[:, 0] = False
    out = fill(poses, missing, np.arange(6))
    np.testing.assert_array_equal(out[:, 5], np.tile([10.0, 20.0], (6, 1)))
    np.testing.assert_array_equal(out[:4, 8], np.tile([1.0, 1.0], (4, 1)))


def test_pca_recovers_a_low_rank_trajectory_set_better_than_splines():
    rng = np.random.default_rng(5)
    T = 120
    t = np.linspace(0, 4 * np.pi, T)
    basis = np.stack([np.sin(t), np.cos(1.7 * t), np.sin(0.6 * t + 1)], axis=1)  # rank 3
    mixing = rng.normal(size=(3, 28)) * 40
    truth = (basis @ mixing + rng.normal(size=28) * 100 + 400).reshape(T, 14, 2)
    missing = np.zeros((T, 14), bool)
    missing[30:70, 4] = True   # 40 frames: a spline cannot know the motion inside
    missing[:25, 9] = True     # at the clip start
    missing[90:, 12] = True    # at the clip end
    missing[50:60, 1] = True
    given = np.where(missing[..., None], np.nan, truth)
    out = fill_pca(given, missing, np.arange(T))
    err_pca = np.abs(out - truth)[missing].max()
    err_cubic = np.abs(fill_cubic(given, missing, np.arange(T)) - truth)[missing].max()
    assert err_pca < 1e-3 * np.abs(truth).max()
    assert err_cubic > 100 * err_pca


def test_check_track_refuses_bad_tracks():
    poses, missing = np.zeros((3, 14, 2)), np.zeros((3, 14), bool)
    with pytest.raises(PoseError, match="frames must be integers"):
        check_track(poses, missing, [0, 1.5, 2])
    with pytest.raises(PoseError, match="sorted and unique"):
        check_track(poses, missing, [0, 2, 1])
    with pytest.raises(PoseError, match="frames must have shape"):
        check_track(poses, missing, [0, 1])
    with pytest.raises(PoseError, match="missing must have shape"):
        check_track(poses, missing[:, :5], [0, 1, 2])
    bad = poses.copy()
    bad[1, 2, 0] = np.nan
    with pytest.raises(PoseError, match="not marked missing"):
        check_track(bad, missing, [0, 1, 2])
    _, _, t = check_track(poses, missing, np.array([0.0, 4.0, 7.0]))  # integral floats pass
    assert t.tolist() == [0.0, 4.0, 7.0]


def test_sparse_filler_fills_from_the_other_joints(cmu_poses, small_dictionary):
    truth = cmu_poses[:40]
    missing = np.zeros((40, 14), bool)
    missing[10:30, 4] = True
    missing[::7, 9] = True
    fill = sparse_filler(small_dictionary, adapt=False)
    out = fill(np.where(missing[..., None], np.nan, truth), missing, np.arange(40))
    assert np.array_equal(out[~missing], truth[~missing])
    assert np.all(np.isfinite(out))
    from sparseedm import recover

    direct = recover(np.where(missing[..., None], np.nan, truth), dictionary=small_dictionary,
                     adapt=False).poses
    np.testing.assert_allclose(out, direct)
    assert np.abs(out - truth)[missing].max() > 0  # filled, not copied from the truth
    assert set(FILLERS) == {"linear", "cubic", "akima", "pca", "sparse"}


def test_pca_without_complete_frames_falls_back_to_em_pca():
    rng = np.random.default_rng(6)
    T = 150
    t = np.linspace(0, 4 * np.pi, T)
    basis = np.stack([np.sin(t), np.cos(1.7 * t)], axis=1)  # rank 2
    truth = (basis @ (rng.normal(size=(2, 28)) * 40) + 300).reshape(T, 14, 2)
    missing = np.zeros((T, 14), bool)
    missing[np.arange(T), rng.integers(0, 14, T)] = True  # one joint per frame: none complete
    missing[np.arange(T), rng.integers(0, 14, T)] = True
    assert missing.any(axis=1).all()
    given = np.where(missing[..., None], np.nan, truth)
    err_pca = np.abs(fill_pca(given, missing, np.arange(T)) - truth)[missing]
    err_linear = np.abs(fill_linear(given, missing, np.arange(T)) - truth)[missing]
    assert err_pca.mean() < 0.05 * err_linear.mean()
