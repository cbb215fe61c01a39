"""The donor step: hidden joints from the file's other rows that show them, when probes say so."""

import json
from dataclasses import replace

import numpy as np
import pytest

import sparseedm
from sparseedm.donors import (DONOR_MIN_PROBES, DONOR_MIN_SHARED, DONOR_PROBES,
                              IN_PLACE_MIN_SHARED, donor_estimates, donor_step,
                              in_place_estimates, probe_rounds, probes)
from sparseedm.real_protocol import body_size


def _turned(poses, rng):
    """Each pose rotated, scaled and moved at random (the same body)."""
    th = rng.uniform(-0.3, 0.3, len(poses))
    rot = np.stack([np.stack([np.cos(th), -np.sin(th)], -1),
                    np.stack([np.sin(th), np.cos(th)], -1)], -2)
    scale = rng.uniform(0.8, 1.2, len(poses))[:, None, None]
    return scale * np.einsum("nij,nkj->nki", rot, poses) + rng.normal(0, 50, (len(poses), 1, 2))


def _twins(cmu_poses, n_complete=120, n_pairs=80, seed=0):
    """(truth, missing): complete poses, then pairs of occluded rows of one pose
    (the second turned), each pair hiding different joints."""
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(cmu_poses))
    complete = cmu_poses[order[:n_complete]]
    body = cmu_poses[order[n_complete:n_complete + n_pairs]]
    truth = np.concatenate([complete, body, _turned(body, rng)])
    missing = np.zeros(truth.shape[:2], bool)
    for i in range(n_pairs):
        a, b = rng.choice(14, 2, replace=False)
        missing[n_complete + i, a] = True
        missing[n_complete + n_pairs + i, b] = True
    return truth, missing


def _hidden_error(filled, truth, missing):
    err = np.linalg.norm(filled - truth, axis=-1) / body_size(truth)[:, None] * 100
    return float(err[missing].mean())


def test_twin_rows_give_back_hidden_joints(cmu_poses, monkeypatch):
    truth, missing = _twins(cmu_poses)
    given = np.where(missing[..., None], np.nan, truth)
    res = sparseedm.recover(given, missing)
    donors = res.adaptation.settings["donors"]
    assert donors["weight"] > 0
    assert donors["probe_err_chosen"] < donors["probe_err_default"]
    assert res.summary()["adaptation"]["donors"] == donors  # JSON-able: no inf gate
    json.dumps(donors, allow_nan=False)
    monkeypatch.setattr(sparseedm.exemplars, "donor_step", lambda res, *a: res)
    alone = sparseedm.recover(given, missing)
    assert "donors" not in alone.adaptation.settings
    assert _hidden_error(res.poses, truth, missing) < 0.6 * _hidden_error(alone.poses, truth,
                                                                          missing)
    # the observed joints stay as given
    assert np.array_equal(res.poses[~missing], truth[~missing])


def test_exact_default_is_kept(cmu_poses):
    """Where the default answer is exact, no donor can lower the probes' error:
    the result is the default's, with the choice recorded."""
    rng = np.random.default_rng(1)
    poses = cmu_poses[rng.permutation(len(cmu_poses))[:200]]
    missing = np.zeros(poses.shape[:2], bool)
    missing[100:] = sparseedm.metrics.occlusion_masks(100, 14, ("mix",), 0)["mix"]
    given = np.where(missing[..., None], np.nan, poses)
    res = replace(sparseedm.recover(given, missing), poses=poses.copy())

    def exact(p, m):
        rows = [int(np.flatnonzero((np.isnan(r) | (poses == r)).all(axis=(1, 2)))[0])
                for r in p]
        return replace(res.take(rows), poses=poses[rows])

    out = donor_step(res, given, missing, exact)
    assert out.adaptation.settings["donors"]["weight"] == 0
    assert np.array_equal(out.poses, poses)


def test_too_few_probes_do_nothing(cmu_poses):
    poses = cmu_poses[:DONOR_MIN_PROBES + 10]
    missing = np.zeros(poses.shape[:2], bool)
    missing[:DONOR_MIN_PROBES - 1, 3] = True
    given = np.where(missing[..., None], np.nan, poses)
    res = sparseedm.recover(given, missing)
    assert res.adaptation is not None

    def never(p, m):
        raise AssertionError("no probes expected")

    assert donor_step(res, given, missing, never) is res


def test_donors_need_shared_joints():
    """A row sharing fewer than DONOR_MIN_SHARED observed joints gives no estimate."""
    rng = np.random.default_rng(2)
    poses = rng.normal(size=(2, 14, 2))
    missing = np.zeros((2, 14), bool)
    missing[0, 0] = True
    missing[1, 1:15 - DONOR_MIN_SHARED] = True  # row 1 shares DONOR_MIN_SHARED - 1
    given = np.where(missing[..., None], np.nan, poses)
    est, near = donor_estimates(given, missing, np.array([0]), np.nan_to_num(given))
    assert np.isnan(est[0, 0]).all() and np.isinf(near[0, 0])
    missing[1, 1] = False  # one more shared joint
    est, near = donor_estimates(np.where(missing[..., None], np.nan, poses), missing,
                                np.array([0]), poses)
    assert np.isfinite(est[0, 0]).all()


@pytest.mark.parametrize("k", [1, 3])
def test_estimates_follow_a_turned_twin(k, cmu_poses):
    rng = np.random.default_rng(3)
    body = cmu_poses[:40]
    truth = np.concatenate([body, _turned(body, rng)])
    missing = np.zeros(truth.shape[:2], bool)
    missing[np.arange(40), rng.integers(0, 14, 40)] = True
    given = np.where(missing[..., None], np.nan, truth)
    est, _ = donor_estimates(given, missing, np.arange(40), np.nan_to_num(given), k=k)
    got = est[missing[:40]]
    err = np.linalg.norm(got - truth[:40][missing[:40]], axis=-1)
    if k == 1:
        assert err.max() < 1e-6 * np.abs(truth).max()
    else:  # the twin weighs most; the others move the mean a little
        assert np.median(err) < 0.1 * body_size(truth[:40]).mean()


def test_refused_probes_are_left_out(cmu_poses):
    """Probes the default path could not answer (NaN) judge nothing; the others
    still choose the donors on a twin file."""
    truth, missing = _twins(cmu_poses)
    given = np.where(missing[..., None], np.nan, truth)
    res = sparseedm.recover(given, missing)

    def half_refused(p, m):
        out = sparseedm.recover(p, m, adapt=False)
        poses = out.poses.copy()
        poses[::2] = np.nan
        return replace(out, poses=poses)

    out = donor_step(res, given, missing, half_refused)
    donors = out.adaptation.settings["donors"]
    assert np.isfinite(donors["probe_err_default"]) and donors["weight"] > 0


def test_recover_file_takes_the_same_donors(cmu_poses, tmp_path):
    """recover_file (`sparseedm recover`), one chunk: the same answers as recover()."""
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, write_keypoints

    truth, missing = _twins(cmu_poses)
    given = np.where(missing[..., None], np.nan, truth)
    src = write_keypoints(tmp_path / "in.npz", KeypointSet(given, missing))
    recover_file(src, tmp_path / "out.npz")
    with np.load(tmp_path / "out.npz") as out:
        filed, radii = out["poses"], out["uncertainty"]
    res = sparseedm.recover(given, missing)
    assert res.adaptation.settings["donors"]["weight"] > 0
    np.testing.assert_allclose(filed[res.ok], res.poses[res.ok], rtol=0, atol=1e-6)
    # the radii rated on the moved joints, as recover()'s
    np.testing.assert_allclose(radii[res.ok], res.uncertainty[res.ok], rtol=1e-6, atol=1e-6)


def test_a_file_longer_than_a_block_takes_its_donors_block_by_block(cmu_poses, monkeypatch):
    """Above `block` rows each block of consecutive rows is its own donor step
    (its own probes and donors), so the search stays linear in the file's rows."""
    truth, missing = _twins(cmu_poses)
    given = np.where(missing[..., None], np.nan, truth)
    monkeypatch.setattr(sparseedm.exemplars, "donor_step", lambda res, *a: res)
    res = sparseedm.recover(given, missing)
    order = np.concatenate([np.arange(120), np.stack([np.arange(120, 200),
                                                      np.arange(200, 280)], 1).ravel()])
    res, given, missing = res.take(order), given[order], missing[order]

    def answer(p, m):
        return sparseedm.recover(p, m, adapt=False, dictionary="default")

    half = len(given) // 2
    whole = donor_step(res, given, missing, answer, block=half)
    for rows in (np.arange(half), np.arange(half, len(given))):
        alone = donor_step(res.take(rows), given[rows], missing[rows], answer)
        np.testing.assert_array_equal(whole.poses[rows], alone.poses)
    assert not np.array_equal(whole.poses, donor_step(res, given, missing, answer).poses)


def test_probes_out_of_range_judge_nothing(cmu_poses):
    """Rows with a joint at 1e300 (a detector's garbage kept by its score) give
    probes whose errors overflow: they judge nothing, and the choice is the one
    the file makes without them (an infinite default error let any donor
    weight win)."""
    rng = np.random.default_rng(3)
    truth = cmu_poses[:200] * 200 / np.ptp(cmu_poses[:200, :, 1], axis=1).mean() + 300
    missing = np.zeros(truth.shape[:2], bool)
    for i in range(0, 200, 2):
        missing[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
    garbage = truth[:10].copy()
    garbage[:, 5] = 1e300
    garbage_missing = np.zeros((10, 14), bool)
    garbage_missing[:, :2] = True
    poses = np.concatenate([truth, garbage])
    missing = np.concatenate([missing, garbage_missing])
    given = np.where(missing[..., None], np.nan, poses)
    said = sparseedm.recover(given, missing).summary()["adaptation"]["donors"]
    clean = sparseedm.recover(given[:200], missing[:200]).summary()["adaptation"]["donors"]
    assert np.isfinite(said["probe_err_default"]) and np.isfinite(said["probe_err_chosen"])
    assert (said["weight"], said["gate"]) == (clean["weight"], clean["gate"])


def test_a_small_file_can_be_probed_several_times_per_row():
    """Fewer occluded rows than DONOR_PROBES: each row probed up to `per_row`
    times, another observed joint each; with one per row (the default) as many
    probes as rows."""
    rng = np.random.default_rng(0)
    missing = np.zeros((60, 14), bool)
    missing[40:] = rng.random((20, 14)) < 0.3
    missing[40:, 0] = True
    cand = np.flatnonzero((~missing).sum(1) > DONOR_MIN_SHARED)
    cand = cand[missing[cand].any(1)]
    rows, joints = probes(missing, 0, per_row=4)
    assert len(rows) == 4 * len(cand) > len(cand)
    assert not missing[rows, joints].any()
    assert len(set(zip(rows.tolist(), joints.tolist()))) == len(rows)  # no joint twice
    rounds = probe_rounds(rows)
    for r in range(4):  # each round: every row once, ascending
        assert rows[rounds == r].tolist() == cand.tolist()
    one, one_joints = probes(missing, 0, per_row=1)
    assert one.tolist() == cand.tolist()
    assert one_joints.tolist() == joints[:len(cand)].tolist()  # the first round as before


def test_a_large_file_is_probed_once_per_row():
    missing = np.zeros((DONOR_PROBES + 50, 14), bool)
    missing[:, 3] = True
    rows, _ = probes(missing, 0, per_row=4)
    assert len(rows) == DONOR_PROBES == len(np.unique(rows))


def test_several_probes_per_row_let_a_small_file_choose_donors(cmu_poses, monkeypatch):
    """Twin rows too few for the donor step one probe per row (fewer than
    DONOR_MIN_PROBES) choose donors when probed several times per row; the
    record says how many probes."""
    truth, missing = _twins(cmu_poses, n_pairs=12)
    given = np.where(missing[..., None], np.nan, truth)
    monkeypatch.setattr(sparseedm.exemplars, "donor_step", lambda res, *a: res)
    res = sparseedm.recover(given, missing)
    n_rows = int(missing.any(1).sum())
    assert n_rows < DONOR_MIN_PROBES

    def answer(p, m):
        return sparseedm.recover(p, m, adapt=False, dictionary="default")

    assert donor_step(res, given, missing, answer) is res
    monkeypatch.setattr(sparseedm.donors, "PROBES_PER_ROW", 4)
    out = donor_step(res, given, missing, answer)
    donors = out.adaptation.settings["donors"]
    assert donors["probes"] == 4 * n_rows
    assert donors["weight"] > 0
    assert _hidden_error(out.poses, truth, missing) < _hidden_error(res.poses, truth, missing)


def _frames_showing_few(cmu_poses, same_person, seed=0):
    """(truth, missing): 100 complete poses, then 60 people seen in 4 frames
    each at one place in the image (or, without `same_person`, 240 people
    once each): in two of each person's frames only 4 joints are shown, the
    other two hide 1 or 2."""
    rng = np.random.default_rng(seed)
    complete = cmu_poses[:100]
    people = cmu_poses[100:160] if same_person else cmu_poses[100:340]
    place = rng.uniform(-3000, 3000, (len(people), 1, 2))
    if same_person:
        body = np.repeat(people + place, 4, axis=0)
    else:
        body = people + place
    truth = np.concatenate([complete, body + rng.normal(0, 0.3, body.shape)])
    missing = np.zeros(truth.shape[:2], bool)
    for i in range(len(body)):
        shown = 4 if i % 4 < 2 else 14 - rng.integers(1, 3)
        missing[100 + i, rng.permutation(14)[shown:]] = True
    return truth, missing


def test_in_place_donors_fill_poses_showing_few_joints(cmu_poses, monkeypatch):
    """A frame showing 4 joints has no aligned donor; the same person's other
    frames at the same place give its hidden joints back, when probes say so."""
    truth, missing = _frames_showing_few(cmu_poses, same_person=True)
    given = np.where(missing[..., None], np.nan, truth)
    res = sparseedm.recover(given, missing)
    placed = res.adaptation.settings["donors"]["in_place"]["bare"]
    assert placed["weight"] > 0 and placed["probe_err_chosen"] < placed["probe_err_default"]
    json.dumps(res.summary()["adaptation"], allow_nan=False)
    few = missing & ((~missing).sum(1) == 4)[:, None]
    monkeypatch.setattr(sparseedm.donors, "IN_PLACE_MIN_SHARED", 15)  # no donor in place
    without = sparseedm.recover(given, missing)
    assert without.adaptation.settings["donors"]["in_place"]["aligned"]["weight"] == 0
    assert _hidden_error(res.poses, truth, few) < 0.5 * _hidden_error(without.poses, truth, few)
    assert np.array_equal(res.poses[~missing], truth[~missing])


def test_in_place_donors_stay_out_of_a_file_of_strangers(cmu_poses):
    """Each person once, each at its own place: no frame is near another, and
    the probes keep the default answer."""
    truth, missing = _frames_showing_few(cmu_poses, same_person=False)
    res = sparseedm.recover(np.where(missing[..., None], np.nan, truth), missing)
    placed = res.adaptation.settings["donors"]["in_place"]
    assert placed["bare"]["weight"] == 0 and placed["aligned"]["weight"] == 0


def test_in_place_estimates_need_shared_joints():
    """Donors in place need IN_PLACE_MIN_SHARED joints observed by both rows."""
    poses = np.random.default_rng(4).normal(size=(2, 14, 2))
    missing = np.ones((2, 14), bool)
    missing[0, :IN_PLACE_MIN_SHARED] = False
    missing[1, 1:] = False  # shares IN_PLACE_MIN_SHARED - 1 joints with row 0
    given = np.where(missing[..., None], np.nan, poses)
    est, near = in_place_estimates(given, missing, np.array([0]), np.nan_to_num(given))
    assert np.isnan(est[0]).all() and np.isinf(near[0]).all()
    missing[1, 0] = False
    given = np.where(missing[..., None], np.nan, poses)
    est, _ = in_place_estimates(given, missing, np.array([0]), poses)
    assert np.allclose(est[0, IN_PLACE_MIN_SHARED:], poses[1, IN_PLACE_MIN_SHARED:])


def test_probes_within_a_range_of_shown_joints():
    missing = np.zeros((40, 14), bool)
    missing[:, :4] = True
    missing[::2, 4:10] = True  # even rows show 4 joints, odd rows 10
    rows, joints = probes(missing, 0, observed=(3, 6))
    assert len(rows) == 20 and (rows % 2 == 0).all() and not missing[rows, joints].any()
    assert (probes(missing, 0)[0] % 2 == 1).all()
