"""Lifting 2D poses to 3D: MDS, lifters, file format, lift(), CLI (tests/fixtures only)."""

import csv
import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sparseedm.cli import main
from sparseedm.edm import pose_to_edm
from sparseedm.exceptions import PoseError, SparseEDMError
from sparseedm.lifting import (LifterError, fit_lifter, lift, load_lifter, training_pairs)
from sparseedm.lifting.mds import (ChiralityPrior, align_to_image, classical_mds, reconstruct,
                                   smacof)
from sparseedm.lifting.metrics import err_ave_3d, pa_mpjpe

CMU_POSES = Path(__file__).resolve().parent / "fixtures" / "cmu_poses.npz"
VAL_CLIPS = ("02_05", "02_10")  # held-out clips of the fixture (punch, wash: 114 poses)


@pytest.fixture(scope="module")
def data():
    with np.load(CMU_POSES, allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def _arrays(d, ix):
    return (d["poses2d"][ix], d["poses3d"][ix], d["camera_R"][ix], d["camera_t"][ix],
            d["camera_f"][ix])


@pytest.fixture(scope="module")
def split(data):
    val = np.isin(data["clips"], VAL_CLIPS)
    return np.flatnonzero(~val), np.flatnonzero(val)


@pytest.fixture(scope="module")
def dict_lifter(data, split):
    return fit_lifter(*_arrays(data, split[0]), method="dictionary", n_components=100,
                      alpha=0.05, alpha_lift=0.002, batch_size=64, n_passes=2,
                      provenance={"files": ["cmu_poses.npz"]})


@pytest.fixture(scope="module")
def mlp_lifter(data, split):
    return fit_lifter(*_arrays(data, split[0]), method="mlp", hidden_layer_sizes=(32,),
                      max_iter=100)


@pytest.fixture(scope="module")
def lifter_path(dict_lifter, tmp_path_factory):
    return dict_lifter.save(tmp_path_factory.mktemp("lifter") / "small.npz")


# ------------------------------------------------------------------ MDS

def _procrustes_residual(Y, X, reflection=True):
    """Max joint distance after the best rigid motion (+ reflection) of Y onto X."""
    Y = Y - Y.mean(0)
    X = X - X.mean(0)
    U, _, Vt = np.linalg.svd(Y.T @ X)
    R = U @ Vt
    if not reflection and np.linalg.det(R) < 0:
        U[:, -1] *= -1
        R = U @ Vt
    return np.abs(Y @ R - X).max()


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_joints=st.integers(4, 14),
       size=st.floats(0.1, 100.0))
def test_mds_recovers_pose_up_to_rigid_motion_and_reflection(seed, n_joints, size):
    X = np.random.default_rng(seed).standard_normal((n_joints, 3)) * size
    E = pose_to_edm(X)[None]
    Y = smacof(E, classical_mds(E))[0]
    assert _procrustes_residual(Y, X) <= 1e-6 * size


def test_small_batches_run_numpy_forms_with_the_compiled_answers():
    # a first lift of a few poses must not wait for numba to compile:
    # below NUMPY_MAX poses smacof and tetra_volumes run numpy forms of the
    # compiled loops; both must give the same poses and volumes
    from sparseedm.lifting import mds

    rng = np.random.default_rng(1)
    n = mds.NUMPY_MAX + 44
    X = rng.standard_normal((n, 14, 3))
    noise = rng.uniform(0.9, 1.1, (n, 14, 14))
    E = pose_to_edm(X) * (noise + noise.transpose(0, 2, 1)) / 2  # not Euclidean
    init = classical_mds(E)
    compiled = smacof(E, init, max_iter=50)
    half = n // 2
    small = np.concatenate([smacof(E[:half], init[:half], max_iter=50),
                            smacof(E[half:], init[half:], max_iter=50)])
    np.testing.assert_allclose(small, compiled, rtol=0, atol=1e-12)
    assert np.abs(compiled - init + init.mean(axis=1, keepdims=True)).max() > 1e-3  # it moved
    V = mds.tetra_volumes(compiled)
    Vs = np.concatenate([mds.tetra_volumes(compiled[:half]), mds.tetra_volumes(compiled[half:])])
    np.testing.assert_allclose(Vs, V, rtol=0, atol=1e-12)


def test_alignment_matches_the_image_and_offers_both_reflections():
    rng = np.random.default_rng(1)
    X = rng.standard_normal((5, 14, 3))
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    Y = X @ Q  # the same shapes in another orientation
    front, back, scale = align_to_image(Y, X[..., :2], np.ones((5, 14), bool))
    Xc = X - X.mean(axis=1, keepdims=True)
    for cand in (front, back):
        np.testing.assert_allclose(cand[..., :2], Xc[..., :2], atol=1e-6)
    # one candidate is the pose itself, the other its depth mirror
    hit = np.minimum(np.abs(front - Xc).max(axis=(1, 2)), np.abs(back - Xc).max(axis=(1, 2)))
    assert hit.max() < 1e-6
    np.testing.assert_allclose(scale, 1.0, rtol=1e-6)


def test_chirality_prior_tells_real_poses_from_mirrors(data, split):
    _, _, _, cam = training_pairs(*_arrays(data, split[0]))
    _, _, _, cam_val = training_pairs(*_arrays(data, split[1]))
    prior = ChiralityPrior().fit(cam)
    mirrored = cam_val * np.array([1.0, 1.0, -1.0])
    assert (prior.score(cam_val) > 0).mean() > 0.8
    np.testing.assert_allclose(prior.score(mirrored), -prior.score(cam_val))


def test_reconstruct_from_exact_edm_picks_the_true_reflection(data, split):
    _, _, _, cam = training_pairs(*_arrays(data, split[0]))
    prior = ChiralityPrior().fit(cam)
    _, _, _, cam_val = training_pairs(*_arrays(data, split[1]))
    P2 = cam_val[..., :2]  # orthographic image of the true pose
    P, margin, _ = reconstruct(pose_to_edm(cam_val), P2, np.ones(P2.shape[:2], bool), prior)
    truth = cam_val - cam_val.mean(axis=1, keepdims=True)
    right = np.abs(P - truth).max(axis=(1, 2)) < 1e-6
    assert right.mean() > 0.8 and (margin >= 0).all()


# ------------------------------------------------------------------ lifters

def test_dictionary_lifter_beats_nearest_neighbour_and_mlp_lifts(data, split, dict_lifter,
                                                                 mlp_lifter):
    tr, val = split
    X2t, X3t, _, _ = training_pairs(*_arrays(data, tr))
    X2, X3, metric, cam = training_pairs(*_arrays(data, val))
    res = lift(data["poses2d"][val], lifter=dict_lifter)
    assert (res.status == "lifted").all()
    err = err_ave_3d(res.vectors3d, metric).mean()
    nn = ((X2[:, None] - X2t[None]) ** 2).sum(-1).argmin(axis=1)
    err_nn = err_ave_3d(X3t[nn], metric).mean()
    assert err < err_nn
    assert pa_mpjpe(res.poses3d, cam).mean() < 120  # mm: a plausible pose, not noise
    res_mlp = lift(data["poses2d"][val], lifter=mlp_lifter)
    assert res_mlp.ok.all() and np.isfinite(res_mlp.poses3d).all()


def test_occluded_poses_lift_from_observed_entries(data, split, dict_lifter):
    from sparseedm.metrics import random_occlusion

    val = split[1]
    _, _, metric, _ = training_pairs(*_arrays(data, val))
    mask = random_occlusion(len(val), 14, "mix", random_state=0)
    poses = np.where(mask[..., None], np.nan, data["poses2d"][val])
    res = lift(poses, lifter=dict_lifter)
    assert (res.status == "lifted_occluded").all()
    full = lift(data["poses2d"][val], lifter=dict_lifter)
    err_occ = err_ave_3d(res.vectors3d, metric).mean()
    err_full = err_ave_3d(full.vectors3d, metric).mean()
    assert err_occ < 2 * err_full


def test_lift_workers_run_numba_on_one_thread_each(data, dict_lifter, monkeypatch):
    """predict(n_jobs=2) codes its chunks in joblib threads, each kernel on one numba
    thread (as recover()'s workers), not numba's count in each worker (they left 2
    workers x 2 threads on 2 cores); in-process (n_jobs=1) numba's threads are kept,
    and the caller's count is unchanged after either."""
    import numba

    from sparseedm.edm import pose_to_vector
    from sparseedm.normalize import normalize
    from sparseedm.solvers import get_solver

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread here: nothing to oversubscribe")
    solver = type(get_solver(dict_lifter.solver))
    seen = []
    solve = solver.solve_masked

    def spy(self, *args, **kwargs):
        seen.append(numba.get_num_threads())
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(solver, "solve_masked", spy)
    X2 = pose_to_vector(normalize(data["poses2d"][:300])[0])
    missing = np.zeros((300, 14), bool)
    missing[::3, 4] = True
    before = numba.get_num_threads()
    numba.set_num_threads(2)
    try:
        ref, _ = dict_lifter.predict(X2, missing, n_jobs=1)
        assert seen == [2]
        seen.clear()
        Y, _ = dict_lifter.predict(X2, missing, n_jobs=2)
        assert len(seen) > 1 and set(seen) == {1}
        assert numba.get_num_threads() == 2
    finally:
        numba.set_num_threads(before)
    np.testing.assert_allclose(Y, ref, rtol=1e-9, atol=1e-12)


def test_bad_rows_are_flagged_and_good_rows_lifted(data, dict_lifter):
    poses = data["poses2d"][:5].copy()
    poses[1, 2:] = np.nan                  # 2 observed joints
    poses[2, 3] = np.inf                   # invalid coordinate
    poses[3] = 7.0                         # every joint at one point
    res = lift(poses, lifter=dict_lifter)
    assert res.status.tolist() == ["lifted", "too_few_observed", "invalid_coordinates",
                                   "degenerate", "lifted"]
    assert np.isfinite(res.poses3d[[0, 4]]).all() and np.isnan(res.poses3d[1:4]).all()
    assert "2 observed joints" in res.reason[1]


def test_an_overflowing_row_is_refused_and_the_rest_lifted(data, dict_lifter):
    poses = data["poses2d"][:3].copy()
    poses[1] = np.where(np.arange(14)[:, None] % 2, 1.5e308, -1.5e308)  # extent overflows
    res = lift(poses, lifter=dict_lifter)
    assert res.status.tolist() == ["lifted", "out_of_range", "lifted"]
    assert "rescale" in res.reason[1] and np.isfinite(res.poses3d[[0, 2]]).all()


def test_summary_counts_every_status_lift_gives(data, dict_lifter):
    """summary() counts each row under its status: out_of_range rows were lost
    while lifting kept its own copy of recovery's statuses."""
    poses = data["poses2d"][:3].copy()
    poses[1] = np.where(np.arange(14)[:, None] % 2, 1.5e308, -1.5e308)  # extent overflows
    poses[2] = np.nan  # no observed joint
    summary = lift(poses, lifter=dict_lifter).summary()
    assert summary["status"] == {"lifted": 1, "too_few_observed": 1, "out_of_range": 1}
    assert sum(summary["status"].values()) == summary["poses"] == 3


def test_lift_refuses_other_joint_counts(dict_lifter):
    with pytest.raises(PoseError, match="13 joints but the lifter is for 14"):
        lift(np.zeros((2, 13, 2)), lifter=dict_lifter)


# ------------------------------------------------------------------ files

def test_decoder_refit_beats_the_learned_3d_halves_on_held_out_clips(data, split):
    """The 3D-half re-fit (decoder_ridge) against the jointly learned halves, same atoms."""
    tr, val = split
    kw = dict(method="dictionary", n_components=100, alpha=0.05, alpha_lift=0.002,
              batch_size=64, n_passes=2)
    learned = fit_lifter(*_arrays(data, tr), decoder_ridge=None, **kw)
    refit = fit_lifter(*_arrays(data, tr), decoder_ridge=0.01, **kw)
    m = learned.components_.shape[1] // 2
    # same learning, same 2D halves (same codes): only the read-out differs
    np.testing.assert_array_equal(refit.components_[:, :m], learned.components_[:, :m])
    _, X3, _, _ = training_pairs(*_arrays(data, val))
    err = {name: float(np.mean(err_ave_3d(lift(data["poses2d"][val], lifter=lf).vectors3d, X3)))
           for name, lf in (("learned", learned), ("refit", refit))}
    assert err["refit"] < err["learned"], err


def test_decoder_refit_shrinks_towards_the_learned_halves(data, split):
    tr = split[0][:300]
    lf = fit_lifter(*_arrays(data, tr), method="dictionary", n_components=60, alpha=0.05,
                    batch_size=64, decoder_ridge=None)
    X2, X3, _, _ = training_pairs(*_arrays(data, tr))
    G, B = lf._decoder_stats(X2, X3)
    m = X2.shape[1]
    far = lf._solve_decoder(G, B, 1e9, len(X2))
    np.testing.assert_allclose(far, lf.components_, atol=1e-6)
    near = lf._solve_decoder(G, B, 1e-6, len(X2))
    np.testing.assert_array_equal(near[:, :m], lf.components_[:, :m])
    # a weak penalty is (close to) the least-squares read-out of the codes: it
    # fits the training 3D halves better than the learned halves do
    before = np.mean((lf.predict(X2)[0] - X3) ** 2)
    lf.components_ = near
    assert np.mean((lf.predict(X2)[0] - X3) ** 2) < 0.9 * before


def test_lifter_files_without_decoder_ridge_load_as_learned(tmp_path, lifter_path):
    with np.load(lifter_path, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    meta = json.loads(str(arrays["meta"]))
    assert meta["params"]["decoder_ridge"] == 0.01
    del meta["params"]["decoder_ridge"]  # as files written before the re-fit existed
    np.savez(tmp_path / "old.npz", **dict(arrays, meta=np.array(json.dumps(meta))))
    old = load_lifter(tmp_path / "old.npz")
    assert old.decoder_ridge is None and "re-fitted" not in old.describe()
    assert "re-fitted to the 2D codes (ridge 0.01)" in load_lifter(lifter_path).describe()


def test_round_trip_dictionary_and_mlp(tmp_path, data, dict_lifter, mlp_lifter):
    poses = data["poses2d"][:20]
    for lf in (dict_lifter, mlp_lifter):
        path = lf.save(tmp_path / f"{lf.method}.npz")
        back = load_lifter(path)
        assert type(back) is type(lf) and back.size_prior_ == lf.size_prior_
        np.testing.assert_array_equal(lift(poses, lifter=back).poses3d,
                                      lift(poses, lifter=lf).poses3d)
        with np.load(path, allow_pickle=False) as npz:
            assert all(npz[k].dtype != object for k in npz.files)


def test_refuses_pickled_corrupt_unknown_and_wrong_n(tmp_path, lifter_path):
    pk = tmp_path / "pickled.npz"
    pk.write_bytes(pickle.dumps({"components": np.zeros(3)}))
    with pytest.raises(LifterError, match="pickled"):
        load_lifter(pk)
    bad = tmp_path / "truncated.npz"
    bad.write_bytes(lifter_path.read_bytes()[:500])
    with pytest.raises(LifterError, match="corrupt or truncated|unreadable"):
        load_lifter(bad)
    with np.load(lifter_path, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    meta = json.loads(str(arrays["meta"]))
    meta["method"] = "gnn"
    np.savez(tmp_path / "gnn.npz", **dict(arrays, meta=np.array(json.dumps(meta))))
    with pytest.raises(LifterError, match="'gnn' is not available.*dictionary, mlp, fconv"):
        load_lifter(tmp_path / "gnn.npz")
    np.savez(tmp_path / "n13.npz", **dict(arrays, joint_names=arrays["joint_names"][:13],
                                          chirality=np.zeros(715)))
    with pytest.raises(LifterError, match="not the 78 of 13 joints"):
        load_lifter(tmp_path / "n13.npz")
    with pytest.raises(LifterError, match="for 14 joints, the poses have 17"):
        load_lifter(lifter_path, n_joints=17)
    with pytest.raises(LifterError, match="no lifter called 'nope'"):
        load_lifter("nope")


# ------------------------------------------------------------------ CLI

def test_cli_lift_end_to_end(tmp_path, data, lifter_path, capsys):
    from sparseedm.keypoints import write_keypoints

    poses = data["poses2d"][:6].copy()
    poses[1, 4] = np.nan
    poses[2, 3:] = np.nan  # 3 observed: still lifted
    poses[3, 2:] = np.nan  # 2 observed: refused
    src = write_keypoints(tmp_path / "in.csv", poses, ids=[f"f{i}" for i in range(6)])
    out = tmp_path / "out.csv"
    assert main(["lift", str(src), "-o", str(out), "--lifter", str(lifter_path)]) == 1
    rows = list(csv.DictReader(open(out)))
    assert [r["status"] for r in rows] == ["lifted", "lifted_occluded", "lifted_occluded",
                                           "too_few_observed", "lifted", "lifted"]
    assert rows[0]["left_ankle_z"] != "" and rows[3]["left_ankle_z"] == ""
    errors = list(csv.DictReader(open(tmp_path / "out.errors.csv")))
    assert [(e["row"], e["id"]) for e in errors] == [("3", "f3")]
    for ext in ("npz", "json"):
        o = tmp_path / f"out.{ext}"
        assert main(["lift", str(src), "-o", str(o), "--lifter", str(lifter_path), "-q"]) == 1
    with np.load(tmp_path / "out.npz", allow_pickle=False) as npz:
        assert npz["poses3d"].shape == (6, 14, 3) and npz["status"][3] == "too_few_observed"
    doc = json.loads((tmp_path / "out.json").read_text())
    assert doc[3]["joints"] is None or doc[3]["joints"]["neck"] is None
    assert len(doc[0]["joints"]["neck"]) == 3
    capsys.readouterr()
    assert main(["info", str(lifter_path)]) == 0
    assert "lifter 'dictionary'" in capsys.readouterr().out


def test_cli_fit_lifter_and_refusals(tmp_path, fixtures_dir, capsys):
    out = tmp_path / "m.npz"
    assert main(["fit-lifter", str(fixtures_dir / "cmu_poses.npz"), "-o", str(out),
                 "--method", "mlp", "--hidden", "16", "--max-iter", "20"]) == 0
    assert load_lifter(out).method == "mlp"
    assert main(["fit-lifter", str(fixtures_dir / "cmu_poses.npz"), "-o", str(out),
                 "--method", "gnn"]) == 2
    assert "'gnn' is not available" in capsys.readouterr().err
    assert main(["lift", str(fixtures_dir / "cmu_poses.npz"), "-o", str(tmp_path / "x.csv"),
                 "--lifter", str(fixtures_dir / "cmu_02.asf")]) == 2
    capsys.readouterr()
    d = tmp_path / "d.npz"
    assert main(["fit-lifter", str(fixtures_dir / "cmu_poses.npz"), "-o", str(d), "--atoms",
                 "40", "--passes", "1", "--decoder-ridge", "none"]) == 0
    lf = load_lifter(d)
    assert lf.decoder_ridge is None and lf.n_passes == 1
    with pytest.raises(SystemExit):
        main(["fit-lifter", str(fixtures_dir / "cmu_poses.npz"), "-o", str(d),
              "--decoder-ridge", "-1"])
    assert "expected a number > 0 or 'none', got '-1'" in capsys.readouterr().err


def test_fit_refuses_bad_training_vectors():
    from sparseedm.lifting.dictionary import DictionaryLifter

    with pytest.raises(SparseEDMError, match="NaN"):
        DictionaryLifter(10).fit(np.full((20, 6), np.nan), np.ones((20, 6)))


def test_application_table_on_fixture(tmp_path, data, split, dict_lifter, mlp_lifter,
                                      small_dictionary):
    from sparseedm.lifting.evaluation import evaluate_lifting

    test = {k: v[split[1]] for k, v in data.items() if k != "joint_names"}
    rep = evaluate_lifting({"dictionary": dict_lifter, "mlp": mlp_lifter}, test,
                           dictionary=small_dictionary, train_poses2d=data["poses2d"][split[0]],
                           counts=(1, "mix"), pipelines=["complete", "as-is average",
                                                         "applyspar", "nearest", "joint"],
                           max_poses=40)
    got = {(r["lifter"], r["pipeline"], str(r["count"])) for r in rep.rows}
    assert ("dictionary", "joint", "mix") in got and ("mlp", "joint", "mix") not in got
    assert ("mlp", "applyspar", "1") in got and ("dictionary", "complete", "none") in got
    row = {(r["lifter"], r["pipeline"], str(r["count"])): r for r in rep.rows}
    assert row["dictionary", "joint", "mix"]["err3d"] < row["dictionary", "as-is average",
                                                             "mix"]["err3d"]
    assert {r["label"] for r in rep.per_action} <= set(VAL_CLIPS)
    written = rep.write(tmp_path)
    lines = (tmp_path / "lift_report.md").read_text().splitlines()
    assert sum(line.startswith("| dictionary |") for line in lines) == 5
    # the figure needs the [plot] extra; without it the report is written without it
    from sparseedm.plotting import have_matplotlib

    assert any(p.name == "lift_poses.png" for p in written) == have_matplotlib()


def test_application_table_survives_rows_recovery_could_not_fill(monkeypatch, data, split,
                                                                 dict_lifter, small_dictionary):
    import sparseedm.lifting.evaluation as ev

    real = ev.recover

    def failing(*args, **kwargs):  # the recovery fails on two rows
        res = real(*args, **kwargs)
        res.poses[[0, 3]] = np.nan
        return res

    monkeypatch.setattr(ev, "recover", failing)
    test = {k: v[split[1]] for k, v in data.items() if k != "joint_names"}
    rep = ev.evaluate_lifting({"dictionary": dict_lifter}, test, dictionary=small_dictionary,
                              counts=(1,), pipelines=["applyspar"], max_poses=12)
    (row,) = rep.rows
    assert np.isfinite(row["err3d"]) and row["n_poses"] == 12 and row["n_failed"] == 2
    assert any("2 of 12 poses could not be lifted" in n for n in rep.notes)
    # (n_failed counts rows without a lifted answer: scored from their stand-ins,
    # they would not be counted)


def test_lift_report_json_is_strict(tmp_path, strict_json):
    """lift_results.json writes a value that is not a number (no pose lifted, no
    reflection to judge) as null, not as a bare NaN that JSON.parse refuses."""
    from sparseedm.lifting.evaluation import COLUMNS, LiftReport

    nan = float("nan")
    row = dict(zip(COLUMNS, ("dictionary", "joint", "mix", 4, 4, nan, nan, nan, nan, nan,
                             np.float64(nan), np.float32(12.5))))
    rep = LiftReport([row], [dict(label="walk", lifter="dictionary", pipeline="joint",
                                  n_poses=0, err3d=np.float64(nan))], {},
                     dict(n_poses=4, data="test", seed=0, lifters={"dictionary": "d.npz"}))
    rep.write(tmp_path, figures=False)
    doc = strict_json((tmp_path / "lift_results.json").read_text())
    assert doc["rows"] == [dict(row, err3d=None, pa_mpjpe=None, n_mpjpe=None, mpjpe=None,
                                reflection_ok=None, ambiguous=None, poses_per_s=12.5)]
    assert doc["per_action"][0]["err3d"] is None


def test_shipped_default_lifter_loads_by_name():
    from sparseedm.lifting import available_lifters

    assert {"default", "cmu-lift"} <= set(available_lifters())
    lf = load_lifter("default")
    assert lf.method == "dictionary" and lf.n_joints == 14
    assert lf.provenance_["files"] == ["cmu.npz"]  # CMU only (lifters/README.md)
    assert 0.5 < lf.size_prior_ < 1.0


def test_cli_evaluate_lift(tmp_path, lifter_path, capsys):
    out = tmp_path / "rep"
    assert main(["evaluate-lift", "--data", str(CMU_POSES), "--lifter", str(lifter_path),
                 "--pipelines", "complete,as-is zero,joint", "--counts", "2,mix",
                 "--max-poses", "20", "-o", str(out)]) == 0
    assert "joint  mix  err3d" in capsys.readouterr().out
    doc = json.loads((out / "lift_results.json").read_text())
    assert len(doc["rows"]) == 5 and (out / "lift_report.md").is_file()


def test_cli_lift_never_writes_its_input(tmp_path, data, lifter_path):
    from sparseedm.keypoints import write_keypoints

    src = write_keypoints(tmp_path / "in.csv", data["poses2d"][:3])
    before = src.read_bytes()
    assert main(["lift", str(src), "-o", str(src), "--lifter", str(lifter_path)]) == 2
    out = tmp_path / "out.csv"
    assert main(["lift", str(src), "-o", str(out), "--errors", str(out),
                 "--lifter", str(lifter_path)]) == 2
    assert src.read_bytes() == before and not out.exists()


def test_whole_file_pickles_and_bad_meta_are_refused_by_name(tmp_path, lifter_path):
    from sparseedm.dictionary import load_dictionary
    from sparseedm.exceptions import DictionaryError, ModelError
    from sparseedm.fconv.model import load_model

    pk = tmp_path / "whole.npz"
    with open(pk, "wb") as f:
        pickle.dump({"meta": "{}"}, f, protocol=4)
    for loader, error in ((load_lifter, LifterError), (load_model, ModelError),
                          (load_dictionary, DictionaryError)):
        with pytest.raises(error, match="pickled data, which is refused"):
            loader(pk)
    with np.load(lifter_path, allow_pickle=False) as z:
        arrays = dict(z)
    for bad, said in ((np.array(5), "0-d string array"), (np.array("[1, 2]"), "got list")):
        path = tmp_path / "badmeta.npz"
        np.savez(path, **dict(arrays, meta=bad))
        with pytest.raises(LifterError, match=said):
            load_lifter(path)
