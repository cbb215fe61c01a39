"""Calls that can run for minutes over a big file say what they are doing.

recover_fconv shows a bar over its chunks with ``progress=True`` (as the sparse
path does) and, with progress on (the command line's :func:`_progress.enable`),
a line; the video and real-people evaluations tell each sequence / clip /
method. Off by default: the API stays silent.
"""

import io
from types import SimpleNamespace

import numpy as np
import pytest

from sparseedm import _progress
from sparseedm.cameras import sample_cameras
from sparseedm.fconv import recover as fconv_recover
from sparseedm.temporal.sequences import Sequence


@pytest.fixture
def told():
    """Progress on, into a buffer (not a terminal: one line per stage); off after."""
    stream = io.StringIO()
    _progress.enable(True, stream)
    yield stream
    _progress.enable(False)


@pytest.fixture
def identity_model(monkeypatch):
    """A stand-in FConv model (no torch): the network returns its input; counts calls."""
    calls = []

    def predict(X, *, batch_size):
        calls.append(len(X))
        return np.asarray(X, float)

    model = SimpleNamespace(n_joints=14, representation="average", predict=predict)
    monkeypatch.setattr(fconv_recover, "load_model", lambda m, **kw: model)
    return calls


def _occluded(n):
    rng = np.random.default_rng(0)
    poses = rng.normal(0, 50, (n, 14, 2))
    poses[:, 4] = np.nan
    return poses


def test_recover_fconv_shows_a_bar_over_its_chunks(identity_model, capsys):
    res = fconv_recover.recover_fconv(_occluded(10), model="stub", chunk_size=4, progress=True)
    assert identity_model == [4, 4, 2]  # chunk by chunk under the bar
    assert (res.status == "recovered").all()
    err = capsys.readouterr().err
    assert "recover (FConv)" in err and "3/3" in err
    fconv_recover.recover_fconv(_occluded(10), model="stub", chunk_size=4)
    assert capsys.readouterr().err == ""  # progress=False: silent


def test_recover_fconv_says_its_stage_when_progress_is_on(identity_model, told):
    fconv_recover.recover_fconv(_occluded(10), model="stub")
    assert "sparseedm: the FConv network on 10 poses" in told.getvalue()


def test_evaluate_video_tells_the_sequences(told):
    from sparseedm.temporal.evaluation import evaluate_video

    T = 60
    p = np.zeros((T, 14, 2))
    p[:, :, 0] = 10.0 * np.arange(T)[:, None]
    p[:, :, 1] = 5.0 * np.arange(14)
    seq = Sequence("w", np.arange(T), p, np.zeros((T, 14, 3)), sample_cameras(1))
    evaluate_video([seq], methods=["linear"], gap_lengths=(3,))
    assert "sparseedm: evaluating linear on the sequences (protocol 'gaps')" in told.getvalue()


def test_evaluate_tracks_tells_the_clips(told):
    from sparseedm.evaluation_real import evaluate_tracks

    base = np.zeros((14, 2))
    base[0] = [0.0, -170.0]
    base[:, 0] += np.arange(14)
    poses = np.concatenate([np.repeat(base[None], 40, 0), np.repeat(base[None], 35, 0) + 50])
    tracks, frames = np.repeat([0, 1], [40, 35]), np.concatenate([np.arange(40), np.arange(35)])
    evaluate_tracks(poses, tracks, frames, gap_lengths=(3,), methods=["linear"])
    assert "sparseedm: evaluating linear clip by clip" in told.getvalue()


def _lift_input(n=40):
    cmu = np.load(__import__("pathlib").Path(__file__).parent / "fixtures" / "cmu_poses.npz",
                  allow_pickle=False)["poses2d"].astype(float)[:n]
    cmu[::3, 4] = np.nan
    return cmu


def test_lift_shows_a_bar_over_its_lasso_chunks(capsys):
    """lift(progress=True) shows a bar over the dictionary lifter's chunks, as
    recover() over its own; the answers are the silent call's."""
    import sparseedm

    poses = _lift_input()
    shown = sparseedm.lift(poses, progress=True)
    err = capsys.readouterr().err
    assert "lift" in err and "1/1" in err and "chunk" in err
    silent = sparseedm.lift(poses)
    assert capsys.readouterr().err == ""  # progress=False: silent
    np.testing.assert_array_equal(shown.poses3d, silent.poses3d)
    np.testing.assert_array_equal(shown.status, silent.status)


def test_cli_lift_shows_the_bar_as_recover_does(tmp_path, monkeypatch, capsys):
    """`sparseedm lift` asks for the bar where `sparseedm recover` does (a terminal,
    no --quiet) and not with --quiet."""
    from sparseedm.cli import lift_cmd, main
    from sparseedm.keypoints import write_keypoints

    src = tmp_path / "in.npz"
    write_keypoints(src, _lift_input())
    monkeypatch.setattr(lift_cmd, "show_progress", lambda args: not args.quiet)
    assert main(["lift", str(src), "-o", str(tmp_path / "o.csv"), "--no-temporal"]) == 0
    assert "1/1" in capsys.readouterr().err
    assert main(["lift", str(src), "-o", str(tmp_path / "q.csv"), "--no-temporal", "-q"]) == 0
    assert "1/1" not in capsys.readouterr().err


def test_recover_progress_true_tells_its_stages_then_stays_silent(capsys):
    """recover(progress=True) says as each long stage starts (here the adaptation
    on the example video's complete poses), as the command line does; reporting
    is off again after the call, and progress=False says nothing."""
    from pathlib import Path

    import sparseedm
    from sparseedm.keypoints import read_keypoints

    kps = read_keypoints(Path(__file__).resolve().parents[1] / "examples" / "video_clip.csv")
    args = dict(tracks=kps.tracks, frames=kps.frames, self_training=0)
    sparseedm.recover(kps.poses, kps.missing, progress=True, **args)
    err = capsys.readouterr().err
    assert "sparseedm: adapting the dictionary on 115 complete poses" in err
    assert not _progress.enabled()
    sparseedm.recover(kps.poses, kps.missing, **args)
    assert "sparseedm:" not in capsys.readouterr().err
