"""Files that are not files, refusals that come late, answers that only
look right, crashes on valid but extreme input.

Device nodes and named pipes are made in pytest's temporary folder, never the
system's (``os.mknod`` needs root: those tests skip without it), and every test
asserts they are still what they were after the run.
"""

from __future__ import annotations

import os
import stat
import threading
from pathlib import Path

import numpy as np
import pytest

from sparseedm._atomic import atomic_path, check_paths
from sparseedm.cli import main
from sparseedm.exceptions import OutputPathError
from sparseedm.keypoints import read_keypoints, write_keypoints
from sparseedm.metrics import random_occlusion

N = 12


@pytest.fixture(scope="module")
def occluded(cmu_poses):
    poses = cmu_poses[::13][:N].copy()
    missing = random_occlusion(N, 14, "mix", random_state=5)
    poses[missing] = np.nan
    return poses


@pytest.fixture
def good_csv(tmp_path, occluded):
    path = tmp_path / "good.csv"
    write_keypoints(path, occluded)
    return path


def _null_device(folder: Path) -> Path:
    """A character device like /dev/null (1, 3), made in `folder` (root only)."""
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    node = folder / "null"
    os.mknod(node, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    return node


def _is_char_device(path) -> bool:
    return stat.S_ISCHR(os.lstat(path).st_mode)


def _read_fifo(path, into):
    """Start a reader on the FIFO `path` (as a shell's `cat fifo` would)."""
    thread = threading.Thread(target=lambda: into.append(Path(path).read_bytes()),
                              daemon=True)
    thread.start()
    return thread


# --------------------------------------------------------------------------
# 1. write only regular files, only where asked


def test_output_to_a_device_is_written_through(tmp_path, good_csv, small_dictionary_path):
    node = _null_device(tmp_path)
    code = main(["recover", str(good_csv), "-o", str(node), "--dictionary",
                 str(small_dictionary_path), "--no-adapt", "--quiet"])
    assert code in (0, 1)
    assert _is_char_device(node)          # still the device, not a regular file
    assert not any(p.name.startswith(".null") for p in tmp_path.iterdir())


def test_errors_file_on_a_device_stays_a_device(tmp_path, good_csv, small_dictionary_path):
    node = _null_device(tmp_path)
    poses = read_keypoints(good_csv).poses
    poses[0, 2:] = np.nan                   # one row refused: the errors file is written
    write_keypoints(good_csv, poses)
    code = main(["recover", str(good_csv), "-o", str(tmp_path / "o.csv"), "--errors",
                 str(node), "--dictionary", str(small_dictionary_path), "--no-adapt",
                 "--quiet"])
    assert code == 1
    assert _is_char_device(node)
    assert len(read_keypoints(tmp_path / "o.csv")) == N


def test_symlink_to_a_device_is_kept(tmp_path, good_csv, small_dictionary_path):
    node = _null_device(tmp_path)
    link = tmp_path / "stdout"
    link.symlink_to(node)
    main(["recover", str(good_csv), "-o", str(link), "--dictionary",
          str(small_dictionary_path), "--no-adapt", "--quiet"])
    assert link.is_symlink() and _is_char_device(node)


def test_output_to_a_fifo_reaches_its_reader(tmp_path, good_csv, small_dictionary_path):
    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    got = []
    reader = _read_fifo(fifo, got)
    code = main(["recover", str(good_csv), "-o", str(fifo), "--dictionary",
                 str(small_dictionary_path), "--no-adapt", "--quiet"])
    reader.join(timeout=60)
    assert code in (0, 1)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    (tmp_path / "copy.csv").write_bytes(got[0])
    assert len(read_keypoints(tmp_path / "copy.csv")) == N


def test_atomic_path_streams_into_a_fifo_and_keeps_it(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = _read_fifo(fifo, got)
    with atomic_path(fifo) as tmp:
        Path(tmp).write_text("a,b\n1,2\n")
    reader.join(timeout=60)
    assert got == [b"a,b\n1,2\n"] and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_symlink_to_a_regular_file_keeps_the_link(tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("old")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    with atomic_path(link) as tmp:
        Path(tmp).write_text("new")
    assert link.is_symlink() and target.read_text() == "new"


def test_dangling_symlink_keeps_the_link_and_makes_its_target(tmp_path):
    """Only regular files are replaced: a link to a file not written yet stays a link,
    and the output is made where it points."""
    (tmp_path / "data").mkdir()
    target = tmp_path / "data" / "out.csv"
    link = tmp_path / "out.csv"
    link.symlink_to(target)
    with atomic_path(link) as tmp:
        Path(tmp).write_text("new")
    assert link.is_symlink() and target.read_text() == "new"


def test_socket_and_block_device_refused(tmp_path):
    import socket

    sock_path = tmp_path / "s.csv"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(sock_path))
        with pytest.raises(OutputPathError, match="is a socket, not a regular file"):
            check_paths([], [("-o", sock_path)])
        with pytest.raises(OutputPathError, match="socket"):
            with atomic_path(sock_path) as tmp:
                Path(tmp).write_text("x")
        assert stat.S_ISSOCK(os.lstat(sock_path).st_mode)
    if os.geteuid() == 0:
        blk = tmp_path / "disk"
        os.mknod(blk, 0o600 | stat.S_IFBLK, os.makedev(7, 200))
        with pytest.raises(OutputPathError, match="block device"):
            check_paths([], [("-o", blk)])
        assert stat.S_ISBLK(os.lstat(blk).st_mode)


def test_lifter_path_is_an_input_whatever_its_name(tmp_path, good_csv):
    from sparseedm.lifting.base import _resolve

    lifter = tmp_path / "L"
    lifter.write_bytes(Path(_resolve(None)).read_bytes())
    before = lifter.read_bytes()
    code = main(["lift", str(good_csv), "-o", str(lifter), "--lifter", str(lifter),
                 "--format", "csv", "--quiet"])
    assert code == 2 and lifter.read_bytes() == before


def test_shipped_dictionary_is_never_a_write_target(tmp_path, good_csv,
                                                    small_dictionary_path, capsys):
    from sparseedm.dictionary import _resolve

    shipped = Path(_resolve(None))
    stamp = shipped.stat().st_mtime_ns
    # checked first, so that a regression fails here before anything is written
    with pytest.raises(OutputPathError, match="shipped with sparseedm"):
        check_paths([], [("--save-dictionary", shipped)])
    code = main(["recover", str(good_csv), "-o", str(tmp_path / "o.csv"), "--dictionary",
                 str(small_dictionary_path), "--no-adapt", "--quiet",
                 "--save-dictionary", str(shipped)])
    assert code == 2 and "shipped with sparseedm" in capsys.readouterr().err
    assert shipped.stat().st_mtime_ns == stamp and not (tmp_path / "o.csv").exists()


def test_long_output_name_is_written(tmp_path):
    out = tmp_path / ("p" * 240 + ".csv")
    with atomic_path(out) as tmp:
        Path(tmp).write_text("x")
    assert out.read_text() == "x" and [p.name for p in tmp_path.iterdir()] == [out.name]


# --------------------------------------------------------------------------
# 2. one exit code per outcome


def test_internal_error_has_its_own_exit_code(tmp_path, good_csv, monkeypatch, capsys):
    import sparseedm.batch

    def broken(*args, **kwargs):
        raise TypeError("unsupported operand type(s) for *: 'float' and 'str'")

    monkeypatch.setattr(sparseedm.batch, "recover_file", broken)
    argv = ["recover", str(good_csv), "-o", str(tmp_path / "o.csv"), "--quiet"]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "internal error (TypeError" in err
    assert "Traceback" not in err
    assert main([*argv, "--debug"]) == 3
    assert "Traceback" in capsys.readouterr().err


def test_help_documents_the_exit_codes(capsys):
    with pytest.raises(SystemExit):
        main(["recover", "--help"])
    assert "3 internal error" in " ".join(capsys.readouterr().out.split())


def test_late_save_dictionary_refusal_writes_nothing(tmp_path, good_csv,
                                                     small_dictionary_path, capsys):
    out = tmp_path / "o.csv"
    code = main(["recover", str(good_csv), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--quiet", "--save-dictionary",
                 str(tmp_path / "d.csv")])
    assert code == 2 and not out.exists() and not (tmp_path / "d.csv").exists()
    assert "must end in .npz" in capsys.readouterr().err


@pytest.mark.parametrize("jobs", ["100000", "99999999999999999999"])
def test_jobs_past_the_machine_run_what_can_run(tmp_path, good_csv, small_dictionary_path,
                                                jobs):
    out = tmp_path / "o.csv"
    code = main(["recover", str(good_csv), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--no-adapt", "--quiet", "--jobs", jobs])
    assert code in (0, 1) and len(read_keypoints(out)) == N


def test_api_n_jobs_past_the_machine(occluded, small_dictionary):
    from sparseedm import recover

    res = recover(occluded[:4], dictionary=small_dictionary, n_jobs=100000, adapt=False)
    ref = recover(occluded[:4], dictionary=small_dictionary, adapt=False)
    assert np.array_equal(res.status, ref.status)
    np.testing.assert_allclose(res.poses, ref.poses, atol=1e-9)


# --------------------------------------------------------------------------
# 3-4. valid but extreme values; answers that only look right


def test_alpha_scaling_none_recovers(occluded, small_dictionary):
    from dataclasses import replace

    from sparseedm import recover

    flat = replace(small_dictionary, alpha_scaling="none")
    res = recover(occluded[:5], dictionary=flat, adapt=False)
    assert set(res.status) <= {"recovered", "inaccurate", "complete"}


@pytest.mark.parametrize("alpha", ["1e308", "5e-324", "1000"])
def test_alpha_outside_the_solvers_range_is_bad_input(tmp_path, good_csv,
                                                      small_dictionary_path, alpha, capsys):
    out = tmp_path / "o.csv"
    code = main(["recover", str(good_csv), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--no-adapt", "--quiet", "--alpha", alpha])
    assert code == 2 and not out.exists()
    assert "alpha must be a real number in [1e-06, 100.0]" in capsys.readouterr().err


def test_all_zero_code_is_not_recovered(occluded, small_dictionary):
    from sparseedm import recover
    from sparseedm.recovery import STATUSES

    res = recover(occluded, dictionary=small_dictionary, alpha=100.0, adapt=False)
    incomplete = np.isnan(occluded).any(axis=(1, 2))
    assert incomplete.any()
    assert (res.status[incomplete] == "empty_code").all()
    assert np.isnan(res.poses[incomplete]).all(axis=(1, 2)).all()
    assert "alpha" in res.reason[incomplete][0] and "empty_code" in STATUSES


@pytest.mark.parametrize("field, value", [("normalization", "zscore"),
                                          ("representation", "bogus"),
                                          ("alpha_scaling", "sqrt"),
                                          ("alpha_recover", 1e300)])
def test_dictionary_meta_outside_its_closed_set_is_refused(tmp_path, small_dictionary,
                                                          field, value):
    import json

    from sparseedm.dictionary import load_dictionary
    from sparseedm.exceptions import DictionaryError

    path = small_dictionary.save(tmp_path / "d.npz")
    with np.load(path) as z:
        arrays = dict(z)
    meta = json.loads(str(arrays["meta"]))
    meta[field] = value
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    with pytest.raises(DictionaryError, match=f"metadata '{field}' must be"):
        load_dictionary(path)


def test_masked_array_mask_is_missing(occluded, small_dictionary):
    from sparseedm import recover

    full = np.nan_to_num(occluded, nan=50.0)          # hidden values where joints were missing
    masked = np.ma.array(full, mask=np.repeat(np.isnan(occluded), 1, axis=-1))
    res = recover(masked, dictionary=small_dictionary, adapt=False)
    ref = recover(occluded, dictionary=small_dictionary, adapt=False)
    assert np.array_equal(res.missing, np.isnan(occluded).any(axis=-1))
    assert np.array_equal(res.status, ref.status) and "complete" not in set(ref.status[
        np.isnan(occluded).any(axis=(1, 2))])
    np.testing.assert_allclose(res.poses, ref.poses, atol=1e-9)


def test_masked_array_lifted_as_missing(occluded):
    from sparseedm import lift

    full = np.nan_to_num(occluded[:3], nan=50.0)
    res = lift(np.ma.array(full, mask=np.isnan(occluded[:3])))
    ref = lift(occluded[:3])
    assert np.array_equal(res.status, ref.status)


def test_xyz_npy_is_not_read_as_confidence(tmp_path, cmu_poses, capsys):
    xyz = np.concatenate([cmu_poses[:5], -np.ones((5, 14, 1))], axis=-1)
    path = tmp_path / "xyz.npy"
    np.save(path, xyz)
    from sparseedm.exceptions import FileFormatError

    with pytest.raises(FileFormatError, match=r"x, y, confidence.*pose 0, joint 0.*-1"):
        read_keypoints(path)
    code = main(["recover", str(path), "-o", str(tmp_path / "o.npy"), "--no-adapt", "-q"])
    assert code == 2 and "x, y, confidence" in capsys.readouterr().err
    assert not (tmp_path / "o.npy").exists()


@pytest.mark.parametrize("command, ext, fmt", [("recover", "csv", "npy"),
                                               ("recover", "npz", "csv"),
                                               ("lift", "csv", "json")])
def test_extension_and_format_never_disagree(tmp_path, good_csv, command, ext, fmt, capsys):
    out = tmp_path / f"o.{ext}"
    code = main([command, str(good_csv), "-o", str(out), "--format", fmt, "--quiet"]
                + (["--no-adapt"] if command == "recover" else []))
    assert code == 2 and not out.exists()
    assert "its extension says" in capsys.readouterr().err


@pytest.mark.parametrize("extra, message", [
    (["--scheduler", "tcp://127.0.0.1:1"], "needs backend='dask'"),
    (["--no-adapt", "--ensemble", "3"], "needs adaptation"),
])
def test_options_that_cannot_apply_are_refused(tmp_path, good_csv, small_dictionary_path,
                                               extra, message, capsys):
    out = tmp_path / "o.csv"
    code = main(["recover", str(good_csv), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--quiet", *extra])
    assert code == 2 and not out.exists() and message in capsys.readouterr().err


def test_api_cases_become_parameter_errors(occluded, small_dictionary, tmp_path):
    from sparseedm import adapt, lift, load_dictionary, recover
    from sparseedm.exceptions import DictionaryError, ParameterError

    res = recover(occluded[:3], dictionary=small_dictionary, chunk_size=np.uint64(7),
                  adapt=False)
    assert len(res.status) == 3
    with pytest.raises(ParameterError, match="lifter"):
        lift(occluded[:2], lifter=small_dictionary)
    with pytest.raises(ParameterError, match="lifter"):
        lift(occluded[:2], lifter=123)
    with pytest.raises(DictionaryError, match="not a dictionary name or path"):
        load_dictionary("x" * 5000)
    with pytest.raises(ParameterError, match="model"):
        recover(occluded[:2], dictionary=small_dictionary, model="m.npz", adapt=False)
    for bad in (occluded.astype(str), occluded.astype(complex),
                occluded.astype(object).tolist() + [["x"]]):
        with pytest.raises(ParameterError, match="adapt"):
            adapt(small_dictionary, bad)


def test_files_that_are_not_files_are_named(tmp_path, good_csv, capsys):
    from sparseedm import load_dictionary
    from sparseedm.exceptions import DictionaryError

    fifo = tmp_path / "d.npz"
    os.mkfifo(fifo)
    with pytest.raises(DictionaryError, match="not a regular file"):
        load_dictionary(fifo)
    with pytest.raises(DictionaryError, match="is a directory"):
        load_dictionary(tmp_path)
    assert main(["recover", str(good_csv), "-o", str(tmp_path / "o.csv"), "--dictionary",
                 str(fifo), "--quiet"]) == 2
    assert "not a regular file" in capsys.readouterr().err


def test_lifter_given_as_dictionary_says_so(tmp_path, good_csv, capsys):
    from sparseedm.lifting.base import _resolve

    code = main(["recover", str(good_csv), "-o", str(tmp_path / "o.csv"), "--dictionary",
                 str(_resolve(None)), "--quiet"])
    assert code == 2 and "lifter file, not a dictionary" in capsys.readouterr().err


def test_csv_line_limit_is_the_documented_one(tmp_path, occluded):
    from sparseedm._safeio import MAX_LINE_BYTES

    path = tmp_path / "long.csv"
    write_keypoints(path, occluded[:2], ids=["a" * 200_000, "b"])
    kps = read_keypoints(path)                      # 200 kB in one field: under 1 MiB
    assert kps.ids[0] == "a" * 200_000 and MAX_LINE_BYTES == 1 << 20


# --------------------------------------------------------------------------
# motion capture and dataset builds


def _one_frame_bvh(fixtures_dir, root=None, bom=False):
    lines = (fixtures_dir / "cmu_02_01_short.bvh").read_text().splitlines()
    motion = next(i for i, line in enumerate(lines) if line.startswith("MOTION"))
    frame = lines[motion + 3].split()
    if root is not None:
        frame[:3] = [root] * 3
    text = "\n".join(lines[:motion + 1] + ["Frames: 1", lines[motion + 2], " ".join(frame)])
    return ("\ufeff" if bom else "") + text + "\n"


def test_folder_build_skips_a_clip_far_off_and_keeps_the_rest(tmp_path, fixtures_dir,
                                                              capsys):
    folder = tmp_path / "clips"
    folder.mkdir()
    (folder / "good.bvh").write_bytes((fixtures_dir / "cmu_02_01_short.bvh").read_bytes())
    (folder / "far.bvh").write_text(_one_frame_bvh(fixtures_dir, root="1e200"))
    out = tmp_path / "set.npz"
    code = main(["dataset", "build", str(folder), "-o", str(out)])
    assert code == 1 and out.exists()
    assert "skipped" in capsys.readouterr().out
    with np.load(out) as z:
        assert len(z["poses3d"]) > 0
        assert {c.rsplit("/", 1)[-1] for c in z["clips"].tolist()} == {"good"}


def test_bvh_with_a_bom_reads(tmp_path, fixtures_dir):
    from sparseedm.mocap import load_mocap

    path = tmp_path / "bom.bvh"
    path.write_text(_one_frame_bvh(fixtures_dir, bom=True), encoding="utf-8")
    assert load_mocap(path).shape == (1, 14, 3)


def test_counts_are_bounded_before_allocating(tmp_path, fixtures_dir, capsys):
    out = tmp_path / "set.npz"
    code = main(["dataset", "build", str(fixtures_dir / "cmu_02_01_short.bvh"), "-o", str(out),
                 "--cameras-per-pose", "100000000", "--quiet"])
    assert code == 2 and not out.exists() and "cameras_per_pose" in capsys.readouterr().err


def test_dataset_output_extension_is_exact(tmp_path, fixtures_dir):
    out = tmp_path / "o.NPZ"
    assert main(["dataset", "build", str(fixtures_dir / "cmu_02_01_short.bvh"), "-o", str(out),
                 "--quiet"]) == 2
    assert not out.exists()


def test_inspect_a_pipe_or_device_is_bounded_and_named(tmp_path, capsys):
    fifo = tmp_path / "walk.bvh"
    os.mkfifo(fifo)
    assert main(["dataset", "inspect", str(fifo)]) == 2
    assert "not a regular file" in capsys.readouterr().err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    if os.geteuid() == 0:
        zero = tmp_path / "zero.bvh"
        os.mknod(zero, 0o666 | stat.S_IFCHR, os.makedev(1, 5))   # like /dev/zero
        assert main(["dataset", "inspect", str(zero)]) == 2
        assert "not a regular file" in capsys.readouterr().err
        assert main(["dataset", "build", str(zero), "-o", str(tmp_path / "o.npz")]) == 2
        assert "not a regular file" in capsys.readouterr().err


def test_write_map_is_json_by_name(tmp_path, fixtures_dir, capsys):
    out = tmp_path / "map.toml"
    assert main(["dataset", "inspect", str(fixtures_dir / "cmu_02_01_short.bvh"),
                 "--write-map", str(out)]) == 2
    assert not out.exists() and "ending in .json" in capsys.readouterr().err


def test_forced_implausible_units_warn_under_quiet_and_exit_1(tmp_path, fixtures_dir, capsys):
    out = tmp_path / "set.npz"
    code = main(["dataset", "build", str(fixtures_dir / "cmu_02_01_short.bvh"), "-o", str(out),
                 "--units", "mm", "--quiet"])
    err = capsys.readouterr().err
    assert code == 1 and "--units mm gives implausible poses" in err


def test_no_poses_names_the_tpose_rule(tmp_path, fixtures_dir, monkeypatch, capsys):
    import sparseedm.dataset
    from sparseedm.mocap import load_mocap

    def one_tpose_frame(path, **kw):
        poses, info = load_mocap(path, **kw)
        info["tpose_frames"] = np.arange(len(poses))
        return poses, info

    monkeypatch.setattr(sparseedm.dataset, "load_mocap", one_tpose_frame)
    code = main(["dataset", "build", str(fixtures_dir / "cmu_02_01_short.bvh"), "-o",
                 str(tmp_path / "o.npz"), "--quiet"])
    assert code == 2 and "T-pose frame(s) dropped" in capsys.readouterr().err


def test_gram_matrix_checked_against_memory(small_dictionary, occluded, monkeypatch):
    import sparseedm.dictionary
    from sparseedm import recover
    from sparseedm.exceptions import DictionaryError

    k = small_dictionary.n_components
    monkeypatch.setattr(sparseedm.dictionary, "available_memory", lambda: 8 * k * k)
    with pytest.raises(DictionaryError, match=f"{k} atoms need a .* GiB Gram matrix"):
        recover(occluded[:2], dictionary=small_dictionary, adapt=False)


def test_stdout_output_keeps_the_summary_off_the_data(tmp_path, good_csv,
                                                      small_dictionary_path):
    import subprocess
    import sys

    code = ("import sys; from sparseedm.cli import main; sys.exit(main(sys.argv[1:]))")
    run = subprocess.run([sys.executable, "-c", code, "recover", str(good_csv), "-o",
                          "/dev/stdout", "--dictionary", str(small_dictionary_path),
                          "--no-adapt", "--format", "csv"],
                         capture_output=True, cwd=tmp_path, timeout=600)
    assert run.returncode in (0, 1), run.stderr
    (tmp_path / "copy.csv").write_bytes(run.stdout)
    assert len(read_keypoints(tmp_path / "copy.csv")) == N      # only the CSV on stdout
    assert b"wrote /dev/stdout" in run.stderr


def test_lift_n_jobs_past_the_machine(occluded):
    from sparseedm import lift

    res = lift(occluded[:4], n_jobs=100000)
    assert np.array_equal(res.status, lift(occluded[:4]).status)


def test_model_and_training_file_folders_are_named(tmp_path, capsys):
    """A folder is a keypoint input (OpenPose frames, MMPose files): an empty one is
    named with what it lacks."""
    assert main(["fit", str(tmp_path), "-o", str(tmp_path / "d.npz")]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path) in err and "no readable OpenPose frame files" in err


def test_debug_after_a_nested_command(tmp_path, monkeypatch, capsys):
    import sparseedm.dataset

    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(sparseedm.dataset, "build_dataset", broken)
    argv = ["dataset", "build", str(tmp_path), "-o", str(tmp_path / "o.npz"), "--debug"]
    assert main(argv) == 3
    assert "Traceback" in capsys.readouterr().err


def test_ensemble_and_atom_counts_bounded(occluded, small_dictionary, tmp_path, monkeypatch):
    from sparseedm import recover
    from sparseedm.exceptions import ParameterError
    from sparseedm.learning import check_params

    with pytest.raises(ParameterError, match="ensemble"):
        recover(occluded[:2], dictionary=small_dictionary, ensemble=100000)
    with pytest.raises(ParameterError, match="n_components=10000000 needs about"):
        check_params(10_000_000, 0.1)


def test_dataset_joint_map_is_an_input_whatever_its_name(tmp_path, fixtures_dir, capsys):
    joint_map = tmp_path / "map.npz"          # a JSON joint map under an .npz name
    joint_map.write_text('{"joints": {}}')
    before = joint_map.read_bytes()
    code = main(["dataset", "build", str(fixtures_dir / "cmu_02_01_short.bvh"), "-o",
                 str(joint_map), "--joint-map", str(joint_map), "--quiet"])
    assert code == 2 and joint_map.read_bytes() == before
    assert "refusing to overwrite" in capsys.readouterr().err


@pytest.fixture
def unwritable(tmp_path):
    """A folder nobody may write in: read-only modes, or (as root, whom modes do
    not stop) the immutable attribute; the test skips where neither holds."""
    import subprocess

    folder = tmp_path / "ro"
    folder.mkdir()
    if os.geteuid() != 0:
        folder.chmod(0o555)
    elif subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode:
        pytest.skip("cannot make a folder unwritable here (chattr +i refused)")
    try:
        yield folder
    finally:
        if os.geteuid() == 0:
            subprocess.run(["chattr", "-i", str(folder)], capture_output=True)
        folder.chmod(0o755)


@pytest.mark.parametrize("command, name", [("recover", "out.csv"), ("recover", "frames"),
                                           ("lift", "out.trc"), ("lift", "sub/out.csv")])
def test_an_unwritable_output_folder_is_refused_before_any_work(
        tmp_path, good_csv, small_dictionary_path, unwritable, monkeypatch, capsys,
        command, name):
    import sparseedm.batch
    import sparseedm.lifting.io

    def started(*a, **k):
        raise AssertionError("the work started before the output was checked")

    for module, fn in [(sparseedm.batch, "_adapt"), (sparseedm.batch, "_run"),
                       (sparseedm.lifting.io, "_lift_chunks")]:
        monkeypatch.setattr(module, fn, started)
    extra = ["--dictionary", str(small_dictionary_path), "--format", "openpose"] \
        if name == "frames" else ["--dictionary", str(small_dictionary_path)] \
        if command == "recover" else []
    code = main([command, str(good_csv), "-o", str(unwritable / name), "-q", *extra])
    err = capsys.readouterr().err
    assert code == 2 and f"the folder {unwritable} is not writable" in err, err
    assert "Errno" not in err and os.listdir(unwritable) == []


# --------------------------------------------------------------------------
# frame numbers: one rule; the environment and warning filters


def _openpose_folder(folder, names, truncated=()):
    import json

    person = {"people": [{"person_id": [-1], "pose_keypoints_2d": [
        float(v) for i in range(25) for v in (100 + 3 * i, 200 + 5 * i, 0.9)]}]}
    folder.mkdir()
    for name in names:
        text = json.dumps(person)
        (folder / name).write_text(text[:40] if name in truncated else text)
    return folder


def test_openpose_frame_past_int64_is_refused_per_row_not_an_internal_error(tmp_path,
                                                                           capsys):
    """A file named for frame 10**20 is answered as a frame past 2**53 is: per row."""
    names = [f"vid_{i:012d}_keypoints.json" for i in range(3)] + \
        ["vid_99999999999999999999_keypoints.json"]
    folder = _openpose_folder(tmp_path / "op", names)
    kps = read_keypoints(folder)
    assert kps.frames.tolist() == [0, 1, 2, 10**20 - 1]
    out = tmp_path / "o.csv"
    assert main(["recover", str(folder), "-o", str(out), "-q"]) == 0
    assert "internal error" not in capsys.readouterr().err
    last = out.read_text().splitlines()[-1]
    assert "frame number 99999999999999999999 is too large (over 2**53)" in last


@pytest.mark.parametrize("cell", ["1_0", "\uff11\uff10", "\u0661\u0660"])
def test_frame_cells_python_reads_as_numbers_are_refused_per_row(tmp_path, occluded, cell):
    """'1_0' is not frame 10, nor are full-width or Arabic-Indic digits: refused
    per row by the one frame-number rule, as a coordinate cell would be."""
    from sparseedm.temporal.tracks import frame_numbers

    src = tmp_path / "clip.csv"
    write_keypoints(src, occluded[:3], extra_columns={"frame": ["0", cell, "2"]})
    frames = read_keypoints(src).frames
    values, reason = frame_numbers(frames, 3)
    assert reason.tolist() == ["", f"frame number {cell!r} is not a number", ""]


def test_a_bad_numba_thread_count_is_named_with_exit_2(tmp_path, good_csv):
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_NUM_THREADS="0")
    proc = subprocess.run([sys.executable, "-m", "sparseedm", "recover", str(good_csv), "-o",
                           str(tmp_path / "o.csv"), "-q"], capture_output=True, text=True,
                          env=env, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "NUMBA_NUM_THREADS='0'" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "o.csv").exists()


def test_warnings_raised_as_errors_are_bad_input_not_internal(tmp_path, capsys):
    """Under PYTHONWARNINGS=error a skipped (truncated) frame file stops the run with
    its own message and exit 2, never 'internal error'."""
    import warnings

    names = [f"vid_{i:012d}_keypoints.json" for i in range(4)]
    folder = _openpose_folder(tmp_path / "op", names, truncated=names[3:])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code = main(["recover", str(folder), "-o", str(tmp_path / "o.csv"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "internal error" not in err
    assert f"error: skipped {folder / names[3]}" in err and "warning filters" in err


def test_a_pipe_is_read_in_the_input_format_given(tmp_path, good_csv):
    """`cat in.csv | sparseedm recover /dev/stdin`: told to give --input-format (the
    option exists), and read with it."""
    import subprocess
    import sys

    def run(*extra):
        with open(good_csv, "rb") as stdin:
            return subprocess.run([sys.executable, "-m", "sparseedm", "recover", "/dev/stdin",
                                   "-o", str(tmp_path / "o.csv"), "--no-adapt", "-q", *extra],
                                  stdin=stdin, capture_output=True, text=True, timeout=300)

    proc = run()
    assert proc.returncode == 2 and "--input-format" in proc.stderr
    proc = run("--input-format", "csv")
    assert proc.returncode in (0, 1), proc.stderr
    assert len(read_keypoints(tmp_path / "o.csv")) == N


def test_a_253_byte_output_name_gets_an_errors_file_name_that_fits(tmp_path, good_csv,
                                                                   small_dictionary_path):
    """The default errors file of a long output name is shortened by a stated rule
    (the stem's first 120 bytes and a hash), not a reason to refuse the output."""
    from sparseedm.batch import default_errors_path

    out = tmp_path / ("p" * 249 + ".csv")
    bad = tmp_path / "bad.csv"
    poses = read_keypoints(good_csv).poses
    poses[0, 2:] = np.nan  # one row refused: the errors file is written
    write_keypoints(bad, poses)
    code = main(["recover", str(bad), "-o", str(out), "--dictionary",
                 str(small_dictionary_path), "--no-adapt", "-q"])
    errors = default_errors_path(out)
    assert code == 1 and out.is_file() and errors.is_file()
    assert len(errors.name.encode()) <= 255 and errors.name.endswith(".errors.csv")
    assert errors.name.startswith("p" * 120 + "~")


def test_a_dataframe_is_named_with_its_real_shape(good_csv, small_dictionary):
    pd = pytest.importorskip("pandas")
    from sparseedm import recover
    from sparseedm.exceptions import ParameterError, PoseError

    numbers = pd.read_csv(good_csv)  # 28 coordinate columns
    with_ids = numbers.assign(id=[f"f{i}" for i in range(N)])
    with pytest.raises(ParameterError, match=rf"in \({N}, 29\) \(pandas DataFrame\); pass its "
                                             r"numbers as \.to_numpy\(\)\.reshape"):
        recover(with_ids, dictionary=small_dictionary)
    with pytest.raises(PoseError, match=rf"got \({N}, 28\) \(pandas DataFrame\);.*"
                                        r"reshape\(n, 14, 2\).*read_keypoints"):
        recover(numbers, dictionary=small_dictionary)
    done = recover(numbers.to_numpy().reshape(N, 14, 2), dictionary=small_dictionary)
    assert done.poses.shape == (N, 14, 2)


@pytest.mark.parametrize("frames", [
    np.arange(N) % 2 == 0,
    np.arange(N).astype("datetime64[D]"),
    np.arange(N).astype("timedelta64[s]"),
    [True] + list(range(1, N)),
], ids=["bool", "datetime64", "timedelta64", "one-bool-in-a-list"])
def test_frames_of_booleans_or_dates_are_refused_naming_frames(frames, occluded,
                                                               small_dictionary):
    from sparseedm import recover
    from sparseedm.exceptions import ParameterError
    from sparseedm.temporal import recover_temporal

    for call, caller in ((recover, "recover"), (recover_temporal, "recover_temporal")):
        with pytest.raises(ParameterError, match=rf"{caller}: frames must be frame numbers"):
            call(occluded, frames=frames, dictionary=small_dictionary)
    done = recover(occluded, frames=np.arange(N), dictionary=small_dictionary)
    assert done.poses.shape == occluded.shape
