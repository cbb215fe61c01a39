"""The fconv lifter (DMR's FConv 2D -> 3D network) and the FConv rows of the application table."""

import json
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

from sparseedm.cli import main
from sparseedm.exceptions import SparseEDMError
from sparseedm.lifting import LifterError, fit_lifter, lift, load_lifter, training_pairs
from sparseedm.lifting.metrics import err_ave_3d

CMU_POSES = Path(__file__).resolve().parent / "fixtures" / "cmu_poses.npz"
SMALL = dict(channels=(8, 16), batch_size=32, learning_rate=3e-3, max_epochs=2)


def test_fit_lifter_fconv_without_torch_names_the_extra(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "torch", None)  # import torch -> ImportError
    assert main(["fit-lifter", str(CMU_POSES), "-o", str(tmp_path / "f.npz"),
                 "--method", "fconv"]) == 2
    assert "sparseedm[torch]" in capsys.readouterr().err
    assert not (tmp_path / "f.npz").exists()


def test_application_table_skips_fconv_rows_without_torch_or_models(monkeypatch):
    from sparseedm.lifting.evaluation import _torch_rows

    notes = []
    _, pipes = _torch_rows({}, ["complete", "applyzero", "ave+basl"], {}, {}, notes)
    assert pipes == ["complete"] and len(notes) == 2 and "fit-cnn" in notes[0]
    monkeypatch.setitem(sys.modules, "torch", None)

    class Fake:
        method = "fconv"

    notes = []
    lifters, _ = _torch_rows({"fconv": Fake(), "x": type("D", (), {"method": "mlp"})()},
                             ["complete"], {}, {}, notes)
    assert list(lifters) == ["x"] and "PyTorch is not installed" in notes[0]


torch = pytest.importorskip("torch", reason="needs the [torch] extra")

from tests.test_fconv import one_thread  # noqa: E402,F401  (autouse: torch on 1 thread)
from tests.test_lifting import _arrays, data, split  # noqa: E402,F401  (fixture poses, clip split)



@pytest.fixture(scope="module")
def fconv_lifter(data, split):
    tr = split[0]
    return fit_lifter(*_arrays(data, tr), method="fconv", clips=data["clips"][tr],
                      provenance={"files": ["cmu_poses.npz"]}, channels=(16, 32), batch_size=16,
                      max_epochs=25, patience=25)


@pytest.fixture(scope="module")
def lifter_path(fconv_lifter, tmp_path_factory):
    return fconv_lifter.save(tmp_path_factory.mktemp("fconv-lifter") / "fconv.npz")


def test_fconv_lifter_learns_tied_3d_edms(data, split, fconv_lifter):
    hist = np.array(fconv_lifter.provenance_["training"]["history"])
    assert hist[:, 1].min() < 0.7 * hist[0, 1]  # validation loss went down
    assert "by clip" in fconv_lifter.provenance_["training"]["validation"]
    X2, X3, _, _ = training_pairs(*_arrays(data, split[1]))
    _, X3_train, _, _ = training_pairs(*_arrays(data, split[0]))
    Y, info = fconv_lifter.predict(X2)
    assert (info["status"] == "optimal").all()
    mean_pose = np.broadcast_to(X3_train.mean(axis=0), X3.shape)
    # 220 training poses only: beating the mean training pose is what can be asked
    assert err_ave_3d(Y, X3).mean() < 0.9 * err_ave_3d(mean_pose, X3).mean()


def test_lift_with_statuses(data, split, fconv_lifter):
    poses = data["poses2d"][split[1][:5]].copy()
    poses[1, 4] = np.nan
    poses[2, 2:] = np.nan  # 2 observed: refused
    poses[3, 0, 0] = np.inf  # observed joint not finite: refused
    res = lift(poses, lifter=fconv_lifter)
    assert res.status.tolist() == ["lifted", "lifted_occluded", "too_few_observed",
                                   "invalid_coordinates", "lifted"]
    assert np.isfinite(res.poses3d[[0, 1, 4]]).all() and np.isnan(res.poses3d[[2, 3]]).all()
    assert 1.0 < np.ptp(res.poses3d[0, :, 1]) < 2.5  # a person's height in metres


def test_round_trip_bit_for_bit(data, split, fconv_lifter, lifter_path):
    back = load_lifter(lifter_path)
    assert back.method == "fconv" and back.n_joints == 14
    X2, _, _, _ = training_pairs(*_arrays(data, split[1][:40]))
    a, b = fconv_lifter.predict(X2)[0], back.predict(X2)[0]
    assert np.array_equal(a, b)
    for k, v in fconv_lifter.model_.params.items():
        assert np.array_equal(v, back.model_.params[k]) and back.model_.params[k].dtype == np.float32
    assert back.size_prior_ == fconv_lifter.size_prior_
    assert back.provenance_["training"]["epochs"] == fconv_lifter.provenance_["training"]["epochs"]
    assert np.array_equal(lift(data["poses2d"][:3], lifter=back).poses3d,
                          lift(data["poses2d"][:3], lifter=fconv_lifter).poses3d)
    with np.load(lifter_path, allow_pickle=False) as npz:
        assert all(npz[k].dtype != object for k in npz.files)


def test_refuses_wrong_n_pickled_truncated_and_bad_weights(tmp_path, lifter_path):
    with np.load(lifter_path, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    np.savez(tmp_path / "n13.npz", **dict(arrays, joint_names=arrays["joint_names"][:13],
                                          chirality=np.zeros(715)))
    with pytest.raises(LifterError, match="trained for 14 joints, the file names 13"):
        load_lifter(tmp_path / "n13.npz")
    with pytest.raises(LifterError, match="for 14 joints, the poses have 17"):
        load_lifter(lifter_path, n_joints=17)
    pk = tmp_path / "pickled.npz"
    pk.write_bytes(pickle.dumps(arrays))
    with pytest.raises(LifterError, match="pickled"):
        load_lifter(pk)
    cut = tmp_path / "truncated.npz"
    cut.write_bytes(lifter_path.read_bytes()[:700])
    with pytest.raises(LifterError, match="corrupt or truncated"):
        load_lifter(cut)
    f64 = {k: (v.astype(np.float64) if k.startswith("param.") else v) for k, v in arrays.items()}
    np.savez(tmp_path / "f64.npz", **f64)
    with pytest.raises(LifterError, match="must be float32"):
        load_lifter(tmp_path / "f64.npz")
    short = {k: (v[:2] if k == "param.enc2.weight" else v) for k, v in arrays.items()}
    np.savez(tmp_path / "short.npz", **short)
    with pytest.raises(LifterError, match="enc2.weight"):
        load_lifter(tmp_path / "short.npz")
    meta = json.loads(str(arrays["meta"]))
    del meta["params"]["n_joints_network"]
    np.savez(tmp_path / "nometa.npz", **dict(arrays, meta=np.array(json.dumps(meta))))
    with pytest.raises(LifterError, match="incomplete or invalid"):
        load_lifter(tmp_path / "nometa.npz")


def test_occluded_training_needs_poses_and_zero_input_is_built_from_average(data, split):
    from sparseedm.lifting.fconv import FConvNetLifter

    X2, X3, _, _ = training_pairs(*_arrays(data, split[0]))
    with pytest.raises(SparseEDMError, match="needs the 2D poses"):
        FConvNetLifter(occluded=(1, 3)).fit(X2, X3)
    lf = fit_lifter(*_arrays(data, split[0]), method="fconv", representation="zero",
                    occluded=(1, 3), **SMALL)
    assert lf.provenance_["training"]["validation"].startswith("by row")  # no clips given
    from sparseedm.normalize import represent

    p = data["poses2d"][split[1][:6]]
    mask = np.zeros((6, 14), bool)
    mask[:, 3] = True
    zero = represent(p, mask, "zero")[0]
    ave = represent(p, mask, "average")[0]
    assert np.array_equal(lf.predict(ave, mask)[0], lf.predict(zero)[0])


def test_application_table_fconv_rows(data, split, fconv_lifter, tmp_path):
    from sparseedm.fconv import fit_fconv
    from sparseedm.lifting.evaluation import evaluate_lifting

    tr, val = split
    models = {rep: fit_fconv(data["poses2d"][tr], data["clips"][tr], representation=rep,
                             **SMALL) for rep in ("zero", "average")}
    basl = fit_lifter(*_arrays(data, tr), method="fconv", representation="zero",
                      occluded=(1, 3), clips=data["clips"][tr], **SMALL)
    test = {k: v[val] for k, v in data.items() if k != "joint_names"}
    rep = evaluate_lifting({"fconv": fconv_lifter}, test, counts=(1, "mix"), max_poses=30,
                           pipelines=["complete", "as-is zero", "applyzero", "applyave",
                                      "zero+basl", "ave+basl"],
                           fconv_models=models, retrained={"zero": basl})
    got = {(r["lifter"], r["pipeline"], str(r["count"])) for r in rep.rows}
    assert {("fconv", p, c) for p in ("applyzero", "applyave", "zero+basl", "as-is zero")
            for c in ("1", "mix")} <= got
    assert not any(p == "ave+basl" for _, p, _ in got)
    assert any("ave+basl skipped" in n for n in rep.notes)
    row = {(r["lifter"], r["pipeline"], str(r["count"])): r for r in rep.rows}
    assert all(np.isfinite(row["fconv", p, "mix"]["err3d"]) for p in ("applyzero", "zero+basl"))
    # recovering first beats lifting the occluded 'zero' EDM as is
    assert row["fconv", "applyzero", "mix"]["err3d"] < row["fconv", "as-is zero", "mix"]["err3d"]
    rep.write(tmp_path, figures=False)
    assert "| fconv | zero+basl |" in (tmp_path / "lift_report.md").read_text()


def test_cli_fit_lifter_fconv_info_and_evaluate(tmp_path, capsys):
    out = tmp_path / "f.npz"
    assert main(["fit-lifter", str(CMU_POSES), "-o", str(out), "--method", "fconv",
                 "--channels", "4,8", "--epochs", "1", "--batch-size", "32",
                 "--occluded", "0-2", "--representation", "zero"]) == 0
    lf = load_lifter(out)
    assert (lf.method, lf.representation, lf.occluded, lf.channels) == ("fconv", "zero",
                                                                         (0, 2), (4, 8))
    assert "by clip" in lf.provenance_["training"]["validation"]  # the file's clips were used
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    assert "lifter 'fconv'" in capsys.readouterr().out
    rep = tmp_path / "rep"
    assert main(["evaluate-lift", "--data", str(CMU_POSES), "--lifter", str(out),
                 "--fconv", str(out), "--basl-zero", str(out), "--pipelines",
                 "complete,zero+basl,applyave", "--counts", "mix", "--max-poses", "10",
                 "-o", str(rep)]) == 0
    io = capsys.readouterr()
    assert "zero+basl  mix" in io.out and "applyave skipped" in io.err
