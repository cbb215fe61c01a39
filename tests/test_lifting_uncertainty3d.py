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


def test_lift_npz_output_holds_both_radii(cmu, tmp_path):
    from sparseedm.cli import main
    from sparseedm.keypoints import write_keypoints

    poses = cmu["poses2d"][:5].copy()
    poses[1, 4] = np.nan
    poses[3, 2:] = np.nan                     # refused
    src = write_keypoints(tmp_path / "in.csv", poses, ids=[f"f{i}" for i in range(5)])
    assert main(["lift", str(src), "-o", str(tmp_path / "out.npz"), "-q"]) == 1
    with np.load(tmp_path / "out.npz", allow_pickle=False) as npz:
        r3, r2 = npz["uncertainty3d"], npz["uncertainty2d"]
    assert r3.shape == r2.shape == (5, 14)
    assert np.isnan(r3[3]).all() and (r3[[0, 1, 2, 4]] > 0).all()
    assert np.isnan(r2[1, 4]) and r2[0, 4] == 0


def test_filled_joint_of_a_video_less_sure_than_observed(cmu):
    ix = np.flatnonzero(cmu["clips"] == "01_01")
    poses = cmu["poses2d"][ix].copy()
    poses[10:14, 4] = np.nan                  # a 4-frame gap in the right wrist
    res = sparseedm.lift(poses, frames=np.arange(len(ix)), uncertainty3d=True)
    filled = res.filled[:, 4]
    assert filled[10:14].all() and not filled[:8].any()
    r = res.uncertainty3d[:, 4]
    assert (r[filled] > r[:8].max()).all()
    assert np.isfinite(res.uncertainty3d).all() and (res.uncertainty3d > 0).all()


def test_weights_leave_complete_poses_unchanged_and_move_filled_ones(cmu):
    from sparseedm.normalize import represent

    lf = load_lifter()
    poses = cmu["poses2d"][:3]
    none = np.zeros((3, 14), bool)
    X2, _, _ = represent(poses, none, "average")
    plain, _ = lf.predict(X2, none)
    ones, _ = lf.predict(X2, none, weights=np.ones((3, 14)))
    assert np.array_equal(plain, ones)
    assert (u3.filled_weights(poses, none, none, np.zeros((3, 14))) == 1).all()
    # a filled wrist with a growing 2D radius counts less and less
    filled = none.copy()
    filled[:, 4] = True
    dropped, _ = lf.predict(X2, filled)
    dist = []
    for r in (1.0, 5.0, 50.0):
        w = u3.filled_weights(poses, none, filled, np.where(filled, r, 0.0))
        assert (w[:, 4] < 1).all() and (w[:, :4] == 1).all()
        Y, info = lf.predict(X2, none, weights=w)
        assert (info["status"] != "failed").all()
        dist.append(np.linalg.norm(Y - dropped, axis=1).mean())
    assert dist[2] < dist[1] < dist[0]


def test_weighted_rows_sharing_a_pattern_solve_together_as_each_alone(cmu, monkeypatch):
    """Rows with the same observed entries and weights are coded in one solve
    (from WEIGHTED_GROUP_MIN rows on, lowered here): the same 3D vectors and
    statuses as each row lifted alone (one solve per row)."""
    from sparseedm.lifting import dictionary as dictionary_lifter
    from sparseedm.normalize import represent

    lf = load_lifter()
    n = 30
    poses = cmu["poses2d"][:n]
    missing = np.zeros((n, 14), bool)
    missing[n // 2:, 7] = True  # two observed-entry patterns
    X2, _, _ = represent(poses, missing, "average")
    w = np.ones((n, 14))
    w[:, 3] = np.where(np.arange(n) % 3 == 0, 0.4, 0.7)  # groups of 5 and 10 rows
    w[27, 10] = 0.2  # a row alone (the second pattern's 0.4 group: 4 rows)
    solves = []
    solver = type(dictionary_lifter.get_solver(lf.solver))
    real_solve = solver.solve
    monkeypatch.setattr(solver, "solve",
                        lambda self, D, X, *a, **k: solves.append(len(X)) or
                        real_solve(self, D, X, *a, **k))
    monkeypatch.setattr(dictionary_lifter, "WEIGHTED_GROUP_MIN", 10)
    together, info = lf.predict(X2, missing, weights=w)
    assert sorted(solves) == [1] * 10 + [10, 10]  # groups under 10 rows: row by row
    monkeypatch.setattr(solver, "solve", real_solve)
    for i in range(n):
        alone, one = lf.predict(X2[i:i + 1], missing[i:i + 1], weights=w[i:i + 1])
        np.testing.assert_allclose(together[i], alone[0], rtol=1e-9, atol=1e-12)
        assert info["status"][i] == one["status"][0]
        assert info["n_active"][i] == one["n_active"][0]
