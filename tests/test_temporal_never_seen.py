"""Joints never seen in their track: their per-frame answers take the mirror
image's in, gated per pose (``TemporalSettings.never_mirror``)."""

from dataclasses import replace

import numpy as np
import pytest

from sparseedm.exceptions import ParameterError
from sparseedm.temporal.model import DEFAULT_SETTINGS, TemporalSettings
from sparseedm.temporal.recover import recover_temporal

WRIST, KNEE = 4, 9
OFF = replace(DEFAULT_SETTINGS, never_mirror=False)


def _never_wrist(track):
    """The wrist hidden in every frame, a knee hidden in a run (seen elsewhere)."""
    free = np.zeros(track.shape[:2], bool)
    free[:, WRIST] = True
    free[100:160, KNEE] = True
    return free


def _fill(given, free, frames, settings=DEFAULT_SETTINGS, tracks=None):
    return recover_temporal(given, free, frames=frames, tracks=tracks, adapt=False,
                            settings=settings).poses


def test_a_joint_never_seen_takes_the_mirror_answer_in(track):
    free = _never_wrist(track)
    given = np.where(free[..., None], np.nan, track)
    frames = np.arange(len(track))
    on, off = _fill(given, free, frames), _fill(given, free, frames, OFF)
    moved = np.linalg.norm(on - off, axis=-1)
    assert moved[:, WRIST].max() > 1e-3 * np.ptp(track[..., 1])
    assert np.isfinite(on[free]).all()
    np.testing.assert_array_equal(on[~free], track[~free])


def test_a_track_whose_hidden_joints_are_all_seen_is_unchanged(track):
    free = np.zeros(track.shape[:2], bool)
    free[100:160, WRIST] = True
    free[20:40, KNEE] = True
    given = np.where(free[..., None], np.nan, track)
    frames = np.arange(len(track))
    np.testing.assert_array_equal(_fill(given, free, frames), _fill(given, free, frames, OFF))


def test_never_seen_is_per_track(track):
    """A wrist hidden throughout one track is never seen there, though the
    other track shows it: that track's rows are as when given alone."""
    free = _never_wrist(track)
    other = np.zeros_like(free)
    poses = np.concatenate([np.where(free[..., None], np.nan, track), track + 500.0])
    mask = np.concatenate([free, other])
    frames = np.tile(np.arange(len(track)), 2)
    tracks = np.repeat([0, 1], len(track))
    both = _fill(poses, mask, frames, tracks=tracks)[: len(track)]
    alone = _fill(poses[: len(track)], free, frames[: len(track)])
    off = _fill(poses, mask, frames, OFF, tracks=tracks)[: len(track)]
    np.testing.assert_allclose(both, alone, atol=1e-9)
    assert not np.allclose(both[:, WRIST], off[:, WRIST])


def test_never_mirror_is_a_switch():
    with pytest.raises(ParameterError, match="never_mirror"):
        TemporalSettings(never_mirror=1)
