"""FConv (sparseedm.fconv): shapes, training, the model file, recovery, lifting, CLI.

The first test runs without torch; the others skip when it is absent.
"""

import json
import subprocess
import sys
import time

import numpy as np
import pytest

from sparseedm.edm import observed_entries, pose_to_vector
from sparseedm.exceptions import ModelError, PoseError, SparseEDMError
from sparseedm.metrics import random_occlusion
from sparseedm.normalize import normalize, represent


def test_core_never_imports_torch():
    code = (
        "import sys, numpy as np, sparseedm, sparseedm.fconv\n"
        "p = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78], [65, 32], [70, 55],"
        " [72, 78], [40, 80], [40, 115], [40, 150], [60, 80], [60, 115], [60, 150]], float)\n"
        "p[4] = np.nan\n"
        "assert sparseedm.recover(p).status[0] == 'recovered'\n"
        "assert 'torch' not in sys.modules, 'torch was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


torch = pytest.importorskip("torch", reason="needs the [torch] extra")

from sparseedm import recover  # noqa: E402
from sparseedm.fconv import (FConvModel, fit_edm_lifter, fit_fconv, lift_edm_vectors,  # noqa: E402
                             load_model)
from sparseedm.fconv.network import build_network, param_shapes  # noqa: E402
from sparseedm.fconv.training import _recover_pairs  # noqa: E402

SMALL = dict(channels=(8, 16), batch_size=32, learning_rate=3e-3, random_state=0)


@pytest.fixture(scope="module", autouse=True)
def one_thread():
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


@pytest.fixture(scope="module")
def clips():
    from tests.conftest import CMU_POSES

    with np.load(CMU_POSES, allow_pickle=False) as d:
        return d["clips"], d["poses3d"]


@pytest.fixture(scope="module")
def trained(cmu_poses, clips):
    return fit_fconv(cmu_poses, clips[0], representation="zero", max_epochs=6, **SMALL)


@pytest.mark.parametrize("n_joints", [14, 9, 17])
@pytest.mark.parametrize("symmetrize", [False, True])
def test_network_shapes(n_joints, symmetrize):
    net = build_network(n_joints, (4, 8), 3, symmetrize)
    y = net(torch.zeros(5, 1, n_joints, n_joints))
    assert y.shape == (5, 1, n_joints, n_joints)
    assert {k: tuple(v.shape) for k, v in net.state_dict().items()} == param_shapes((4, 8))
    if symmetrize:
        y = net(torch.rand(2, 1, n_joints, n_joints))
        assert torch.equal(y, y.transpose(-1, -2))


def test_training_lowers_validation_loss(trained):
    t = trained.meta["training"]
    val = [h[1] for h in t["history"]]
    assert t["validation"].startswith("by clip")
    assert t["best_val_loss"] == min(val) and min(val) < 0.5 * val[0]
    assert trained.predict(np.zeros((3, 91))).shape == (3, 91)


def test_training_is_seeded(cmu_poses, clips):
    a = fit_fconv(cmu_poses, clips[0], max_epochs=1, **SMALL)
    b = fit_fconv(cmu_poses, clips[0], max_epochs=1, **SMALL)
    assert all(np.array_equal(a.params[k], b.params[k]) for k in a.params)


def test_save_load_round_trip_bit_for_bit(trained, cmu_poses, tmp_path):
    path = trained.save(tmp_path / "m.npz")
    again = load_model(path, n_joints=14, representation="zero", kind="recover")
    assert again.meta == json.loads(json.dumps(trained.meta))
    X = represent(cmu_poses[:50], random_occlusion(50, 14, "mix", random_state=1), "zero")[0]
    assert np.array_equal(trained.predict(X), again.predict(X))
    occluded = np.where(random_occlusion(50, 14, 2, random_state=2)[..., None], np.nan,
                        cmu_poses[:50])
    r1 = recover(occluded, method="fconv", model=trained, representation="zero")
    r2 = recover(occluded, method="fconv", model=path, representation="zero")
    assert np.array_equal(r1.poses, r2.poses) and np.array_equal(r1.vectors, r2.vectors)


@pytest.mark.parametrize("rep", ["zero", "average"])
def test_inputs_built_as_normalize_builds_them(cmu_poses, rep):
    poses = cmu_poses[:40]
    mask = random_occlusion(40, 14, "mix", random_state=3)
    X, target = _recover_pairs(poses, mask, rep)
    # by hand: normalise by the observed joints' box, as sparseedm.normalize does
    if rep == "zero":
        normed, c, s = normalize(poses, mask)
        expect = np.where(observed_entries(mask), pose_to_vector(np.where(
            mask[..., None], 0.0, normed)), 0.0)
    else:
        mean = np.where(mask[..., None], 0, poses).sum(1) / (~mask).sum(1)[:, None]
        normed, c, s = normalize(np.where(mask[..., None], mean[:, None], poses))
        expect = pose_to_vector(normed)
    np.testing.assert_array_equal(X, represent(poses, mask, rep)[0])
    np.testing.assert_allclose(X, expect, atol=1e-12)
    np.testing.assert_allclose(target, pose_to_vector(normalize(poses, mask)[0]), atol=1e-12)


def test_recover_fconv_result(trained, cmu_poses):
    poses = cmu_poses[:6].copy()
    mask = np.zeros((6, 14), bool)
    mask[0, [1, 4]] = True
    mask[1, :12] = True          # too few observed
    poses[2, 3] = np.inf         # invalid
    mask[3, 7] = True
    # 4 complete
    mask[5, 0] = True
    res = recover(np.where(mask[..., None], np.nan, poses), mask, method="fconv",
                  model=trained, representation="zero")
    assert res.status.tolist() == ["recovered", "too_few_observed", "invalid_coordinates",
                                   "recovered", "complete", "recovered"]
    ok = res.status == "recovered"
    T = represent(np.where(mask[..., None], np.nan, poses)[ok], mask[ok], "zero")[0]
    keep = observed_entries(mask[ok])
    assert np.array_equal(res.vectors[ok][keep], T[keep])           # Eq. 10
    assert np.array_equal(res.poses[ok][~mask[ok]], poses[ok][~mask[ok]])
    assert np.isfinite(res.poses[ok]).all() and np.isnan(res.poses[1]).all()


def test_bad_model_files(trained, tmp_path):
    path = trained.save(tmp_path / "m.npz")
    with pytest.raises(ModelError, match="14 joints"):
        load_model(path, n_joints=13)
    with pytest.raises(ModelError, match="for 14 joints, the data has 13"):
        recover(np.zeros((2, 13, 2)), method="fconv", model=path, representation="zero")
    with pytest.raises(ModelError, match="'zero' inputs"):
        recover(np.zeros((1, 14, 2)), method="fconv", model=path, representation="average")
    with pytest.raises(ModelError, match="'lift' model is needed"):
        lift_edm_vectors(path, np.zeros((1, 14, 2)))
    cut = tmp_path / "cut.npz"
    cut.write_bytes(path.read_bytes()[:300])
    with pytest.raises(ModelError, match="truncated"):
        load_model(cut)
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, meta=np.array({"a": 1}, dtype=object))
    with pytest.raises(ModelError, match="pickled"):
        load_model(pickled)
    with pytest.raises(ModelError, match="no such"):
        load_model(tmp_path / "absent.npz")
    params = dict(trained.params, **{"enc1.weight": np.zeros((3, 1, 3, 3), np.float32)})
    bad = tmp_path / "shape.npz"
    np.savez(bad, meta=np.array(json.dumps(trained.meta)),
             **{"param." + k: v for k, v in params.items()})
    with pytest.raises(ModelError, match="enc1.weight has shape"):
        load_model(bad)
    with pytest.raises(SparseEDMError, match="needs model="):
        recover(np.zeros((1, 14, 2)), method="fconv")
    with pytest.raises(SparseEDMError, match="method must be one of"):
        recover(np.zeros((1, 14, 2)), method="cnn")


def test_bad_training_input_fails_before_any_epoch(cmu_poses):
    nan = cmu_poses[:100].copy()
    nan[17, 3, 0] = np.nan
    t0 = time.perf_counter()
    with pytest.raises(PoseError, match="first row 17"):
        fit_fconv(nan, **SMALL)
    with pytest.raises(SparseEDMError, match="fewer than one batch"):
        fit_fconv(cmu_poses[:30], **SMALL)
    with pytest.raises(SparseEDMError, match="device"):
        fit_fconv(cmu_poses, device="no-such-device", **SMALL)
    assert time.perf_counter() - t0 < 10


def test_lifter_learns_3d_edms(cmu_poses, clips):
    model = fit_edm_lifter(cmu_poses, clips[1], clips[0], occluded=(0, 1), max_epochs=4, **SMALL)
    val = [h[1] for h in model.meta["training"]["history"]]
    assert model.kind == "lift" and min(val) < 0.5 * val[0]
    occluded = cmu_poses[:5].copy()
    occluded[0, 2] = np.nan
    occluded[1, :12] = np.nan    # too few observed: NaN row
    out = lift_edm_vectors(model, occluded)
    assert out.shape == (5, 91)
    assert np.isnan(out[1]).all() and np.isfinite(out[[0, 2, 3, 4]]).all()


def test_cli_fit_cnn_recover_evaluate(tmp_path, fixtures_dir, capsys):
    from sparseedm.cli import main

    model = tmp_path / "fconv.npz"
    assert main(["fit-cnn", str(fixtures_dir / "cmu_poses.npz"), "-o", str(model),
                 "--representation", "zero", "--channels", "4,8", "--batch-size", "32",
                 "--epochs", "2", "-q"]) == 0
    assert load_model(model).representation == "zero"
    assert main(["info", str(model)]) == 0
    assert "FConv recover model" in capsys.readouterr().out
    with np.load(fixtures_dir / "cmu_poses.npz") as d:
        poses = d["poses2d"][:10].copy()
    poses[:, 5] = np.nan
    np.savez(tmp_path / "kp.npz", poses=poses)
    args = ["recover", str(tmp_path / "kp.npz"), "-o", str(tmp_path / "out.npz"), "-q",
            "--method", "fconv", "--model", str(model)]
    assert main(args + ["--representation", "average"]) == 2  # the model is 'zero'
    assert not (tmp_path / "out.npz").exists()
    assert main(args) == 0  # by default, the model's own representation
    with np.load(tmp_path / "out.npz") as out:
        assert np.isfinite(out["poses"]).all()
    assert main(["evaluate", "--data", str(fixtures_dir / "cmu_poses.npz"), "--methods",
                 "mean-fill", "--counts", "mix", "--fconv-model", str(model), "--max-poses",
                 "40", "-o", str(tmp_path / "rep")]) == 0
    text = (tmp_path / "rep" / "results.csv").read_text()
    assert "fconv,zero,mix,40," in text
