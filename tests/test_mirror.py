"""recover(mirror=True): each pose and its mirror image coded, the answers averaged."""

import numpy as np
import pytest

import sparseedm
from sparseedm.dictionary import Dictionary, load_dictionary
from sparseedm.exceptions import DictionaryError, ParameterError
from sparseedm.skeleton import SKELETON_14

FLIP = SKELETON_14.flip_permutation()
POSE = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78], [65, 32], [70, 55],
                 [72, 78], [40, 80], [40, 115], [40, 150], [60, 80], [60, 115], [60, 150]],
                float)


def mirror(poses):
    """Left and right joints swapped, x negated."""
    out = np.asarray(poses, float)[:, FLIP].copy()
    out[..., 0] *= -1
    return out


def occluded(n=40, seed=0):
    rng = np.random.default_rng(seed)
    poses = POSE + rng.normal(0, 6, (n, 14, 2))
    missing = np.zeros((n, 14), bool)
    for row in missing:
        row[rng.choice(14, 3, replace=False)] = True
    return np.where(missing[..., None], np.nan, poses), missing


def test_a_mirrored_dictionary_codes_a_pose_as_the_original_codes_its_mirror_image():
    d = load_dictionary()
    given, _ = occluded()
    over_mirrored = sparseedm.recover(given, adapt=False, dictionary=d.mirrored()).poses
    of_mirror_image = mirror(sparseedm.recover(mirror(given), adapt=False, dictionary=d).poses)
    assert np.allclose(over_mirrored, of_mirror_image, atol=1e-6)
    assert not np.allclose(over_mirrored, sparseedm.recover(given, adapt=False, dictionary=d).poses)
    assert np.array_equal(d.mirrored().mirrored().components, d.components)


def test_mirror_averages_the_two_answers_and_keeps_the_observed_joints():
    given, missing = occluded()
    d = load_dictionary()
    one = sparseedm.recover(given, adapt=False, dictionary=d).poses
    other = mirror(sparseedm.recover(mirror(given), adapt=False, dictionary=d).poses)
    res = sparseedm.recover(given, adapt=False, dictionary=d, mirror=True)
    assert np.allclose(res.poses, (one + other) / 2, atol=1e-6)
    assert np.array_equal(res.poses[~missing], given[~missing])
    assert (res.status == "recovered").all() and np.isfinite(res.uncertainty[missing]).all()


def test_mirror_is_refused_where_it_would_be_ignored_or_has_no_meaning():
    given, _ = occluded(6)
    with pytest.raises(ParameterError, match="mirror"):
        sparseedm.recover(given, mirror=True, frames=np.arange(6))
    with pytest.raises(ParameterError, match="mirror='auto' averages"):  # the value given
        sparseedm.recover(given, mirror="auto", frames=np.arange(6))
    with pytest.raises(ParameterError, match="mirror"):
        sparseedm.recover(given, mirror="yes")
    three = Dictionary(np.eye(3), ("a", "b", "c"), alpha_recover=0.1)
    with pytest.raises(DictionaryError, match="14-joint layout"):
        three.mirrored()


def test_mirror_lowers_the_cold_error_on_validation_photos(shared_data):
    """MPII validation poses under transplanted real masks (the hidden joints
    chosen as in studies/real_prior/harness.py), the real-people prior without
    adaptation: averaging with the mirror image's answer is closer to the
    annotations."""
    pytest.importorskip("h5py", reason="needs the [real] extra (h5py)")
    from benchmarks import real2d

    if not real2d.available(shared_data / "real2d"):
        pytest.skip(f"no {shared_data / 'real2d'}")
    rs = real2d.load("mpii", shared_data / "real2d")
    val = rs.take(real2d.split(rs) == "val")
    rng = np.random.default_rng(0)
    truth = val.poses[val.complete][:150]
    hidden = ~val.visible
    pool = hidden[hidden.any(axis=1) & ((~hidden).sum(axis=1) >= 3)]
    missing = pool[rng.integers(len(pool), size=len(truth))]
    given = np.where(missing[..., None], np.nan, truth)
    size = real2d.body_size(truth)[:, None]

    def error(res):
        return (np.linalg.norm(res.poses - truth, axis=-1) / size)[missing].mean()

    prior = load_dictionary("cmu-coco-k2932")
    plain = error(sparseedm.recover(given, adapt=False, dictionary=prior))
    mirrored = error(sparseedm.recover(given, adapt=False, dictionary=prior, mirror=True))
    auto = error(sparseedm.recover(given, adapt=False, dictionary=prior, mirror="auto"))
    assert mirrored < plain and auto < plain


def test_the_command_line_mirrors_with_no_adapt(tmp_path, capsys):
    from sparseedm.cli import main
    from sparseedm.keypoints import read_keypoints, write_keypoints

    given, missing = occluded(12)
    src = tmp_path / "in.npz"
    write_keypoints(src, given)
    assert main(["recover", str(src), "-o", str(tmp_path / "out.npz"), "--no-adapt",
                 "--mirror"]) == 0
    assert "mirror:" in capsys.readouterr().out
    out = read_keypoints(tmp_path / "out.npz").poses
    assert np.allclose(out, sparseedm.recover(given, adapt=False, mirror=True).poses, atol=1e-6)


def test_the_estimator_passes_mirror_on():
    from sparseedm.recovery import OcclusionRecoverer

    given, _ = occluded(10)
    est = OcclusionRecoverer(adapt=False, mirror=True).fit()
    assert np.allclose(est.transform(given),
                       sparseedm.recover(given, adapt=False, mirror=True).poses, atol=1e-9)
    with pytest.raises(ParameterError, match="mirror"):
        OcclusionRecoverer(mirror=1).fit()


def test_mirror_auto_weighs_the_two_answers_by_their_objectives():
    from sparseedm._recovery_base import MIRROR_TEMPERATURE, mirror_weights

    given, missing = occluded()
    d = load_dictionary()
    own = sparseedm.recover(given, adapt=False, dictionary=d)
    other = sparseedm.recover(given, adapt=False, dictionary=d.mirrored())
    w = mirror_weights([own, other])
    r = other.objective / own.objective - 1
    expected = np.minimum(0.5, 1 / (1 + np.exp(r / MIRROR_TEMPERATURE)))
    assert np.allclose(w[1], expected) and np.allclose(w.sum(axis=0), 1)
    res = sparseedm.recover(given, adapt=False, dictionary=d, mirror="auto")
    assert np.allclose(res.poses, w[0][:, None, None] * own.poses
                       + w[1][:, None, None] * other.poses, atol=1e-6)
    assert np.array_equal(res.poses[~missing], given[~missing])
    assert (w[1] < 0.5).any() and (w[1] > 0).all()


def test_mirror_auto_keeps_the_own_answer_on_poses_the_dictionary_learned_from(cmu_poses):
    """The CMU fixture poses are among the default dictionary's training poses:
    their mirror images fit it worse, and the always-on mean is worse than the
    pose's own answer; the objective gate gives the mirror little weight."""
    truth = np.asarray(cmu_poses[:120], float)
    rng = np.random.default_rng(0)
    missing = np.zeros((len(truth), 14), bool)
    for row in missing:
        row[rng.choice(14, 2, replace=False)] = True
    given = np.where(missing[..., None], np.nan, truth)

    def error(**kw):
        res = sparseedm.recover(given, missing, adapt=False, dictionary="default", **kw)
        return np.linalg.norm(res.poses - truth, axis=-1)[missing].mean()

    plain, mean, auto = error(), error(mirror=True), error(mirror="auto")
    assert plain < mean and auto < mean
    assert abs(auto - plain) < (mean - plain) / 3


def test_the_command_line_passes_mirror_auto(tmp_path, capsys):
    from sparseedm.cli import main
    from sparseedm.keypoints import read_keypoints, write_keypoints

    given, _ = occluded(12)
    src = tmp_path / "in.npz"
    write_keypoints(src, given)
    assert main(["recover", str(src), "-o", str(tmp_path / "out.npz"), "--no-adapt",
                 "--mirror-auto"]) == 0
    assert "by their lasso objectives" in capsys.readouterr().out
    out = read_keypoints(tmp_path / "out.npz").poses
    assert np.allclose(out, sparseedm.recover(given, adapt=False, mirror="auto").poses,
                       atol=1e-6)
    with pytest.raises(ParameterError, match="mirror"):
        sparseedm.recover(given, mirror="on")


def test_the_photo_protocol_runs_the_gated_mirror():
    from sparseedm.evaluation_real import evaluate_photos

    rng = np.random.default_rng(1)
    poses = POSE + rng.normal(0, 6, (60, 14, 2))
    methods = ["sparseedm-no-adapt-mirror", "sparseedm-no-adapt-mirror-auto"]
    rep = evaluate_photos(poses, conditions=[2], methods=methods)
    means = {r["method"]: r["mean"] for r in rep.rows if r["group"] == "overall"}
    assert set(means) == set(methods) and all(np.isfinite(list(means.values())))


def test_adapt_false_without_a_dictionary_codes_over_the_cold_prior_with_the_gate():
    """No dictionary and adapt=False: cmu-coco-k2932 with mirror="auto" (an
    explicit mirror or dictionary is kept); adapting, and in time, the default."""
    from sparseedm.cold_bank import cold_bank_stack

    given, missing = occluded(12)
    cold = sparseedm.recover(given, adapt=False)
    union = sparseedm.recover(given, adapt=False, dictionary="cmu-coco-k2932", mirror="auto")
    # the codes stacked with the shipped pose bank's answer (tests/test_cold_bank.py)
    assert np.array_equal(cold.poses, cold_bank_stack(union, given, missing).poses)
    assert np.array_equal(sparseedm.recover(given, adapt=None).poses, cold.poses)
    default = sparseedm.recover(given, adapt=False, dictionary="default")
    assert not np.allclose(cold.poses[missing], default.poses[missing])
    plain = sparseedm.recover(given, adapt=False, mirror=False)
    assert np.array_equal(plain.poses, cold_bank_stack(sparseedm.recover(
        given, adapt=False, dictionary="cmu-coco-k2932"), given, missing).poses)
    assert not np.allclose(plain.poses[missing], cold.poses[missing])
    frames = np.arange(len(given))
    in_time = sparseedm.recover(given, adapt=False, frames=frames)
    assert np.array_equal(in_time.poses, sparseedm.recover(
        given, adapt=False, frames=frames, dictionary="default").poses)


def test_the_file_and_the_estimator_take_the_same_cold_prior(tmp_path):
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import read_keypoints, write_keypoints
    from sparseedm.recovery import OcclusionRecoverer

    given, _ = occluded(12)
    src = tmp_path / "in.npz"
    write_keypoints(src, given)
    summary = recover_file(src, tmp_path / "out.npz", adapt=False)
    assert summary["mirror"] == "auto"
    cold = sparseedm.recover(given, adapt=False).poses
    assert np.allclose(read_keypoints(tmp_path / "out.npz").poses, cold, atol=1e-6)
    assert recover_file(src, tmp_path / "o2.npz", adapt=False, dictionary="default")[
        "mirror"] is False
    est = OcclusionRecoverer(adapt=False).fit()
    assert est.dictionary_.n_components == 2932 and est.mirror_ == "auto"
    assert np.allclose(est.transform(given), cold, atol=1e-9)
    est = OcclusionRecoverer().fit()
    assert est.dictionary_.n_components == 2000 and est.mirror_ is False
