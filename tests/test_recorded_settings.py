"""A model or lifter file that records how it was trained is used that way:
``representation=None`` (the default) is the file's own, another one is refused."""

import numpy as np
import pytest

from sparseedm import lift, recover
from sparseedm.exceptions import ModelError, ParameterError
from sparseedm.fconv.model import FConvModel
from sparseedm.fconv.network import param_shapes
from sparseedm.lifting import load_lifter
from sparseedm.metrics import random_occlusion
from sparseedm.normalize import represent


def _zero_model(tmp_path):
    """An FConv recovery model trained (so its file says) on 'zero' inputs."""
    params = {k: np.zeros(s, np.float32) for k, s in param_shapes((4, 8)).items()}
    model = FConvModel(params, {"kind": "recover", "n_joints": 14, "representation": "zero",
                                "channels": [4, 8], "kernel": 3, "symmetrize": False})
    return model.save(tmp_path / "zero.npz")


@pytest.fixture
def seen(monkeypatch):
    """The vectors the FConv network is given (it answers them back: no torch needed)."""
    got = []

    def predict(self, X, *, batch_size=4096):
        got.append(np.array(X))
        return np.array(X)

    monkeypatch.setattr(FConvModel, "predict", predict)
    return got


def test_recover_uses_the_models_own_representation(cmu_poses, tmp_path, seen):
    path = _zero_model(tmp_path)
    mask = random_occlusion(20, 14, 2, random_state=0)
    occluded = np.where(mask[..., None], np.nan, cmu_poses[:20])
    res = recover(occluded, method="fconv", model=path)
    assert (res.status == "recovered").all()
    np.testing.assert_array_equal(seen[-1], represent(occluded, mask, "zero")[0])
    assert not np.array_equal(seen[-1], represent(occluded, mask, "average")[0])
    again = recover(occluded, method="fconv", model=path, representation="zero")
    np.testing.assert_array_equal(again.poses, res.poses)
    with pytest.raises(ModelError, match="trained on 'zero' inputs, not 'average': leave "
                       "representation"):
        recover(occluded, method="fconv", model=path, representation="average")


def test_recover_command_uses_the_models_own_representation(cmu_poses, tmp_path, seen,
                                                             monkeypatch, capsys):
    import sparseedm._extras as extras
    from sparseedm.cli import main

    monkeypatch.setattr(extras, "have", lambda extra: True)  # torch is not needed here
    path = _zero_model(tmp_path)
    poses = cmu_poses[:10].copy()
    poses[:, 4] = np.nan
    src = tmp_path / "in.npy"
    np.save(src, poses)
    argv = ["recover", str(src), "--method", "fconv", "--model", str(path), "-q"]
    assert main(argv + ["-o", str(tmp_path / "a.npy")]) == 0
    np.testing.assert_array_equal(seen[-1], represent(poses, None, "zero")[0])
    assert main(argv + ["-o", str(tmp_path / "b.npy"), "--representation", "average"]) == 2
    assert "trained on 'zero' inputs, not 'average'" in capsys.readouterr().err
    assert not (tmp_path / "b.npy").exists()


def test_lift_uses_the_lifters_own_representation(cmu_poses, monkeypatch):
    lifter = load_lifter(None)
    lifter.representation = "zero"  # as an FConv lifter's file records it
    lifter.codes_observed_only = False
    got = []
    real = type(lifter).predict

    def predict(X2, missing=None, *, n_jobs=1):
        got.append(np.array(X2))
        return real(lifter, X2, missing, n_jobs=n_jobs)

    monkeypatch.setattr(lifter, "predict", predict)
    poses = cmu_poses[:3].copy()
    poses[:, 7] = np.nan
    mask = np.isnan(poses).any(axis=-1)
    lift(poses, lifter=lifter)
    np.testing.assert_array_equal(got[-1], represent(poses, mask, "zero")[0])
    with pytest.raises(ParameterError, match="trained on 'zero' inputs, not 'average'"):
        lift(poses, lifter=lifter, representation="average")
    lifter.representation = None  # trained on complete poses: the caller's, else average
    lift(poses, lifter=lifter)
    np.testing.assert_array_equal(got[-1], represent(poses, mask, "average")[0])
