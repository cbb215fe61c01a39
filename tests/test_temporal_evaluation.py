"""The video evaluation (sparseedm.temporal.evaluation): its table computed by hand
on a tiny case, its protocols wired, its files and figure written."""

import json

import numpy as np
import pytest

from sparseedm.cameras import sample_cameras
from sparseedm.exceptions import ParameterError
from sparseedm.temporal.evaluation import (edge_jumps, evaluate_video, plot_fill,
                                             protocol_masks, ratio_interval)
from sparseedm.temporal.fillers import fill_linear
from sparseedm.temporal.protocols import GAP_LENGTHS
from sparseedm.temporal.sequences import Sequence

T = 10


def walker():
    """Every joint moves 10 px per frame in x; head top at y 0, ankles at y 100 and
    x +-10 around the others: the body's height is 100 px in every frame."""
    p = np.zeros((T, 14, 2))
    p[:, :, 0] = 10.0 * np.arange(T)[:, None]
    p[:, :, 1] = 5.0 * np.arange(14)
    p[:, 0, 1] = 0.0
    p[:, [10, 13], 1] = 100.0
    p[:, 10, 0] -= 10
    p[:, 13, 0] += 10
    return Sequence("walker", np.arange(T), p, np.zeros((T, 14, 3)), sample_cameras(1))


def hand_protocol(sequence):
    m = np.zeros((T, 14), bool)
    m[0:2, 4] = True   # run of 2 at the clip start
    m[3:10, 7] = True  # run of 7 to the clip end
    m[4:6, 9] = True   # run of 2 inside
    return {"hand": m}


def offset(poses, missing, frames):
    """Fills a joint 5 px off (3, 4) on even frames, 10 px off (0, 10) on odd ones."""
    truth = walker().poses2d
    shift = np.where((np.asarray(frames) % 2 == 0)[:, None], [3.0, 4.0], [0.0, 10.0])
    return np.where(missing[..., None], truth + shift[:, None, :], poses)


def offset_but_not_7(poses, missing, frames):
    out = offset(poses, missing, frames)
    out[missing[:, 7], 7] = np.nan
    return out


def test_the_table_by_hand():
    report = evaluate_video([walker()], {"offset": offset, "linear": fill_linear},
                            hand_protocol)
    row = report.row
    # offset: joint 4 frames 0, 1 -> 5, 10 %; joint 9 frames 4, 5 -> 5, 10 %;
    # joint 7 frames 3..9 -> 10, 5, 10, 5, 10, 5, 10 %
    assert row("offset", "1-5")["error"] == pytest.approx(7.5)
    assert row("offset", "1-5", "end")["error"] == pytest.approx(7.5)
    assert row("offset", "1-5", "inside")["n"] == 2
    assert row("offset", "6-15")["error"] == pytest.approx(55 / 7)
    assert row("offset", "6-15", "inside")["n"] == 0
    assert np.isnan(row("offset", "6-15", "inside")["error"])
    assert row("offset", "overall")["error"] == pytest.approx(85 / 11)
    assert row("offset", "overall")["n"] == 11
    assert row("offset", "16-45")["n"] == 0
    # linear on this straight-line motion: exact inside; at the start joint 4 holds
    # frame 2's x (20) at frames 0, 1 (truth 0, 10): 20 and 10 px; at the end joint 7
    # holds frame 2's x (20) against 30..90: 10, 20, ..., 70 px
    assert row("linear", "1-5", "inside")["error"] == 0.0
    assert row("linear", "1-5", "end")["error"] == pytest.approx(15.0)
    assert row("linear", "6-15")["error"] == pytest.approx(40.0)
    assert row("linear", "overall")["error"] == pytest.approx((30 + 280) / 11)
    assert report.settings["hidden_fraction"] == pytest.approx(11 / 140)


def test_edge_jumps_by_hand():
    truth = np.zeros((8, 2, 2))
    truth[:, :, 0] = 2.0 * np.arange(8)[:, None]       # 2 px a frame in x
    missing = np.zeros((8, 2), bool)
    missing[0:2, 0] = True    # at the clip start: only its end has a neighbour
    missing[4, 0] = True      # one frame: start and end on the same row
    missing[5:7, 1] = True    # a run whose end borders a skipped frame
    frames = np.array([0, 1, 2, 3, 4, 5, 6, 9])
    filled = truth.copy()
    filled[1, 0] += [0.0, 3.0]   # 3 px off in y: sqrt(2² + 3²) from frame 2
    filled[4, 0] = truth[3, 0]   # held: it does not move into the gap, moves 4 out
    filled[5, 1] += [6.0, 0.0]   # 6 px ahead in x: moves 8 into the gap
    jumps = edge_jumps(truth, filled, missing, frames)
    expected = np.full((8, 2, 2), np.nan)
    expected[1, 0, 1] = np.sqrt(13) - 2
    expected[4, 0] = [0 - 2, 4 - 2]
    expected[5, 1, 0] = 8 - 2
    # row 6 -> row 7 is frames 6 -> 9: no edge counted there
    np.testing.assert_allclose(jumps, expected)
    # a fill that follows the truth has no excess jump anywhere
    assert np.nanmax(np.abs(edge_jumps(truth, truth, missing, frames))) == 0


def test_the_report_has_the_mean_excess_jump_per_method():
    report = evaluate_video([walker()], {"offset": offset, "linear": fill_linear},
                            hand_protocol)
    row = report.row
    # offset's edges (body height 100 px, truth 10 px a frame in x): joint 4's end at
    # frame 1 (0, 10) off -> |(10, -10)|; joint 7's start at frame 3 (0, 10) off ->
    # |(10, 10)|; joint 9's start at frame 4 (3, 4) off -> |(13, 4)|, end at 5 -> |(10, -10)|
    diagonal, skew = np.hypot(10, 10) - 10, np.hypot(13, 4) - 10
    assert row("offset", "overall")["edges"] == 4
    assert row("offset", "overall")["edge_jump"] == pytest.approx((3 * diagonal + skew) / 4)
    assert row("offset", "1-5", "inside")["edge_jump"] == pytest.approx((diagonal + skew) / 2)
    assert row("offset", "6-15")["edge_jump"] == pytest.approx(diagonal)
    assert row("offset", "16-45")["edges"] == 0 and np.isnan(row("offset", "16-45")["edge_jump"])
    # linear: exact inside (no excess), holding at the clip ends: stays put where the
    # truth moves 10 px
    assert row("linear", "1-5", "inside")["edge_jump"] == pytest.approx(0.0, abs=1e-9)
    assert row("linear", "overall")["edge_jump"] == pytest.approx(-20 / 4)
    assert "edge jump" in report.table() and f"{(3 * diagonal + skew) / 4:.2f}" in \
        report.table()
    assert "edge_jump" in report.to_csv().splitlines()[0]


def ends_unfilled(poses, missing, frames):
    """offset's fill, but a run's first and last hidden frames left NaN: scored
    joint-frames inside the runs, no gap edge filled."""
    out = offset(poses, missing, frames)
    edge = missing & ~(np.roll(missing, 1, axis=0) & np.roll(missing, -1, axis=0))
    out[edge] = np.nan
    return out


def test_report_json_is_strict_and_reads_back(tmp_path, strict_json):
    """NaN (no edge, no scored joint-frame) is written as null, never as a bare NaN
    that JavaScript's JSON.parse refuses; the rows read back serve ratio_interval."""
    report = evaluate_video([walker()], {"ends": ends_unfilled, "linear": fill_linear},
                            hand_protocol)
    assert np.isnan(report.row("linear", "overall")["edge_jump"])  # a NaN to write
    report.write(tmp_path / "r.json")
    for doc in (strict_json(report.to_json()), strict_json((tmp_path / "r.json").read_text())):
        rows = {(r["method"], r["group"], r["end"]): r for r in doc["rows"]}
        assert rows["linear", "overall", "all"]["edge_jump"] is None
        assert rows["linear", "1-5", "all"]["error"] is None
        assert rows["linear", "overall", "all"]["error"] == report.row("linear", "overall")[
            "error"]
        assert ratio_interval(doc["rows"], "ends", ["linear"], "6-15") == \
            report.ratio_interval("ends", ["linear"], "6-15")


def test_the_table_leaves_a_cell_without_an_edge_or_a_joint_blank():
    """The edge jump without an edge (and an error without a scored joint-frame) is a
    blank cell, as in evaluation_real's table, not 'nan'."""
    report = evaluate_video([walker()], {"ends": ends_unfilled, "linear": fill_linear},
                            hand_protocol)
    assert report.row("linear", "overall")["edges"] == 0
    assert report.row("linear", "overall")["scored"] > 0 == report.row("linear", "1-5")[
        "scored"]
    table = report.table()
    for m in ("ends", "linear"):
        cells = [c.strip() for c in next(line for line in table.splitlines()
                                         if line.startswith(f"| {m} |")).split("|")[1:-1]]
        assert "nan" not in " ".join(cells)
        assert cells[-2] == ""                                  # edge jump: no edge
        assert cells[5] == f"{report.row(m, 'overall')['error']:.2f}" + (
            " (55% unfilled)" if m == "ends" else " [28.18 on all 11]")
    assert "| ends | (100% unfilled) |" in table and "| linear | [7.50 on all 4] |" in table


def test_the_benchmark_summary_reads_a_written_report(strict_json):
    """benchmarks/video_protocols.py's tables read the reports' JSON, null included."""
    video_protocols = pytest.importorskip("benchmarks.video_protocols")
    report = evaluate_video([walker()], {"ends": ends_unfilled, "linear": fill_linear},
                            hand_protocol)
    rows = strict_json(report.to_json())["rows"]
    runs = [dict(source="walker", split=s, protocol="gaps", rows=rows)
            for s in ("validation", "test")]
    text = video_protocols.summary({"runs": runs})
    line = next(line for line in text.splitlines() if line.startswith("| linear |"))
    assert line.endswith("| – / – |")                 # the edge jump: none in either split
    assert f"{report.row('linear', '6-15')['error']:.2f} / " in line


def shifted(name, dx):
    """A sequence like walker() moved by dx in x, under another clip id."""
    w = walker()
    return Sequence(name, w.frames, w.poses2d + [dx, 0.0], w.poses3d, sample_cameras(1))


def scaled_offset(factors):
    """offset()'s error times factors[i] on the sequence shifted by 1000 i px
    (told by its head top, which hand_protocol never hides)."""
    def fill(poses, missing, frames):
        clip = int(round(np.nanmin(poses[:, 0, 0]) / 1000))
        truth = walker().poses2d + [1000.0 * clip, 0.0]
        shift = np.where((np.asarray(frames) % 2 == 0)[:, None], [3.0, 4.0], [0.0, 10.0])
        return np.where(missing[..., None], truth + factors[clip] * shift[:, None, :], poses)
    return fill


def test_per_sequence_sums_pool_to_the_row():
    seqs = [shifted("a", 0.0), shifted("b", 1000.0), shifted("c", 2000.0)]
    report = evaluate_video(seqs, {"m": scaled_offset([1, 2, 4])},
                            hand_protocol)
    for r in report.rows:
        assert len(r["sequence_sums"]) == len(r["sequence_counts"]) == 3
        assert sum(r["sequence_counts"]) == r["scored"]
        if r["scored"]:
            assert sum(r["sequence_sums"]) / r["scored"] == pytest.approx(r["error"])
    row = report.row("m", "overall")
    assert row["sequence_counts"] == [11, 11, 11]
    assert row["sequence_sums"] == pytest.approx([85.0, 170.0, 340.0])


def test_ratio_interval_resamples_sequences():
    seqs = [shifted("a", 0.0), shifted("b", 1000.0), shifted("c", 2000.0)]
    half = scaled_offset([0.5, 0.5, 0.5])
    peer = scaled_offset([1, 1, 1])
    mixed = scaled_offset([0.25, 1, 2])
    other = scaled_offset([4, 4, 0.1])  # worse pooled, better on the third clip
    report = evaluate_video(seqs, {"half": half, "peer": peer, "mixed": mixed, "other": other},
                            hand_protocol)
    # the same ratio on every sequence: no spread
    r = report.ratio_interval("half", ["peer"], "overall")
    assert r["ratio"] == pytest.approx(0.5) and r["best"] == "peer" and r["sequences"] == 3
    assert r["low"] == pytest.approx(0.5) and r["high"] == pytest.approx(0.5)
    # ratios 0.25, 1, 2 on the three clips: pooled 3.25 / 3, and a wide interval
    r = ratio_interval(report.rows, "mixed", ["peer"], "overall", level=0.9)
    assert r["ratio"] == pytest.approx(3.25 / 3)
    assert r["low"] < 0.6 and r["high"] > 1.6 and r["low"] <= r["ratio"] <= r["high"]
    # the best peer is taken anew in each resample: "other" wins the resamples
    # of the third clip alone (1 in 27), so the interval reaches above "peer"'s alone
    alone = ratio_interval(report.rows, "mixed", ["peer"], "overall", level=0.99)
    both = ratio_interval(report.rows, "mixed", ["peer", "other"], "overall", level=0.99)
    assert both["best"] == "peer" and both["ratio"] == pytest.approx(r["ratio"])
    assert alone["high"] == pytest.approx(2.0) and both["high"] == pytest.approx(20.0)
    assert both["low"] >= alone["low"]
    # seeded: the same interval twice
    assert ratio_interval(report.rows, "mixed", ["peer"], "overall") == r
    # a group with no scored joint-frames
    empty = report.ratio_interval("mixed", ["peer"], "16-45")
    assert empty["sequences"] == 0 and np.isnan(empty["ratio"]) and empty["best"] is None


def test_ratio_interval_refusals():
    report = evaluate_video([walker()], {"offset": offset, "linear": fill_linear},
                            hand_protocol)
    with pytest.raises(ParameterError, match="level"):
        report.ratio_interval("offset", ["linear"], "overall", level=1.5)
    with pytest.raises(ParameterError, match="peer"):
        report.ratio_interval("offset", ["offset"], "overall")
    with pytest.raises(KeyError):
        report.ratio_interval("offset", ["akima"], "overall")
    old = [{k: v for k, v in r.items() if not k.startswith("sequence_")} for r in report.rows]
    with pytest.raises(ParameterError, match="per-sequence"):
        ratio_interval(old, "offset", ["linear"], "overall")


def test_a_method_that_leaves_joints_unfilled():
    report = evaluate_video([walker()], {"offset": offset, "partial": offset_but_not_7},
                            hand_protocol)
    row = report.row
    assert row("partial", "6-15")["unfilled"] == 7 and row("offset", "6-15")["unfilled"] == 0
    assert row("offset", "6-15")["scored"] == 0 and np.isnan(row("offset", "6-15")["error"])
    assert row("offset", "6-15")["error_own"] == pytest.approx(55 / 7)
    # overall: both scored on the 4 joint-frames both filled
    assert row("offset", "overall")["scored"] == 4
    assert row("partial", "overall")["error"] == row("offset", "overall")["error"] == 7.5
    assert "unfilled" in report.table()


def test_gap_protocol_groups_by_gap_length_and_is_seeded():
    seq = Sequence("w", np.arange(200), np.cumsum(np.ones((200, 14, 2)), axis=0),
                   np.zeros((200, 14, 3)), sample_cameras(1))
    seq.poses2d[:, 0, 1] -= 100  # a body height
    a = evaluate_video([seq], ["linear"], "gaps", random_state=3)
    b = evaluate_video([seq], ["linear"], "gaps", random_state=3)
    assert json.dumps(a.rows) == json.dumps(b.rows)
    other = evaluate_video([seq], ["linear"], "gaps", random_state=4)
    assert json.dumps(a.rows) != json.dumps(other.rows)
    assert a.groups == [f"gap {L}" for L in GAP_LENGTHS] + ["overall"]
    masks = protocol_masks(seq, "gaps", random_state=3)
    for L in GAP_LENGTHS:
        assert a.row("linear", f"gap {L}")["n"] == masks[f"gap {L}"].sum()
        assert a.row("linear", f"gap {L}", "inside")["error"] < 1e-9  # a straight line


def test_self_occlusion_protocol_uses_the_camera():
    from sparseedm.cameras import look_at

    X = np.zeros((40, 14, 3))
    X[:, [2, 5, 11, 8]] = [[-0.2, 1.4, 0], [0.2, 1.4, 0], [0.15, 0.9, 0], [-0.15, 0.9, 0]]
    X[:, [0, 1, 3, 6, 7, 9, 10, 12, 13]] = [2.0, 1.0, 0.0]
    X[:, 4] = [0.0, 1.15, 0.3]
    X[10:20, 4, 2] = -0.3  # the right wrist goes behind the back for 10 frames
    eye = np.array([0.0, 1.2, 4.0])
    R = look_at(eye, [0.0, 1.2, 0.0])
    from sparseedm.cameras import Cameras, project

    cam = Cameras(R, -np.einsum("nij,nj->ni", R, eye[None]), np.array([1000.0]),
                  np.array([[500.0, 500.0]]))
    p2 = project(X, cam[np.zeros(40, int)])
    seq = Sequence("b", np.arange(40), p2, X, cam)
    m = protocol_masks(seq, "self-occlusion")["self-occlusion"]
    assert m[10:20, 4].all()
    assert m[:, 4].sum() < 20  # in front of the chest it shows (but for dropouts)
    assert 0.05 <= m.mean() - 10 / 560 < 0.07  # + 5 % dropouts


def test_noise_jitters_what_methods_see_and_errors_stay_against_the_truth():
    seq = Sequence("w", np.arange(200), np.cumsum(np.ones((200, 14, 2)), axis=0),
                   np.zeros((200, 14, 3)), sample_cameras(1))
    seq.poses2d[:, 0, 1] -= 100  # a body height of about 100 px
    seen = {}

    def truth_fill(poses, missing, frames):  # records what it is given
        seen.setdefault("given", []).append(np.where(missing[..., None], np.nan, poses))
        return np.where(missing[..., None], seq.poses2d, poses)

    clean = evaluate_video([seq], ["linear"], "gaps", random_state=3)
    methods = {"linear": fill_linear, "again": fill_linear, "truth": truth_fill}
    noisy = evaluate_video([seq], methods, "gaps", random_state=3, noise=0.01)
    assert noisy.settings["noise"] == 0.01 and clean.settings["noise"] == 0.0
    # a straight line: exact when clean, off by the jitter when noisy
    assert clean.row("linear", "gap 10", "inside")["error"] < 1e-9
    assert 0.3 < noisy.row("linear", "gap 10", "inside")["error"] < 3
    # every method sees the same noise; the truth scores 0 against the truth
    for group in noisy.groups:
        assert noisy.row("again", group)["error"] == noisy.row("linear", group)["error"]
    assert noisy.row("truth", "overall")["error"] == 0.0
    jitter = np.concatenate([(g - seq.poses2d)[np.isfinite(g)] for g in seen["given"]])
    assert 0.8 < jitter.std() / (0.01 * seq.height) < 1.2


@pytest.mark.parametrize("noise", [-0.1, 1.5, float("nan"), "x"])
def test_bad_noise_is_named(noise):
    with pytest.raises(ParameterError, match="noise must be in"):
        evaluate_video([walker()], ["linear"], "gaps", noise=noise)


def test_bad_arguments_are_named():
    with pytest.raises(ParameterError, match="protocol"):
        evaluate_video([walker()], ["linear"], "occlusion")
    with pytest.raises(ParameterError, match="unknown method 'splines'"):
        evaluate_video([walker()], ["splines"], "gaps")
    with pytest.raises(ParameterError, match="cannot import"):
        evaluate_video([walker()], ["sparseedm.nothing:fill"], "gaps")


def test_a_filler_named_by_module_and_function():
    a = evaluate_video([walker()], ["sparseedm.temporal.fillers:fill_linear"], hand_protocol)
    b = evaluate_video([walker()], ["linear"], hand_protocol)
    assert a.methods == ["fill_linear"]
    assert json.dumps([r["error"] for r in a.rows]) == json.dumps([r["error"] for r in b.rows])


def test_report_files_and_figure(tmp_path, strict_json):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    report = evaluate_video([walker()], {"offset": offset}, hand_protocol)
    report.write(tmp_path / "r.json", tmp_path / "r.csv")
    saved = strict_json((tmp_path / "r.json").read_text())
    assert saved["rows"] == json.loads(json.dumps(report.rows).replace("NaN", "null"))
    assert (tmp_path / "r.csv").read_text().splitlines()[0].startswith("method,group,end,n")
    fig = plot_fill(walker(), {"offset": offset, "linear": fill_linear}, hand_protocol,
                    "left_wrist", path=tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 1000
    labels = [line.get_label() for line in fig.axes[0].lines]
    assert labels == ["truth", "offset", "linear"]


@pytest.fixture
def sequence_file(tmp_path, fixtures_dir):
    """A one-camera-per-clip .npz of two 60-frame clips: the CMU fixture walk played
    forwards and back (3D), seen through one seeded camera per clip."""
    from sparseedm.cameras import project
    from sparseedm.dataset import save_dataset
    from sparseedm.mocap import load_mocap
    from sparseedm.skeleton import JOINT_NAMES

    walk = load_mocap(fixtures_dir / "cmu_02_01_short.bvh")
    loop = np.concatenate([walk, walk[::-1], walk])[:60]
    poses3d = np.concatenate([loop, loop + [0.3, 0, 0]])
    cams = sample_cameras(2, targets=poses3d.reshape(2, -1, 3).mean(axis=1), random_state=1)
    rows = np.repeat([0, 1], 60)
    n = len(rows)
    data = {"poses2d": project(poses3d, cams[rows]), "poses3d": poses3d,
            "labels": np.repeat(["walk"], n), "clips": np.repeat(["a", "b"], 60),
            "styles": np.repeat([""], n), "subjects": np.repeat(["02"], n),
            "frames": np.tile(np.arange(60) * 4, 2), "joint_names": np.array(JOINT_NAMES),
            **{k: v[rows] for k, v in cams.as_dict().items()}}
    path = tmp_path / "seq.npz"
    save_dataset(path, data)
    return path


def test_cli_video_protocol(sequence_file, tmp_path, capsys, strict_json):
    from sparseedm.cli import main

    out = tmp_path / "rep"
    argv = ["evaluate", "--protocol", "gaps", "--data", str(sequence_file), "--methods",
            "linear,akima,kalman", "--gap-lengths", "3,10", "-o", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "| linear |" in printed and "gap 10" in printed and "gap 30" not in printed
    assert "| kalman |" in printed and "edge jump" in printed
    saved = strict_json((out / "video.json").read_text())
    ref = evaluate_video(str(sequence_file), ["linear", "akima", "kalman"], "gaps",
                         gap_lengths=(3, 10))
    assert saved["rows"] == strict_json(ref.to_json())["rows"]
    assert (out / "video.csv").is_file()
    assert main(argv + ["--noise", "0.01"]) == 0
    assert "jittered by 0.01 x body height" in capsys.readouterr().out
    saved = strict_json((out / "video.json").read_text())
    assert saved["settings"]["noise"] == 0.01
    assert saved["rows"] != strict_json(ref.to_json())["rows"]


def test_cli_video_bad_options(sequence_file, tmp_path, capsys):
    from sparseedm.cli import main

    base = ["evaluate", "--data", str(sequence_file), "-o", str(tmp_path / "r")]
    assert main(base + ["--protocol", "gaps", "--methods", "spline"]) == 2
    assert "unknown method 'spline'" in capsys.readouterr().err
    assert main(base + ["--protocol", "gaps", "--plot-joint", "nose"]) == 2
    assert "--plot-joint must be one of" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(base + ["--protocol", "gaps", "--gap-lengths", "3,x"])
    with pytest.raises(SystemExit):
        main(base + ["--protocol", "gaps", "--noise", "2"])
    assert "--noise: must be a fraction of the body height" in capsys.readouterr().err


def test_cli_video_figure(sequence_file, tmp_path):
    pytest.importorskip("matplotlib", reason="needs the [plot] extra")
    from sparseedm.cli import main

    out = tmp_path / "rep"
    assert main(["evaluate", "--protocol", "self-occlusion", "--data", str(sequence_file),
                 "--methods", "linear,pca", "--plot-joint", "left_wrist", "--plot-clip", "b",
                 "-o", str(out)]) == 0
    assert (out / "fill_left_wrist.png").stat().st_size > 1000
