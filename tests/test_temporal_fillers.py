"""Gap fillers (sparseedm.temporal.fillers): exact where they should be, observed
joints kept, clip ends held, never-observed joints NaN, bad tracks refused; the
Kalman smoother against the textbook filter and RTS pass, its noise fit against
simulated noise."""

import numpy as np
import pytest

from sparseedm.exceptions import ParameterError, PoseError
from sparseedm.temporal.fillers import (FILLERS, check_track, fill_akima, fill_cubic,
                                        fill_kalman, fill_linear, fill_pca, fit_kalman_noise,
                                        sparse_filler)

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


@pytest.mark.parametrize("fill", SPLINES + [fill_kalman])
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


@pytest.mark.parametrize("fill", SPLINES + [fill_pca, fill_kalman])
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


@pytest.mark.parametrize("fill", SPLINES + [fill_pca, fill_kalman])
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
    assert set(FILLERS) == {"linear", "cubic", "akima", "pca", "kalman", "sparse"}


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


def textbook_rts(y, t, q, r, prior=1e10):
    """The constant-velocity Kalman filter and RTS smoother in its plainest form: one
    series y (T,) with NaN where missing, times t (T,), a broad prior at t[0]."""
    x, P = np.zeros(2), prior * np.eye(2)
    H = np.array([[1.0, 0.0]])
    xs_pred, Ps_pred, xs_filt, Ps_filt = [], [], [], []
    for k in range(len(t)):
        if k > 0:
            dt = t[k] - t[k - 1]
            F = np.array([[1.0, dt], [0.0, 1.0]])
            Q = q * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
            x, P = F @ x, F @ P @ F.T + Q
        xs_pred.append(x)
        Ps_pred.append(P)
        if not np.isnan(y[k]):
            S = H @ P @ H.T + r
            gain = P @ H.T @ np.linalg.inv(S)
            x = x + (gain @ (y[k] - H @ x)).ravel()
            P = (np.eye(2) - gain @ H) @ P
        xs_filt.append(x)
        Ps_filt.append(P)
    smoothed = [xs_filt[-1]]
    for k in range(len(t) - 2, -1, -1):
        dt = t[k + 1] - t[k]
        F = np.array([[1.0, dt], [0.0, 1.0]])
        C = Ps_filt[k] @ F.T @ np.linalg.inv(Ps_pred[k + 1])
        smoothed.insert(0, xs_filt[k] + C @ (smoothed[0] - xs_pred[k + 1]))
    return np.array(smoothed)[:, 0]


def test_kalman_is_the_textbook_rts_smoother():
    rng = np.random.default_rng(7)
    frames = np.cumsum(rng.integers(1, 4, 40))  # frames skip by 1-3
    T = len(frames)
    poses = np.cumsum(np.cumsum(rng.normal(size=(T, 14, 2)), axis=0), axis=0) * 3 + 200
    poses += rng.normal(size=poses.shape)
    missing = np.zeros((T, 14), bool)
    missing[:3, 1] = True        # before the first observation
    missing[10:18, 1] = True     # inside
    missing[30:, 1] = True       # after the last
    missing[5:25, 6] = True
    missing[rng.random((T, 14)) < 0.2] = True
    missing[:, 0] = False
    q, r = 0.7, 2.0
    out = fill_kalman(np.where(missing[..., None], np.nan, poses), missing, frames, q=q, r=r,
                      persistence=np.inf)
    for j, k in [(1, 0), (1, 1), (6, 0), (9, 1)]:
        y = np.where(missing[:, j], np.nan, poses[:, j, k])
        expected = textbook_rts(y, frames.astype(float), q, r)
        hidden = missing[:, j]
        # rtol: the textbook's broad prior costs it about 1e-7 of rounding
        np.testing.assert_allclose(out[hidden, j, k], expected[hidden], rtol=1e-6)
    # the result depends on q / r only; another ratio gives other fills
    same = fill_kalman(poses, missing, frames, q=2 * q, r=2 * r, persistence=np.inf)
    np.testing.assert_allclose(same, out, rtol=1e-9)
    other = fill_kalman(poses, missing, frames, q=q, r=10 * r, persistence=np.inf)
    assert np.abs(other - out)[missing].max() > 0.1


def simulate_constant_velocity(T, q, r, rng, frames=None):
    """Every coordinate of a (T, 14, 2) track drawn from the model itself."""
    frames = np.arange(T) if frames is None else frames
    x = np.zeros((28, 2))
    x[:, 1] = rng.normal(scale=3.0, size=28)
    out = np.empty((T, 28))
    for k in range(T):
        if k:
            dt = frames[k] - frames[k - 1]
            Q = q * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
            x = x @ np.array([[1.0, 0.0], [dt, 1.0]]) + rng.multivariate_normal([0, 0], Q, 28)
        out[k] = x[:, 0]
    return (out + rng.normal(scale=np.sqrt(r), size=out.shape)).reshape(T, 14, 2)


def test_the_noise_fit_recovers_simulated_noise():
    rng = np.random.default_rng(8)
    frames = np.cumsum(rng.integers(1, 3, 2000))
    poses = simulate_constant_velocity(len(frames), 0.3, 2.5, rng, frames)
    missing = rng.random((len(frames), 14)) < 0.1
    noise = fit_kalman_noise(poses, missing, frames)
    assert noise.q.shape == noise.r.shape == (14, 2)
    assert np.ptp(noise.q) == 0 and np.ptp(noise.r) == 0  # one pair for the clip
    assert noise.q[0, 0] == pytest.approx(0.3, rel=0.1)
    assert noise.r[0, 0] == pytest.approx(2.5, rel=0.05)
    # per coordinate: each series' own, all near the truth, not all equal
    each = fit_kalman_noise(poses, missing, frames, pooling="coordinate")
    assert np.ptp(each.q) > 0
    np.testing.assert_allclose(each.q, 0.3, rtol=0.35)
    np.testing.assert_allclose(each.r, 2.5, rtol=0.2)
    assert each.log_likelihood > noise.log_likelihood  # more freedom, a higher maximum
    # a joint seen twice has nothing to fit: NaN there, the others' own
    missing[:, 6] = True
    missing[[5, 9], 6] = False
    by_joint = fit_kalman_noise(poses, missing, frames, pooling="joint")
    assert np.isnan(by_joint.q[6]).all() and np.isnan(by_joint.r[6]).all()
    assert np.isfinite(np.delete(by_joint.q, 6, axis=0)).all()
    np.testing.assert_allclose(np.delete(by_joint.r, 6, axis=0), 2.5, rtol=0.2)


def test_kalman_clip_ends_held_extrapolated_or_damped():
    frames = np.arange(20)
    truth = track(2.0 * frames + 1.0, frames)
    missing = np.zeros((20, 14), bool)
    missing[:4, 3] = missing[15:, 3] = True
    given = np.where(missing[..., None], np.nan, truth)
    held = fill_kalman(given, missing, frames, persistence=0)
    np.testing.assert_allclose(held[:4, 3], np.repeat(truth[4:5, 3], 4, axis=0), atol=1e-9)
    np.testing.assert_allclose(held[15:, 3], np.repeat(truth[14:15, 3], 5, axis=0), atol=1e-9)
    # extrapolated at the velocity there: the line goes on
    np.testing.assert_allclose(fill_kalman(given, missing, frames, persistence=np.inf), truth,
                               atol=1e-6)
    # damped: d frames out, the velocity's reach over tau (1 - exp(-d / tau)) frames
    tau = 3.0
    reach = tau * (1 - np.exp(-np.arange(1, 6) / tau))
    velocity = (truth[1, 3] - truth[0, 3])[None]
    damped = fill_kalman(given, missing, frames, persistence=tau)
    np.testing.assert_allclose(damped[15:, 3], truth[14, 3] + reach[:, None] * velocity,
                               atol=1e-6)
    np.testing.assert_allclose(damped[:4, 3], truth[4, 3] - reach[:4][::-1, None] * velocity,
                               atol=1e-6)
    assert np.array_equal(fill_kalman(given, missing, frames),
                          fill_kalman(given, missing, frames, persistence=20.0))
    # one observation: held everywhere; two: the line through them
    missing = np.ones((20, 14), bool)
    missing[7, 2] = missing[[5, 9], 4] = False
    missing[:, 0] = False
    out = fill_kalman(np.where(missing[..., None], np.nan, truth), missing, frames,
                      persistence=np.inf)
    np.testing.assert_allclose(out[:, 2], np.repeat(truth[7:8, 2], 20, axis=0), atol=1e-9)
    np.testing.assert_allclose(out[:, 4], truth[:, 4], atol=1e-6)


def test_kalman_refuses_bad_options():
    poses, missing = np.zeros((5, 14, 2)), np.zeros((5, 14), bool)
    with pytest.raises(ParameterError, match="give both q and r"):
        fill_kalman(poses, missing, np.arange(5), q=1.0)
    with pytest.raises(ParameterError, match="r must be"):
        fill_kalman(poses, missing, np.arange(5), q=1.0, r=0.0)
    with pytest.raises(ParameterError, match="pooling must be one of"):
        fit_kalman_noise(poses, missing, np.arange(5), pooling="frame")
    with pytest.raises(ParameterError, match="persistence must be"):
        fill_kalman(poses, missing, np.arange(5), persistence=-1.0)
    with pytest.raises(PoseError, match="sorted and unique"):
        fill_kalman(poses, missing, [0, 1, 1, 2, 3])


def test_pca_ignores_a_component_the_observed_joints_barely_see():
    """A joint moving on its own, seen by an observed joint only at 1e-6: a
    hundredth of a pixel of noise there must not be read as that motion (it sent
    short real clips' fills 10^9 body heights away)."""
    rng = np.random.default_rng(0)
    T = 40
    a, b = rng.normal(size=T), rng.normal(size=T)
    poses = a[:, None, None] * rng.normal(size=(14, 2))
    poses[:, 13] += 20 * b[:, None]
    poses[:, 0, 0] += 1e-6 * b
    missing = np.zeros((T, 14), bool)
    missing[20:, 13] = True
    poses[20:, 0, 0] += 0.01
    filled = fill_pca(poses, missing, np.arange(T))
    assert np.abs(filled - poses)[missing].max() <= np.ptp(poses[:, 13])
