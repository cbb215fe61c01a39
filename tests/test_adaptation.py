"""sparseedm.adaptation: warm-started dictionary adaptation, its guard and filters,
recover(adapt=...), recover_file / `sparseedm recover` adaptation, `fit --init`."""

import json

import numpy as np
import pytest

import sparseedm
from sparseedm.adaptation import (MIN_COMPLETE_POSES, adapt_vectors,
                                  duplicate_rows, filter_poses, holdout_blocks, masked_error,
                                  pose_vectors as _vectors, run_adaptation, sample_complete,
                                  swapped_rows)
from sparseedm.batch import recover_file
from sparseedm.cli import main
from sparseedm.dictionary import Dictionary, load_dictionary
from sparseedm.file_atoms import with_file_atoms
from sparseedm.keypoints import COCO_KEYPOINTS, read_keypoints, write_keypoints
from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors
from sparseedm.metrics import random_occlusion
from sparseedm.recovery import _recover
from sparseedm.skeleton import JOINT_NAMES


def _stretch(poses, fx=1.7):
    """The same motion under another 'rig': x stretched about each pose's centre."""
    c = poses.mean(axis=1, keepdims=True)
    out = poses.copy()
    out[..., 0] = c[..., 0] + fx * (poses[..., 0] - c[..., 0])
    return out


@pytest.fixture(scope="module")
def shifted_dictionary(cmu_poses):
    """k=100 atoms learned on x-stretched fixture poses: the wrong domain for the real ones."""
    X, _ = complete_pose_vectors(_stretch(cmu_poses))
    odl = OnlineDictionaryLearning(100, alpha=0.05, batch_size=64, n_passes=2,
                                   random_state=0).fit(X)
    return Dictionary(odl.components_, alpha_recover=0.002, alpha_train=0.05)


def _jittered(poses, n, seed=0, sd=0.5):
    """n poses drawn from `poses` with a little pixel noise (no exact repeats)."""
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, len(poses), n)
    return poses[np.sort(pick)] + rng.normal(0, sd, (n,) + poses.shape[1:])


def test_adaptation_lowers_masked_error_on_held_back_poses(cmu_poses, shifted_dictionary):
    held_back = np.random.default_rng(0).permutation(len(cmu_poses)) >= 250
    train, held = cmu_poses[~held_back], cmu_poses[held_back]
    before = masked_error(shifted_dictionary, held)
    res = run_adaptation(shifted_dictionary, train, min_poses=50, guard=False)
    after = masked_error(res.dictionary, held)
    assert res.adapted and res.n_used == 250
    assert after < 0.92 * before, (before, after)


def test_guard_accepts_a_better_dictionary(cmu_poses, shifted_dictionary):
    res = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50)
    assert res.adapted and res.err_adapted < res.err_base
    assert res.n_validation > 0 and res.n_used + res.n_validation <= len(cmu_poses)
    assert res.dictionary is res.candidate
    assert "adapted the dictionary" in res.line()


def test_guard_keeps_the_base_when_the_adapted_one_is_worse(cmu_poses, small_dictionary):
    # the rows the guard holds back are real poses (the base's domain); the
    # rows it adapts on are stretched ones: the adapted atoms are worse there
    n = len(cmu_poses)
    held = holdout_blocks(n, 0.2, random_state=0)
    poses = np.where(held[:, None, None], cmu_poses, _stretch(cmu_poses))
    res = run_adaptation(small_dictionary, poses, min_poses=50, filter=False, passes=3)
    assert not res.adapted
    assert res.err_adapted > res.err_base
    assert res.dictionary is small_dictionary and res.candidate is not None
    assert "not better" in res.reason and "kept the base" in res.line()


def test_base_guard_error_beside_the_learning_is_the_one_worked_out_alone(
        cmu_poses, shifted_dictionary, monkeypatch):
    """The base dictionary's guard error is worked out in a side thread while the
    candidate is learned: the same number as the guard's masked_error in this
    thread, the side thread really used, and the warning filters and BLAS
    threads as they were."""
    import threading
    import warnings

    from threadpoolctl import threadpool_info

    from sparseedm import adaptation
    from sparseedm._recovery_kernel import compiled_solver

    names = []
    real = adaptation._guard_error

    def spy(*args):
        names.append(threading.current_thread().name)
        return real(*args)

    monkeypatch.setattr(adaptation, "_guard_error", spy)
    filters, blas = list(warnings.filters), [i["num_threads"] for i in threadpool_info()]
    res = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50)
    held = res.pool[holdout_blocks(len(res.pool), 0.2, random_state=0)]
    alone = masked_error(shifted_dictionary, held, n_patterns=len(held) // 12,
                         solver=compiled_solver())
    assert res.err_base == alone and np.isfinite(alone)
    assert names[0].startswith("sparseedm-guard") and names[1] == "MainThread"
    assert warnings.filters == filters
    assert [i["num_threads"] for i in threadpool_info()] == blas
    assert res.step_seconds["guard"] > 0


def test_an_error_while_learning_waits_for_the_guard_thread(cmu_poses, shifted_dictionary,
                                                            monkeypatch):
    """A failure in the learning is raised as it is, after the base's side thread
    has ended, with the warning filters restored."""
    import threading
    import warnings

    from sparseedm import adaptation

    def broken(*args, **kwargs):
        raise MemoryError("planted")

    monkeypatch.setattr(adaptation, "adapt_vectors", broken)
    filters = list(warnings.filters)
    with pytest.raises(MemoryError, match="planted"):
        run_adaptation(shifted_dictionary, cmu_poses, min_poses=50)
    assert not [t for t in threading.enumerate() if t.name.startswith("sparseedm-guard")]
    assert warnings.filters == filters


def test_max_train_bounds_the_complete_poses_learned_from(cmu_poses, shifted_dictionary):
    """max_train: a seeded sample of the complete training rows (the guard's
    held-back poses unchanged); the same sample every time."""
    full = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50)
    a = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50, max_train=100)
    b = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50, max_train=100)
    assert full.n_used > 100 and a.n_used == 100
    assert a.n_validation == full.n_validation and a.err_base == full.err_base
    np.testing.assert_array_equal(a.candidate.components, b.candidate.components)
    assert not np.array_equal(a.candidate.components, full.candidate.components)


def test_adapt_false_reproduces_todays_results_exactly(cmu_poses, small_dictionary):
    poses = cmu_poses.copy()
    missing = random_occlusion(len(poses), 14, "mix", random_state=1)
    missing[::2] = False                       # half the poses complete
    poses[missing] = np.nan
    ref = _recover(poses, missing, dictionary=small_dictionary)
    off = sparseedm.recover(poses, missing, dictionary=small_dictionary, adapt=False)
    for name in ("poses", "vectors", "objective", "gap", "n_active"):
        np.testing.assert_array_equal(getattr(off, name), getattr(ref, name))
    assert off.adaptation is None and not off.adapted and "adaptation" not in off.summary()
    # 167 complete poses are below the threshold: "auto" does not adapt; it codes
    # with those poses as extra atoms (sparseedm.file_atoms), nothing else
    # (exemplars=False: without the check that may average in a second code with
    # their mirror images, sparseedm.exemplars)
    assert MIN_COMPLETE_POSES > 167
    auto = sparseedm.recover(poses, missing, dictionary=small_dictionary, exemplars=False)
    atoms = with_file_atoms(small_dictionary, poses, missing)
    assert atoms.n_atoms == 167
    with_atoms = _recover(poses, missing, dictionary=atoms.dictionary)
    np.testing.assert_array_equal(auto.poses, with_atoms.poses)
    assert not auto.adapted
    s = auto.summary()["adaptation"]
    assert s["adapted"] is False and "fewer than" in s["reason"] and s["complete_poses"] <= 167
    assert s["file_atoms"] == 167


def test_recover_adapts_on_separate_poses(cmu_poses, shifted_dictionary):
    held_back = np.random.default_rng(0).permutation(len(cmu_poses)) >= 250
    poses = cmu_poses[held_back].copy()
    missing = random_occlusion(len(poses), 14, "mix", random_state=2)
    poses[missing] = np.nan
    res = sparseedm.recover(poses, missing, dictionary=shifted_dictionary,
                            adapt=_jittered(cmu_poses[~held_back], 600))
    assert res.adapted and res.dictionary is res.adaptation.dictionary
    s = res.summary()["adaptation"]
    assert s["adapted"] and s["poses_used"] > 0
    assert s["validation_err_adapted"] < s["validation_err_base"]
    cold = sparseedm.recover(poses, missing, dictionary=shifted_dictionary, adapt=False)
    gt = sparseedm.edm.pose_to_vector(cmu_poses[held_back])
    err = [np.mean(sparseedm.metrics.err_ave(r.vectors * r.scale[:, None], gt))
           for r in (cold, res)]
    assert err[1] < err[0]


def test_recover_rejects_a_bad_adapt_argument(cmu_poses, small_dictionary):
    with pytest.warns(UserWarning, match="no adaptation: 2 complete"):
        res = sparseedm.recover(cmu_poses[:2], dictionary=small_dictionary,
                                adapt=cmu_poses[2:4])
    assert not res.adapted and "fewer than" in res.summary()["adaptation"]["reason"]
    with pytest.raises(sparseedm.exceptions.SparseEDMError, match="adapt must be"):
        sparseedm.recover(cmu_poses[:2], dictionary=small_dictionary, adapt="always")
    with pytest.raises(sparseedm.exceptions.PoseError, match="missing must have shape"):
        sparseedm.recover(cmu_poses[:3], np.zeros((2, 14), bool), dictionary=small_dictionary)


def test_adapted_dictionary_round_trips(tmp_path, cmu_poses, shifted_dictionary):
    d = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50).dictionary
    back = load_dictionary(d.save(tmp_path / "adapted.npz"))
    np.testing.assert_array_equal(back.components, d.components)
    assert back.provenance["adaptation"]["poses"] == d.provenance["adaptation"]["poses"]
    assert back.alpha_recover == d.alpha_recover


def test_nan_inf_and_duplicates_are_ignored(cmu_poses, small_dictionary):
    poses = cmu_poses[:100].copy()
    poses[3, 4] = np.nan
    poses[5, 2, 0] = np.inf
    poses = np.concatenate([poses, poses[10:20]])   # 10 exact repeats
    rep = filter_poses(poses, small_dictionary)
    assert rep.counts["incomplete"] == 2 and rep.counts["duplicate"] == 10
    assert not rep.keep[3] and not rep.keep[5] and not rep.keep[100:].any()
    res = run_adaptation(small_dictionary, poses, min_poses=1000)
    assert not res.adapted and res.n_complete == rep.keep.sum()
    assert duplicate_rows(np.zeros((0, 3))).shape == (0,)


def test_filters_check_only_the_bounded_sample(cmu_poses, small_dictionary):
    """More complete poses than max_poses: the seeded sample is drawn first and only
    it is filtered (its duplicates dropped); the rest are counted in, unchecked."""
    poses = np.concatenate([cmu_poses[:200], cmu_poses[:100]])  # 100 exact repeats
    res = run_adaptation(small_dictionary, poses, max_poses=150, min_poses=100)
    rows = np.sort(np.random.default_rng([0, 17]).choice(300, 150, replace=False))
    rep = filter_poses(poses[rows], small_dictionary)  # the sample, filtered alone
    assert res.dropped == rep.counts
    assert 0 < res.dropped["duplicate"] < 100  # the file's 100 repeats, not all drawn
    assert res.n_complete == rep.keep.sum() + 150


def test_swapped_labels_are_flagged(cmu_poses, small_dictionary):
    poses = cmu_poses[::3]
    legs = [(8, 11), (9, 12), (10, 13)]
    swapped = poses.copy()
    for a, b in legs:
        swapped[:, [a, b]] = poses[:, [b, a]]
    flagged_real = swapped_rows(poses, small_dictionary.components, 0.05).mean()
    flagged_swapped = swapped_rows(swapped, small_dictionary.components, 0.05).mean()
    assert flagged_real < 0.1 and flagged_swapped > 0.5, (flagged_real, flagged_swapped)


def test_adapt_vectors_options(cmu_poses, small_dictionary):
    X = _vectors(cmu_poses[:100])
    base = small_dictionary.components
    for kw in ({"stats": "carried"}, {"replay": 0.25}):
        C = adapt_vectors(base, X, 0.05, passes=1, batch_size=32, **kw)
        assert C.shape == base.shape and np.allclose(np.linalg.norm(C, axis=1), 1)
        assert not np.array_equal(C, base)
    again = adapt_vectors(base, X, 0.05, passes=1, batch_size=32, stats="carried")
    np.testing.assert_array_equal(again, adapt_vectors(base, X, 0.05, passes=1, batch_size=32,
                                                       stats="carried"))
    with pytest.raises(sparseedm.exceptions.SparseEDMError, match="stats"):
        adapt_vectors(base, X, 0.05, stats="warm")


def test_sample_complete_is_bounded_seeded_and_chunking_free(cmu_poses):
    poses = cmu_poses.copy()
    missing = np.zeros(poses.shape[:2], bool)
    missing[::4, 3] = True
    a = sample_complete([(poses, missing)], max_poses=50)
    b = sample_complete([(poses[s:s + 7], missing[s:s + 7]) for s in range(0, len(poses), 7)],
                        max_poses=50)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (50, 14, 2) and np.isfinite(a).all()


# --------------------------------------------------------------------------
# files and the CLI

@pytest.fixture(scope="module")
def many_poses(cmu_poses):
    """Enough real (jittered) poses to adapt on, 40 of them with a missing joint."""
    poses = _jittered(cmu_poses, MIN_COMPLETE_POSES + 150, seed=1)
    missing = np.zeros(poses.shape[:2], bool)
    missing[5::17, 4] = True
    poses[missing] = np.nan
    return poses


@pytest.fixture(scope="module")
def shifted_dictionary_path(shifted_dictionary, tmp_path_factory):
    return shifted_dictionary.save(tmp_path_factory.mktemp("shifted") / "shifted.npz")


def test_cli_prints_the_adaptation_line(tmp_path, many_poses, shifted_dictionary_path, capsys):
    inp, out = tmp_path / "in.npz", tmp_path / "out.npz"
    write_keypoints(inp, many_poses)
    saved = tmp_path / "adapted.npz"
    # --no-exemplars: the adaptation's line (its jittered repeats would otherwise make
    # the file's own poses the atoms: sparseedm.exemplars)
    assert main(["recover", str(inp), "-o", str(out), "--dictionary",
                 str(shifted_dictionary_path), "--save-dictionary", str(saved),
                 "--no-exemplars"]) == 0
    text = capsys.readouterr().out
    line = next(ln for ln in text.splitlines() if ln.startswith("adaptation:"))
    assert "adapted the dictionary" in line and "poses used" in line and "->" in line
    assert load_dictionary(saved).provenance["adaptation"]["poses"] > 0

    out2 = tmp_path / "out2.npz"
    assert main(["recover", str(inp), "-o", str(out2), "--dictionary",
                 str(shifted_dictionary_path), "--no-adapt"]) == 0
    assert "adaptation:" not in capsys.readouterr().out
    a, b = read_keypoints(out).poses, read_keypoints(out2).poses
    assert not np.array_equal(a, b)
    observed = np.isfinite(many_poses)
    np.testing.assert_array_equal(a[observed], b[observed])


def test_cli_too_few_complete_poses_says_so(tmp_path, cmu_poses, small_dictionary_path,
                                            capsys):
    poses = cmu_poses[:40].copy()
    poses[::2, 3] = np.nan
    inp, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_keypoints(inp, poses)
    assert main(["recover", str(inp), "-o", str(out), "--dictionary",
                 str(small_dictionary_path)]) == 0
    cap = capsys.readouterr()
    assert "no adaptation: 19 complete plausible poses, fewer than" in cap.err   # 1 outlier
    assert "kept the base dictionary" in cap.out


def test_cli_adapt_from_and_streamed_npy(tmp_path, many_poses, cmu_poses,
                                         shifted_dictionary_path, capsys):
    occluded = cmu_poses[:60].copy()
    occluded[:, 3] = np.nan
    inp, out = tmp_path / "in.npy", tmp_path / "out.npy"
    np.save(inp, occluded)
    src = tmp_path / "same_source.npy"
    np.save(src, many_poses)
    assert main(["recover", str(inp), "-o", str(out), "--dictionary",
                 str(shifted_dictionary_path), "--adapt-from", str(src), "--quiet"]) == 0
    assert "adapted the dictionary" in capsys.readouterr().err
    # a streamed .npy adapts on its own complete poses, sampled in a first pass
    s = recover_file(src, tmp_path / "o.npy", dictionary=shifted_dictionary_path,
                     chunk_size=100, exemplars=False)
    assert s["adaptation"]["poses_given"] <= 5000 and s["adaptation"]["poses_used"] > 0


def test_coco17_file_adapts(tmp_path, cmu_poses, shifted_dictionary_path):
    """A COCO-17 file (another joint convention: neck = mid-shoulders, head top
    extrapolated from the face keypoints) is what adaptation is for."""
    poses = _jittered(cmu_poses, MIN_COMPLETE_POSES + 150, seed=2)
    names = dict(zip(JOINT_NAMES, range(14)))
    anns = []
    for i, p in enumerate(poses):
        kp = np.zeros((17, 3))
        for c, name in enumerate(COCO_KEYPOINTS):
            if name in names:
                kp[c] = [*p[names[name]], 2]
        face = p[1] + 0.6 * (p[0] - p[1])
        for c, dx in ((0, 0), (1, 3), (2, -3), (3, 6), (4, -6)):
            kp[c] = [face[0] + dx, face[1], 2]
        if i % 9 == 0:
            kp[9] = 0                            # left wrist not detected
        anns.append({"image_id": i, "keypoints": kp.ravel().tolist()})
    inp = tmp_path / "coco.json"
    inp.write_text(json.dumps({"annotations": anns}))
    out = tmp_path / "out.json"
    # exemplars=False: the adaptation itself on such a file (its jittered repeats
    # would otherwise make the file's own poses the better atoms: sparseedm.exemplars)
    s = recover_file(inp, out, dictionary=shifted_dictionary_path, exemplars=False)
    ad = s["adaptation"]
    assert ad["complete_poses"] > MIN_COMPLETE_POSES and ad["poses_used"] > 0
    assert np.isfinite(ad["validation_err_base"]) and np.isfinite(ad["validation_err_adapted"])
    back = read_keypoints(out)
    assert not back.missing.any() and s["refused"] == 0


def test_fit_init_fine_tunes(tmp_path, cmu_poses, small_dictionary_path, capsys):
    train = tmp_path / "train.npz"
    np.savez(train, poses2d=_stretch(cmu_poses))
    out = tmp_path / "tuned.npz"
    assert main(["fit", str(train), "-o", str(out), "--init", str(small_dictionary_path),
                 "--passes", "1", "--quiet"]) == 0
    assert "fine-tuned from" in capsys.readouterr().err
    base, tuned = load_dictionary(small_dictionary_path), load_dictionary(out)
    assert tuned.n_components == base.n_components
    assert tuned.alpha_recover == base.alpha_recover
    assert not np.array_equal(tuned.components, base.components)
    assert tuned.provenance["n_poses"] == len(cmu_poses)


def test_sparse_inner_stats_match_the_dense_update():
    from sparseedm.learning import update_inner_stats

    rng = np.random.default_rng(0)
    k, X = 300, rng.standard_normal((64, 91))
    code = np.zeros((64, k))
    for i in range(64):  # ~4 atoms a row: the sparse path
        code[i, rng.choice(k, 4, replace=False)] = rng.standard_normal(4)
    A, B = rng.standard_normal((k, k)), rng.standard_normal((91, k))
    A2, B2 = 0.9 * A + code.T @ code, 0.9 * B + X.T @ code
    update_inner_stats(A, B, X, code, 0.9)
    np.testing.assert_allclose(A, A2, atol=1e-12)
    np.testing.assert_allclose(B, B2, atol=1e-12)


def test_guard_masks_share_few_patterns_of_the_mix():
    from sparseedm.adaptation import guard_masks
    from sparseedm.evaluation import occlusion_masks

    m = guard_masks(300, 14, n_patterns=25, random_state=3)
    assert len(np.unique(m, axis=0)) <= 25 and set(m.sum(axis=1)) <= {1, 2, 3}
    full = guard_masks(30, 14, None, random_state=3)
    assert (full == occlusion_masks(30, 14, ("mix",), 3)["mix"]).all()


def test_adaptation_alpha_scales_with_the_base(shifted_dictionary):
    from sparseedm.adaptation import ADAPTED_ALPHA_TRAIN, adaptation_alpha

    assert adaptation_alpha(load_dictionary()) == ADAPTED_ALPHA_TRAIN
    assert adaptation_alpha(shifted_dictionary) == pytest.approx(4 * 0.05)


# ---------------------------------------------------------------- self-training

@pytest.fixture(scope="module")
def cross_domain(cmu_poses):
    """Complete real poses to adapt on, and other real poses occluded (Mix) to recover."""
    order = np.random.default_rng(5).permutation(len(cmu_poses))
    adapt_on = cmu_poses[np.sort(order[:260])]
    target = cmu_poses[np.sort(order[260:])]
    mask = random_occlusion(len(target), 14, "mix", random_state=3)
    return adapt_on, np.where(mask[..., None], np.nan, target), mask, target


def _err(res, truth):
    from sparseedm.edm import pose_to_vector
    from sparseedm.metrics import err_ave

    return float(np.nanmean(err_ave(res.vectors * res.scale[:, None], pose_to_vector(truth))))


def test_self_training_learns_from_the_recovered_poses(cross_domain, shifted_dictionary):
    adapt_on, inputs, mask, truth = cross_domain
    kw = dict(dictionary=shifted_dictionary, adapt=adapt_on)
    r0 = sparseedm.recover(inputs, mask, self_training=0, **kw)
    r2 = sparseedm.recover(inputs, mask, self_training=2, **kw)
    assert r0.adapted and r0.adaptation.self_training == [] and r0.adaptation.n_extra == 0
    rounds = r2.adaptation.summary()["self_training"]
    assert 1 <= len(rounds) <= 2
    assert rounds[0]["poses"] == int((r0.status == "recovered").sum())
    if rounds[0]["adopted"]:
        assert r2.adaptation.n_extra == [r for r in rounds if r["adopted"]][-1]["poses"]
        assert "self-training: " in r2.adaptation.line()
    # the observed joints come back as given, and the filled ones are better
    np.testing.assert_array_equal(r2.poses[~mask], truth[~mask])
    assert _err(r2, truth) < _err(r0, truth)


def test_self_training_off_reproduces_adaptation_alone(cross_domain, shifted_dictionary):
    adapt_on, inputs, mask, _ = cross_domain
    off = sparseedm.recover(inputs, mask, dictionary=shifted_dictionary, adapt=adapt_on,
                            self_training=0)
    d = run_adaptation(shifted_dictionary, adapt_on).dictionary
    alone = sparseedm.recover(inputs, mask, dictionary=d, adapt=False)
    np.testing.assert_array_equal(off.poses, alone.poses)


def test_only_the_last_round_is_judged_and_its_rejection_keeps_the_first_adaptation(
        cross_domain, shifted_dictionary, monkeypatch):
    import dataclasses

    from sparseedm import adaptation

    adapt_on, inputs, mask, _ = cross_domain
    first = run_adaptation(shifted_dictionary, adapt_on)
    real = adaptation.run_adaptation
    guards = []

    def rejecting(*args, extra=None, guard=True, **kw):
        guards.append(guard)
        res = real(*args, extra=extra, guard=guard, **kw)
        return dataclasses.replace(res, adapted=False) if guard else res

    monkeypatch.setattr(adaptation, "run_adaptation", rejecting)
    out = adaptation.self_train(shifted_dictionary, first, adapt_on, None, inputs, mask,
                                rounds=3)
    assert guards == [False, False, True]
    assert out.dictionary is first.dictionary
    assert [r["checked"] for r in out.self_training] == [False, False, True]
    assert [r["adopted"] for r in out.self_training] == [False, False, False]
    assert "0 of 3 rounds adopted" in out.line()


def test_unchecked_rounds_learn_on_the_held_back_poses_too(cross_domain, shifted_dictionary,
                                                          monkeypatch):
    from sparseedm import adaptation

    adapt_on, inputs, mask, _ = cross_domain
    first = run_adaptation(shifted_dictionary, adapt_on)
    real, seen = adaptation.run_adaptation, []
    monkeypatch.setattr(adaptation, "run_adaptation",
                        lambda *a, **kw: seen.append(real(*a, **kw)) or seen[-1])
    out = adaptation.self_train(shifted_dictionary, first, adapt_on, None, inputs, mask,
                                rounds=2)
    assert first.adapted and first.n_validation > 0
    unchecked, last = seen
    assert unchecked.n_validation == 0 and unchecked.n_used == first.n_used + first.n_validation
    assert np.isnan(out.self_training[0]["validation_err"])
    # the last round is judged on the same held-back poses as the first adaptation
    assert last.n_validation == first.n_validation and last.n_used == first.n_used
    assert np.isfinite(last.err_adapted) and last.err_base == first.err_base


def test_self_training_rounds_recover_their_sample_at_their_own_alpha(cross_domain,
                                                                     shifted_dictionary):
    from sparseedm import adaptation

    adapt_on, inputs, mask, _ = cross_domain
    first = run_adaptation(shifted_dictionary, adapt_on)
    assert first.adapted
    # at an absurd alpha every code is empty: the round has no filled pose to learn from
    none = adaptation.self_train(shifted_dictionary, first, adapt_on, None, inputs, mask,
                                 rounds=1, alpha_factor=1e9)
    some = adaptation.self_train(shifted_dictionary, first, adapt_on, None, inputs, mask,
                                 rounds=1, alpha_factor=adaptation.SELF_TRAINING_ALPHA_FACTOR)
    assert none.self_training[0]["poses"] == 0
    assert some.self_training[0]["poses"] > 0.9 * mask.any(axis=1).sum()
    steps = some.step_seconds
    assert {"first learning", "round 1 recovery", "round 1 learning", "self_training"} <= set(steps)
    assert all(v >= 0 for v in steps.values())


def test_filled_poses_are_learned_from_but_never_held_back(cmu_poses, shifted_dictionary):
    plain = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50)
    more = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50,
                          extra=_jittered(cmu_poses, 40, seed=9))
    assert more.n_extra == 40 and plain.n_extra == 0
    assert (more.n_used, more.n_validation) == (plain.n_used, plain.n_validation)
    assert more.err_base == plain.err_base  # the same held-back poses judge both
    assert not np.array_equal(more.candidate.components, plain.candidate.components)


def test_sample_stream_samples_incomplete_rows_chunking_free(cmu_poses):
    from sparseedm.adaptation import sample_stream

    poses = cmu_poses.copy()
    missing = np.zeros(poses.shape[:2], bool)
    missing[::3, 4] = True
    missing[7, :] = True  # nothing observed: neither sample
    a = sample_stream([(poses, missing)], max_poses=30)
    b = sample_stream([(poses[s:s + 11], missing[s:s + 11])
                       for s in range(0, len(poses), 11)], max_poses=30)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    complete, partial, partial_missing = a
    assert len(complete) == len(partial) == 30
    assert partial_missing.any(axis=1).all() and not partial_missing.all(axis=1).any()
    np.testing.assert_array_equal(complete, sample_complete([(poses, missing)], max_poses=30))


def test_cli_self_training_flag(tmp_path, cmu_poses, shifted_dictionary_path, capsys):
    poses = _jittered(cmu_poses, MIN_COMPLETE_POSES + 250, seed=4)
    poses[3::4, 4] = np.nan  # ~160 incomplete poses
    inp = tmp_path / "in.npz"
    write_keypoints(inp, poses)
    lines = {}
    for rounds in ("0", "1"):
        assert main(["recover", str(inp), "-o", str(tmp_path / f"out{rounds}.npz"),
                     "--dictionary", str(shifted_dictionary_path),
                     "--self-training", rounds, "--no-exemplars"]) == 0
        lines[rounds] = next(ln for ln in capsys.readouterr().out.splitlines()
                             if ln.startswith("adaptation:"))
    assert "self-training" not in lines["0"] and "self-training: " in lines["1"]
    with pytest.raises(SystemExit):
        main(["recover", str(inp), "-o", str(tmp_path / "x.npz"), "--self-training", "x"])


def test_the_learning_starts_from_the_base_gram_the_filter_formed(cmu_poses,
                                                                  shifted_dictionary,
                                                                  monkeypatch):
    """The first mini-batch codes on the base atoms with the Gram the filter
    already formed (sparseedm.solvers.gram), and the candidate is the same to
    the last bit as when every Gram is formed anew."""
    from sparseedm import learning
    from sparseedm.solvers import gram

    gram.clear_gram_cache()
    given = []
    real = learning.minibatch_step

    def spy(X, components, *args, **kwargs):
        given.append(kwargs.get("gram"))
        return real(X, components, *args, **kwargs)

    monkeypatch.setattr(learning, "minibatch_step", spy)
    shared = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50)
    base_gram = gram.gram_matrix(shifted_dictionary.components.T)
    assert given[0] is base_gram and all(g is None for g in given[1:])
    gram.clear_gram_cache()
    monkeypatch.setattr(gram, "GRAM_CACHE_SIZE", 0)
    alone = run_adaptation(shifted_dictionary, cmu_poses, min_poses=50)
    np.testing.assert_array_equal(shared.candidate.components, alone.candidate.components)
    assert (shared.err_base, shared.err_adapted) == (alone.err_base, alone.err_adapted)
