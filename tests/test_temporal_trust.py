"""The temporal model where time is the better evidence: still joints, joined
edges, and a per-frame prior a segment's own probes find wrong."""

from dataclasses import replace

import numpy as np

from sparseedm.temporal.model import (DEFAULT_SETTINGS, TRUST_LEVELS, TemporalSettings,
                                      choose_trust, clip_trust, fill_segment, free_runs,
                                      prior_scale, probe_errors, probe_mask, repeat_rate,
                                      segment_settings, still_runs)
from sparseedm.temporal.tracks import distance_to_observed

ANKLE, WRIST = 10, 4
LOWER_BODY = list(range(8, 14))


def _height(poses):
    return np.ptp(poses[..., 1], axis=1).mean()


def _resting_legs(track, start=40, stop=120):
    """The track with hips, knees and ankles held still from `start` to `stop`."""
    out = track.copy()
    out[start:stop, LOWER_BODY] = track[start, LOWER_BODY]
    return out


def _off_by(truth, share):
    """A per-frame prior `share` of the body's height away from the truth."""
    return truth + share * _height(truth), np.ones(len(truth))


def test_a_joint_still_on_both_sides_of_a_gap_comes_back_still(track):
    truth = _resting_legs(track)
    free = np.zeros(truth.shape[:2], bool)
    free[60:100, ANKLE] = True
    values = np.where(free[..., None], 0.0, truth)
    prior, confidence = _off_by(truth, 0.3)
    assert still_runs(values, free)[60:100, ANKLE].all()
    out = fill_segment(values, free, prior, confidence)[0]
    moved = np.linalg.norm(out[60:100, ANKLE] - truth[60, ANKLE], axis=-1).max()
    dragged = fill_segment(values, free, prior, confidence, TemporalSettings(still=0))[0]
    away = np.linalg.norm(dragged[60:100, ANKLE] - truth[60, ANKLE], axis=-1).max()
    height = _height(truth)
    assert moved < 0.005 * height < 0.05 * height < away, (moved, away, height)


def test_a_still_joint_between_noisy_observations_stays_at_rest(track):
    """With a detector's jitter on the observations the smoothed curve would
    carry the motion before and after the rest into the run; a still run is
    held on the line between its neighbours instead."""
    truth = _noisy(_resting_legs(track), 0.003)
    free = np.zeros(truth.shape[:2], bool)
    free[60:100, ANKLE] = True
    values = np.where(free[..., None], 0.0, truth)
    prior, confidence = _off_by(truth, 0.3)
    out = fill_segment(values, free, prior, confidence)[0]
    rest = truth[55:60, ANKLE].mean(axis=0)
    spread = np.linalg.norm(truth[60:100, ANKLE] - rest, axis=-1).max()
    moved = np.linalg.norm(out[60:100, ANKLE] - rest, axis=-1).max()
    assert moved <= spread, (moved, spread)
    ends = [np.linalg.norm(out[60, ANKLE] - truth[59, ANKLE]),
            np.linalg.norm(out[99, ANKLE] - truth[100, ANKLE])]
    assert max(ends) <= 2 * spread, (ends, spread)


def test_a_moving_joint_is_not_still(track):
    free = np.zeros(track.shape[:2], bool)
    free[60:100, WRIST] = True
    assert not still_runs(np.where(free[..., None], 0.0, track), free).any()


def _edge_jumps(filled, observed, free):
    """Distance from each run's first / last filled frame to its observed neighbour."""
    out = []
    for j, a, b in free_runs(free):
        out += [np.linalg.norm(filled[a, j] - observed[a - 1, j]),
                np.linalg.norm(filled[b - 1, j] - observed[b, j])]
    return np.array(out)


def test_filled_runs_join_noisy_observations_at_both_ends(track):
    rng = np.random.default_rng(0)
    noise = 0.01 * _height(track)
    noisy = track + rng.normal(scale=noise, size=track.shape)
    free = np.zeros(track.shape[:2], bool)
    for start in range(20, 220, 40):
        free[start:start + 15, WRIST] = True
    values = np.where(free[..., None], 0.0, noisy)
    prior, confidence = np.full_like(values, np.nan), np.zeros(len(values))
    joined = fill_segment(values, free, prior, confidence)[0]
    apart = fill_segment(values, free, prior, confidence, TemporalSettings(edge_decay=0))[0]
    # the local motion: the truth's own step between the two frames
    steps = _edge_jumps(track, track, free)
    assert (_edge_jumps(joined, noisy, free) <= steps + 1e-9 + 0.5 * noise).all()
    assert (_edge_jumps(apart, noisy, free) > steps + 0.5 * noise).any()
    np.testing.assert_array_equal(joined[~free], noisy[~free])


def _long_gaps(track):
    free = np.zeros(track.shape[:2], bool)
    free[100:140, [WRIST, 7]] = True
    return free


def test_a_wrong_prior_is_caught_by_the_probes_and_time_fills(track):
    free = _long_gaps(track)
    values = np.where(free[..., None], 0.0, track)
    probe = probe_mask(values, free)
    assert probe.any() and not (probe & free).any()
    assert not probe_mask(values, free, TemporalSettings(probe=False)).any()
    wrong, confidence = _off_by(track, 0.4)
    right, _ = _off_by(track, 0.0)
    assert clip_trust(values, free, probe, right, confidence) == TRUST_LEVELS[-1]
    trust = clip_trust(values, free, probe, wrong, confidence)
    assert trust < TRUST_LEVELS[-1]
    err = {t: np.linalg.norm(fill_segment(values, free, wrong, confidence, trust=t)[0]
                             - track, axis=-1)[free].mean() for t in (trust, 1.0)}
    assert err[trust] < 0.5 * err[1.0], err


def test_a_joint_never_observed_keeps_the_prior_whatever_the_trust(track):
    free = _long_gaps(track)
    free[:, ANKLE] = True
    values = np.where(free[..., None], 0.0, track)
    prior, confidence = _off_by(track, 0.0)
    out, weight, _ = fill_segment(values, free, prior, confidence, trust=0.0)
    assert np.isfinite(out).all() and weight[:, ANKLE].max() == 1.0
    assert weight[:, WRIST].max() == 0.0


def test_no_probe_where_the_prior_has_no_weight():
    free = np.zeros((60, 14), bool)
    free[20:26, WRIST] = True  # every frame within ramp_start of an observation
    assert not probe_mask(np.zeros((60, 14, 2)), free).any()


# ------------------------------------------------------------ the fused prior (fusion=True)
#: the per-frame answers fused (not the joints carried from their own frames, ``carry``)
FUSED = TemporalSettings(fusion=True, carry=0.0)


def _noisy(track, share=0.005, seed=0):
    """The track with white keypoint noise of `share` of its height (a detector's)."""
    rng = np.random.default_rng(seed)
    return track + rng.normal(scale=share * _height(track), size=track.shape)


def _fused_probe(values, free, prior, confidence):
    """The fused segment's prior scale from its own probes, as recover_temporal pools it."""
    probe = probe_mask(values, free, FUSED)
    score = probe_errors(values, free, probe, prior, confidence, FUSED)
    return probe, score, prior_scale(score.prior_error, score.prior_count, FUSED)


def test_fusion_is_for_noisy_keypoints_only(track):
    free = _long_gaps(track)
    clean = np.where(free[..., None], 0.0, track)
    noisy = np.where(free[..., None], 0.0, _noisy(track))
    assert segment_settings(clean, free, FUSED) is FUSED
    assert segment_settings(noisy, free, FUSED).ramp_floor == 1.0
    assert segment_settings(noisy, free) is DEFAULT_SETTINGS  # off by default


def test_fused_still_joint_comes_back_still(track):
    """A still run is left to time under the fused prior too: the fill is the
    prior-free one, while a joint not taken as still is dragged to the prior."""
    truth = _noisy(_resting_legs(track), 0.003)
    free = np.zeros(truth.shape[:2], bool)
    free[60:100, ANKLE] = True
    values = np.where(free[..., None], 0.0, truth)
    prior, confidence = _off_by(truth, 0.3)
    fused = segment_settings(values, free, FUSED)
    assert fused.ramp_floor == 1.0 and still_runs(values, free, fused)[60:100, ANKLE].all()
    out = fill_segment(values, free, prior, confidence, fused)[0]
    alone = fill_segment(values, free, np.full_like(prior, np.nan), np.zeros(len(prior)),
                         fused)[0]
    np.testing.assert_allclose(out[60:100, ANKLE], alone[60:100, ANKLE], atol=1e-6)
    rest = truth[55:60, ANKLE].mean(axis=0)
    height = _height(truth)
    moved = np.linalg.norm(out[60:100, ANKLE] - rest, axis=-1).max()
    dragged = fill_segment(values, free, prior, confidence, replace(fused, still=0))[0]
    away = np.linalg.norm(dragged[60:100, ANKLE] - rest, axis=-1).max()
    assert moved < 0.01 * height < 0.05 * height < away, (moved, away, height)


def test_fused_fill_is_continuous_at_both_ends_of_a_gap(track):
    noisy = _noisy(track)
    free = np.zeros(track.shape[:2], bool)
    for start in range(20, 220, 40):
        free[start:start + 15, WRIST] = True
    values = np.where(free[..., None], 0.0, noisy)
    prior, confidence = _off_by(track, 0.05)  # a prior off by 5 % of the height
    scale = _fused_probe(values, free, prior, confidence)[2]
    fused = replace(segment_settings(values, free, FUSED), ramp_floor=scale)
    out = fill_segment(values, free, prior, confidence, fused)[0]
    steps = _edge_jumps(track, track, free)
    noise = 0.005 * _height(track)
    jumps = _edge_jumps(out, noisy, free)
    assert (jumps <= steps + noise).all(), (jumps - steps, noise)
    apart = fill_segment(values, free, prior, confidence, replace(fused, edge_decay=0))[0]
    assert (_edge_jumps(apart, noisy, free) > steps + noise).any()
    np.testing.assert_array_equal(out[~free], noisy[~free])


def test_a_wrong_prior_measured_by_the_probes_leaves_the_fused_fill_to_time(track):
    noisy = _noisy(track)
    free = _long_gaps(track)
    values = np.where(free[..., None], 0.0, noisy)
    wrong, confidence = _off_by(track, 0.4)
    right, _ = _off_by(track, 0.0)
    probe, score, scale = _fused_probe(values, free, wrong, confidence)
    assert probe.any() and score.prior_count > 0
    assert _fused_probe(values, free, right, confidence)[2] > 20 * scale
    trust = choose_trust(score.errors, score.count)
    assert trust < TRUST_LEVELS[-1] and scale < 0.01
    nothing = np.full_like(values, np.nan)
    alone = fill_segment(values, free, nothing, np.zeros(len(values)), FUSED)[0]
    fused = replace(segment_settings(values, free, FUSED), ramp_floor=scale)
    err = {name: np.linalg.norm(out - track, axis=-1)[free].mean() for name, out in (
        ("time", alone),
        ("measured", fill_segment(values, free, wrong, confidence, fused, trust=trust)[0]),
        ("trusted", fill_segment(values, free, wrong, confidence,
                                 replace(fused, ramp_floor=1.0))[0]))}
    assert err["measured"] < 1.1 * err["time"] < 0.5 * err["trusted"], err


def test_noisy_keypoints_are_smoothed_with_their_own_jerk_penalty(track):
    """Noisy observations (data, not anchors) are smoothed with ``noisy_jerk``
    and ``noisy_acceleration``; clean ones keep ``jerk``."""
    free = np.zeros(track.shape[:2], bool)
    for start in range(20, 220, 40):
        free[start:start + 3, WRIST] = True
    prior, confidence = np.full_like(track, np.nan), np.zeros(len(track))
    fills = {}
    for name, poses in (("clean", track), ("noisy", _noisy(track, 0.01))):
        values = np.where(free[..., None], 0.0, poses)
        for noisy_jerk, jerk in ((0.0, 300.0), (0.0, 5.0), (300.0, 300.0)):
            st = TemporalSettings(noisy_jerk=noisy_jerk, jerk=jerk)
            fills[name, noisy_jerk, jerk] = fill_segment(values, free, prior, confidence, st)[0]
    np.testing.assert_array_equal(fills["noisy", 0.0, 300.0], fills["noisy", 0.0, 5.0])
    assert np.abs(fills["noisy", 0.0, 300.0] - fills["noisy", 300.0, 300.0])[free].max() > 0.1
    np.testing.assert_array_equal(fills["clean", 0.0, 300.0], fills["clean", 300.0, 300.0])
    assert np.abs(fills["clean", 0.0, 300.0] - fills["clean", 0.0, 5.0])[free].max() > 1e-6


def _repeating(track, rate=0.3, seed=0):
    """The track from a keypoint source that repeats a joint's previous
    coordinates with probability `rate` at each frame (an annotator or a
    tracker holding a point)."""
    rng = np.random.default_rng(seed)
    out = track.copy()
    for t in range(1, len(out)):
        hold = rng.random(out.shape[1]) < rate
        out[t, hold] = out[t - 1, hold]
    return out


def _edge_excess(filled, truth, free):
    """Each run's step from its observed neighbours into it, beyond the truth's."""
    return _edge_jumps(filled, truth, free) - _edge_jumps(truth, truth, free)


def test_repeating_keypoints_are_expected_to_repeat_at_gap_edges(track):
    """Where the keypoints repeat their previous frame, a hidden joint is
    expected to have repeated its observed neighbour as often: the fill steps
    into and out of each run less than the smoothed curve, and lies nearer."""
    truth = _repeating(track)
    free = np.zeros(truth.shape[:2], bool)
    for start in range(21, 221, 20):
        free[start:start + 3, WRIST] = True
        free[start + 6:start + 9, 7] = True
    values = np.where(free[..., None], 0.0, truth)
    rates = repeat_rate(values, free)
    assert ((0.2 < rates) & (rates < 0.4)).all(), rates
    prior, confidence = np.full_like(values, np.nan), np.zeros(len(values))
    fills = {on: fill_segment(values, free, prior, confidence,
                              TemporalSettings(repeats=on))[0] for on in (True, False)}
    excess = {on: np.clip(_edge_excess(f, truth, free), 0, None).mean()
              for on, f in fills.items()}
    error = {on: np.linalg.norm(f - truth, axis=-1)[free].mean() for on, f in fills.items()}
    assert excess[True] < 0.8 * excess[False], excess
    assert error[True] < error[False], error


def test_keypoints_that_never_repeat_are_filled_as_without_the_rule(track):
    free = np.zeros(track.shape[:2], bool)
    free[50:53, WRIST] = True
    free[80:110, ANKLE] = True
    values = np.where(free[..., None], 0.0, track)
    prior, confidence = _off_by(track, 0.05)
    assert not repeat_rate(values, free).any()
    on, off = (fill_segment(values, free, prior, confidence, TemporalSettings(repeats=r))[0]
               for r in (True, False))
    np.testing.assert_array_equal(on, off)
    resting = _resting_legs(track, 0, len(track))   # the legs repeat, the arms move
    assert not repeat_rate(resting[:2], free[:2]).any()   # too few pairs to tell
    rates = repeat_rate(np.where(free[..., None], 0.0, resting), free)
    assert rates[WRIST] < 0.5 * rates[ANKLE], rates


def _end_runs(track):
    """A wrist hidden from the track's first frame and up to its last, and once
    inside; an ankle hidden up to the last frame."""
    free = np.zeros(track.shape[:2], bool)
    free[:12, WRIST] = True
    free[100:115, WRIST] = True
    free[-15:, WRIST] = True
    free[-20:, ANKLE] = True
    return free


def test_a_run_at_a_tracks_end_takes_a_damped_first_step(track):
    """Between noisy keypoints, a run observed on one side only (it reaches the
    track's first or last frame) keeps end_step of the smoothed curve's
    displacement from its observed neighbour at the first filled frame, close
    to all of it a few frames on; a run observed on both sides (a still one
    too) is as without the rule, and clean keypoints (exact anchors) are
    untouched."""
    truth = _resting_legs(track, 90, 125)
    noisy = truth + np.random.default_rng(3).normal(scale=0.01 * _height(track),
                                                    size=track.shape)
    free = _end_runs(track)
    free[100:115, ANKLE] = True                       # at rest on both sides
    prior, confidence = np.full(track.shape, np.nan), np.zeros(len(track))
    fills = {}
    for keep in (0.8, 1.0):
        settings = TemporalSettings(end_step=keep)
        fills[keep] = fill_segment(np.where(free[..., None], 0.0, noisy), free, prior,
                                   confidence, settings)[0]
    T = len(track)
    for j, first, near, edge in ((WRIST, 11, 0, 12), (WRIST, T - 15, -1, T - 16),
                                 (ANKLE, T - 20, -1, T - 21)):
        far = first + 8 * (1 if near == -1 else -1)   # 8 frames further from the edge
        damped, plain = (fills[k][:, j] - noisy[edge, j] for k in (0.8, 1.0))
        np.testing.assert_allclose(damped[first], 0.8 * plain[first])
        assert np.linalg.norm(damped[far] - plain[far]) < 0.01 * np.linalg.norm(plain[far])
    np.testing.assert_array_equal(fills[0.8][100:115], fills[1.0][100:115])
    assert still_runs(np.where(free[..., None], 0.0, noisy), free)[100:115, ANKLE].all()
    clean = {k: fill_segment(np.where(free[..., None], 0.0, track), free, prior, confidence,
                             TemporalSettings(end_step=k))[0] for k in (0.8, 1.0)}
    np.testing.assert_array_equal(clean[0.8], clean[1.0])
