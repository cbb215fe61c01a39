"""Cameras, the training-set builder, its .npz schema, and the CLI."""

import json
import shutil
import warnings
import zipfile

import numpy as np
import pytest

from sparseedm.cameras import Cameras, look_at, project, sample_cameras
from sparseedm.cli import main
from sparseedm.dataset import (
    SCHEMA, build_dataset, clip_metadata, find_mocap_files, load_dataset, save_dataset,
)
from sparseedm.exceptions import FileFormatError, PoseError, SparseEDMError
from sparseedm.skeleton import JOINT_NAMES


# ---------------------------------------------------------------- cameras
def test_sample_cameras_seeded_and_valid():
    targets = np.array([[0.0, 1.0, 0.0], [2.0, 0.9, -1.0], [0.5, 1.2, 3.0]])
    a = sample_cameras(targets=targets, random_state=3)
    b = sample_cameras(targets=targets, random_state=3)
    for x, y in zip((a.R, a.t, a.f, a.c), (b.R, b.t, b.f, b.c)):
        np.testing.assert_array_equal(x, y)
    assert not np.allclose(a.R, sample_cameras(targets=targets, random_state=4).R)
    np.testing.assert_allclose(a.R @ a.R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), (3, 3, 3)),
                               atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(a.R), 1.0)
    centers = a.centers
    horizontal = np.linalg.norm((centers - targets)[:, [0, 2]], axis=1)
    assert np.all((horizontal >= 3) & (horizontal <= 6))
    assert np.all((centers[:, 1] >= 0.5) & (centers[:, 1] <= 2.0))
    # the target projects onto the principal point
    uv = project(targets[:, None, :], a)
    np.testing.assert_allclose(uv[:, 0], a.c, atol=1e-9)
    np.testing.assert_array_equal(a.f, 1000.0)
    np.testing.assert_array_equal(a.c, 500.0)


def test_azimuth_covers_all_round():
    cams = sample_cameras(2000, targets=[0, 1, 0], random_state=0)
    d = cams.centers - [0, 1, 0]
    az = np.arctan2(d[:, 2], d[:, 0])
    counts, _ = np.histogram(az, bins=8, range=(-np.pi, np.pi))
    assert counts.min() > 150


def test_image_orientation_y_up_and_z_up():
    # Y-up: a point above the target is higher in the image (smaller v)
    cams = sample_cameras(50, targets=[0, 1, 0], random_state=1, up="y")
    uv = project(np.repeat([[[0, 1, 0], [0, 1.5, 0]]], 50, axis=0), cams)
    assert np.all(uv[:, 1, 1] < uv[:, 0, 1])
    # Z-up: heights are along z
    cams = sample_cameras(50, targets=[0, 0, 1], random_state=1, up="z")
    assert np.all((cams.centers[:, 2] >= 0.5) & (cams.centers[:, 2] <= 2.0))
    uv = project(np.repeat([[[0, 0, 1], [0, 0, 1.5]]], 50, axis=0), cams)
    assert np.all(uv[:, 1, 1] < uv[:, 0, 1])


def test_no_mirroring():
    # camera on +z looking at the origin, Y up: world +x is image right
    R = look_at([0, 0, 5], [0, 0, 0], up="y")
    cams = Cameras(R, -np.einsum("nij,j->ni", R, [0, 0, 5]), np.array([1000.0]),
                   np.array([[500.0, 500.0]]))
    uv = project([[[0, 0, 0], [1, 0, 0]]], cams)
    assert uv[0, 1, 0] > uv[0, 0, 0]


def test_camera_options_and_errors():
    cams = sample_cameras(5, distance=4.0, height=1.5, focal=(800, 1200),
                          principal_point=(320, 240), random_state=0)
    assert np.all((cams.f >= 800) & (cams.f <= 1200))
    np.testing.assert_array_equal(cams.c, [[320, 240]] * 5)
    with pytest.raises(ValueError, match="distance"):
        sample_cameras(2, distance=(6, 3))
    with pytest.raises(ValueError, match="up must be"):
        sample_cameras(2, up="w")
    with pytest.raises(PoseError, match="behind"):
        project(np.zeros((1, 2, 3)), Cameras(np.eye(3)[None], np.zeros((1, 3)),
                                             np.ones(1), np.zeros((1, 2))))
    with pytest.raises(PoseError, match="2 poses for 5 cameras"):
        project(np.zeros((2, 14, 3)), cams)


# ---------------------------------------------------------------- builder
def test_build_dataset_schema(mocap_dir, tmp_path):
    out = tmp_path / "train.npz"
    data, report = build_dataset(mocap_dir, out, cameras_per_pose=2, frame_step=5,
                                 progress=False, return_report=True)
    chosen = report.pop("chosen")
    assert report == {"files": 2, "skipped": [], "poses": 16, "tpose_frames": 0, "warnings": []}
    assert len(chosen) == 2 and all(c["height"] > 1 and c["units"] and c["rig"] for c in chosen)
    with np.load(out, allow_pickle=False) as npz:
        assert set(npz.files) == set(SCHEMA)
        assert npz["labels"].dtype.kind == "U"
    loaded = load_dataset(out)
    assert loaded["poses2d"].shape == (16, 14, 2) and loaded["poses3d"].shape == (16, 14, 3)
    assert loaded["camera_R"].shape == (16, 3, 3) and loaded["camera_c"].shape == (16, 2)
    assert loaded["joint_names"].tolist() == list(JOINT_NAMES)
    assert sorted(set(loaded["labels"].tolist())) == ["02_01", "walk_take"]
    assert set(loaded["subjects"].tolist()) == {"02", ""}
    assert set(loaded["styles"].tolist()) == {""}
    np.testing.assert_array_equal(loaded["frames"][:8], [0, 0, 5, 5, 10, 10, 15, 15])
    # two cameras per pose: same 3D pose, different views
    p3, p2 = loaded["poses3d"], loaded["poses2d"]
    np.testing.assert_array_equal(p3[0], p3[1])
    assert not np.allclose(p2[0], p2[1])
    # the BVH and the AMC are the same motion
    amc = loaded["clips"] == "02_01"
    np.testing.assert_allclose(p3[amc], p3[~amc], atol=1e-5)
    # 2D is the projection of 3D through the stored camera
    cams = Cameras(loaded["camera_R"], loaded["camera_t"], loaded["camera_f"], loaded["camera_c"])
    np.testing.assert_allclose(project(p3, cams), p2)
    # seeded: the same build twice is identical
    again = build_dataset(mocap_dir, cameras_per_pose=2, frame_step=5, progress=False)
    np.testing.assert_array_equal(again["poses2d"], data["poses2d"])


def test_default_frame_step_is_about_40_fps(mocap_dir):
    data = build_dataset(mocap_dir / "02", progress=False)
    np.testing.assert_array_equal(data["frames"], np.arange(0, 20, 3))  # 120 fps -> every 3rd


def test_bad_file_is_skipped_with_warning(mocap_dir, tmp_path):
    (mocap_dir / "bvh" / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    (mocap_dir / "02" / "02_02.amc").write_text("1\nroot 1 2 3\n")
    with pytest.warns(UserWarning) as record:
        data, report = build_dataset(mocap_dir, frame_step=5, progress=False, return_report=True)
    messages = " ".join(str(w.message) for w in record)
    assert "broken.bvh" in messages and "02_02.amc" in messages
    assert report["files"] == 2 and len(report["skipped"]) == 2
    assert len(data["labels"]) == 8


def test_nothing_built_is_an_error(tmp_path):
    (tmp_path / "a.bvh").write_text("nonsense\n")
    with pytest.warns(UserWarning, match="a.bvh"), pytest.raises(SparseEDMError, match="no poses"):
        build_dataset(tmp_path, progress=False)
    with pytest.raises(FileNotFoundError):
        find_mocap_files(tmp_path / "missing")


def test_cli_says_why_when_every_file_is_skipped(tmp_path, capsys):
    """Every file bad: the error names each skipped file and its reason; -q as the
    other commands take it."""
    (tmp_path / "bad.bvh").write_text("garbage\n")
    (tmp_path / "walk.asf").write_text(":version 1.10\n")
    for quiet in (["-q"], []):
        code = main(["dataset", "build", str(tmp_path / "bad.bvh"), str(tmp_path / "walk.asf"),
                     "-o", str(tmp_path / "t.npz"), *quiet])
        err = capsys.readouterr().err
        assert code == 2 and "2 motion file(s) found, 2 skipped" in err
        assert f"skipped {tmp_path / 'bad.bvh'}: line 1: expected 'HIERARCHY'" in err, err
        assert "walk.asf" in err and not (tmp_path / "t.npz").exists()


def test_bandai_labels_from_json(tmp_path, fixtures_dir):
    root = tmp_path / "bandai"
    (root / "cfg").mkdir(parents=True)
    (root / "data").mkdir()
    (root / "cfg" / "content_label.txt").write_text("dataset-1_walk\ndataset-1_run\n")
    (root / "cfg" / "style_label.txt").write_text("dataset-1_normal\ndataset-1_happy\n")
    clip = root / "data" / "dataset-1_run_happy_001.bvh"
    shutil.copy(fixtures_dir / "cmu_02_01_short.bvh", clip)
    clip.with_suffix(".json").write_text(json.dumps({"content": 1, "style": 1}))
    assert clip_metadata(clip) == {"label": "run", "clip": "dataset-1_run_happy_001",
                                   "style": "happy", "subject": ""}
    data = build_dataset(root, progress=False)
    assert set(data["labels"].tolist()) == {"run"} and set(data["styles"].tolist()) == {"happy"}


def test_load_dataset_validates(tmp_path, mocap_dir):
    data = build_dataset(mocap_dir / "02", frame_step=5, progress=False)
    bad = dict(data)
    del bad["camera_f"]
    np.savez(tmp_path / "missing.npz", **bad)
    with pytest.raises(FileFormatError, match="missing camera_f"):
        load_dataset(tmp_path / "missing.npz")
    bad = dict(data, poses2d=data["poses2d"][:-1])
    np.savez(tmp_path / "rows.npz", **bad)
    with pytest.raises(FileFormatError, match="rows"):
        load_dataset(tmp_path / "rows.npz")
    bad = dict(data, labels=np.array(list(data["labels"]), dtype=object))
    np.savez(tmp_path / "pickle.npz", **bad)
    with pytest.raises(FileFormatError, match="pickle"):
        load_dataset(tmp_path / "pickle.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(FileFormatError, match="junk.npz"):
        load_dataset(tmp_path / "junk.npz")
    with pytest.raises(FileFormatError, match="poses3d has NaN"):
        save_dataset(tmp_path / "nan.npz", dict(data, poses3d=data["poses3d"] * np.nan))
    assert not (tmp_path / "nan.npz").exists()


def test_cmu_poses_fixture(fixtures_dir):
    data = load_dataset(fixtures_dir / "cmu_poses.npz")
    assert 250 <= len(data["labels"]) <= 400
    assert len(set(data["labels"].tolist())) >= 8
    assert set(data["subjects"].tolist()) == {"01", "02", "03"}
    with zipfile.ZipFile(fixtures_dir / "cmu_poses.npz") as z:
        assert all(name.endswith(".npy") for name in z.namelist())


def test_real_bandai_subset(shared_data):
    files = sorted((shared_data / "bandai-namco-1" / "data").glob("dataset-1_walk_*_001.bvh"))[:2]
    data = build_dataset(files, progress=False)
    assert set(data["labels"].tolist()) == {"walk"}
    assert len(set(data["styles"].tolist())) == 2
    assert np.all(np.isfinite(data["poses2d"]))
    # a 1000 x 1000 image at 3-6 m: the person is inside and not tiny
    assert np.percentile(data["poses2d"], 1) > -200 and np.percentile(data["poses2d"], 99) < 1200


# ---------------------------------------------------------------- CLI
def test_cli_build(mocap_dir, tmp_path, capsys):
    out = tmp_path / "cli.npz"
    code = main(["dataset", "build", str(mocap_dir), "-o", str(out), "--cameras-per-pose", "3",
                 "--frame-step", "10", "--seed", "7"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "read 2 file(s), skipped 0" in printed and "wrote 12 poses" in printed
    per_file = [line for line in printed.splitlines() if ": rig " in line]
    assert len(per_file) == 2  # the rig, units and height chosen for each file
    assert all(", units " in line and ", height " in line and " m, " in line
               for line in per_file)
    data = load_dataset(out)
    assert len(data["labels"]) == 12
    ref = build_dataset(mocap_dir, cameras_per_pose=3, frame_step=10, random_state=7, progress=False)
    np.testing.assert_array_equal(data["poses2d"], ref["poses2d"])


def test_cli_partial_and_bad_input(mocap_dir, tmp_path, capsys):
    (mocap_dir / "bvh" / "broken.bvh").write_text("HIERARCHY\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a refusal is a printed line, not a Python warning
        code = main(["dataset", "build", str(mocap_dir), "-o", str(tmp_path / "p.npz")])
    assert code == 1
    printed = capsys.readouterr()
    assert "skipped 1" in printed.out
    skipped = [line for line in printed.out.splitlines() if "broken.bvh" in line]
    assert len(skipped) == 1 and skipped[0].startswith("  skipped ")
    assert "Warning" not in printed.err and "broken.bvh" not in printed.err
    code = main(["dataset", "build", str(mocap_dir), "-o", str(tmp_path / "q.npz"), "--quiet"])
    assert code == 1 and capsys.readouterr().out == ""
    code = main(["dataset", "build", str(tmp_path / "nowhere"), "-o", str(tmp_path / "r.npz")])
    assert code == 2 and "nowhere" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["dataset", "build", str(mocap_dir), "-o", "x.npz", "--frame-step", "0"])
