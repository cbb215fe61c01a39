"""The 3D radius of lifted joints (sparseedm.lifting.uncertainty3d, lift(uncertainty3d=True))."""

import numpy as np
import pytest

import sparseedm
from sparseedm.lifting import load_lifter, training_pairs
from sparseedm.lifting import uncertainty3d as u3
from sparseedm.lifting.lift import lift_reflections
from sparseedm.lifting.metrics import pelvis

from conftest import CMU_POSES


@pytest.fixture(scope="module")
def cmu():
    with np.load(CMU_POSES, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def test_radius_positive_finite_nan_for_refused(cmu):
    poses = cmu["poses2d"][:6].copy()
    poses[1, 4] = np.nan                      # an occluded wrist
    poses[2, 2:] = np.nan                     # too few joints: refused
    res = sparseedm.lift(poses, uncertainty3d=True)
    r = res.uncertainty3d
    assert r.shape == (6, 14)
    assert not res.ok[2] and np.isnan(r[2]).all()
    ok = r[res.ok]
    assert np.isfinite(ok).all() and (ok > 0).all()
    # a joint the lifter must place from the others is less sure than seen
    assert r[1, 4] > r[0, 4] and r[1, 4] > r[3, 4]


def test_radius_off_by_default(cmu):
    assert sparseedm.lift(cmu["poses2d"][:2]).uncertainty3d is None


def test_radius_grows_with_the_2d_radius(cmu):
    lf = load_lifter()
    poses = cmu["poses2d"][:4]
    filled = np.zeros((4, 14), bool)
    filled[:, 4] = True                       # the right wrist was filled
    height = np.ptp(poses[..., 1], axis=1)[:, None]

    def relift(p):
        return lift_reflections(lf, p)

    radii = []
    for frac in (0.0, 0.05, 0.2):
        spread = u3.spread3d(relift, poses, filled, np.where(filled, frac * height, 0.0), seed=0)
        base = u3.base_radius(lf.size_prior_, np.zeros((4, 14), bool), np.ones(4, bool))
        radii.append(u3.combine_radius(base, spread)[:, 4])
    assert np.allclose(radii[0], u3.BASE_OBSERVED[4] * lf.size_prior_)
    assert (radii[1] > radii[0]).all() and radii[2].mean() > radii[1].mean()


def test_coverage_of_complete_poses_in_a_sane_band(cmu):
    # fixture poses through their virtual cameras, the shipped lifter
    _, _, _, truth = training_pairs(cmu["poses2d"], cmu["poses3d"], cmu["camera_R"],
                                    cmu["camera_t"], cmu["camera_f"])
    res = sparseedm.lift(cmu["poses2d"], uncertainty3d=True)
    P = res.poses3d[res.ok]
    t = truth[res.ok]
    err = np.linalg.norm((P - pelvis(P)[:, None]) - (t - pelvis(t)[:, None]), axis=-1)
    cover = float(np.mean(err <= res.uncertainty3d[res.ok]))
    assert 0.75 <= cover <= 1.0, cover
