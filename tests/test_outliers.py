"""The outlier check: low-scored points that the pose model and their track
both contradict are treated as missing, filled and named; right ones stay."""

import json
from pathlib import Path

import numpy as np
import pytest

from sparseedm import recover
from sparseedm.batch import recover_file
from sparseedm.cli import main
from sparseedm.exceptions import ParameterError
from sparseedm.keypoints import read_keypoints
from sparseedm.outliers import DEFAULT_OUTLIER_SETTINGS, OutlierSettings
from sparseedm.real_protocol import body_size
from sparseedm.skeleton import JOINT_NAMES

_BODY_25 = ("nose", "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder",
            "left_elbow", "left_wrist", "mid_hip", "right_hip", "right_knee", "right_ankle",
            "left_hip", "left_knee", "left_ankle")
WRIST, KNEE = JOINT_NAMES.index("left_wrist"), JOINT_NAMES.index("right_knee")
NECK, HEAD = JOINT_NAMES.index("neck"), JOINT_NAMES.index("head_top")
WRONG_FRAMES, RIGHT_FRAMES = range(100, 106), range(50, 56)


def write_openpose(folder, poses, score):
    """One BODY_25 file per frame; the head top through the nose (the reader's
    face rule gives it back)."""
    folder.mkdir()
    for f, (pose, s) in enumerate(zip(poses, score)):
        kp = np.zeros((25, 3))
        for k, name in enumerate(_BODY_25):
            if name not in ("nose", "mid_hip"):
                kp[k] = (*pose[JOINT_NAMES.index(name)], s[JOINT_NAMES.index(name)])
        kp[0] = (*((pose[HEAD] + 0.8 * pose[NECK]) / 1.8), 0.9)
        doc = {"people": [{"person_id": [0], "pose_keypoints_2d": kp.ravel().tolist()}]}
        (folder / f"clip_{f:012d}_keypoints.json").write_text(json.dumps(doc))
    return folder


@pytest.fixture
def case(tmp_path, track):
    """The smooth track as an OpenPose folder: the left wrist of six frames moved
    0.4 body sizes and scored 0.1 (wrong), the right knee of six others
    scored 0.1 at its place (right)."""
    size = float(np.median(body_size(track)))
    given = track.copy()
    given[list(WRONG_FRAMES), WRIST] += (0.4 * size, 0.0)
    score = np.full(track.shape[:2], 0.9)
    score[list(WRONG_FRAMES), WRIST] = 0.1
    score[list(RIGHT_FRAMES), KNEE] = 0.1
    return write_openpose(tmp_path / "clip", given, score), given, size


def _named(outliers):
    return [str(v).split() for v in outliers]


def test_wrong_low_scored_point_is_flagged_and_filled_near_truth(case, tmp_path, track,
                                                                 small_dictionary):
    folder, given, size = case
    summary = recover_file(folder, tmp_path / "out.npz", dictionary=small_dictionary,
                           adapt=False)
    with np.load(tmp_path / "out.npz", allow_pickle=False) as out:
        poses, named, filled = out["poses"], _named(out["outliers"]), out["filled"]
    assert summary["outliers"] == len(WRONG_FRAMES)
    for f in WRONG_FRAMES:
        assert named[f] == ["left_wrist"] and filled[f, WRIST]
    error = np.linalg.norm(poses[list(WRONG_FRAMES), WRIST] - track[list(WRONG_FRAMES), WRIST],
                           axis=-1) / size
    assert error.max() < 0.1  # the wrong points were 0.4 away
    # the right low-scored knees stay observed, exactly as given
    assert not any(named[f] for f in RIGHT_FRAMES)
    np.testing.assert_array_equal(poses[list(RIGHT_FRAMES), KNEE],
                                  given[list(RIGHT_FRAMES), KNEE])


def test_openpose_output_names_the_outliers_and_reads_back(case, tmp_path, small_dictionary):
    folder, _, _ = case
    out = tmp_path / "out"
    recover_file(folder, out, dictionary=small_dictionary, adapt=False)
    person = json.loads((out / "clip_000000000100_keypoints.json").read_text())["people"][0]
    assert person["sparseedm"]["outliers"] == "left_wrist"
    assert "left_wrist" in person["sparseedm"]["filled"]
    kps = read_keypoints(out)  # the filled wrist reads back as present
    assert not kps.missing[100, WRIST]
    # run again on the output: the joints sparseedm filled (score 0) are not checked
    again = recover_file(out, tmp_path / "again.npz", dictionary=small_dictionary,
                         adapt=False)
    assert again["outliers"] == 0
    with np.load(tmp_path / "again.npz", allow_pickle=False) as res:
        np.testing.assert_array_equal(res["poses"][100, WRIST], kps.poses[100, WRIST])


def test_csv_output_has_an_outliers_column(case, tmp_path, small_dictionary):
    folder, _, _ = case
    recover_file(folder, tmp_path / "out.csv", dictionary=small_dictionary, adapt=False)
    kps = read_keypoints(tmp_path / "out.csv")
    column = kps.meta["extra_columns"]["outliers"]
    assert [str(v) for v in column][100] == "left_wrist"
    assert sum(bool(str(v)) for v in column) == len(WRONG_FRAMES)


def test_off_switch_keeps_every_point(case, tmp_path, small_dictionary):
    folder, given, _ = case
    summary = recover_file(folder, tmp_path / "out.npz", dictionary=small_dictionary,
                           adapt=False, outliers=False)
    with np.load(tmp_path / "out.npz", allow_pickle=False) as out:
        assert "outliers" not in out.files
        np.testing.assert_array_equal(out["poses"][list(WRONG_FRAMES), WRIST],
                                      given[list(WRONG_FRAMES), WRIST])
    assert summary["outliers"] is None


def test_cli_no_outliers(case, tmp_path, small_dictionary_path, capsys):
    folder, given, _ = case
    code = main(["recover", str(folder), "-o", str(tmp_path / "on.npz"), "--no-adapt",
                 "--dictionary", str(small_dictionary_path)])
    assert code == 0 and "--no-outliers keeps them" in capsys.readouterr().err
    main(["recover", str(folder), "-o", str(tmp_path / "off.npz"), "--no-adapt",
          "--dictionary", str(small_dictionary_path), "--no-outliers"])
    with np.load(tmp_path / "off.npz", allow_pickle=False) as out:
        np.testing.assert_array_equal(out["poses"][100, WRIST], given[100, WRIST])


def test_api_names_outliers_in_the_result(track, small_dictionary):
    given = track.copy()
    size = float(np.median(body_size(track)))
    given[100, WRIST] += (0.4 * size, 0.0)
    conf = np.full(track.shape[:2], 0.9)
    conf[100, WRIST] = conf[50, KNEE] = 0.1
    frames = np.arange(len(track))
    res = recover(given, confidence=conf, frames=frames, dictionary=small_dictionary,
                  adapt=False)
    assert np.argwhere(res.outliers).tolist() == [[100, WRIST]]
    assert res.source[100, WRIST] == "outlier" and res.source[50, KNEE] == "observed"
    assert res.summary()["temporal"]["joints"]["outlier"] == 1
    off = recover(given, confidence=conf, frames=frames, dictionary=small_dictionary,
                  adapt=False, outliers=False)
    assert off.outliers is None and off.source[100, WRIST] == "observed"


def test_photo_alone_flags_only_a_gross_error(track, small_dictionary):
    pose = track[:1].copy()
    size = float(body_size(pose)[0])
    conf = np.full((1, 14), 0.9)
    conf[0, WRIST] = 0.1
    near = recover(pose, confidence=conf, dictionary=small_dictionary, adapt=False)
    assert not near.outliers.any()
    pose[0, WRIST] += ((DEFAULT_OUTLIER_SETTINGS.alone_limit + 0.3) * size, 0.0)
    far = recover(pose, confidence=conf, dictionary=small_dictionary, adapt=False)
    assert far.outliers[0, WRIST] and far.status[0] == "recovered"


def test_confidence_is_checked(track):
    with pytest.raises(ParameterError, match="confidence must have the poses' shape"):
        recover(track[:2], confidence=np.ones((2, 13)))
    with pytest.raises(ParameterError, match="outside"):
        recover(track[:2], confidence=np.full((2, 14), 1.5))


def test_defaults_are_the_ones_the_study_chose():
    chosen = json.loads((Path(__file__).resolve().parents[1] / "studies" / "outliers"
                         / "selection.json").read_text())["chosen"]
    assert DEFAULT_OUTLIER_SETTINGS == OutlierSettings(
        **{k: chosen[k] for k in OutlierSettings._fields})
