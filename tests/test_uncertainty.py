"""The calibrated 90 % radius per joint: its rules, its calibration on a known clip, files."""

import json

import numpy as np
import pytest

import sparseedm
from sparseedm.skeleton import JOINT_NAMES
from sparseedm.keypoints import read_keypoints, write_keypoints
from sparseedm.formats._base import FILLED_LIKELIHOOD_CAP, filled_likelihood
from sparseedm.uncertainty import (coding_way, joint_features, joint_uncertainty, radius_at,
                                   uncertainty_rule)

WRIST = 4


def _mask(T, seed, runs=12, length=(3, 30)):
    """Random runs of hidden joints (1-3 joints each) inside a clip of T frames."""
    rng = np.random.default_rng(seed)
    mask = np.zeros((T, 14), bool)
    for _ in range(runs):
        L = int(rng.integers(*length))
        start = int(rng.integers(1, T - L - 1))
        mask[start:start + L, rng.choice(14, int(rng.integers(1, 4)), replace=False)] = True
    return mask


@pytest.fixture(scope="module")
def clip_result(track, small_dictionary):
    mask = _mask(len(track), 0)
    res = sparseedm.recover(track, mask, frames=np.arange(len(track)),
                            dictionary=small_dictionary, adapt=False)
    return res, mask


def test_observed_zero_filled_positive_refused_nan(cmu_poses, small_dictionary):
    poses = cmu_poses[:6].copy()
    poses[0, WRIST] = np.nan
    poses[1, [3, 4, 9]] = np.nan
    poses[2, 2:] = np.nan  # two joints left: refused
    res = sparseedm.recover(poses, dictionary=small_dictionary, adapt=False)
    u = res.uncertainty
    assert u.shape == (6, 14)
    assert res.status[2] == "too_few_observed" and np.isnan(u[2]).all()
    ok = res.ok
    assert (u[ok][~res.missing[ok]] == 0).all()
    assert (u[ok][res.missing[ok]] > 0).all()
    assert np.isfinite(u[ok]).all() and (u[ok] >= 0).all()


def test_joint_uncertainty_is_what_recover_attaches(clip_result, track):
    res, _ = clip_result
    again = joint_uncertainty(res, None, np.arange(len(track)))
    np.testing.assert_array_equal(again, res.uncertainty)


def test_coverage_on_a_clip_whose_truth_is_known(clip_result, track):
    res, mask = clip_result
    err = np.linalg.norm(res.poses - track, axis=-1)[mask]
    radius = res.uncertainty[mask]
    covered = (err <= radius).mean()
    assert 0.8 <= covered <= 1.0, covered
    # informative: the surest quarter errs less than the least sure quarter
    order = np.argsort(radius)
    q = len(order) // 4
    assert err[order[:q]].mean() < err[order[-q:]].mean()


def test_radius_grows_into_a_long_gap(track, small_dictionary):
    mask = np.zeros(track.shape[:2], bool)
    start, length = 60, 61
    mask[start:start + length, WRIST] = True
    res = sparseedm.recover(track, mask, frames=np.arange(len(track)),
                            dictionary=small_dictionary, adapt=False)
    r = res.uncertainty[start:start + length, WRIST]
    middle = length // 2
    assert np.all(np.diff(r[:middle + 1]) >= 0) and np.all(np.diff(r[middle:]) <= 0)
    assert r[middle] > r[0] and r[middle] > r[-1]


def test_never_below_the_observed_joints_noise(track, small_dictionary):
    rng = np.random.default_rng(1)
    noisy = track + rng.normal(0.0, 3.0, track.shape)  # pixels of jitter
    mask = np.zeros(track.shape[:2], bool)
    mask[50:52, WRIST] = True
    res = sparseedm.recover(noisy, mask, frames=np.arange(len(track)),
                            dictionary=small_dictionary, adapt=False)
    # the jitter's own 90 % radius, sqrt(2 ln 10) sigma, give or take its estimate
    assert (res.uncertainty[mask] >= 0.7 * 3.0 * np.sqrt(2 * np.log(10))).all()


def _own_poses_file(pool, n_complete=400, n_occluded=60, seed=0):
    """n_complete jittered poses of `pool`, then n_occluded with 1-3 joints hidden."""
    from sparseedm.metrics import occlusion_masks

    rng = np.random.default_rng(seed)
    n = n_complete + n_occluded
    poses = pool[rng.integers(0, len(pool), n)] + rng.normal(0, 0.5, (n, 14, 2))
    missing = np.zeros((n, 14), bool)
    missing[n_complete:] = occlusion_masks(n_occluded, 14, ("mix",), seed)["mix"]
    return np.where(missing[..., None], np.nan, poses), missing


def test_each_coding_path_gets_its_own_rule(cmu_poses, small_dictionary):
    """The base dictionary, a dictionary adapted to the file, the file's own poses as
    the only atoms under the lasso (the default path's exemplars) and under the fast
    preset's local ridge: each filled joint's radius is its own path's rule, not the
    base dictionary's."""
    from dataclasses import replace

    poses, missing = _own_poses_file(cmu_poses[:60])  # near-copies: the exemplars win
    weak = replace(small_dictionary, components=small_dictionary.components[:10])
    runs = {"per_frame": sparseedm.recover(poses, missing, dictionary=small_dictionary,
                                           adapt=False),
            "adapted": sparseedm.recover(poses, missing, dictionary=small_dictionary,
                                         exemplars=False, self_training=0),
            "file_atoms": sparseedm.recover(poses, missing, dictionary=weak),
            "local_ridge": sparseedm.recover(poses, missing, dictionary=small_dictionary,
                                             preset="fast")}
    paths = {way: res.summary()["adaptation"]["path"] for way, res in runs.items()
             if res.adaptation is not None}
    assert paths["adapted"] == "adapted" and paths["local_ridge"] == "file atoms"
    assert paths["file_atoms"].startswith("file atoms")  # alone, or codes of them averaged
    for way, res in runs.items():
        filled = res.missing & res.ok[:, None]
        assert filled.sum() > 50 and coding_way(res) == way
        features = joint_features(res)
        assert (features["way"][filled] == way).all()
        np.testing.assert_array_equal(uncertainty_rule(features)[filled],
                                      res.uncertainty[filled])
        as_base = dict(features, way=np.where(filled, "per_frame", ""))
        base_rule = uncertainty_rule(as_base)[filled]
        assert (way == "per_frame") == np.allclose(base_rule, res.uncertainty[filled])


def test_the_file_atoms_rule_reads_the_files_held_back_error(cmu_poses, small_dictionary):
    """The file-atoms rule reads the error the default path's check measured on the
    file's held-back poses from the result's record: a file measured to err more gets
    wider circles (by that error's ratio to the power of its coefficient); a file
    without a check gets the way's unchecked rule, which reads no such error."""
    from dataclasses import replace

    from sparseedm.uncertainty import (CALIBRATION, FEATURES, MIN_RELATIVE,
                                       UNCHECKED_FEATURES)

    poses, missing = _own_poses_file(cmu_poses[:60])
    weak = replace(small_dictionary, components=small_dictionary.components[:10])
    res = sparseedm.recover(poses, missing, dictionary=weak)
    assert coding_way(res) == "file_atoms"
    filled = res.missing & res.ok[:, None]
    measured = res.adaptation.settings["held_err_path"]
    features = joint_features(res)
    assert (features["checked"][filled] == 1).all()
    np.testing.assert_allclose(features["log_held_error"][filled], np.log(measured / 100))

    def radius(**settings):
        kept = {k: v for k, v in res.adaptation.settings.items() if k != "held_err_path"}
        again = replace(res, adaptation=replace(res.adaptation, settings=dict(kept, **settings)))
        return joint_uncertainty(again)[filled], joint_features(again)

    (low, _), (high, _), (unchecked, seen) = (radius(held_err_path=5.0),
                                              radius(held_err_path=20.0), radius())
    assert (seen["checked"][filled] == 0).all() and (seen["log_held_error"] == 0).all()
    entry = CALIBRATION["file_atoms"]
    coef = dict(zip(FEATURES["file_atoms"], entry["coef"]))
    size = features["size"][filled]
    above = low > MIN_RELATIVE * size * 1.001  # not at the floor
    assert above.sum() > 50 and (high >= low).all()
    np.testing.assert_allclose(high[above] / low[above], 4.0 ** coef["log_held_error"])
    rule = entry["unchecked"]
    x = np.stack([seen[f][filled] for f in UNCHECKED_FEATURES["file_atoms"]], axis=-1)
    own = size * np.exp(x @ np.asarray(rule["coef"])) * rule["conformal"]
    at = own > MIN_RELATIVE * size * 1.001
    assert at.sum() > 50
    np.testing.assert_allclose(unchecked[at], own[at])


def test_averaged_codes_of_the_files_poses_take_the_file_atoms_rule():
    """The default path's mean of three codes of the file's own poses is rated as the
    file's poses as atoms, not as the base dictionary."""
    from dataclasses import replace
    from types import SimpleNamespace

    from sparseedm.adaptation import AVERAGED_PATH, AdaptationResult
    from sparseedm.dictionary import load_dictionary

    base = load_dictionary()

    def way(path, **settings):  # an AdaptationResult whose path is `path`
        own = replace(base, provenance={"file_dictionary": {}})
        res = AdaptationResult(dictionary=own if path == "file atoms" else base,
                               adapted=path == "adapted", reason="",
                               settings=dict(settings, path=path))
        assert res.path == path
        return coding_way(SimpleNamespace(adaptation=res))

    assert way(AVERAGED_PATH) == "file_atoms"
    assert way("file atoms") == "file_atoms"
    assert way("file atoms", preset="fast") == "local_ridge"
    assert way("adapted") == "adapted"


@pytest.mark.parametrize("preset,way", [("default", "file_atoms"), ("fast", "local_ridge")])
def test_a_path_over_the_files_own_poses_covers_real_people(shared_data, preset, way):
    """Bonn PoseTrack validation frames as photos (half the complete poses kept, the
    other half under real missing patterns; masks the calibration did not see): the
    path over the file's own poses holds 85-95 % of the hidden joints."""
    from benchmarks import real2d
    from sparseedm.real_protocol import transplant_masks

    if not real2d.available(shared_data / "real2d"):
        pytest.skip(f"no {shared_data / 'real2d'}")
    rs = real2d.load("bonn", shared_data / "real2d")
    val = real2d.split(rs) == "val"
    rows = np.flatnonzero(rs.complete & val & (real2d.body_size(rs.poses) > 0))
    rng = np.random.default_rng([100, 3])
    order = rng.permutation(rows)
    c = len(order) - len(order) // 2
    truth = rs.poses[order]
    mask = np.zeros(truth.shape[:2], bool)
    mask[c:] = transplant_masks(len(order) - c, ~rs.visible[val & ~rs.complete],
                                random_state=rng)[0]
    res = sparseedm.recover(np.where(mask[..., None], np.nan, truth), preset=preset)
    assert coding_way(res) == way
    hidden = mask & res.ok[:, None]
    covered = (np.linalg.norm(res.poses - truth, axis=-1)[hidden] <= res.uncertainty[hidden])
    assert hidden.sum() > 1000 and 0.85 <= covered.mean() <= 0.95, covered.mean()


def test_the_adapted_rule_reads_the_guards_error(cmu_poses, small_dictionary):
    """The adapted path's rule reads the error its guard measured on the file's
    held-back poses: a dictionary measured to err more gets wider circles (by that
    error's ratio to the power of its coefficient); without a guard's error, the
    way's unchecked rule."""
    from dataclasses import replace

    from sparseedm.uncertainty import (CALIBRATION, FEATURES, MIN_RELATIVE,
                                       UNCHECKED_FEATURES)

    poses, missing = _own_poses_file(cmu_poses[:60])
    res = sparseedm.recover(poses, missing, dictionary=small_dictionary, exemplars=False,
                            self_training=0)
    assert coding_way(res) == "adapted" and np.isfinite(res.adaptation.err_adapted)
    filled = res.missing & res.ok[:, None]
    features = joint_features(res)
    assert (features["guarded"][filled] == 1).all()
    np.testing.assert_allclose(features["log_guard_error"][filled],
                               np.log(res.adaptation.err_adapted / 100))

    def radius(err):
        again = replace(res, adaptation=replace(res.adaptation, err_adapted=err))
        return joint_uncertainty(again)[filled], joint_features(again)

    (low, _), (high, _), (unguarded, seen) = radius(1.0), radius(3.0), radius(np.nan)
    assert (seen["guarded"][filled] == 0).all() and (seen["log_guard_error"] == 0).all()
    entry = CALIBRATION["adapted"]
    coef = dict(zip(FEATURES["adapted"], entry["coef"]))
    size = features["size"][filled]
    above = low > MIN_RELATIVE * size * 1.001
    assert above.sum() > 50 and (high >= low).all()
    np.testing.assert_allclose(high[above] / low[above], 3.0 ** coef["log_guard_error"])
    rule = entry["unchecked"]
    x = np.stack([seen[f][filled] for f in UNCHECKED_FEATURES["adapted"]], axis=-1)
    own = size * np.exp(x @ np.asarray(rule["coef"])) * rule["conformal"]
    at = own > MIN_RELATIVE * size * 1.001
    assert at.sum() > 50
    np.testing.assert_allclose(unguarded[at], own[at])


def test_radius_at_reads_each_ways_measured_factors():
    """radius_at: the 90 % radius at 0.9, growing with the level for every way and
    pooled, the way's own factor at each tabulated level, one way per radius."""
    from sparseedm.uncertainty import CALIBRATION, LEVELS

    fine = np.linspace(0.05, 0.995, 60)
    for way in [None, *sorted(CALIBRATION)]:
        assert radius_at(2.0, 0.9, way) == pytest.approx(2.0)
        radii = np.array([radius_at(2.0, p, way) for p in fine])
        assert (np.diff(radii) >= 0).all() and radii[0] > 0, way
        table = CALIBRATION["pooled" if way is None else way]["levels"]
        np.testing.assert_allclose([radius_at(2.0, p, way) for p in LEVELS],
                                   2.0 * np.asarray(table))
    ways = np.array([["temporal", "", "adapted"]])
    got = radius_at(np.array([[1.0, 0.0, 3.0]]), 0.5, ways)
    np.testing.assert_allclose(got, [[radius_at(1.0, 0.5, "temporal"), 0.0,
                                      radius_at(3.0, 0.5, "adapted")]])
    assert np.isnan(radius_at(np.nan, 0.5))
    for level in (0.0, 1.0, -0.5, True, "0.5"):
        with pytest.raises(sparseedm.exceptions.ParameterError, match="level"):
            radius_at(1.0, level)
    with pytest.raises(sparseedm.exceptions.ParameterError, match="way"):
        radius_at(1.0, 0.5, "kalman")


def test_radius_at_takes_the_result_the_radii_belong_to(clip_result, cmu_poses,
                                                       small_dictionary):
    """Given the result, radius_at scales each joint by its own way's factors: the
    time-filled joints of a clip by the temporal ones, a photo's by the base's."""
    from sparseedm.uncertainty import joint_ways

    res, mask = clip_result
    ways = joint_ways(res)
    assert set(np.unique(ways[mask])) <= {"temporal", "per_frame"} and (ways[~mask] == "").all()
    np.testing.assert_allclose(radius_at(res.uncertainty, 0.5, res),
                               radius_at(res.uncertainty, 0.5, ways))
    poses = cmu_poses[:4].copy()
    poses[:, WRIST] = np.nan
    photo = sparseedm.recover(poses, dictionary=small_dictionary, adapt=False)
    np.testing.assert_allclose(radius_at(photo.uncertainty, 0.7, photo),
                               radius_at(photo.uncertainty, 0.7, "per_frame"))


def test_radius_at_and_likelihood():
    assert radius_at(2.0, 0.9) == pytest.approx(2.0)
    assert radius_at(2.0, 0.99) > 2.0 > radius_at(2.0, 0.5)
    pose = np.array([[[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]]])
    like = filled_likelihood(pose, np.array([[0.0, 5.0, np.nan]]), 0.01)
    assert like[0, 0] == FILLED_LIKELIHOOD_CAP and 0.01 < like[0, 1] < like[0, 0]
    assert like[0, 2] == 0.01


@pytest.mark.parametrize("name,fmt", [("out.npz", None), ("out.csv", None),
                                      ("out.json", None), ("out.json", "mmpose"),
                                      ("frames", "openpose")])
def test_round_trip_through_writer_and_reader(tmp_path, name, fmt, cmu_poses):
    rng = np.random.default_rng(2)
    poses = cmu_poses[:5].copy()
    radii = np.zeros((5, 14))
    radii[:, [4, 7]] = rng.uniform(1.0, 30.0, (5, 2))
    radii[3] = np.nan  # a refused pose
    path = write_keypoints(tmp_path / name, poses, uncertainty=radii, format=fmt)
    kps = read_keypoints(path, format=fmt)
    np.testing.assert_allclose(kps.uncertainty, radii, equal_nan=True)


def test_writer_refuses_a_negative_radius(tmp_path, cmu_poses):
    with pytest.raises(sparseedm.exceptions.FileFormatError, match="uncertainty"):
        write_keypoints(tmp_path / "out.npz", cmu_poses[:2], uncertainty=-np.ones((2, 14)))


def test_coco_field_lists_the_joints_by_name(tmp_path, cmu_poses):
    radii = np.zeros((1, 14))
    radii[0, WRIST] = 12.5
    path = write_keypoints(tmp_path / "out.json", cmu_poses[:1], uncertainty=radii)
    with open(path) as f:
        doc = json.load(f)
    assert doc[0]["sparseedm"]["uncertainty"] == {
        name: (12.5 if name == "right_wrist" else 0.0) for name in JOINT_NAMES}


@pytest.mark.parametrize("ext,fmt", [("npz", None), ("csv", None), ("json", None),
                                     ("npy", None), ("", "openpose"), ("json", "mmpose"),
                                     ("csv", "dlc")])
def test_recover_file_writes_what_reads_back(tmp_path, ext, fmt, cmu_poses,
                                             small_dictionary_path):
    from sparseedm.batch import recover_file

    poses = cmu_poses[:8].copy()
    poses[::2, WRIST] = np.nan
    src = write_keypoints(tmp_path / "in.npz", poses)
    out = tmp_path / (f"out.{ext}" if ext else "out")  # OpenPose: a folder of frames
    recover_file(src, out, dictionary=small_dictionary_path, adapt=False, output_format=fmt)
    kps = read_keypoints(out, format=fmt)
    assert kps.uncertainty is not None
    assert (kps.uncertainty[::2, WRIST] > 0).all()
    assert (kps.uncertainty[1::2] == 0).all()


def test_deeplabcut_output_keeps_its_layout_with_a_likelihood(tmp_path, cmu_poses,
                                                              small_dictionary_path):
    from sparseedm.batch import recover_file

    poses = cmu_poses[:6].copy()
    poses[::2, WRIST] = np.nan
    src = write_keypoints(tmp_path / "in.npz", poses)
    out = tmp_path / "out.csv"
    recover_file(src, out, dictionary=small_dictionary_path, adapt=False,
                 output_format="dlc")
    kps = read_keypoints(out, format="dlc")
    assert (kps.uncertainty[::2, WRIST] > 0).all()  # from the status sidecar
    like = kps.confidence[::2, WRIST]
    assert ((0 < like) & (like <= FILLED_LIKELIHOOD_CAP)).all()
    expected = filled_likelihood(kps.poses, kps.uncertainty)[::2, WRIST]
    np.testing.assert_allclose(like, expected)
