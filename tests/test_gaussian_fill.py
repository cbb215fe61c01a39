"""sparseedm.gaussian_fill: the conditional mean of hidden joints under one Gaussian
of a file's poses, or per pose of its nearest draws; and the default path's stacked
mean of its answer with it (sparseedm.exemplars.linear_weight / linear_stack)."""

import numpy as np
import pytest

from sparseedm.exemplars import LINEAR_WEIGHTS, linear_weight
from sparseedm.gaussian_fill import (conditional_mean, file_gaussian, gaussian_fill,
                                     local_gaussian_fill)


def _template_file(n, seed=0, sd=0.0):
    """n poses: one template, each scaled, shifted and deformed along one fixed
    direction (a linear family), with `sd` pixels of noise."""
    rng = np.random.default_rng(seed)
    template = rng.normal(0, 30, (14, 2))
    direction = rng.normal(0, 10, (14, 2))
    a = rng.normal(size=(n, 1, 1))
    scale = rng.uniform(0.5, 2, (n, 1, 1))
    shift = rng.uniform(-100, 100, (n, 1, 2))
    return (template + a * direction) * scale + shift + rng.normal(0, sd, (n, 14, 2)) if sd \
        else (template + a * direction) * scale + shift


def test_conditional_mean_is_the_textbook_formula():
    """Without a ridge: mu_h - P_hh^-1 P_ho (x_o - mu_o), P the precision matrix (the
    Schur complement form, computed independently)."""
    rng = np.random.default_rng(3)
    train = rng.normal(size=(200, 5)) @ rng.normal(size=(5, 5))
    query = rng.normal(size=(4, 5))
    observed = np.array([True, False, True, True, False])
    got = conditional_mean(train, query, observed, ridge=0.0)
    mu, prec = train.mean(axis=0), np.linalg.inv(np.cov(train, rowvar=False))
    h, o = ~observed, observed
    want = mu[h] - (query[:, o] - mu[o]) @ np.linalg.solve(prec[np.ix_(h, h)],
                                                           prec[np.ix_(h, o)]).T
    np.testing.assert_allclose(got[:, h], want, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(got[:, o], query[:, o])


def test_the_ridge_shrinks_towards_the_mean():
    """A large ridge moves the hidden column to (nearly) its mean."""
    rng = np.random.default_rng(4)
    x = rng.normal(size=(300, 1))
    train = np.hstack([x, 3 * x])
    q = np.array([[2.0, 0.0]])
    free = conditional_mean(train, q, np.array([True, False]), ridge=0.0)[0, 1]
    shrunk = conditional_mean(train, q, np.array([True, False]), ridge=1e6)[0, 1]
    assert free == pytest.approx(6.0)
    assert abs(shrunk - train[:, 1].mean()) < 1e-3


def test_gaussian_fill_is_exact_on_a_linear_family_in_the_pose_frame():
    """Poses of one template scaled, shifted and deformed along one direction: in
    the frame of any observed joints the family is nearly linear, and the hidden
    joints come back to a small fraction of the pose's size; observed ones as given."""
    poses = _template_file(401)
    train, query = poses[:400], poses[400:].repeat(3, axis=0)
    missing = np.zeros((3, 14), bool)
    missing[0, 4] = missing[1, [9, 10]] = missing[2, [0, 7, 13]] = True
    got = gaussian_fill(train, np.where(missing[..., None], np.nan, query), missing, ridge=1e-9)
    size = np.sqrt(((query - query.mean(axis=1, keepdims=True)) ** 2).sum(-1).mean(-1))
    err = np.linalg.norm(got - query, axis=-1) / size[:, None]
    assert err[missing].max() < 0.02
    np.testing.assert_array_equal(got[~missing], query[~missing])


def test_a_pose_without_a_frame_is_left_nan():
    """One observed joint: no spread to set the frame, so no answer."""
    poses = _template_file(50)
    missing = np.ones((1, 14), bool)
    missing[0, 0] = False
    got = gaussian_fill(poses, poses[:1], missing)
    assert np.isnan(got[0, 1:]).all()


def test_file_gaussian_refits_on_the_incomplete_poses():
    """The refitted Gaussian's draws are the complete poses and the filled ones;
    with no rounds, the complete poses alone."""
    poses = _template_file(120, sd=1.0)
    missing = np.zeros((20, 14), bool)
    missing[:, 3] = True
    filled, train = file_gaussian(poses[:100], poses[100:], missing)
    assert len(train) == 120
    np.testing.assert_array_equal(train[:100], poses[:100])
    np.testing.assert_array_equal(train[100:, :3], poses[100:, :3])  # observed as given
    assert np.isfinite(train).all()
    _, alone = file_gaussian(poses[:100], poses[100:], missing, rounds=0)
    assert len(alone) == 100
    np.testing.assert_array_equal(filled[:, :3], poses[100:, :3])


def test_local_gaussian_of_every_draw_without_prior_is_the_one_gaussian():
    """With every draw as the neighbours and no prior, the pose's Gaussian is the
    file's (its scatter's scale cancels in the regression): gaussian_fill's answer."""
    poses = _template_file(150, seed=5, sd=2.0)
    train, query = poses[:120], poses[120:]
    missing = np.zeros((30, 14), bool)
    missing[np.arange(30), np.arange(30) % 14] = True
    missing[np.arange(0, 30, 3), 13 - np.arange(0, 30, 3) % 14] = True
    given = np.where(missing[..., None], np.nan, query)
    want = gaussian_fill(train, given, missing, ridge=0.0)
    got = local_gaussian_fill(train, given, missing, neighbours=len(train), prior=0, ridge=0.0)
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-7)


def test_local_gaussian_follows_a_curved_family():
    """Poses deformed along a curve: every joint moves with a, the first also with a²
    (a parabola). Hidden, it is linear in the observed joints only near each pose:
    one Gaussian of the file fits a straight line, the neighbours' Gaussian the
    curve there, so the joint comes back closer."""
    rng = np.random.default_rng(6)
    template, u = rng.normal(0, 30, (2, 14, 2))
    v = np.zeros((14, 2))
    v[0] = [0.0, 20.0]
    a = rng.uniform(-2, 2, (600, 1, 1))
    poses = template + a * u + a * a * v + rng.normal(0, 0.2, (600, 14, 2))
    train, query = poses[:500], poses[500:]
    missing = np.zeros((len(query), 14), bool)
    missing[:, 0] = True
    given = np.where(missing[..., None], np.nan, query)

    def err(filled):
        return np.linalg.norm(filled - query, axis=-1)[missing].mean()

    one = err(gaussian_fill(train, given, missing))
    local = err(local_gaussian_fill(train, given, missing, neighbours=50, prior=5))
    assert local < 0.5 * one


def test_local_gaussian_leaves_the_pose_itself_out():
    """A draw that matches the pose on its observed joints (the pose as filled,
    among the file's draws) is not its own neighbour: with no prior (the Gaussian of
    every draw, which holds it), whatever its hidden joint holds, the answer is the
    same."""
    poses = _template_file(200, seed=8, sd=1.0)
    missing = np.zeros((1, 14), bool)
    missing[0, 6] = True
    given = np.where(missing[..., None], np.nan, poses[:1])
    answers = []
    for value in (0.0, 1e4):
        itself = poses[:1].copy()
        itself[0, 6] = value
        answers.append(local_gaussian_fill(np.concatenate([poses[1:], itself]), given, missing,
                                           neighbours=60, prior=0))
    np.testing.assert_array_equal(answers[0], answers[1])
    assert np.isfinite(answers[0]).all()


def _frame_of(poses, observed):
    """poses shifted to their observed joints' centroid and divided by their RMS radius."""
    centre = poses[:, observed].mean(axis=1, keepdims=True)
    radius = np.sqrt(((poses[:, observed] - centre) ** 2).sum(axis=-1).mean(axis=1))
    return (poses - centre) / radius[:, None, None], centre, radius


def test_local_gaussian_chooses_its_neighbours_again_on_the_filled_pose():
    """By hand, one pose: the 60 draws nearest on the observed joints (in their
    frame) fill it; the 60 nearest on the whole filled pose, the hidden joints'
    squared distances weighted 0.5, fill it again: the default's answer, which is
    not the first fill."""
    rng = np.random.default_rng(9)
    template, u = rng.normal(0, 30, (2, 14, 2))
    v = rng.normal(0, 15, (14, 2))
    a = rng.uniform(-2, 2, (400, 1, 1))
    train = template + a * u + np.sin(2 * a) * v + rng.normal(0, 3, (400, 14, 2))
    pose = template + 0.7 * u + np.sin(1.4) * v
    observed = np.ones(14, bool)
    observed[[2, 9]] = False
    z, _, _ = _frame_of(train, observed)
    zq, centre, radius = _frame_of(pose[None], observed)
    flat, q, cols = z.reshape(400, -1), zq.reshape(1, -1), np.repeat(observed, 2)

    def fill(distance):
        near = np.argsort(distance)[:60]
        return conditional_mean(flat[near], q, cols, ridge=0.0)

    first = fill(((flat - q)[:, cols] ** 2).sum(axis=1))
    weights = np.where(cols, 1.0, 0.5)
    again = fill((weights * (flat - first) ** 2).sum(axis=1))
    missing = ~observed[None]
    got = local_gaussian_fill(train, pose[None], missing, neighbours=60, prior=0)
    once = local_gaussian_fill(train, pose[None], missing, neighbours=60, prior=0, reselect=0)
    np.testing.assert_allclose(got, again.reshape(1, 14, 2) * radius + centre, atol=1e-6)
    np.testing.assert_allclose(once, first.reshape(1, 14, 2) * radius + centre, atol=1e-6)
    assert np.abs(got - once).max() > 1e-3


def test_local_gaussian_of_a_rotated_file_is_rotated():
    """Draws and poses turned in the image together: the fills turn with them (the
    frame and both choices of neighbours are by distances, which turning keeps)."""
    poses = _template_file(300, seed=10, sd=4.0)
    missing = np.zeros((40, 14), bool)
    missing[np.arange(40), np.arange(40) % 14] = True
    missing[np.arange(0, 40, 2), (np.arange(0, 40, 2) + 5) % 14] = True
    given = np.where(missing[..., None], np.nan, poses[260:])
    angle = 0.9
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    plain = local_gaussian_fill(poses[:260], given, missing, neighbours=50)
    turned = local_gaussian_fill(poses[:260] @ turn.T, given @ turn.T, missing, neighbours=50)
    np.testing.assert_allclose(turned, plain @ turn.T, atol=1e-6)


def test_file_gaussian_fits_the_augmented_draws():
    """`augment` shapes the Gaussian, not the returned draws: each draw twice is the
    same Gaussian (same answer); the draws with a shifted copy of each are another."""
    poses = _template_file(140, seed=9, sd=1.0)
    missing = np.zeros((40, 14), bool)
    missing[np.arange(40), np.arange(40) % 14] = True
    given = np.where(missing[..., None], np.nan, poses[100:])
    plain, train = file_gaussian(poses[:100], given, missing)
    twice, train2 = file_gaussian(poses[:100], given, missing,
                                  augment=lambda d: np.concatenate([d, d]))
    np.testing.assert_allclose(twice, plain, rtol=1e-6, atol=1e-6)
    assert train2.shape == train.shape
    bent, _ = file_gaussian(poses[:100], given, missing,
                            augment=lambda d: np.concatenate([d, d[:, ::-1]]))
    assert np.abs(bent - plain)[missing].max() > 1.0


def _answer(truth, mask):
    """A RecoveryResult of `truth` under `mask` (its poses replaced by the caller)."""
    from sparseedm import recover

    return recover(np.where(mask[..., None], np.nan, truth), mask, adapt=False)


def test_linear_weight_goes_to_the_exact_candidate():
    """Held-back poses of a linear family: an answer off by 20 px at every hidden joint
    gets weight 1 on the Gaussian (exact there); an exact answer gets weight 0."""
    from dataclasses import replace

    poses = _template_file(300)
    truth, rest = poses[:40], poses[40:]
    mask = np.zeros((40, 14), bool)
    mask[np.arange(40), np.arange(40) % 14] = True
    answer = _answer(truth, mask)
    off = replace(answer, poses=np.where(mask[..., None], truth + 20.0, truth))
    exact = replace(answer, poses=truth.copy())
    file_poses = np.where(mask[..., None], np.nan, truth)
    w_off, e_off = linear_weight(off, truth, mask, rest, file_poses, mask)
    w_exact, e_exact = linear_weight(exact, truth, mask, rest, file_poses, mask)
    assert w_off == LINEAR_WEIGHTS[-1] and w_exact == 0.0
    assert e_exact == 0.0 and e_off < 1.0


def _stack_file(n_complete=400, n_occluded=60, seed=2):
    """A linear-family file: complete poses, then poses with 1-3 joints hidden."""
    from sparseedm.adaptation import guard_masks

    poses = _template_file(n_complete + n_occluded, seed=seed, sd=0.5)
    missing = np.zeros(poses.shape[:2], bool)
    missing[n_complete:] = guard_masks(n_occluded, 14, random_state=seed)
    return np.where(missing[..., None], np.nan, poses), missing, poses


@pytest.mark.usefixtures("without_donor_step")
def test_recover_stacks_the_gaussian_at_the_checks_weight(small_dictionary, monkeypatch):
    """On a file the Gaussian nearly fits, the check gives it weight; every occluded
    pose is then (1 - w) * the path's answer + w * the Gaussian's, which errs less
    than the path alone; the complete poses as the path gives them."""
    import sparseedm.exemplars
    from sparseedm import recover
    from sparseedm.exemplars import linear_stack

    given, missing, truth = _stack_file()
    res = recover(given, missing, dictionary=small_dictionary)
    w = res.adaptation.settings["linear_weight"]
    assert w in LINEAR_WEIGHTS and w > 0
    stack = linear_stack(small_dictionary, given, missing, res.adaptation)
    # its draws: the file's poses as filled, then their mirror images
    from sparseedm.file_atoms import mirror_images
    half = len(stack.train) // 2
    np.testing.assert_array_equal(stack.train, mirror_images(stack.train[:half]))
    np.testing.assert_array_equal(stack.train[:400], truth[:400])
    monkeypatch.setattr(sparseedm.exemplars, "linear_stack", lambda *a: None)
    path = recover(given, missing, dictionary=small_dictionary)
    occ = np.flatnonzero(missing.any(axis=1) & res.ok)
    fill = local_gaussian_fill(stack.train, given[occ], missing[occ])
    np.testing.assert_allclose(res.poses[occ], (1 - w) * path.poses[occ] + w * fill,
                               rtol=0, atol=1e-6)
    done = ~missing.any(axis=1)
    np.testing.assert_array_equal(res.poses[done], path.poses[done])

    def err(p):
        return np.linalg.norm(p - truth[occ], axis=-1)[missing[occ]].mean()

    assert err(res.poses[occ]) < err(path.poses[occ])
    # what was done is said: every stacked pose names the Gaussian, the
    # spread is the two answers' distance at its filled joints
    from sparseedm.exemplars import AVERAGED_GAUSSIAN
    assert all(AVERAGED_GAUSSIAN in a for a in res.averaged[occ])
    gap = np.linalg.norm(path.poses[occ] - fill, axis=-1)
    np.testing.assert_allclose(res.spread[occ][missing[occ]],
                               np.maximum(gap, 0)[missing[occ]], rtol=1e-6, atol=1e-6)
    said = res.summary()["averaged"]["with"]
    assert sum(v["poses"] for k, v in said.items() if AVERAGED_GAUSSIAN in k) == len(occ)


@pytest.mark.usefixtures("without_donor_step")
def test_recover_file_stacks_as_recover_does(small_dictionary, tmp_path):
    """recover_file (`sparseedm recover`) gives the same filled poses as recover()
    on a file it reads whole."""
    from sparseedm import recover
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import KeypointSet, write_keypoints

    given, missing, _ = _stack_file()
    src = write_keypoints(tmp_path / "in.npz", KeypointSet(given, missing))
    recover_file(src, tmp_path / "out.npz", dictionary=small_dictionary)
    with np.load(tmp_path / "out.npz") as out:
        filed = out["poses"]
    res = recover(given, missing, dictionary=small_dictionary)
    assert res.adaptation.settings["linear_weight"] > 0
    np.testing.assert_allclose(filed[res.ok], res.poses[res.ok], rtol=0, atol=1e-6)


@pytest.mark.usefixtures("without_donor_step")
def test_too_few_complete_poses_take_the_weight_from_probes(small_dictionary, tmp_path,
                                                            monkeypatch):
    """Below FEW_MIN_POSES complete poses no check runs; probes of the occluded rows
    give the Gaussian (nearly exact on this file) weight, and the occluded poses'
    answers, so stacked, err less than the path's alone; recover_file stacks as
    recover() does; the complete poses as the path gives them."""
    import sparseedm.batch
    import sparseedm.recovery
    from sparseedm import recover
    from sparseedm.batch import recover_file
    from sparseedm.exemplars import AVERAGED_GAUSSIAN, FEW_MIN_POSES
    from sparseedm.keypoints import KeypointSet, write_keypoints

    given, missing, truth = _stack_file(n_complete=FEW_MIN_POSES - 20, n_occluded=200)
    res = recover(given, missing, dictionary=small_dictionary)
    settings = res.adaptation.settings
    assert settings["linear_weight"] in LINEAR_WEIGHTS and settings["linear_weight"] > 0
    assert settings["linear_probes"] >= 30
    src = write_keypoints(tmp_path / "in.npz", KeypointSet(given, missing))
    recover_file(src, tmp_path / "out.npz", dictionary=small_dictionary)
    with np.load(tmp_path / "out.npz") as out:
        filed = out["poses"]
    np.testing.assert_allclose(filed[res.ok], res.poses[res.ok], rtol=0, atol=1e-6)
    monkeypatch.setattr(sparseedm.exemplars, "probe_stack",
                        lambda res, p, m, a, blend: (res, blend))
    path = recover(given, missing, dictionary=small_dictionary)
    assert "linear_weight" not in path.adaptation.settings
    occ = np.flatnonzero(missing.any(axis=1) & res.ok)
    assert all(AVERAGED_GAUSSIAN in a for a in res.averaged[occ])

    def err(p):
        return np.linalg.norm(p - truth[occ], axis=-1)[missing[occ]].mean()

    assert err(res.poses[occ]) < err(path.poses[occ])
    done = ~missing.any(axis=1)
    np.testing.assert_array_equal(res.poses[done], path.poses[done])


@pytest.mark.usefixtures("without_donor_step")
def test_probe_weight_clusters_the_gain_by_probed_pose(small_dictionary, monkeypatch):
    """probe_stack's rounds probe a pose again (another joint): its gain's standard
    error is taken with each probe's row as its cluster."""
    import sparseedm.exemplars
    from sparseedm import recover
    from sparseedm.exemplars import FEW_MIN_POSES

    seen = []
    real = sparseedm.exemplars.paired_gain

    def spy(gain, clusters=None):
        seen.append((len(gain), clusters))
        return real(gain, clusters)

    monkeypatch.setattr(sparseedm.exemplars, "paired_gain", spy)
    given, missing, _ = _stack_file(n_complete=FEW_MIN_POSES - 20, n_occluded=200)
    res = recover(given, missing, dictionary=small_dictionary)
    n_probes = res.adaptation.settings["linear_probes"]
    assert len(seen) == 1
    n, clusters = seen[0]
    assert clusters is not None and n == len(clusters) == n_probes  # every probe scored
    assert len(np.unique(clusters)) < n  # a pose probed in two rounds: one cluster
    assert missing[np.asarray(clusters)].any(axis=1).all()  # the clusters are occluded rows
