"""Batch recovery on a Dask cluster equals the local run."""

import numpy as np
import pytest

from sparseedm import recover
from sparseedm.exceptions import SparseEDMError
from sparseedm.metrics import random_occlusion

distributed = pytest.importorskip("distributed", reason="needs the [dask] extra")


def test_local_cluster_two_workers_equals_local_run(cmu_poses, small_dictionary):
    poses = cmu_poses[:120]
    mask = random_occlusion(len(poses), 14, "mix", random_state=5)
    local = recover(poses, mask, dictionary=small_dictionary, chunk_size=16)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
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
