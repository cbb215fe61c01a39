"""recover()'s default path takes a file's own complete poses as its only atoms when
sparseedm.exemplars' rule says so: from EXEMPLAR_MIN_POSES complete poses, or when the
check on held-back poses prefers them; below MIN_COMPLETE_POSES the base with the
file atoms, averaged with the base with them and their mirror images when a check
says so (from FEW_MIN_POSES); with exemplars=False the path is what it was.
Statuses, certificates and refusals unchanged."""

import numpy as np
import pytest

from sparseedm import recover
from sparseedm._recovery_base import FIRST_ROWS, STATUSES
from sparseedm.adaptation import (AVERAGED_PATH, GUARD_POSES_PER_PATTERN, MIN_COMPLETE_POSES,
                                  MIRRORED_ATOMS_PATH, guard_masks)
from sparseedm.cli import build_parser
from sparseedm.exceptions import ParameterError
from sparseedm.exemplars import (AVERAGED_MANY_HIDDEN, AVERAGED_RIDGE_MEAN, EXEMPLAR_MARGIN,
                                 EXEMPLAR_MIN_POSES, FEW_MIN_POSES, choose_exemplars,
                                 held_masks, hidden_joint_error)
from sparseedm.solvers.fast import FastSolver


# These tests rebuild the default path's answer from its parts: without the
# donor step after it (their files repeat poses, twins the donors would use;
# tests/test_donors.py covers the step)
pytestmark = pytest.mark.usefixtures("without_donor_step")


def _jittered(poses, n, seed=0, sd=0.5):
    """n poses drawn from `poses` with a little pixel noise (no exact repeats)."""
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, len(poses), n)
    return poses[np.sort(pick)] + rng.normal(0, sd, (n,) + poses.shape[1:])


def _file(cmu_poses, n_complete, n_occluded=60, seed=0):
    """n_complete jittered complete poses, then n_occluded with 1-3 joints hidden,
    one with 2 joints left (refused) and one with an infinite coordinate (refused)."""
    poses = _jittered(cmu_poses, n_complete + n_occluded, seed=seed)
    missing = np.zeros(poses.shape[:2], bool)
    missing[n_complete:] = guard_masks(n_occluded, 14, random_state=seed)
    missing[-1, :12] = True
    poses[-2, 3, 0] = np.inf
    return np.where(missing[..., None], np.nan, poses), missing


@pytest.fixture
def without_ridge_mean(monkeypatch):
    """recover() without the mean with the local ridge over base + file atoms on
    every occluded pose: the path's own answers."""
    import sparseedm.exemplars

    monkeypatch.setattr(sparseedm.exemplars, "ridge_mean_atoms", lambda *a: None)


@pytest.fixture(scope="module")
def large_file(cmu_poses):
    return _file(cmu_poses, EXEMPLAR_MIN_POSES + 50)


def test_many_complete_poses_take_the_file_atoms(large_file, small_dictionary):
    poses, missing = large_file
    res = recover(poses, missing, dictionary=small_dictionary)
    ad = res.adaptation
    s = res.summary()["adaptation"]
    assert s["path"] == "file atoms" and not res.adapted
    # nothing learned, no self-training: the atoms are the file's complete poses
    assert ad.candidate is None and s["poses_used"] == 0 and s["self_training"] == []
    # jittered copies of the fixture's few hundred poses: near-copies merged
    # (file_atoms.ATOM_SPACING) into fewer atoms than the rule's count, which
    # counts atoms: the held-back check chose them
    assert res.dictionary.n_components == ad.file_atoms < EXEMPLAR_MIN_POSES
    assert f"{ad.file_atoms} atoms once near-copies are merged" in ad.reason
    assert ad.line().startswith("adaptation: none, the file's own poses are the atoms")
    # the same dictionary as the fast preset's, coded by the lasso (the preset's
    # own coder is a local ridge): the same answers as the preset with the lasso
    fast = recover(poses, missing, dictionary=small_dictionary, preset="fast",
                   solver=FastSolver())
    np.testing.assert_allclose(res.poses, fast.poses, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(res.status, fast.status)


def test_statuses_certificates_and_refusals_unchanged(large_file, small_dictionary):
    poses, missing = large_file
    res = recover(poses, missing, dictionary=small_dictionary)
    plain = recover(poses, missing, dictionary=small_dictionary, adapt=False)
    assert set(res.status) <= set(STATUSES)
    refused = ~np.isin(plain.status, ("recovered", "complete", "inaccurate"))
    assert refused.sum() == 2
    np.testing.assert_array_equal(res.status[refused], plain.status[refused])
    np.testing.assert_array_equal(res.reason[refused], plain.reason[refused])
    rec = res.status == "recovered"
    assert rec.sum() > 50
    assert (res.gap[rec] <= 1e-6 * res.objective[rec]).all()
    given = ~missing[rec] & np.isfinite(poses[rec]).all(axis=-1)
    np.testing.assert_array_equal(res.poses[rec][given], poses[rec][given])
    assert res.uncertainty is not None and np.isfinite(res.uncertainty[rec][missing[rec]]).all()


def test_an_ensemble_on_the_file_atoms_path_says_one_member_ran(large_file, small_dictionary):
    """ensemble=K where the file's own poses are the atoms: nothing is learned, so
    every seed would code with the same atoms; one dictionary recovers, a warning
    says why, and the record says how many were asked and how many ran. The answer
    and its uncertainty are the ones without an ensemble."""
    from sparseedm.uncertainty import coding_way

    poses, missing = large_file
    with pytest.warns(UserWarning, match=r"ensemble=3: .*own complete poses are the "
                                         r"atoms.*1 dictionary recovers"):
        res = recover(poses, missing, dictionary=small_dictionary, ensemble=3,
                      self_training=0)
    plain = recover(poses, missing, dictionary=small_dictionary)
    assert res.members == 1 and res.adaptation.path == "file atoms"
    assert res.summary()["adaptation"]["ensemble"] == {"asked": 3, "members": 1}
    assert "ensemble" not in plain.summary()["adaptation"]
    np.testing.assert_array_equal(res.poses, plain.poses)
    assert coding_way(res) == coding_way(plain) == "file_atoms"
    np.testing.assert_array_equal(res.uncertainty, plain.uncertainty)


def test_the_summary_says_an_ensemble_only_for_adapted_members():
    """The averaged path's three dictionaries are not an ensemble of adapted ones:
    `sparseedm recover`'s lines do not call them so."""
    from sparseedm.cli.recover_cmd import format_summary

    base = dict(output="o.npz", format="npz", poses=3, recovered_joints=2, refused=0,
                seconds=1.0, poses_per_second=3.0, status={"recovered": 3}, ensemble=3)
    averaged = format_summary(dict(base, adaptation={"adapted": False,
                                                     "path": AVERAGED_PATH}))
    adapted = format_summary(dict(base, adaptation={"adapted": True, "path": "adapted"}))
    assert "adapted dictionaries" not in averaged
    said = format_summary(dict(base, averaged={"with": {"local ridge over file atoms": {
        "poses": 12}}}))
    assert "averaged with the answer of the local ridge over file atoms: 12 pose(s)" in said
    assert "ensemble: the mean of 3 adapted dictionaries' recoveries" in adapted


def test_exemplars_false_keeps_adaptation(cmu_poses, small_dictionary):
    """The same large file with exemplars=False adapts, as the path did before the rule."""
    poses, missing = _file(cmu_poses, EXEMPLAR_MIN_POSES + 50)
    res = recover(poses, missing, dictionary=small_dictionary, exemplars=False,
                  self_training=0)
    s = res.summary()["adaptation"]
    assert s["path"] in ("adapted", "base + file atoms") and s["poses_used"] > 0
    assert res.adaptation.candidate is not None
    assert "held_err_atoms" not in res.adaptation.settings


def test_a_small_file_keeps_the_old_path(cmu_poses, small_dictionary):
    """Fewer complete poses than the check needs: the base with them as atoms, whatever
    `exemplars` says, nothing checked."""
    poses, missing = _file(cmu_poses, FEW_MIN_POSES - 10)
    auto = recover(poses, missing, dictionary=small_dictionary)
    off = recover(poses, missing, dictionary=small_dictionary, exemplars=False)
    assert auto.summary()["adaptation"]["path"] == "base + file atoms"
    assert "held_err_base" not in auto.adaptation.settings
    np.testing.assert_array_equal(auto.poses, off.poses)
    n_atoms = auto.adaptation.file_atoms
    assert auto.dictionary.n_components == small_dictionary.n_components + n_atoms


def _mirror_twins(cmu_poses, n, n_occluded=60):
    """A file whose n complete poses come in mirror pairs (each pose's mirror image is
    beside it: the held-back check finds every held pose among the other poses'
    mirror images), then n_occluded with 1-3 joints hidden."""
    from sparseedm.file_atoms import mirror_images

    half = _jittered(cmu_poses, n // 2, seed=3)
    rest, mask = _file(cmu_poses[::-1], 0, n_occluded=n_occluded, seed=4)
    poses = np.concatenate([mirror_images(half), rest])  # half, then their images
    missing = np.concatenate([np.zeros((2 * len(half), 14), bool), mask])
    return poses, missing


def test_few_poses_are_averaged_with_their_mirror_images_when_the_check_says_so(
        cmu_poses, small_dictionary):
    """Below MIN_COMPLETE_POSES, a file whose held-back complete poses the base with the
    file's mirror images as atoms recovers better: recover() returns the mean of the
    answers of the base with the file atoms and with them and their mirror images, nothing
    learned, statuses and certificates as each gives them, rated as the base with file
    atoms is (per frame)."""
    from sparseedm._recovery_base import combine
    from sparseedm.file_atoms import complete_rows, mirror_images, with_file_atoms
    from sparseedm.uncertainty import coding_way

    poses, missing = _mirror_twins(cmu_poses, 120)
    check = choose_exemplars(small_dictionary, poses, missing)
    assert FEW_MIN_POSES <= check.n_complete < MIN_COMPLETE_POSES
    assert check.err_both < check.err_base and not np.isfinite(check.err_atoms)
    assert check.result.path == MIRRORED_ATOMS_PATH and len(check.members) == 2
    res = recover(poses, missing, dictionary=small_dictionary)
    s = res.summary()["adaptation"]
    assert s["path"] == MIRRORED_ATOMS_PATH and res.members == 2 and not res.adapted
    assert res.adaptation.settings["held_err_both"] == check.err_both
    assert coding_way(res) == "per_frame"
    complete = poses[complete_rows(poses, missing)]
    own = [recover(poses, missing, dictionary=d, adapt=False)
           for d in (with_file_atoms(small_dictionary, complete).dictionary,
                     with_file_atoms(small_dictionary, mirror_images(complete)).dictionary)]
    mean = combine(own)
    np.testing.assert_allclose(res.poses, mean.poses, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(res.status, mean.status)
    rec = res.status == "recovered"
    assert rec.sum() > 50 and (res.gap[rec] <= 1e-6 * res.objective[rec]).all()
    assert "mirror images" in res.adaptation.reason
    said = res.summary()
    assert "ensemble" not in said and len(said["averaged"]["answers"]) == 2


def test_recover_file_says_the_paths_own_averaged_answers_are_no_ensemble(
        cmu_poses, small_dictionary, tmp_path):
    """`sparseedm recover` on a file the default path averages two codes of: its
    summary names the answers averaged and reports no ensemble nobody asked for."""
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, write_keypoints

    poses, missing = _mirror_twins(cmu_poses, 120)
    src = write_keypoints(tmp_path / "in.npz", KeypointSet(poses, missing))
    summary = recover_file(src, tmp_path / "out.npz", dictionary=small_dictionary)
    assert summary["adaptation"]["path"] == MIRRORED_ATOMS_PATH
    assert summary["ensemble"] == 1 and len(summary["averaged"]["answers"]) == 2


def test_few_poses_keep_the_base_with_file_atoms_when_the_check_declines(
        cmu_poses, small_dictionary):
    """Below MIN_COMPLETE_POSES, when the mean with the mirror images did not recover
    the held-back poses better, the path is the base with file atoms as before, the
    check's errors recorded."""
    poses, missing = _file(cmu_poses, MIN_COMPLETE_POSES - 50)
    check = choose_exemplars(small_dictionary, poses, missing)
    assert np.isfinite(check.err_base) and np.isfinite(check.err_both)
    res = recover(poses, missing, dictionary=small_dictionary)
    if check.err_both < check.err_base:
        assert res.adaptation.path == MIRRORED_ATOMS_PATH
    else:
        assert res.adaptation.path == "base + file atoms" and res.members == 1
        off = recover(poses, missing, dictionary=small_dictionary, exemplars=False)
        np.testing.assert_array_equal(res.poses, off.poses)
    assert res.adaptation.settings["held_err_base"] == check.err_base


@pytest.mark.parametrize("copies", [EXEMPLAR_MIN_POSES // 100 + 1, 3])
def test_exact_repeats_count_once(cmu_poses, small_dictionary, copies):
    """Complete poses that repeat exactly (a still person with integer keypoints)
    make one atom each: the rule counts distinct poses, so 100 poses repeated past
    EXEMPLAR_MIN_POSES or MIN_COMPLETE_POSES are not 100 atoms taken unchecked or a
    held-back check judged on twins of its own poses; the reason says so."""
    complete = np.round(np.tile(cmu_poses[:100], (copies, 1, 1)))
    assert len(complete) >= (EXEMPLAR_MIN_POSES if copies > 3 else MIN_COMPLETE_POSES)
    occluded, mask = _file(cmu_poses[100:], 0, n_occluded=60)
    poses = np.concatenate([complete, occluded])
    missing = np.concatenate([np.zeros(complete.shape[:2], bool), mask])
    check = choose_exemplars(small_dictionary, poses, missing)
    assert check.dictionary is None and check.n_complete == len(complete)
    assert not np.isfinite(check.err_atoms)          # too few distinct: not checked
    res = recover(poses, missing, dictionary=small_dictionary, self_training=0)
    assert res.adaptation.path != "file atoms"
    rec = res.status == "recovered"
    assert rec.sum() >= 50 and np.isfinite(res.poses[rec]).all()
    assert np.isfinite(res.uncertainty[rec][missing[rec]]).all()
    fast = recover(poses, missing, dictionary=small_dictionary, preset="fast")
    assert f"{len(complete)} complete poses (100 distinct)" in fast.adaptation.reason


@pytest.mark.parametrize("scale", [1.0, 1000.0])
def test_near_copies_count_as_one_pose(cmu_poses, small_dictionary, scale):
    """A still person whose complete poses differ by 1e-4 px of noise: past
    EXEMPLAR_MIN_POSES of them, still one pose (REPEAT_TOLERANCE, relative to the
    pose's size: at any pixel scale). Neither 2,050 near-identical atoms taken
    unchecked nor a dictionary adapted on them (each recovered the other people's
    hidden joints from that one pose, 15 times the base's error): the base with it
    as one extra atom, the reason saying so."""
    rng = np.random.default_rng(0)
    still = cmu_poses[0] + rng.normal(0, 1e-4, (EXEMPLAR_MIN_POSES + 50, 14, 2))
    occluded, mask = _file(cmu_poses[100:], 0, n_occluded=60)
    poses = np.concatenate([still, occluded]) * scale
    missing = np.concatenate([np.zeros(still.shape[:2], bool), mask])
    check = choose_exemplars(small_dictionary, poses, missing)
    assert check.dictionary is None and check.n_complete == len(still)
    res = recover(poses, missing, dictionary=small_dictionary, self_training=0)
    assert res.adaptation.path == "base + file atoms" and res.adaptation.file_atoms == 1
    base = recover(poses, missing, dictionary=small_dictionary, adapt=False)
    truth = np.concatenate([still, cmu_poses[100:160]]) * scale
    rec = (res.status == "recovered") & (base.status == "recovered")
    assert rec.sum() >= 50

    def err(r):
        return np.linalg.norm(r.poses - truth, axis=-1)[rec][missing[rec]].mean()
    assert err(res) < 1.5 * err(base)
    fast = recover(poses, missing, dictionary=small_dictionary, preset="fast")
    assert f"{len(still)} complete poses (1 distinct)" in fast.adaptation.reason


def test_the_check_between_decides_on_the_hidden_joints(cmu_poses, small_dictionary):
    """Between MIN_COMPLETE_POSES and EXEMPLAR_MIN_POSES: the check scores both on
    held-back poses; the margin decides; recover() follows the check."""
    poses, missing = _file(cmu_poses, 400)
    never = choose_exemplars(small_dictionary, poses, missing, margin=-1.0)
    assert never.dictionary is None and never.n_complete == 400 and never.members == []
    assert np.isfinite([never.err_base, never.err_atoms, never.err_both]).all()
    always = choose_exemplars(small_dictionary, poses, missing, margin=1e9)
    own = "file atoms" if never.err_atoms <= never.err_both else AVERAGED_PATH
    assert always.dictionary is not None and always.result.path == own
    assert always.err_atoms == never.err_atoms
    assert always.result.settings["held_err_base"] == never.err_base
    res = recover(poses, missing, dictionary=small_dictionary, self_training=0)
    s = res.adaptation.settings
    assert s["held_err_atoms"] == never.err_atoms and s["held_err_base"] == never.err_base
    assert s["held_err_both"] == never.err_both
    best = min(never.err_atoms, never.err_both)
    taken = best <= (1 + EXEMPLAR_MARGIN) * never.err_base
    assert (res.adaptation.path == own) == taken
    if not taken:   # adapted as before, the check noted
        assert res.adaptation.n_used > 0 and "exemplar_check" in res.adaptation.step_seconds


def test_the_check_prefers_exemplars_that_hold_the_poses(cmu_poses, small_dictionary):
    """A file whose occluded poses are near-copies of its complete ones (a video's
    neighbouring frames) against a dictionary of another domain: the exemplars."""
    shrunk = replace_atoms(small_dictionary, 10)
    poses, missing = _file(cmu_poses[:60], 400, seed=3)
    check = choose_exemplars(shrunk, poses, missing)
    assert check.err_atoms < check.err_base and check.dictionary is not None
    res = recover(poses, missing, dictionary=shrunk)
    own = "file atoms" if check.err_atoms <= check.err_both else AVERAGED_PATH
    assert res.adaptation.path == own and res.adaptation.candidate is None


def test_the_check_averages_the_two_when_their_mean_recovers_best(cmu_poses, small_dictionary,
                                                                  without_ridge_mean):
    """A file where the mean of the answers of the exemplars, the exemplars with their
    mirror images and the base with the exemplars as extra atoms recovered the
    held-back hidden joints better than the exemplars or the base: recover() codes
    the occluded poses with the three and returns the mean of their answers, nothing
    learned, statuses and certificates as each gives them."""
    from sparseedm._recovery_base import combine
    from sparseedm.file_atoms import (complete_rows, file_dictionary, mirror_images,
                                      with_file_atoms)

    poses, missing = _file(cmu_poses, 400, seed=1)
    check = choose_exemplars(small_dictionary, poses, missing)
    assert check.err_both < min(check.err_atoms, check.err_base)
    assert check.result.path == AVERAGED_PATH and len(check.members) == 3
    res = recover(poses, missing, dictionary=small_dictionary)
    assert res.adaptation.path == AVERAGED_PATH and res.members == 3
    assert res.adaptation.candidate is None and not res.adapted
    assert res.adaptation.settings["held_err_both"] == check.err_both
    complete = poses[complete_rows(poses, missing)]
    own = [recover(poses, missing, dictionary=d, adapt=False)
           for d in (file_dictionary(small_dictionary, complete).dictionary,
                     file_dictionary(small_dictionary, mirror_images(complete)).dictionary,
                     with_file_atoms(small_dictionary, complete).dictionary)]
    mean = combine(own)
    np.testing.assert_allclose(res.poses, mean.poses, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(res.status, mean.status)
    rec = res.status == "recovered"
    assert rec.sum() > 50 and (res.gap[rec] <= 1e-6 * res.objective[rec]).all()
    assert np.isfinite(res.uncertainty[rec][missing[rec]]).all()
    assert "mirror images, averaged with the base dictionary" in res.adaptation.reason
    # said as the path's own averaged answers, not as an ensemble nobody asked for
    said = res.summary()
    assert "ensemble" not in said and "ensemble" not in said["adaptation"]
    assert said["averaged"]["answers"] == list(res.adaptation.averaged_answers)
    assert len(said["averaged"]["answers"]) == 3 and "with" not in said["averaged"]


def test_the_check_hides_the_files_own_missing_patterns(cmu_poses):
    """The held-back poses are masked as the file's incomplete poses are (a seeded
    draw among the patterns that keep 3 joints); the guard's Mix masks without one."""
    poses, missing = _file(cmu_poses, 300)
    masks = held_masks(poses, missing, 60)
    patterns = {m.tobytes() for m in missing[missing.any(axis=1) & (missing.sum(axis=1) <= 11)]}
    assert masks.shape == (60, 14) and all(m.tobytes() in patterns for m in masks)
    np.testing.assert_array_equal(masks, held_masks(poses, missing, 60))
    with_nan = np.where(missing[..., None], np.nan, poses)
    np.testing.assert_array_equal(held_masks(with_nan, None, 60), masks)
    complete = cmu_poses[:300]
    np.testing.assert_array_equal(held_masks(complete, None, 60),
                                  guard_masks(60, 14, 60 // GUARD_POSES_PER_PATTERN, 0))


def replace_atoms(dictionary, k):
    """`dictionary` with only its first k atoms (a poor prior)."""
    from dataclasses import replace

    return replace(dictionary, components=dictionary.components[:k])


def test_hidden_joint_error_is_zero_for_a_pose_the_atoms_hold(cmu_poses, small_dictionary):
    from sparseedm.file_atoms import file_dictionary

    atoms = file_dictionary(small_dictionary, cmu_poses[:300]).dictionary
    mask = guard_masks(20, 14, random_state=1)
    seen = hidden_joint_error(atoms, cmu_poses[:20], mask)
    unseen = hidden_joint_error(atoms, cmu_poses[300:320], mask)
    assert seen < 1.0 < unseen


@pytest.mark.parametrize("scale", [1e-300, 1e200])
def test_the_check_does_not_depend_on_the_pixel_scale(cmu_poses, small_dictionary, scale):
    """The check's errors are in % of each pose's size: the same at any pixel scale
    recover() accepts (at 1e200 the distances' squares overflow unless scaled first),
    so the path chosen and the poses it fills scale with the input."""
    poses, missing = _file(cmu_poses, 400)
    one = choose_exemplars(small_dictionary, poses, missing)
    scaled = choose_exemplars(small_dictionary, poses * scale, missing)
    assert np.isfinite(one.err_atoms) and np.isfinite(one.err_base)
    np.testing.assert_allclose([scaled.err_atoms, scaled.err_base],
                               [one.err_atoms, one.err_base], rtol=1e-6)
    assert (scaled.dictionary is None) == (one.dictionary is None)


def test_bad_exemplars_argument_is_refused(cmu_poses):
    with pytest.raises(ParameterError, match="exemplars"):
        recover(cmu_poses[:2], exemplars="yes")
    with pytest.raises(ParameterError, match="exemplars"):
        recover(cmu_poses[:2], exemplars=True)


def test_cli_no_exemplars_flag():
    args = build_parser().parse_args(["recover", "in.csv", "-o", "o.csv", "--no-exemplars"])
    assert args.no_exemplars
    assert not build_parser().parse_args(["recover", "in.csv", "-o", "o.csv"]).no_exemplars


def test_cli_large_file_takes_the_atoms_and_says_so(tmp_path, large_file,
                                                    small_dictionary_path, capsys):
    """`sparseedm recover` (recover_file) takes the same rule: the line says which path
    ran, no refusal is printed, an ensemble asked for warns that one dictionary
    recovers, and --no-exemplars adapts."""
    from sparseedm.cli import main
    from sparseedm.keypoints import write_keypoints

    poses, missing = large_file
    ok = np.isfinite(poses).all(axis=-1).any(axis=-1) & ~np.isinf(poses).any(axis=(1, 2))
    inp = tmp_path / "in.npz"
    write_keypoints(inp, poses[ok])
    assert main(["recover", str(inp), "-o", str(tmp_path / "out.npz"), "--dictionary",
                 str(small_dictionary_path), "--self-training", "0", "--ensemble", "2"]) in (0, 1)
    cap = capsys.readouterr()
    assert "adaptation: none, the file's own poses are the atoms" in cap.out
    assert "no adaptation:" not in cap.err and "adapted dictionaries" not in cap.out
    assert "sparseedm recover: warning: ensemble=2: the file's own complete poses" in cap.err
    assert main(["recover", str(inp), "-o", str(tmp_path / "out2.npz"), "--dictionary",
                 str(small_dictionary_path), "--self-training", "0", "--no-exemplars"]) in (0, 1)
    line = next(ln for ln in capsys.readouterr().out.splitlines()
                if ln.startswith("adaptation:"))
    assert "the file's own poses are the atoms" not in line and "poses used" in line


def _legs_file(cmu_poses, n_complete=120, n_legs=12):
    """`_file` (1-3 hidden joints) with `n_legs` more poses whose knees and ankles are
    all hidden."""
    poses, missing = _file(cmu_poses, n_complete)
    legs = _jittered(cmu_poses[::-1], n_legs, seed=5)
    hidden = np.zeros((n_legs, 14), bool)
    hidden[:, [9, 10, 12, 13]] = True
    return (np.concatenate([poses, np.where(hidden[..., None], np.nan, legs)]),
            np.concatenate([missing, hidden]))


def test_poses_with_four_hidden_joints_are_averaged_with_the_local_ridge(cmu_poses,
                                                                         small_dictionary,
                                                                         monkeypatch,
                                                                         without_ridge_mean):
    """The default path, nothing learned: each pose with at least four hidden joints
    gets the mean of the path's answer and the local ridge's over the file's complete
    poses as the only atoms; every other pose is the path's answer."""
    import sparseedm.exemplars
    from sparseedm._recovery_kernel import FAST_RIDGE
    from sparseedm.exemplars import blend_rows
    from sparseedm.file_atoms import complete_rows, file_dictionary
    from sparseedm.solvers import LocalRidgeSolver

    poses, missing = _legs_file(cmu_poses)
    rows = blend_rows(missing)
    assert len(rows) == 13  # the 12, and the refused pose of 12 hidden joints
    res = recover(poses, missing, dictionary=small_dictionary)
    assert not res.adapted and res.adaptation.file_atoms > 0
    monkeypatch.setattr(sparseedm.exemplars, "blend_atoms", lambda *a: None)
    path = recover(poses, missing, dictionary=small_dictionary)
    atoms = file_dictionary(small_dictionary, poses[complete_rows(poses, missing)]).dictionary
    ridge = recover(poses[rows], missing[rows], dictionary=atoms, adapt=False,
                    solver=LocalRidgeSolver(**FAST_RIDGE))
    np.testing.assert_allclose(res.poses[rows], (path.poses[rows] + ridge.poses) / 2,
                               rtol=0, atol=1e-6)
    assert np.nanmax(np.abs(res.poses[rows] - path.poses[rows])) > 1e-3  # the ridge differs
    others = np.setdiff1d(np.arange(len(poses)), rows)
    np.testing.assert_array_equal(res.poses[others], path.poses[others])
    np.testing.assert_array_equal(res.status, path.status)
    # the record: which poses, and how far apart the two answers were per joint
    done = rows[res.ok[rows]]
    assert len(done) == 12 and path.averaged is None
    assert (res.averaged[done] == AVERAGED_MANY_HIDDEN).all()
    assert (res.averaged[np.setdiff1d(np.arange(len(poses)), done)] == "").all()
    apart = np.linalg.norm(path.poses[done] - ridge.poses[res.ok[rows]], axis=-1)
    np.testing.assert_allclose(res.spread[done], np.where(missing[done], apart, 0.0),
                               rtol=1e-9, atol=1e-9)
    assert (res.spread[others] == 0).all()
    said = res.summary()
    # counted, with the first few rows named (res.averaged says it per pose)
    assert said["averaged"] == {"with": {AVERAGED_MANY_HIDDEN: {
        "poses": 12, "first_rows": done[:FIRST_ROWS].tolist()}}} and "ensemble" not in said
    assert FIRST_ROWS < 12
    assert "averaged" not in path.summary()


def test_adapted_or_small_files_are_not_blended(cmu_poses, small_dictionary):
    """An adapted dictionary's answers, and files with fewer than BLEND_MIN_POSES
    complete poses, stay as the path gives them."""
    from dataclasses import replace

    from sparseedm.exemplars import BLEND_MIN_POSES, blend_atoms

    poses, missing = _legs_file(cmu_poses)
    res = recover(poses, missing, dictionary=small_dictionary)
    assert blend_atoms(small_dictionary, poses, missing, res.adaptation) is not None
    adapted = replace(res.adaptation, adapted=True)
    assert blend_atoms(small_dictionary, poses, missing, adapted) is None
    few, few_missing = _legs_file(cmu_poses, n_complete=BLEND_MIN_POSES - 10)
    small = recover(few, few_missing, dictionary=small_dictionary)
    assert blend_atoms(small_dictionary, few, few_missing, small.adaptation) is None


@pytest.mark.parametrize("noise", [0.0, 1e-4])
def test_copies_of_one_pose_are_not_blended(cmu_poses, small_dictionary, noise):
    """A file whose BLEND_MIN_POSES or more complete poses are copies of one pose (a
    still person) makes one exemplar atom: the poses of other people with four
    hidden joints keep the path's answer, not its mean with that one pose."""
    from sparseedm.exemplars import BLEND_MIN_POSES, blend_atoms

    still = cmu_poses[0] + np.random.default_rng(0).normal(0, noise, (BLEND_MIN_POSES + 10,
                                                                      14, 2))
    legs = _jittered(cmu_poses[100:], 20)
    hidden = np.zeros((20, 14), bool)
    hidden[:, [9, 10, 12, 13]] = True
    poses = np.concatenate([still, np.where(hidden[..., None], np.nan, legs)])
    missing = np.concatenate([np.zeros(still.shape[:2], bool), hidden])
    res = recover(poses, missing, dictionary=small_dictionary)
    assert blend_atoms(small_dictionary, poses, missing, res.adaptation) is None
    base = recover(poses, missing, dictionary=small_dictionary, adapt=False)

    def err(r):
        return np.linalg.norm(r.poses[len(still):] - legs, axis=-1)[hidden].mean()
    assert err(res) < 1.1 * err(base)


def test_recover_file_blends_as_recover_does(cmu_poses, small_dictionary, tmp_path):
    """recover_file (`sparseedm recover`) averages the same poses with the local
    ridge as recover() does: the same filled poses."""
    from sparseedm.batch import recover_file
    from sparseedm.exemplars import blend_rows
    from sparseedm.keypoints import KeypointSet, read_keypoints, write_keypoints

    poses, missing = _legs_file(cmu_poses)
    keep = ~np.isinf(poses).any(axis=(1, 2))
    poses, missing = poses[keep], missing[keep]
    src = write_keypoints(tmp_path / "in.npz", KeypointSet(poses, missing))
    summary = recover_file(src, tmp_path / "out.npz", dictionary=small_dictionary)
    with np.load(tmp_path / "out.npz") as out:
        filed, averaged, radii = out["poses"], out["averaged"], out["uncertainty"]
    res = recover(poses, missing, dictionary=small_dictionary)
    rows = np.intersect1d(blend_rows(missing), np.flatnonzero(res.ok))  # not the refused
    assert len(rows) == 12
    np.testing.assert_allclose(filed[rows], res.poses[rows], rtol=0, atol=1e-6)
    np.testing.assert_allclose(filed[res.ok], res.poses[res.ok], rtol=0, atol=1e-6)
    # rated as recover() rates the path's answers (not as the members' own)
    np.testing.assert_allclose(radii[res.ok], res.uncertainty[res.ok], rtol=1e-6, atol=1e-6)
    # which poses were averaged reaches the file, its summary and its reader
    np.testing.assert_array_equal(averaged, res.averaged)
    assert all(AVERAGED_MANY_HIDDEN in a for a in averaged[rows])
    want = {k: {"poses": v["poses"]} for k, v in res.summary()["averaged"]["with"].items()}
    assert summary["averaged"]["with"] == want and summary["ensemble"] == 1
    back = read_keypoints(tmp_path / "out.npz")
    np.testing.assert_array_equal(back.meta["npz_extra"]["averaged"], res.averaged)
    recover_file(src, tmp_path / "out.csv", dictionary=small_dictionary)
    column = read_keypoints(tmp_path / "out.csv").meta["extra_columns"]["averaged"]
    np.testing.assert_array_equal(np.asarray(column, str), res.averaged)


def test_every_occluded_pose_gets_the_mean_with_the_ridge_when_the_check_says_so(
        cmu_poses, small_dictionary, monkeypatch):
    """A file whose held-back poses the mean of the path's answer and the local
    ridge's over the base with the file atoms recovered better: every occluded pose
    is that mean, the complete poses and their statuses as the path gives them."""
    import sparseedm.exemplars
    from sparseedm._recovery_base import combine
    from sparseedm._recovery_kernel import FAST_RIDGE
    from sparseedm.file_atoms import complete_rows, with_file_atoms
    from sparseedm.solvers import LocalRidgeSolver

    poses, missing = _file(cmu_poses, 400, seed=1)
    check = choose_exemplars(small_dictionary, poses, missing)
    assert check.err_ridge_mean < check.err_path
    res = recover(poses, missing, dictionary=small_dictionary)
    assert res.adaptation.settings["held_err_ridge_mean"] == check.err_ridge_mean
    monkeypatch.setattr(sparseedm.exemplars, "ridge_mean_atoms", lambda *a: None)
    path = recover(poses, missing, dictionary=small_dictionary)  # without the mean
    occ = np.flatnonzero(missing.any(axis=1))
    complete = poses[complete_rows(poses, missing)]
    ridge = recover(poses[occ], missing[occ], adapt=False, solver=LocalRidgeSolver(**FAST_RIDGE),
                    dictionary=with_file_atoms(small_dictionary, complete).dictionary)
    mean = combine([path.take(occ), ridge])
    np.testing.assert_allclose(res.poses[occ], mean.poses, rtol=0, atol=1e-6)
    assert np.nanmax(np.abs(res.poses[occ] - path.poses[occ])) > 1e-3  # the ridge differs
    done = np.setdiff1d(np.arange(len(poses)), occ)
    np.testing.assert_array_equal(res.poses[done], path.poses[done])
    np.testing.assert_array_equal(res.status[done], path.status[done])
    usable = occ[res.ok[occ]]  # recorded: averaged with the ridge over base + file atoms
    assert all(a.endswith(AVERAGED_RIDGE_MEAN) for a in res.averaged[usable])
    assert (res.averaged[done] == "").all() and (res.spread[done] == 0).all()
    assert res.summary()["averaged"]["with"][AVERAGED_RIDGE_MEAN]["poses"] == len(usable)


def test_the_mean_with_the_ridge_follows_the_checks_errors(cmu_poses, small_dictionary):
    """ridge_mean_atoms answers the base with the file atoms only when the check's
    held-back error of the mean is below the path's; never for an adapted
    dictionary or without a check."""
    from dataclasses import replace

    from sparseedm.exemplars import ridge_mean_atoms
    from sparseedm.file_atoms import complete_rows

    poses, missing = _file(cmu_poses, 400, seed=1)
    res = recover(poses, missing, dictionary=small_dictionary)
    found = res.adaptation
    err = found.settings["held_err_path"]
    lower = replace(found, settings=dict(found.settings, held_err_ridge_mean=err - 0.01))
    higher = replace(found, settings=dict(found.settings, held_err_ridge_mean=err + 0.01))
    unchecked = replace(found, settings={k: v for k, v in found.settings.items()
                                         if not k.startswith("held_err")})
    atoms = ridge_mean_atoms(small_dictionary, poses, missing, lower)
    assert atoms.n_components == (small_dictionary.n_components
                                  + int(complete_rows(poses, missing).sum()))
    assert ridge_mean_atoms(small_dictionary, poses, missing, higher) is None
    assert ridge_mean_atoms(small_dictionary, poses, missing, unchecked) is None
    assert ridge_mean_atoms(small_dictionary, poses, missing,
                            replace(lower, adapted=True)) is None


def test_a_still_persons_near_copies_count_as_the_one_atom_they_make(cmu_poses,
                                                                      small_dictionary):
    """A file of one still person's frames (a detector's sub-pixel noise: distinct
    beyond REPEAT_TOLERANCE, within ATOM_SPACING of one another) and other people:
    the rule that codes over the file's poses alone, unchecked, from `min_poses`
    on counts the atoms file_dictionary makes of them (the copies merged into
    one), so the file is checked on held-back poses instead."""
    from sparseedm.adaptation import pose_vectors, repeat_rows
    from sparseedm.file_atoms import file_dictionary

    rng = np.random.default_rng(0)
    extent = np.ptp(cmu_poses[0], axis=0).max()
    still = cmu_poses[0] + rng.normal(0, 5e-4 * extent, size=(300, 14, 2))
    poses = np.concatenate([still, cmu_poses[1:]])
    missing = np.zeros(poses.shape[:2], bool)
    missing[300::3, 7] = True
    complete = poses[~missing.any(axis=1)]
    distinct = len(complete) - repeat_rows(pose_vectors(complete)).sum()
    atoms = file_dictionary(small_dictionary, complete).n_atoms
    min_poses = (distinct + atoms) // 2
    assert atoms < min_poses <= distinct  # the two counts fall either side of the rule
    check = choose_exemplars(small_dictionary, poses, missing, min_poses=min_poses)
    assert np.isfinite(check.err_base)  # checked, not taken unchecked
    if check.result is not None:
        assert f"{atoms} atoms once near-copies are merged" in check.result.reason


def test_the_probes_gain_is_judged_by_pose_not_by_probe():
    """Several probes of one pose are not independent: paired_gain averages each
    pose's first, the mean and standard error then over the poses. Three poses
    with per-pose gains 2, -1.5 and 0.4, each probed ten times alike: over the 30
    probes the mean 0.3 exceeds its standard error (0.27), over the three poses
    it does not (1.01), and a weight is then not taken (LINEAR_MIN_SE)."""
    from sparseedm.exemplars import LINEAR_MIN_SE, paired_gain

    per_pose = np.array([2.0, -1.5, 0.4])
    gain = np.repeat(per_pose, 10)
    rows = np.repeat([4, 9, 17], 10)
    naive_mean, naive_se = paired_gain(gain)
    mean, se = paired_gain(gain, clusters=rows)
    assert mean == pytest.approx(0.3) and naive_mean == pytest.approx(0.3)
    assert se == pytest.approx(np.sqrt(6.14 / 2 / 3))  # sd of (2, -1.5, 0.4) / sqrt(3)
    assert naive_se == pytest.approx(np.sqrt(10 * 6.14 / 29 / 30))
    assert naive_mean > LINEAR_MIN_SE * naive_se and not mean > LINEAR_MIN_SE * se
    # poses probed unequally count once each: the mean of their means
    mean, se = paired_gain([2.0, 2.0, 2.0, 0.0, 1.0], clusters=[5, 5, 5, 7, 9])
    assert mean == pytest.approx(1.0) and se == pytest.approx(1 / np.sqrt(3))
    assert np.isnan(paired_gain([1.0, 2.0], clusters=[3, 3])[1])  # one pose: no error
