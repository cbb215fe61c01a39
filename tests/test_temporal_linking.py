"""Poses without track ids linked into tracks (sparseedm.temporal.linking)."""

import numpy as np
import pytest

import sparseedm
from sparseedm.temporal.linking import MIN_COMMON_JOINTS, link_tracks, needs_linking
from sparseedm.temporal.model import TemporalSettings
from sparseedm.temporal.recover import recover_temporal

WRIST, KNEE = 4, 8


def _same_partition(a, b):
    """Whether two labelings group the rows alike (labels may differ)."""
    pairs = set(zip(np.asarray(a).tolist(), np.asarray(b).tolist()))
    return len(pairs) == len(set(a)) == len(set(b))


def _two_people(track, n=80, shift=(250.0, 0.0), seed=1):
    """Two people's rows, each frame's in a seeded order, no ids: (poses, mask,
    frames, person, truth)."""
    shift = np.broadcast_to(np.asarray(shift, dtype=float), (n, 2))
    truth = np.concatenate([track[:n], track[n:2 * n] + shift[:, None, :]])
    person = np.repeat([0, 1], n)
    frames = np.concatenate([np.arange(n), np.arange(n)])
    mask = np.zeros(truth.shape[:2], bool)
    mask[20:32, WRIST] = True
    mask[n + 40:n + 60, KNEE] = True
    order = np.lexsort((np.random.default_rng(seed).random(2 * n), frames))
    poses = np.where(mask[..., None], np.nan, truth)
    return poses[order], mask[order], frames[order], person[order], truth[order]


def test_two_people_given_in_any_order_are_told_apart(track):
    poses, mask, frames, person, _ = _two_people(track)
    linked = link_tracks(poses, mask, frames=frames)
    np.testing.assert_array_equal(linked, person)  # numbered left to right as they start
    perm = np.random.default_rng(2).permutation(len(poses))
    np.testing.assert_array_equal(link_tracks(poses[perm], mask[perm], frames=frames[perm]),
                                  person[perm])  # whatever the rows' order


def test_people_walking_across_each_other_keep_their_ids(track):
    # two people in the same pose walk through each other's place in the image,
    # one rightwards, one leftwards: where they overlap only the tracks'
    # velocities tell them apart (without them every seed switched identities)
    n = 80
    shift = np.stack([np.linspace(-100, 100, n), np.zeros(n)], axis=1)[:, None, :]
    truth = np.concatenate([track[:n] + shift, track[:n] - shift])
    person, frames = np.repeat([0, 1], n), np.tile(np.arange(n), 2)
    for seed in range(3):
        order = np.lexsort((np.random.default_rng(seed).random(2 * n), frames))
        linked = link_tracks(truth[order], frames=frames[order])
        assert _same_partition(linked, person[order])


def test_a_person_missing_for_some_frames_is_taken_up_again(track):
    poses, mask, frames, person, _ = _two_people(track)
    gone = (person == 1) & (frames >= 30) & (frames < 40)  # not detected for 10 frames
    linked = link_tracks(poses[~gone], mask[~gone], frames=frames[~gone])
    assert _same_partition(linked, person[~gone])
    far = link_tracks(poses[~gone], mask[~gone], frames=frames[~gone], max_skip=5)
    assert len(set(far.tolist())) == 3  # beyond max_skip it starts a new track


def test_a_pose_far_from_every_track_starts_its_own(track):
    poses = np.stack([track[0], track[1], track[2] + 5000.0])
    assert link_tracks(poses, frames=[0, 1, 2]).tolist() == [0, 0, 1]


def test_rows_that_cannot_be_linked_get_ids_of_their_own(track):
    poses = track[:4].copy()
    poses[2, MIN_COMMON_JOINTS - 1:] = np.nan  # too few joints to compare
    linked = link_tracks(poses, frames=np.array([0, 1, 2, np.nan]))
    assert linked[0] == linked[1] and len(set(linked.tolist())) == 3


def test_needs_linking_only_without_tracks_and_with_a_shared_frame():
    assert needs_linking(None, [3, 1, 3])
    assert not needs_linking(None, [0, 1, 2]) and not needs_linking(["a", "b"], [0, 0])
    assert not needs_linking(None, None)
    assert not needs_linking(None, [0.5, 0.5, 1])  # not integers: refused per row anyway


def test_recover_links_people_given_without_tracks(track, small_dictionary):
    poses, mask, frames, person, truth = _two_people(track)
    given = sparseedm.recover(poses, mask, frames=frames, dictionary=small_dictionary,
                              adapt=False)
    known = sparseedm.recover(poses, mask, tracks=person, frames=frames,
                              dictionary=small_dictionary, adapt=False)
    assert _same_partition(given.linked_tracks, person)
    assert given.summary()["temporal"]["linked_tracks"] == 2
    assert known.linked_tracks is None and "linked_tracks" not in known.summary()["temporal"]
    np.testing.assert_allclose(given.poses, known.poses, rtol=0, atol=1e-9)
    hidden = mask.any(axis=1)
    assert (given.reason[hidden] == "filled across time by the temporal model").all()


@pytest.mark.parametrize("ext", ["csv", "npz", "openpose", "mmpose"])
def test_cli_links_a_file_without_tracks_and_writes_them(tmp_path, track,
                                                         small_dictionary_path, ext, capsys):
    # a CSV / npz with a frame column, a folder of OpenPose frames or MMPose
    # predictions without ids: linked, and the ids written back (a track
    # column, a tracks array, OpenPose's person_id, MMPose's track_id)
    from sparseedm.cli import main
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    poses, mask, frames, person, truth = _two_people(track)
    if ext in ("openpose", "mmpose"):
        inp = tmp_path / ("frames" if ext == "openpose" else "pred.json")
        write_keypoints(inp, poses, mask, format=ext, frames=frames)  # rows in frame order
    else:
        inp = write_keypoints(tmp_path / f"v.{ext}", KeypointSet(poses, mask, frames=frames))
    src = read_keypoints(inp)  # what the file holds (OpenPose: BODY_25's head and neck)
    assert src.tracks is None
    np.testing.assert_array_equal(src.frames, frames)
    out = tmp_path / {"openpose": "out", "mmpose": "out.json"}.get(ext, f"o.{ext}")
    assert main(["recover", str(inp), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--no-adapt"]) == 0
    assert "linked them into 2 track(s)" in capsys.readouterr().err
    back = read_keypoints(out)
    assert _same_partition(back.tracks, person)
    np.testing.assert_array_equal(back.frames, frames)
    api = sparseedm.recover(src.poses, src.missing, tracks=person, frames=frames,
                            dictionary=str(small_dictionary_path), adapt=False)
    np.testing.assert_allclose(back.poses, api.poses, rtol=0, atol=1e-6)


def test_a_folder_of_photos_is_not_a_video(cmu_poses, small_dictionary):
    """Unrelated poses numbered in a row (photos IMG_4501, IMG_4502...): every
    step jumps, so every row is answered alone, as without frames, and says why."""
    from sparseedm.temporal.linking import JUMP_REASON

    rng = np.random.default_rng(0)
    pick = rng.choice(len(cmu_poses), 20, replace=False)
    poses = cmu_poses[pick] * rng.uniform(0.7, 2.5, (20, 1, 1)) + rng.uniform(-300, 600, (20, 1, 2))
    poses[:, WRIST] = np.nan
    res = sparseedm.recover(poses, frames=np.arange(4501, 4521), dictionary=small_dictionary,
                            adapt=False)
    alone = sparseedm.recover(poses, dictionary=small_dictionary, adapt=False)
    assert res.segments == 0 and (res.source[:, WRIST] == "per_frame").all()
    assert all(JUMP_REASON in r for r in res.reason)
    # the same lasso; in time on the compiled kernel, alone on the numpy homotopy
    np.testing.assert_allclose(res.poses, alone.poses, rtol=0, atol=1e-6)


def test_a_cut_in_the_video_splits_the_track(track, small_dictionary):
    """A shot change (the person 2 body heights away from frame 100 on) cuts the
    track: a wrist hidden across the cut is not carried from one shot to the
    other, and the motion either side is still filled across time."""
    from sparseedm.temporal.linking import split_at_jumps, step_distances
    from sparseedm.temporal.tracks import split_tracks

    height = np.ptp(track[..., 1], axis=1).mean()
    truth = track.copy()
    truth[100:] += [0.0, 2.0 * height]
    mask = np.zeros(truth.shape[:2], bool)
    mask[90:110, WRIST] = True
    poses = np.where(mask[..., None], np.nan, truth)
    steps = step_distances(poses, np.arange(len(poses)))
    assert np.nanargmax(steps) == 99 and np.nanmax(np.delete(steps, 99)) < 0.1
    layout = split_at_jumps(split_tracks(len(poses), None, np.arange(len(poses))), poses, mask)
    assert [len(s) for s in layout.segments] == [100, len(track) - 100]
    res = sparseedm.recover(poses, frames=np.arange(len(poses)), dictionary=small_dictionary,
                            adapt=False)
    assert res.segments == 2 and (res.source[mask] == "temporal").all()
    err = np.linalg.norm(res.poses[mask] - truth[mask], axis=-1) / height
    assert err.max() < 0.25  # across the cut it would be pulled a body height off


def test_a_fast_move_seen_on_a_few_joints_does_not_cut_the_track(track):
    """A person moving fast (a fifth of the body's extent a frame) while only an arm
    is seen for a few frames: judged against the arm's own small extent the steps
    read as jumps and cut the track, leaving the hidden legs to run on from the
    last frame before the cut; in the body's extent they are ordinary motion."""
    from sparseedm.temporal.linking import (MAX_LINK_DISTANCE, body_extent, split_at_jumps,
                                            step_distances)
    from sparseedm.temporal.tracks import split_tracks

    poses = track.copy()
    frames = np.arange(len(poses))
    body = body_extent(poses)
    poses += (0.2 * body * np.clip(frames - 90, 0, 20))[:, None, None] * [0.0, 1.0]
    mask = np.zeros(poses.shape[:2], bool)
    mask[95:100] = True
    mask[95:100, [3, 4, 7]] = False            # an elbow and both wrists seen
    given = np.where(mask[..., None], np.nan, poses)
    assert np.nanmax(step_distances(given, frames)) > MAX_LINK_DISTANCE   # the arm's unit
    steps = step_distances(given, frames, body)
    assert np.nanmax(steps) < MAX_LINK_DISTANCE
    layout = split_at_jumps(split_tracks(len(poses), None, frames), given, mask)
    assert [len(s) for s in layout.segments] == [len(poses)]


#: joints a row shows in _never_complete: an arm, the other arm, a leg, the other leg
_PARTS = ((1, 2, 3, 4), (1, 5, 6, 7), (8, 9, 10, 11), (11, 12, 13, 8))


def _never_complete(track, block=10):
    """A mask of the track under which no row is complete: each block of rows
    shows one limb and its neighbours (:data:`_PARTS`, in turn)."""
    mask = np.ones(track.shape[:2], bool)
    for t in range(len(track)):
        mask[t, list(_PARTS[t // block % len(_PARTS)])] = False
    return mask


def test_a_track_without_a_complete_row_reads_its_body_from_pairs(track):
    """No row shows every joint: the unit is the largest distance between two
    joints seen together (pair_extent), at most the complete body's extent and
    above the rows' own extents, and a walk between rows that show different
    joints does not stretch it."""
    from sparseedm.temporal.linking import body_extent, pair_extent

    mask = _never_complete(track)
    given = np.where(mask[..., None], np.nan, track)
    body = body_extent(track)
    rows = np.median([np.linalg.norm(np.ptp(p[~m], axis=0)) for p, m in zip(track, mask)])
    assert rows < body_extent(given) <= body
    walked = given + (5.0 * body * np.arange(len(track)) / len(track))[:, None, None]
    assert pair_extent(walked) == pytest.approx(pair_extent(given))
    assert np.isnan(pair_extent(given[:2]))  # fewer rows than PAIR_MIN_ROWS: nothing read


def test_a_fast_move_without_a_complete_row_does_not_cut_the_track(track):
    """The same person moving fast (a fifth of the body's extent a frame) while
    every row shows only 4 joints: judged against those joints' own extent the
    steps read as jumps; in the extent read from the pairs they are ordinary
    motion, and one segment fills the clip. A shot change still cuts it."""
    from sparseedm.temporal.linking import (MAX_LINK_DISTANCE, body_extent, split_at_jumps,
                                            step_distances)
    from sparseedm.temporal.tracks import split_tracks

    frames = np.arange(len(track))
    body = body_extent(track)
    poses = track + (0.2 * body * np.clip(frames - 90, 0, 20))[:, None, None] * [1.0, 0.0]
    mask = _never_complete(track)
    given = np.where(mask[..., None], np.nan, poses)
    assert np.nanmax(step_distances(given, frames)) > MAX_LINK_DISTANCE   # the rows' unit
    layout = split_at_jumps(split_tracks(len(poses), None, frames), given, mask)
    assert [len(s) for s in layout.segments] == [len(poses)]
    cut = given.copy()
    cut[155:] += [0.0, 2.0 * body]
    layout = split_at_jumps(split_tracks(len(poses), None, frames), cut, mask)
    assert [len(s) for s in layout.segments] == [155, len(poses) - 155]


@pytest.mark.parametrize("wild", [1e6, 1e308])
def test_a_wild_coordinate_stays_on_its_own_row(track, small_dictionary, wild):
    """A detector's wild coordinate in one complete row of a track: that row is
    answered alone, its neighbours keep their statuses and come back as
    without it (to a few pixels near the cut), and no numpy warning leaks."""
    import warnings

    mask = np.zeros(track.shape[:2], bool)
    mask[95:125, WRIST] = True
    mask[150:160, KNEE] = True
    clean = np.where(mask[..., None], np.nan, track)
    bad = clean.copy()
    bad[100, 1, 0] = wild  # the neck of a complete row inside the wrist's gap
    mask_bad = mask.copy()
    frames = np.arange(len(track))
    # the per-segment test of the prior (TemporalSettings.probe) is off: it may
    # rightly decide otherwise on a track cut in two, which is not what is tested
    fixed = dict(dictionary=small_dictionary, adapt=False,
                 settings=TemporalSettings(probe=False))
    ref = recover_temporal(clean, frames=frames, **fixed)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = recover_temporal(bad, mask_bad, frames=frames, **fixed)
    others = np.arange(len(track)) != 100
    np.testing.assert_array_equal(res.status[others], ref.status[others])
    # answered alone; at 1e308 refused before any linking: beside that neck
    # the other joints' distances vanish in rounding (normalize.far_joint)
    assert ("jumps" if wild < 1e300 else "not a body") in res.reason[100]
    height = np.ptp(track[..., 1], axis=1).mean()
    assert np.abs(res.poses[others] - ref.poses[others]).max() < 0.05 * height


def test_a_single_image_is_not_a_video(tmp_path, track, small_dictionary_path):
    """Every pose in one frame (a single image: MMPose's image mode, COCO): the
    file is recovered pose by pose, nothing linked, no tracks written."""
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    poses = np.stack([track[0], track[0] + [250.0, 0.0], track[0] + [500.0, 0.0]])
    mask = np.zeros(poses.shape[:2], bool)
    mask[1, WRIST] = True
    path = write_keypoints(tmp_path / "image.csv", KeypointSet(
        np.where(mask[..., None], np.nan, poses), mask, frames=np.zeros(3, int)))
    summary = recover_file(path, tmp_path / "out.csv", dictionary=small_dictionary_path,
                           adapt=False)
    assert summary["temporal"] is None and summary.get("linked_tracks") is None
    out = read_keypoints(tmp_path / "out.csv")
    assert out.tracks is None and np.isfinite(out.poses).all()


def test_a_deeplabcut_table_takes_the_linked_tracks(tmp_path, track, small_dictionary):
    # two poses a frame, no tracks: refused as a single-animal table's duplicate
    # frames only if the run's check came before linking; linked, one track each
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    poses, mask, frames, person, _ = _two_people(track)
    inp = write_keypoints(tmp_path / "v.csv", KeypointSet(poses, mask, frames=frames))
    out = tmp_path / "o.csv"
    recover_file(inp, out, dictionary=small_dictionary, adapt=False, output_format="dlc",
                 progress=False)
    back = read_keypoints(out, format="dlc")  # rows frame-major per individual
    assert sorted(back.frames.tolist()) == sorted(frames.tolist())
    assert len(set(back.tracks.tolist())) == 2
    assert len(set(zip(back.tracks.tolist(), back.frames.tolist()))) == len(poses)
