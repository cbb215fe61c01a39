"""Keypoint I/O: .npz/.npy, CSV and COCO-style JSON."""

import csv
import json
import os
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, HealthCheck
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from sparseedm.exceptions import FileFormatError, SparseEDMError
from sparseedm.keypoints import (
    COCO_KEYPOINTS,
    HEAD_TOP_FACTOR,
    KeypointSet,
    origin_joints,
    read_keypoints,
    write_keypoints,
)
from sparseedm.skeleton import JOINT_NAMES, SKELETON_14

J = SKELETON_14.index


def _poses(n=3, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-50, 500, size=(n, 14, 2))


def _assert_same(a, b):
    np.testing.assert_array_equal(a, b)  # NaN == NaN for this helper


# ---------------------------------------------------------------- npz / npy


def test_npz_round_trip(tmp_path):
    poses = _poses()
    missing = np.zeros((3, 14), bool)
    missing[0, J("left_wrist")] = missing[2, [0, 13]] = True
    conf = np.full((3, 14), 0.9)
    path = tmp_path / "k.npz"
    write_keypoints(path, poses, missing, confidence=conf, ids=["a", "b", "c"])
    kps = read_keypoints(path)
    assert isinstance(kps, KeypointSet) and len(kps) == 3
    _assert_same(kps.missing, missing)
    assert np.isnan(kps.poses[missing]).all()
    _assert_same(kps.poses[~missing], poses[~missing])
    _assert_same(kps.confidence, conf)
    assert kps.ids.tolist() == ["a", "b", "c"]
    assert kps.meta["format"] == "npz"
    # a KeypointSet writes itself back unchanged
    write_keypoints(tmp_path / "k2.npz", kps)
    again = read_keypoints(tmp_path / "k2.npz")
    _assert_same(again.poses, kps.poses)
    _assert_same(again.missing, kps.missing)


def test_npz_missing_from_mask_nan_and_confidence(tmp_path):
    poses = _poses(2)
    poses[0, 3] = np.nan
    missing = np.zeros((2, 14), bool)
    missing[1, 5] = True
    conf = np.ones((2, 14))
    conf[1, 8] = 0.2
    conf[0, 9] = 0.0  # zero confidence: always missing
    np.savez(tmp_path / "k.npz", poses=poses, missing=missing, confidence=conf)
    kps = read_keypoints(tmp_path / "k.npz", confidence_threshold=0.5)
    expected = np.zeros((2, 14), bool)
    expected[0, 3] = expected[1, 5] = expected[1, 8] = expected[0, 9] = True
    _assert_same(kps.missing, expected)
    assert np.isnan(kps.poses[expected]).all()
    assert not np.isnan(kps.poses[~expected]).any()


def test_npz_result_fields_round_trip_and_unknown_members_are_ignored(tmp_path):
    """Per-row result arrays are kept; any other member is never read nor copied
    (a small zipped member can decompress to gigabytes)."""
    np.savez(tmp_path / "k.npz", poses=_poses(2), frame_rate=np.array(30.0),
             status=np.array(["recovered", "complete"]))
    kps = read_keypoints(tmp_path / "k.npz")
    assert kps.meta["npz_ignored"] == ["frame_rate"]
    write_keypoints(tmp_path / "out.npz", kps)
    with np.load(tmp_path / "out.npz") as data:
        assert "frame_rate" not in data.files
        assert data["status"].tolist() == ["recovered", "complete"]


class _Boom:
    """Unpickling this would create a file: the readers must never do it."""

    def __init__(self, target):
        self.target = target

    def __reduce__(self):
        return (open, (self.target, "w"))


def test_npz_with_pickle_is_refused_not_executed(tmp_path):
    target = tmp_path / "pwned"
    ids = np.empty(2, dtype=object)
    ids[:] = [_Boom(str(target)), "x"]
    np.savez(tmp_path / "k.npz", poses=_poses(2), ids=ids)
    with pytest.raises(FileFormatError, match="pickle"):
        read_keypoints(tmp_path / "k.npz")
    assert not target.exists()


def test_npy_with_pickle_is_refused_not_executed(tmp_path):
    target = tmp_path / "pwned"
    arr = np.empty((1, 14, 2), dtype=object)
    arr[0, 0, 0] = _Boom(str(target))
    np.save(tmp_path / "k.npy", arr, allow_pickle=True)
    with pytest.raises(FileFormatError, match="pickle"):
        read_keypoints(tmp_path / "k.npy")
    assert not target.exists()


def test_npy_plain_and_with_confidence(tmp_path):
    poses = _poses(2)
    poses[1, 4] = np.nan
    np.save(tmp_path / "p.npy", poses)
    kps = read_keypoints(tmp_path / "p.npy")
    assert kps.missing.sum() == 1 and kps.missing[1, 4]
    assert kps.confidence is None

    conf = np.ones((2, 14))
    conf[0, 2] = 0.1
    np.save(tmp_path / "c.npy", np.concatenate([_poses(2), conf[..., None]], -1))
    kps = read_keypoints(tmp_path / "c.npy", confidence_threshold=0.3)
    assert kps.missing.sum() == 1 and kps.missing[0, 2]
    _assert_same(kps.confidence, conf)

    write_keypoints(tmp_path / "w.npy", kps)
    back = np.load(tmp_path / "w.npy")
    assert back.shape == (2, 14, 3)
    assert np.isnan(back[0, 2, :2]).all()


def test_single_pose_array_is_one_pose(tmp_path):
    np.save(tmp_path / "p.npy", _poses(1)[0])
    assert read_keypoints(tmp_path / "p.npy").poses.shape == (1, 14, 2)


def test_npy_ids_dropped_with_warning(tmp_path):
    with pytest.warns(UserWarning, match="ids"):
        write_keypoints(tmp_path / "p.npy", _poses(1), ids=["a"])


@pytest.mark.parametrize("shape", [(2, 17, 2), (2, 13, 2)])
def test_joint_count_mismatch(tmp_path, shape):
    np.save(tmp_path / "p.npy", np.zeros(shape))
    with pytest.raises(FileFormatError, match=f"{shape[1]} joints"):
        read_keypoints(tmp_path / "p.npy")
    np.savez(tmp_path / "p.npz", poses=np.zeros(shape))
    with pytest.raises(FileFormatError, match=f"{shape[1]} joints"):
        read_keypoints(tmp_path / "p.npz")
    with pytest.raises(FileFormatError, match=f"{shape[1]} joints"):
        write_keypoints(tmp_path / "out.csv", np.zeros(shape))


@pytest.mark.parametrize("shape", [(2, 14, 4), (2, 14), (14,), (2, 3, 14, 2)])
def test_wrong_array_shape(tmp_path, shape):
    arr = np.zeros(shape)
    np.save(tmp_path / "p.npy", arr)
    with pytest.raises(FileFormatError, match="shape|joints"):
        read_keypoints(tmp_path / "p.npy")


def test_npz_errors(tmp_path):
    np.savez(tmp_path / "a.npz", joints=_poses(1))
    with pytest.raises(FileFormatError, match="'poses'"):
        read_keypoints(tmp_path / "a.npz")
    np.savez(tmp_path / "b.npz", poses=_poses(2), missing=np.zeros((2, 13), bool))
    with pytest.raises(FileFormatError, match="missing must have shape"):
        read_keypoints(tmp_path / "b.npz")
    (tmp_path / "c.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(FileFormatError, match="c.npz"):
        read_keypoints(tmp_path / "c.npz")


# ---------------------------------------------------------------------- CSV


def test_csv_round_trip_with_ids_conf_and_extra_columns(tmp_path):
    poses = _poses()
    poses[1, 7] = np.nan
    conf = np.random.default_rng(1).uniform(0.5, 1, (3, 14))
    path = tmp_path / "k.csv"
    write_keypoints(path, poses, confidence=conf, ids=["img1", "img2", "img3"],
                    extra_columns={"status": ["ok", "recovered", "failed"]})
    with open(path, newline="") as f:
        header = next(csv.reader(f))
    assert header[0] == "id"
    assert header[1:29] == [f"{n}_{a}" for n in JOINT_NAMES for a in "xy"]
    assert header[29:43] == [f"{n}_conf" for n in JOINT_NAMES]
    assert header[43:] == ["status"]

    kps = read_keypoints(path)
    _assert_same(kps.poses, poses)  # repr() floats: exact
    _assert_same(kps.confidence, conf)
    assert kps.missing.sum() == 1 and kps.missing[1, 7]
    assert kps.ids.tolist() == ["img1", "img2", "img3"]
    assert kps.meta["extra_columns"] == {"status": ["ok", "recovered", "failed"]}

    write_keypoints(tmp_path / "again.csv", kps)
    assert (tmp_path / "again.csv").read_text() == path.read_text()


def _header(id_col=True):
    return (["id"] if id_col else []) + [f"{n}_{a}" for n in JOINT_NAMES for a in "xy"]


def _write_rows(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def test_csv_reads_any_column_order_blank_lines_and_nan(tmp_path):
    header = _header(id_col=False)[::-1]
    row = [str(float(i)) for i in range(28)]
    row[0] = ""       # left_ankle_y empty -> left_ankle missing
    row[3] = "NaN"    # left_knee_x -> left_knee missing
    path = tmp_path / "k.csv"
    _write_rows(path, header, [row, [], row])
    kps = read_keypoints(path)
    assert len(kps) == 2 and kps.ids is None
    assert kps.missing[0].tolist() == [False] * 12 + [True, True]
    assert kps.poses[0, J("head_top")].tolist() == [27.0, 26.0]


def test_csv_wrong_field_count_names_line(tmp_path):
    good = ["a"] + ["1"] * 28
    path = tmp_path / "k.csv"
    _write_rows(path, _header(), [good, good[:-3]])
    with pytest.raises(FileFormatError, match=r"k\.csv, line 3: 26 fields"):
        read_keypoints(path)


def test_csv_non_numeric_names_line_and_column(tmp_path):
    bad = ["a"] + ["1"] * 28
    bad[3] = "abc"  # neck_x (after id, head_top_x, head_top_y)
    path = tmp_path / "k.csv"
    _write_rows(path, _header(), [["a"] + ["1"] * 28, bad])
    with pytest.raises(FileFormatError, match=r"line 3, column 'neck_x': 'abc'"):
        read_keypoints(path)


def _csv_of_every_kind(path, n=11):
    """A CSV with ids, confidences, filled flags, a track/frame, blank lines."""
    poses = _poses(n, seed=4)
    poses[2, 5] = np.nan
    poses[9, 0] = np.nan
    conf = np.random.default_rng(5).uniform(0.5, 1, (n, 14))
    filled = np.zeros((n, 14), dtype=bool)
    filled[7, 3] = True
    write_keypoints(path, poses, confidence=conf, ids=[f"f{i}" for i in range(n)],
                    filled=filled, extra_columns={"track": ["a"] * 6 + ["b"] * (n - 6),
                                                  "frame": [str(i) for i in range(n)]})
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:4] + ["\n"] + lines[4:8] + ["\n", "\n"] + lines[8:]))


def test_csv_read_and_written_in_blocks_as_in_one(tmp_path, monkeypatch):
    # a file of millions of rows is parsed CSV_BLOCK_ROWS rows at a time: with
    # blocks of 3 rows every field comes out as with one block, blank lines
    # and rows straddling the blocks included, and is written back the same
    import sparseedm.keypoints as kp
    path = tmp_path / "k.csv"
    _csv_of_every_kind(path)
    one = read_keypoints(path)
    write_keypoints(tmp_path / "one.csv", one)
    monkeypatch.setattr(kp, "CSV_BLOCK_ROWS", 3)
    parsed, cells = [], []  # the rows each parse saw, the rows each write formatted
    float_columns, csv_cells = kp._float_columns, kp.csv_cells
    monkeypatch.setattr(kp, "_float_columns",
                        lambda rows, *a: parsed.append(len(rows)) or float_columns(rows, *a))
    monkeypatch.setattr(kp, "csv_cells", lambda v: cells.append(len(v)) or csv_cells(v))
    blocks = read_keypoints(path)
    write_keypoints(tmp_path / "blocks.csv", blocks)
    assert parsed == [3, 3] * 3 + [2, 2] and cells == [3, 3] * 3 + [2, 2]  # xy, conf
    assert len(blocks) == len(one) == 11
    for name in ("poses", "missing", "confidence", "filled", "ids", "tracks", "frames"):
        _assert_same(getattr(blocks, name), getattr(one, name))
    assert blocks.meta["extra_columns"] == one.meta["extra_columns"]
    assert (tmp_path / "blocks.csv").read_text() == (tmp_path / "one.csv").read_text()


@pytest.mark.parametrize("what", ["width", "number", "flag"])
def test_csv_bad_cell_in_a_later_block_names_its_line(tmp_path, monkeypatch, what):
    import sparseedm.keypoints as kp
    monkeypatch.setattr(kp, "CSV_BLOCK_ROWS", 3)
    header = _header() + [f"{n}_filled" for n in JOINT_NAMES]
    rows = [[f"r{i}"] + ["1"] * 28 + ["0"] * 14 for i in range(8)]
    if what == "width":
        rows[6] = rows[6][:-2]
        match = r"line 8: 41 fields, the header has 43"
    elif what == "number":
        rows[6][3] = "x1"
        match = r"line 8, column 'neck_x': 'x1' is not a number"
    else:
        rows[6][30] = "yes"
        match = r"line 8, column 'neck_filled': 'yes' is not a filled flag"
    path = tmp_path / "k.csv"
    _write_rows(path, header, rows)
    with pytest.raises(FileFormatError, match=match):
        read_keypoints(path)


def test_csv_header_errors(tmp_path):
    path = tmp_path / "k.csv"
    _write_rows(path, _header() + ["lefty_wrist_x"], [])
    with pytest.raises(FileFormatError, match="unknown joint 'lefty_wrist'"):
        read_keypoints(path)
    _write_rows(path, _header()[:-1], [])
    with pytest.raises(FileFormatError, match="missing column.*left_ankle_y"):
        read_keypoints(path)
    _write_rows(path, _header() + ["neck_conf"], [])
    with pytest.raises(FileFormatError, match="all 14 joints or none"):
        read_keypoints(path)
    _write_rows(path, _header() + ["id"], [])
    with pytest.raises(FileFormatError, match="twice"):
        read_keypoints(path)
    path.write_text("")
    with pytest.raises(FileFormatError, match="empty"):
        read_keypoints(path)


@pytest.mark.parametrize("suffix", ["score", "confidence", "likelihood"])
def test_csv_confidence_column_synonyms(tmp_path, suffix):
    poses = _poses()
    poses[:, 7] = 0.0  # a detector's "not found": 0, 0 scored 0
    conf = np.full((3, 14), 0.9)
    conf[:, 7] = 0.0
    conf[1, 3] = 0.2
    path = tmp_path / "k.csv"
    write_keypoints(path, poses, confidence=conf, extra_columns={"bbox_score": [1, 2, 3]})
    text = path.read_text()
    (tmp_path / "s.csv").write_text(text.replace("_conf", f"_{suffix}"))
    want, got = read_keypoints(path, confidence_threshold=0.3), \
        read_keypoints(tmp_path / "s.csv", confidence_threshold=0.3)
    np.testing.assert_array_equal(got.confidence, want.confidence)
    np.testing.assert_array_equal(got.missing, want.missing)
    assert got.missing[:, 7].all() and got.missing[1, 3]
    assert list(got.meta["extra_columns"]) == ["bbox_score"]  # not a joint: an extra
    mixed = text.replace("neck_conf", f"neck_{suffix}")
    (tmp_path / "m.csv").write_text(mixed)
    with pytest.raises(FileFormatError, match=rf"line 1: the confidence columns mix the "
                       rf"suffixes _conf, _{suffix}; use one for all 14 joints"):
        read_keypoints(tmp_path / "m.csv")
    header = _header() + [f"neck_{suffix}"]
    _write_rows(tmp_path / "one.csv", header, [])
    with pytest.raises(FileFormatError, match=rf"<joint>_{suffix} columns must be given for "
                       "all 14 joints or none"):
        read_keypoints(tmp_path / "one.csv")


def test_csv_extra_column_validation(tmp_path):
    with pytest.raises(FileFormatError, match="2 values for 3 poses"):
        write_keypoints(tmp_path / "k.csv", _poses(), extra_columns={"s": [1, 2]})
    with pytest.raises(FileFormatError, match="clashes"):
        write_keypoints(tmp_path / "k.csv", _poses(), extra_columns={"neck_x": [1, 2, 3]})


# --------------------------------------------------------------------- COCO


def _coco_kp(points):
    """51 values from {coco_name: (x, y, v)}; others [0, 0, 0]."""
    kp = [0.0] * 51
    for name, xyv in points.items():
        c = COCO_KEYPOINTS.index(name)
        kp[3 * c: 3 * c + 3] = list(xyv)
    return kp


FULL = {
    "nose": (100, 50, 2), "left_eye": (105, 45, 2), "right_eye": (95, 45, 2),
    "left_ear": (110, 50, 1), "right_ear": (90, 50, 2),
    "left_shoulder": (130, 100, 2), "right_shoulder": (70, 100, 2),
    "left_elbow": (140, 150, 2), "right_elbow": (60, 150, 2),
    "left_wrist": (145, 200, 2), "right_wrist": (55, 200, 2),
    "left_hip": (120, 200, 2), "right_hip": (80, 200, 2),
    "left_knee": (120, 280, 2), "right_knee": (80, 280, 2),
    "left_ankle": (120, 360, 2), "right_ankle": (80, 360, 2),
}


def test_coco_mapping(tmp_path):
    # head centre H = mean of the five head points = (100, 48); neck = (100, 100)
    # head_top = H + 0.8 (H - neck) = (100, 48 - 0.8 * 52) = (100, 6.4)
    ann = {"image_id": 42, "id": 5, "keypoints": _coco_kp(FULL), "num_keypoints": 17}
    path = tmp_path / "a.json"
    path.write_text(json.dumps({"images": [{"id": 42}], "annotations": [ann]}))
    kps = read_keypoints(path)
    assert HEAD_TOP_FACTOR == 0.8
    assert kps.ids.tolist() == ["42"]
    assert not kps.missing.any()
    np.testing.assert_allclose(kps.poses[0, J("neck")], [100, 100])
    np.testing.assert_allclose(kps.poses[0, J("head_top")], [100, 6.4])
    for name in JOINT_NAMES[2:]:
        assert kps.poses[0, J(name)].tolist() == list(FULL[name][:2])
    assert kps.confidence[0, J("head_top")] == 1  # smallest used (left ear v=1)


def test_coco_missing_rules(tmp_path):
    no_head = {k: v for k, v in FULL.items() if k not in COCO_KEYPOINTS[:5]}
    one_shoulder = dict(FULL, left_shoulder=(0, 0, 0))
    only_nose = {k: v for k, v in FULL.items() if k not in COCO_KEYPOINTS[1:5]}
    anns = [{"keypoints": _coco_kp(p)} for p in (no_head, one_shoulder, only_nose)]
    path = tmp_path / "a.json"
    path.write_text(json.dumps(anns))
    kps = read_keypoints(path)
    assert kps.ids.tolist() == ["", "", ""]
    assert kps.missing[0].tolist() == [True] + [False] * 13
    m1 = kps.missing[1]
    assert m1[J("neck")] and m1[J("head_top")] and m1[J("left_shoulder")]
    assert m1.sum() == 3
    # nose only: H = nose (100, 50); head_top = (100, 50 - 0.8 * 50) = (100, 10)
    np.testing.assert_allclose(kps.poses[2, J("head_top")], [100, 10])


def test_coco_results_scores_and_threshold(tmp_path):
    points = {k: (x, y, 0.9) for k, (x, y, _) in FULL.items()}
    points["right_knee"] = (80, 280, 0.2)
    path = tmp_path / "res.json"
    path.write_text(json.dumps([{"image_id": 1, "category_id": 1,
                                 "keypoints": _coco_kp(points), "score": 0.8}]))
    assert not read_keypoints(path, confidence_threshold=0).missing.any()
    for threshold in (None, 0.5):  # COCO's default, 0.3 (sparseedm.formats), or given
        kps = read_keypoints(path, confidence_threshold=threshold)
        assert kps.missing[0].tolist() == [j == J("right_knee") for j in range(14)]
    assert kps.confidence[0, J("right_knee")] == pytest.approx(0.2)


def test_coco_write_back_fills_missing_limbs(tmp_path):
    points = dict(FULL, left_wrist=(0, 0, 0), right_ankle=(0, 0, 0))
    anns = [{"image_id": 7, "id": 3, "category_id": 1, "area": 12.5,
             "keypoints": _coco_kp(points), "num_keypoints": 15}]
    doc = {"info": {"v": 1}, "annotations": anns}
    src = tmp_path / "gt.json"
    src.write_text(json.dumps(doc))
    kps = read_keypoints(src)
    assert kps.missing[0, J("left_wrist")] and kps.missing[0, J("right_ankle")]

    recovered = kps.poses.copy()
    recovered[0, J("left_wrist")] = [146.5, 201.25]   # recovered by someone
    out = tmp_path / "out.json"
    write_keypoints(out, recovered, meta=kps.meta)
    res = json.loads(out.read_text())
    assert res["info"] == {"v": 1}
    ann = res["annotations"][0]
    for key in ("image_id", "id", "category_id", "area", "num_keypoints"):
        assert ann[key] == anns[0][key]
    c = COCO_KEYPOINTS.index("left_wrist")
    assert ann["keypoints"][3 * c: 3 * c + 3] == [146.5, 201.25, 0.0]  # the filled score
    assert ann["num_keypoints"] == 15   # v > 0: the filled joint is no detection
    c = COCO_KEYPOINTS.index("right_ankle")
    assert ann["keypoints"][3 * c: 3 * c + 3] == [0, 0, 0]   # still missing
    # untouched keypoints: exactly the originals
    for c in range(17):
        if COCO_KEYPOINTS[c] != "left_wrist":
            assert ann["keypoints"][3 * c: 3 * c + 3] == anns[0]["keypoints"][3 * c: 3 * c + 3]
    extra = ann["sparseedm"]
    assert extra["filled"] == ["left_wrist"]
    assert extra["neck"] == [100.0, 100.0]
    assert extra["head_top"] == pytest.approx([100, 6.4])
    # the original document in meta was not modified
    assert "sparseedm" not in kps.meta["coco_document"]["annotations"][0]

    back = read_keypoints(out)
    _assert_same(back.poses, np.where(np.isnan(recovered), np.nan, recovered))


def test_coco_sparseedm_field_overrides_derived_joints(tmp_path):
    ann = {"keypoints": _coco_kp(FULL), "sparseedm": {"neck": [1, 2], "head_top": None}}
    path = tmp_path / "a.json"
    path.write_text(json.dumps([ann]))
    kps = read_keypoints(path)
    assert kps.poses[0, J("neck")].tolist() == [1, 2]
    assert kps.missing[0, J("head_top")]  # null: written missing, not derived again
    del ann["sparseedm"]["head_top"]       # left out: derived from the face
    path.write_text(json.dumps([ann]))
    kps = read_keypoints(path)
    np.testing.assert_allclose(kps.poses[0, J("head_top")][1], 48 + 0.8 * (48 - 100))


def test_coco_write_without_meta(tmp_path):
    poses = _poses(2)
    poses[1, J("left_knee")] = np.nan
    out = tmp_path / "new.json"
    write_keypoints(out, poses, ids=["12", "img_b"])
    anns = json.loads(out.read_text())
    assert [a["image_id"] for a in anns] == [12, "img_b"]
    c = COCO_KEYPOINTS.index("left_knee")
    assert anns[1]["keypoints"][3 * c: 3 * c + 3] == [0, 0, 0]
    assert anns[0]["keypoints"][3 * c + 2] == 2
    assert anns[0]["keypoints"][:15] == [0] * 15  # head keypoints unknown
    back = read_keypoints(out)
    _assert_same(back.poses, poses)


@pytest.mark.parametrize(
    "text, match",
    [
        ('[{"keypoints": [1, 2', "truncated JSON at line 1"),
        ('[{"keypoints": [1, 2, 3]}]', "annotation 0: 'keypoints' has 3 values"),
        ('[{"keypoints": %s}, {"bbox": []}]' % json.dumps([0] * 51),
         r"annotation 1 has no 'keypoints' \(its keys: 'bbox'\); a .json is read as COCO"),
        ('[{"keypoints": %s}]' % json.dumps(["a"] * 51), "annotation 0: .*non-numeric"),
        ('{"images": []}', r"'annotations' list \(its keys: 'images'\); .*OpenPose frame"),
        ('42', "list of annotations"),
    ],
)
def test_coco_errors(tmp_path, text, match):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=match) as info:
        read_keypoints(path)
    assert "bad.json" in str(info.value)


def test_coco_write_back_count_mismatch(tmp_path):
    path = tmp_path / "a.json"
    path.write_text(json.dumps([{"keypoints": _coco_kp(FULL)}]))
    kps = read_keypoints(path)
    with pytest.raises(FileFormatError, match="2 poses for 1 annotations"):
        write_keypoints(tmp_path / "o.json", _poses(2), meta=kps.meta)


# ---------------------------------------------------------- formats, atomic


def test_format_selection(tmp_path):
    with pytest.raises(FileFormatError, match=r"\.txt"):
        read_keypoints(tmp_path / "k.txt")
    with pytest.raises(FileFormatError, match="unknown keypoint format"):
        write_keypoints(tmp_path / "k.csv", _poses(1), format="xml")
    write_keypoints(tmp_path / "k.txt", _poses(1), format="csv")
    assert read_keypoints(tmp_path / "k.txt", format="csv").meta["format"] == "csv"
    write_keypoints(tmp_path / "k.dat", _poses(1), format="json")
    assert len(read_keypoints(tmp_path / "k.dat", format="coco")) == 1
    assert issubclass(FileFormatError, SparseEDMError)


def test_failed_write_leaves_target_untouched(tmp_path, monkeypatch):
    path = tmp_path / "k.csv"
    write_keypoints(path, _poses(1))
    before = path.read_text()

    import sparseedm.keypoints as mod

    def boom(values):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(mod, "csv_cells", boom)  # fails once the temporary file is open
    with pytest.raises(RuntimeError):
        write_keypoints(path, _poses(2))
    assert path.read_text() == before
    assert os.listdir(tmp_path) == ["k.csv"]


# ------------------------------------------------------------- round trips

finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    poses=hnp.arrays(float, st.tuples(st.integers(0, 4), st.just(14), st.just(2)),
                     elements=finite),
    data=st.data(),
    fmt=st.sampled_from(["npz", "csv", "npy"]),
)
def test_round_trip_property(tmp_path, poses, data, fmt):
    missing = data.draw(hnp.arrays(bool, poses.shape[:2]))
    path = tmp_path / f"rt.{fmt}"
    path.unlink(missing_ok=True)  # tmp_path is shared by hypothesis's examples
    if origin_joints(poses, missing).any():  # would read back missing: refused
        with pytest.raises(FileFormatError, match=r"exactly \(0, 0\)"):
            write_keypoints(path, poses, missing)
        assert not path.exists()
        return
    write_keypoints(path, poses, missing)
    kps = read_keypoints(path)
    _assert_same(kps.missing, missing)
    _assert_same(kps.poses, np.where(missing[..., None], np.nan, poses))


def test_infinite_values_and_bad_keypointset(tmp_path):
    """An infinite coordinate is a bad row, not a bad file: read as it is (the
    recovery refuses that row, tests/test_cli_recover.py)."""
    poses = _poses(2)
    poses[1, 3, 0] = np.inf
    np.save(tmp_path / "p.npy", poses)
    kps = read_keypoints(tmp_path / "p.npy")
    assert np.isposinf(kps.poses[1, 3, 0]) and not kps.missing[1, 3]
    np.testing.assert_array_equal(kps.poses[0], poses[0])
    with pytest.raises(SparseEDMError, match="missing must have shape"):
        KeypointSet(np.zeros((2, 14, 2)), np.zeros((2, 13), bool))


def _csv_with_cell(tmp_path, text, row=1, column="neck_y"):
    """A 3-pose CSV (written by write_keypoints) with one cell replaced by `text`."""
    poses = np.arange(3 * 14 * 2, dtype=float).reshape(3, 14, 2) + 0.25
    path = write_keypoints(tmp_path / "k.csv", KeypointSet(poses, np.zeros((3, 14), bool)))
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = text
    lines[row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("text, value", [
    (" 1.5 ", 1.5), ("1e3", 1000.0), ("-.5E-1", -0.05), ("+7.", 7.0), ("nan", None),
    ("-Infinity", -np.inf), ("", None), ("\u20031.5\u2003", 1.5),  # Unicode blanks strip
])
def test_csv_number_cells_read_as_before(tmp_path, text, value):
    """The whole-block fast path and the per-cell check accept the same cells."""
    ks = read_keypoints(_csv_with_cell(tmp_path, text))
    got = ks.poses[0, 1, 1]
    if value is None:
        assert ks.missing[0, 1] and np.isnan(got)
    else:
        assert got == value
    assert ks.poses[2, 13, 0] == 2 * 28 + 26 + 0.25  # the other cells as written


@pytest.mark.parametrize("text", ["1_0", "\u0661", "\uff11", "0x10", "1e", "+-1", "1,5",
                                  "nan1", "inf inity"])
def test_csv_non_number_cells_are_named(tmp_path, text):
    path = _csv_with_cell(tmp_path, f'"{text}"', row=2)
    with pytest.raises(FileFormatError, match=r"line 3, column 'neck_y': .* is not a number"):
        read_keypoints(path)


# ------------------------------------------------- zeros for missing joints


def _pixel_poses_with_holes(n=4, seed=3):
    """Pixel poses (all coordinates positive) and a mask of hidden joints."""
    rng = np.random.default_rng(seed)
    poses = rng.uniform(100, 500, size=(n, 14, 2))
    hidden = np.zeros((n, 14), bool)
    hidden[np.arange(n), rng.integers(0, 14, n)] = True
    hidden[0, 5] = True
    return poses, hidden


@pytest.mark.parametrize("fmt", ["csv", "npz", "npy"])
def test_zeros_for_missing_joints_read_as_missing(tmp_path, fmt):
    """A pixel file that writes (0, 0) for a joint its tool did not find reads as
    the same file with NaN there, and a warning says how many joints."""
    poses, hidden = _pixel_poses_with_holes()
    zeros = np.where(hidden[..., None], 0.0, poses)
    blank = np.where(hidden[..., None], np.nan, poses)
    write_keypoints(tmp_path / f"nan.{fmt}", blank)
    # written by hand: write_keypoints refuses them (they would read back missing)
    if fmt == "npy":
        np.save(tmp_path / "zeros.npy", zeros)
    elif fmt == "npz":
        np.savez(tmp_path / "zeros.npz", poses=zeros)
    else:
        header = ",".join(f"{name}_{c}" for name in JOINT_NAMES for c in "xy")
        rows = [",".join(repr(v) for v in pose.ravel().tolist()) for pose in zeros]
        (tmp_path / "zeros.csv").write_text("\n".join([header, *rows]) + "\n")
    with pytest.warns(UserWarning, match=rf"read {hidden.sum()} joint\(s\) at exactly \(0, 0\)"):
        got = read_keypoints(tmp_path / f"zeros.{fmt}")
    want = read_keypoints(tmp_path / f"nan.{fmt}")
    _assert_same(got.missing, hidden)
    _assert_same(got.poses, want.poses)


def test_a_centred_pose_keeps_its_joint_at_the_origin(tmp_path):
    """A pose centred on a joint has negative coordinates: its joint at (0, 0)
    is observed, and written and read back as it is."""
    poses, _ = _pixel_poses_with_holes()
    centred = poses - poses[:, 8:9]  # right hip at the origin
    path = write_keypoints(tmp_path / "c.csv", centred)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = read_keypoints(path)
    assert not got.missing.any()
    _assert_same(got.poses, centred)


@pytest.mark.parametrize("fmt", ["csv", "npz", "npy"])
def test_writer_refuses_an_observed_joint_at_the_origin(tmp_path, fmt):
    poses, _ = _pixel_poses_with_holes()
    poses[2, 4] = 0.0
    with pytest.raises(FileFormatError, match=r"pose 2, joint right_wrist is at exactly"):
        write_keypoints(tmp_path / f"o.{fmt}", poses)
    assert not (tmp_path / f"o.{fmt}").exists()
    missing = np.zeros((4, 14), bool)
    missing[2, 4] = True  # marked missing: written as missing
    read = read_keypoints(write_keypoints(tmp_path / f"m.{fmt}", poses, missing))
    assert read.missing[2, 4] and read.missing.sum() == 1


@pytest.mark.parametrize("fmt", ["csv", "npz", "npy"])
def test_a_joint_flagged_filled_at_the_origin_reads_back_as_written(tmp_path, fmt):
    """A filled joint is kept as the file holds it, (0, 0) too, without a warning;
    write_keypoints keeps no filled flags in a .npy (sparseedm recover puts
    them in its sidecar), so there it is refused."""
    poses, _ = _pixel_poses_with_holes()
    poses[1, 7] = 0.0
    filled = np.zeros((4, 14), bool)
    filled[1, 7] = True
    if fmt == "npy":
        with pytest.raises(FileFormatError, match="pose 1, joint left_wrist"):
            write_keypoints(tmp_path / "f.npy", poses, filled=filled)
        return
    path = write_keypoints(tmp_path / f"f.{fmt}", poses, filled=filled)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = read_keypoints(path)
    assert not back.missing.any()
    _assert_same(back.poses, poses)


def test_csv_scores_under_an_unknown_suffix_are_named(tmp_path):
    """<joint>_visibility for every joint: kept as extra columns, and a warning
    says how to have them read as confidences."""
    poses, _ = _pixel_poses_with_holes()
    path = write_keypoints(tmp_path / "v.csv", poses, confidence=np.full((4, 14), 0.9))
    path.write_text(path.read_text().replace("_conf", "_visibility"))
    with pytest.warns(UserWarning, match=r"<joint>_visibility columns are kept as they are, "
                                         r"not read; .* name them <joint>_conf"):
        got = read_keypoints(path)
    assert got.confidence is None and "left_ankle_visibility" in got.meta["extra_columns"]


def test_csv_without_the_joint_columns_shows_its_own(tmp_path):
    path = tmp_path / "dots.csv"
    path.write_text(",".join(f"{j}.{c}" for j in JOINT_NAMES for c in "xy") + "\n")
    with pytest.raises(FileFormatError, match=r"needs <joint>_x and <joint>_y for all 14 "
                                              r"joints \(its columns: 'head_top.x', "):
        read_keypoints(path)
