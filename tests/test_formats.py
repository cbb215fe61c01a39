"""Detector and tracker formats: OpenPose, MMPose, AlphaPose, DeepLabCut, PoseTrack.

Fixtures: tests/fixtures/formats (made by make_formats.py from the formats'
documented layouts). Round trips go read -> recover -> write -> read.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import stat
import warnings
from pathlib import Path

import numpy as np
import pytest

from sparseedm.batch import recover_file
from sparseedm.exceptions import FileFormatError, OutputPathError
from sparseedm import formats
from sparseedm.formats import DEFAULT_THRESHOLDS, detect
from sparseedm.formats._base import FILLED_LIKELIHOOD_CAP
from sparseedm.keypoints import read_keypoints, write_keypoints
from sparseedm.skeleton import JOINT_NAMES

F = Path(__file__).resolve().parent / "fixtures" / "formats"
MAP = F / "dlc_joints.json"
NECK, HEAD_TOP = JOINT_NAMES.index("neck"), JOINT_NAMES.index("head_top")
RW, LW = JOINT_NAMES.index("right_wrist"), JOINT_NAMES.index("left_wrist")


def digest(path):
    path = Path(path)
    files = sorted(path.rglob("*")) if path.is_dir() else [path]
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest() for p in files if p.is_file()}


def needs_pandas():
    pytest.importorskip("pandas", reason="DeepLabCut .h5 needs the dlc extra (pandas)")
    pytest.importorskip("tables", reason="DeepLabCut .h5 needs the dlc extra (PyTables)")


# --------------------------------------------------------------------------
# round trips through recover_file, one per format

CASES = {
    "openpose-folder": (F / "openpose", "out", {}, 0.05),
    "openpose-file": (F / "openpose" / "video_000000000001_keypoints.json", "out.json", {},
                      0.05),
    "mmpose": (F / "mmpose_predictions.json", "out.json", {}, 0.3),
    "alphapose-halpe26": (F / "alphapose_halpe26.json", "out.json", {}, 0.3),
    "alphapose-coco17": (F / "alphapose_coco17.json", "out.json", {}, 0.3),
    "dlc-csv": (F / "dlc.csv", "out.csv", {"joint_map": MAP}, 0.6),
    "dlc-h5": (F / "dlc.h5", "out.h5", {"joint_map": MAP}, 0.6),
    "dlc-multi": (F / "dlc_multi.csv", "out.csv", {"joint_map": MAP}, 0.6),
}


@pytest.mark.parametrize("case", CASES)
def test_round_trip_fills_and_flags_every_occluded_joint(case, tmp_path, small_dictionary):
    src, name, kw, threshold = CASES[case]
    if src.suffix == ".h5":
        needs_pandas()
    before = digest(src)
    first = read_keypoints(src, confidence_threshold=threshold, **kw)
    assert first.missing.any(), "the fixture has occluded joints"
    out = tmp_path / name
    summary = recover_file(src, out, dictionary=small_dictionary, adapt=False,
                           confidence_threshold=threshold, **kw)
    assert summary["refused"] == 0 and summary["recovered_joints"] == first.missing.sum()
    assert digest(src) == before, "the input was changed"
    # a DeepLabCut table (no room for flags) too: its flags are read from the sidecar
    back = read_keypoints(out, confidence_threshold=threshold, **kw)
    assert back.meta["format"] == first.meta["format"]
    assert not back.missing.any(), "every occluded joint is filled"
    np.testing.assert_array_equal(back.filled, first.missing)
    observed = ~first.missing
    np.testing.assert_allclose(back.poses[observed], first.poses[observed])
    assert np.isfinite(back.poses).all()
    np.testing.assert_array_equal(back.tracks, first.tracks)
    np.testing.assert_array_equal(back.frames, first.frames)
    if case != "openpose-file":  # an OpenPose pose's id is its file's name
        np.testing.assert_array_equal(back.ids, first.ids)
    # filled joints carry the filled score, never a detection's; DeepLabCut's
    # likelihood says how sure the fill is, below its default cutoff
    if back.meta["format"] == "dlc":
        like = back.confidence[first.missing]
        assert ((0 < like) & (like <= FILLED_LIKELIHOOD_CAP)).all()
        assert FILLED_LIKELIHOOD_CAP < DEFAULT_THRESHOLDS["dlc"]
    else:
        np.testing.assert_array_equal(back.confidence[first.missing], 0.0)


def test_openpose_folder_round_trip_writes_the_same_files(tmp_path, small_dictionary):
    out = tmp_path / "op"
    recover_file(F / "openpose", out, dictionary=small_dictionary, adapt=False)
    assert sorted(p.name for p in out.iterdir()) == \
        sorted([".sparseedm-output"] + [p.name for p in (F / "openpose").iterdir()])
    doc = json.loads((out / "video_000000000001_keypoints.json").read_text())
    person = doc["people"][0]
    assert person["sparseedm"]["filled"] == ["right_wrist"]
    assert person["sparseedm"]["status"] == "recovered"
    assert person["pose_keypoints_2d"][3 * 4 + 2] == 0.0  # RWrist: filled score
    assert person["pose_keypoints_2d"][3 * 4] != 0.0
    # a second run replaces the earlier output folder
    recover_file(F / "openpose", out, dictionary=small_dictionary, adapt=False)
    assert len(list(out.glob("*.json"))) == 4


def test_openpose_output_never_the_input_folder(tmp_path, small_dictionary):
    folder = tmp_path / "in"
    shutil.copytree(F / "openpose", folder)
    before = digest(folder)
    with pytest.raises(OutputPathError, match="refusing to overwrite"):
        recover_file(folder, folder, dictionary=small_dictionary, adapt=False)
    assert digest(folder) == before


def test_openpose_folder_to_one_json_is_refused_before_work(tmp_path, small_dictionary):
    with pytest.raises(FileFormatError, match="written as a folder"):
        recover_file(F / "openpose", tmp_path / "x.json", dictionary=small_dictionary,
                     adapt=False)
    assert list(tmp_path.iterdir()) == []


def _no_work(monkeypatch):
    """Recovery that fails the test if it starts: a refusal must come first."""
    import sparseedm.batch

    def started(*a, **k):
        raise AssertionError("the work started before the output was checked")

    monkeypatch.setattr(sparseedm.batch, "_run", started)
    monkeypatch.setattr(sparseedm.batch, "_adapt", started)


@pytest.mark.parametrize("kind", ["user files", "another clip", "marked, then added to"])
def test_folder_output_replaces_only_a_folder_sparseedm_wrote(tmp_path, small_dictionary,
                                                               monkeypatch, kind):
    out = tmp_path / "out"
    if kind == "user files":
        out.mkdir()
        (out / "config.json").write_text('{"my": "settings"}')
    elif kind == "another clip":
        shutil.copytree(F / "openpose", out)
    else:
        recover_file(F / "openpose", out, dictionary=small_dictionary, adapt=False)
        (out / "notes.json").write_text("{}")
    before = digest(out)
    _no_work(monkeypatch)
    with pytest.raises(OutputPathError, match="did not write.*refusing to replace it"):
        recover_file(F / "openpose", out, dictionary=small_dictionary, adapt=False)
    assert digest(out) == before


def test_folder_output_into_an_empty_folder_with_the_usual_mode(tmp_path, small_dictionary):
    out = tmp_path / "out"
    out.mkdir()
    umask = os.umask(0o022)
    try:
        recover_file(F / "openpose", out, dictionary=small_dictionary, adapt=False)
    finally:
        os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o755  # not mkdtemp's 0700
    assert stat.S_IMODE((out / "video_000000000001_keypoints.json").stat().st_mode) == 0o644
    mark = json.loads((out / ".sparseedm-output").read_text())
    assert sorted(mark["files"]) == sorted(p.name for p in out.glob("*.json"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporaries left


# --------------------------------------------------------------------------
# OpenPose


def _person(n_keypoints, pid=-1, score=0.8, **points):
    kp = np.zeros((n_keypoints, 3))
    kp[:, :2] = np.arange(n_keypoints * 2).reshape(-1, 2) + 100
    kp[:, 2] = score
    for k, xy in points.items():
        kp[int(k[1:]), :2] = xy
    return {"person_id": [pid], "pose_keypoints_2d": kp.ravel().tolist()}


def _frame(path, *people):
    path.write_text(json.dumps({"version": 1.3, "people": list(people)}))
    return path


def test_openpose_layouts_map_by_their_documented_order(tmp_path):
    # BODY_25: Neck (1) is the neck; RWrist is 4, LAnkle 14
    k = read_keypoints(_frame(tmp_path / "a_000000000005_keypoints.json", _person(25)))
    assert k.poses[0, NECK].tolist() == [102, 103]
    assert k.poses[0, RW].tolist() == [108, 109]
    assert k.poses[0, JOINT_NAMES.index("left_ankle")].tolist() == [128, 129]
    assert k.frames.tolist() == [5] and k.ids.tolist() == ["a_000000000005"]
    # COCO-18: RHip is 8 (BODY_25 has MidHip there)
    k = read_keypoints(_frame(tmp_path / "b_keypoints.json", _person(18)))
    assert k.poses[0, JOINT_NAMES.index("right_hip")].tolist() == [116, 117]
    # BODY_135: COCO order, HeadTop (18) is the head top, neck = shoulders' midpoint
    k = read_keypoints(_frame(tmp_path / "c_keypoints.json", _person(135)))
    assert k.poses[0, HEAD_TOP].tolist() == [136, 137]
    assert k.poses[0, NECK].tolist() == [(110 + 112) / 2, (111 + 113) / 2]


def test_openpose_before_1_2_names_its_keypoints_pose_keypoints(tmp_path):
    """OpenPose before 1.2 wrote ``pose_keypoints``: read as ``pose_keypoints_2d``
    is, and written back under its own name."""
    new = read_keypoints(_frame(tmp_path / "n_keypoints.json", _person(25)))
    person = _person(25)
    person["pose_keypoints"] = person.pop("pose_keypoints_2d")
    old = read_keypoints(_frame(tmp_path / "o_keypoints.json", person))
    np.testing.assert_array_equal(old.poses, new.poses)
    write_keypoints(tmp_path / "back_keypoints.json", old)
    back = json.loads((tmp_path / "back_keypoints.json").read_text())["people"][0]
    assert "pose_keypoints" in back and "pose_keypoints_2d" not in back
    np.testing.assert_array_equal(read_keypoints(tmp_path / "back_keypoints.json").poses,
                                  new.poses)


def test_openpose_person_without_body_keypoints_names_its_keys(tmp_path):
    path = _frame(tmp_path / "k_keypoints.json", {"person_id": [-1], "pose": [1, 2]})
    with pytest.raises(FileFormatError, match=r"people\[0\] has no 'pose_keypoints_2d' "
                                              r"\(its keys: 'person_id', 'pose'\)"):
        read_keypoints(path)


@pytest.mark.parametrize("whole", [False, True])
def test_mmpose_inferencer_results_saved_whole_say_how_to_save_them(tmp_path, whole):
    """``{"predictions": [[instance]], "visualization": []}`` (or a list of them)
    is refused, saying what the inferencer should write instead."""
    instance = {"keypoints": [[100.0 + k, 200.0] for k in range(17)],
                "keypoint_scores": [0.9] * 17}
    result = {"predictions": [[instance]], "visualization": []}
    path = tmp_path / "results.json"
    path.write_text(json.dumps([result, result] if whole else result))
    with pytest.raises(FileFormatError, match=r"results\.json: not an MMPose .* "
                                              r"pred_out_dir=.*result\['predictions'\]\[0\]"):
        read_keypoints(path)
    path.write_text(json.dumps(result["predictions"][0]))  # one image's instances: read
    assert len(read_keypoints(path)) == 1


def test_openpose_people_and_tracks(tmp_path):
    empty = read_keypoints(_frame(tmp_path / "e_keypoints.json"))
    assert len(empty) == 0
    two = read_keypoints(_frame(tmp_path / "t_keypoints.json", _person(25), _person(25)))
    assert len(two) == 2 and two.tracks is None  # no ids: persons cannot be told apart
    d = tmp_path / "tracked"
    d.mkdir()
    for f in range(3):
        _frame(d / f"v_{f:012d}_keypoints.json", _person(25, 7), _person(25, 3))
    _frame(d / "v_000000000003_keypoints.json")  # an empty frame is kept
    k = read_keypoints(d)
    assert k.tracks.tolist() == [7, 3] * 3 and k.frames.tolist() == [0, 0, 1, 1, 2, 2]
    out = tmp_path / "back"
    write_keypoints(out, k)
    assert len(list(out.glob("*.json"))) == 4
    assert read_keypoints(out).tracks.tolist() == [7, 3] * 3


def test_openpose_bad_frames_are_named_and_good_frames_kept(tmp_path):
    d = tmp_path / "mixed"
    shutil.copytree(F / "openpose", d)
    text = (d / "video_000000000002_keypoints.json").read_text()
    (d / "video_000000000002_keypoints.json").write_text(text[: len(text) // 2])
    shutil.copy(F / "mmpose_predictions.json", d / "video_000000000007_keypoints.json")
    bad_score = json.loads(text)
    bad_score["people"][0]["pose_keypoints_2d"][2] = 1.5
    (d / "video_000000000008_keypoints.json").write_text(json.dumps(bad_score))
    (d / "notes.txt").write_text("not a frame")
    before = digest(d)
    with pytest.warns(UserWarning) as record:
        k = read_keypoints(d)
    assert len(k) == 3 and k.frames.tolist() == [0, 1, 3]
    messages = " ".join(str(w.message) for w in record)
    assert "video_000000000002_keypoints.json: invalid or truncated JSON" in messages
    assert "video_000000000007_keypoints.json: not an OpenPose frame" in messages
    assert "'pose_keypoints_2d confidence' value 0 is 1.5" in messages
    assert [name for name, _ in k.meta["skipped"]] == [
        "video_000000000002_keypoints.json", "video_000000000007_keypoints.json",
        "video_000000000008_keypoints.json"]
    assert k.meta["ignored"] == ["notes.txt"]
    assert digest(d) == before


def test_openpose_folder_without_a_good_frame_is_an_error(tmp_path):
    d = tmp_path / "bad"
    d.mkdir()
    (d / "x_keypoints.json").write_text('{"people": [')
    with pytest.raises(FileFormatError, match="no readable OpenPose frame files"):
        read_keypoints(d)


# --------------------------------------------------------------------------
# MMPose


def _instances(k, scores=None, **extra):
    xy = (np.arange(2 * k).reshape(k, 2) + 10.0).tolist()
    return dict(keypoints=xy, keypoint_scores=scores or [0.9] * k, **extra)


@pytest.mark.parametrize("shape", ["demo", "instance_info", "inferencer"])
def test_mmpose_shapes(shape, tmp_path):
    inst = _instances(17, track_id=4)
    doc = {"demo": {"meta_info": {}, "instance_info": [{"frame_id": 3, "instances": [inst]}]},
           "instance_info": [{"frame_id": 3, "instances": [inst]}],
           "inferencer": [inst]}[shape]
    path = tmp_path / "p.json"
    path.write_text(json.dumps(doc))
    assert detect(path) == "mmpose"
    k = read_keypoints(path)
    assert k.poses[0, LW].tolist() == [28.0, 29.0]  # COCO left_wrist is 9
    assert k.tracks.tolist() == [4] and k.frames.tolist() == [0 if shape == "inferencer"
                                                              else 3]


def test_mmpose_halpe_and_wholebody(tmp_path):
    path = tmp_path / "h.json"
    path.write_text(json.dumps([_instances(26)]))
    k = read_keypoints(path)
    assert k.poses[0, HEAD_TOP].tolist() == [44.0, 45.0]  # Halpe head (17)
    assert k.poses[0, NECK].tolist() == [46.0, 47.0]      # Halpe neck (18)
    path.write_text(json.dumps([_instances(133)]))
    k = read_keypoints(path)
    assert k.poses[0, LW].tolist() == [28.0, 29.0]
    assert k.poses[0, NECK].tolist() == [(20 + 22) / 2, (21 + 23) / 2]


def test_mmpose_scores_above_one_are_kept_negative_refused(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps([_instances(17, [1.08] * 17)]))
    assert not read_keypoints(path).missing.any()
    path.write_text(json.dumps([_instances(17, [0.9] * 16 + [-0.1])]))
    with pytest.raises(FileFormatError, match=r"s.json: frame 0, instance 0: "
                       r"'keypoint_scores' value 16"):
        read_keypoints(path)


# --------------------------------------------------------------------------
# AlphaPose


def _alphapose(k, scores=None, **extra):
    """One AlphaPose result of `k` keypoints: flat x, y, score."""
    xy = np.arange(2 * k).reshape(k, 2) + 10.0
    kp = np.column_stack([xy, scores or [0.9] * k]).ravel().tolist()
    return dict(image_id="0.jpg", category_id=1, keypoints=kp, score=2.5, **extra)


def test_alphapose_halpe26_maps_its_own_head_and_neck():
    k = read_keypoints(F / "alphapose_halpe26.json")
    assert k.meta["format"] == "alphapose" and k.meta["layout"] == "Halpe-26"
    doc = json.loads((F / "alphapose_halpe26.json").read_text())
    kp = np.asarray(doc[2]["keypoints"]).reshape(26, 3)
    assert k.poses[2, HEAD_TOP].tolist() == kp[17, :2].tolist()  # Halpe head (17)
    assert k.poses[2, NECK].tolist() == kp[18, :2].tolist()      # Halpe neck (18)
    assert k.poses[2, LW].tolist() == kp[9, :2].tolist()         # COCO's left wrist
    # idx is the track, the image's number the frame; scores below 0.3 are missing
    assert k.tracks.tolist() == [1, 2] * 3 and k.frames.tolist() == [0, 0, 1, 1, 2, 2]
    assert k.ids.tolist() == ["0.jpg", "0.jpg", "1.jpg", "1.jpg", "2.jpg", "2.jpg"]
    assert k.missing.sum() == 3 and k.missing[0, LW]


def test_alphapose_coco17_reads_as_the_same_coco_results(tmp_path):
    """A COCO-17 AlphaPose file gives the poses its keypoints give as a COCO file."""
    doc = json.loads((F / "alphapose_coco17.json").read_text())
    ap = read_keypoints(F / "alphapose_coco17.json")
    coco = tmp_path / "coco.json"
    coco.write_text(json.dumps([{k: v for k, v in d.items() if k not in ("idx", "box")}
                                for d in doc]))
    assert detect(coco) is None  # no idx, no box: a COCO results file
    plain = read_keypoints(coco)
    assert plain.meta["format"] == "coco"
    np.testing.assert_array_equal(ap.poses, plain.poses)
    np.testing.assert_array_equal(ap.missing, plain.missing)
    # untracked: idx holds the pose NMS's box ids; one pose a frame is one track
    assert ap.tracks.tolist() == [0, 0, 0] and ap.frames.tolist() == [0, 1, 2]


@pytest.mark.parametrize("entry, fmt", [
    (_alphapose(17, idx=3), "alphapose"), (_alphapose(17, box=[0, 0, 1, 1]), "alphapose"),
    (_alphapose(26), "alphapose"), (_alphapose(136), "alphapose"),
    (_alphapose(17), None)])
def test_alphapose_is_told_from_its_content(tmp_path, entry, fmt):
    path = tmp_path / "alphapose-results.json"
    path.write_text(json.dumps([entry]))
    assert detect(path) == fmt
    assert read_keypoints(path).meta["format"] == (fmt or "coco")


@pytest.mark.parametrize("names, frames, tracks", [
    (["frame_000010.png", "frame_000011.png"], [10, 11], [0, 0]),
    ([10, 11], [10, 11], [0, 0]),                           # --eval: integer image ids
    (["dog.jpg", "cat.jpg"], None, None),                   # photos: no frames, no tracks
    (["IMG_7.jpg", "img7.jpg"], None, None)])
def test_alphapose_frames_from_image_names(tmp_path, names, frames, tracks):
    path = tmp_path / "a.json"
    path.write_text(json.dumps([_alphapose(17, idx=[0.0]) | {"image_id": n} for n in names]))
    k = read_keypoints(path)
    assert (None if k.frames is None else k.frames.tolist()) == frames
    assert (None if k.tracks is None else k.tracks.tolist()) == tracks
    assert k.ids.tolist() == [str(n) for n in names]


@pytest.mark.parametrize("change, words", [
    ({"image_id": "camB_000001.jpg"}, "images of 2 videos (name stems 'camA_*.jpg', "
                                      "'camB_*.jpg')"),
    ({"idx": 1.5}, "result 1: 'idx' must be an integer or a string"),
    ({"keypoints": [1.0] * 60}, "result 1: 'keypoints' has 60 values; AlphaPose layouts"),
    ({"keypoints": [1.0, 2.0, -0.5] * 17}, "result 1: 'keypoints score' value 0 is -0.5")])
def test_alphapose_refusals_name_the_result(tmp_path, change, words):
    path = tmp_path / "a.json"
    first = _alphapose(17, idx=0) | {"image_id": "camA_000001.jpg"}
    path.write_text(json.dumps([first, first | change]))
    with pytest.raises(FileFormatError, match=re.escape(words)):
        read_keypoints(path)


def test_alphapose_scores_above_one_are_kept(tmp_path):
    path = tmp_path / "a.json"
    path.write_text(json.dumps([_alphapose(26, [2.7] * 26, idx=0)]))
    assert not read_keypoints(path).missing.any()


def test_halpe_read_as_coco_says_what_it_is(tmp_path):
    path = tmp_path / "a.json"
    path.write_text(json.dumps([_alphapose(26)]))
    with pytest.raises(FileFormatError, match="78 values; COCO-17 needs 51.*26 keypoints: "
                       "Halpe-26, as AlphaPose writes them; read it with format='alphapose'"):
        read_keypoints(path, format="coco")
    assert read_keypoints(path, format="alphapose").meta["layout"] == "Halpe-26"


def test_alphapose_recover_flags_the_low_scored_joints(tmp_path, small_dictionary):
    """The occluded joints (scored 0.03-0.2) are filled, written back with score 0."""
    summary = recover_file(F / "alphapose_halpe26.json", tmp_path / "o.json",
                           dictionary=small_dictionary, adapt=False)
    assert summary["recovered_joints"] == 3
    doc = json.loads((tmp_path / "o.json").read_text())
    assert doc[0]["sparseedm"]["filled"] == ["left_wrist"] and doc[0]["keypoints"][29] == 0.0
    assert doc[0]["idx"] == 1 and doc[0]["box"] == json.loads(
        (F / "alphapose_halpe26.json").read_text())[0]["box"]


def test_low_detector_scores_are_recovered_with_the_default_threshold(tmp_path,
                                                                      small_dictionary):
    """Occluded joints scored 0.02-0.2 (not 0) are recovered by default."""
    summary = recover_file(F / "mmpose_predictions.json", tmp_path / "o.json",
                           dictionary=small_dictionary, adapt=False)
    assert summary["recovered_joints"] == 4
    doc = json.loads((tmp_path / "o.json").read_text())
    inst = doc["instance_info"][1]["instances"][0]
    assert sorted(inst["sparseedm"]["filled"]) == ["left_elbow", "left_wrist"]
    assert inst["keypoint_scores"][9] == 0.0 and inst["keypoint_scores"][7] == 0.0


def test_cli_summary_names_the_threshold(tmp_path, capsys, small_dictionary_path):
    from sparseedm.cli import main

    args = ["--dictionary", str(small_dictionary_path), "--no-adapt", "-q"]
    assert main(["recover", str(F / "mmpose_predictions.json"), "-o",
                 str(tmp_path / "a.json")] + args) == 0
    out = capsys.readouterr().err  # -q: the summary goes to stderr
    assert "confidence threshold 0.3 (the mmpose default): 4 scored joints below it" in out
    assert main(["recover", str(F / "dlc.csv"), "-o", str(tmp_path / "b.csv"),
                 "--joint-map", str(MAP), "--confidence-threshold", "0.05"] + args) == 0
    out = capsys.readouterr().err
    assert "confidence threshold 0.05 (given): the file has scores, none below it" in out


@pytest.mark.parametrize("option", ["-o", "--errors"])
def test_recover_never_writes_over_its_joint_map(tmp_path, capsys, small_dictionary_path, option):
    from sparseedm.cli import main

    joint_map = tmp_path / "map.json"
    shutil.copy(MAP, joint_map)
    before = joint_map.read_bytes()
    out = ["-o", str(joint_map)] if option == "-o" else \
        ["-o", str(tmp_path / "out.csv"), "--errors", str(joint_map)]
    code = main(["recover", str(F / "dlc.csv"), *out, "--joint-map", str(joint_map),
                 "--dictionary", str(small_dictionary_path), "--no-adapt", "-q"])
    assert code == 2 and joint_map.read_bytes() == before
    assert "is the joint map" in capsys.readouterr().err
    assert not (tmp_path / "out.csv").exists()


# --------------------------------------------------------------------------
# DeepLabCut


def test_dlc_h5_and_csv_read_the_same():
    needs_pandas()
    a = read_keypoints(F / "dlc.csv", joint_map=MAP)
    b = read_keypoints(F / "dlc.h5", joint_map=MAP)
    np.testing.assert_array_equal(a.poses, b.poses)
    np.testing.assert_array_equal(a.confidence, b.confidence)
    assert a.meta["format"] == b.meta["format"] == "dlc"


def test_dlc_needs_a_map_for_its_own_part_names():
    with pytest.raises(FileFormatError, match=r"dlc.csv: DeepLabCut body parts \(head, "
                       r"neckbase.*--joint-map"):
        read_keypoints(F / "dlc.csv")


def test_dlc_map_naming_an_unknown_body_part(tmp_path):
    m = tmp_path / "map.json"
    m.write_text(json.dumps({"joints": {"left_wrist": "hand_left", "left_elbow": "elbowL",
                                        "left_shoulder": "shoulderL"}}))
    with pytest.raises(FileFormatError, match=r"map.json: 'joints.left_wrist' names body "
                       r"part 'hand_left'"):
        read_keypoints(F / "dlc.csv", joint_map=m)
    m.write_text(json.dumps({"joints": {"left_hand": "wristL"}}))
    with pytest.raises(FileFormatError, match="'joints.left_hand' is not a joint"):
        read_keypoints(F / "dlc.csv", joint_map=m)


@pytest.mark.parametrize("doc,match", [
    ({"head_top": "head"}, r"the map gives 1 joint \(head_top\); a pose needs at least 3 "
     r"observed joints .* could recover nothing; a joints map is \{\"joints\""),
    ({}, r"the map gives 0 joints; a pose needs at least 3"),
    ({"joints": {"head_top": "head", "right_wrist": "wristR"}},
     r"gives 2 joints \(head_top, right_wrist\);.*nothing$"),
    ({"joints": {"left_wrist": "wristL", "right_wrist": "wristL", "neck": "neckbase"}},
     r"body part 'wristL' is given to both 'right_wrist' and 'left_wrist'; each joint"),
])
def test_dlc_map_that_can_never_work_is_refused_up_front(doc, match, tmp_path,
                                                         monkeypatch, capsys):
    import sparseedm.batch

    m = tmp_path / "map.json"
    m.write_text(json.dumps(doc))
    with pytest.raises(FileFormatError, match=match):
        read_keypoints(F / "dlc.csv", joint_map=m)
    monkeypatch.setattr(sparseedm.batch, "load_dictionary", pytest.fail)  # no work
    from sparseedm.cli import main

    assert main(["recover", str(F / "dlc.csv"), "-o", str(tmp_path / "o.csv"),
                 "--joint-map", str(m)]) == 2
    assert "map.json: " in capsys.readouterr().err
    # shoulders and a null neck: three joints (the neck is their midpoint)
    m.write_text(json.dumps({"joints": {"left_shoulder": "shoulderL",
                                        "right_shoulder": "shoulderR"}}))
    assert read_keypoints(F / "dlc.csv", joint_map=m).missing[:, NECK].sum() == 0


@pytest.mark.parametrize("command", ["recover", "lift"])
@pytest.mark.parametrize("src", ["mmpose_predictions.json", "openpose", "plain.csv",
                                 "poses.npy"])
def test_joint_map_with_an_input_that_is_not_deeplabcut_is_refused(command, src, tmp_path,
                                                                   capsys):
    from sparseedm.cli import main

    k = read_keypoints(F / "mmpose_predictions.json")
    if src in ("plain.csv", "poses.npy"):
        write_keypoints(tmp_path / src, k.poses)
        path = tmp_path / src
    else:
        path = F / src
    out = tmp_path / "out.csv"
    assert main([command, str(path), "-o", str(out), "--joint-map", str(MAP), "-q"]) == 2
    assert f"{path}: --joint-map (joint_map=) applies to DeepLabCut inputs only" in \
        capsys.readouterr().err
    assert not out.exists()


def test_dlc_likelihood_rules(tmp_path):
    lines = (F / "dlc.csv").read_text().splitlines()
    row = lines[3].split(",")
    row[3] = "nan"          # head likelihood NaN: missing, not an error
    lines[3] = ",".join(row)
    p = tmp_path / "nan.csv"
    p.write_text("\n".join(lines) + "\n")
    k = read_keypoints(p, joint_map=MAP)
    assert k.missing[0, HEAD_TOP] and not k.missing[1, HEAD_TOP]
    row[3] = "1.7"
    lines[3] = ",".join(row)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(FileFormatError, match=r"row '0', body part 'head': likelihood "
                       r"1.7 is outside \[0, 1\]"):
        read_keypoints(p, joint_map=MAP)


def test_dlc_map_is_optional_when_parts_are_the_joint_names(tmp_path):
    k = read_keypoints(F / "dlc.csv", joint_map=MAP)
    out = tmp_path / "fresh.csv"
    write_keypoints(out, k.poses, format="dlc")
    again = read_keypoints(out)
    np.testing.assert_allclose(again.poses, k.poses)


def _dlc_header(path, levels):
    """The header rows of a DeepLabCut CSV, as DeepLabCut's ``read_csv(header=[0..])``
    gives its column levels: {level name: the row's cells after the first}."""
    rows = [line.split(",") for line in path.read_text().splitlines()[:levels]]
    return {row[0]: row[1:] for row in rows}


@pytest.mark.parametrize("src", ["dlc.csv", "dlc_multi.csv", "dlc.h5"])
def test_dlc_output_keeps_deeplabcuts_own_layout(src, tmp_path, small_dictionary):
    # DeepLabCut's make_labeled_video: df.values.reshape((nframes, -1, 3)).T and
    # bodyparts = df.columns.get_level_values("bodyparts")[::3]
    src = F / src
    if src.suffix == ".h5":
        needs_pandas()  # reading and writing .h5 need the [dlc] extra
    out = tmp_path / f"out{src.suffix}"
    first = read_keypoints(src, joint_map=MAP)
    recover_file(src, out, dictionary=small_dictionary, adapt=False, joint_map=MAP)
    flags = np.load(tmp_path / "out.status.npz")["filled"]
    np.testing.assert_array_equal(flags, first.missing)
    assert flags.any()
    if src.suffix == ".h5":
        import pandas as pd

        df_in, df = pd.read_hdf(src), pd.read_hdf(out, "df_with_missing")
        assert list(df.columns.names) == list(df_in.columns.names)
        assert list(df.columns) == list(df_in.columns)
        values, bodyparts = df.values, list(df.columns.get_level_values("bodyparts")[::3])
        parts_in = list(df_in.columns.get_level_values("bodyparts")[::3])
    else:
        levels = 4 if "multi" in src.name else 3
        head, head_in = _dlc_header(out, levels), _dlc_header(src, levels)
        assert head == head_in  # same levels, columns and order as the input
        assert head["coords"] == ["x", "y", "likelihood"] * (len(head["coords"]) // 3)
        values = np.loadtxt(out, delimiter=",", skiprows=levels)[:, 1:]
        bodyparts, parts_in = head["bodyparts"][::3], head_in["bodyparts"][::3]
    x, y, likelihood = values.reshape((len(values), -1, 3)).T
    assert bodyparts == parts_in and x.shape[0] == len(parts_in)
    assert np.isfinite(x).all() and np.isfinite(y).all()  # the filled joints written in


def test_dlc_older_output_with_a_filled_column_is_still_read(tmp_path, small_dictionary):
    lines = (F / "dlc.csv").read_text().splitlines()
    cells = [line.split(",") for line in lines]
    for r, row in enumerate(cells):  # a 'filled' column after head's likelihood
        row.insert(4, {0: row[3], 1: "head", 2: "filled"}.get(r, "1" if r == 3 else "0"))
    old = tmp_path / "old.csv"
    old.write_text("\n".join(",".join(row) for row in cells) + "\n")
    k = read_keypoints(old, joint_map=MAP)
    assert k.filled[0, HEAD_TOP] and k.filled.sum() == 1
    out = tmp_path / "new.csv"
    recover_file(old, out, dictionary=small_dictionary, adapt=False, joint_map=MAP)
    assert "filled" not in out.read_text().splitlines()[2]
    assert np.load(tmp_path / "new.status.npz")["filled"][0, HEAD_TOP]


def test_h5_without_pandas_names_the_extra(tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_pandas(name, *args, **kwargs):
        if name in ("pandas", "tables"):
            raise ImportError(f"No module named {name!r}")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pandas)
    with pytest.raises(FileFormatError, match=r"sparseedm\[dlc\]"):
        read_keypoints(F / "dlc.h5", joint_map=MAP)


def _no_dlc_extra(monkeypatch):
    """pandas and PyTables not installed, and any reading or adapting a failure."""
    import importlib.util

    import sparseedm.batch
    import sparseedm.lifting.io

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in ("pandas", "tables")
                        else real(name, *a))

    def no_work(*args, **kwargs):
        raise AssertionError("work started before the extra was checked")

    for module in (sparseedm.batch, sparseedm.lifting.io):
        monkeypatch.setattr(module, "read_keypoints", no_work)
    monkeypatch.setattr(sparseedm.batch, "load_dictionary", no_work)


@pytest.mark.parametrize("command,src,out", [
    ("recover", "dlc.csv", "out.h5"), ("recover", "dlc.h5", "out.csv"),
    ("lift", "dlc.h5", "out.csv")])
def test_h5_without_the_extra_is_refused_before_any_work(command, src, out, tmp_path,
                                                         monkeypatch, capsys):
    from sparseedm.cli import main

    _no_dlc_extra(monkeypatch)
    assert main([command, str(F / src), "-o", str(tmp_path / out), "--joint-map", str(MAP),
                 "-q"]) == 2
    err = capsys.readouterr().err
    assert "reading/writing DeepLabCut .h5 files needs pandas and tables (the " \
        "sparseedm[dlc] extra): pip install 'sparseedm[dlc]'" in err
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------
# PoseTrack


def _coco_kp(head_top=(50, 5)):
    kp = []
    for k in range(17):
        kp += [10.0 * k, 20.0 + k, 1]
    kp[6:8] = head_top
    return kp


def test_posetrack_ground_truth_tracks_frames_and_head_top(tmp_path, small_dictionary):
    doc = {"images": [{"id": 100, "frame_id": 0, "vid_id": 1},
                      {"id": 101, "frame_id": 1, "vid_id": 1}],
           "categories": [{"id": 1, "name": "person", "keypoints": [
               "nose", "head_bottom", "head_top", "left_ear", "right_ear", "left_shoulder",
               "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
               "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
               "right_ankle"]}],
           "annotations": [{"image_id": i, "track_id": t, "keypoints": _coco_kp()}
                           for i in (100, 101) for t in (0, 1)]}
    path = tmp_path / "pt.json"
    path.write_text(json.dumps(doc))
    k = read_keypoints(path)
    assert k.tracks.tolist() == [0, 1, 0, 1] and k.frames.tolist() == [0, 0, 1, 1]
    assert k.poses[0, HEAD_TOP].tolist() == [50.0, 5.0]
    out = tmp_path / "o.json"
    recover_file(path, out, dictionary=small_dictionary, adapt=False)
    back = read_keypoints(out)
    assert back.tracks.tolist() == [0, 1, 0, 1] and back.frames.tolist() == [0, 0, 1, 1]


def test_posetrack_track_id_on_some_annotations_only(tmp_path):
    anns = [{"image_id": 1, "track_id": 0, "keypoints": _coco_kp()},
            {"image_id": 1, "keypoints": _coco_kp()}]
    path = tmp_path / "r.json"
    path.write_text(json.dumps(anns))
    with pytest.raises(FileFormatError, match="annotation 1 has no 'track_id'"):
        read_keypoints(path)


def test_detect_tells_formats_apart(tmp_path):
    assert detect(F / "openpose") == "openpose"
    assert detect(F / "openpose" / "video_000000000000_keypoints.json") == "openpose"
    assert detect(F / "mmpose_predictions.json") == "mmpose"
    assert detect(F / "dlc.csv") == "dlc" and detect(F / "dlc.h5") == "dlc"
    coco = tmp_path / "c.json"
    coco.write_text(json.dumps([{"image_id": 1, "keypoints": _coco_kp()}]))
    assert detect(coco) is None  # COCO: read by sparseedm.keypoints
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_keypoints(coco).meta["format"] == "coco"


# --------------------------------------------------------------------------
# filled flags and scores in the formats of sparseedm.keypoints


def _coco_results(tmp_path):
    """A COCO results file from the MMPose fixture: occluded joints scored 0.02-0.2."""
    doc = json.loads((F / "mmpose_predictions.json").read_text())
    anns = []
    for entry in doc["instance_info"]:
        inst = entry["instances"][0]
        kp = [v for (x, y), s in zip(inst["keypoints"], inst["keypoint_scores"])
              for v in (x, y, s)]
        anns.append({"image_id": entry["frame_id"], "category_id": 1, "keypoints": kp,
                     "score": 0.9, "num_keypoints": 17})
    path = tmp_path / "results.json"
    path.write_text(json.dumps(anns))
    return path


def test_coco_low_scores_recovered_by_default_and_never_look_detected(tmp_path,
                                                                      small_dictionary):
    src = _coco_results(tmp_path)
    summary = recover_file(src, tmp_path / "o.json", dictionary=small_dictionary,
                           adapt=False)
    assert summary["recovered_joints"] == 4 and summary["below_threshold"] == 4
    anns = json.loads((tmp_path / "o.json").read_text())
    lw = 9  # COCO left_wrist: scored 0.02 in frame 1, now filled with score 0
    assert anns[0]["keypoints"][3 * lw + 2] == 0.0 and anns[0]["num_keypoints"] == 16
    assert anns[0]["sparseedm"]["filled"] == ["left_wrist"]
    back = read_keypoints(tmp_path / "o.json")
    assert not back.missing.any() and back.filled.sum() == 4
    again = recover_file(tmp_path / "o.json", tmp_path / "o2.json",
                         dictionary=small_dictionary, adapt=False)
    assert again["recovered_joints"] == 0  # flagged joints are read as present
    assert json.loads((tmp_path / "o2.json").read_text())[0]["sparseedm"]["filled"] == \
        ["left_wrist"]


@pytest.mark.parametrize("ext", [".csv", ".npz", ".json"])
def test_filled_flags_in_csv_npz_and_fresh_coco(ext, tmp_path, small_dictionary):
    k = read_keypoints(F / "mmpose_predictions.json")
    src = tmp_path / "in.csv"
    write_keypoints(src, k.poses, ids=k.ids, filled=np.zeros(k.missing.shape, bool))
    out = tmp_path / f"out{ext}"
    recover_file(src, out, dictionary=small_dictionary, adapt=False, filled_score=0.05)
    back = read_keypoints(out)
    np.testing.assert_array_equal(back.filled, k.missing)
    assert not back.missing.any()
    if ext == ".json":
        anns = json.loads(out.read_text())
        assert anns[0]["keypoints"][3 * 9 + 2] == 0.05   # --filled-score
        assert anns[0]["keypoints"][3 * 10 + 2] == 2      # a plain keypoint


def test_csv_filled_column_rules(tmp_path):
    k = read_keypoints(F / "mmpose_predictions.json")
    p = tmp_path / "f.csv"
    write_keypoints(p, np.nan_to_num(k.poses), filled=k.missing)
    text = p.read_text()
    assert "left_wrist_filled" in text.splitlines()[0]
    np.testing.assert_array_equal(read_keypoints(p).filled, k.missing)
    lines = text.splitlines()
    lines[1] = lines[1][:-1] + "7"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(FileFormatError, match=r"line 2, column 'left_ankle_filled': '7' "
                       r"is not a filled flag"):
        read_keypoints(p)


def test_tracks_written_back_by_formats_without_a_document(tmp_path):
    k = read_keypoints(F / "dlc_multi.csv", joint_map=MAP)
    for name in ("c.json", "m.json"):
        out = tmp_path / name
        write_keypoints(out, k.poses, tracks=k.tracks, frames=k.frames,
                        format="coco" if name == "c.json" else "mmpose")
        back = read_keypoints(out)
        assert back.tracks.tolist() == k.tracks.tolist()
    assert read_keypoints(tmp_path / "m.json").frames.tolist() == k.frames.tolist()


def test_cli_lists_skipped_frame_files(tmp_path, capsys, small_dictionary_path):
    from sparseedm.cli import main

    d = tmp_path / "frames"
    shutil.copytree(F / "openpose", d)
    (d / "video_000000000009_keypoints.json").write_text('{"people": [')
    code = main(["recover", str(d), "-o", str(tmp_path / "out"), "-q", "--no-adapt",
                 "--dictionary", str(small_dictionary_path)])
    assert code == 1  # nothing lost silently: the file is listed, the exit code says so
    err = capsys.readouterr().err
    # the warning: one clean line, no Python source line or category
    assert "sparseedm recover: warning: skipped " + \
        str(d / "video_000000000009_keypoints.json") + ": invalid or truncated JSON" in err
    assert "UserWarning" not in err and "warnings.warn" not in err and ".py:" not in err
    assert "skipped " + str(d / "video_000000000009_keypoints.json") + ": invalid or " \
        "truncated JSON" in err
    assert len(list((tmp_path / "out").glob("*.json"))) == 4
    assert "1 input file(s) unreadable; see" in err
    errors = (tmp_path / "out.errors.csv").read_text().splitlines()
    assert errors[0] == "row,id,status,reason" and len(errors) == 2
    assert errors[1].startswith(",video_000000000009_keypoints.json,unreadable_file,")
    # lift lists it the same way
    assert main(["lift", str(d), "-o", str(tmp_path / "p.csv"), "-q", "--no-temporal"]) == 1
    lines = (tmp_path / "p.errors.csv").read_text().splitlines()
    assert lines[-1].startswith(",video_000000000009_keypoints.json,unreadable_file,")
    # and a clean rerun removes the stale errors file
    (d / "video_000000000009_keypoints.json").unlink()
    assert main(["recover", str(d), "-o", str(tmp_path / "out"), "-q", "--no-adapt",
                 "--dictionary", str(small_dictionary_path)]) == 0
    assert not (tmp_path / "out.errors.csv").exists()


def _mmpose_image_folder(folder, cmu_poses):
    """What MMPoseInferencer's pred_out_dir holds after a folder of images: one JSON
    per image, a list of COCO-17 instances; frame 2 has nobody, the right wrist of
    frames 1 and 3 is scored 0.05 (occluded), a notes file is not a frame."""
    from sparseedm.formats import COCO_17
    from sparseedm.skeleton import JOINT_NAMES

    folder.mkdir()
    for f in range(4):
        instances = []
        if f != 2:
            xy, scores = np.zeros((17, 2)), np.full(17, 0.9)
            for j, k in COCO_17.sources().items():
                xy[k] = cmu_poses[f, j]
            face = cmu_poses[f, 1] + 0.6 * (cmu_poses[f, 0] - cmu_poses[f, 1])
            xy[:5] = face
            if f in (1, 3):
                scores[COCO_17.index("right_wrist")] = 0.05
            instances.append({"keypoints": xy.tolist(), "keypoint_scores": scores.tolist(),
                              "bbox": [[0.0, 0.0, 100.0, 200.0]], "bbox_score": 0.99})
        (folder / f"img_{f:04d}.json").write_text(json.dumps(instances))
    (folder / "notes.txt").write_text("not a frame")
    return JOINT_NAMES.index("right_wrist")


def test_a_folder_of_mmpose_image_files_reads_and_writes_back(cmu_poses, tmp_path,
                                                              small_dictionary):
    from sparseedm.formats import detect

    folder = tmp_path / "preds"
    wrist = _mmpose_image_folder(folder, cmu_poses)
    assert detect(folder) == "mmpose"
    kps = read_keypoints(folder)
    assert kps.meta["format"] == "mmpose"
    assert kps.frames.tolist() == [0, 1, 3]  # from the names; frame 2: nobody
    assert kps.ids.tolist() == ["img_0000", "img_0001", "img_0003"]
    assert kps.missing[:, wrist].tolist() == [False, True, True]
    assert kps.meta["ignored"] == ["notes.txt"]
    out = tmp_path / "out"
    summary = recover_file(folder, out, dictionary=small_dictionary, adapt=False)
    assert summary["format"] == "mmpose" and summary["refused"] == 0
    assert sorted(p.name for p in out.glob("*.json")) == \
        sorted(p.name for p in folder.glob("*.json"))
    first = json.loads((out / "img_0001.json").read_text())[0]
    assert first["sparseedm"]["filled"] == ["right_wrist"] and first["bbox_score"] == 0.99
    assert json.loads((out / "img_0002.json").read_text()) == []
    back = read_keypoints(out)
    assert not back.missing.any()
    np.testing.assert_array_equal(back.filled, kps.missing)
    np.testing.assert_array_equal(back.frames, kps.frames)


def test_a_folder_of_neither_format_is_refused_naming_the_file(tmp_path):
    folder = tmp_path / "x"
    folder.mkdir()
    (folder / "a_000001.json").write_text('{"images": []}')
    with pytest.raises(FileFormatError, match="no readable OpenPose frame files.*a_000001"):
        read_keypoints(folder)


def test_a_folder_of_two_videos_is_refused_naming_both_stems(tmp_path):
    d = tmp_path / "two"
    d.mkdir()
    for cam in ("camA", "camB"):
        for f in (1, 2):
            _frame(d / f"{cam}_{f:012d}_keypoints.json", _person(25))
    with pytest.raises(FileFormatError, match=r"2 videos.*'camA_\*_keypoints\.json', "
                                              r"'camB_\*_keypoints\.json'.*split the folder"):
        read_keypoints(d)
    one = tmp_path / "one"  # one stem: one video, read as before
    one.mkdir()
    for f in (1, 2):
        _frame(one / f"camA_{f:012d}_keypoints.json", _person(25))
    assert read_keypoints(one).frames.tolist() == [1, 2]


def test_a_folder_of_two_videos_of_mmpose_image_files_is_refused(cmu_poses, tmp_path):
    folder = tmp_path / "preds"
    _mmpose_image_folder(folder, cmu_poses)
    shutil.copy(folder / "img_0001.json", folder / "other_0001.json")
    with pytest.raises(FileFormatError, match=r"'img_\*\.json', 'other_\*\.json'"):
        read_keypoints(folder)


def test_posetrack_file_of_two_videos_names_vid_id(tmp_path):
    doc = {"images": [{"id": 100, "frame_id": 0, "vid_id": "000001"},
                      {"id": 200, "frame_id": 0, "vid_id": "000002"}],
           "annotations": [{"image_id": i, "track_id": 0, "keypoints": _coco_kp()}
                           for i in (100, 200)]}
    path = tmp_path / "pt.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(FileFormatError, match=r"vid_id '000001', '000002'.*one per vid_id"):
        read_keypoints(path)
    doc["images"][1]["vid_id"] = "000001"  # one video, two frames 0 of track 0: as before
    doc["images"][1]["frame_id"] = 1
    path.write_text(json.dumps(doc))
    assert read_keypoints(path).frames.tolist() == [0, 1]


def _labelled_csv(path, parts, rows):
    """DeepLabCut's labelled data: three index columns, x and y per body part."""
    head = [["scorer", "", ""], ["bodyparts", "", ""], ["coords", "", ""]]
    for part in parts:
        for c in "xy":
            head[0].append("Alice")
            head[1].append(part)
            head[2].append(c)
    body = [["labeled-data", "vid1", name] + [repr(float(v)) for v in xy.ravel()]
            for name, xy in rows]
    path.write_text("\n".join(",".join(r) for r in head + body) + "\n")
    return path


def test_dlc_labelled_data_with_three_index_columns(cmu_poses, tmp_path, small_dictionary):
    rows = [(f"img{f:03d}.png", cmu_poses[f]) for f in range(3)]
    src = _labelled_csv(tmp_path / "CollectedData_Alice.csv", JOINT_NAMES, rows)
    k = read_keypoints(src)
    assert k.ids.tolist() == [f"labeled-data/vid1/img{f:03d}.png" for f in range(3)]
    np.testing.assert_allclose(k.poses, cmu_poses[:3])
    out = tmp_path / "out.csv"
    recover_file(src, out, dictionary=small_dictionary, adapt=False)
    lines = out.read_text().splitlines()
    assert lines[0].startswith("scorer,,,Alice") and lines[2].startswith("coords,,,x,y")
    assert lines[3].startswith("labeled-data,vid1,img000.png,")
    assert read_keypoints(out).ids.tolist() == k.ids.tolist()


def test_dlc_body_part_named_twice_is_named(cmu_poses, tmp_path):
    parts = ["left_wrist" if j == "right_wrist" else j for j in JOINT_NAMES]
    src = _labelled_csv(tmp_path / "twice.csv", parts, [("img0.png", cmu_poses[0])])
    with pytest.raises(FileFormatError, match="body part 'left_wrist' is named twice"):
        read_keypoints(src)


def test_alphapose_open_format_results_say_what_to_read(tmp_path):
    """AlphaPose's --format open writes OpenPose frames by image name in one file."""
    path = tmp_path / "alphapose-results.json"
    frame = {"version": "AlphaPose v0.3", "people": [{"pose_keypoints_2d": [1.0] * 54}]}
    path.write_text(json.dumps({"0.jpg": frame, "1.jpg": frame}))
    with pytest.raises(FileFormatError, match="AlphaPose --format open results.*sep-json"):
        read_keypoints(path)


@pytest.mark.parametrize("how", ["file", "input_format", "sep_file", "sep_folder"])
def test_alphapose_cmu_format_output_is_refused_by_name(tmp_path, how):
    """AlphaPose's --format cmu writes CMU-Pose 'bodies' by image name (one file,
    or one per image in sep-json): not read, and the refusal names it and says
    what to run instead, whichever way the file is given, before any output."""
    body = {"joints": [1.0] * 54}
    doc = {"0.jpg": {"version": "AlphaPose v0.3", "bodies": [body]},
           "1.jpg": {"version": "AlphaPose v0.3", "bodies": [body, body]}}
    folder = tmp_path / "sep-json"
    folder.mkdir()
    for name, image in doc.items():
        (folder / name.replace(".jpg", ".json")).write_text(json.dumps(image))
    src = tmp_path / "alphapose-results.json"
    src.write_text(json.dumps(doc))
    given = {"file": (src, None), "input_format": (src, "alphapose"),
             "sep_file": (folder / "0.json", None), "sep_folder": (folder, None)}[how]
    out = tmp_path / "out.csv"
    with pytest.raises(FileFormatError,
                       match="AlphaPose --format cmu output.*without --format"):
        recover_file(given[0], out, input_format=given[1], adapt=False)
    assert not out.exists()
