"""Real-people protocols: transplanted masks, scores, evaluate_photos / evaluate_tracks
and `sparseedm evaluate --protocol photos|video-real` (no ../shared needed)."""

import json

import numpy as np
import pytest

from sparseedm.cli import main
from sparseedm.evaluation_real import (PHOTO_METHODS, evaluate_photos, evaluate_tracks,
                                       track_clips, video_methods)
from sparseedm.exceptions import PoseError
from sparseedm.keypoints import write_keypoints
from sparseedm.normalize import MIN_OBSERVED_JOINTS
from sparseedm.real_protocol import (JOINT_GROUPS, body_size, error_summary, group_summaries,
                                     hidden_errors, transplant_masks, transplant_track_mask)


def _pool():
    pool = np.zeros((4, 14), bool)
    pool[0, [4, 7]] = True                 # both wrists
    pool[1, 10] = True                     # right ankle
    pool[2, :12] = True                    # only 2 observed: never drawn
    return pool                            # row 3 hides nothing: never drawn


# ---------------------------------------------------------------- masks


def test_transplanted_masks_are_pool_patterns_keeping_three_joints():
    pool = _pool()
    masks, donors = transplant_masks(500, pool, random_state=0)
    assert masks.shape == (500, 14) and donors.shape == (500,)
    assert set(donors.tolist()) == {0, 1}
    assert (masks == pool[donors]).all()
    assert ((~masks).sum(axis=1) >= MIN_OBSERVED_JOINTS).all()
    assert (masks.sum(axis=1) >= 1).all()


def test_transplanted_masks_are_seeded():
    pool = _pool()
    a = transplant_masks(200, pool, random_state=3)[1]
    assert (a == transplant_masks(200, pool, random_state=3)[1]).all()
    assert (a != transplant_masks(200, pool, random_state=4)[1]).any()


def test_transplant_without_a_usable_pattern_is_refused():
    pool = np.zeros((2, 14), bool)
    pool[0, :12] = True
    with pytest.raises(PoseError, match="no pool pattern"):
        transplant_masks(3, pool)


def test_track_mask_is_a_window_of_a_donor_with_three_joints_left():
    long = np.zeros((60, 14), bool)
    long[10:25, 3] = True
    long[40:42] = True
    long[40:42, 3] = False                 # frames with one joint left: two come back
    empty = np.zeros((80, 14), bool)       # hides nothing: never the donor
    for seed in range(5):
        mask, k = transplant_track_mask(50, [empty, long], random_state=seed)
        assert k == 1 and mask.shape == (50, 14)
        assert ((~mask).sum(axis=1) >= MIN_OBSERVED_JOINTS).all()
        assert not (mask & ~np.any([(long[s:s + 50]) for s in range(11)], axis=0)).any()
        offsets = [s for s in range(11) if (mask[:, 3] == long[s:s + 50, 3]).all()]
        assert offsets, "joint 3's run is a window of the donor's"
    short = np.zeros((5, 14), bool)
    short[1:4, 7] = True
    mask, _ = transplant_track_mask(40, [short], random_state=1)
    assert mask.sum() == 3 and mask[:, 7].sum() == 3


def test_track_mask_needs_a_donor_with_a_missing_joint():
    with pytest.raises(PoseError, match="no donor"):
        transplant_track_mask(10, [np.zeros((20, 14), bool)])


# ---------------------------------------------------------------- scores


def test_known_displacement_gives_known_percentage_and_pckh():
    truth = np.zeros((2, 14, 2))
    truth[:, 0] = [0.0, -200.0]            # head top 200 px above the ankles
    filled = truth.copy()
    filled[0, 4] += [30.0, 40.0]           # 50 px: 25 % of 200 px
    filled[1, 0] += [0.0, 10.0]            # 10 px: 5 %
    missing = np.zeros((2, 14), bool)
    missing[0, 4] = missing[1, 0] = True
    size = body_size(truth)
    assert size.tolist() == [200.0, 200.0]
    e = hidden_errors(filled, truth, missing, size, head_size=[60.0, 60.0])
    assert e.error.tolist() == [25.0, 5.0]
    assert e.hit.tolist() == [0.0, 1.0]    # 50 > 0.5 x 60 >= 10
    rows = {r["group"]: r for r in group_summaries(e)}
    assert rows["wrists"]["mean"] == 25.0 and rows["wrists"]["pckh"] == 0.0
    assert rows["head"]["mean"] == 5.0 and rows["head"]["pckh"] == 1.0
    assert rows["overall"]["mean"] == 15.0 and rows["overall"]["median"] == 15.0
    assert rows["overall"]["pckh"] == 0.5 and rows["knees"]["n"] == 0
    assert list(rows) == list(JOINT_GROUPS) + ["overall"]
    no_head = hidden_errors(filled, truth, missing, size)
    assert np.isnan(error_summary(no_head.error, no_head.hit)["pckh"])


def test_unfilled_joints_are_counted_not_scored():
    s = error_summary(np.array([2.0, np.nan, 4.0]), np.full(3, np.nan),
                      keep=np.array([True, True, False]))
    assert (s["n"], s["scored"], s["unfilled"], s["mean"]) == (3, 1, 1, 2.0)
    assert s["mean_own"] == 3.0            # every finite error, pooled or not


# ---------------------------------------------------------------- photos


@pytest.fixture(scope="module")
def photos(cmu_poses):
    pool = np.zeros((3, 14), bool)
    pool[:, [4, 7]] = True                 # every transplanted pattern: both wrists
    return cmu_poses[:120], pool


def test_photos_hide_the_pool_patterns_and_report_sizes(photos, strict_json):
    poses, pool = photos
    rep = evaluate_photos(poses, pool, n_complete=100, n_occluded=100,
                          methods=["mean-fill", "nearest", "knn"])
    s = rep.settings
    assert (s["n_complete"], s["n_occluded"]) == (60, 60)   # scaled to the 120 poses
    assert rep.conditions == ["mix", "transplanted"]
    assert rep.row("nearest", "transplanted", "wrists")["n"] == 120
    assert rep.row("nearest", "transplanted", "overall")["n"] == 120
    mix = rep.row("nearest", "mix", "overall")
    assert 60 <= mix["n"] <= 180 and mix["scored"] == mix["n"]
    assert mix["mean"] < rep.row("mean-fill", "mix", "overall")["mean"]
    assert np.isnan(mix["pckh"])
    again = evaluate_photos(poses, pool, n_complete=100, n_occluded=100,
                            methods=["mean-fill", "nearest", "knn"])
    assert json.dumps(again.rows) == json.dumps(rep.rows)   # NaN PCKh compared as text
    # its JSON is strict: the NaN PCKh (no head sizes) is null, JSON.parse reads it
    doc = strict_json(rep.to_json())
    assert doc["rows"] == json.loads(json.dumps(rep.rows).replace("NaN", "null"))
    assert [r["pckh"] for r in doc["rows"]] == [None] * len(rep.rows)


def test_photos_every_method_with_head_sizes(photos, small_dictionary):
    poses, pool = photos
    rep = evaluate_photos(poses, pool, conditions=[2], head_size=np.full(len(poses), 1e6),
                          dictionary=small_dictionary)
    assert rep.methods == list(PHOTO_METHODS)
    for m in PHOTO_METHODS:
        r = rep.row(m, "2")
        assert r["n"] == 120 and r["pckh"] == 1.0 and np.isfinite(r["mean"])
    assert rep.settings["notes"][0].startswith("2: sparseedm not adapted")


def test_photos_complete_poses_from_elsewhere(photos, cmu_poses):
    poses, pool = photos
    rep = evaluate_photos(poses[:30], pool, complete=cmu_poses[200:], n_complete=80,
                          conditions=["transplanted"], methods=["nearest"])
    assert (rep.settings["n_complete"], rep.settings["n_occluded"]) == (80, 30)
    assert rep.row("nearest", "transplanted", "wrists")["n"] == 60


def test_photos_without_a_pool_skip_transplanted(photos):
    rep = evaluate_photos(photos[0], None, methods=["mean-fill"])
    assert rep.conditions == ["mix"] and "transplanted: skipped" in rep.settings["notes"][0]
    with pytest.raises(PoseError, match="complete"):
        evaluate_photos(np.full((4, 14, 2), np.nan), methods=["mean-fill"])


# ---------------------------------------------------------------- video


def _still_tracks():
    """Two still people (40 and 35 frames) and a short track hiding joint 7 in 5 frames."""
    base = np.zeros((14, 2))
    base[0] = [0.0, -170.0]
    base[:, 0] += np.arange(14)
    poses = np.concatenate([np.repeat(base[None], 40, 0), np.repeat(base[None], 35, 0) + 50,
                            np.repeat(base[None], 10, 0)])
    tracks = np.repeat([0, 1, 2], [40, 35, 10])
    frames = np.concatenate([np.arange(40), np.arange(35) + 7, np.arange(10)])
    poses[75 + 2:75 + 7, 7] = np.nan
    return poses, tracks, frames


def test_clips_are_complete_consecutive_runs():
    poses, tracks, frames = _still_tracks()
    clips = track_clips(poses, tracks, frames, min_frames=30)
    assert [(int(t), len(r)) for t, r in clips] == [(0, 40), (1, 35)]
    holed = poses.copy()
    holed[20, 3] = np.nan
    assert [len(r) for _, r in track_clips(holed, tracks, frames, min_frames=15)] == \
        [20, 19, 35]


def test_tracks_still_people_are_exact_for_interpolation():
    poses, tracks, frames = _still_tracks()
    rep = evaluate_tracks(poses, tracks, frames, gap_lengths=(3, 10),
                          methods=["linear", "akima"])
    assert rep.conditions == ["gaps", "transplanted"]
    for m in ("linear", "akima"):
        for cond in rep.conditions:
            r = rep.row(m, cond)
            assert r["n"] > 0 and r["mean"] == 0.0
    # the only donor is the short track: 5 frames of joint 7 on each of the two clips
    assert rep.row("linear", "transplanted", "1-5")["n"] == 10
    assert rep.row("linear", "transplanted", "overall")["n"] == 10
    assert rep.settings["clips"] == 2


def test_tracks_score_the_jump_at_gap_edges(monkeypatch):
    """A fill that is 3 px off where the truth is still jumps 3 px at every edge
    of every gap (in % of the clip's body size); interpolation does not jump."""
    from sparseedm.real_protocol import body_size
    from sparseedm.temporal import fillers

    def shifted(poses, missing, frames):
        out = fillers.fill_linear(poses, missing, frames)
        out[missing] += [3.0, 0.0]
        return out

    monkeypatch.setitem(fillers.FILLERS, "shifted", shifted)
    poses, tracks, frames = _still_tracks()
    rep = evaluate_tracks(poses, tracks, frames, gap_lengths=(3, 10),
                          methods=["linear", "shifted"])
    size = float(body_size(poses[:1])[0])
    for cond in rep.conditions:
        lin, off = rep.row("linear", cond), rep.row("shifted", cond)
        assert lin["edges"] == off["edges"] > 0
        assert lin["edge_jump"] == 0.0
        assert off["edge_jump"] == pytest.approx(3.0 / size * 100.0)
    # at most two edges per gap of 3 frames (fewer where gaps touch or meet a clip end)
    gap3 = rep.row("linear", "gaps", "gap 3")
    assert 0 < gap3["edges"] <= 2 * gap3["n"] / 3
    assert "| edge jump |" in rep.table("gaps").splitlines()[0]
    assert "edge_jump" in rep.to_csv().splitlines()[0]


def test_tracks_edges_only_where_every_method_filled(monkeypatch, strict_json):
    """A method that leaves joint 7 unfilled: the edges are counted where every method
    filled, so fewer than linear's alone; where none is left (the transplanted runs are
    all joint 7) the table's edge-jump cell is blank, as an error cell without a joint,
    not 'nan', and the CSV says NaN, the JSON null (strict JSON), with 0 edges."""
    from sparseedm.temporal import fillers

    def holey(poses, missing, frames):
        out = fillers.fill_linear(poses, missing, frames)
        out[missing[:, 7], 7] = np.nan
        return out

    monkeypatch.setitem(fillers.FILLERS, "holey", holey)
    poses, tracks, frames = _still_tracks()
    alone = evaluate_tracks(poses, tracks, frames, gap_lengths=(3,), methods=["linear"])
    rep = evaluate_tracks(poses, tracks, frames, gap_lengths=(3,), methods=["linear", "holey"])
    both = rep.row("linear", "gaps")["edges"]
    assert rep.row("holey", "gaps")["edges"] == both
    assert 0 < both < alone.row("linear", "gaps")["edges"]
    assert alone.row("linear", "transplanted")["edges"] > 0
    assert rep.row("holey", "transplanted")["edges"] == 0
    holey_line = [line for line in rep.table("transplanted").splitlines()
                  if line.startswith("| holey |")][0]
    assert "nan" not in holey_line and holey_line.endswith("|  | 0.0 |")
    assert "| 0 edges |" in rep.table("transplanted")
    csv_rows = [line for line in rep.to_csv().splitlines() if line.startswith("holey,trans")]
    assert csv_rows[-1].endswith(",0,nan")
    doc = strict_json(rep.to_json())
    last = [r for r in doc["rows"] if r["method"] == "holey"][-1]
    assert last["edges"] == 0 and last["edge_jump"] is None


def test_tracks_note_a_gap_longer_than_every_clip():
    """Gaps of a length no clip can hold leave nothing to score: a note says so
    (before, the report came back empty without a word)."""
    poses, tracks, frames = _still_tracks()
    rep = evaluate_tracks(poses, tracks, frames, gap_lengths=(3, 40), transplanted=False,
                          methods=["linear"])
    assert rep.row("linear", "gaps", "gap 3")["n"] > 0
    assert rep.row("linear", "gaps", "gap 40")["n"] == 0
    assert rep.settings["notes"] == ["gap 40: no clip longer than 40 frames (the longest has "
                                     "40), so no gap of 40 frames"]


def test_tracks_edge_jump_counts_only_moving_farther(monkeypatch):
    """On a joint moving steadily, a fill spread out from each gap's centre steps
    less than the truth at both edges of a short gap: its excess jump is 0 there,
    not negative (a lag at one edge cannot offset a jump at another)."""
    from sparseedm.temporal import fillers
    from sparseedm.temporal.evaluation import edge_jumps

    def spread(poses, missing, frames):
        lin = fillers.fill_linear(poses, missing, frames)
        out = lin.copy()
        for j in range(missing.shape[1]):
            starts = np.flatnonzero(np.diff(np.r_[0, missing[:, j].astype(int)]) == 1)
            ends = np.flatnonzero(np.diff(np.r_[missing[:, j].astype(int), 0]) == -1)
            for a, e in zip(starts, ends):
                if a > 0 and e + 1 < len(poses):
                    centre = (lin[a - 1, j] + lin[e + 1, j]) / 2
                    out[a:e + 1, j] = centre + 1.5 * (lin[a:e + 1, j] - centre)
        return out

    monkeypatch.setitem(fillers.FILLERS, "spread", spread)
    poses, tracks, frames = _still_tracks()
    poses = poses + (frames * 2.0)[:, None, None] * [1.0, 0.0]   # 2 px a frame in x
    rep = evaluate_tracks(poses, tracks, frames, gap_lengths=(3,), transplanted=False,
                          methods=["linear", "spread"])
    assert rep.row("spread", "gaps")["edges"] > 0
    assert rep.row("spread", "gaps")["edge_jump"] == 0.0
    assert rep.row("spread", "gaps")["mean"] > 0.0
    # the signed excess at those edges is negative: it moved less than the truth
    clip = poses[:40]
    mask = np.zeros((40, 14), bool); mask[10:13, 4] = True
    given = np.where(mask[..., None], np.nan, clip)
    signed = edge_jumps(clip, spread(given, mask, frames[:40]), mask, frames[:40])
    assert np.nanmax(signed) < 0


def test_tracks_with_sparseedm_and_a_clip_sample(small_dictionary):
    poses, tracks, frames = _still_tracks()
    rep = evaluate_tracks(poses, tracks, frames, gap_lengths=(10,), max_clips=1,
                          methods=["sparseedm", "per-frame", "linear"],
                          dictionary=small_dictionary, head_size=np.full(len(poses), 40.0))
    assert rep.settings["clips"] == 1 and "sample of 1 of 2" in rep.settings["notes"][0]
    r = rep.row("sparseedm", "gaps", "gap 10")
    assert r["n"] > 0 and np.isfinite(r["mean"]) and r["pckh_n"] == r["scored"]


def test_tracks_name_a_frame_given_twice():
    """A tracker's duplicate (the same track and frame twice) is refused naming
    the track, the frame and the two rows, so the user can find them."""
    poses, tracks, frames = _still_tracks()
    frames = frames.copy()
    frames[12] = frames[11]
    with pytest.raises(PoseError, match=rf"track 0: frame {frames[11]} is given twice "
                                        r"\(rows 11 and 12\)"):
        evaluate_tracks(poses, tracks, frames, methods=["linear"])


def test_tracks_refuse_an_unknown_method():
    from sparseedm.exceptions import ParameterError

    poses, tracks, frames = _still_tracks()
    with pytest.raises(ParameterError, match="'spline'.*per-frame") as err:
        evaluate_tracks(poses, tracks, frames, methods=["linear", "spline"])
    assert str(err.value).count("kalman") == 1  # named once, not as its own and a filler
    with pytest.raises(ParameterError, match="no method given; give one or more of "
                                             "sparseedm, per-frame"):
        evaluate_tracks(poses, tracks, frames, methods=[])


def test_video_methods_include_kalman_when_the_fillers_have_it(monkeypatch):
    from sparseedm.temporal import fillers

    monkeypatch.delattr(fillers, "fill_kalman", raising=False)
    assert "kalman" not in video_methods()
    monkeypatch.setattr(fillers, "fill_kalman", fillers.fill_linear, raising=False)
    assert video_methods()[-1] == "kalman"


# ---------------------------------------------------------------- CLI


def test_cli_photos(tmp_path, cmu_poses, capsys, strict_json):
    poses = cmu_poses[:150].copy()
    poses[120:, 9] = np.nan                # 30 incomplete poses: the transplanted pattern
    data = tmp_path / "people.csv"
    write_keypoints(data, poses)
    out = tmp_path / "rep"
    code = main(["evaluate", "--protocol", "photos", "--data", str(data), "-o", str(out),
                 "--methods", "mean-fill,nearest", "--poses", "50,40"])
    assert code == 0
    text = capsys.readouterr().out
    assert "50 complete + 40 occluded" in text and "| nearest |" in text
    doc = strict_json((out / "photos.json").read_text())  # no head sizes: PCKh null
    knees = [r for r in doc["rows"] if r["condition"] == "transplanted"
             and r["group"] == "knees" and r["method"] == "nearest"]
    assert knees[0]["n"] == 40
    assert (out / "photos.csv").read_text().startswith("method,condition,group,n,")


def test_cli_photos_no_adapt_is_recovers_no_adapt(tmp_path, cmu_poses, capsys, strict_json):
    # the command's sparseedm-no-adapt row is `recover --no-adapt` (no dictionary given:
    # the CMU + COCO prior, mirror image and pose bank), not the default dictionary alone
    poses = cmu_poses[:60].copy()
    poses[50:, 9] = np.nan
    data = tmp_path / "people.csv"
    write_keypoints(data, poses)
    row = dict(method="sparseedm-no-adapt", condition="mix", group="overall")

    def overall(rows):
        return next(r["mean"] for r in rows if all(r[k] == v for k, v in row.items()))

    args = ["evaluate", "--protocol", "photos", "--data", str(data), "--methods",
            "sparseedm-no-adapt", "--conditions", "mix", "--poses", "25,25"]
    assert main(args + ["-o", str(tmp_path / "a")]) == 0
    assert main(args + ["-o", str(tmp_path / "b"), "--dictionary", "default"]) == 0
    capsys.readouterr()
    cli = overall(strict_json((tmp_path / "a" / "photos.json").read_text())["rows"])
    alone = overall(strict_json((tmp_path / "b" / "photos.json").read_text())["rows"])
    complete = ~np.isnan(poses).any(axis=(1, 2))
    api = evaluate_photos(poses[complete], np.isnan(poses[~complete, :, 0]), n_complete=25,
                          n_occluded=25, conditions=("mix",),
                          methods=("sparseedm-no-adapt",))
    assert cli == pytest.approx(overall(api.rows))
    assert cli != pytest.approx(alone)


def test_cli_video_real(tmp_path, capsys, strict_json):
    poses, tracks, frames = _still_tracks()
    data = tmp_path / "clip.csv"
    write_keypoints(data, poses, tracks=tracks.astype(str), frames=frames)
    out = tmp_path / "rep"
    assert main(["evaluate", "--protocol", "video-real", "--data", str(data), "-o", str(out),
                 "--methods", "linear", "--gap-lengths", "3"]) == 0
    text = capsys.readouterr().out
    assert "2 clips" in text and "| linear |" in text and "| edge jump |" in text
    assert "edge jump: how much farther the filled joints move" in text
    doc = strict_json((out / "video-real.json").read_text())
    assert doc["settings"]["clips"] == 2
    assert {r["condition"] for r in doc["rows"]} == {"gaps", "transplanted"}
    still = tmp_path / "photo.csv"
    write_keypoints(still, poses)
    assert main(["evaluate", "--protocol", "video-real", "--data", str(still), "-o",
                 str(out)]) == 2
    assert "no frame numbers" in capsys.readouterr().err
