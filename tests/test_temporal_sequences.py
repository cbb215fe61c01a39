"""Video sequences from mocap (sparseedm.temporal.sequences, build_dataset camera="clip")."""

import numpy as np
import pytest

from sparseedm.cameras import project
from sparseedm.cli import main
from sparseedm.dataset import build_dataset
from sparseedm.exceptions import FileFormatError, ParameterError
from sparseedm.temporal.sequences import body_height, load_sequences, sequences_from_dataset


def test_one_camera_per_clip(mocap_dir):
    data = build_dataset(mocap_dir, camera="clip", frame_step=1, progress=False)
    for clip in np.unique(data["clips"]):
        rows = data["clips"] == clip
        for key in ("camera_R", "camera_t", "camera_f", "camera_c"):
            assert np.allclose(data[key][rows], data[key][rows][:1])
    # the two clips got different cameras
    assert not np.allclose(data["camera_t"][data["clips"] == "02_01"][0],
                           data["camera_t"][data["clips"] != "02_01"][0])
    # and a per-pose build does not hold one camera per clip
    per_pose = build_dataset(mocap_dir, frame_step=1, progress=False)
    rows = per_pose["clips"] == "02_01"
    assert not np.allclose(per_pose["camera_t"][rows], per_pose["camera_t"][rows][:1])


def test_clip_camera_defaults_to_video_frame_rate(mocap_dir):
    data = build_dataset(mocap_dir / "02", camera="clip", progress=False)
    np.testing.assert_array_equal(data["frames"], np.arange(0, 20, 4))  # 120 fps -> 30


def test_clip_camera_refuses_several_cameras(mocap_dir):
    with pytest.raises(ParameterError, match="cameras_per_pose must be 1"):
        build_dataset(mocap_dir, camera="clip", cameras_per_pose=2, progress=False)
    with pytest.raises(ParameterError, match="camera"):
        build_dataset(mocap_dir, camera="frame", progress=False)


def test_sequences_from_a_clip_camera_file(mocap_dir, tmp_path):
    out = tmp_path / "seq.npz"
    assert main(["dataset", "build", str(mocap_dir), "-o", str(out), "--camera-per", "clip",
                 "--frame-step", "1", "--quiet"]) == 0
    seqs = load_sequences(out, min_frames=5, max_frames=12)
    assert [s.clip for s in seqs] == ["02_01#0", "02_01#1", "bvh/walk_take#0", "bvh/walk_take#1"]
    assert [len(s) for s in seqs] == [10, 10, 10, 10]
    assert seqs[1].frames.tolist() == list(range(10, 20))
    for s in seqs:
        np.testing.assert_allclose(project(s.poses3d, s.camera[np.zeros(len(s), int)]),
                                   s.poses2d)
        assert 50 < s.height < 1000
    assert load_sequences(out, min_frames=11, max_frames=12) == []


def test_a_per_pose_file_is_refused_with_the_way_out(mocap_dir, tmp_path):
    out = tmp_path / "train.npz"
    build_dataset(mocap_dir, out, frame_step=1, progress=False)
    with pytest.raises(FileFormatError, match="--camera-per clip"):
        load_sequences(out, min_frames=5)


def test_frame_numbers_skip_where_frames_were_dropped():
    from sparseedm.cameras import sample_cameras

    frames = np.array([8, 12, 16, 28, 32])  # step 4; 20 and 24 absent
    n = len(frames)
    cams = sample_cameras(1, random_state=0).as_dict()
    data = {"poses2d": np.zeros((n, 14, 2)), "poses3d": np.zeros((n, 14, 3)),
            "clips": np.array(["c"] * n), "frames": frames[::-1],  # rows in any order
            **{k: np.repeat(v, n, axis=0) for k, v in cams.items()}}
    (seq,) = sequences_from_dataset(data, min_frames=1)
    assert seq.frames.tolist() == [0, 1, 2, 5, 6]


def test_body_height_is_the_median_head_to_ankles():
    p = np.zeros((4, 14, 2))
    p[:, 10] = [-20, 0]
    p[:, 13] = [20, 0]
    p[:, 0, 1] = [-100, -200, -300, -400]
    assert body_height(p) == 250.0
