"""recover(adapt=False) without a dictionary: its codes stacked with the shipped pose bank's
local Gaussian (sparseedm.cold_bank)."""

import numpy as np
import pytest

import sparseedm
from sparseedm.cold_bank import (AVERAGED_BANK, COLD_BANK_WEIGHTS, bank_fill, cold_bank_stack,
                                 load_pose_bank)
from sparseedm.dictionary import available_dictionaries
from sparseedm.exceptions import DictionaryError
from sparseedm.metrics import occlusion_masks


def pixel_file(cmu_poses, n, seed=0):
    """n fixture poses about 200 px tall, 1-3 joints hidden (NaN), and the mask."""
    p = cmu_poses[:n]
    lo, hi = p.min(axis=1, keepdims=True), p.max(axis=1, keepdims=True)
    poses = (p - lo) / (hi - lo).max(axis=2, keepdims=True) * 200 + [220.0, 140.0]
    missing = occlusion_masks(n, 14, ("mix",), seed)["mix"]
    return poses, missing


def test_the_shipped_bank_is_finite_poses_and_no_dictionary():
    bank = load_pose_bank()
    assert bank.poses.shape[1:] == (14, 2) and np.isfinite(bank.poses).all()
    assert 500 <= bank.photographed.sum() < len(bank.poses)  # COCO's people, then CMU's
    assert "cold-bank" not in available_dictionaries()
    with pytest.raises(ValueError):
        bank.poses[0, 0, 0] = 1.0  # shared by every call: read-only


def test_cold_recovery_is_the_codes_stacked_with_the_bank(cmu_poses):
    truth, missing = pixel_file(cmu_poses, 16)
    given = np.where(missing[..., None], np.nan, truth)
    cold = sparseedm.recover(given, missing, adapt=False)
    codes = sparseedm.recover(given, missing, adapt=False, dictionary="cmu-coco-k2932",
                              mirror="auto")
    w = np.asarray(COLD_BANK_WEIGHTS)[missing.sum(axis=1)][:, None, None]
    expected = (1 - w) * codes.poses + w * bank_fill(load_pose_bank(), given, missing)
    assert np.allclose(cold.poses, expected, atol=1e-9)
    assert np.array_equal(cold.poses[~missing], truth[~missing])
    assert not np.allclose(cold.poses[missing], codes.poses[missing], atol=1e-3)
    assert (cold.averaged == AVERAGED_BANK).all() and codes.averaged is None
    assert (cold.spread[missing] > 0).any() and np.isfinite(cold.uncertainty[missing]).all()
    # a dictionary given (even the cold prior's own): its codes alone
    assert sparseedm.recover(given, missing, adapt=False, dictionary="default").averaged is None


def test_a_file_turned_in_the_image_gets_the_banks_joints_turned(cmu_poses):
    truth, missing = pixel_file(cmu_poses, 30, seed=2)
    given = np.where(missing[..., None], np.nan, truth)
    c, s = np.cos(2.0), np.sin(2.0)
    turn = np.array([[c, -s], [s, c]])
    bank = load_pose_bank()
    plain, turned = bank_fill(bank, given, missing), bank_fill(bank, given @ turn.T, missing)
    assert np.allclose(turned, plain @ turn.T, atol=1e-6)
    # the bank left upright would fill the turned file with upright people's joints
    from sparseedm.gaussian_fill import local_gaussian_fill

    upright = local_gaussian_fill(bank.poses, given @ turn.T, missing)
    assert np.abs(upright - turned)[missing].max() > 1.0


def test_a_bank_file_that_is_not_one_is_refused(tmp_path):
    bad = tmp_path / "no-poses.npz"
    np.savez(bad, joint_names=np.array(["a"] * 14))
    with pytest.raises(DictionaryError, match="no 'poses'"):
        load_pose_bank(str(bad))
    nan = tmp_path / "nan.npz"
    poses = np.zeros((3, 14, 2))
    poses[1, 2, 0] = np.nan
    np.savez(nan, poses=poses, photographed=np.ones(3, bool), joint_names=np.array(["a"] * 14))
    with pytest.raises(DictionaryError, match="finite"):
        load_pose_bank(str(nan))
    flags = tmp_path / "flags.npz"
    np.savez(flags, poses=np.ones((3, 14, 2)), photographed=np.ones(2, bool),
             joint_names=np.array(["a"] * 14))
    with pytest.raises(DictionaryError, match="one per pose"):
        load_pose_bank(str(flags))


def test_the_gate_takes_the_photographed_people_for_a_pose_near_them(cmu_poses):
    """A photographed pose filled alone: its Gaussian from the photographed
    poses (gate inf) and from the whole bank (gate 0) differ; the default
    gate takes the first for it, and the whole bank for a motion-capture pose."""
    bank = load_pose_bank()
    photo = bank.poses[np.flatnonzero(bank.photographed)[5]][None] * 100 + 300
    mocap = pixel_file(cmu_poses, 1)[0]
    missing = np.zeros((1, 14), bool)
    missing[0, [4, 12]] = True
    for pose, alone in ((photo, np.inf), (mocap, 0.0)):
        ends = [bank_fill(bank, pose, missing, gate=g) for g in (0.0, np.inf)]
        assert not np.allclose(ends[0], ends[1])
        assert np.allclose(bank_fill(bank, pose, missing), bank_fill(
            bank, pose, missing, gate=alone))


def test_gated_fill_is_the_gate_then_the_local_fill_with_distances_computed_once(
        cmu_poses, monkeypatch):
    """gated_local_fill gives what the gate (nearest_distances) followed by
    local_gaussian_fill over each row's part gives, the distances to the draws
    computed once per missing pattern (the two steps computed them apart)."""
    import sparseedm.gaussian_fill as gf

    rng = np.random.default_rng(0)
    draws = cmu_poses
    parts = rng.random(len(draws)) < 0.4
    poses, missing = pixel_file(cmu_poses[::-1], 60, seed=1)
    missing[:2] = False                      # complete: as given
    missing[2, 2:] = True                    # two observed joints: a frame still
    missing[3, 1:] = True                    # one observed joint: no frame, NaN
    given = np.where(missing[..., None], np.nan, poses)
    patterns = {tuple(m) for m in missing if m.any() and (~m).sum() >= 2}
    calls = {"n": 0}
    counted = gf._square_distances

    def counting(*args, **kwargs):
        calls["n"] += 1
        return counted(*args, **kwargs)

    monkeypatch.setattr(gf, "_square_distances", counting)
    split = []
    for gate in (0.0, 1.2, np.inf):
        calls["n"] = 0
        got = gf.gated_local_fill(draws, given, missing, parts, gate, 20, neighbours=30)
        assert calls["n"] == len(patterns)
        with np.errstate(invalid="ignore"):
            dist = gf.nearest_distances(draws, given, missing, 20, parts)
            inside = dist[:, 0] < gate * dist[:, 1]
        want = np.array(given)
        for rows, pool in ((inside, draws[parts]), (~inside, draws)):
            want[rows] = gf.local_gaussian_fill(pool, given[rows], missing[rows],
                                                neighbours=30, reselect=0.0)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
        assert np.isnan(got[3, 1:]).all() and np.array_equal(got[:2], poses[:2])
        split.append(int(inside.sum()))
    assert split[0] == 0 and 0 < split[1] < split[2]  # gate 1.2: rows on both sides


def test_the_bank_lowers_the_cold_error_on_coco_validation_people(shared_data):
    """COCO's validation poses are in neither the bank nor the cold dictionary."""
    from benchmarks import real2d

    if not real2d.available(shared_data / "real2d"):
        pytest.skip(f"no {shared_data / 'real2d'}")
    rs = real2d.load("coco", shared_data / "real2d")
    rows = np.flatnonzero(rs.complete & (real2d.split(rs) == "val")
                          & (real2d.body_size(rs.poses) > 0))
    truth = rs.poses[rows]
    rng = np.random.default_rng(0)
    missing = np.zeros((len(truth), 14), bool)
    for row in missing:
        row[rng.choice(14, 2, replace=False)] = True
    given = np.where(missing[..., None], np.nan, truth)
    size = real2d.body_size(truth)[:, None]

    def error(filled):
        return (np.linalg.norm(filled - truth, axis=-1) / size)[missing].mean()

    codes = sparseedm.recover(given, missing, adapt=False, dictionary="cmu-coco-k2932",
                              mirror="auto")
    cold = cold_bank_stack(codes, given, missing)
    assert error(cold.poses) < 0.95 * error(codes.poses)


def _bank_people(n_complete, n_occluded, seed=0):
    """A file of the bank's photographed people (1 % of their size of noise,
    about 200 px tall), the first n_complete whole, the others with 1-3 joints
    hidden: (given, missing, truth)."""
    from sparseedm.adaptation import guard_masks

    bank = load_pose_bank()
    rng = np.random.default_rng(seed)
    rows = rng.choice(np.flatnonzero(bank.photographed), n_complete + n_occluded, replace=False)
    truth = bank.poses[rows] * 100 + [300.0, 200.0]
    truth = truth + rng.normal(0, 1.0, truth.shape)
    missing = np.zeros(truth.shape[:2], bool)
    missing[n_complete:] = guard_masks(n_occluded, 14, random_state=seed)
    return np.where(missing[..., None], np.nan, truth), missing, truth


def _template_people(n_complete, n_occluded, seed=0):
    """A file of one non-human template of 14 points, each scaled, shifted and
    deformed along one fixed direction: no people of the bank."""
    from sparseedm.adaptation import guard_masks

    rng = np.random.default_rng(seed)
    n = n_complete + n_occluded
    template, direction = rng.normal(0, 30, (14, 2)), rng.normal(0, 10, (14, 2))
    truth = ((template + rng.normal(size=(n, 1, 1)) * direction)
             * rng.uniform(0.5, 2, (n, 1, 1)) + rng.uniform(-100, 100, (n, 1, 2)))
    missing = np.zeros(truth.shape[:2], bool)
    missing[n_complete:] = guard_masks(n_occluded, 14, random_state=seed)
    return np.where(missing[..., None], np.nan, truth), missing, truth


def _without_bank_step(monkeypatch):
    import sparseedm.batch
    import sparseedm.recovery

    for module in (sparseedm.recovery, sparseedm.batch):
        monkeypatch.setattr(module, "bank_step", lambda res, p, m, answer: (res, answer))


def test_probe_weight_goes_to_a_right_candidate_and_not_to_a_wrong_one():
    """exemplars.probe_weight (the bank step's choice): a candidate that answers the
    probes exactly gets the largest weight, one that answers them far off none."""
    from types import SimpleNamespace

    from sparseedm.exemplars import LINEAR_WEIGHTS, probe_weight

    _, missing, truth = _template_people(0, 200, seed=3)
    rng = np.random.default_rng(0)
    given = np.where(missing[..., None], np.nan, truth)

    def answer(p, m):  # the path: the truth off by a few pixels
        return SimpleNamespace(poses=np.where(m[..., None], truth[rows] + rng.normal(
            0, 5, p.shape), p))

    def exact(r, j, p, m):
        return truth[r]

    def wrong(r, j, p, m):
        return truth[r] + rng.normal(0, 50, p.shape)

    seen = []

    def spy(r, j, p, m):
        seen.append(r)
        return exact(r, j, p, m)

    from sparseedm.donors import DONOR_PROBES, probes

    drawn = [probes(missing, 0)[0]]  # rounds until DONOR_PROBES probes
    while sum(map(len, drawn)) < DONOR_PROBES:
        drawn.append(probes(missing, len(drawn))[0])
    rows = np.concatenate(drawn)
    right = probe_weight(given, missing, answer, exact)
    assert right.weight == LINEAR_WEIGHTS[-1] and right.probes == len(rows)
    assert right.err_chosen < right.err_default
    assert probe_weight(given, missing, answer, wrong).weight == 0
    probe_weight(given, missing, answer, spy)
    assert np.array_equal(seen[0], rows)  # the candidate answers the probed rows


def test_probe_weight_probes_a_small_file_several_times_per_row(monkeypatch):
    """With donors.PROBES_PER_ROW above one, a file of few occluded rows gets
    that many probes per row (another joint each) in one draw, and the choice
    records how many."""
    from types import SimpleNamespace

    import sparseedm.donors as dn
    import sparseedm.exemplars as ex

    given, missing, truth = _template_people(0, 40, seed=3)

    def answer(p, m):  # the path: the hidden joints far off
        return SimpleNamespace(poses=np.where(m[..., None], truth[rows] + 40, p))

    def exact(r, j, p, m):
        return truth[r]

    rows = dn.probes(missing, 0, per_row=1)[0]
    n_rows = len(rows)
    assert 0 < n_rows < dn.DONOR_PROBES
    monkeypatch.setattr(ex, "LINEAR_PROBE_ROUNDS", 1)
    assert ex.probe_weight(given, missing, answer, exact).probes == n_rows
    monkeypatch.setattr(dn, "PROBES_PER_ROW", 4)
    rows = dn.probes(missing, 0)[0]
    choice = ex.probe_weight(given, missing, answer, exact)
    assert choice.probes == len(rows) == 4 * n_rows
    assert choice.weight == ex.LINEAR_WEIGHTS[-1] and choice.err_chosen < choice.err_default


def test_the_bank_step_weights_the_bank_where_the_file_is_its_people(small_dictionary,
                                                                     monkeypatch, tmp_path):
    """Few complete poses of the bank's own people: the probes give the bank weight,
    recorded in the settings like the donor step's; the occluded poses' answers err
    less than without the step and say AVERAGED_BANK; recover_file's chunks take
    it as recover() does."""
    from sparseedm.batch import recover_file
    from sparseedm.exemplars import LINEAR_WEIGHTS
    from sparseedm.keypoints import KeypointSet, write_keypoints

    given, missing, truth = _bank_people(20, 150)
    res = sparseedm.recover(given, missing, dictionary=small_dictionary)
    record = res.adaptation.settings["bank"]
    assert record["weight"] in LINEAR_WEIGHTS and record["weight"] > 0
    assert record["probes"] >= 30 and record["probe_err_chosen"] < record["probe_err_default"]
    assert res.summary()["adaptation"]["bank"] == record
    occ = np.flatnonzero(missing.any(axis=1) & res.ok)
    assert all(AVERAGED_BANK in a for a in res.averaged[occ])
    src = write_keypoints(tmp_path / "in.npz", KeypointSet(given, missing))
    recover_file(src, tmp_path / "out.npz", dictionary=small_dictionary)
    with np.load(tmp_path / "out.npz") as out:
        np.testing.assert_allclose(out["poses"][res.ok], res.poses[res.ok], rtol=0, atol=1e-6)
    _without_bank_step(monkeypatch)
    path = sparseedm.recover(given, missing, dictionary=small_dictionary)
    assert "bank" not in path.adaptation.settings

    def err(p):
        return np.linalg.norm(p - truth[occ], axis=-1)[missing[occ]].mean()

    assert err(res.poses[occ]) < err(path.poses[occ])


def test_the_bank_step_gives_no_weight_where_the_bank_is_wrong(small_dictionary,
                                                               monkeypatch):
    """A file of one non-human shape: the bank's people answer its probes worse
    than the path, so the weight is 0 and the answers are the path's."""
    given, missing, _ = _template_people(30, 200)
    res = sparseedm.recover(given, missing, dictionary=small_dictionary)
    record = res.adaptation.settings["bank"]
    assert record["weight"] == 0 and record["probes"] >= 30
    assert not any(AVERAGED_BANK in a for a in res.averaged)
    _without_bank_step(monkeypatch)
    path = sparseedm.recover(given, missing, dictionary=small_dictionary)
    np.testing.assert_array_equal(res.poses, path.poses)


def test_the_bank_step_is_skipped_on_files_of_many_complete_poses(small_dictionary,
                                                                  monkeypatch):
    """From BANK_STEP_MAX_COMPLETE complete poses the step runs no probe: it says
    why, and the answers are the path's."""
    import sparseedm.cold_bank as cold_bank

    given, missing, _ = _bank_people(20, 150)
    monkeypatch.setattr(cold_bank, "BANK_STEP_MAX_COMPLETE", 20)
    res = sparseedm.recover(given, missing, dictionary=small_dictionary)
    record = res.adaptation.settings["bank"]
    assert record["weight"] == 0 and record["probes"] == 0
    assert record["skipped"] == "20 complete poses, at least 20"
    _without_bank_step(monkeypatch)
    path = sparseedm.recover(given, missing, dictionary=small_dictionary)
    np.testing.assert_array_equal(res.poses, path.poses)
