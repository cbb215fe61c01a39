"""Every format ``recover`` writes reads back with its filled joints present and flagged."""

import re

import numpy as np
import pytest

from sparseedm.batch import recover_file
from sparseedm.exceptions import FileFormatError
from sparseedm.keypoints import read_keypoints, status_sidecar, write_keypoints

OUTPUTS = [  # (output name, --format)
    ("out.csv", None), ("out.npz", None), ("out.npy", None), ("out.json", None),
    ("mmpose.json", "mmpose"), ("openpose", "openpose"), ("dlc.csv", "dlc"),
    ("dlc.h5", "dlc")]


@pytest.fixture(scope="module")
def occluded(cmu_poses, tmp_path_factory):
    """A CSV of 30 real poses, a wrist or a knee missing in two rows of three."""
    poses = cmu_poses[:30].copy()
    poses[::3, 7] = np.nan
    poses[1::3, 10] = np.nan
    src = tmp_path_factory.mktemp("read_back") / "in.csv"
    write_keypoints(src, poses, ids=[f"f{i}" for i in range(30)])
    return src, np.isnan(poses).any(axis=-1)


@pytest.mark.parametrize("name,fmt", OUTPUTS, ids=[n for n, _ in OUTPUTS])
def test_recovered_file_reads_back_filled_and_flagged(occluded, tmp_path, name, fmt):
    if name.endswith(".h5"):
        pytest.importorskip("pandas")
        pytest.importorskip("tables")
    src, was_missing = occluded
    out = tmp_path / name
    summary = recover_file(src, out, output_format=fmt, adapt=False)
    assert summary["status"].get("recovered") == int(was_missing.any(axis=1).sum())
    kps = read_keypoints(out)
    assert kps.meta["format"] == (fmt or {"csv": "csv", "npz": "npz", "npy": "npy",
                                          "json": "coco"}[name.rsplit(".", 1)[1]])
    present = ~np.isnan(kps.poses).any(axis=-1)
    assert present.all() and not kps.missing.any()  # the filled joints: coordinates
    assert kps.filled is not None
    np.testing.assert_array_equal(kps.filled, was_missing)


def test_a_sidecar_of_another_file_is_ignored_with_a_warning(occluded, tmp_path):
    src, was_missing = occluded
    out = tmp_path / "dlc.csv"
    recover_file(src, out, output_format="dlc", adapt=False)
    side = status_sidecar(out)
    with open(side, "wb") as f:  # stale: another file's rows
        np.savez(f, filled=np.ones((5, 14), bool))
    with pytest.warns(UserWarning, match=f"ignored {side}.*for its 30 poses"):
        kps = read_keypoints(out)
    assert kps.filled is None
    # without its flags, a filled joint is what the table says: likelihood 0, missing
    np.testing.assert_array_equal(kps.missing, was_missing)
    side.unlink()
    assert read_keypoints(out).filled is None


@pytest.mark.parametrize("ext", ["csv", "npz"])
def test_a_rerun_writes_what_it_did_not_an_earlier_runs_results(cmu_poses, small_dictionary,
                                                                tmp_path, ext):
    """An input that is an earlier run's output: its result columns (what that
    run averaged, its outliers, its EDMs) are not carried into this run's
    output, which blends nothing here; a CSV's own columns are."""
    poses = cmu_poses[:20].copy()
    poses[::2, 7] = np.nan
    stale = {"averaged": np.array(["local ridge over file atoms"] * 20),
             "outliers": np.array(["l_wrist"] * 20), "note": np.array([f"n{i}" for i in range(20)])}
    src = tmp_path / f"in.{ext}"
    if ext == "csv":
        write_keypoints(src, poses, extra_columns={k: v.tolist() for k, v in stale.items()})
    else:
        stale["edm_vectors"] = np.zeros((20, 91))
        write_keypoints(src, poses, meta={"npz_extra": stale})
    read = read_keypoints(src).meta
    assert "averaged" in read.get("extra_columns", read.get("npz_extra"))  # the input has it
    out = tmp_path / f"out.{ext}"
    recover_file(src, out, dictionary=small_dictionary, adapt=False, exemplars=False)
    back = read_keypoints(out).meta
    carried = back["extra_columns"] if ext == "csv" else back["npz_extra"]
    assert not {"averaged", "outliers", "edm_vectors"} & set(carried)
    if ext == "csv":
        np.testing.assert_array_equal(np.asarray(carried["note"], str), stale["note"])
    assert (np.asarray(carried["status"], str)[::2] == "recovered").all()


def test_photos_whose_names_hold_numbers_are_recovered_as_photos(cmu_poses, tmp_path,
                                                                  small_dictionary, capsys):
    """Frames far apart (photo names' numbers, as COCO's 000000397133.jpg): no pose
    has a neighbouring frame of its track, so the file is recovered as photos,
    said in the summary and the CLI, its frames written back as read; frames
    close together stay a video."""
    from sparseedm.cli import main

    poses = cmu_poses[:40].copy()
    poses[::2, 7] = np.nan
    far = [str(397133 + 1000 * i) for i in range(40)]
    src = tmp_path / "photos.csv"
    write_keypoints(src, poses, extra_columns={"frame": far})
    summary = recover_file(src, tmp_path / "out.csv", dictionary=small_dictionary)
    assert summary["temporal"] is None
    assert summary["frames_unused"] == {"alone": 40, "poses": 40, "max_skip": 30}
    back = read_keypoints(tmp_path / "out.csv")
    np.testing.assert_array_equal(back.frames.astype(int), np.asarray(far, int))
    assert back.tracks is None  # no tracks linked for photos
    video = tmp_path / "video.csv"
    write_keypoints(video, poses, extra_columns={"frame": [str(i) for i in range(40)]})
    summary = recover_file(video, tmp_path / "v.csv", dictionary=small_dictionary)
    assert summary["temporal"] is not None and summary["frames_unused"] is None
    dict_path = small_dictionary.save(tmp_path / "d.npz")
    assert main(["recover", str(src), "-o", str(tmp_path / "cli.csv"), "--quiet",
                 "--dictionary", str(dict_path)]) == 0
    said = capsys.readouterr().err
    assert "40 of 40 poses have no other frame of their track" in said
    assert "recovered as photos" in said and "recovered across time" not in said
    assert f"has frame numbers {far[0]}-{far[-1]} " in said  # what was inferred
    assert main(["recover", str(video), "-o", str(tmp_path / "cli_v.csv"), "--quiet",
                 "--dictionary", str(dict_path)]) == 0
    assert "has frames 0-39: recovered across time" in capsys.readouterr().err


def test_frames_survive_conversion_to_coco_and_npz(cmu_poses, tmp_path, small_dictionary):
    """A video CSV written as COCO keeps its frames (PoseTrack images; they were
    dropped and read back as 0, 1, 2...); as .npz its frame text becomes numbers
    the .npz reader takes (blank: NaN; it wrote text the reader refused), and
    text that is no frame number is refused naming the output, nothing written."""
    poses = cmu_poses[:6].copy()
    poses[::2, 4] = np.nan
    src = tmp_path / "in.csv"
    write_keypoints(src, poses, extra_columns={"frame": ["1", "1", "2", "2", "3", "3"],
                                               "track": list("ababab")})
    recover_file(src, tmp_path / "out.json", dictionary=small_dictionary, adapt=False,
                 temporal=False)
    back = read_keypoints(tmp_path / "out.json")
    assert back.frames is not None and back.frames.tolist() == [1, 1, 2, 2, 3, 3]
    write_keypoints(src, poses, extra_columns={"frame": ["1", "2", "3", "4", str(2 ** 62),
                                                         "6"]})
    recover_file(src, tmp_path / "out.npz", dictionary=small_dictionary, adapt=False)
    assert read_keypoints(tmp_path / "out.npz").frames.tolist() == [1, 2, 3, 4, 2 ** 62, 6]
    write_keypoints(src, poses, extra_columns={"frame": ["1", "2", "", "4", "5", "6"]})
    recover_file(src, tmp_path / "blank.npz", dictionary=small_dictionary, adapt=False)
    assert np.isnan(read_keypoints(tmp_path / "blank.npz").frames[2])
    write_keypoints(src, poses, extra_columns={"frame": ["1", "2", "x", "4", "5", "6"]})
    out = tmp_path / "text.npz"
    with pytest.raises(FileFormatError, match=rf"writing {re.escape(str(out))}: pose 2: "
                                              "frame 'x' is not a whole number"):
        recover_file(src, out, dictionary=small_dictionary, adapt=False)
    assert not out.exists()
