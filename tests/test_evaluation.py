"""Evaluation protocol, baselines, report and the `sparseedm evaluate` command."""

import csv
from pathlib import Path

import numpy as np
import pytest

from sparseedm.cli import main
from sparseedm.dictionary import Dictionary
from sparseedm.edm import pose_to_vector
from sparseedm.evaluation import (METHODS, evaluate, extreme_occluded, occlusion_masks,
                                  sweep_atoms, torso_size)
from sparseedm.exceptions import DictionaryError, SparseEDMError
from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors
from sparseedm.metrics import err_ave
from sparseedm.skeleton import JOINT_NAMES

TEST_CLIPS = ["02_05", "02_06", "03_01"]  # 114 poses; the other 220 train


@pytest.fixture(scope="module")
def split(tmp_path_factory):
    d = dict(np.load(Path(__file__).parent / "fixtures" / "cmu_poses.npz"))
    n = len(d["poses2d"])
    test = np.isin(d["clips"], TEST_CLIPS)
    out = tmp_path_factory.mktemp("eval")
    for name, sel in (("train", ~test), ("test", test)):
        np.savez(out / f"{name}.npz",
                 **{k: (v[sel] if v.shape[:1] == (n,) else v) for k, v in d.items()})
    # test data without labels or 3D
    np.savez(out / "bare.npz", poses2d=d["poses2d"][test])
    X, _ = complete_pose_vectors(d["poses2d"][~test])
    odl = OnlineDictionaryLearning(100, alpha=0.05, batch_size=64, n_passes=2,
                                   random_state=0).fit(X)
    dictionary = Dictionary(odl.components_, alpha_recover=0.01, alpha_train=0.05)
    dictionary.save(out / "dict.npz")
    return {"dir": out, "dictionary": dictionary, "train": d["poses2d"][~test],
            "test": d["poses2d"][test], "labels": d["labels"][test]}


def _pose():
    return np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78], [65, 32], [70, 55],
                     [72, 78], [40, 80], [40, 115], [40, 150], [60, 80], [60, 115],
                     [60, 150]], float)


# ---------------------------------------------------------------- metric by hand
def test_err_ave_hand_computed():
    # 3-4-5 triangle in pixels; estimate 10 % off on the 3 entry, 25 % off on the 4
    gt = pose_to_vector([[0, 0], [3, 0], [3, 4]])  # [3, 5, 4]
    assert err_ave([3.3, 5.0, 5.0], gt) == pytest.approx((10 + 0 + 25) / 3)


def test_mean_fill_zero_err_ave_is_fraction_of_zeroed_entries(split):
    # 'zero' representation as is: the 13 entries touching the occluded joint are
    # 0 (100 % error each), the 78 others exact: Err_ave = 13 / 91 * 100, whatever
    # the pose -- checks the vectors x scale vs pixel-EDM path end to end
    poses = np.stack([_pose(), _pose() * 3 + 7])
    rep = evaluate(split["dictionary"], poses, methods=("mean-fill",), counts=(1, 2),
                   representations=("zero",))
    assert rep.table(count=1)[0]["err_ave_mean"] == pytest.approx(13 / 91 * 100)
    assert rep.table(count=2)[0]["err_ave_mean"] == pytest.approx(25 / 91 * 100)


def test_torso_and_extreme_by_hand():
    p = _pose()[None]
    # neck (50, 30), mid-hip (50, 80)
    assert torso_size(p, JOINT_NAMES).tolist() == [50.0]
    miss = np.zeros((3, 14), bool)
    miss[0, 0] = True    # head_top: highest (smallest y)
    miss[1, 10] = True   # right ankle: lowest (ties with the left ankle; argmax picks 10)
    miss[2, 4] = True    # a wrist: neither
    assert extreme_occluded(np.repeat(p, 3, 0), miss).tolist() == [True, True, False]


def test_sparse_beats_mean_fill(split):
    rep = evaluate(split["dictionary"], split["test"][:20], methods=("sparse", "mean-fill"),
                   counts=(1,), representations=("average",))
    sparse, fill = rep.rows
    assert sparse["err_ave_mean"] < fill["err_ave_mean"]
    assert sparse["n_failed"] == 0


# ---------------------------------------------------------------- protocol
def test_same_seed_same_masks_same_table(split):
    kw = dict(methods=("sparse", "mean-fill"), counts=(1, "mix"), random_state=3)
    a = evaluate(split["dictionary"], split["test"][:40], **kw)
    b = evaluate(split["dictionary"], split["test"][:40], **kw)
    for c in a.masks:
        assert (a.masks[c] == b.masks[c]).all()
    strip = [{k: v for k, v in r.items() if k != "poses_per_s"} for r in a.rows]
    assert strip == [{k: v for k, v in r.items() if k != "poses_per_s"} for r in b.rows]
    c = evaluate(split["dictionary"], split["test"][:40], **{**kw, "random_state": 4})
    assert not (c.masks["mix"] == a.masks["mix"]).all()
    # a count's masks do not depend on which other counts are run
    assert (occlusion_masks(40, 14, ("mix",), 3)["mix"] == a.masks["mix"]).all()


def test_sparse_same_for_both_representations(split):
    rep = evaluate(split["dictionary"], split["test"][:30], methods=("sparse",),
                   counts=(2, "mix"))
    assert rep.sparse_representation_max_diff == 0.0
    for c in (2, "mix"):
        a, z = rep.table(count=c)
        assert a["err_ave_mean"] == z["err_ave_mean"]


def test_report_has_every_method_count_and_representation(split):
    rep = evaluate(split["dictionary"], split["test"], train_poses2d=split["train"],
                   labels=split["labels"], max_poses=50, random_state=0)
    got = {(r["method"], str(r["count"]), r["representation"]) for r in rep.rows}
    want = {(m, str(c), r) for m in METHODS for c in (1, 2, 3, "mix")
            for r in ("average", "zero")}
    assert got == want
    md = rep.to_markdown()
    for m in METHODS:
        assert f"| {m} |" in md
    for c in ("1", "2", "3", "mix"):
        assert f"| {c} |" in md
    assert "Per action" in md and "Where it fails" in md and "unit cancels" in md
    labels = {r["label"] for r in rep.per_action}
    assert labels <= set(TEST_CLIPS) and labels
    for r in rep.rows:
        assert np.isfinite(r["err_ave_mean"]) and r["n_failed"] == 0
        assert r["n_extreme"] >= 0
        # the representation-independent baselines are computed once
        if r["method"] in ("knn", "iterative", "nearest") and r["representation"] == "zero":
            assert r["note"]
    mix = {r["method"]: r["err_ave_mean"] for r in rep.table(count="mix",
                                                             representation="average")}
    assert mix["sparse"] < mix["mean-fill"]
    # the filled poses' EDM: the imputers' completed EDM is their poses' EDM;
    # the sparse method's placed joints are a different (realisable) answer
    for r in rep.table(count="mix", representation="average"):
        assert np.isfinite(r["err_ave_filled"])
        if r["method"] in ("knn", "iterative"):  # they fill joints; nearest places them
            assert r["err_ave_filled"] == pytest.approx(r["err_ave_mean"], rel=1e-9)
    sparse = rep.table(count="mix", representation="average", method="sparse")[0]
    assert sparse["err_ave_filled"] != sparse["err_ave_mean"]
    assert "filled-pose Err_ave" in md


def test_baselines_without_train_are_skipped(split):
    rep = evaluate(split["dictionary"], split["test"][:10], counts=(1,),
                   representations=("average",))
    assert {r["method"] for r in rep.rows} == {"sparse", "mean-fill"}
    assert any("knn, iterative, nearest" in n for n in rep.notes)
    assert any("per-action" in n for n in rep.notes)


@pytest.mark.parametrize("methods, why", [(("knn",), "skipped knn"),
                                          (("knn", "nearest"), "they need --train"),
                                          ((), "list of methods is empty")])
def test_nothing_to_evaluate_is_refused_not_an_empty_report(split, methods, why):
    """A hostile run: --methods knn without --train (or an empty list) exited 0
    with an empty report; refused before any work, saying why."""
    from sparseedm.exceptions import SparseEDMError

    with pytest.raises(SparseEDMError, match=why):
        evaluate(split["dictionary"], split["test"][:10], methods=methods, counts=(1,),
                 representations=("average",))


def test_test_poses_recover_refuses_are_left_out(split):
    """The test set keeps the poses normalize.usable_rows keeps (the one
    rule): a pose whose extent overflows float64 is left out with a note, as a
    NaN one is, instead of being counted as a failed recovery."""
    test = split["test"][:6].copy()
    test[1] = np.where(np.arange(14)[:, None] % 2, 1.5e308, -1.5e308)  # extent overflows
    test[4, 2] = np.nan
    rep = evaluate(split["dictionary"], test, methods=("sparse",), counts=(1,),
                   representations=("average",))
    assert rep.settings["n_poses"] == 4
    assert [r["n_failed"] for r in rep.rows] == [0]
    assert any("2 of 6 test poses are incomplete or degenerate" in n for n in rep.notes)


def test_errors(split):
    with pytest.raises(SparseEDMError, match="known: sparse, mean-fill, knn"):
        evaluate(split["dictionary"], split["test"][:5], methods=("sparse", "magic"))
    with pytest.raises(SparseEDMError, match="occlusion count"):
        evaluate(split["dictionary"], split["test"][:5], counts=(4,))
    with pytest.raises(DictionaryError, match="14 joints"):
        evaluate(split["dictionary"], split["test"][:5, :13])


# ---------------------------------------------------------------- command line
def test_cli_end_to_end(split, tmp_path, capsys):
    d = split["dir"]
    out = tmp_path / "report"
    code = main(["evaluate", "--dictionary", str(d / "dict.npz"), "--data", str(d / "test.npz"),
                 "--train", str(d / "train.npz"), "--max-poses", "60", "--seed", "1",
                 "--sweep-atoms", "50,100,5000", "-o", str(out)])
    assert code == 0
    assert "sparse" in capsys.readouterr().out
    md = (out / "report.md").read_text()
    assert "Fig. 5" in md and "skipped: 220 training poses < 5000 atoms" in md
    with open(out / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(METHODS) * 4 * 2
    assert {r["method"] for r in rows} == set(METHODS)
    with open(out / "per_action.csv") as f:
        assert {r["label"] for r in csv.DictReader(f)} <= set(TEST_CLIPS)
    with open(out / "sweep.csv") as f:
        sweep = list(csv.DictReader(f))
    assert [r["atoms"] for r in sweep] == ["50", "100", "5000"]
    assert sweep[2]["note"].startswith("skipped") and float(sweep[0]["err_ave_mix"]) > 0


def test_cli_figures(split, tmp_path):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    d = split["dir"]
    out = tmp_path / "report"
    assert main(["evaluate", "--dictionary", str(d / "dict.npz"), "--data",
                 str(d / "test.npz"), "--train", str(d / "train.npz"), "--methods",
                 "sparse,mean-fill", "--max-poses", "20", "--sweep-atoms", "50",
                 "-o", str(out)]) == 0
    for name in ("poses.png", "error_by_count.png", "sweep_atoms.png"):
        assert (out / name).read_bytes()[:4] == b"\x89PNG"
    assert "![poses](poses.png)" in (out / "report.md").read_text()


def test_cli_bad_input(split, tmp_path, capsys):
    d = split["dir"]
    base = ["evaluate", "--dictionary", str(d / "dict.npz"), "-o", str(tmp_path / "r")]
    assert main(base + ["--data", str(d / "test.npz"), "--methods", "sparse,bogus"]) == 2
    err = capsys.readouterr().err
    assert "bogus" in err and "known: sparse, mean-fill, knn, iterative, nearest" in err
    # no labels, no 3D, no --train: evaluates what it can and says what it skipped
    assert main(base + ["--data", str(d / "bare.npz"), "--counts", "1",
                        "--max-poses", "10"]) == 0
    err = capsys.readouterr().err
    assert "no labels" in err and "no poses3d" in err and "need --train" in err
    md = (tmp_path / "r" / "report.md").read_text()
    assert "per-action table skipped" in md and "skipped knn, iterative, nearest" in md
    # a dictionary for another joint count
    small = Dictionary(np.eye(3), ("a", "b", "c"))
    small.save(tmp_path / "small.npz")
    assert main(["evaluate", "--dictionary", str(tmp_path / "small.npz"), "--data",
                 str(d / "test.npz"), "-o", str(tmp_path / "r2")]) == 2
    assert "dictionary is for 3 joints" in capsys.readouterr().err


def test_report_without_matplotlib(split, tmp_path, monkeypatch):
    from sparseedm import plotting

    monkeypatch.setattr(plotting, "have_matplotlib", lambda: False)
    rep = evaluate(split["dictionary"], split["test"][:10], methods=("mean-fill",),
                   counts=(1,))
    written, message = rep.write(tmp_path / "r")
    assert "pip install sparseedm[plot]" in message
    assert sorted(p.name for p in written) == ["per_action.csv", "report.md", "results.csv"]
    assert "pip install sparseedm[plot]" in (tmp_path / "r" / "report.md").read_text()


@pytest.mark.parametrize("kwargs", [dict(ensemble=3), dict(self_training=2)])
def test_evaluate_refuses_adaptation_options_without_adaptation(kwargs):
    # an option that cannot apply refuses instead of being ignored
    from sparseedm.exceptions import ParameterError

    poses = np.random.default_rng(0).normal(size=(5, 14, 2))
    with pytest.raises(ParameterError, match="need"):
        evaluate("default", poses, methods=("sparse",), counts=(1,), **kwargs)


def test_sweep_codes_as_the_sparse_row(split):
    """The atom sweep (Fig. 5) codes each test pose by the lasso over the
    learned dictionary alone, as evaluate()'s "sparse" row does (nothing taken
    from the test file's other poses): at the same dictionary, seed and masks
    its Mix Err_ave is that row's."""
    kw = dict(alpha=0.05, alpha_recover=0.01, n_passes=2, batch_size=64, random_state=3)
    test = split["test"][:60]
    row, = sweep_atoms(split["train"], test, atoms=(100,), **kw)
    X, _ = complete_pose_vectors(split["train"])
    odl = OnlineDictionaryLearning(100, alpha=0.05, batch_size=64, n_passes=2,
                                   random_state=3).fit(X)
    d = Dictionary(odl.components_ / np.linalg.norm(odl.components_, axis=1, keepdims=True),
                   alpha_recover=0.01, alpha_train=0.05)
    rep = evaluate(d, test, methods=("sparse",), counts=("mix",), representations=("average",),
                   random_state=3)
    assert row["err_ave_mix"] == pytest.approx(rep.rows[0]["err_ave_mean"], rel=1e-9)


def test_errors_of_poses_far_beyond_pixel_sizes_are_the_scaled_errors(split):
    # norms of 1e200-pixel differences overflow unless the errors are scaled first
    kw = dict(methods=("sparse", "mean-fill"), counts=(1,), representations=("average",))
    small = evaluate(split["dictionary"], split["test"][:12], **kw)
    huge = evaluate(split["dictionary"], split["test"][:12] * 1e200, **kw)
    for a, b in zip(small.rows, huge.rows):
        for key in ("err_ave_mean", "err_ave_filled", "joint_err_torso"):
            assert np.isfinite(b[key]) and b[key] == pytest.approx(a[key], rel=1e-6), key
        assert b["joint_err_px"] == pytest.approx(a["joint_err_px"] * 1e200, rel=1e-6)
