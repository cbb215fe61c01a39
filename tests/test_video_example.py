"""The shipped video example (examples/video_clip.csv): read with time, filled
across time better than a spline or the pose model alone, and reproducible."""

from pathlib import Path

import numpy as np
import pytest

import sparseedm
from sparseedm.keypoints import read_keypoints
from sparseedm.metrics import joint_error
from sparseedm.temporal.fillers import fill_akima

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def clip():
    kps = read_keypoints(EXAMPLES / "video_clip.csv")
    with np.load(EXAMPLES / "video_clip_truth.npz", allow_pickle=False) as truth:
        return kps, truth["poses2d"], truth["missing"]


def _error(poses, truth, missing):
    return float(np.nanmean(joint_error(poses, truth, missing)))


def test_the_example_is_two_tracks_with_hidden_runs(clip):
    kps, truth, missing = clip
    assert sorted(set(kps.tracks)) == ["02_01", "02_05"]
    assert kps.frames is not None and (kps.missing == missing).all()
    assert np.isnan(kps.poses[missing]).all()
    np.testing.assert_array_equal(kps.poses[~missing], truth[~missing])
    assert (missing.sum(axis=0) >= 50).any()     # a joint hidden for long runs


def test_its_docs_say_what_it_holds(clip):
    """examples/README.md and make_video_example.py's docstring: the clips as
    ../shared/data/README.md names them (02_05 is punch/strike), each track's
    length, and the extra a --plot command needs."""
    kps = clip[0]
    lengths = {t: int((kps.tracks == t).sum()) for t in ("02_01", "02_05")}
    assert lengths == {"02_01": 86, "02_05": 150}
    readme = (EXAMPLES / "README.md").read_text()
    doc = (EXAMPLES / "make_video_example.py").read_text().split('"""')[1]
    for text in (readme, doc):
        assert "punch/strike" in text and "dance" not in text
    assert "02_01 walk, 86 frames" in readme and "02_05 punch/strike, its first 150" in readme
    assert "the tracks have 86 and 150" in " ".join(doc.split())
    for line in readme.splitlines():
        if "--plot" in line:
            assert "[plot]" in line or "[test,plot]" in line, line


def test_time_fills_it_better_than_a_spline_or_each_frame_alone(clip):
    """What examples/README.md says of its example, with defaults: the shipped dictionary
    (it learned from these clips; the small test dictionary of 334 poses fills
    the example worse than Akima: 5.75 against 4.21 px)."""
    kps, truth, missing = clip
    res = sparseedm.recover(kps.poses, kps.missing, tracks=kps.tracks, frames=kps.frames)
    per_frame = sparseedm.recover(kps.poses, kps.missing)
    akima = np.empty_like(truth)
    for track in np.unique(kps.tracks):
        rows = kps.tracks == track
        akima[rows] = fill_akima(kps.poses[rows], kps.missing[rows], kps.frames[rows])
    assert res.ok.all() and res.summary()["temporal"]
    np.testing.assert_array_equal(res.poses[~missing], truth[~missing])
    err = _error(res.poses, truth, missing)
    assert err < _error(akima, truth, missing)
    assert err < _error(per_frame.poses, truth, missing)


def test_the_example_is_rebuilt_identically(shared_data, tmp_path, monkeypatch):
    """examples/make_video_example.py regenerates both files byte for byte."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_video_example",
                                                  EXAMPLES / "make_video_example.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "OUTPUT", tmp_path / "video_clip.csv")
    monkeypatch.setattr(module, "TRUTH", tmp_path / "video_clip_truth.npz")
    monkeypatch.setattr("sys.argv", ["make_video_example.py", "--data-dir", str(shared_data)])
    module.main()
    assert (tmp_path / "video_clip.csv").read_bytes() == (EXAMPLES / "video_clip.csv").read_bytes()
    with np.load(tmp_path / "video_clip_truth.npz", allow_pickle=False) as new, \
            np.load(EXAMPLES / "video_clip_truth.npz", allow_pickle=False) as old:
        for name in ("poses2d", "missing"):
            np.testing.assert_array_equal(new[name], old[name])

