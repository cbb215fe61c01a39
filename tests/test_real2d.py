"""benchmarks/real2d.py reads every hand-annotated set of ../shared/data/real2d sanely."""

import numpy as np
import pytest


@pytest.mark.parametrize("source", ["bonn", "mpii", "coco", "flic"])
def test_real2d_sources_load_with_sane_shapes_and_splits(shared_data, source):
    if source in ("mpii", "flic"):  # HDF5 files
        pytest.importorskip("h5py", reason="needs the [real] extra (h5py)")
    from benchmarks import real2d

    if not real2d.available(shared_data / "real2d"):
        pytest.skip(f"no {shared_data / 'real2d'}")
    d = real2d.load(source, shared_data / "real2d")
    n = len(d)
    assert n > 100 and d.poses.shape == (n, 14, 2)
    assert d.visible.shape == d.annotated.shape == (n, 14)
    assert not (d.visible & ~d.annotated).any()            # visible implies annotated
    assert d.group.shape == d.head_size.shape == (n,)
    parts = real2d.split(d)
    assert set(parts) <= {"train", "val", "test"} and {"val", "test"} <= set(parts)
    groups = {p: set(d.group[parts == p]) for p in ("train", "val", "test")}
    assert not (groups["train"] & groups["val"] or groups["train"] & groups["test"]
                or groups["val"] & groups["test"])       # no image or video in two splits
    if source == "flic":
        assert not d.complete.any()                          # upper bodies only
        return
    assert d.complete.sum() > 50
    c = d.poses[d.complete]
    assert np.all(real2d.body_size(c) > 0)
    upright = c[:, 0, 1] < c[:, [10, 13], 1].mean(axis=1)   # image y points down
    assert upright.mean() > 0.8                              # most people stand or walk
    if source == "bonn":
        assert d.tracks.shape == d.frames.shape == (n,)
        assert np.isfinite(d.head_size).mean() > 0.3
        key = np.char.add(np.char.add(d.group, "/"), d.tracks.astype(str))
        for k in np.unique(key)[:20]:                        # one pose per frame per track
            f = d.frames[key == k]
            assert len(np.unique(f)) == len(f)
    if source == "mpii":
        assert np.isfinite(d.head_size).all() and (d.head_size > 0).all()
