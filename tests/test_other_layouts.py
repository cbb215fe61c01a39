"""A dictionary of another joint layout than the 14 joints (here 12): recover()'s
paths finish with their answers; the steps that need the 14-joint skeleton's
left and right joints or its bones (the swapped-labels filter, the mirror image
of a never-seen joint, the carried prior's probes, the calibrated uncertainty)
stand aside instead of failing."""

import numpy as np
import pytest

from sparseedm import recover

N = 12


@pytest.fixture(scope="module")
def dictionary12(cmu_poses):
    from sparseedm.dictionary import Dictionary
    from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors

    X, _ = complete_pose_vectors(cmu_poses[:, :N])
    odl = OnlineDictionaryLearning(100, alpha=0.05, batch_size=64, n_passes=1,
                                   random_state=0).fit(X)
    return Dictionary(odl.components_, alpha_recover=0.002,
                      joint_names=tuple(f"marker_{i}" for i in range(N)))


def _hidden(poses, runs, joints):
    missing = np.zeros(poses.shape[:2], bool)
    for start in runs:
        missing[start:start + 10, joints] = True
    return np.where(missing[..., None], np.nan, poses), missing


@pytest.mark.parametrize("adapt", [False, "auto"])
def test_photos_are_recovered_without_an_uncertainty(cmu_poses, dictionary12, adapt):
    poses, missing = _hidden(cmu_poses[:, :N], range(0, 300, 40), [4, 7])
    res = recover(poses, missing, dictionary=dictionary12, adapt=adapt)
    assert res.ok.all() and np.isfinite(res.poses).all()
    assert res.uncertainty is None  # the calibrated rule is the 14-joint skeleton's


def test_a_clip_with_a_joint_never_seen_is_recovered(track, dictionary12):
    noisy = track[:, :N] + np.random.default_rng(0).normal(0, 1.0, (len(track), N, 2))
    poses, missing = _hidden(noisy, (20, 80, 150), [4])
    missing[:, 7] = True  # never seen in the clip: no mirror image without left and right
    poses[:, 7] = np.nan
    res = recover(poses, missing, frames=np.arange(len(poses)), dictionary=dictionary12)
    assert res.ok.all() and np.isfinite(res.poses).all()


def test_probes_score_no_carried_prior_without_a_skeleton(track):
    """probe_errors on a noisy 12-joint segment: the carried prior needs the
    skeleton's bones, so its distances are 0 (not tried), as fill_segment carries
    nothing there."""
    from sparseedm.temporal.model import probe_errors

    rng = np.random.default_rng(0)
    values = track[:60, :N] + rng.normal(0, 2.0, (60, N, 2))
    free = np.zeros((60, N), bool)
    free[20:30, 4] = True
    probe = np.zeros_like(free)
    probe[25:55, [3, 6]] = True
    prior = values + rng.normal(0, 3.0, values.shape)
    score = probe_errors(values, free, probe, prior, np.ones(60))
    assert score.count > 0 and np.isfinite(score.errors).all()
    assert (score.answers_distance, score.carried_distance) == (0.0, 0.0)
