"""Rotation in the image plane: recovery's normalisation (a dictionary's
``recovery_scale``) and what recover() fills for a rotated pose or file."""

from dataclasses import replace

import numpy as np
import pytest

import sparseedm
from sparseedm.dictionary import Dictionary, load_dictionary
from sparseedm.exceptions import DictionaryError, ParameterError
from sparseedm.metrics import random_occlusion
from sparseedm.normalize import normalize, represent

ANGLES = (np.pi / 2, 0.7, -2.4)


def rotate(poses, angle, about=(320.0, 240.0)):
    """`poses` rotated by `angle` (radians) about the point `about` in the image plane."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s], [s, c]])
    about = np.asarray(about)
    return (np.asarray(poses) - about) @ R.T + about


def pixel_poses(cmu_poses, n):
    """`n` fixture poses in a camera's pixel frame (about 200 px tall)."""
    p = cmu_poses[:n]
    lo = p.min(axis=1, keepdims=True)
    hi = p.max(axis=1, keepdims=True)
    return (p - lo) / (hi - lo).max(axis=2, keepdims=True) * 200 + [220.0, 140.0]


def filled_after_rotation(poses, missing, angle, **kwargs):
    """recover() on the rotated poses, rotated back: the unrotated answer if the
    recovery commutes with the rotation."""
    given = np.where(missing[..., None], np.nan, poses)
    res = sparseedm.recover(rotate(given, angle), missing, **kwargs)
    assert (res.status == "recovered").all(), res.reason
    return rotate(res.poses, -angle)


@pytest.mark.parametrize("rule", ["box", "radius"])
def test_radius_rule_is_invariant_and_box_is_not(cmu_poses, rule):
    poses = pixel_poses(cmu_poses, 50)
    missing = random_occlusion(len(poses), 14, "mix", random_state=1)
    T, _, _ = represent(np.where(missing[..., None], np.nan, poses), missing, rule=rule)
    gaps = []
    for angle in ANGLES:
        moved = rotate(poses, angle) * 1.7 + [13.0, -4.0]
        T2, _, _ = represent(np.where(missing[..., None], np.nan, moved), missing, rule=rule)
        gaps.append(np.abs(T2 - T).max())
    if rule == "radius":
        assert max(gaps) < 1e-9
    else:  # the bounding box turns with the body (but for quarter turns): T changes
        assert max(gaps) > 1e-3


def test_radius_rule_measures_the_observed_joints_only():
    pose = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [100.0, 100.0]])
    missing = np.array([False, False, False, False, True])
    normed, center, scale = normalize(pose, missing, rule="radius")
    alone, c4, s4 = normalize(pose[:4], rule="radius")
    assert np.allclose(center, c4) and np.isclose(scale, s4)
    assert np.allclose(normed[:4], alone)
    # the 'average' fill (the observed joints' mean) must not shrink the radius
    assert np.isclose(represent(pose, missing, "average", rule="radius")[2], s4)
    with pytest.raises(ParameterError, match="rule"):
        normalize(pose, rule="diagonal")


@pytest.mark.parametrize("angle", ANGLES)
def test_single_pose_with_defaults_fills_the_rotated_joints(cmu_poses, angle):
    pose = pixel_poses(cmu_poses, 3)[2:]
    missing = np.zeros((1, 14), bool)
    missing[0, [4, 9, 13]] = True  # right wrist, right knee, left ankle
    plain = filled_after_rotation(pose, missing, 0.0)
    turned = filled_after_rotation(pose, missing, angle)
    assert np.allclose(turned, plain, atol=1e-6)
    assert np.abs(plain[missing] - pose[missing]).max() < 100  # a pose, not noise


@pytest.mark.parametrize("angle", ANGLES)
def test_small_file_without_adaptation_fills_the_rotated_joints(cmu_poses, angle):
    poses = pixel_poses(cmu_poses, 40)
    missing = random_occlusion(len(poses), 14, "mix", random_state=3)
    plain = filled_after_rotation(poses, missing, 0.0, adapt=False)
    turned = filled_after_rotation(poses, missing, angle, adapt=False)
    assert np.allclose(turned, plain, atol=1e-6)


def test_small_file_on_the_file_atoms_path_fills_the_rotated_joints(cmu_poses):
    poses = pixel_poses(cmu_poses, 60)
    missing = random_occlusion(len(poses), 14, "mix", random_state=4)
    missing[:20] = False  # 20 complete poses: atoms, too few to adapt
    given = np.where(missing[..., None], np.nan, poses)
    plain = sparseedm.recover(given, missing)
    turned = sparseedm.recover(rotate(given, 0.7), missing)
    assert plain.adaptation is not None and plain.adaptation.file_atoms == 20
    assert np.allclose(rotate(turned.poses, -0.7), plain.poses, atol=1e-6)


def test_a_box_dictionary_is_not_rotation_invariant(cmu_poses):
    """The check above can fail: under the bounding-box rule the answers move."""
    poses = pixel_poses(cmu_poses, 40)
    missing = random_occlusion(len(poses), 14, "mix", random_state=3)
    box = replace(load_dictionary(), recovery_scale="box")
    plain = filled_after_rotation(poses, missing, 0.0, adapt=False, dictionary=box)
    turned = filled_after_rotation(poses, missing, 0.7, adapt=False, dictionary=box)
    assert np.abs(turned - plain).max() > 1e-3


def test_shipped_dictionaries_recover_with_the_radius_rule():
    for name in ("default", "cmu-k2000", "cmu-coco-k2466", "cmu-coco-k2932"):
        assert load_dictionary(name).recovery_scale == "radius"


def test_files_without_the_field_keep_the_box_rule(tmp_path):
    d = Dictionary(np.eye(91)[:5], alpha_recover=0.01)
    assert d.recovery_scale == "radius"
    path = tmp_path / "d.npz"
    d.save(path)
    assert load_dictionary(path).recovery_scale == "radius"
    with np.load(path, allow_pickle=False) as z:
        arrays = dict(z)
    meta = str(arrays["meta"])
    assert '"recovery_scale": "radius"' in meta
    for text, want in ((meta.replace('"recovery_scale": "radius", ', ""), "box"),):
        arrays["meta"] = np.array(text)
        np.savez(path, **arrays)
        assert load_dictionary(path).recovery_scale == want
    arrays["meta"] = np.array(meta.replace('"radius"', '"diagonal"'))
    np.savez(path, **arrays)
    with pytest.raises(DictionaryError, match="recovery_scale"):
        load_dictionary(path)


def test_radius_beyond_float64_falls_back_to_the_box():
    """Corners at +-8e307: the box's half side is finite, the scaled radius is not."""
    pose = np.array([[-8e307, -8e307], [8e307, 8e307], [-8e307, 8e307], [8e307, -8e307]])
    _, center, scale = normalize(pose, rule="radius")
    _, box_center, box_scale = normalize(pose, rule="box")
    assert np.isfinite(scale) and scale == box_scale and np.array_equal(center, box_center)
    # a moderate pose keeps its radius
    assert normalize(pose * 1e-300, rule="radius")[2] != normalize(pose * 1e-300)[2]


def test_the_gaussians_draws_and_fill_rotate_with_the_file(cmu_poses):
    """The stacked mean's Gaussian fills from the file's poses and their mirror
    images, each reflected across its own body axis: a file rotated in the
    image gets the same filled joints rotated (a mirror across the image's
    vertical would turn the other way)."""
    from sparseedm.file_atoms import mirror_images
    from sparseedm.gaussian_fill import local_gaussian_fill

    poses = pixel_poses(cmu_poses, 260)
    train, query = poses[:200], poses[200:260]
    missing = random_occlusion(len(query), 14, 2, random_state=4)
    for angle in (0.7, np.pi):
        turned = local_gaussian_fill(mirror_images(rotate(train, angle)),
                                     rotate(query, angle), missing)
        plain = local_gaussian_fill(mirror_images(train), query, missing)
        np.testing.assert_allclose(rotate(turned, -angle), plain, atol=1e-6)
