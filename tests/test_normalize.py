"""sparseedm.normalize: hand-computed representations and properties."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from sparseedm.edm import observed_entries, pose_to_vector
from sparseedm.exceptions import PoseError
from sparseedm.normalize import (
    REPRESENTATIONS,
    denormalize,
    missing_mask,
    normalize,
    represent,
)

# Hand-computed example: 4 joints, joint 3 occluded (its coordinates are far
# away to show that they are ignored).
#   observed p0 = (2, 1), p1 = (6, 1), p2 = (6, 3)
#   bounding box x in [2, 6], y in [1, 3]  ->  center = (4, 2)
#   scale = max(6 - 2, 3 - 1) / 2 = 2
#   normalised: p0 = (-1, -0.5), p1 = (1, -0.5), p2 = (1, 0.5)
#   distances: d01 = 2, d02 = sqrt(2^2 + 1^2) = sqrt(5), d12 = 1
# 'zero': entries touching joint 3 are 0:
#   T = [d01, d02, d03, d12, d13, d23] = [2, sqrt5, 0, 1, 0, 0]
# 'average': joint 3 := mean of observed = ((2+6+6)/3, (1+1+3)/3) = (14/3, 5/3),
#   inside the box, so center/scale unchanged; normalised
#   ((14/3 - 4)/2, (5/3 - 2)/2) = (1/3, -1/6)
#   d03 = |(4/3, 1/3)|  = sqrt(17)/3
#   d13 = |(-2/3, 1/3)| = sqrt(5)/3
#   d23 = |(-2/3, -2/3)| = sqrt(8)/3
POSE = np.array([[2.0, 1.0], [6.0, 1.0], [6.0, 3.0], [100.0, 100.0]])
MISSING = np.array([False, False, False, True])
S5 = np.sqrt(5.0)
EXPECTED = {
    "zero": [2.0, S5, 0.0, 1.0, 0.0, 0.0],
    "average": [2.0, S5, np.sqrt(17) / 3, 1.0, S5 / 3, np.sqrt(8) / 3],
}


def test_normalize_hand_example():
    out, center, scale = normalize(POSE, MISSING)
    np.testing.assert_array_equal(center, [4.0, 2.0])
    assert float(scale) == 2.0
    np.testing.assert_array_equal(out[:3], [[-1, -0.5], [1, -0.5], [1, 0.5]])
    # the missing joint gets the same transform: ((100-4)/2, (100-2)/2)
    np.testing.assert_array_equal(out[3], [48.0, 49.0])


@pytest.mark.parametrize("representation", ["zero", "average"])
def test_represent_hand_example(representation):
    T, center, scale = represent(POSE, MISSING, representation)
    np.testing.assert_allclose(T, EXPECTED[representation], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(center, [4.0, 2.0])
    assert float(scale) == 2.0


def test_representations_listed():
    assert set(REPRESENTATIONS) == {"zero", "average"}


# ------------------------------------------------------------- properties

coord = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@st.composite
def occluded_poses(draw, max_batch=3):
    n_joints = draw(st.integers(3, 14))
    batch = draw(st.integers(1, max_batch))
    poses = draw(hnp.arrays(float, (batch, n_joints, 2), elements=coord))
    missing = draw(hnp.arrays(bool, (batch, n_joints)))
    # keep at least 3 observed joints per pose
    for b in range(batch):
        observed = np.flatnonzero(~missing[b])
        if len(observed) < 3:
            missing[b, : 3] = False
    used = np.where(missing[..., None], np.nan, poses)
    extent = np.nanmax(used, axis=1) - np.nanmin(used, axis=1)
    assume((extent.max(axis=-1) > 1e-6).all())
    return poses, missing


SETTINGS = settings(max_examples=40, deadline=None)


@SETTINGS
@given(data=occluded_poses())
def test_observed_joints_in_unit_box_longer_axis_spans(data):
    poses, missing = data
    out, center, scale = normalize(poses, missing)
    obs = np.where(missing[..., None], np.nan, out)
    lo, hi = np.nanmin(obs, axis=1), np.nanmax(obs, axis=1)
    tol = 1e-12
    assert (lo >= -1 - tol).all() and (hi <= 1 + tol).all()
    # the longer axis spans [-1, 1]: extent exactly 2 up to rounding
    span = (hi - lo).max(axis=-1)
    np.testing.assert_allclose(span, 2.0, rtol=0, atol=tol)
    longer = (hi - lo).argmax(axis=-1)
    b = np.arange(len(poses))
    np.testing.assert_allclose(lo[b, longer], -1.0, rtol=0, atol=tol)
    np.testing.assert_allclose(hi[b, longer], 1.0, rtol=0, atol=tol)
    assert (scale > 0).all()


@SETTINGS
@given(data=occluded_poses())
def test_normalize_denormalize_round_trip(data):
    poses, missing = data
    out, center, scale = normalize(poses, missing)
    back = denormalize(out, center, scale)
    np.testing.assert_allclose(back, poses, rtol=1e-12, atol=1e-9)


def test_round_trip_single_pose():
    out, center, scale = normalize(POSE, MISSING)
    np.testing.assert_array_equal(denormalize(out, center, scale), POSE)


@SETTINGS
@given(data=occluded_poses(), threshold=st.floats(0.05, 1.0))
def test_mask_nan_and_confidence_agree(data, threshold):
    poses, mask = data
    with_nan = np.where(mask[..., None], np.nan, poses)
    confidence = np.where(mask, threshold / 2, threshold)  # missing: below
    masks = [
        mask,
        missing_mask(with_nan),
        missing_mask(poses, confidence=confidence, threshold=threshold),
        missing_mask(poses, mask),
    ]
    for m in masks[1:]:
        np.testing.assert_array_equal(m, mask)

    ref, c_ref, s_ref = normalize(poses, mask)
    for src, m in ((with_nan, masks[1]), (poses, masks[2])):
        out, c, s = normalize(src, m)
        np.testing.assert_array_equal(c, c_ref)
        np.testing.assert_array_equal(s, s_ref)
        np.testing.assert_array_equal(out[~mask], ref[~mask])

    for rep in REPRESENTATIONS:
        T_ref, _, _ = represent(poses, mask, rep)
        np.testing.assert_array_equal(represent(with_nan, None, rep)[0], T_ref)
        np.testing.assert_array_equal(represent(poses, masks[2], rep)[0], T_ref)


@SETTINGS
@given(data=occluded_poses())
def test_representations_share_observed_entries(data):
    poses, mask = data
    T_zero, c0, s0 = represent(poses, mask, "zero")
    T_avg, c1, s1 = represent(poses, mask, "average")
    np.testing.assert_allclose(c0, c1, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(s0, s1, rtol=1e-12)
    obs = observed_entries(mask)
    np.testing.assert_allclose(T_zero[obs], T_avg[obs], rtol=1e-9, atol=1e-12)
    assert (T_zero[~obs] == 0).all()
    normalized, _, _ = normalize(poses, mask)
    np.testing.assert_array_equal(T_zero[obs], pose_to_vector(normalized)[obs])


# ------------------------------------------------------------------ errors


def test_nan_in_observed_coordinate():
    pose = POSE.copy()
    pose[1, 0] = np.nan
    with pytest.raises(PoseError, match="observed joint 1"):
        normalize(pose)
    with pytest.raises(PoseError, match="NaN"):
        normalize(pose, [False, False, False, True])
    pose[1, 0] = np.inf
    with pytest.raises(PoseError, match="infinite"):
        represent(pose, MISSING, "average")


@pytest.mark.parametrize("representation", [None, "zero", "average"])
def test_fewer_than_three_observed(representation):
    missing = [False, False, True, True]
    with pytest.raises(PoseError, match="2 observed joints"):
        if representation is None:
            normalize(POSE, missing)
        else:
            represent(POSE, missing, representation)


@pytest.mark.parametrize("representation", [None, "zero", "average"])
def test_all_observed_coincide(representation):
    pose = np.array([[1.0, 1.0], [1.0, 1.0], [1.0, 1.0], [5.0, 5.0]])
    with pytest.raises(PoseError, match="coincide"):
        if representation is None:
            normalize(pose, MISSING)
        else:
            represent(pose, MISSING, representation)


def test_bad_representation_name():
    with pytest.raises(ValueError, match="unknown representation 'mean'"):
        represent(POSE, MISSING, "mean")


def test_bad_shapes():
    with pytest.raises(PoseError):
        normalize(np.zeros((4, 3)))
    with pytest.raises(PoseError, match="missing must have shape"):
        missing_mask(POSE, [True, False])
    with pytest.raises(PoseError, match="confidence must have shape"):
        missing_mask(POSE, confidence=[1.0])
