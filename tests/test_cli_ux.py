"""Command-line behaviour a user meets first: closed pipes, early extra checks, progress."""

import io
import sys
from pathlib import Path

import numpy as np
import pytest

from sparseedm import _progress
from sparseedm.cli import build_parser, main


class ClosedPipe(io.StringIO):
    """A stdout whose reader has gone (`... | head`)."""

    def write(self, text):
        raise BrokenPipeError(32, "Broken pipe")


def test_closed_pipe_ends_quietly(monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdout", ClosedPipe())
    assert main(["info", "default"]) == 0
    assert capsys.readouterr().err == ""


def test_recover_jobs_help_says_threads():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    jobs = next(a for a in sub.choices["recover"]._actions if a.dest == "jobs")
    assert "threads" in jobs.help and "worker processes" not in jobs.help


def test_dask_backend_without_the_extra_fails_before_any_work(monkeypatch, tmp_path,
                                                               capsys):
    import sparseedm._extras as extras
    import sparseedm.batch as batch

    monkeypatch.setattr(extras, "have", lambda extra: extra != "dask")
    monkeypatch.setattr(batch, "_adapt", lambda *a, **k: pytest.fail("adapted before the check"))
    src = tmp_path / "in.npy"
    np.save(src, np.ones((3, 14, 2)))
    out = tmp_path / "out.npy"
    assert main(["recover", str(src), "-o", str(out), "--backend", "dask"]) == 2
    assert "needs distributed (the sparseedm[dask] extra)" in capsys.readouterr().err
    assert not out.exists()


def test_progress_lines_on_stderr_and_none_with_quiet(cmu_poses, small_dictionary_path,
                                                      tmp_path, capsys):
    rng = np.random.default_rng(0)
    poses = np.concatenate([cmu_poses, cmu_poses + rng.normal(0, 1, cmu_poses.shape)])
    poses[rng.random(len(poses)) < 0.3, 3] = np.nan
    src = tmp_path / "in.npy"
    np.save(src, poses)
    args = ["recover", str(src), "--dictionary", str(small_dictionary_path),
            "--self-training", "1"]
    assert main(args + ["-o", str(tmp_path / "a.npy")]) == 0
    err = capsys.readouterr().err
    assert "sparseedm: adapting the dictionary on" in err
    assert f"sparseedm: recovering {len(poses):,} poses" in err
    assert main(args + ["-o", str(tmp_path / "b.npy"), "--quiet"]) == 0
    assert "sparseedm: " not in capsys.readouterr().err
    assert not _progress.enabled()  # main() turns it off again: the API stays silent


def test_ensemble_names_each_dropped_member(monkeypatch, capsys):
    import sparseedm.ensemble as ens
    from sparseedm.adaptation import AdaptationResult

    def fake(dictionary, poses, missing, adapt, *, random_state, **kw):
        adopted = random_state != 2
        return dictionary, AdaptationResult(
            dictionary=dictionary, adapted=adopted,
            reason="better" if adopted else "the adapted dictionary was not better")

    monkeypatch.setattr(ens, "resolve_adaptation", fake)
    _progress.enable(True)
    try:
        members, _ = ens.adapt_members("d", None, None, "auto", 4)
    finally:
        _progress.enable(False)
    assert len(members) == 3
    err = capsys.readouterr().err
    assert "ensemble: member seed 2 dropped: the adapted dictionary was not better" in err
    assert "seed 1 dropped" not in err and "seed 3 dropped" not in err


# --------------------------------------------------------------------------
# messages: the same words for the same problem, in every command


def test_lift_and_joint_map_say_no_such_file(tmp_path, capsys):
    dlc = str(Path(__file__).parent / "fixtures" / "formats" / "dlc.csv")
    missing = str(tmp_path / "nothere.csv")
    assert main(["lift", missing, "-o", str(tmp_path / "o.csv")]) == 2
    assert capsys.readouterr().err.strip() == f"sparseedm lift: error: {missing}: no such file"
    assert main(["recover", missing, "-o", str(tmp_path / "o.csv")]) == 2
    assert capsys.readouterr().err.strip() == \
        f"sparseedm recover: error: {missing}: no such file"
    no_map = str(tmp_path / "nonexist.json")
    for command in ("recover", "lift"):
        assert main([command, dlc, "-o", str(tmp_path / "o.csv"), "--joint-map", no_map]) == 2
        err = capsys.readouterr().err
        assert err.strip() == f"sparseedm {command}: error: {no_map}: no such joints map file"
    assert not (tmp_path / "o.csv").exists()


def test_lift_jobs_zero_names_lift(tmp_path, capsys):
    src = str(Path(__file__).parents[1] / "examples" / "video_clip.csv")
    assert main(["lift", src, "-o", str(tmp_path / "o.csv"), "--jobs", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sparseedm lift: error: lift_file: n_jobs must be") and "fit:" not in err


def test_api_warnings_are_one_line_in_the_cli_and_warnings_in_the_api(capsys):
    import warnings

    from sparseedm.cli import _warning_line

    with pytest.warns(UserWarning, match="from elsewhere"), warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = _warning_line("lift")
        warnings.warn_explicit("skipped x.json: bad", UserWarning, _progress.__file__, 7)
        warnings.warn_explicit("from elsewhere", UserWarning, "/elsewhere/lib.py", 3)
    err = capsys.readouterr().err  # another library's warning: shown as Python shows it
    assert err == "sparseedm lift: warning: skipped x.json: bad\n"


def test_help_names_every_format_recover_reads_and_writes(capsys):
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    summary = next(c.help for c in sub._choices_actions if c.dest == "recover")
    for fmt in ("OpenPose", "MMPose", "AlphaPose", "PoseTrack", "DeepLabCut .csv/.h5", "COCO"):
        assert fmt in summary
    out = next(a for a in sub.choices["recover"]._actions if a.dest == "output").help
    for what in (".h5", "folder", "MMPose .json", ".npy"):
        assert what in out


@pytest.mark.parametrize("argv", [["recover", "in.csv", "-o", "-"],
                                  ["recover", "in.csv", "-o", "o.csv", "--errors", "-"],
                                  ["lift", "in.csv", "-o", "-"],
                                  ["fit", "t.npz", "-o", "d.npz", "--checkpoint", "-"],
                                  ["dataset", "build", "a.bvh", "-o", "-"]])
def test_dash_is_not_a_file_named_dash(tmp_path, monkeypatch, capsys, argv):
    """Outputs land at exactly the path given, and '-' would be a file called '-':
    refused, naming /dev/stdout (and ./- for that file)."""
    monkeypatch.chdir(tmp_path)
    np.savetxt("in.csv", np.zeros((0, 28)))  # never read: refused first
    assert main(argv + ["-q"]) == 2
    err = capsys.readouterr().err
    assert "'-' is not standard output here" in err and "/dev/stdout" in err
    assert not (tmp_path / "-").exists()


def test_a_mistyped_command_is_answered_with_the_nearest_one(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["recovr", "in.csv", "-o", "out.csv"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: sparseedm")
    assert "invalid choice: 'recovr'" in err and "did you mean 'recover'?" in err


def test_a_mistyped_option_is_answered_with_the_nearest_ones(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["recover", "in.csv", "-o", "out.csv", "--confidence-treshold", "0.5"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: sparseedm recover")  # the command's own usage line
    assert "unrecognized arguments: --confidence-treshold 0.5" in err
    assert "did you mean '--confidence-threshold'?" in err
    with pytest.raises(SystemExit):
        main(["recover", "in.csv", "-o", "out.csv", "--solver", "fsat"])
    assert "did you mean 'fast'?" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # nothing near: argparse's message alone
        main(["recover", "in.csv", "-o", "out.csv", "--zzzzzz"])
    assert "did you mean" not in capsys.readouterr().err


def test_fit_lifter_says_its_stages_unless_quiet(fixtures_dir, tmp_path, capsys):
    argv = ["fit-lifter", str(fixtures_dir / "cmu_poses.npz"), "--atoms", "40",
            "--passes", "1"]
    assert main(argv + ["-o", str(tmp_path / "a.npz")]) == 0
    err = capsys.readouterr().err
    assert "sparseedm: fitting a dictionary lifter on 334 training poses" in err
    assert "sparseedm: learning 40 atoms from 334 samples" in err
    assert "sparseedm: re-fitting the 3D halves" in err
    assert main(argv + ["-o", str(tmp_path / "b.npz"), "-q"]) == 0
    assert "sparseedm:" not in capsys.readouterr().err


def test_fit_says_its_batches_off_a_terminal(fixtures_dir, tmp_path, capsys):
    argv = ["fit", str(fixtures_dir / "cmu_poses.npz"), "--atoms", "40"]
    assert main(argv + ["-o", str(tmp_path / "a.npz")]) == 0
    assert "sparseedm: learning 40 atoms from 334 poses: 2 mini-batches" in \
        capsys.readouterr().err
    assert main(argv + ["-o", str(tmp_path / "b.npz"), "-q"]) == 0
    assert "sparseedm:" not in capsys.readouterr().err
