"""`sparseedm recover` and sparseedm.batch.recover_file: round trips per format,
errors file, exit codes, atomic output."""

import csv
import json
import os

import numpy as np
import pytest

from sparseedm.batch import default_errors_path, recover_file
from sparseedm.cli import main
from sparseedm.exceptions import FileFormatError, SparseEDMError
from sparseedm.keypoints import read_keypoints, write_keypoints
from sparseedm.metrics import random_occlusion

N = 30
BAD_ROW = 4   # two observed joints only: too_few_observed


@pytest.fixture(scope="module")
def occluded(cmu_poses):
    """30 real poses, Mix occlusion, one row with only 2 observed joints."""
    poses = cmu_poses[::11][:N].copy()
    missing = random_occlusion(N, 14, "mix", random_state=3)
    missing[BAD_ROW] = True
    missing[BAD_ROW, :2] = False
    poses[missing] = np.nan
    return poses, missing


def _ids():
    return [f"img{i:03d}" for i in range(N)]


def _write_input(path, poses, fmt):
    if fmt == "npy":
        np.save(path, poses)
    else:
        write_keypoints(path, poses, ids=_ids())


def _recover(inp, out, dict_path, *extra):
    return main(["recover", str(inp), "-o", str(out), "--dictionary", str(dict_path),
                 "--quiet", *extra])


@pytest.mark.parametrize("ext", ["csv", "npz", "npy", "json"])
def test_round_trip_each_format(tmp_path, occluded, small_dictionary_path, ext, capsys):
    poses, missing = occluded
    inp, out = tmp_path / f"in.{ext}", tmp_path / f"out.{ext}"
    _write_input(inp, poses, ext)
    before = read_keypoints(inp)

    assert _recover(inp, out, small_dictionary_path) == 1       # one row refused
    err = capsys.readouterr().err
    assert "rows refused: 1" in err and "poses: 30" in err

    back = read_keypoints(out)
    assert len(back) == N
    ok = np.arange(N) != BAD_ROW
    assert not back.missing[ok].any()                            # every joint filled
    assert np.isfinite(back.poses[ok]).all()
    observed = ~before.missing
    np.testing.assert_array_equal(back.poses[observed], before.poses[observed])
    # the refused row comes back as it was read
    np.testing.assert_array_equal(back.missing[BAD_ROW], before.missing[BAD_ROW])
    if ext != "npy":
        assert back.ids.tolist() == before.ids.tolist()

    # per-row status travels with the output
    if ext == "csv":
        status = back.meta["extra_columns"]["status"]
        n_active = back.meta["extra_columns"]["n_active"]
        objective = back.meta["extra_columns"]["objective"]
        assert objective[BAD_ROW] == "" and float(objective[0]) > 0
        assert int(n_active[0]) > 0
    elif ext == "npz":
        status = back.meta["npz_extra"]["status"]
        assert back.meta["npz_extra"]["gap"].shape == (N,)
    elif ext == "npy":
        with np.load(tmp_path / "out.status.npz") as side:
            status = side["status"]
            assert {"reason", "objective", "gap", "n_active"} <= set(side.files)
    else:
        anns = json.loads(out.read_text())
        status = [a["sparseedm"]["status"] for a in anns]
        assert anns[BAD_ROW]["sparseedm"]["objective"] is None
    status = list(status)
    assert status[BAD_ROW] == "too_few_observed"
    assert all(s in ("recovered", "complete") for i, s in enumerate(status) if i != BAD_ROW)

    # errors file: the refused row
    with open(tmp_path / "out.errors.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows == [{"row": str(BAD_ROW), "id": "" if ext == "npy" else _ids()[BAD_ROW],
                     "status": "too_few_observed", "reason": rows[0]["reason"]}]
    assert "2 observed joints" in rows[0]["reason"]
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".")]  # no temp files


def test_coco_document_kept(tmp_path, occluded, small_dictionary_path, strict_json):
    """A COCO ground-truth document comes back with its other fields untouched, as
    strict JSON: a NaN it held (Python's json reads and writes them) comes back null."""
    poses, _ = occluded
    fresh = tmp_path / "fresh.json"
    write_keypoints(fresh, poses, ids=[str(i) for i in range(N)])
    doc = {"info": {"year": 2024, "threshold": float("nan")},
           "annotations": json.loads(fresh.read_text())}
    for i, ann in enumerate(doc["annotations"]):
        ann["id"] = 100 + i
        ann["score"] = float("nan") if i % 2 else 0.5
        del ann["sparseedm"]
    inp = tmp_path / "gt.json"
    inp.write_text(json.dumps(doc))
    out = tmp_path / "gt_out.json"
    main(["recover", str(inp), "-o", str(out), "--dictionary", str(small_dictionary_path), "-q"])
    back = strict_json(out.read_text())
    assert back["info"] == {"year": 2024, "threshold": None}
    assert [a["score"] for a in back["annotations"][:2]] == [0.5, None]
    refused = back["annotations"][BAD_ROW]["sparseedm"]
    assert refused["status"] == "too_few_observed" and refused["objective"] is None
    assert np.array_equal(read_keypoints(out).missing, read_keypoints(inp).missing
                          & (np.arange(N) == BAD_ROW)[:, None])  # read back: filled but row 4
    assert [a["id"] for a in back["annotations"]] == list(range(100, 100 + N))
    filled = [a for a in back["annotations"] if a["sparseedm"]["filled"]]
    assert filled and all(a["sparseedm"]["status"] == "recovered" for a in filled)


def test_all_rows_ok_exit_0_and_no_errors_file(tmp_path, occluded, small_dictionary_path,
                                               capsys):
    poses, _ = occluded
    good = np.delete(poses, BAD_ROW, axis=0)
    inp, out = tmp_path / "good.csv", tmp_path / "good_out.csv"
    write_keypoints(inp, good)
    stale = default_errors_path(out)
    stale.write_text("row,id,status,reason\n0,,too_few_observed,old\n")
    assert main(["recover", str(inp), "-o", str(out), "--dictionary",
                 str(small_dictionary_path)]) == 0
    printed = capsys.readouterr().out
    assert "rows refused: 0" in printed and "poses/s" in printed
    assert out.exists() and not stale.exists()   # an earlier run's errors file is removed


def test_format_conversion_and_errors_path(tmp_path, occluded, small_dictionary_path):
    poses, _ = occluded
    inp = tmp_path / "in.csv"
    write_keypoints(inp, poses, ids=_ids())
    out, errs = tmp_path / "out.data", tmp_path / "refused.csv"
    code = _recover(inp, out, small_dictionary_path, "--format", "npz", "--errors", str(errs),
                    "--save-edm")
    assert code == 1 and errs.exists() and not default_errors_path(out).exists()
    back = read_keypoints(out, format="npz")
    assert back.ids.tolist() == _ids()
    edm = back.meta["npz_extra"]["edm_vectors"]
    assert edm.shape == (N, 91) and np.isnan(edm[BAD_ROW]).all()
    assert np.isfinite(np.delete(edm, BAD_ROW, axis=0)).all()


@pytest.mark.parametrize("ext,content", [
    ("csv", "id,head_top_x\nfoo,1\n"),                          # missing columns
    ("json", '[{"image_id": 1, "keypoints": [1, 2'),           # truncated
    ("npz", "not a zip file"),
    ("npy", "\x93NUMPY garbage"),
])
def test_corrupt_input_exit_2_nothing_written(tmp_path, small_dictionary_path, ext, content,
                                              capsys):
    inp, out = tmp_path / f"bad.{ext}", tmp_path / f"out.{ext}"
    inp.write_text(content)
    assert _recover(inp, out, small_dictionary_path) == 2
    assert "error" in capsys.readouterr().err
    assert sorted(os.listdir(tmp_path)) == [f"bad.{ext}"]


def test_csv_with_a_bad_row_halfway_leaves_no_output(tmp_path, occluded, small_dictionary_path):
    poses, _ = occluded
    inp, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_keypoints(inp, poses)
    lines = inp.read_text().splitlines()
    lines[10] = lines[10].replace(",", ",abc", 1)
    inp.write_text("\n".join(lines) + "\n")
    assert _recover(inp, out, small_dictionary_path) == 2
    assert sorted(os.listdir(tmp_path)) == ["in.csv"]


def test_whole_file_errors(tmp_path, occluded, small_dictionary_path, capsys):
    poses, _ = occluded
    inp = tmp_path / "in.npy"
    np.save(inp, poses)
    out = tmp_path / "out.npy"
    assert _recover(inp, out, small_dictionary_path, "--alpha", "0") == 2
    assert _recover(inp, out, tmp_path / "nope.npz") == 2
    assert _recover(tmp_path / "missing.npy", out, small_dictionary_path) == 2
    wrong = tmp_path / "wrong.npy"
    np.save(wrong, np.ones((3, 17, 2)))
    assert _recover(wrong, out, small_dictionary_path) == 2
    assert sorted(os.listdir(tmp_path)) == ["in.npy", "wrong.npy"]


def test_infinite_coordinate_flags_its_row_and_the_rest_recover(tmp_path, occluded,
                                                                small_dictionary_path, capsys):
    """One row with an infinite coordinate never sinks the batch (.npy streamed,
    .csv read whole): that row is refused and named in the errors file, every
    other row but the fixture's bad one is recovered."""
    poses, _ = occluded
    poses = poses.copy()
    joint = int(np.flatnonzero(np.isfinite(poses[20, :, 0]))[0])
    poses[20, joint, 0] = np.inf                  # an observed joint of row 20
    for ext in ("npy", "csv"):
        inp, out = tmp_path / f"in.{ext}", tmp_path / f"out.{ext}"
        if ext == "npy":
            np.save(inp, poses)
        else:  # write_keypoints writes an inf as missing: the token is put in by hand
            marked = poses.copy()
            marked[20, joint, 0] = 123456.5
            write_keypoints(inp, marked, ids=_ids())
            inp.write_text(inp.read_text().replace("123456.5", "inf"))
        assert _recover(inp, out, small_dictionary_path) == 1
        assert "2 row(s) refused" in capsys.readouterr().err
        with open(default_errors_path(out), newline="") as f:
            errors = {int(r["row"]): r["status"] for r in csv.DictReader(f)}
        assert errors == {BAD_ROW: "too_few_observed", 20: "invalid_coordinates"}
        back = read_keypoints(out)
        good = np.setdiff1d(np.arange(N), [BAD_ROW, 20])
        assert not back.missing[good].any() and np.isfinite(back.poses[good]).all()
        assert back.missing[20, joint]            # written back as read, the inf as missing
        np.testing.assert_array_equal(back.missing[20], np.isnan(poses[20, :, 0]) |
                                      (np.arange(14) == joint))

def test_recover_file_chunks_and_confidence(tmp_path, occluded, small_dictionary):
    """Small chunks give the same output as one chunk; a confidence threshold
    turns low-confidence joints into recovered ones."""
    poses, missing = occluded
    conf = np.where(missing, 0.0, 0.9)
    j = int(np.flatnonzero(~missing[0])[0])
    conf[0, j] = 0.2                       # observed, but below the threshold
    arr = np.concatenate([np.nan_to_num(poses), conf[..., None]], axis=-1)
    inp = tmp_path / "in.npy"
    np.save(inp, arr)
    one = recover_file(inp, tmp_path / "one.npy", dictionary=small_dictionary,
                       confidence_threshold=0.5)
    many = recover_file(inp, tmp_path / "many.npy", dictionary=small_dictionary,
                        chunk_size=7, confidence_threshold=0.5)
    a, b = np.load(tmp_path / "one.npy"), np.load(tmp_path / "many.npy")
    # chunks regroup poses by missing pattern: equal up to BLAS round-off
    np.testing.assert_allclose(a, b, rtol=1e-10)
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    assert one["poses"] == many["poses"] == N and one["refused"] == 1
    assert one["recovered_joints"] == int(np.delete(missing, BAD_ROW, axis=0).sum()) + 1
    assert a.shape == (N, 14, 2) and a[0, j].tolist() != poses[0, j].tolist()
    assert set(one) >= {"poses", "recovered_joints", "refused", "seconds", "poses_per_second"}


def test_recover_file_rejects_bad_options(tmp_path, occluded, small_dictionary):
    poses, _ = occluded
    inp = tmp_path / "in.csv"
    write_keypoints(inp, poses)
    with pytest.raises(SparseEDMError, match="alpha"):
        recover_file(inp, tmp_path / "o.csv", dictionary=small_dictionary, alpha=-1)
    with pytest.raises(SparseEDMError, match="representation"):
        recover_file(inp, tmp_path / "o.csv", dictionary=small_dictionary,
                     representation="mean")
    with pytest.raises(FileFormatError):
        recover_file(inp, tmp_path / "o.csv", dictionary=small_dictionary,
                     output_format="xml")
    assert sorted(os.listdir(tmp_path)) == ["in.csv"]


@pytest.mark.parametrize("score", ["2", "-1", "1.0000001", "nan"])
def test_filled_score_outside_0_1_is_refused(tmp_path, occluded, small_dictionary_path,
                                             small_dictionary, score, capsys):
    """A score the readers refuse would make the tool's own output unreadable."""
    poses, _ = occluded
    inp = tmp_path / "in.json"
    write_keypoints(inp, poses, ids=_ids())
    assert _recover(inp, tmp_path / "o.json", small_dictionary_path, "--no-adapt",
                    "--filled-score", score) == 2
    assert "filled_score must be a real number in [0, 1]" in capsys.readouterr().err
    with pytest.raises(SparseEDMError, match=r"filled_score must be a real number in \[0, 1\]"):
        recover_file(inp, tmp_path / "o.json", dictionary=small_dictionary, adapt=False,
                     filled_score=float(score))
    with pytest.raises(SparseEDMError, match="filled_score"):
        write_keypoints(tmp_path / "o.json", poses, filled_score=float(score))
    assert sorted(os.listdir(tmp_path)) == ["in.json"]


def test_example_file_recovers(tmp_path, small_dictionary_path):
    """The README's job on the shipped example (with the small test dictionary)."""
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "examples" / "occluded_poses.csv"
    out = tmp_path / "recovered.csv"
    assert _recover(example, out, small_dictionary_path) == 0
    kps = read_keypoints(out)
    assert len(kps) == 50 and not kps.missing.any()


def test_a_video_keeps_its_tracks_and_frames_across_formats(tmp_path):
    """CSV in, npz out and back: the time axis is not lost on the way."""
    from sparseedm.keypoints import read_keypoints

    from pathlib import Path

    video = Path(__file__).resolve().parents[1] / "examples" / "video_clip.csv"
    given = read_keypoints(video)
    as_npz = tmp_path / "filled.npz"
    assert main(["recover", str(video), "-o", str(as_npz), "-q", "--no-adapt"]) == 0
    with np.load(as_npz, allow_pickle=False) as z:
        np.testing.assert_array_equal(z["tracks"], given.tracks)
        np.testing.assert_array_equal(z["frames"], given.frames)
    back = tmp_path / "back.csv"
    assert main(["recover", str(as_npz), "-o", str(back), "-q", "--no-adapt"]) == 0
    again = read_keypoints(back)
    np.testing.assert_array_equal(again.tracks, given.tracks)
    np.testing.assert_array_equal(again.frames, given.frames)


def test_a_streamed_npy_with_zeros_for_missing_joints(tmp_path, occluded, small_dictionary_path,
                                                       capsys):
    """A .npy read in chunks with 0, 0 for its missing joints is recovered as the
    same file with NaN there, and the warning is given once, not per chunk."""
    poses, missing = occluded
    np.save(tmp_path / "nan.npy", poses)
    np.save(tmp_path / "zeros.npy", np.nan_to_num(poses))
    for name in ("nan", "zeros"):
        _recover(tmp_path / f"{name}.npy", tmp_path / f"{name}_out.npy",
                 small_dictionary_path, "--chunk-size", "8", "--no-adapt")
    err = capsys.readouterr().err
    assert err.count("at exactly (0, 0)") == 1, err
    assert "zeros.npy (poses 0-7; later chunks alike" in err
    np.testing.assert_array_equal(np.load(tmp_path / "zeros_out.npy"),
                                  np.load(tmp_path / "nan_out.npy"))
