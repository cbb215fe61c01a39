"""sparseedm.placement: occluded joints placed from a completed EDM."""

import numpy as np
import pytest

from sparseedm.edm import pose_to_edm
from sparseedm.placement import WEIGHT_POWER, place_missing_joints


@pytest.mark.parametrize("weight_power", [0.0, WEIGHT_POWER, 2.0])
def test_exact_distances_give_the_joints_back(cmu_poses, weight_power):
    poses = cmu_poses[:60]
    rng = np.random.default_rng(0)
    missing = np.zeros(poses.shape[:2], bool)
    for row in missing:  # three joints each, every pattern different
        row[rng.choice(14, 3, replace=False)] = True
    placed = place_missing_joints(poses, pose_to_edm(poses), missing,
                                  weight_power=weight_power)
    np.testing.assert_allclose(placed, poses[missing].reshape(60, 3, 2), atol=1e-6)


def test_the_weights_matter_only_when_the_distances_disagree(cmu_poses):
    poses = cmu_poses[:40]
    missing = np.zeros(poses.shape[:2], bool)
    missing[:, [4, 7]] = True  # both wrists
    edm = pose_to_edm(poses)
    noisy = edm * np.exp(np.random.default_rng(1).normal(0, 0.05, edm.shape))
    noisy = (noisy + noisy.transpose(0, 2, 1)) / 2
    a, b = (place_missing_joints(poses, noisy, missing, weight_power=w) for w in (0.0, 2.0))
    assert np.isfinite(a).all() and np.isfinite(b).all()
    assert np.abs(a - b).max() > 1e-3
    # both stay near the truth: the weighting re-balances, it does not break the fit
    truth = poses[missing].reshape(40, 2, 2)
    scale = np.ptp(poses, axis=1).max(axis=1)[:, None, None]
    assert (np.abs(a - truth) / scale).mean() < 0.05
    assert (np.abs(b - truth) / scale).mean() < 0.05


def test_nearly_collinear_anchors_stay_within_reach():
    # Observed joints on (almost) one line make the linearised trilateration
    # ill-posed across it; with noisy distances the start and plain
    # Gauss-Newton used to throw joints hundreds of body sizes away (a video
    # benchmark found one 'recovered' pose thousands of heights off).
    from sparseedm.edm import pose_to_edm
    from sparseedm.placement import place_missing_joints

    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(300):
        pose = rng.normal(0, 1, (14, 2))
        obs = rng.choice(14, 8, replace=False)
        pose[obs, 0] = rng.normal(0, 10.0 ** rng.uniform(-8, -3), 8)
        miss = np.ones(14, bool)
        miss[obs] = False
        edm = pose_to_edm(pose[None])[0]
        noisy = edm * (1 + rng.normal(0, 0.05, edm.shape))
        noisy = (noisy + noisy.T) / 2
        np.fill_diagonal(noisy, 0)
        placed = place_missing_joints(pose[None], noisy[None], miss[None])[0]
        anchors = pose[obs]
        c = anchors.mean(axis=0)
        reach = (noisy[np.ix_(miss, obs)] + np.linalg.norm(anchors - c, axis=1)).max(axis=1)
        worst = max(worst, float((np.linalg.norm(placed - c, axis=1) / reach).max()))
    assert worst <= 1.0 + 1e-9
