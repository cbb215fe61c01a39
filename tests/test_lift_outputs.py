"""`sparseedm lift` outputs one can look at and use elsewhere: TRC files and --plot."""

import numpy as np
import pytest

from sparseedm.cli import main
from sparseedm.lifting.trc import read_trc, write_trc
from sparseedm.skeleton import JOINT_NAMES


def test_trc_header_and_rows_follow_the_format(tmp_path):
    poses = np.random.default_rng(0).normal(size=(3, 14, 3))
    poses[1] = np.nan  # a refused pose
    path = write_trc(tmp_path / "p.trc", poses, rate=50)
    lines = path.read_text().split("\n")
    assert lines[0].split("\t") == ["PathFileType", "4", "(X/Y/Z)", "p.trc"]
    head = dict(zip(lines[1].split("\t"), lines[2].split("\t")))
    assert head == {"DataRate": "50", "CameraRate": "50", "NumFrames": "3", "NumMarkers": "14",
                    "Units": "m", "OrigDataRate": "50", "OrigDataStartFrame": "1",
                    "OrigNumFrames": "3"}
    names = lines[3].split("\t")
    assert names[:2] == ["Frame#", "Time"]
    assert [n for n in names[2:] if n] == list(JOINT_NAMES)
    assert names.index("neck") - names.index("head_top") == 3  # X, Y, Z columns each
    assert lines[4].split("\t")[2:5] == ["X1", "Y1", "Z1"]
    rows = [line.split("\t") for line in lines[6:] if line]
    assert [r[0] for r in rows] == ["1", "2", "3"]
    assert [float(r[1]) for r in rows] == [0.0, 0.02, 0.04]
    assert all(len(r) == 2 + 42 for r in rows)
    assert rows[1][2:] == [""] * 42
    # y up: camera y (down) is negated
    assert float(rows[0][3]) == pytest.approx(-poses[0, 0, 1], abs=1e-6)
    back = read_trc(path)
    np.testing.assert_allclose(back["poses"], poses, atol=1e-6)
    assert back["rate"] == 50 and back["units"] == "m" and back["markers"] == list(JOINT_NAMES)


def test_lift_writes_a_trc_that_parses_back(fixtures_dir, tmp_path, capsys):
    out = tmp_path / "poses.trc"
    csv_out = tmp_path / "poses.csv"
    src = str(fixtures_dir.parents[1] / "examples" / "occluded_poses.csv")
    assert main(["lift", src, "-o", str(out), "--rate", "25", "-q"]) == 0
    assert main(["lift", src, "-o", str(csv_out), "-q"]) == 0
    trc = read_trc(out)
    assert len(trc["poses"]) == 50 and trc["rate"] == 25
    np.testing.assert_allclose(trc["times"], np.arange(50) / 25, atol=1e-6)
    import csv

    with open(csv_out, newline="") as f:
        rows = list(csv.DictReader(f))
    from_csv = np.array([[[float(r[f"{j}_{a}"]) for a in "xyz"] for j in JOINT_NAMES]
                         for r in rows])
    np.testing.assert_allclose(trc["poses"], from_csv, atol=1e-6)
    head, ankle = JOINT_NAMES.index("head_top"), JOINT_NAMES.index("left_ankle")
    up = -trc["poses"][..., 1]  # what TRC's y holds
    assert (up[:, head] > up[:, ankle]).mean() > 0.9


@pytest.mark.parametrize("rate", ["0", "inf", "nan", "-3"])
def test_lift_refuses_a_bad_rate_before_any_work(tmp_path, capsys, rate):
    # inf wrote a .trc whose times were all 0
    assert main(["lift", "missing.csv", "-o", str(tmp_path / "p.trc"), "--rate", rate]) == 2
    assert "frame rate must be a finite number > 0" in capsys.readouterr().err


def test_lift_plot(fixtures_dir, tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    src = str(fixtures_dir.parents[1] / "examples" / "occluded_poses.csv")
    png = tmp_path / "poses.png"
    assert main(["lift", src, "-o", str(tmp_path / "p.csv"), "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"figure: {png}" in capsys.readouterr().out


def test_lift_plot_draws_the_frames_chosen(fixtures_dir, tmp_path, monkeypatch, capsys):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    import sparseedm.lifting.io as io

    drawn = []
    real = io.plot_lifted
    monkeypatch.setattr(io, "plot_lifted", lambda P, path, titles=None, missing=None: (
        drawn.append(titles), real(P, path, titles=titles, missing=missing))[1])
    src = str(fixtures_dir.parents[1] / "examples" / "occluded_poses.csv")
    png = tmp_path / "poses.png"
    argv = ["lift", src, "-o", str(tmp_path / "p.csv"), "--plot", str(png)]
    assert main(argv + ["--frames", "5,9:11"]) == 0  # a file without frames: rows
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ids = (fixtures_dir.parents[1] / "examples" / "occluded_poses.csv").read_text() \
        .splitlines()[1:]
    assert drawn[-1] == [ids[r].split(",")[0] for r in (5, 9, 10)]
    assert main(argv + ["--frames", "7:2000"]) == 0  # at most 8, spread over them
    assert len(drawn[-1]) == 8 and drawn[-1][0] == ids[7].split(",")[0]
    capsys.readouterr()
    assert main(argv + ["--frames", "500"]) == 2
    assert "row 500 is not in the file (its rows: 0 to 49)" in capsys.readouterr().err


def test_lift_plot_without_matplotlib_fails_before_work(monkeypatch, fixtures_dir, tmp_path,
                                                        capsys):
    import sparseedm._extras as extras
    import sparseedm.lifting.io as io

    monkeypatch.setattr(extras, "have", lambda extra: extra != "plot")
    monkeypatch.setattr(io, "lift", lambda *a, **k: pytest.fail("lifted before the check"))
    src = str(fixtures_dir.parents[1] / "examples" / "occluded_poses.csv")
    out = tmp_path / "p.csv"
    assert main(["lift", src, "-o", str(out), "--plot", str(tmp_path / "x.png")]) == 2
    assert "--plot needs matplotlib (the sparseedm[plot] extra)" in capsys.readouterr().err
    assert not out.exists()


def test_lift_json_writes_integer_frames_as_numbers(fixtures_dir, tmp_path, capsys):
    import json

    lines = (fixtures_dir.parents[1] / "examples" / "video_clip.csv").read_text().splitlines()
    src = tmp_path / "clip.csv"
    src.write_text("\n".join(lines[:7]) + "\n")   # 6 poses with track and frame
    out = tmp_path / "p.json"
    assert main(["lift", str(src), "-o", str(out), "--no-temporal", "-q"]) == 0
    doc = json.loads(out.read_text())
    assert [row["frame"] for row in doc] == list(range(6))
    assert all(isinstance(row["track"], str) for row in doc)
    head = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:7]]
    rows[2][head.index("frame")] = "2b"  # a frame that is not a number: all kept as text
    src.write_text("\n".join(",".join(r) for r in [head] + rows) + "\n")
    assert main(["lift", str(src), "-o", str(out), "--no-temporal", "-q"]) == 0
    assert [row["frame"] for row in json.loads(out.read_text())][:3] == ["0", "1", "2b"]


@pytest.mark.parametrize("src, ext", [("npy", "npz"), ("npy", "trc"), ("csv", "csv"),
                                      ("csv", "json")])
def test_lift_of_zero_poses_writes_an_empty_output(tmp_path, capsys, src, ext):
    """As recover does: exit 0, an empty output (never an internal error)."""
    inp = tmp_path / f"zero.{src}"
    if src == "npy":
        np.save(inp, np.zeros((0, 14, 2)))
    else:  # a header-only CSV, with frames
        inp.write_text(",".join(["id", "frame"] + [f"{j}_{a}" for j in JOINT_NAMES
                                                  for a in "xy"]) + "\n")
    out = tmp_path / f"out.{ext}"
    assert main(["lift", str(inp), "-o", str(out), "-q"]) == 0
    assert "poses: 0" in capsys.readouterr().err
    if ext == "trc":
        assert read_trc(out)["poses"].shape == (0, 14, 3)
    elif ext == "npz":
        with np.load(out, allow_pickle=False) as z:
            assert z["poses3d"].shape == (0, 14, 3)
    elif ext == "csv":
        assert out.read_text().splitlines()[0].startswith("id,") and \
            len(out.read_text().splitlines()) == 1  # the header alone
    else:
        assert out.read_text() == "[]"


def _clip_with_frames(fixtures_dir, tmp_path, frames):
    """The example clip's first rows (one track) with the frame column set to `frames`."""
    lines = (fixtures_dir.parents[1] / "examples" / "video_clip.csv").read_text().splitlines()
    head = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:1 + len(frames)]]
    for row, frame in zip(rows, frames):
        row[head.index("frame")] = frame
    src = tmp_path / "clip.csv"
    src.write_text("\n".join(",".join(r) for r in [head] + rows) + "\n")
    return src


def test_lift_trc_keeps_each_rows_frame_time(fixtures_dir, tmp_path, capsys):
    """Frames 10 apart are 10/rate s apart in the .trc, whatever order they come in."""
    frames = ["0", "10", "30", "20", "40", "50"]
    src = _clip_with_frames(fixtures_dir, tmp_path, frames)
    out = tmp_path / "p.trc"
    assert main(["lift", str(src), "-o", str(out), "--no-temporal", "-q"]) == 0
    trc = read_trc(out)
    np.testing.assert_array_equal(trc["frames"], [1, 11, 21, 31, 41, 51])
    np.testing.assert_allclose(trc["times"], np.arange(0, 60, 10) / 30, atol=1e-6)


@pytest.mark.parametrize("bad, words", [("nan", "row 2 has no usable frame number"),
                                        ("1_0", "row 2 has no usable frame number"),
                                        ("10", "rows 1 and 2 are both frame 10")])
def test_lift_trc_refuses_rows_it_cannot_place_in_time(fixtures_dir, tmp_path, capsys, bad,
                                                      words):
    """A frame cell that is not a usable number, or a frame given twice, refuses the
    .trc before any work (exit 2), never renumbered 1, 2, 3 at 1/rate s."""
    src = _clip_with_frames(fixtures_dir, tmp_path, ["0", "10", bad, "30", "40", "50"])
    out = tmp_path / "p.trc"
    assert main(["lift", str(src), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert words in err and "a .trc places each row at its frame's time" in err
    assert not out.exists()
    assert main(["lift", str(src), "-o", str(tmp_path / "p.csv"), "--no-temporal", "-q"]) == 0


def test_every_lift_output_with_room_carries_the_3d_radius(fixtures_dir, tmp_path, capsys):
    """`sparseedm lift` to .csv, .json and .npz: the same 3D 90 % radius per
    joint in each (a CSV column per joint, a JSON object per pose), read back
    equal to the .npz's; NaN (a refused pose) as an empty cell / null."""
    import csv
    import json

    src = str(fixtures_dir.parents[1] / "examples" / "occluded_poses.csv")
    outs = {ext: tmp_path / f"p.{ext}" for ext in ("npz", "csv", "json")}
    for out in outs.values():
        assert main(["lift", src, "-o", str(out), "-q"]) == 0
    with np.load(outs["npz"], allow_pickle=False) as data:
        radius = data["uncertainty3d"]
    assert radius.shape == (50, len(JOINT_NAMES)) and (radius[np.isfinite(radius)] > 0).all()
    with open(outs["csv"], newline="") as f:
        rows = list(csv.DictReader(f))
    from_csv = np.array([[float(r[f"{j}_uncertainty3d"] or "nan") for j in JOINT_NAMES]
                         for r in rows])
    from_json = np.array([[np.nan if row["uncertainty3d"][j] is None
                           else row["uncertainty3d"][j] for j in JOINT_NAMES]
                          for row in json.loads(outs["json"].read_text())])
    np.testing.assert_array_equal(from_csv, radius)
    np.testing.assert_array_equal(from_json, radius)


def test_write_poses3d_refused_pose_radius_is_empty_and_null(tmp_path):
    import csv
    import json

    from sparseedm.lifting.io import write_poses3d
    from sparseedm.lifting.lift import LiftResult

    n, N = 2, len(JOINT_NAMES)
    poses = np.random.default_rng(0).normal(size=(n, N, 3))
    poses[1] = np.nan
    radius = np.full((n, N), 0.12)
    radius[1] = np.nan
    res = LiftResult(poses3d=poses, vectors3d=np.zeros((n, 91)), scale_metric=np.ones(n),
                     missing=np.zeros((n, N), bool), status=np.array(["lifted", "refused"]),
                     reason=np.array(["", "x"]), chirality_margin=np.zeros(n),
                     seconds=0.0, uncertainty3d=radius)
    write_poses3d(tmp_path / "r.csv", res)
    write_poses3d(tmp_path / "r.json", res)
    with open(tmp_path / "r.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows[0]["neck_uncertainty3d"] == "0.12" and rows[1]["neck_uncertainty3d"] == ""
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc[0]["uncertainty3d"]["neck"] == 0.12 and doc[1]["uncertainty3d"]["neck"] is None
