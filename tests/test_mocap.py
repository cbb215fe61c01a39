"""Mocap loaders: BVH parser/FK, ASF/AMC FK, rigs, bad files, real data."""

import shutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sparseedm.exceptions import FileFormatError
from sparseedm.mocap import (
    detect_rig, find_asf, load_asf_amc, load_bvh, load_mocap, parse_amc, parse_asf,
    parse_bvh, rotation_matrices,
)
from sparseedm.mocap.bvh import BANDAI_HEAD_TOP, CMU_SCALE, bvh_forward_kinematics
from sparseedm.mocap.rigs import FAMILIES
from sparseedm.skeleton import SKELETON_14

J = SKELETON_14.index
#: 14-joint pairs that are one rigid bone in both rigs (limb bones, hip width)
RIGID = [("right_shoulder", "right_elbow"), ("right_elbow", "right_wrist"),
         ("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"),
         ("right_hip", "right_knee"), ("right_knee", "right_ankle"),
         ("left_hip", "left_knee"), ("left_knee", "left_ankle"),
         ("right_hip", "left_hip")]
PAIRS = [(0, 2), (1, 3), (4, 6), (5, 7)]  # right/left counterparts within RIGID


def bone_lengths(poses):
    return np.stack([np.linalg.norm(poses[:, J(a)] - poses[:, J(b)], axis=-1)
                     for a, b in RIGID], axis=1)


def check_physical(poses, spread_tol=1e-6):
    lengths = bone_lengths(poses)
    spread = (lengths.max(0) - lengths.min(0)) / lengths.mean(0)
    assert spread.max() <= spread_tol, spread
    mean = lengths.mean(0)
    for r, l in PAIRS:
        assert abs(mean[r] - mean[l]) / max(mean[r], mean[l]) <= 0.05, (RIGID[r], mean[r], mean[l])
    ankles = poses[:, [J("left_ankle"), J("right_ankle")], 1].mean(axis=1)
    height = np.max(poses[:, J("head_top"), 1] - ankles)
    assert 1.4 <= height <= 2.0, height
    assert np.all(np.isfinite(poses))


# ---------------------------------------------------------------- rotations
@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-360, 360), min_size=3, max_size=3),
       st.sampled_from(["XYZ", "ZXY", "ZYX", "YXZ"]))
def test_rotation_matrices_are_rotations(angles, axes):
    R = rotation_matrices([angles], axes)[0]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    # intrinsic order: the product of single-axis rotations, left to right
    single = [rotation_matrices([[a]], ax)[0] for a, ax in zip(angles, axes)]
    np.testing.assert_allclose(R, single[0] @ single[1] @ single[2], atol=1e-12)


def test_rotation_matrix_right_handed():
    Rz = rotation_matrices([[90.0]], "Z")[0]
    np.testing.assert_allclose(Rz @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    Rx = rotation_matrices([[90.0]], "X")[0]
    np.testing.assert_allclose(Rx @ [0, 1, 0], [0, 0, 1], atol=1e-12)


# ---------------------------------------------------------------- BVH parser
TWO_JOINTS = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Arm
  {
    OFFSET 0 5 0
    CHANNELS 2 Xrotation Zrotation
    End Site
    {
      OFFSET 2 0 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 2 3 0 0 0 0 0
1 2 3 90 0 0 90 90
"""


def test_bvh_forward_kinematics_known_answers():
    bvh = parse_bvh(TWO_JOINTS)
    assert bvh.joint_names == ["Hips", "Arm"]
    assert bvh.motion.shape == (2, 8)
    assert bvh.joints[1].channels == ("Xrotation", "Zrotation")
    pos, rot = bvh_forward_kinematics(bvh)
    np.testing.assert_allclose(pos[0], [[1, 2, 3], [1, 7, 3]], atol=1e-12)
    # frame 2: root Rz(90) maps the arm offset (0,5,0) to (-5,0,0)
    np.testing.assert_allclose(pos[1], [[1, 2, 3], [-4, 2, 3]], atol=1e-12)
    # End Site: Rz(90) @ Rx(90) @ Rz(90) @ (2,0,0)
    expected = rotation_matrices([[90, 90, 90]], "ZXZ")[0] @ [2, 0, 0]
    end = pos[1, 1] + rot[1, 1] @ bvh.joints[1].end_sites[0]
    np.testing.assert_allclose(end, [-4, 2, 3] + expected, atol=1e-12)


def test_bvh_position_channels_replace_offset():
    text = TWO_JOINTS.replace("CHANNELS 2 Xrotation Zrotation",
                              "CHANNELS 3 Yposition Xrotation Zrotation")
    text = text.replace("1 2 3 0 0 0 0 0\n1 2 3 90 0 0 90 90",
                        "0 0 0 0 0 0 7 0 0\n0 0 0 0 0 0 7 0 0")
    pos, _ = bvh_forward_kinematics(parse_bvh(text))
    np.testing.assert_allclose(pos[:, 1], [[0, 7, 0], [0, 7, 0]])


def _bandai_like_text():
    """A rest-pose BVH with the Bandai rig's names, offsets in cm along +x."""
    chain = [("Hips", None, (0, 90, 0)), ("Spine", "Hips", (0, 10, 0)),
             ("Chest", "Spine", (0, 10, 0)), ("Neck", "Chest", (0, 20, 0)),
             ("Head", "Neck", (0, 7, 0)),
             ("UpperArm_L", "Chest", (18, 20, 0)), ("LowerArm_L", "UpperArm_L", (25, 0, 0)),
             ("Hand_L", "LowerArm_L", (22, 0, 0)),
             ("UpperArm_R", "Chest", (-18, 20, 0)), ("LowerArm_R", "UpperArm_R", (-25, 0, 0)),
             ("Hand_R", "LowerArm_R", (-22, 0, 0)),
             ("UpperLeg_L", "Hips", (10, -5, 0)), ("LowerLeg_L", "UpperLeg_L", (0, -40, 0)),
             ("Foot_L", "LowerLeg_L", (0, -40, 0)),
             ("UpperLeg_R", "Hips", (-10, -5, 0)), ("LowerLeg_R", "UpperLeg_R", (0, -40, 0)),
             ("Foot_R", "LowerLeg_R", (0, -40, 0))]
    children = {}
    for name, parent, _ in chain:
        children.setdefault(parent, []).append(name)
    offsets = {name: off for name, _, off in chain}
    lines = ["HIERARCHY"]

    def emit(name, depth):
        ind = "  " * depth
        lines.append(f"{ind}{'ROOT' if depth == 0 else 'JOINT'} {name}")
        lines.append(ind + "{")
        lines.append(f"{ind}  OFFSET {' '.join(map(str, offsets[name]))}")
        lines.append(f"{ind}  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
        for kid in children.get(name, []):
            emit(kid, depth + 1)
        if name not in children:
            lines.extend([f"{ind}  End Site", ind + "  {", f"{ind}    OFFSET 0 0 0", ind + "  }"])
        lines.append(ind + "}")

    emit("Hips", 0)
    row = " ".join(" ".join(map(str, offsets[n])) + " 0 0 0" for n, _, _ in _dfs(children))
    lines += ["MOTION", "Frames: 1", "Frame Time: 0.0333333", row]
    return "\n".join(lines) + "\n"


def _dfs(children, name="Hips"):
    yield name, None, None
    for kid in children.get(name, []):
        yield from _dfs(children, kid)


def test_bandai_rig_head_top_convention():
    poses, info = load_bvh(_bandai_like_text(), return_info=True)
    assert info["rig"] == "bandai" and info["scale"] == 0.01
    head = np.array([0, 90 + 10 + 10 + 20 + 7, 0]) * 0.01
    np.testing.assert_allclose(poses[0, J("neck")], [0, 1.30, 0], atol=1e-12)
    # 0.2 m beyond Head along the Neck -> Head direction
    np.testing.assert_allclose(poses[0, J("head_top")], head + [0, BANDAI_HEAD_TOP, 0], atol=1e-12)
    np.testing.assert_allclose(poses[0, J("left_shoulder")], [0.18, 1.30, 0], atol=1e-12)
    np.testing.assert_allclose(poses[0, J("left_ankle")], [0.10, 0.05, 0], atol=1e-12)
    # scale overrides the unit; the head-top distance stays in metres
    p2 = load_bvh(_bandai_like_text(), scale=0.02)
    np.testing.assert_allclose(p2[0, J("head_top")] - p2[0, J("neck")],
                               [0, 0.14 + 0.2, 0], atol=1e-12)


def test_unknown_rig_lists_missing_names():
    with pytest.raises(FileFormatError, match=r"unknown BVH rig.*bandai rig misses Head, Neck, UpperArm_R.*--joint-map"):
        load_bvh(TWO_JOINTS)
    with pytest.raises(FileFormatError, match="cmu rig misses Neck1, RightArm, RightForeArm"):
        detect_rig(["Hips", "Head"])


# ---------------------------------------------------------------- fixtures
def test_fixture_bvh_matches_asf_amc(fixtures_dir):
    from_amc = load_asf_amc(fixtures_dir / "cmu_02.asf", fixtures_dir / "cmu_02_01_short.amc")
    from_bvh, info = load_bvh(fixtures_dir / "cmu_02_01_short.bvh", return_info=True)
    assert info["rig"] == "cmu" and info["scale"] == pytest.approx(CMU_SCALE)
    assert from_amc.shape == from_bvh.shape == (20, 14, 3)
    np.testing.assert_allclose(from_bvh, from_amc, atol=1e-5)  # metres


def test_fixture_asf_amc_is_a_person(fixtures_dir):
    poses = load_asf_amc(fixtures_dir / "cmu_02.asf", fixtures_dir / "cmu_02_01_short.amc")
    check_physical(poses)
    # head above neck above hips above knees above ankles (walking, Y up)
    y = poses[..., 1]
    assert np.all(y[:, J("head_top")] > y[:, J("neck")])
    assert np.all(y[:, J("neck")] > y[:, J("left_hip")])
    assert np.all(y[:, J("left_hip")] > y[:, J("left_knee")])
    assert np.all(y[:, J("left_knee")] > y[:, J("left_ankle")])


def test_parse_asf_fixture(fixtures_dir):
    skel = parse_asf(fixtures_dir / "cmu_02.asf")
    assert skel.length_unit == 0.45 and skel.angle_unit == "deg"
    assert len(skel.bones) == 30 and skel.parents["lfemur"] == "lhipjoint"
    assert skel.bones["lfemur"].dof == ("rx", "ry", "rz")
    assert skel.scale == pytest.approx((1.0 / 0.45) * 2.54 / 100)
    motion, degrees = parse_amc(fixtures_dir / "cmu_02_01_short.amc", skel)
    assert degrees and motion["root"].shape == (20, 6) and motion["ltibia"].shape == (20, 1)


def test_load_mocap_dispatch_and_find_asf(tmp_path, fixtures_dir):
    shutil.copy(fixtures_dir / "cmu_02.asf", tmp_path / "02.asf")
    shutil.copy(fixtures_dir / "cmu_02_01_short.amc", tmp_path / "02_01.amc")
    assert find_asf(tmp_path / "02_01.amc") == tmp_path / "02.asf"
    assert load_mocap(tmp_path / "02_01.amc").shape == (20, 14, 3)
    with pytest.raises(FileFormatError, match="unsupported"):
        load_mocap(tmp_path / "x.c3d")


# ---------------------------------------------------------------- bad files
def _bad_bvh(tmp_path, text):
    path = tmp_path / "bad.bvh"
    path.write_text(text)
    return path


@pytest.mark.parametrize("mutate, message", [
    (lambda t: t.replace("1 2 3 90 0 0 90 90\n", "1 2 3 90 0 0 90\n"),
     r"bad\.bvh, line 20: 7 channel values on a MOTION line, expected 8"),
    (lambda t: t.replace("1 2 3 90 0 0 90 90\n", ""),
     r"line 19: 'Frames: 2' but only 1 frame lines \(file truncated\?\)"),
    (lambda t: t.split("MOTION")[0],
     "no MOTION section"),
    (lambda t: t.replace("}\nMOTION", "MOTION"),
     r"line 15: MOTION before the hierarchy is closed"),
    (lambda t: t.replace("Xrotation Zrotation", "Xrotation Wrotation"),
     "line 9: unknown channel 'Wrotation'"),
    (lambda t: t.replace("CHANNELS 2", "CHANNELS 3"),
     "line 9: CHANNELS says 3 channels but lists 2"),
    (lambda t: t.replace("OFFSET 0 5 0", "OFFSET 0 5"),
     "line 8: OFFSET needs 3 numbers"),
    (lambda t: t.replace("1 2 3 0 0 0 0 0", "1 2 3 0 0 x 0 0"),
     "line 19: a channel value is not a number"),
    (lambda t: t.replace("HIERARCHY", "HIERARCHIE"),
     "line 1: expected 'HIERARCHY'"),
    (lambda t: t.replace("Frame Time: 0.0333333\n", ""),
     "expected 'Frame Time"),
])
def test_bad_bvh_errors(tmp_path, mutate, message):
    path = _bad_bvh(tmp_path, mutate(TWO_JOINTS))
    with pytest.raises(FileFormatError, match=message):
        parse_bvh(path)


@pytest.fixture
def skel(fixtures_dir):
    return parse_asf(fixtures_dir / "cmu_02.asf")


@pytest.mark.parametrize("mutate, message", [
    (lambda t: t.replace("lowerneck", "lowernek", 1), r"bad\.amc, line 9: unknown bone 'lowernek'"),
    (lambda t: t.replace("rtibia 11.5302", "rtibia 11.5302 3"),
     "line 27: bone 'rtibia' has 2 values, expected 1"),
    (lambda t: t.replace("rtibia 11.5302", "rtibia eleven"),
     "line 27: values of 'rtibia' are not numbers"),
    (lambda t: "\n".join(t.splitlines()[: t.splitlines().index("20") + 4]),
     r"frame 20 .* has no values for bone .* \(file truncated\?\)"),
    (lambda t: "\n".join(t.splitlines()[:3]), "no frames"),
])
def test_bad_amc_errors(tmp_path, fixtures_dir, skel, mutate, message):
    text = (fixtures_dir / "cmu_02_01_short.amc").read_text()
    path = tmp_path / "bad.amc"
    path.write_text(mutate(text))
    with pytest.raises(FileFormatError, match=message):
        parse_amc(path, skel)


@pytest.mark.parametrize("mutate, message", [
    (lambda t: t.replace(":bonedata", ":bonedat"), "no :bonedata section before :hierarchy"),
    (lambda t: t[: t.index(":hierarchy")], r"no :hierarchy section"),
    (lambda t: t.replace("lfemur ltibia", "lfemur ltibea"), r"line \d+: unknown bone 'ltibea' in :hierarchy"),
    (lambda t: t.replace("length 7.59371", "length long"), r"line 29: length values are not numbers"),
    (lambda t: t.replace("direction 0.34202 -0.939693 0  \n", "\n", 1),
     r"bone block starting at line \d+ has no 'direction'"),
    (lambda t: t[: t.index("name lowerback")], r"not closed \(file truncated\?\)"),
])
def test_bad_asf_errors(tmp_path, fixtures_dir, mutate, message):
    text = (fixtures_dir / "cmu_02.asf").read_text()
    path = tmp_path / "bad.asf"
    path.write_text(mutate(text))
    with pytest.raises(FileFormatError, match=message) as info:
        parse_asf(path)
    assert "bad.asf" in str(info.value)


# ---------------------------------------------------------------- real data
@pytest.mark.parametrize("clip", ["02_01", "03_01", "02_05"])
def test_real_cmu_clips(shared_data, clip):
    amc = shared_data / "cmu-mocap" / "subjects" / clip[:2] / f"{clip}.amc"
    poses = load_mocap(amc)
    assert poses.shape[1:] == (14, 3) and poses.shape[0] > 100
    check_physical(poses)


def test_real_bandai_clips(shared_data):
    data = shared_data / "bandai-namco-1" / "data"
    for name in ["dataset-1_walk_normal_001.bvh", "dataset-1_run_happy_001.bvh",
                 "dataset-1_bow_active_001.bvh"]:
        poses, info = load_bvh(data / name, return_info=True)
        assert info["rig"] == "bandai" and info["frame_rate"] == pytest.approx(30, rel=1e-3)
        check_physical(poses)


def test_rigs_cover_all_joints():
    for rig in FAMILIES:
        assert set(rig.joints) == set(SKELETON_14.joint_names)


def test_real_left_is_subjects_left(shared_data):
    """Walking forward (Y up), the left hip is on the walker's left: up x forward."""
    for path in [shared_data / "cmu-mocap" / "subjects" / "02" / "02_01.amc",
                 shared_data / "bandai-namco-1" / "data" / "dataset-1_walk_normal_001.bvh"]:
        poses = load_mocap(path)
        pelvis = poses[:, [J("left_hip"), J("right_hip")]].mean(axis=1)
        forward = pelvis[-1] - pelvis[0]
        forward[1] = 0
        left = np.cross([0.0, 1.0, 0.0], forward / np.linalg.norm(forward))
        assert np.all((poses[:, J("left_hip")] - poses[:, J("right_hip")]) @ left > 0.05), path
        assert np.all((poses[:, J("left_shoulder")] - poses[:, J("right_shoulder")]) @ left > 0), path
