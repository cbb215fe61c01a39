"""The default path's newest steps give the same answers whatever the workers:
photos (the held-back check, the averaged members, the blend of poses with many
hidden joints, the mean with the local ridge) and a noisy clip (the carried
prior, a joint never seen taking its mirror image in), n_jobs=1 against 2."""

import numpy as np
import pytest

from sparseedm import recover
from sparseedm.adaptation import guard_masks


def _photos(cmu_poses):
    rng = np.random.default_rng(0)
    poses = cmu_poses[np.sort(rng.integers(0, len(cmu_poses), 340))]
    poses = poses + rng.normal(0, 0.5, poses.shape)
    missing = np.zeros(poses.shape[:2], bool)
    missing[300:] = guard_masks(40, 14, random_state=0)
    missing[300:320, [9, 10, 12, 13]] = True  # four hidden: blended
    return np.where(missing[..., None], np.nan, poses), missing, {}


def _clip(track):
    poses = track + np.random.default_rng(0).normal(0, 1.0, track.shape)
    missing = np.zeros(poses.shape[:2], bool)
    for start in (20, 80, 150):
        missing[start:start + 10, [4, 10]] = True
    missing[:, 7] = True  # never seen
    return (np.where(missing[..., None], np.nan, poses), missing,
            {"frames": np.arange(len(poses))})


@pytest.mark.parametrize("make", [_photos, _clip], ids=["photos", "clip"])
def test_two_workers_give_the_answers_of_one(make, cmu_poses, track,
                                                         small_dictionary):
    poses, missing, kw = make(cmu_poses if make is _photos else track)
    one = recover(poses, missing, dictionary=small_dictionary, **kw)
    two = recover(poses, missing, dictionary=small_dictionary, n_jobs=2, **kw)
    assert one.ok.all() and np.isfinite(one.poses).all()
    np.testing.assert_array_equal(two.poses, one.poses)
    np.testing.assert_array_equal(two.status, one.status)
    np.testing.assert_array_equal(two.uncertainty, one.uncertainty)
