"""Batch recovery on a Dask cluster equals the local run."""

import numpy as np
import pytest

from sparseedm import recover
from sparseedm.exceptions import SparseEDMError
from sparseedm.metrics import random_occlusion

distributed = pytest.importorskip("distributed", reason="needs the [dask] extra")

from tests.test_adaptation import cross_domain, shifted_dictionary  # noqa: E402,F401


def test_local_cluster_two_workers_equals_local_run(cmu_poses, small_dictionary):
    poses = cmu_poses[:120]
    mask = random_occlusion(len(poses), 14, "mix", random_state=5)
    local = recover(poses, mask, dictionary=small_dictionary, chunk_size=16)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=":0") as cluster:
        remote = recover(poses, mask, dictionary=small_dictionary, chunk_size=16,
                         backend="dask", scheduler=cluster.scheduler_address)
    np.testing.assert_array_equal(remote.poses, local.poses)
    np.testing.assert_array_equal(remote.vectors, local.vectors)
    np.testing.assert_array_equal(remote.status, local.status)


def test_dask_without_scheduler_or_client_is_a_clear_error(cmu_poses, small_dictionary):
    mask = random_occlusion(4, 14, 1, random_state=0)
    with pytest.raises(SparseEDMError, match="scheduler"):
        recover(cmu_poses[:4], mask, dictionary=small_dictionary, backend="dask")


@pytest.mark.parametrize("address", ["inproc://x", "foo://host:1", "tcp://"])
def test_a_scheduler_address_the_client_cannot_use_is_bad_input(address, tmp_path, capsys,
                                                                cmu_poses,
                                                                small_dictionary_path):
    from sparseedm.cli import main
    from sparseedm.keypoints import write_keypoints

    poses = cmu_poses[:4].copy()
    poses[:, 4] = np.nan
    src = tmp_path / "in.csv"
    write_keypoints(src, poses)
    code = main(["recover", str(src), "-o", str(tmp_path / "out.csv"), "--dictionary",
                 str(small_dictionary_path), "--no-adapt", "--backend", "dask",
                 "--scheduler", address])
    err = capsys.readouterr().err
    assert code == 2, err
    assert f"scheduler {address!r} is not an address" in err and "internal" not in err
    assert not (tmp_path / "out.csv").exists()


@pytest.fixture
def round_backends(monkeypatch):
    """The backend each self-training round's recovery is called with, in call order (a spy)."""
    from sparseedm import adaptation

    seen, inner = [], adaptation.recover_sparse

    def spy(*args, **kwargs):
        seen.append(kwargs.get("backend"))
        return inner(*args, **kwargs)

    monkeypatch.setattr(adaptation, "recover_sparse", spy)
    return seen


def test_the_default_path_adaptation_included_runs_on_the_cluster(cross_domain,
                                                                   shifted_dictionary,
                                                                   round_backends):
    adapt_on, inputs, mask, _ = cross_domain  # the dictionary's wrong domain: adopted
    kw = dict(dictionary=shifted_dictionary, adapt=adapt_on, self_training=2, chunk_size=16)
    local = recover(inputs, mask, **kw)
    assert local.adapted and len(local.adaptation.self_training) == 2

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        with distributed.get_task_stream(client) as adapted_run:
            remote = recover(inputs, mask, backend="dask", **kw)
        with distributed.get_task_stream(client) as final_only:
            recover(inputs, mask, dictionary=remote.adaptation.dictionary, adapt=False,
                    chunk_size=16, backend="dask")
    assert round_backends == [None, None, "dask", "dask"]  # the local run, then the cluster
    # the guard's and the rounds' recoveries were tasks too, not only the final one's
    assert len(adapted_run.data) > len(final_only.data) > 0
    np.testing.assert_allclose(remote.poses, local.poses, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(remote.status, local.status)
    assert remote.adaptation.self_training == local.adaptation.self_training
    assert remote.adaptation.err_adapted == pytest.approx(local.adaptation.err_adapted,
                                                          abs=1e-9)


def test_recover_file_adapts_on_the_cluster_too(cross_domain, shifted_dictionary, tmp_path,
                                                round_backends):
    from sparseedm.batch import recover_file
    from sparseedm.keypoints import read_keypoints, write_keypoints

    adapt_on, inputs, _, _ = cross_domain  # one file: 260 complete poses, 74 occluded
    src = tmp_path / "in.npz"
    write_keypoints(src, np.concatenate([adapt_on, inputs]))
    # exemplars=False: adaptation itself (the file's 260 complete poses might
    # otherwise be taken as its atoms: sparseedm.exemplars)
    kw = dict(dictionary=shifted_dictionary, self_training=2, temporal=False,
              exemplars=False)
    recover_file(src, tmp_path / "local.npz", **kw)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster):
        recover_file(src, tmp_path / "remote.npz", backend="dask", **kw)
    assert round_backends == [None, None, "dask", "dask"]  # the local run, then the cluster
    local = read_keypoints(tmp_path / "local.npz").poses
    remote = read_keypoints(tmp_path / "remote.npz").poses
    np.testing.assert_allclose(remote, local, rtol=0, atol=1e-9)
