"""Lifting a video (sparseedm.lift with frames): 2D filled across time first,
depth reflections chosen per track together (sparseedm.lifting.mds.reflection_path)."""

import csv
import itertools
from pathlib import Path

import numpy as np
import pytest

import sparseedm
from sparseedm.cli import main
from sparseedm.exceptions import SparseEDMError
from sparseedm.keypoints import read_keypoints
from sparseedm.lifting.metrics import mpjpe
from sparseedm.lifting import video as video_module
from sparseedm.lifting.mds import reflection_path
from sparseedm.lifting.video import smooth_tracks
from sparseedm.temporal.tracks import split_tracks
from sparseedm.skeleton import JOINT_NAMES

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _path_cost(path, front, back, score, frames, smoothness):
    P = np.where(path[:, None, None], back, front)
    unary = np.where(path, np.logaddexp(0, score), np.logaddexp(0, -score)).sum()
    dt = np.diff(frames)
    return unary + smoothness * (((P[1:] - P[:-1]) ** 2).sum(axis=(1, 2)) / dt).sum()


@pytest.mark.parametrize("seed", range(4))
def test_reflection_path_is_the_exact_optimum(seed):
    rng = np.random.default_rng(seed)
    T = 9
    front = np.cumsum(0.05 * rng.standard_normal((T, 14, 3)), axis=0) \
        + rng.standard_normal((1, 14, 3)) * [0.3, 0.8, 0.3]
    back = front * [1.0, 1.0, -1.0]
    score = 2.0 * rng.standard_normal(T)
    frames = np.cumsum(rng.integers(1, 4, T))
    got = reflection_path(front, back, score, frames, smoothness=3.0)
    best = min(itertools.product([False, True], repeat=T),
               key=lambda p: _path_cost(np.array(p), front, back, score, frames, 3.0))
    assert _path_cost(got, front, back, score, frames, 3.0) == pytest.approx(
        _path_cost(np.array(best), front, back, score, frames, 3.0), rel=1e-12)
    # smoothness 0 is the prior's sign, frame by frame
    np.testing.assert_array_equal(reflection_path(front, back, score, frames, 0.0), score < 0)


def test_a_misjudged_frame_of_a_moving_person_follows_its_neighbours():
    rng = np.random.default_rng(1)
    base = rng.standard_normal((14, 3)) * [0.3, 0.8, 0.3]
    front = np.stack([base + 0.01 * t for t in range(7)])
    back = front * [1.0, 1.0, -1.0]
    score = np.array([1.5, 2.0, 1.0, -0.8, 1.2, 2.2, 1.7])
    assert not reflection_path(front, back, score, np.arange(7)).any()
    # far apart in time, the frame is judged on its own again
    frames = np.array([0, 1, 2, 500, 1000, 1001, 1002])
    np.testing.assert_array_equal(reflection_path(front, back, score, frames), score < 0)


@pytest.fixture(scope="module")
def video():
    kps = read_keypoints(EXAMPLES / "video_clip.csv")
    with np.load(EXAMPLES / "video_clip_truth.npz") as z:
        truth = z["poses2d"]
    return kps, truth


@pytest.fixture(scope="module")
def lifted(video):
    """(complete truth lifted frame by frame, the same as a video, the occluded
    clip lifted frame by frame, the same as a video)."""
    kps, truth = video
    when = dict(tracks=kps.tracks, frames=kps.frames)
    return (sparseedm.lift(truth).poses3d, sparseedm.lift(truth, **when).poses3d,
            sparseedm.lift(kps.poses, kps.missing),
            sparseedm.lift(kps.poses, kps.missing, **when))


def test_video_lift_fills_2d_across_time_first(video, lifted):
    kps, truth = video
    complete3d, complete_video, per_frame, in_time = lifted
    hidden = kps.missing.any(axis=1)
    np.testing.assert_array_equal(in_time.filled, kps.missing)  # every hidden joint filled
    np.testing.assert_array_equal(in_time.missing, kps.missing)
    assert set(in_time.status[hidden]) == {"lifted_filled"}
    assert set(per_frame.status[hidden]) == {"lifted_occluded"}
    assert in_time.summary()["filled_across_time"] == int(hidden.sum())
    # observed 2D joints are lifted as given; filled ones near the truth
    obs = ~kps.missing
    np.testing.assert_array_equal(in_time.poses2d[obs], kps.poses[obs])
    # the 2D radius travels with the lift: 0 observed, positive filled, NaN per frame
    assert (in_time.uncertainty2d[obs] == 0).all()
    assert (in_time.uncertainty2d[kps.missing] > 0).all()
    assert np.isnan(per_frame.uncertainty2d[kps.missing]).all()
    body = np.ptp(truth[..., 1], axis=1).mean()
    assert np.linalg.norm(in_time.poses2d - truth, axis=-1)[kps.missing].mean() < 0.03 * body
    # the 3D of the hidden frames lands much nearer what the complete 2D lifts to
    near_time = mpjpe(in_time.poses3d, complete_video)[hidden].mean()
    near_frame = mpjpe(per_frame.poses3d, complete3d)[hidden].mean()
    assert near_time < 0.6 * near_frame, (near_time, near_frame)


def test_complete_frames_lift_as_alone_but_for_the_smoothing(video, lifted, monkeypatch):
    kps, truth = video
    complete3d, complete_video = lifted[:2]
    # smoothing moves them (the per-frame lasso's jitter), by little
    moved = mpjpe(complete_video, complete3d)
    assert 0 < moved.mean() < 15  # mm
    monkeypatch.setattr(video_module, "TRAJECTORY_SMOOTHNESS", 0.0)
    alone = sparseedm.lift(truth, tracks=kps.tracks, frames=kps.frames).poses3d
    np.testing.assert_array_equal(alone, complete3d)  # every reflection here is clear


def _layout(frames):
    return split_tracks(len(frames), None, frames)


def test_smoothing_keeps_steady_motion_and_refused_rows():
    rng = np.random.default_rng(3)
    frames = np.r_[0:10, 12:20]  # two skipped frames
    start, step = rng.standard_normal((1, 14, 3)), 0.01 * rng.standard_normal((1, 14, 3))
    steady = start + frames[:, None, None] * step
    steady[4] = np.nan  # a refused row
    out = smooth_tracks(steady.copy(), _layout(frames), 30.0)
    assert np.isnan(out[4]).all()
    np.testing.assert_allclose(out[np.arange(18) != 4], steady[np.arange(18) != 4],
                               rtol=0, atol=1e-9)
    # jitter around the steady motion is pulled back towards it
    noisy = steady + 0.02 * rng.standard_normal(steady.shape)
    out = smooth_tracks(noisy.copy(), _layout(frames), 30.0)
    keep = np.arange(18) != 4
    assert np.abs(out - steady)[keep].mean() < 0.6 * np.abs(noisy - steady)[keep].mean()
    np.testing.assert_array_equal(smooth_tracks(noisy.copy(), _layout(frames), 0.0), noisy)


def test_video_lift_does_not_depend_on_row_order(video, lifted):
    kps, _ = video
    order = np.random.default_rng(0).permutation(len(kps.poses))
    res = sparseedm.lift(kps.poses[order], kps.missing[order], tracks=kps.tracks[order],
                         frames=kps.frames[order])
    np.testing.assert_allclose(res.poses3d, lifted[3].poses3d[order], rtol=0, atol=1e-9)


def test_rows_time_cannot_use_are_lifted_alone_and_nothing_is_lost(video):
    kps, _ = video
    rows = slice(0, 60)
    poses, missing = kps.poses[rows].copy(), kps.missing[rows].copy()
    frames = kps.frames[rows].astype(float)
    frames[5] = np.nan  # no frame number
    frames[7] = frames[6]  # a duplicate (track, frame)
    poses[9, 0] = np.inf  # a bad coordinate
    res = sparseedm.lift(poses, missing, tracks=np.full(60, "a"), frames=frames)
    assert res.status[9] == "invalid_coordinates" and res.reason[9]
    for r in (5, 6, 7):
        assert not res.filled[r].any()
        assert res.status[r] == ("lifted_occluded" if missing[r].any() else "lifted")
    assert res.reason[5] == "lifted on its own, not across time: frame number is nan"
    assert res.reason[6] == res.reason[7] == ("lifted on its own, not across time: its "
                                              "(track, frame) pair is given more than once")
    assert not any("on its own" in r for r in np.delete(res.reason, [5, 6, 7]))
    assert res.ok.sum() == len(poses) - 1
    assert np.isfinite(res.poses3d[res.ok]).all()


def test_a_frame_with_every_joint_missing_is_lifted_from_its_fill(cmu_poses):
    """A detector's empty frame in a track of poses that move a lot between
    frames (every joint below the threshold): filled across time with wide
    radii, then lifted from the filled joints alone (their weights say how they
    compare; all far below 1, the lasso coded no pose and the image alignment
    met a singular matrix: an internal error)."""
    poses = cmu_poses[:40].copy()
    poses[[10, 25]] = np.nan
    res = sparseedm.lift(poses, frames=np.arange(40))
    assert res.ok.all() and res.filled[[10, 25]].all()
    assert np.isfinite(res.poses3d).all() and (np.ptp(res.poses3d[[10, 25]], axis=1) > 0).all()
    height = np.ptp(res.poses3d[:, :, 1], axis=1)
    assert np.all(np.abs(height[[10, 25]] / np.median(height) - 1) < 0.3)


def test_lift_cli_uses_time_and_writes_track_and_frame(tmp_path, video, lifted, capsys):
    kps, _ = video
    out = tmp_path / "poses3d.csv"
    assert main(["lift", str(EXAMPLES / "video_clip.csv"), "-o", str(out), "-q"]) == 0
    said = capsys.readouterr()
    assert "lifted across time: 156 pose(s)" in said.out + said.err
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["track"] for r in rows] == kps.tracks.astype(str).tolist()
    assert [int(r["frame"]) for r in rows] == kps.frames.tolist()
    got = np.array([[float(r[f"{j}_{a}"]) for j in JOINT_NAMES for a in "xyz"]
                    for r in rows]).reshape(-1, 14, 3)
    # the file path adapts once, then fills without adapting: round-off apart
    np.testing.assert_allclose(got, lifted[3].poses3d, rtol=0, atol=1e-9)
    assert [r["status"] for r in rows] == lifted[3].status.tolist()
    # --no-temporal: each row alone, as lift() without frames
    out2 = tmp_path / "alone.npz"
    assert main(["lift", str(EXAMPLES / "video_clip.csv"), "-o", str(out2), "-q",
                 "--no-temporal"]) == 0
    assert "lifted across time" not in capsys.readouterr().out
    with np.load(out2) as z:
        np.testing.assert_array_equal(z["poses3d"], lifted[2].poses3d)
        np.testing.assert_array_equal(z["frames"], kps.frames)


@pytest.mark.parametrize("temporal", [True, False])
def test_lift_file_works_in_bounded_chunks_of_whole_tracks(tmp_path, monkeypatch, temporal):
    from sparseedm.lifting import io as lift_io

    kps = read_keypoints(EXAMPLES / "video_clip.csv")
    whole = lift_io.lift_file(EXAMPLES / "video_clip.csv", tmp_path / "whole.npz",
                              temporal=temporal)
    sizes, real = [], lift_io.lift
    monkeypatch.setattr(lift_io, "lift", lambda poses, *a, **k: (
        sizes.append(len(poses)), real(poses, *a, **k))[1])
    parts = lift_io.lift_file(EXAMPLES / "video_clip.csv", tmp_path / "parts.npz",
                              temporal=temporal, chunk_size=100)
    n_rows = {t: int((kps.tracks == t).sum()) for t in np.unique(kps.tracks)}
    # with time whole tracks: 86 rows, then the 150-row track in two windows of
    # 75 rows of its own, each with 300 frames of context: all 150 rows;
    # without time, 100 rows at most
    assert sizes == ([86, 150, 150] if temporal else [100, 100, 36])
    assert list(n_rows.values()) == [86, 150]
    assert parts["status"] == whole["status"]
    with np.load(tmp_path / "whole.npz") as a, np.load(tmp_path / "parts.npz") as b:
        np.testing.assert_allclose(b["poses3d"], a["poses3d"], rtol=0, atol=1e-6)
        np.testing.assert_array_equal(b["status"], a["status"])
    with pytest.raises(SparseEDMError, match="chunk_size"):
        lift_io.lift_file(EXAMPLES / "video_clip.csv", tmp_path / "x.npz", chunk_size=0)


@pytest.mark.parametrize("args", [["openpose"], ["mmpose_predictions.json"],
                                  ["dlc.csv", "--joint-map", "dlc_joints.json"]])
def test_lift_cli_reads_the_detector_files_users_have(tmp_path, fixtures_dir, args, capsys):
    """OpenPose folders, MMPose predictions and DeepLabCut files (with their
    joint map) are lifted as videos: their frames come through."""
    fmt = fixtures_dir / "formats"
    argv = [str(fmt / a) if i != 1 else a for i, a in enumerate(args)]
    kps = read_keypoints(argv[0], joint_map=argv[2] if len(argv) > 2 else None)
    out = tmp_path / "poses3d.csv"
    assert main(["lift", argv[0], *argv[1:], "-o", str(out), "-q"]) == 0
    said = capsys.readouterr()
    assert "lifted across time" in said.out + said.err  # -q: the report goes to stderr
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["frame"]) for r in rows] == np.asarray(kps.frames).tolist()
    assert all(r["status"].startswith("lifted") for r in rows)


def _example_rows():
    with open(EXAMPLES / "video_clip.csv", newline="") as f:
        return list(csv.DictReader(f))


def _write_rows(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return path


def test_a_video_trc_follows_the_frames_and_holds_one_person(tmp_path, capsys):
    from sparseedm.lifting.trc import read_trc

    walk = [r for r in _example_rows() if r["track"] == "02_01"]
    walk = [walk[i] for i in np.random.default_rng(0).permutation(len(walk))]  # any order
    del walk[5]  # a frame where the person was not seen
    one = _write_rows(tmp_path / "walk.csv", walk)
    assert main(["lift", str(one), "-o", str(tmp_path / "walk.trc"), "-q"]) == 0
    trc = read_trc(tmp_path / "walk.trc")
    frames = np.sort([int(r["frame"]) for r in walk])
    np.testing.assert_array_equal(trc["frames"], frames + 1)
    np.testing.assert_allclose(trc["times"], frames / 30.0, atol=1e-6)
    # several people cannot share one .trc: refused before any work, nothing written
    capsys.readouterr()
    out = tmp_path / "two.trc"
    assert main(["lift", str(EXAMPLES / "video_clip.csv"), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "a .trc file holds one person's markers" in err
    assert "2 tracks ('02_01', '02_05')" in err and "--track" in err
    assert not out.exists()


def test_lift_track_writes_one_persons_trc_from_a_file_of_two(tmp_path, capsys):
    """--track lifts one person's rows: the .trc a file of that person alone gives."""
    from sparseedm.lifting.trc import read_trc

    rows = _example_rows()
    run = tmp_path / "run.trc"
    argv = ["lift", str(EXAMPLES / "video_clip.csv"), "-o", str(run), "--track", "02_05",
            "--no-adapt", "-q"]
    assert main(argv) == 0
    alone = _write_rows(tmp_path / "alone.csv", [r for r in rows if r["track"] == "02_05"])
    assert main(["lift", str(alone), "-o", str(tmp_path / "alone.trc"), "--no-adapt",
                 "-q"]) == 0
    got, want = read_trc(run), read_trc(tmp_path / "alone.trc")
    frames = sorted(int(r["frame"]) for r in rows if r["track"] == "02_05")
    np.testing.assert_array_equal(got["frames"], np.asarray(frames) + 1)
    np.testing.assert_array_equal(got["poses"], want["poses"])


@pytest.mark.parametrize("source, track, words", [
    ("video_clip.csv", "02_09", "has no track '02_09'; its tracks: '02_01', '02_05'"),
    ("occluded_poses.csv", "1", "has no track ids")])
def test_lift_track_refuses_a_track_the_input_lacks(tmp_path, capsys, source, track, words):
    out = tmp_path / "p.trc"
    assert main(["lift", str(EXAMPLES / source), "-o", str(out), "--track", track, "-q"]) == 2
    err = capsys.readouterr().err
    assert "--track" in err and words in err
    assert not out.exists()


def test_lift_track_errors_file_names_the_inputs_rows(tmp_path, capsys):
    rows = _example_rows()
    first = [i for i, r in enumerate(rows) if r["track"] == "02_05"]
    bad = first[3]  # a pose of no joint at all: refused
    for key in rows[bad]:
        if key.endswith(("_x", "_y")):
            rows[bad][key] = ""
    src = _write_rows(tmp_path / "two.csv", rows)
    out = tmp_path / "p.csv"
    assert main(["lift", str(src), "-o", str(out), "--track", "02_05", "--no-temporal",
                 "-q"]) == 1
    with open(tmp_path / "p.errors.csv", newline="") as f:
        errors = list(csv.DictReader(f))
    assert [int(e["row"]) for e in errors] == [bad]
    with open(out, newline="") as f:
        assert {r["track"] for r in csv.DictReader(f)} == {"02_05"}


def test_a_video_with_unreadable_frame_numbers_still_writes_a_pickle_free_npz(tmp_path):
    rows = _example_rows()[:40]
    rows[3]["frame"], rows[5]["frame"] = "nan", ""  # read as text: an object array
    src = _write_rows(tmp_path / "v.csv", rows)
    assert main(["lift", str(src), "-o", str(tmp_path / "out.npz"), "-q"]) == 0
    with np.load(tmp_path / "out.npz", allow_pickle=False) as z:
        assert z["frames"].tolist()[:6] == ["0", "1", "2", "nan", "4", ""]
        assert z["poses3d"].shape == (40, 14, 3)


@pytest.mark.parametrize("ext", ["npz", "csv"])
def test_frame_numbers_past_2_53_lift_frame_by_frame(tmp_path, ext):
    """uint64 frames past the int64 limit (npz) or of 19 digits (csv) are refused
    per row as too large, never an internal error."""
    from sparseedm.keypoints import KeypointSet, write_keypoints

    kps = read_keypoints(EXAMPLES / "video_clip.csv")
    n = len(kps.poses)
    frames = np.arange(n, dtype=np.uint64)  # npz: across the int64 limit, in one track
    frames += np.uint64(2**63 - n // 2) if ext == "npz" else np.uint64(2**62)
    src = write_keypoints(tmp_path / f"v.{ext}", KeypointSet(
        kps.poses, kps.missing, ids=kps.ids, tracks=kps.tracks, frames=frames))
    assert main(["lift", str(src), "-o", str(tmp_path / "out.npz"), "-q"]) == 0
    back = read_keypoints(src)
    res = sparseedm.lift(back.poses, back.missing, tracks=back.tracks, frames=back.frames)
    assert res.ok.all() and all("too large" in r for r in res.reason), res.reason[:3]


def test_lift_says_who_is_who_when_it_links_people(track):
    """Two people per frame without track ids: lift links them (as recover does)
    and its result says which rows it linked into which track."""
    n = 60
    truth = np.concatenate([track[:n], track[n:2 * n] + [250.0, 0.0]])
    person = np.repeat([0, 1], n)
    frames = np.concatenate([np.arange(n), np.arange(n)])
    order = np.lexsort((np.random.default_rng(0).random(2 * n), frames))
    poses = truth[order].copy()
    poses[20:30, 4] = np.nan
    res = sparseedm.lift(poses, frames=frames[order])
    assert res.linked_tracks is not None and res.linked_tracks.shape == (2 * n,)
    pairs = set(zip(res.linked_tracks.tolist(), person[order].tolist()))
    assert len(pairs) == 2  # each linked track is one person
    assert sparseedm.lift(poses, tracks=person[order], frames=frames[order]).linked_tracks is None


def test_lift_file_takes_the_2d_fill_settings_recover_takes(tmp_path):
    """sparseedm lift --no-adapt / --dictionary / --self-training: the 2D
    dictionary that fills a video's joints first, as lift(fill_adapt=False)
    with it; refused where nothing is filled (no time) or contradictory."""
    from sparseedm.lifting import io as lift_io

    src = EXAMPLES / "video_clip.csv"
    kps = read_keypoints(src)
    lift_io.lift_file(src, tmp_path / "a.npz", adapt=False, dictionary="cmu-k2000")
    api = sparseedm.lift(kps.poses, kps.missing, tracks=kps.tracks, frames=kps.frames,
                         dictionary="cmu-k2000", fill_adapt=False)
    with np.load(tmp_path / "a.npz") as z:
        np.testing.assert_allclose(z["poses3d"], api.poses3d, rtol=0, atol=1e-9)
    with pytest.raises(SparseEDMError, match="only fills a video"):
        lift_io.lift_file(src, tmp_path / "b.npz", adapt=False, temporal=False)
    with pytest.raises(SparseEDMError, match="needs adaptation"):
        lift_io.lift_file(src, tmp_path / "b.npz", adapt=False, self_training=1)
    assert not (tmp_path / "b.npz").exists()
    with pytest.raises(SystemExit) as exc:  # argparse: mutually exclusive
        main(["lift", str(src), "-o", str(tmp_path / "c.csv"), "--no-adapt",
              "--self-training", "2"])
    assert exc.value.code == 2
