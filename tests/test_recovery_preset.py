"""recover(preset="fast"): the file's complete poses as the atoms, the same statuses and
certificate as every other path; the CLI's --preset round trip."""

import numpy as np
import pytest

from sparseedm import recover
from sparseedm._recovery_base import STATUSES
from sparseedm._recovery_kernel import FAST_RIDGE
from sparseedm.adaptation import MIN_COMPLETE_POSES, pose_vectors
from sparseedm.cli import main
from sparseedm.exceptions import ParameterError, PoseError
from sparseedm.file_atoms import file_dictionary, resolve_fast
from sparseedm.keypoints import read_keypoints, write_keypoints


@pytest.fixture(scope="module")
def file_poses(cmu_poses):
    """The fixture poses: the first 300 complete, the rest with 1-3 joints hidden,
    one row with too few joints left and one with a non-finite coordinate."""
    poses = cmu_poses.copy()
    missing = np.zeros(poses.shape[:2], bool)
    rng = np.random.default_rng(0)
    for i in range(300, len(poses)):
        missing[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
    missing[-1, :12] = True                     # 2 joints left: refused
    poses[-2, 3, 0] = np.inf                    # refused as invalid coordinates
    return poses, missing


def test_fast_dictionary_is_the_complete_poses(file_poses, small_dictionary):
    poses, missing = file_poses
    d, res = resolve_fast(small_dictionary, poses, missing, "auto")
    assert 300 >= MIN_COMPLETE_POSES
    assert d.n_components == res.file_atoms == 300
    X = pose_vectors(poses[:300])
    np.testing.assert_allclose(d.components, X / np.linalg.norm(X, axis=1, keepdims=True))
    assert d.alpha_scaling == small_dictionary.alpha_scaling
    assert not res.adapted and res.line().startswith("adaptation: none (preset 'fast'")


def test_too_few_complete_poses_join_the_base(file_poses, small_dictionary):
    poses, missing = file_poses
    few = np.concatenate([poses[:20], poses[300:]])
    few_missing = np.concatenate([missing[:20], missing[300:]])
    d, res = resolve_fast(small_dictionary, few, few_missing, "auto")
    assert d.n_components == small_dictionary.n_components + 20
    assert d.alpha_recover == small_dictionary.alpha_recover
    assert resolve_fast(small_dictionary, poses, missing, False) == (small_dictionary, None)


def test_fast_statuses_and_certificates(file_poses, small_dictionary):
    poses, missing = file_poses
    fast = recover(poses, missing, dictionary=small_dictionary, preset="fast")
    plain = recover(poses, missing, dictionary=small_dictionary, adapt=False)
    assert set(fast.status) <= set(STATUSES)
    # screening is the same for every preset: the same refusals, the same reasons
    refused = ~np.isin(plain.status, ("recovered", "complete", "inaccurate"))
    np.testing.assert_array_equal(fast.status[refused], plain.status[refused])
    np.testing.assert_array_equal(fast.reason[refused], plain.reason[refused])
    assert {"too_few_observed", "invalid_coordinates"} <= set(fast.status)
    rec = fast.status == "recovered"
    assert rec.sum() > 0
    # the local ridge's certificate: its normal equations solved (relative residual)
    assert (fast.gap[rec] <= 1e-6).all()
    assert (fast.n_active[rec] == FAST_RIDGE["n_atoms"]).all()
    assert np.isfinite(fast.poses[rec]).all()
    np.testing.assert_array_equal(fast.poses[rec][~missing[rec]], poses[rec][~missing[rec]])
    assert fast.dictionary.n_components == 300
    assert fast.summary()["adaptation"]["file_atoms"] == 300


def test_fast_alpha_given_wins(file_poses, small_dictionary):
    poses, missing = file_poses
    res = recover(poses[:320], missing[:320], dictionary=small_dictionary, preset="fast",
                  alpha=0.01)
    assert res.alpha == 0.01


@pytest.mark.parametrize("kw", [dict(ensemble=2), dict(self_training=2),
                                dict(frames=np.arange(334)), dict(method="fconv"),
                                dict(exemplars=False)])
def test_fast_refuses_what_it_would_ignore(file_poses, small_dictionary, kw):
    poses, missing = file_poses
    with pytest.raises(ParameterError, match="preset"):
        recover(poses, missing, dictionary=small_dictionary, preset="fast", **kw)


def test_cli_fast_refuses_no_exemplars(tmp_path, file_poses, small_dictionary_path, capsys):
    """--preset fast always codes over the file's own poses: --no-exemplars with it
    is refused before any work, naming both."""
    poses, missing = file_poses
    inp, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_keypoints(inp, np.where(missing[..., None], np.nan, poses)[:-2])
    code = main(["recover", str(inp), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--preset", "fast", "--no-exemplars", "-q"])
    err = capsys.readouterr().err
    assert code != 0 and not out.exists()
    assert "preset='fast'" in err and "exemplars=False" in err


def test_unknown_preset_is_refused(file_poses):
    with pytest.raises(ParameterError, match="preset"):
        recover(file_poses[0][:2], preset="quick")


def test_file_dictionary_default_alpha(cmu_poses, small_dictionary):
    out = file_dictionary(small_dictionary, cmu_poses[:50], alpha_recover=0.003)
    assert out.dictionary.alpha_recover == 0.003 and out.n_atoms == 50


def test_cli_preset_round_trip(tmp_path, file_poses, small_dictionary_path, capsys):
    poses, missing = file_poses
    ok = np.isfinite(poses).all(axis=(1, 2))
    inp, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_keypoints(inp, np.where(missing[..., None], np.nan, poses)[ok])
    code = main(["recover", str(inp), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--preset", "fast", "-q"])
    assert code == 1                                   # the one row with 2 joints left
    filled = read_keypoints(out).poses
    api = recover(np.where(missing[..., None], np.nan, poses)[ok],
                  dictionary=small_dictionary_path, preset="fast")
    np.testing.assert_allclose(filled[api.ok], api.poses[api.ok], atol=1e-6)
    assert "preset 'fast'" in capsys.readouterr().err


def test_fast_preset_is_a_local_ridge(cmu_poses, small_dictionary):
    """preset="fast" codes by the local ridge (preset_solver) when the file's own
    complete poses are the only atoms, not the lasso: the same screening and
    statuses as the lasso on the same atoms, other codes (K atoms each), the
    observed joints kept."""
    from sparseedm.solvers.fast import FastSolver

    rng = np.random.default_rng(1)
    # every fixture pose complete (334, enough for a dictionary of their own), and
    # jittered copies of them with 1-3 joints hidden
    poses = np.concatenate([cmu_poses, cmu_poses + rng.normal(0, 2, cmu_poses.shape)])
    missing = np.zeros(poses.shape[:2], bool)
    for i in range(len(cmu_poses), len(poses)):
        missing[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
    ridge = recover(poses, missing, dictionary=small_dictionary, preset="fast")
    assert ridge.dictionary.n_components == ridge.adaptation.file_atoms == len(cmu_poses)
    lasso = recover(poses, missing, dictionary=small_dictionary, preset="fast",
                    solver=FastSolver(working_set=True))
    np.testing.assert_array_equal(ridge.status, lasso.status)
    rec = ridge.status == "recovered"
    assert rec.sum() > 100
    assert (ridge.n_active[rec] == FAST_RIDGE["n_atoms"]).all()
    assert (ridge.n_active[rec] != lasso.n_active[rec]).any()

    assert np.isfinite(ridge.poses[rec]).all()
    np.testing.assert_array_equal(ridge.poses[~missing], poses[~missing])


def test_fast_preset_first_pass_lowers_the_error(cmu_poses, small_dictionary):
    """The preset's first pass (FAST_RIDGE's first_atoms: the working set chosen
    on the whole pose as a first ridge filled it): the odd fixture poses with 1-3
    joints hidden (two draws), the even ones the only atoms; the hidden joints
    come back closer to the truth than with the working set of the observed
    entries alone, under the same statuses."""
    from sparseedm.solvers.local_ridge import LocalRidgeSolver

    one_pass = {k: v for k, v in FAST_RIDGE.items() if k != "first_atoms"}
    errors = np.zeros(2)
    for seed in (0, 1):
        rng = np.random.default_rng(seed)
        missing = np.zeros(cmu_poses.shape[:2], bool)
        for i in range(1, len(cmu_poses), 2):
            missing[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
        poses = np.where(missing[..., None], np.nan, cmu_poses)
        atoms = file_dictionary(small_dictionary, poses, missing).dictionary
        for j, settings in enumerate((FAST_RIDGE, one_pass)):
            res = recover(poses, missing, dictionary=atoms, adapt=False,
                          solver=LocalRidgeSolver(**settings))
            assert (res.status[missing.any(axis=1)] == "recovered").all()
            errors[j] += np.linalg.norm(res.poses - cmu_poses, axis=-1)[missing].sum()
    assert errors[0] < errors[1]


def test_fast_preset_with_few_complete_poses_keeps_the_lasso(cmu_poses, small_dictionary):
    """Fewer complete poses than a dictionary of their own needs: they join the base
    dictionary's learned atoms, and the preset codes with the lasso as given."""
    poses = cmu_poses.copy()
    missing = np.zeros(poses.shape[:2], bool)
    rng = np.random.default_rng(1)
    for i in range(150, len(poses)):
        missing[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
    res = recover(poses, missing, dictionary=small_dictionary, preset="fast")
    assert res.dictionary.n_components == small_dictionary.n_components + 150
    rec = res.status == "recovered"
    assert rec.sum() > 100
    assert (res.n_active[rec] != FAST_RIDGE["n_atoms"]).any()
    default_solver = recover(poses, missing, dictionary=small_dictionary, preset="fast",
                             solver="fast")
    np.testing.assert_array_equal(res.poses, default_solver.poses)


@pytest.mark.parametrize("how", ["argument", "dictionary"])
def test_fast_preset_with_non_negative_codes_codes_by_the_lasso(file_poses, small_dictionary,
                                                                tmp_path, how):
    """The local ridge's codes are signed: with positive=True, or a dictionary whose
    positive_code is True (API and CLI), the preset codes over the file's own poses
    by the lasso with non-negative codes instead of raising from the ridge."""
    from dataclasses import replace

    from sparseedm.solvers.fast import FastSolver

    poses, missing = file_poses
    d = small_dictionary if how == "argument" else replace(small_dictionary,
                                                           positive_code=True)
    kw = dict(positive=True) if how == "argument" else {}
    res = recover(poses, missing, dictionary=d, preset="fast", **kw)
    assert res.dictionary.n_components == res.adaptation.file_atoms == 300
    lasso = recover(poses, missing, dictionary=d, preset="fast", positive=True,
                    solver=FastSolver(working_set=True))
    np.testing.assert_array_equal(res.status, lasso.status)
    np.testing.assert_allclose(res.poses, lasso.poses, rtol=0, atol=1e-9)
    rec = res.status == "recovered"
    assert rec.sum() > 20 and np.isfinite(res.poses[rec]).all()
    assert np.isfinite(res.uncertainty[rec][missing[rec]]).all()
    if how == "dictionary":
        ok = np.isfinite(poses).all(axis=(1, 2))
        inp, out = tmp_path / "in.csv", tmp_path / "out.csv"
        write_keypoints(inp, np.where(missing[..., None], np.nan, poses)[ok])
        code = main(["recover", str(inp), "-o", str(out), "--dictionary",
                     str(d.save(tmp_path / "positive.npz")), "--preset", "fast", "-q"])
        assert code == 1                               # the one row with 2 joints left
        api = recover(np.where(missing[..., None], np.nan, poses)[ok], dictionary=d,
                      preset="fast")
        np.testing.assert_allclose(read_keypoints(out).poses[api.ok], api.poses[api.ok],
                                   atol=1e-6)


@pytest.mark.parametrize("preset", ["default", "fast"])
@pytest.mark.parametrize("adapt, error, words", [
    (True, ParameterError, "adapt must be 'auto', False or an array"),
    (0, ParameterError, "adapt must be 'auto', False or an array"),
    ("false", ParameterError, "adapt must be 'auto', False or an array"),
    (np.ones((300, 14, 2), bool), ParameterError, "adapt must hold real numbers"),
    (np.ones((300, 14, 2), complex), ParameterError, "adapt must hold real numbers"),
    (np.full((300, 14, 2), "1e400"), ParameterError, "adapt must hold real numbers"),
    (np.zeros((300, 13, 2)), PoseError, "adapt poses have 13 joints")])
def test_bad_adapt_is_refused_by_every_preset(file_poses, small_dictionary, preset, adapt,
                                              error, words):
    """adapt is checked once at recover()'s entrance: the fast preset no longer crashes
    on True or a number, nor reads 'false' as 'auto' or booleans, complex numbers or
    strings as poses."""
    poses, missing = file_poses
    with pytest.raises(error, match=words):
        recover(poses, missing, dictionary=small_dictionary, preset=preset, adapt=adapt)


@pytest.mark.parametrize("preset", ["default", "fast"])
@pytest.mark.parametrize("adapt", [True, 1, np.ones((300, 14, 2), bool)])
def test_recover_file_refuses_bad_adapt_before_writing(tmp_path, file_poses, small_dictionary,
                                                       preset, adapt):
    """recover_file's adapt (not a path) is checked as recover()'s, before any output."""
    from sparseedm.batch import recover_file

    poses, missing = file_poses
    inp, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_keypoints(inp, np.where(missing[..., None], np.nan, poses)[:-2])
    with pytest.raises(ParameterError, match="recover_file: adapt must"):
        recover_file(inp, out, dictionary=small_dictionary, preset=preset, adapt=adapt)
    assert not out.exists()


def test_adapt_poses_with_nan_rows_are_used_without_them(file_poses, small_dictionary):
    """An adapt array's rows with NaN or inf are not complete: the preset's atoms are
    the other rows, as when they are left out."""
    poses, missing = file_poses
    other = poses[:300] + 1.0
    holed = other.copy()
    holed[:20, 3] = np.nan
    holed[20:25, 5, 0] = np.inf
    res = recover(poses, missing, dictionary=small_dictionary, preset="fast", adapt=holed)
    ref = recover(poses, missing, dictionary=small_dictionary, preset="fast",
                  adapt=other[25:])
    assert res.adaptation.file_atoms == ref.adaptation.file_atoms == 275
    np.testing.assert_array_equal(res.poses, ref.poses)


def test_cold_codes_on_working_sets(file_poses, small_dictionary, monkeypatch):
    """adapt=False over a dictionary of WS_MIN_ATOMS atoms or more (the cold
    prior's 2,932; here lowered to the test dictionary's size) codes by the
    lasso on working sets of atoms (FastSolver's "auto"): the same joints as
    the homotopy over every atom."""
    import sparseedm.solvers.fast as fast
    from sparseedm.solvers.fast import FastSolver

    calls = []
    real = fast.lars_lasso_working_set

    def spy(*args, **kwargs):
        calls.append(len(args[1]))
        return real(*args, **kwargs)

    monkeypatch.setattr(fast, "lars_lasso_working_set", spy)
    monkeypatch.setattr(fast, "WS_MIN_ATOMS", small_dictionary.n_components)
    poses, missing = file_poses
    missing = missing.copy()
    rng = np.random.default_rng(2)
    for i in range(300):  # every pose occluded: batches the size working sets run at
        missing[i, rng.choice(14, rng.integers(1, 4), replace=False)] = True
    P = np.where(missing[..., None], np.nan, poses)
    sets = recover(P, missing, dictionary=small_dictionary, adapt=False)
    assert sum(calls) >= 300
    calls.clear()
    full = recover(P, missing, dictionary=small_dictionary, adapt=False,
                   solver=FastSolver(working_set=False))
    assert not calls
    np.testing.assert_array_equal(sets.status, full.status)
    np.testing.assert_allclose(sets.poses, full.poses, atol=1e-6)
