"""Properties of sparseedm.edm: invariances, symmetry, vector order, shapes."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.spatial.distance import pdist, squareform
from scipy.spatial.transform import Rotation

from sparseedm.edm import (
    edm_to_vector,
    num_joints_from_dim,
    observed_entries,
    pose_to_edm,
    pose_to_vector,
    triu_indices,
    vector_to_edm,
)
from sparseedm.exceptions import PoseError

coords = st.floats(-100, 100, allow_nan=False, allow_infinity=False, width=64)


@st.composite
def poses(draw, dims=(2, 3), max_batch=3):
    d = draw(st.sampled_from(dims))
    n_joints = draw(st.integers(3, 16))
    batch = draw(st.lists(st.integers(1, max_batch), max_size=2))
    return draw(hnp.arrays(float, tuple(batch) + (n_joints, d), elements=coords))


def _orthogonal(d, seed, reflect):
    if d == 2:
        theta = np.random.default_rng(seed).uniform(0, 2 * np.pi)
        q = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    else:
        q = Rotation.random(random_state=seed).as_matrix()
    if reflect:
        q = q @ np.diag([-1.0] + [1.0] * (d - 1))
    return q


SETTINGS = settings(max_examples=40, deadline=None)


@SETTINGS
@given(p=poses(), seed=st.integers(0, 2**32 - 1), reflect=st.booleans(),
       shift=st.lists(coords, min_size=3, max_size=3))
def test_invariant_to_rigid_motion_and_reflection(p, seed, reflect, shift):
    d = p.shape[-1]
    q = _orthogonal(d, seed, reflect)
    moved = p @ q.T + np.asarray(shift[:d])
    scale = max(1.0, np.abs(p).max())
    np.testing.assert_allclose(pose_to_edm(moved), pose_to_edm(p), atol=1e-9 * scale)
    np.testing.assert_allclose(pose_to_vector(moved), pose_to_vector(p), atol=1e-9 * scale)


@SETTINGS
@given(p=poses())
def test_symmetric_with_exact_zero_diagonal(p):
    e = pose_to_edm(p)
    n = p.shape[-2]
    assert e.shape == p.shape[:-1] + (n,)
    np.testing.assert_array_equal(e, np.swapaxes(e, -1, -2))
    np.testing.assert_array_equal(np.diagonal(e, axis1=-2, axis2=-1), 0.0)
    assert (e >= 0).all()


@SETTINGS
@given(p=poses())
def test_vector_matrix_round_trip(p):
    e = pose_to_edm(p)
    v = edm_to_vector(e)
    n = p.shape[-2]
    assert v.shape == p.shape[:-2] + (n * (n - 1) // 2,)
    np.testing.assert_array_equal(vector_to_edm(v), e)
    np.testing.assert_array_equal(edm_to_vector(vector_to_edm(v)), v)


@SETTINGS
@given(p=poses(max_batch=1))
def test_order_matches_scipy_pdist(p):
    single = p.reshape(p.shape[-2:]) if p.ndim > 2 else p
    np.testing.assert_allclose(pose_to_vector(single), pdist(single), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(vector_to_edm(pdist(single)), squareform(pdist(single)))


@SETTINGS
@given(p=poses())
def test_pose_to_vector_equals_edm_to_vector(p):
    np.testing.assert_array_equal(pose_to_vector(p), edm_to_vector(pose_to_edm(p)))


def test_row_major_order_hand_example():
    rows, cols = triu_indices(4)
    assert list(zip(rows.tolist(), cols.tolist())) == [
        (0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)
    ]
    pose = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 2.0], [3.0, 4.0]])
    # (0,1)=1, (0,2)=2, (0,3)=5, (1,2)=sqrt(5), (1,3)=sqrt(20), (2,3)=sqrt(13)
    expected = [1.0, 2.0, 5.0, np.sqrt(5), np.sqrt(20), np.sqrt(13)]
    np.testing.assert_allclose(pose_to_vector(pose), expected)
    assert num_joints_from_dim(91) == 14


def test_triu_indices_read_only():
    rows, _ = triu_indices(5)
    with pytest.raises(ValueError):
        rows[0] = 3


def test_observed_entries():
    missing = np.array([[False, True, False, False], [False] * 4])
    obs = observed_entries(missing)
    # entries (0,1) (0,2) (0,3) (1,2) (1,3) (2,3); joint 1 missing in pose 0
    assert obs.tolist() == [[False, True, True, False, False, True], [True] * 6]


@pytest.mark.parametrize(
    "func, arg",
    [
        (pose_to_edm, np.zeros(3)),               # no joint axis
        (pose_to_edm, np.zeros((5, 4))),          # 4-D coordinates
        (pose_to_edm, np.zeros((5, 1))),          # 1-D coordinates
        (pose_to_edm, np.zeros((2, 2))),          # fewer than 3 joints
        (pose_to_vector, np.zeros((4, 7, 5))),
        (pose_to_vector, np.zeros((1, 2, 3))),
        (edm_to_vector, np.zeros((3, 4))),        # not square
        (edm_to_vector, np.zeros(3)),
        (vector_to_edm, np.zeros(4)),             # not N(N-1)/2
        (vector_to_edm, np.zeros((2, 90))),
        (vector_to_edm, np.float64(3.0)),         # scalar
        (num_joints_from_dim, 0),
        (num_joints_from_dim, 7),
    ],
)
def test_bad_shapes_raise_pose_error(func, arg):
    with pytest.raises(PoseError):
        func(arg)
