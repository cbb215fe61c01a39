"""Video occlusion protocols (sparseedm.temporal.protocols): seeded, reproducible,
the requested run lengths, and a self-occlusion rule that follows the geometry."""

import numpy as np
import pytest

from sparseedm.cameras import look_at
from sparseedm.temporal.protocols import (GAP_LENGTHS, LIMB_JOINTS, dropout_mask, gap_mask,
                                          run_bin, run_lengths, self_occlusion_mask)


def test_gap_masks_are_seeded():
    a = gap_mask(150, 10, random_state=7)
    assert np.array_equal(a, gap_mask(150, 10, random_state=7))
    assert not np.array_equal(a, gap_mask(150, 10, random_state=8))


@pytest.mark.parametrize("length", GAP_LENGTHS)
def test_gap_masks_have_exactly_the_requested_runs(length):
    ends = 0
    for seed in range(12):
        T = 120 + 15 * seed
        m = gap_mask(T, length, random_state=seed)
        lengths, at_end = run_lengths(m)
        assert set(lengths[m].tolist()) == {length}
        assert m.mean() >= 0.17
        assert m.sum(axis=1).max() <= 7
        assert not m.all(axis=0).any()  # every joint observed somewhere
        ends += at_end.any()
    assert ends >= 3  # some gaps touch a clip end


def test_gap_mask_leaves_a_clip_too_short_for_the_gap_alone():
    assert not gap_mask(90, 90, random_state=0).any()
    assert gap_mask(91, 90, random_state=0).any()


def test_dropouts_are_short_and_about_the_fraction():
    m = dropout_mask(300, random_state=3)
    assert np.array_equal(m, dropout_mask(300, random_state=3))
    assert 0.05 <= m.mean() < 0.06
    lengths, _ = run_lengths(m)
    assert np.median(lengths[m]) <= 5


def body(limb_z, camera_z, wrist_x=0.0):
    """A standing torso in the z = 0 plane, the right wrist at depth `limb_z`; the
    other limb joints far out to the side; a camera on the z axis at `camera_z`."""
    pose = np.zeros((1, 14, 3))
    pose[0, [2, 5, 11, 8]] = [[-0.2, 1.4, 0], [0.2, 1.4, 0], [0.15, 0.9, 0], [-0.15, 0.9, 0]]
    pose[0, 1] = [0, 1.45, 0]
    pose[0, [0, 3, 6, 7, 9, 10, 12, 13]] = [2.0, 1.0, 0.0]
    pose[0, 4] = [wrist_x, 1.15, limb_z]
    eye = np.array([0.0, 1.2, camera_z])
    R = look_at(eye, [0.0, 1.2, 0.0])[0]
    return pose, R, -R @ eye


@pytest.mark.parametrize("camera_z", [4.0, -4.0])
def test_a_joint_behind_the_torso_is_hidden_and_in_front_is_not(camera_z):
    away = -np.sign(camera_z)  # the side of the torso away from the camera
    for limb_z, hidden in [(0.3 * away, True), (-0.3 * away, False), (0.02 * away, False)]:
        pose, R, t = body(limb_z, camera_z)
        mask = self_occlusion_mask(pose, R, t, 1000.0)
        assert mask[0, 4] == hidden, (camera_z, limb_z)
        assert not mask[0, [j for j in range(14) if j != 4]].any()


def test_a_joint_behind_but_beside_the_torso_is_visible():
    pose, R, t = body(-0.3, 4.0, wrist_x=0.45)  # 0.25 m beyond the shoulder line
    assert not self_occlusion_mask(pose, R, t, 1000.0)[0, 4]
    pose, R, t = body(-0.3, 4.0, wrist_x=0.22)  # within the 5 cm margin of the torso
    assert self_occlusion_mask(pose, R, t, 1000.0)[0, 4]
    assert not self_occlusion_mask(pose, R, t, 1000.0, margin=0.0)[0, 4]


def test_torso_joints_are_never_hidden():
    rng = np.random.default_rng(0)
    pose = rng.normal(size=(50, 14, 3)) * 0.3 + [0, 1.2, 0]
    eye = np.array([0.0, 1.2, 5.0])
    R = look_at(eye, [0.0, 1.2, 0.0])[0]
    mask = self_occlusion_mask(pose, R, -R @ eye, 1000.0)
    others = [j for j in range(14) if j not in LIMB_JOINTS]
    assert not mask[:, others].any()
    assert mask.any()  # random bodies do put limbs behind the torso


def test_run_lengths_and_bins_by_hand():
    m = np.zeros((20, 2), bool)
    m[0:3, 0] = True      # 3, at the start
    m[5:12, 0] = True     # 7, inside
    m[4:20, 1] = True     # 16, at the end
    lengths, at_end = run_lengths(m)
    assert lengths[:, 0].tolist() == [3] * 3 + [0, 0] + [7] * 7 + [0] * 8
    assert at_end[:3, 0].all() and not at_end[5:12, 0].any() and at_end[4:, 1].all()
    assert run_bin(lengths[[0, 5, 4], [0, 0, 1]]).tolist() == ["1-5", "6-15", "16-45"]
