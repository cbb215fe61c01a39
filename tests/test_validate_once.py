"""The user's poses, masks and frames are validated once, at the public entrance.

Every module's reference to a checker is wrapped with a counter; a recovery or
a lift that checks its input again further in (a second ``validate_poses``, the
kernel's own checks, the frames read twice) fails here.
"""

import collections
import sys

import numpy as np
import pytest

import sparseedm
from sparseedm import _recovery_base, _validation
from sparseedm.exceptions import SparseEDMError
from sparseedm.temporal import tracks as temporal_tracks

WRIST = 4
CHECKERS = [(_validation, "unmask"), (_validation, "check_poses"), (_validation, "check_mask"),
            (_validation, "check_frames"), (_recovery_base, "validate_poses"),
            (temporal_tracks, "frame_numbers"), (_validation, "frame_value")]


@pytest.fixture
def counted(monkeypatch):
    """Counts of each checker's calls, from wherever they are imported."""
    counts = collections.Counter()

    def counting(name, f):
        def wrapper(*args, **kwargs):
            counts[name] += 1
            return f(*args, **kwargs)
        return wrapper

    for home, name in CHECKERS:
        original = getattr(home, name)
        wrapped = counting(name, original)
        for module in list(sys.modules.values()):
            if (getattr(module, "__name__", "").startswith("sparseedm")
                    and getattr(module, name, None) is original):
                monkeypatch.setattr(module, name, wrapped)
    return counts


def _clip(track):
    """Two people, 60 frames each, a wrist and a knee hidden for a stretch."""
    n = 60
    truth = np.concatenate([track[:n], track[n:2 * n] + 250.0])
    mask = np.zeros(truth.shape[:2], bool)
    mask[20:32, WRIST] = True
    mask[n + 30:n + 45, 10] = True
    tracks = np.repeat(["p1", "p2"], n)
    frames = np.concatenate([np.arange(n), np.arange(n)])
    return np.where(mask[..., None], np.nan, truth), mask, tracks, frames


def _once(counts, names):
    assert {name: counts[name] for name in names} == dict.fromkeys(names, 1), dict(counts)


def test_recover_on_a_video_validates_once(track, small_dictionary, counted):
    poses, mask, tracks, frames = _clip(track)
    res = sparseedm.recover(poses, mask, tracks=tracks, frames=frames,
                            dictionary=small_dictionary)
    assert res.segments > 0  # the temporal path ran
    _once(counted, ["validate_poses", "unmask", "check_poses", "check_mask", "check_frames",
                    "frame_numbers"])


@pytest.mark.parametrize("adapt", ["auto", False])
def test_recover_per_pose_validates_once(track, small_dictionary, counted, adapt):
    poses, mask, _, _ = _clip(track)
    sparseedm.recover(poses, mask, dictionary=small_dictionary, adapt=adapt)
    _once(counted, ["validate_poses", "unmask", "check_poses", "check_mask"])
    assert counted["check_frames"] == counted["frame_numbers"] == 0


def test_lift_validates_once(track, small_dictionary, counted):
    poses, mask, tracks, frames = _clip(track)
    sparseedm.lift(poses, mask)
    _once(counted, ["validate_poses", "unmask", "check_poses", "check_mask"])
    counted.clear()
    sparseedm.lift(poses, mask, tracks=tracks, frames=frames, dictionary=small_dictionary)
    _once(counted, ["validate_poses", "unmask", "check_poses", "check_mask", "check_frames"])


def test_inner_calls_trust_what_the_entrance_refuses(small_dictionary):
    """The checks still run once: a bad mask or bad frames are refused."""
    poses = np.zeros((3, 14, 2)) + np.arange(14)[None, :, None]
    with pytest.raises(SparseEDMError, match="missing"):
        sparseedm.recover(poses, np.zeros((3, 13), bool), dictionary=small_dictionary)
    with pytest.raises(SparseEDMError, match="frames"):
        sparseedm.recover(poses, frames=[True, False, True], dictionary=small_dictionary)
    with pytest.raises(SparseEDMError, match="frames"):
        sparseedm.lift(poses, frames=[True, False, True])


def test_recover_file_on_a_video_validates_each_row_once(track, small_dictionary_path,
                                                         tmp_path, counted):
    """The reader checks the file; adapting on the whole file trusts it, and the
    one chunk's recovery validates its rows once (frame numbers: each step reads
    the int64 array at numpy speed; text ones are read once, below)."""
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, write_keypoints

    poses, mask, tracks, frames = _clip(track)
    src = write_keypoints(tmp_path / "clip.npz",
                          KeypointSet(poses, mask, tracks=tracks, frames=frames))
    counted.clear()
    recover_file(src, tmp_path / "out.npz", dictionary=str(small_dictionary_path))
    _once(counted, ["validate_poses", "unmask", "check_mask", "check_frames"])


@pytest.mark.parametrize("confidence", [False, True])
def test_recover_file_reads_each_frame_number_once(track, small_dictionary_path, tmp_path,
                                                   counted, confidence):
    """A CSV whose frame numbers are written as floats ("12.0", as pandas writes a
    column with a gap) reads back as text; recover_file reads each one once by the
    frame-number rule, not again in each step (the test for time, the outlier check,
    adapting on the clip, the chunks, the recovery)."""
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import read_keypoints, write_keypoints

    poses, mask, tracks, frames = _clip(track)
    src = tmp_path / "clip.csv"
    scores = np.where(mask, np.nan, 0.9) if confidence else None
    write_keypoints(src, poses, tracks=tracks, frames=np.array([f"{f}.0" for f in frames]),
                    confidence=scores)
    assert read_keypoints(src).frames.dtype == object
    counted.clear()
    s = recover_file(src, tmp_path / "out.csv", dictionary=str(small_dictionary_path))
    assert s["temporal"]["segments"] > 0  # recovered across time
    assert counted["frame_value"] == len(poses), dict(counted)


def test_recover_blending_many_hidden_joints_validates_once(track, small_dictionary,
                                                           counted):
    """Poses with four hidden joints are averaged with a second code
    (sparseedm.exemplars.blend_many_hidden): still one validation."""
    poses, mask, _, _ = _clip(track)
    mask[40:50, [9, 10, 12, 13]] = True
    poses = np.where(mask[..., None], np.nan, poses)
    res = sparseedm.recover(poses, mask, dictionary=small_dictionary)
    assert res.adaptation.file_atoms > 0 and not res.adapted  # the blend's path
    _once(counted, ["validate_poses", "unmask", "check_poses", "check_mask"])


def test_recover_with_the_mean_with_the_ridge_validates_once(track, small_dictionary,
                                                            counted, monkeypatch):
    """Every occluded pose averaged with the local ridge over the base with the file
    atoms (sparseedm.exemplars.ridge_mean_atoms, here forced on): still one validation."""
    import sparseedm.exemplars
    from sparseedm.file_atoms import complete_rows, with_file_atoms

    monkeypatch.setattr(sparseedm.exemplars, "ridge_mean_atoms", lambda d, p, m, a: (
        with_file_atoms(d, p[complete_rows(p, m)]).dictionary))
    poses, mask, _, _ = _clip(track)
    res = sparseedm.recover(poses, mask, dictionary=small_dictionary)
    assert res.adaptation.file_atoms > 0 and not res.adapted  # the blend's path
    assert "held_err_ridge_mean" in res.adaptation.settings  # the check scored the mean
    _once(counted, ["validate_poses", "unmask", "check_poses", "check_mask"])


def _row_key(pose, mask):
    return np.where(mask[:, None], 0.0, pose).tobytes(), mask.tobytes()


@pytest.fixture
def screened(monkeypatch):
    """How often each (pose, mask) row was screened (screen_poses), from wherever
    it is imported: a row screened again further in counts twice."""
    rows = collections.Counter()
    original = _recovery_base.screen_poses

    def screening(poses, mask, bad_coord):
        rows.update(_row_key(p, m) for p, m in zip(poses, mask))
        return original(poses, mask, bad_coord)

    for module in list(sys.modules.values()):
        if (getattr(module, "__name__", "").startswith("sparseedm")
                and getattr(module, "screen_poses", None) is original):
            monkeypatch.setattr(module, "screen_poses", screening)
    return rows


def _scored_clip(cmu_poses):
    """Two tracks of 120 frames, random and long gaps, three low-scored wrong wrists."""
    poses = cmu_poses[:240] * 200 + 300
    rng = np.random.default_rng(0)
    missing = rng.random(poses.shape[:2]) < 0.15
    missing[40:90, 3:6] = True
    missing[150:200, 8:12] = True
    confidence = np.where(missing, 0.0, rng.uniform(0.3, 1.0, missing.shape))
    poses[200:203, WRIST] += 80
    missing[200:203, WRIST] = False
    confidence[200:203, WRIST] = 0.1
    return (np.where(missing[..., None], np.nan, poses), missing, confidence,
            np.repeat([0, 1], 120), np.tile(np.arange(120), 2))


@pytest.mark.parametrize("scores", [False, True], ids=["no scores", "scores"])
def test_recover_on_a_clip_screens_each_row_once(cmu_poses, counted, screened, scores):
    """The temporal model screens the clip; its per-frame rows are not screened again
    (nor, with scores, validated again by the outlier check's pose model)."""
    clip, missing, confidence, tracks, frames = _scored_clip(cmu_poses)
    res = sparseedm.recover(clip, tracks=tracks, frames=frames,
                            confidence=confidence if scores else None)
    assert counted["validate_poses"] == 1
    assert np.isfinite(res.objective).any()  # the per-frame path ran (its lasso)
    assert not scores or res.outliers[200:203, WRIST].any()  # and the outlier check
    assert max(screened[_row_key(p, m)] for p, m in zip(clip, missing)) == 1


@pytest.mark.parametrize("kwargs", [dict(adapt=False), dict(mirror=True)],
                         ids=["adapt=False", "mirror"])
def test_the_members_of_a_recovery_share_one_screening(cmu_poses, counted, screened, kwargs):
    """Several dictionaries recover the same poses (mirror images; the cold prior's
    mirror gate): the poses are screened once for all of them."""
    poses = cmu_poses[:80] * 200 + 300
    missing = np.zeros(poses.shape[:2], bool)
    missing[::2, WRIST] = True
    missing[1::4, 9:11] = True
    sparseedm.recover(np.where(missing[..., None], np.nan, poses), **kwargs)
    assert counted["validate_poses"] == 1
    assert max(screened[_row_key(p, m)] for p, m in zip(poses, missing)) == 1
