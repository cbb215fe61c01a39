"""`sparseedm plot` and sparseedm.plotting.plot_recovery: a recovery to check by eye."""

import numpy as np
import pytest

from sparseedm.cli import main
from sparseedm.exceptions import SparseEDMError
from sparseedm.keypoints import write_keypoints
from sparseedm.plotting import plot_recovery, select_values
from sparseedm.skeleton import JOINT_NAMES

PNG = b"\x89PNG\r\n\x1a\n"
WRIST, KNEE = JOINT_NAMES.index("right_wrist"), JOINT_NAMES.index("left_knee")


@pytest.fixture
def clip(track):
    """40 frames of two people (the second shifted): person 'a' loses the right wrist
    in frames 10-14 and the left knee in 30-31, person 'b' the wrist in 20-21."""
    truth = np.concatenate([track[:40], track[:40] + 150.0])
    frames = np.tile(np.arange(40), 2)
    tracks = np.repeat(["a", "b"], 40)
    seen = truth.copy()
    seen[10:15, WRIST] = np.nan
    seen[30:32, KNEE] = np.nan
    seen[40 + 20:40 + 22, WRIST] = np.nan
    return seen, truth, frames, tracks


def test_the_figure_draws_each_joint_over_time_and_a_few_poses(clip):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    seen, truth, frames, tracks = clip
    fig = plot_recovery(seen, truth, frames=frames, tracks=tracks, n_poses=3)
    # default: the track with the most filled joints ('a'), its filled joints, x and y
    titles = [ax.get_title() for ax in fig.axes]
    assert titles[:4] == ["right_wrist: x (track a)", "right_wrist: y (track a)",
                          "left_knee: x (track a)", "left_knee: y (track a)"]
    assert len(fig.axes) == 4 + 3
    wrist_x = fig.axes[0]
    recovered, observed, filled = wrist_x.lines
    assert len(recovered.get_xdata()) == 40
    assert np.isfinite(np.asarray(observed.get_ydata(), float)).sum() == 35
    np.testing.assert_array_equal(filled.get_xdata(), np.arange(10, 15))
    np.testing.assert_array_equal(filled.get_ydata(), truth[10:15, WRIST, 0])
    assert len(wrist_x.patches) == 1  # one shaded band: frames 10-14
    # the poses: those with filled joints first, each filled joint one cross
    crosses = [ax.lines[-1] for ax in fig.axes[4:]]
    assert [len(c.get_xdata()) for c in crosses] == [1, 1, 1]
    assert [ax.get_title().split(", ")[1] for ax in fig.axes[4:]] == \
        ["frame 10", "frame 13", "frame 31"]  # spread over the 7 with filled joints


def test_the_figure_draws_the_tracks_frames_and_joints_asked_for(clip):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    seen, truth, frames, tracks = clip
    fig = plot_recovery(seen, truth, frames=frames, tracks=tracks, show_tracks=["a", "b"],
                        show_frames="5:25", show_joints=["right_wrist"], n_poses=0)
    assert [ax.get_title() for ax in fig.axes] == [
        "right_wrist: x (track a)", "right_wrist: y (track a)",
        "right_wrist: x (track b)", "right_wrist: y (track b)"]
    np.testing.assert_array_equal(fig.axes[0].lines[0].get_xdata(), np.arange(5, 25))
    np.testing.assert_array_equal(fig.axes[2].lines[2].get_xdata(), [20, 21])


def test_a_file_without_frames_draws_the_poses_of_the_rows_asked_for(clip):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    seen, truth, _, _ = clip
    fig = plot_recovery(seen, truth, show_rows="0,12,61", ids=[f"p{i}" for i in range(80)])
    assert [ax.get_title() for ax in fig.axes] == ["p0", "p12", "p61"]
    assert [len(ax.lines[-1].get_xdata()) for ax in fig.axes] == [0, 1, 1]
    with pytest.raises(SparseEDMError, match="no frames"):
        plot_recovery(seen, truth, show_frames="1:3")


@pytest.mark.parametrize("kwargs,message", [
    (dict(show_joints=["right_wirst"]), "unknown joint 'right_wirst' \\(did you mean "
     "'right_wrist'\\?\\)"),
    (dict(show_tracks=["c"]), "track 'c' is not in the file \\(its tracks: a, b\\)"),
    (dict(show_frames="50"), "frame 50 is not in the file \\(its frames: 0 to 39\\)"),
    (dict(show_frames="50:60"), "frames 50:60 are not in the file"),
    (dict(show_frames="ten"), "'ten' is not a number or a range"),
])
def test_unknown_choices_are_refused_naming_them(clip, kwargs, message):
    seen, truth, frames, tracks = clip
    with pytest.raises(SparseEDMError, match=message):
        plot_recovery(seen, truth, frames=frames, tracks=tracks, **kwargs)


def test_select_values_reads_ranges_and_numbers():
    values = np.array([3, 4, 5, 10, 11])
    assert select_values("4:11", values).tolist() == [False, True, True, True, False]
    assert select_values(":4,11", values).tolist() == [True, False, False, False, True]
    assert select_values("10:", values).tolist() == [False, False, False, True, True]
    assert select_values([3, 10], values).tolist() == [True, False, False, True, False]


def _files(clip, tmp_path):
    seen, truth, frames, tracks = clip
    src, out = tmp_path / "in.csv", tmp_path / "filled.csv"
    write_keypoints(src, seen, tracks=tracks, frames=frames)
    write_keypoints(out, truth, tracks=tracks, frames=frames, filled=np.isnan(seen).any(-1))
    return src, out


def test_the_command_writes_a_png(clip, tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    src, out = _files(clip, tmp_path)
    fig = tmp_path / "check.png"
    assert main(["plot", str(src), str(out), "-o", str(fig), "--frames", "5:35",
                 "--joints", "right_wrist,left_knee", "--tracks", "a"]) == 0
    assert fig.read_bytes()[:8] == PNG
    said = capsys.readouterr()
    assert f"wrote {fig}" in said.out
    assert "sparseedm: drawing 4 trajectory panels and 4 poses" in said.err
    svg = tmp_path / "check.svg"
    assert main(["plot", str(src), str(out), "-o", str(svg)]) == 0
    assert b"<svg" in svg.read_bytes()[:500]
    # an INPUT whose name does not tell its format, read as recover reads it
    odd = tmp_path / "in.keypoints"
    odd.write_bytes(src.read_bytes())
    assert main(["plot", str(odd), str(out), "-o", str(svg), "--input-format", "csv"]) == 0


def test_the_command_reads_a_recovered_file_in_the_format_recover_wrote(tmp_path, capsys,
                                                                       fixtures_dir):
    """recover writes INPUT's format where OUTPUT's name does not tell (``out.keypoints``):
    plot reads RECOVERED so too, DeepLabCut with INPUT's joint map (it used to refuse
    RECOVERED, sending the user to --input-format, which is INPUT's)."""
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    formats = fixtures_dir / "formats"
    joint_map = str(formats / "dlc_joints.json")
    src = tmp_path / "walk.keypoints"
    src.write_bytes((formats / "dlc.csv").read_bytes())
    out = tmp_path / "walk_out.keypoints"
    assert main(["recover", str(src), "--input-format", "dlc", "-o", str(out),
                 "--joint-map", joint_map, "-q"]) == 0
    assert "(dlc)" in capsys.readouterr().err
    fig = tmp_path / "walk.png"
    assert main(["plot", str(src), str(out), "-o", str(fig), "--input-format", "dlc",
                 "--joint-map", joint_map, "-q"]) == 0
    assert fig.read_bytes()[:8] == PNG
    # without the map, the refusal names it
    assert main(["plot", str(src), str(out), "-o", str(fig), "--input-format", "dlc"]) == 2
    assert "joints map" in capsys.readouterr().err


@pytest.mark.parametrize("option,message", [
    (["--joints", "elbow"], "unknown joint 'elbow'"),
    (["--tracks", "z"], "track 'z' is not in the file"),
    (["--frames", "99"], "frame 99 is not in the file"),
])
def test_the_command_refuses_an_unknown_choice(clip, tmp_path, capsys, option, message):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    src, out = _files(clip, tmp_path)
    fig = tmp_path / "check.png"
    assert main(["plot", str(src), str(out), "-o", str(fig)] + option) == 2
    err = capsys.readouterr().err
    assert "sparseedm plot: error: " in err and message in err
    assert not fig.exists()


def test_the_command_checks_matplotlib_before_reading(monkeypatch, tmp_path, capsys):
    import sparseedm._extras as extras

    monkeypatch.setattr(extras, "have", lambda extra: extra != "plot")
    assert main(["plot", str(tmp_path / "none.csv"), str(tmp_path / "none2.csv"),
                 "-o", str(tmp_path / "x.png")]) == 2
    assert "sparseedm plot needs matplotlib" in capsys.readouterr().err


def test_the_command_refuses_another_figure_format(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    assert main(["plot", "a.csv", "b.csv", "-o", str(tmp_path / "x.jpg")]) == 2
    assert "ending in .png, .pdf, .svg" in capsys.readouterr().err


def test_the_command_matches_rows_of_a_file_written_frame_by_frame(clip, tmp_path,
                                                                  monkeypatch):
    """An OpenPose folder reads back frame by frame, not in the input's row order."""
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    import sparseedm.plotting as plotting

    seen, truth, frames, tracks = clip
    src, out = tmp_path / "in.csv", tmp_path / "op"
    tracks = (tracks == "b").astype(int)
    write_keypoints(src, seen, tracks=tracks, frames=frames)
    write_keypoints(out, truth, format="openpose", tracks=tracks, frames=frames,
                    filled=np.isnan(seen).any(-1))
    got = {}
    monkeypatch.setattr(plotting, "plot_recovery",
                        lambda *a, **k: got.update(args=a, kwargs=k))
    assert main(["plot", str(src), str(out), "-o", str(tmp_path / "f.png")]) == 0
    observed, recovered, filled = got["args"]
    np.testing.assert_allclose(recovered, truth, atol=1e-6)
    np.testing.assert_array_equal(filled, np.isnan(seen).any(-1))


def test_the_command_takes_the_tracks_recover_linked(clip, tmp_path, monkeypatch):
    """An input without track ids: the people are told apart by the tracks that
    recover linked and wrote into the recovered file."""
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    import sparseedm.plotting as plotting

    seen, truth, frames, tracks = clip
    src, out = tmp_path / "in.csv", tmp_path / "out.csv"
    write_keypoints(src, seen, frames=frames)
    write_keypoints(out, truth, tracks=tracks, frames=frames, filled=np.isnan(seen).any(-1))
    got = {}
    monkeypatch.setattr(plotting, "plot_recovery",
                        lambda *a, **k: got.update(args=a, kwargs=k))
    assert main(["plot", str(src), str(out), "-o", str(tmp_path / "f.png")]) == 0
    np.testing.assert_array_equal(got["kwargs"]["tracks"], tracks)
