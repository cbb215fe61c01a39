"""sparseedm.ensemble: several adapted dictionaries, their recoveries averaged."""

import numpy as np
import pytest

import sparseedm
from sparseedm.cli import main
from sparseedm.dictionary import Dictionary
from sparseedm.ensemble import adapt_members, combine
from sparseedm.exceptions import SparseEDMError
from sparseedm.keypoints import read_keypoints, write_keypoints
from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors
from sparseedm.metrics import random_occlusion


@pytest.fixture(scope="module")
def shifted(cmu_poses):
    """k=100 atoms learned on x-stretched poses: the wrong domain, so adaptation is adopted."""
    c = cmu_poses.mean(axis=1, keepdims=True)
    stretched = cmu_poses.copy()
    stretched[..., 0] = c[..., 0] + 1.7 * (cmu_poses[..., 0] - c[..., 0])
    X, _ = complete_pose_vectors(stretched)
    odl = OnlineDictionaryLearning(100, alpha=0.05, batch_size=64, n_passes=2,
                                   random_state=0).fit(X)
    return Dictionary(odl.components_, alpha_recover=0.002, alpha_train=0.05)


@pytest.fixture(scope="module")
def split(cmu_poses):
    order = np.random.default_rng(5).permutation(len(cmu_poses))
    adapt_on, target = cmu_poses[np.sort(order[:260])], cmu_poses[np.sort(order[260:])]
    mask = random_occlusion(len(target), 14, "mix", random_state=3)
    return adapt_on, np.where(mask[..., None], np.nan, target), mask


def test_members_differ_by_seed_and_the_answer_is_their_mean(split, shifted):
    adapt_on, inputs, mask = split
    kw = dict(self_training=1)
    res = sparseedm.recover(inputs, mask, dictionary=shifted, adapt=adapt_on, ensemble=3, **kw)
    members, adaptations = adapt_members(shifted, inputs, mask, adapt_on, 3, **kw)
    assert res.members == 3 and res.summary()["ensemble"] == 3 and res.adapted
    assert res.summary()["adaptation"]["ensemble"] == {"asked": 3, "members": 3}
    assert len(members) == 3 and all(a.adapted for a in adaptations)
    assert not np.array_equal(members[0].components, members[1].components)
    one = [sparseedm.recover(inputs, mask, dictionary=d, adapt=False) for d in members]
    assert all(r.ok.all() for r in one)
    np.testing.assert_allclose(res.poses, np.mean([r.poses for r in one], axis=0), atol=1e-9)
    np.testing.assert_allclose(res.vectors, np.mean([r.vectors for r in one], axis=0),
                               atol=1e-12)
    np.testing.assert_array_equal(res.poses[~mask], inputs[~mask])  # observed as given
    # member 0 is what recover() adapts by default
    np.testing.assert_array_equal(res.dictionary.components, members[0].components)
    default = sparseedm.recover(inputs, mask, dictionary=shifted, adapt=adapt_on, **kw)
    np.testing.assert_allclose(default.poses, one[0].poses, atol=1e-9)


def test_no_adaptation_means_one_member(split, shifted):
    adapt_on, inputs, mask = split
    # an ensemble with adaptation off would silently be one member: refused
    with pytest.raises(SparseEDMError, match="ensemble=4 averages adapted dictionaries"):
        sparseedm.recover(inputs, mask, dictionary=shifted, adapt=False, ensemble=4)
    with pytest.warns(UserWarning) as said:  # 20 poses: too few to adapt on
        few = sparseedm.recover(inputs, mask, dictionary=shifted, adapt=adapt_on[:20],
                                ensemble=4)
    said = [str(w.message) for w in said]
    assert any(m.startswith("no adaptation") for m in said)
    assert any(m.startswith("ensemble=4: seed 0's adaptation was not adopted")
               and m.endswith("1 dictionary recovers, not 4 members") for m in said)
    assert few.members == 1 and not few.adapted
    assert few.summary()["adaptation"]["ensemble"] == {"asked": 4, "members": 1}
    with pytest.raises(SparseEDMError, match="ensemble"):
        sparseedm.recover(inputs, mask, dictionary=shifted, ensemble=0)


def test_a_clip_too_short_to_adapt_says_the_ensemble_is_one_member(track, shifted):
    """recover(frames=..., ensemble=K) on a clip shorter than ADAPT_MIN_FRAMES
    (nothing adapted) warns as the photo path does, instead of recovering with
    one dictionary unsaid."""
    from sparseedm.temporal.recover import ADAPT_MIN_FRAMES

    n = ADAPT_MIN_FRAMES - 1
    mask = np.zeros((n, 14), bool)
    mask[10:50, 4] = True  # a long gap: its middle asks the per-frame model
    poses = np.where(mask[..., None], np.nan, track[:n])
    with pytest.warns(UserWarning, match=f"ensemble=3: no dictionary is adapted \\({n} poses"):
        res = sparseedm.recover(poses, mask, frames=np.arange(n), dictionary=shifted,
                                ensemble=3)
    assert res.members == 1 and res.ok.all()


def test_combine_fails_a_row_any_member_failed_and_keeps_refusals(split, shifted):
    _, inputs, mask = split
    bad = inputs[:6].copy()
    bad[0] = np.nan  # no joint observed: refused by the screening, in every member
    a = sparseedm.recover(bad, mask[:6] | np.isnan(bad).any(-1), dictionary=shifted,
                          adapt=False)
    b = sparseedm.recover(bad, mask[:6] | np.isnan(bad).any(-1), dictionary=shifted,
                          adapt=False)
    b.status[2], b.reason[2] = "solver_failed", "solver status not optimal"
    b.status[3] = "inaccurate"
    both = combine([a, b])
    assert both.status[0] == a.status[0] != "recovered" and both.reason[0] == a.reason[0]
    assert both.status[2] == "solver_failed" and np.isnan(both.poses[2]).all()
    assert both.status[3] == "inaccurate" and np.isfinite(both.poses[3]).all()
    assert both.status[1] == "recovered" and both.ok.sum() == 4
    np.testing.assert_allclose(both.poses[1], a.poses[1])
    assert both.seconds == pytest.approx(a.seconds + b.seconds)


def test_cli_recover_ensemble(tmp_path, cmu_poses, shifted, capsys):
    from sparseedm.adaptation import MIN_COMPLETE_POSES

    rng = np.random.default_rng(1)  # as test_adaptation's many_poses: adopted
    n = MIN_COMPLETE_POSES + 150
    poses = cmu_poses[np.sort(rng.integers(0, len(cmu_poses), n))] + rng.normal(
        0, 0.5, (n, 14, 2))
    poses[5::17, 4] = np.nan
    inp, path = tmp_path / "in.npz", shifted.save(tmp_path / "shifted.npz")
    write_keypoints(inp, poses)
    outs = {}
    for k in ("1", "2"):
        out = tmp_path / f"out{k}.npz"
        # --no-exemplars: adapted members (the file's jittered repeats might
        # otherwise be taken as its atoms: sparseedm.exemplars)
        assert main(["recover", str(inp), "-o", str(out), "--dictionary", str(path),
                     "--self-training", "0", "--ensemble", k, "--no-exemplars"]) == 0
        outs[k] = read_keypoints(out).poses
        text = capsys.readouterr().out
        assert "adapted the dictionary" in text
        assert ("ensemble: the mean of 2" in text) == (k == "2")
    assert not np.array_equal(outs["1"], outs["2"])
    observed = np.isfinite(poses)
    np.testing.assert_array_equal(outs["2"][observed], poses[observed])
    assert main(["recover", str(inp), "-o", str(tmp_path / "x.npz"), "--ensemble", "0"]) != 0
    assert "ensemble must be an integer in [1, 64]" in capsys.readouterr().err  # bounded
    assert not (tmp_path / "x.npz").exists()


def test_evaluate_adaptation_with_an_ensemble(cmu_poses, shifted):
    from sparseedm.evaluation import evaluate_adaptation

    order = np.random.default_rng(5).permutation(len(cmu_poses))
    adapt_on, test = cmu_poses[np.sort(order[:260])], cmu_poses[np.sort(order[260:320])]
    kw = dict(methods=("sparse",), self_training=0)
    one = evaluate_adaptation(shifted, test, adapt_on, **kw)
    two = evaluate_adaptation(shifted, test, adapt_on, ensemble=2, **kw)
    assert any("ensemble of 2" in n for n in two.notes)
    assert not any("ensemble" in n for n in one.notes)
    e1, e2 = (r.table(method="sparse-adapted")[0]["err_ave_filled"] for r in (one, two))
    assert np.isfinite(e1) and np.isfinite(e2) and e1 != e2
    with pytest.raises(SparseEDMError, match="ensemble"):
        evaluate_adaptation(shifted, test, adapt_on, ensemble=0, **kw)


def test_combine_keeps_whole_statuses_when_the_first_member_had_only_short_ones(split,
                                                                               shifted):
    _, inputs, mask = split
    a = sparseedm.recover(inputs[:5], mask[:5], dictionary=shifted, adapt=False)
    b = sparseedm.recover(inputs[:5], mask[:5], dictionary=shifted, adapt=False)
    assert set(a.status) == {"recovered"} and a.status.dtype.itemsize < 13 * 4
    b.status = b.status.astype(object)
    b.reason = b.reason.astype(object)
    b.status[1], b.reason[1] = "inaccurate", "duality gap above tolerance"
    b.status[2], b.reason[2] = "solver_failed", "solver status not optimal"
    both = combine([a, b])
    assert both.status.tolist() == ["recovered", "inaccurate", "solver_failed", "recovered",
                                    "recovered"]
    assert both.reason[1] == "duality gap above tolerance"
    assert both.reason[2] == "solver status not optimal"
    assert both.ok.tolist() == [True, True, False, True, True]


def test_a_later_seed_the_guard_rejects_is_left_out(monkeypatch, split, shifted):
    import sparseedm.ensemble as ens

    real = ens.resolve_adaptation

    def reject_seed_1(*args, random_state=0, **kwargs):
        d, res = real(*args, random_state=random_state, **kwargs)
        if random_state == 1:  # as if seed 1's held-back poses had preferred the base
            res.adapted, d = False, args[0]
        return d, res

    monkeypatch.setattr(ens, "resolve_adaptation", reject_seed_1)
    adapt_on, inputs, mask = split
    members, adaptations = adapt_members(shifted, inputs, mask, adapt_on, 3, self_training=0)
    assert len(members) == 2 and all(a.adapted for a in adaptations)
    assert all(m is not shifted for m in members)


def test_ensemble_is_refused_where_it_cannot_apply(tmp_path, split, capsys):
    _, inputs, mask = split
    with pytest.raises(SparseEDMError, match="needs method='sparse'"):
        sparseedm.recover(inputs, mask, method="fconv", model="x.npz", ensemble=2)
    data = tmp_path / "test.npz"
    np.savez(data, poses2d=np.nan_to_num(inputs[:20]))
    assert main(["evaluate", "--data", str(data), "--ensemble", "3", "-o",
                 str(tmp_path / "rep")]) != 0
    assert "--ensemble averages adapted dictionaries" in capsys.readouterr().err
    assert not (tmp_path / "rep").exists()


def test_evaluate_adapts_once_per_count_and_scores_as_recover_does(cmu_poses, shifted):
    """Both representations share one count's adapted members; each scores as a direct
    recover(adapt=..., ensemble=2) with that representation."""
    from sparseedm.edm import pose_to_vector
    from sparseedm.evaluation import evaluate, occlusion_masks
    from sparseedm.metrics import err_ave

    order = np.random.default_rng(5).permutation(len(cmu_poses))
    adapt_on, test = cmu_poses[np.sort(order[:260])], cmu_poses[np.sort(order[260:300])]
    rep = evaluate(shifted, test, methods=("sparse",), counts=(2,),
                   adapt=adapt_on, self_training=1, ensemble=2, random_state=4)
    mask = occlusion_masks(len(test), 14, (2,), 4)[2]
    inputs = np.where(mask[..., None], np.nan, test)
    for r in ("average", "zero"):
        res = sparseedm.recover(inputs, mask, dictionary=shifted, adapt=adapt_on,
                                self_training=1, ensemble=2, representation=r)
        assert res.members == 2 and res.adapted
        want = err_ave(res.vectors * res.scale[:, None], pose_to_vector(test))
        np.testing.assert_allclose(rep.per_pose[("sparse", r, 2)], want, rtol=1e-12)
    assert sum("adapted the dictionary" in n for n in rep.notes) == 2


def test_members_side_by_side_are_the_members_one_after_the_other(split, shifted):
    """n_jobs=2 adapts seeds 1.. on threads, one each: the same atoms as n_jobs=1, and
    the caller's warning filters as they were."""
    import warnings

    adapt_on, inputs, mask = split
    before = list(warnings.filters)
    kw = dict(self_training=1)
    serial, _ = adapt_members(shifted, inputs, mask, adapt_on, 3, n_jobs=1, **kw)
    threaded, ads = adapt_members(shifted, inputs, mask, adapt_on, 3, n_jobs=2, **kw)
    assert len(serial) == len(threaded) == 3 and all(a.adapted for a in ads)
    for a, b in zip(serial, threaded):
        np.testing.assert_array_equal(a.components, b.components)
    assert warnings.filters == before


def test_adapt_none_means_no_adaptation(split, shifted):
    """adapt=None is taken as adapt=False (resolve_adaptation's rule): one member, no
    adaptation attached, the same answer as adapt=False."""
    _, inputs, mask = split
    none = sparseedm.recover(inputs[:5], mask[:5], dictionary=shifted, adapt=None)
    off = sparseedm.recover(inputs[:5], mask[:5], dictionary=shifted, adapt=False)
    assert none.adaptation is None and none.members == 1
    np.testing.assert_array_equal(none.poses, off.poses)
