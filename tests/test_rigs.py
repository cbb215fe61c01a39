"""Rig families, joint maps, units, T-pose frames, plausibility (sparseedm.mocap.rigs).

The fixtures in tests/fixtures/rigs/ are the same CMU motion renamed and
rescaled per naming family (make_rig_fixtures.py), so every loader result is
checked against the ASF/AMC ground truth.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from sparseedm.cli import main
from sparseedm.dataset import build_dataset
from sparseedm.exceptions import FileFormatError
from sparseedm.mocap import load_asf_amc, load_bvh, parse_bvh
from sparseedm.mocap.rigs import (
    FAMILIES, HEIGHT_RANGE, UNITS, Source, UnitsError, chirality, choose_units,
    joint_map_to_json, match_names, plausibility, read_joint_map, standing_height, tpose_frames,
)
from sparseedm.skeleton import SKELETON_14

J = SKELETON_14.index
BODY = [j for j in SKELETON_14.joint_names if j != "head_top"]

#: fixture -> (rig detected, units chosen, head top equals CMU's End Site)
FIXTURES = {
    "cmu_cgspeed_cm.bvh": ("cmu", "cm", True),
    "mixamo_cm.bvh": ("mixamo", "cm", True),
    "motionbuilder_m.bvh": ("motionbuilder", "m", True),
    "cmu_3dsmax_inch.bvh": ("cmu-3dsmax", "inch", True),
    "daz_cm.bvh": ("daz", "cm", False),
    "reallusion_cm.bvh": ("reallusion", "cm", True),
    "bandai_cm.bvh": ("bandai", "cm", False),
}


@pytest.fixture
def truth(fixtures_dir):
    """Ground truth: the ASF/AMC poses of the fixture frames 0, 4, ..., 16."""
    return load_asf_amc(fixtures_dir / "cmu_02.asf", fixtures_dir / "cmu_02_01_short.amc")[::4]


def limb_lengths(poses):
    pairs = [("shoulder", "elbow"), ("elbow", "wrist"), ("hip", "knee"), ("knee", "ankle")]
    return {(side, a, b): np.linalg.norm(poses[:, J(f"{side}_{a}")] - poses[:, J(f"{side}_{b}")],
                                         axis=-1)
            for side in ("left", "right") for a, b in pairs}


@pytest.mark.parametrize("name", sorted(FIXTURES))
def test_family_fixture_builds_the_true_poses(fixtures_dir, truth, name):
    rig, units, same_head = FIXTURES[name]
    poses, info = load_bvh(fixtures_dir / "rigs" / name, return_info=True)
    assert (info["rig"], info["units"]) == (rig, units)
    assert poses.shape == (5, 14, 3)
    body = [J(j) for j in BODY]
    # every body joint where the ASF/AMC puts it: correct mapping, scale and chirality
    np.testing.assert_allclose(poses[:, body], truth[:, body], atol=2e-4)
    if same_head:
        np.testing.assert_allclose(poses[:, 0], truth[:, 0], atol=2e-4)
    # rigid bones, left/right symmetry, plausible height, head above neck (Y up)
    for length in limb_lengths(poses).values():
        assert np.ptp(length) < 1e-4
    lengths = limb_lengths(poses)
    for (side, a, b), length in lengths.items():
        if side == "left":
            assert abs(length.mean() - lengths[("right", a, b)].mean()) < 0.05 * length.mean()
    assert HEIGHT_RANGE[0] <= info["height"] <= HEIGHT_RANGE[1]
    assert np.all(poses[:, J("head_top"), 1] > poses[:, J("neck"), 1] + 0.1)
    assert plausibility(poses, height=info["height"]) == []
    assert len(info["tpose_frames"]) == 0
    assert chirality(poses) > 0.5


def test_left_right_swapped_map_is_flagged(fixtures_dir):
    path = fixtures_dir / "rigs" / "daz_cm.bvh"
    _, info = load_bvh(path, return_info=True)
    swapped = {}
    for joint, src in info["joint_map"].items():
        other = joint.replace("left", "R").replace("right", "left").replace("R", "right")
        swapped[other] = src.to_json()
    mirror = load_bvh(path, joint_map={"joints": swapped})
    assert chirality(mirror) < -0.5
    problems = plausibility(mirror, name="swapped.bvh")
    assert len(problems) == 1 and "left and right look swapped" in problems[0]


def test_units_never_both_plausible():
    """HEIGHT_RANGE is narrower than the ratio of any two units: auto is unambiguous."""
    lo, hi = HEIGHT_RANGE
    scales = sorted(UNITS.values())
    assert all(b / a > hi / lo for a, b in zip(scales, scales[1:]))


def test_head_top_rules_along_the_head_bone(fixtures_dir):
    path = fixtures_dir / "rigs" / "daz_cm.bvh"
    poses, info = load_bvh(path, return_info=True)
    assert info["sources"]["head_top"] == "head + 0.18 m along its bone"
    # a one-line joint map overrides one joint: head_top at the head joint itself
    head = load_bvh(path, joint_map={"joints": {"head_top": "head"}})
    neck = poses[:, J("neck")]
    np.testing.assert_allclose(np.linalg.norm(poses[:, 0] - head[:, 0], axis=-1), 0.18)
    # the head top continues the neck -> head line (head's offset direction, rotated)
    along = (poses[:, 0] - head[:, 0]) / 0.18
    bvh = parse_bvh(path)
    assert np.all(np.einsum("ni,ni->n", along, head[:, 0] - neck) > 0)
    # extrapolation neck -> head, factor 1: head + (head - neck)
    ext = load_bvh(path, joint_map={"joints": {"head_top": {"extrapolate": ["neck", "head"]}}})
    np.testing.assert_allclose(ext[:, 0], 2 * head[:, 0] - neck, atol=1e-9)
    # joint + an offset in the joint's local frame, in metres
    off = load_bvh(path, joint_map={"joints": {"head_top": {"joint": "head",
                                                              "offset": [0, 0.2, 0]}}})
    np.testing.assert_allclose(np.linalg.norm(off[:, 0] - head[:, 0], axis=-1), 0.2)
    assert bvh.joint_names[0] == "hip"


def test_case_and_prefix_insensitive_names():
    names = ["Armature|hips", "Armature|leftarm", "Armature|LEFTFOREARM"]
    assert match_names(["LeftArm", "LeftForeArm", "Hips"], names) == {
        "LeftArm": "Armature|leftarm", "LeftForeArm": "Armature|LEFTFOREARM",
        "Hips": "Armature|hips"}
    # an ambiguous suffix match is no match
    assert match_names(["Arm"], ["a_Arm", "b_Arm"]) == {}
    assert match_names(["Arm"], ["Arm", "b_Arm"]) == {"Arm": "Arm"}


def test_mixamo_text_with_namespace_case_changed(fixtures_dir, truth):
    text = (fixtures_dir / "rigs" / "mixamo_cm.bvh").read_text()
    text = text.replace("mixamorig:", "MIXAMORIG:").replace("LeftForeArm", "leftforearm")
    poses, info = load_bvh(text, return_info=True)
    assert info["rig"] == "mixamo"
    np.testing.assert_allclose(poses, truth, atol=2e-4)


# ---------------------------------------------------------------- units
def test_cgspeed_in_cm_is_auto_scaled_or_refused_clearly(fixtures_dir, truth, tmp_path):
    path = fixtures_dir / "rigs" / "cmu_cgspeed_cm.bvh"
    poses = load_bvh(path)
    np.testing.assert_allclose(poses, truth, atol=2e-4)
    # forcing CMU's unit builds the 7-10 m giant -- and the plausibility check says so
    giant, info = load_bvh(path, units="cmu", return_info=True)
    assert info["height"] > 5
    assert any("outside the plausible" in p for p in plausibility(giant, height=info["height"]))
    # a dataset build warns per clip
    with pytest.warns(UserWarning, match="cmu_cgspeed_cm.bvh: standing height"):
        build_dataset(path, units="cmu", progress=False)
    # no unit makes a 1000x-scaled figure human: a clear error
    text = path.read_text()
    bvh = parse_bvh(text)
    for j in bvh.joints:
        j.offset = j.offset * 1000
        for k in range(len(j.end_sites)):
            j.end_sites[k] = j.end_sites[k] * 1000
    bvh.motion[:, :3] *= 1000
    bvh.path = "huge.bvh"
    with pytest.raises(UnitsError, match=r"huge\.bvh: the rest pose is .* --units"):
        load_bvh(bvh)


def test_every_unit_is_recognised(fixtures_dir, truth):
    for unit, per_m in [("m", 1), ("cm", 100), ("mm", 1000), ("inch", 1 / 0.0254)]:
        chosen, h = choose_units(lambda s, per_m=per_m: 1.55 * per_m * s, None)
        assert chosen == unit and h == pytest.approx(1.55)
    with pytest.raises(UnitsError, match="x.bvh.*plausible"):
        choose_units(lambda s: 0.01 * s, None, path="x.bvh")


def test_asf_units_auto(fixtures_dir):
    poses, info = load_asf_amc(fixtures_dir / "cmu_02.asf", fixtures_dir / "cmu_02_01_short.amc",
                               return_info=True)
    assert info["units"] == "asf" and info["rig"] == "acclaim-asf"
    assert info["height"] == pytest.approx(standing_height(poses).max(), rel=0.05)
    # an ASF whose ':units length' is wrong by 100x is rescaled to a plausible height
    text = (fixtures_dir / "cmu_02.asf").read_text().replace("length 0.45", "length 0.0045")
    poses2, info2 = load_asf_amc(text, fixtures_dir / "cmu_02_01_short.amc", return_info=True)
    assert info2["units"] != "asf" and HEIGHT_RANGE[0] <= info2["height"] <= HEIGHT_RANGE[1]


# ---------------------------------------------------------------- T-pose
def test_tpose_frame_is_detected_and_dropped(fixtures_dir, tmp_path):
    text = (fixtures_dir / "rigs" / "motionbuilder_m.bvh").read_text()
    head, motion = text.split("Frame Time:")
    lines = motion.splitlines()
    first = lines[1].split()
    rest = " ".join(first[:3] + ["0"] * (len(first) - 3))  # rest pose: no rotation
    text = head.replace("Frames: 5", "Frames: 6") + "Frame Time:" + "\n".join(
        [lines[0], rest] + lines[1:]) + "\n"
    path = tmp_path / "with_tpose.bvh"
    path.write_text(text)
    poses, info = load_bvh(path, return_info=True)
    assert info["tpose_frames"].tolist() == [0]
    data, report = build_dataset(path, frame_step=1, progress=False, return_report=True)
    assert report["tpose_frames"] == 1 and data["frames"].tolist() == [1, 2, 3, 4, 5]
    kept = build_dataset(path, frame_step=1, progress=False, keep_tpose=True)
    assert kept["frames"].tolist() == [0, 1, 2, 3, 4, 5]
    assert len(tpose_frames(poses[1:])) == 0


# ---------------------------------------------------------------- joint maps
def test_joint_map_round_trip(fixtures_dir, truth, tmp_path):
    path = fixtures_dir / "rigs" / "mixamo_cm.bvh"
    poses, info = load_bvh(path, return_info=True)
    as_json = joint_map_to_json(info["joint_map"], units="cm")
    (tmp_path / "map.json").write_text(json.dumps(as_json))
    again = read_joint_map(tmp_path / "map.json")
    assert again["joints"] == info["joint_map"]
    # the map alone (rig names scrambled to an unknown family) gives the same poses
    text = path.read_text()
    renamed = {src.joint: f"bone{k:02d}" for k, src in enumerate(info["joint_map"].values())}
    for old, new in renamed.items():
        text = text.replace(f" {old}\n", f" {new}\n")
    with pytest.raises(FileFormatError, match="unknown BVH rig"):
        load_bvh(text)
    scrambled = {"units": "cm", "joints": {
        j: (renamed[s["joint"]] if isinstance(s, dict) and "joint" in s else renamed[s])
        for j, s in as_json["joints"].items()}}
    out, info2 = load_bvh(text, joint_map=scrambled, return_info=True)
    assert info2["rig"] == "joint-map" and info2["units"] == "cm"
    np.testing.assert_allclose(out, poses, atol=1e-12)
    # TOML with the same keys (Python >= 3.11)
    pytest.importorskip("tomllib")
    toml = "units = \"cm\"\n[joints]\n" + "\n".join(
        f'{j} = "{renamed[s] if isinstance(s, str) else renamed[s["joint"]]}"'
        for j, s in as_json["joints"].items())
    (tmp_path / "map.toml").write_text(toml)
    np.testing.assert_allclose(load_bvh(text, joint_map=tmp_path / "map.toml"), poses, atol=1e-12)


def test_readme_mixamo_example(fixtures_dir, truth):
    """The worked example in README.md ('Motion capture from any rig') works."""
    poses, info = load_bvh(fixtures_dir / "rigs" / "mixamo_cm.bvh",
                           joint_map=fixtures_dir / "rigs" / "mixamo_map.json", return_info=True)
    assert info["sources"]["head_top"] == "mixamorig:HeadTop_End"
    np.testing.assert_allclose(poses, truth, atol=2e-4)


@pytest.mark.parametrize("bad, message", [
    ({"joints": {"nose": "Head"}}, "unknown joint.*nose"),
    ({"units": "furlong"}, "unknown units 'furlong'"),
    ({"rig": "poser"}, "unknown rig 'poser'"),
    ({"joints": {"head_top": {"joint": "Head", "offset": [0, 1]}}}, "3 numbers"),
    ({"joints": {"head_top": {"bone": "Head"}}}, "unknown rule"),
    ({"joints": {"head_top": {"extrapolate": "Head"}}}, r"\[from_joint, to_joint\]"),
    ({"joints": {"head_top": {"joint": "Head", "along_bone": "far"}}}, "bad value"),
    ({"colour": 1}, "unknown key"),
])
def test_bad_joint_maps(bad, message):
    with pytest.raises(FileFormatError, match=message):
        read_joint_map(bad)


def test_joint_map_naming_missing_joint(fixtures_dir, tmp_path):
    (tmp_path / "m.json").write_text('{"joints": {"neck": "Nek"}}')
    with pytest.raises(FileFormatError, match=r"m\.json.*names Nek for neck.*no such joint"):
        load_bvh(fixtures_dir / "rigs" / "daz_cm.bvh", joint_map=tmp_path / "m.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(FileFormatError, match=r"bad\.json: not a valid joint map"):
        read_joint_map(tmp_path / "bad.json")


def test_sources_json_round_trip():
    for src in [Source("joint", "A"), Source("end", "A"), Source("along", "A", distance=0.1),
                Source("offset", "A", vector=(0.0, 0.1, 0.0)),
                Source("extrapolate", "B", other="A", factor=0.5)]:
        assert Source.from_json(src.to_json(), "x") == src


def test_every_family_is_detected_from_its_own_names():
    for rig in FAMILIES:
        names = sorted({s.joint for alts in rig.joints.values() for s in alts[:1]})
        from sparseedm.mocap import detect_rig
        assert detect_rig(names) == rig.name, rig.name


# ---------------------------------------------------------------- CLI
def test_cli_inspect_and_options(fixtures_dir, tmp_path, capsys):
    path = fixtures_dir / "rigs" / "daz_cm.bvh"
    assert main(["dataset", "inspect", str(path), "--write-map", str(tmp_path / "m.json")]) == 0
    out = capsys.readouterr().out
    assert "rig:     daz" in out and "units:   cm" in out
    assert "right_shoulder  <- rShldr" in out and "head_top        <- head + 0.18 m" in out
    assert read_joint_map(tmp_path / "m.json")["units"] == "cm"
    # forced wrong units: inspect warns and exits 1
    assert main(["dataset", "inspect", str(path), "--units", "inch"]) == 1
    assert "outside the plausible" in capsys.readouterr().out
    # build with a joint map and units
    code = main(["dataset", "build", str(path), "-o", str(tmp_path / "d.npz"), "--quiet",
                 "--joint-map", str(tmp_path / "m.json"), "--units", "cm"])
    assert code == 0
    # an unknown rig is a clean error (exit 2), naming the file and --joint-map
    bad = tmp_path / "unknown.bvh"
    bad.write_text(path.read_text().replace("rShldr", "upperarm_r"))
    assert main(["dataset", "inspect", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "unknown.bvh" in err and "--joint-map" in err and "Traceback" not in err


def test_asf_bone_names_any_case(fixtures_dir):
    """HDM05-style ASF/AMC: Acclaim bone names, matched whatever their case."""
    from sparseedm.mocap.asf_amc import JOINT_BONES

    asf = (fixtures_dir / "cmu_02.asf").read_text()
    amc = (fixtures_dir / "cmu_02_01_short.amc").read_text()
    for bone in JOINT_BONES.values():
        asf = asf.replace(f" {bone}", f" {bone.upper()}").replace(f"{bone} ", f"{bone.upper()} ")
        amc = amc.replace(f"\n{bone} ", f"\n{bone.upper()} ")
    assert "LFEMUR" in asf and "\nLFEMUR " in amc
    upper = load_asf_amc(asf, amc)
    ref = load_asf_amc(fixtures_dir / "cmu_02.asf", fixtures_dir / "cmu_02_01_short.amc")
    np.testing.assert_allclose(upper, ref, atol=1e-12)
    # a joint map moves a joint to another bone's end
    moved = load_asf_amc(fixtures_dir / "cmu_02.asf", fixtures_dir / "cmu_02_01_short.amc",
                         joint_map={"joints": {"neck": "upperneck"}})
    assert np.all(moved[:, J("neck"), 1] > ref[:, J("neck"), 1])


def test_real_tpose_frames(shared_data):
    """The Daz conversions start with a T-pose; Bandai dancers and wavers spread
    their arms mid-clip, which is motion and is kept."""
    _, info = load_bvh(shared_data / "cmu-bvh-daz" / "salsa" / "01.bvh", return_info=True)
    assert info["tpose_frames"].tolist() == [0]
    for name in ["dataset-1_walk_musical_002.bvh", "dataset-1_byebye_active_001.bvh"]:
        poses, info = load_bvh(shared_data / "bandai-namco-1" / "data" / name, return_info=True)
        assert len(info["tpose_frames"]) == 0
        assert len(tpose_frames(poses, edges_only=False)) > 0


@pytest.mark.parametrize("loader", ["bvh", "asf"])
def test_an_unknown_unit_is_refused_by_both_loaders_even_with_a_scale(loader):
    fixtures = Path(__file__).parent / "fixtures"
    with pytest.raises(ValueError, match="unknown units 'furlong'"):
        if loader == "bvh":
            load_bvh(fixtures / "cmu_02_01_short.bvh", units="furlong", scale=1.0)
        else:
            load_asf_amc(fixtures / "cmu_02.asf", fixtures / "cmu_02_01_short.amc",
                         units="furlong", scale=1.0)
