"""The carried prior: a joint hidden in a run placed from its own observed frames
by its nearest observed neighbours (``TemporalSettings.carry``), and the probes
that keep it or the per-frame answers."""

from dataclasses import replace

import numpy as np

from sparseedm.skeleton import SKELETON_14, skeleton_hops
from sparseedm.temporal.carried import carried_prior
from sparseedm.temporal.model import (DEFAULT_SETTINGS, carries, choose_carry, fill_segment,
                                      probe_errors, probe_mask, still_runs)
from sparseedm.temporal.recover import recover_temporal

WRIST, ELBOW = 4, 3
OFF = replace(DEFAULT_SETTINGS, carry=0.0)


def _height(poses):
    return np.ptp(poses[..., 1], axis=1).mean()


def _noisy(track, share=0.005, seed=0):
    rng = np.random.default_rng(seed)
    return track + rng.normal(scale=share * _height(track), size=track.shape)


def _wrist_hidden(track, start=100, stop=160):
    free = np.zeros(track.shape[:2], bool)
    free[start:stop, WRIST] = True
    return free


def _error(out, truth, free):
    return np.linalg.norm(out - truth, axis=-1)[free].mean()


def test_hops_of_the_14_joint_skeleton():
    hops = skeleton_hops(SKELETON_14.parents)
    assert hops[WRIST, ELBOW] == 1 and hops[WRIST, WRIST] == 0
    assert (hops == hops.T).all() and hops.max() < 14


def test_a_hidden_wrist_is_carried_by_its_elbow(track):
    """Where the elbow moves, the carried wrist moves with it (not held where
    it was last seen)."""
    free = _wrist_hidden(track)
    values = np.where(free[..., None], 0.0, track)
    out = carried_prior(values, free, SKELETON_14.parents, 3.0)
    assert np.isfinite(out[free]).all() and np.isnan(out[~free]).all()
    held = np.where(np.arange(len(track))[:, None] < 130, track[99, WRIST], track[160, WRIST])
    assert _error(out, track, free) < 0.5 * np.linalg.norm(held - track[:, WRIST], axis=-1)[
        free[:, WRIST]].mean()


def test_a_joint_never_observed_is_not_carried(track):
    free = np.zeros(track.shape[:2], bool)
    free[:, WRIST] = True
    out = carried_prior(np.where(free[..., None], 0.0, track), free, SKELETON_14.parents, 3.0)
    assert np.isnan(out).all()


def test_noisy_keypoints_take_the_carried_prior_over_a_wrong_answer(track):
    noisy = _noisy(track)
    free = _wrist_hidden(track)
    values = np.where(free[..., None], 0.0, noisy)
    wrong = track + 0.2 * _height(track)
    confidence = np.ones(len(track))
    assert carries(values, free)
    out = fill_segment(values, free, wrong, confidence)[0]
    answers = fill_segment(values, free, wrong, confidence, OFF)[0]
    assert _error(out, track, free) < 0.5 * _error(answers, track, free)


def test_clean_keypoints_keep_the_per_frame_answers(track):
    free = _wrist_hidden(track)
    values = np.where(free[..., None], 0.0, track)
    wrong = track + 0.2 * _height(track)
    assert not carries(values, free)
    np.testing.assert_array_equal(fill_segment(values, free, wrong, np.ones(len(track)))[0],
                                  fill_segment(values, free, wrong, np.ones(len(track)), OFF)[0])


def test_the_probes_measure_both_priors(track):
    """A wrong per-frame answer loses to the carried placement at the probes; the
    exact answer wins."""
    noisy = _noisy(track)
    free = _wrist_hidden(track)
    values = np.where(free[..., None], 0.0, noisy)
    probe = probe_mask(values, free)
    assert probe.any()
    confidence = np.ones(len(track))
    wrong = probe_errors(values, free, probe, track + 0.2 * _height(track), confidence)
    right = probe_errors(values, free, probe, track.copy(), confidence)
    assert choose_carry(wrong.answers_distance, wrong.carried_distance) is True
    assert choose_carry(right.answers_distance, right.carried_distance) is False
    off = probe_errors(values, free, probe, track.copy(), confidence, OFF)
    assert off.carried_distance == 0
    assert choose_carry(off.answers_distance, off.carried_distance) is None


def test_recover_temporal_keeps_what_the_probes_chose(track):
    """A segment whose probes prefer the per-frame answers is filled as with
    ``carry=0``; the carried prior would have filled it otherwise."""
    noisy = _noisy(track, 0.004)
    free = _wrist_hidden(track)
    free[100:160, 7] = True  # the other wrist too
    given = np.where(free[..., None], np.nan, noisy)
    frames = np.arange(len(track))
    res = recover_temporal(given, free, frames=frames, adapt=False)
    off = recover_temporal(given, free, frames=frames, adapt=False, settings=OFF)
    carried = recover_temporal(given, free, frames=frames, adapt=False,
                               settings=replace(DEFAULT_SETTINGS, probe=False))
    assert not np.allclose(carried.poses, off.poses)
    np.testing.assert_allclose(res.poses, off.poses)


def test_carry_floor_weighs_the_carried_wrist_from_its_first_hidden_frame(track):
    """Between noisy keypoints a wrist hidden for 4 frames at a time, its elbow
    seen: with ``carry_floor`` the placement the elbow carries weighs from the
    first hidden frame where the wrist moves (the ramp alone gives it none so
    close to an observation) and moves the fill there; a joint never seen
    keeps the ramp, and clean keypoints (never carried) are filled as
    without it."""
    noisy = _noisy(track, 0.01)
    free = np.zeros(track.shape[:2], bool)
    for start in range(20, 220, 12):
        free[start:start + 4, WRIST] = True
    free[:, 7] = True                                  # the other wrist, never seen
    values = np.where(free[..., None], 0.0, noisy)
    prior, confidence = np.full(track.shape, np.nan), np.zeros(len(track))
    prior[:, 7], confidence[:] = track[:, 7], 1.0       # a per-frame answer for it
    floor = replace(DEFAULT_SETTINGS, carry_floor=0.5)
    out, weight = fill_segment(values, free, prior, confidence, floor)[:2]
    base, weight0 = fill_segment(values, free, prior, confidence)[:2]
    moving = free[:, WRIST] & ~still_runs(values, free)[:, WRIST]   # still runs: time alone
    assert moving.sum() > 40 and (weight[moving, WRIST] >= 0.5).all()
    assert not weight0[:, WRIST].any()
    np.testing.assert_array_equal(weight[:, 7], weight0[:, 7])
    assert (np.abs(out[moving, WRIST] - base[moving, WRIST]).max(axis=-1) > 0).all()
    np.testing.assert_array_equal(out[~free], base[~free])
    clean = np.where(free[..., None], 0.0, track)
    np.testing.assert_array_equal(fill_segment(clean, free, prior, confidence, floor)[0],
                                  fill_segment(clean, free, prior, confidence)[0])
