"""sparseedm.metrics: Err_ave, joint error and the seeded occlusion protocol."""

import numpy as np
import pytest

from sparseedm.edm import edm_to_vector, pose_to_edm, pose_to_vector, vector_to_edm
from sparseedm.exceptions import PoseError
from sparseedm.metrics import (
    OCCLUSION_COUNTS,
    err_ave,
    err_entries,
    joint_error,
    random_occlusion,
)

# ------------------------------------------------------------------ Err_ave


def test_err_ave_hand_example():
    # 3-4-5 triangle: T_gt = [d01, d02, d12] = [3, 5, 4]
    gt = np.array([3.0, 5.0, 4.0])
    f = np.array([3.3, 5.0, 3.6])
    # |3.3-3|/3 = 10 %, |5-5|/5 = 0 %, |3.6-4|/4 = 10 %  ->  mean 20/3 %
    np.testing.assert_allclose(err_entries(f, gt), [10.0, 0.0, 10.0])
    assert err_ave(f, gt) == pytest.approx(20.0 / 3.0)
    # the same through full EDMs: the mean over the N^2 - N off-diagonal
    # entries counts each pair twice, so it equals the upper-triangle mean
    assert err_ave(edm_to_vector(vector_to_edm(f)), edm_to_vector(vector_to_edm(gt))) == pytest.approx(20.0 / 3.0)


def test_err_ave_batched_edms():
    rng = np.random.default_rng(0)
    poses = rng.normal(size=(5, 14, 2))
    noisy = poses + 0.01 * rng.normal(size=poses.shape)
    from_edm = err_ave(edm_to_vector(pose_to_edm(noisy)), edm_to_vector(pose_to_edm(poses)))
    from_vec = err_ave(pose_to_vector(noisy), pose_to_vector(poses))
    assert from_edm.shape == (5,)
    np.testing.assert_allclose(from_edm, from_vec)
    with pytest.raises(PoseError):  # full EDMs are never guessed to be vectors
        err_ave(pose_to_edm(poses), pose_to_edm(poses))


def test_zero_ground_truth_distances_excluded():
    # joints 0 and 1 coincide in the ground truth: entry (0,1) has no ratio
    gt = np.array([0.0, 5.0, 4.0])
    f = np.array([1.0, 5.5, 4.0])
    entries = err_entries(f, gt)
    assert np.isnan(entries[0])
    np.testing.assert_allclose(entries[1:], [10.0, 0.0])
    assert err_ave(f, gt) == pytest.approx(5.0)  # mean of 10 and 0, not of 3


def test_err_shape_errors():
    with pytest.raises(PoseError, match="shapes differ"):
        err_ave(np.zeros(3), np.ones(6))
    with pytest.raises(PoseError):
        err_ave(np.ones(4), np.ones(4))  # 4 is not N(N-1)/2


def test_err_ave_square_batch_of_vectors():
    gt = np.array([[3.0, 5.0, 4.0]] * 3)
    f = gt.copy()
    f[:, 0] = 3.3
    np.testing.assert_allclose(err_ave(f, gt), [10 / 3] * 3)


# -------------------------------------------------------------- joint_error


def test_joint_error_hand_example():
    gt = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    f = np.array([[3.0, 4.0], [1.0, 1.0], [2.0, 3.0]])
    np.testing.assert_array_equal(joint_error(f, gt), [5.0, 0.0, 1.0])
    err = joint_error(f, gt, missing=[True, False, True])
    assert err[0] == 5.0 and np.isnan(err[1]) and err[2] == 1.0
    assert np.nanmean(err) == 3.0
    # batched, 3-D
    f3 = np.zeros((2, 3, 3))
    f3[1, 2] = [2.0, 3.0, 6.0]
    np.testing.assert_array_equal(joint_error(f3, np.zeros((2, 3, 3)))[1], [0, 0, 7])
    with pytest.raises(PoseError, match="shapes differ"):
        joint_error(f, gt[:2])


# --------------------------------------------------------- random occlusion


@pytest.mark.parametrize("k", [1, 2, 3])
def test_random_occlusion_exact_counts_and_seed(k):
    m = random_occlusion(200, 14, k, random_state=7)
    assert m.shape == (200, 14) and m.dtype == bool
    assert (m.sum(axis=1) == k).all()
    np.testing.assert_array_equal(m, random_occlusion(200, 14, k, random_state=7))
    assert not np.array_equal(m, random_occlusion(200, 14, k, random_state=8))
    # every joint gets occluded somewhere: the draw is not stuck
    assert m.any(axis=0).all()


def test_random_occlusion_generator_state():
    rng = np.random.default_rng(3)
    a = random_occlusion(5, 14, 2, random_state=rng)
    b = random_occlusion(5, 14, 2, random_state=rng)
    assert not np.array_equal(a, b)  # the generator advances
    np.testing.assert_array_equal(a, random_occlusion(5, 14, 2, random_state=3))


def test_random_occlusion_mix():
    m = random_occlusion(300, 14, "mix", random_state=0)
    counts = m.sum(axis=1)
    assert set(counts.tolist()) == {1, 2, 3}
    np.testing.assert_array_equal(m, random_occlusion(300, 14, "mix", random_state=0))
    assert "mix" in OCCLUSION_COUNTS


def test_random_occlusion_zero_and_too_many():
    assert not random_occlusion(3, 14, 0, random_state=0).any()
    assert (random_occlusion(3, 14, 11, random_state=0).sum(axis=1) == 11).all()
    with pytest.raises(ValueError, match="at least 3"):
        random_occlusion(3, 14, 12)
    with pytest.raises(ValueError):
        random_occlusion(3, 14, -1)


def test_random_occlusion_mix_small_skeleton_keeps_three_observed():
    try:
        m = random_occlusion(500, 5, "mix", random_state=0)
    except ValueError:
        return  # refusing is also acceptable
    assert ((~m).sum(axis=1) >= 3).all()
