"""Malformed inputs and arguments give a SparseEDMError or a per-row status.

Never another exception, never a changed input, never a misplaced output, and
never unbounded work: every test here runs under an address-space cap
(``RLIMIT_AS`` = what the process maps now + 2 GiB), so a reader that believed
a header claiming terabytes would fail with MemoryError instead of passing.

The committed corpus (tests/fixtures/bad_input/, made by make_corpus.py)
names what each file must give: ``err_*`` an error, ``ok_*`` a result,
``rows_*`` per-row statuses; inputs too large to commit are made here.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import resource
import signal
import subprocess
import sys
import textwrap
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sparseedm
from sparseedm import OcclusionRecoverer, load_dictionary, recover
from sparseedm._atomic import TEMP_MARK, atomic_path, remove_leftovers
from sparseedm.batch import recover_file
from sparseedm.cli import main
from sparseedm.dataset import build_dataset
from sparseedm.evaluation import evaluate, sweep_atoms
from sparseedm.dictionary import Dictionary
from sparseedm.normalize import usable_rows
from sparseedm.exceptions import (DictionaryError, FileFormatError, OutputPathError,
                                  ParameterError, SparseEDMError)
from sparseedm.keypoints import read_keypoints, write_keypoints
from sparseedm.learning import fit_dictionary_file
from sparseedm.mocap import load_asf_amc, load_mocap
from sparseedm.recovery import STATUSES

ROOT = Path(__file__).resolve().parent
FIXTURES = ROOT / "fixtures"
CORPUS = FIXTURES / "bad_input"
KEYPOINT_DIRS = ("csv", "coco", "npy", "npz", "openpose", "mmpose", "alphapose", "dlc")
CORPUS_FILES = sorted(p for p in CORPUS.rglob("*") if p.is_file() and p.suffix != ".py")
SETTINGS = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])


# --------------------------------------------------------------------------
# harness


def _mapped_bytes():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0  # pragma: no cover


@pytest.fixture(autouse=True)
def memory_cap():
    """Cap the address space at what is mapped now + 2 GiB for the test's duration."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    mapped = _mapped_bytes()
    if not mapped:  # pragma: no cover - not Linux
        yield
        return
    cap = mapped + (2 << 30)
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def test_the_memory_cap_bites():
    """The cap is real: 3 GiB more than is mapped cannot be had under it."""
    with pytest.raises(MemoryError):
        np.ones(3 << 30, dtype=np.uint8)


def _digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@contextlib.contextmanager
def unchanged(*paths):
    """The files keep their bytes, and their folders gain nothing."""
    before = {Path(p): _digest(p) for p in paths if Path(p).is_file()}
    yield
    for p, digest in before.items():
        assert _digest(p) == digest, f"{p} was changed"


def _read(path):
    sub = path.parent.name
    if sub == "dictionary":
        return load_dictionary(path)
    if sub == "mocap":
        if path.suffix == ".bvh":
            return load_mocap(path)
        if path.suffix == ".amc":
            return load_asf_amc(FIXTURES / "cmu_02.asf", path)
        return load_asf_amc(path, FIXTURES / "cmu_02_01_short.amc")
    return read_keypoints(path)


def _expect(path):
    return "error" if path.name.startswith("err_") else "ok"


def _outcome(fn, *args, **kwargs):
    """'ok' or 'error' (a SparseEDMError); any other exception fails the test."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fn(*args, **kwargs)
    except SparseEDMError as exc:
        assert str(exc), "an error without a message"
        return "error"
    return "ok"


# --------------------------------------------------------------------------
# the committed corpus, through every public reader


def test_corpus_is_large_enough():
    bad = [p for p in CORPUS_FILES if not p.name.startswith("ok_")]
    assert len(CORPUS_FILES) >= 250 and len(bad) >= 200


@pytest.mark.parametrize("path", CORPUS_FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_corpus_reader(path):
    with unchanged(path):
        assert _outcome(_read, path) == _expect(path)


KEYPOINT_FILES = [p for p in CORPUS_FILES if p.parent.name in KEYPOINT_DIRS]


@pytest.mark.parametrize("path", KEYPOINT_FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_corpus_through_recover_file(path, tmp_path, small_dictionary):
    """Bad files: an error and nothing written. Readable ones: every row gets a
    status, the good rows are recovered, bad rows are flagged, not fatal."""
    out = tmp_path / ("out" + path.suffix)
    with unchanged(path):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                summary = recover_file(path, out, dictionary=small_dictionary)
        except SparseEDMError:
            assert _expect(path) == "error"
            assert os.listdir(tmp_path) == []
            return
    assert _expect(path) == "ok", f"{path.name} was accepted"
    assert out.is_file()
    assert sum(summary["status"].values()) == summary["poses"]
    assert set(summary["status"]) <= set(STATUSES)
    if path.name.startswith("rows_"):
        assert summary["refused"] >= 1, summary
        usable = sum(summary["status"].get(k, 0) for k in ("recovered", "complete"))
        assert usable == summary["poses"] - summary["refused"] >= 1, summary
        back = read_keypoints(out)
        ok = ~back.missing.all(axis=1)
        assert np.isfinite(back.poses[~back.missing]).all() and ok.any()


def test_cli_reports_every_bad_keypoint_file_without_traceback(tmp_path, capsys,
                                                                small_dictionary_path):
    bad = [p for p in KEYPOINT_FILES if p.name.startswith("err_")]
    assert len(bad) > 100
    for path in bad:
        code = main(["recover", str(path), "-o", str(tmp_path / f"o{path.suffix}"),
                     "--dictionary", str(small_dictionary_path), "-q"])
        err = capsys.readouterr().err
        assert code == 2 and "error:" in err and "Traceback" not in err, (path, err)
    assert os.listdir(tmp_path) == []


DICTIONARY_FILES = [p for p in CORPUS_FILES if p.parent.name == "dictionary"]


@pytest.mark.parametrize("path", DICTIONARY_FILES, ids=lambda p: p.name)
def test_cli_info_and_recover_with_each_dictionary(path, tmp_path, capsys):
    code = main(["info", str(path)])
    err = capsys.readouterr().err
    assert code == (2 if _expect(path) == "error" else 0) and "Traceback" not in err
    poses = np.load(FIXTURES / "cmu_poses.npz")["poses2d"][:2].astype(float)
    poses[:, 3] = np.nan
    with unchanged(path):
        outcome = _outcome(recover, poses, dictionary=path)
    # a dictionary for another layout loads, but is refused for SKELETON_14 poses
    assert outcome == ("error" if not path.name.startswith("ok_") else "ok")


def test_layout_mismatch_is_named(tmp_path):
    poses = np.load(FIXTURES / "cmu_poses.npz")["poses2d"][:1].astype(float)
    with pytest.raises(DictionaryError, match="position 0 is 'left_ankle'"):
        recover(poses, dictionary=CORPUS / "dictionary" / "layout_reversed.npz")
    with pytest.raises(DictionaryError, match="'head'"):
        recover_file(CORPUS / "npy" / "ok_float32.npy", tmp_path / "o.npy",
                     dictionary=str(CORPUS / "dictionary" / "layout_renamed.npz"))
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------
# hostile inputs made on the fly (too big to commit)


@pytest.mark.parametrize("suffix", [".csv", ".json", ".npy", ".npz"])
def test_dev_zero_is_refused_quickly(tmp_path, suffix):
    link = tmp_path / f"zero{suffix}"
    link.symlink_to("/dev/zero")
    with pytest.raises(FileFormatError):
        read_keypoints(link)


def test_endless_line_is_capped_while_read(tmp_path):
    path = tmp_path / "long.csv"
    path.write_bytes(b"id," + b"9" * (3 << 20) + b"\n")
    with pytest.raises(FileFormatError, match="line 1 .*longer than"):
        read_keypoints(path)


def test_deep_json_and_big_integers(tmp_path):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(FileFormatError, match="nested 100000 levels"):
        read_keypoints(deep)
    big = tmp_path / "big.json"
    big.write_text(json.dumps([{"keypoints": [10 ** 400] + [1] * 50}]))
    with pytest.raises(FileFormatError, match="401 digits"):
        read_keypoints(big)


def test_latin1_csv_names_the_byte(tmp_path):
    path = CORPUS / "csv" / "err_latin1_id.csv"
    offset = path.read_bytes().index(b"\xe9")
    with pytest.raises(FileFormatError, match=f"line 2, byte {offset}: not UTF-8"):
        read_keypoints(path)


def test_bom_keeps_the_ids():
    kps = read_keypoints(CORPUS / "csv" / "ok_bom.csv")
    assert kps.ids.tolist() == ["f0", "f1", "f2"]


def _zip_bomb(path, poses, member_bytes):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("poses.npy", "w") as f:
            np.save(f, poses)
        with z.open("blob.npy", "w", force_zip64=True) as f:
            np.lib.format.write_array_header_1_0(
                f, {"descr": "<f8", "fortran_order": False, "shape": (member_bytes // 8,)})
            block = bytes(1 << 20)
            for _ in range(member_bytes >> 20):
                f.write(block)


def test_zipped_extra_member_is_never_decompressed_nor_copied(tmp_path, small_dictionary):
    poses = np.load(FIXTURES / "cmu_poses.npz")["poses2d"][:3].astype(float)
    poses[:, 2] = np.nan
    path = tmp_path / "bomb.npz"
    _zip_bomb(path, poses, 256 << 20)          # 256 MB of zeros in ~250 kB
    assert path.stat().st_size < 1 << 20
    kps = read_keypoints(path)
    assert kps.meta["npz_ignored"] == ["blob"]
    recover_file(path, tmp_path / "out.npz", dictionary=small_dictionary)
    assert (tmp_path / "out.npz").stat().st_size < 1 << 20
    with zipfile.ZipFile(tmp_path / "out.npz") as z:
        assert "blob.npy" not in z.namelist()


def test_header_claiming_terabytes_in_a_compressed_member(tmp_path):
    path = tmp_path / "liar.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("poses.npy", "w") as f:
            np.lib.format.write_array_header_1_0(
                f, {"descr": "<f8", "fortran_order": False, "shape": (10 ** 11, 14, 2)})
            f.write(bytes(4096))
    with pytest.raises(FileFormatError, match="declares shape"):
        read_keypoints(path)
    dpath = tmp_path / "dict.npz"
    with zipfile.ZipFile(dpath, "w") as z:
        with z.open("components.npy", "w") as f:
            np.lib.format.write_array_header_1_0(
                f, {"descr": "<f8", "fortran_order": False, "shape": (10 ** 11, 91)})
        for name, arr in (("joint_names", np.array(sparseedm.skeleton.JOINT_NAMES)),
                          ("meta", np.array("{}"))):
            with z.open(f"{name}.npy", "w") as f:
                np.save(f, arr)
    with pytest.raises(DictionaryError, match="declares shape"):
        load_dictionary(dpath)


def test_honest_zip_bomb_in_a_wanted_member_is_refused_before_decompressing(
        tmp_path, monkeypatch):
    """A member whose true size exceeds the free memory is refused from its header."""
    from sparseedm import _safeio

    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, poses=np.zeros((20_000, 14, 2)))   # 4.5 MB in ~5 kB
    monkeypatch.setattr(_safeio, "_free_memory", lambda: 1 << 20)
    with pytest.raises(FileFormatError, match="needs 4480000 bytes of memory"):
        read_keypoints(path)


@pytest.mark.parametrize("args", [
    ["dataset", "build", str(FIXTURES / "cmu_02_01_short.bvh"), "-o", "{d}/ds.npz",
     "--seed", "-1", "--quiet"],
    ["evaluate", "--data", str(FIXTURES / "cmu_poses.npz"), "-o", "{d}/rep",
     "--sweep-atoms", "x"],
    ["evaluate", "--data", str(FIXTURES / "cmu_poses.npz"), "-o", "{d}/rep", "--jobs", "0"],
    ["evaluate", "--data", str(FIXTURES / "cmu_poses.npz"), "-o", "{d}/rep",
     "--max-poses", "-1"],
    ["evaluate", "--data", str(FIXTURES / "cmu_poses.npz"), "-o", "{d}/rep", "--counts", "5"],
    ["evaluate", "--data", str(CORPUS / "npz" / "err_poses_huge_header.npz"), "-o", "{d}/rep"],
    ["evaluate", "--data", str(CORPUS / "npz" / "err_not_zip.npz"), "-o", "{d}/rep"],
    ["info", str(CORPUS / "npy" / "err_huge_shape.npy")],
    ["evaluate", "--data", str(FIXTURES / "cmu_poses.npz"), "-o", str(FIXTURES / "cmu_02.asf")],
    ["evaluate", "--data", str(FIXTURES / "cmu_poses.npz"), "-o",
     str(FIXTURES / "cmu_02.asf" / "rep")],
])
def test_other_commands_report_bad_input_without_traceback(args, tmp_path, capsys):
    assert main([a.format(d=tmp_path) for a in args]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "Traceback" not in err
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------
# one extreme row never sinks the batch


def _rows():
    poses = np.load(FIXTURES / "cmu_poses.npz")["poses2d"][:12].astype(float)
    poses[:, 4] = np.nan
    return poses


EXTREME_ROWS = {
    "scale_1e308": lambda p: p / np.nanmax(np.abs(p)) * 1e308,
    "scale_1e307": lambda p: p / np.nanmax(np.abs(p)) * 1.7e307,
    "subnormal_5e-324": lambda p: np.round(p / np.nanmax(np.abs(p)) * 100) * 5e-324,
    "subnormal_1e-310": lambda p: p / np.nanmax(np.abs(p)) * 1e-310,
    "plus_minus_1e308": lambda p: np.where(np.arange(14)[:, None] % 2, 1e308, -1e308)
    * np.isfinite(p),
    "offset_1e308_tiny_extent": lambda p: 1e308 + p,
    "one_joint_far": lambda p: np.where(np.arange(14)[:, None] == 0, 1.7e308, p),
    "all_zero": lambda p: np.where(np.isfinite(p), 0.0, np.nan),
    "one_observed_inf": lambda p: np.where(np.arange(14)[:, None] == 3, np.inf, p),
    "one_observed_neg_inf": lambda p: np.where(np.arange(14)[:, None] == 5, -np.inf, p),
    "all_missing": lambda p: np.full_like(p, np.nan),
    "two_observed": lambda p: np.where(np.arange(14)[:, None] < 2, p, np.nan),
}


@pytest.mark.parametrize("name", sorted(EXTREME_ROWS))
def test_one_extreme_row_gets_a_status_and_the_rest_recover(name, small_dictionary):
    poses = _rows()
    with np.errstate(all="ignore"):
        poses[5] = EXTREME_ROWS[name](poses[5])
    res = recover(poses, dictionary=small_dictionary)
    good = np.delete(np.arange(len(poses)), 5)
    assert (res.status[good] == "recovered").all()
    assert np.isfinite(res.poses[good]).all()
    if res.status[5] in ("recovered", "inaccurate"):
        assert np.isfinite(res.poses[5]).all() and np.isfinite(res.gap[5])
    else:
        assert res.reason[5] and "observed joint 4" not in res.reason[5]
        assert np.isnan(res.poses[5]).all()


def test_a_complete_pose_with_a_joint_far_beyond_the_body_is_refused(small_dictionary):
    # a joint at 1e300 beside a body of ~100 px: no body, whatever else it is
    rows = _rows()
    whole = np.load(FIXTURES / "cmu_poses.npz")["poses2d"][12:14].astype(float)
    bad = whole[0].copy()
    bad[7] = [1e300, 5.0]
    res = recover(np.concatenate([rows, bad[None], whole[1:]]), dictionary=small_dictionary)
    assert res.status[12] == "out_of_range" and res.reason[12].startswith("joint 7 lies")
    assert np.isnan(res.poses[12]).all()
    alone = recover(np.concatenate([rows, whole[1:]]), dictionary=small_dictionary)
    keep = np.r_[0:12, 13]
    assert res.status[keep].tolist() == alone.status.tolist()
    np.testing.assert_array_equal(res.poses[keep], alone.poses)  # the file's rows unchanged
    assert usable_rows(whole).all() and not usable_rows(bad[None]).any()


def test_recovered_rows_are_finite_and_certified(small_dictionary):
    """The wrong answer once given: +/-1e308 came back 'recovered' with NaN joints."""
    poses = _rows()[:3]
    poses[1, :, 0] = np.where(np.arange(14) % 2, 1e308, -1e308)
    poses[1, 4] = np.nan
    res = recover(poses, dictionary=small_dictionary)
    assert res.status.tolist() == ["recovered", "out_of_range", "recovered"]
    ok = res.status == "recovered"
    assert np.isfinite(res.poses[ok]).all() and (res.gap[ok] <= 1e-4 + 1e-6).all()


@pytest.mark.parametrize("name", ["rows_huge_pose.npy", "rows_subnormal_pose.npy"])
def test_cli_extreme_row_in_npy_exit_1_and_output_written(name, tmp_path, capsys,
                                                          small_dictionary_path):
    code = main(["recover", str(CORPUS / "npy" / name), "-o", str(tmp_path / "o.npy"),
                 "--dictionary", str(small_dictionary_path), "-q"])
    assert code == 1
    status = np.load(tmp_path / "o.status.npz")["status"].tolist()
    assert status[1] == "out_of_range" and status.count("recovered") == 2


@SETTINGS
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True,
                          width=64), min_size=28, max_size=28),
       st.lists(st.booleans(), min_size=14, max_size=14))
def test_recover_never_raises_on_any_row_values(small_dictionary, values, missing):
    poses = _rows()[:2]
    poses[1] = np.array(values).reshape(14, 2)
    res = recover(poses, np.array([[False] * 14, missing]) | np.isnan(poses).any(-1),
                  dictionary=small_dictionary)
    assert res.status[0] == "recovered"
    assert res.status[1] in STATUSES
    done = np.isin(res.status, ("recovered", "inaccurate", "complete"))
    assert np.isfinite(res.poses[done]).all()


# --------------------------------------------------------------------------
# no input is ever written, outputs land where asked


@pytest.fixture
def csv_input(tmp_path):
    poses = _rows()[:4]
    path = tmp_path / "in.csv"
    write_keypoints(path, poses)
    return path


def _cli(args, dictionary):
    return main(["recover", *map(str, args), "--dictionary", str(dictionary), "-q"])


PATH_CASES = {
    "output_is_input": lambda d, i: [i, "-o", i],
    "errors_is_input": lambda d, i: [i, "-o", d / "out.csv", "--errors", i],
    "errors_is_output": lambda d, i: [i, "-o", d / "out.csv", "--errors", d / "out.csv"],
    "output_dotdot_input": lambda d, i: [i, "-o", d / "sub" / ".." / "in.csv"],
    "output_hard_link": lambda d, i: (os.link(i, d / "hard.csv"), [i, "-o", d / "hard.csv"])[1],
    "output_symlink": lambda d, i: (os.symlink(i, d / "link.csv"), [i, "-o", d / "link.csv"])[1],
    "errors_symlink": lambda d, i: (os.symlink(i, d / "e.csv"),
                                    [i, "-o", d / "out.csv", "--errors", d / "e.csv"])[1],
    "parent_is_a_file": lambda d, i: [i, "-o", i / "out.csv"],
    "grandparent_is_a_file": lambda d, i: [i, "-o", i / "x" / "out.csv"],
    "output_is_a_directory": lambda d, i: [i, "-o", d],
    "errors_is_a_directory": lambda d, i: [i, "-o", d / "out.csv", "--errors", d],
    "output_is_the_dictionary": lambda d, i: [i, "-o", d / "dict.npz"],
    "sidecar_is_input": lambda d, i: (write_keypoints(d / "o.status.npz", _rows()[:2]),
                                      [d / "o.status.npz", "-o", d / "o.npy"])[1],
    "edm_sidecar_is_errors": lambda d, i: [i, "-o", d / "o.csv", "--save-edm",
                                           "--errors", d / "o.edm.npz"],
}


@pytest.mark.parametrize("case", sorted(PATH_CASES))
def test_outputs_never_overwrite_inputs(case, tmp_path, csv_input, small_dictionary,
                                        capsys):
    dictionary = small_dictionary.save(tmp_path / "dict.npz")
    args = PATH_CASES[case](tmp_path, csv_input)
    before = sorted(os.listdir(tmp_path))
    with unchanged(*tmp_path.iterdir()):
        code = _cli(args, dictionary)
    err = capsys.readouterr().err
    assert code == 2 and "error:" in err, err
    assert sorted(os.listdir(tmp_path)) == before


@pytest.mark.parametrize("args", [
    ["fit-lifter", "{t}", "-o", "{t}", "--method", "mlp"],
    ["fit-cnn", "{t}", "-o", "{t}"],
    ["dataset", "inspect", "{b}", "--write-map", "{b}"],
])
def test_training_and_inspect_commands_never_overwrite_their_input(args, tmp_path, capsys):
    if args[0] == "fit-cnn":
        pytest.importorskip("torch", reason="needs the [torch] extra")
    train = tmp_path / "train.npz"
    train.write_bytes((FIXTURES / "cmu_poses.npz").read_bytes())
    bvh = tmp_path / "clip.bvh"
    bvh.write_bytes((FIXTURES / "cmu_02_01_short.bvh").read_bytes())
    with unchanged(train, bvh):
        code = main([a.format(t=train, b=bvh) for a in args])
    err = capsys.readouterr().err
    assert code == 2 and "refusing to overwrite" in err, err
    assert sorted(os.listdir(tmp_path)) == ["clip.bvh", "train.npz"]


def test_output_with_any_extension_lands_at_that_path(tmp_path, csv_input, small_dictionary):
    for name in ("out.data", "out", "out.csv.bak", "out.npz.tmp"):
        recover_file(csv_input, tmp_path / name, dictionary=small_dictionary)
        assert (tmp_path / name).stat().st_size > 0
        assert read_keypoints(tmp_path / name, format="csv").poses.shape == (4, 14, 2)
    for fmt in ("npz", "npy"):
        recover_file(csv_input, tmp_path / f"x.{fmt}.out", dictionary=small_dictionary,
                     output_format=fmt)
        assert len(read_keypoints(tmp_path / f"x.{fmt}.out", format=fmt)) == 4
    hidden = [n for n in os.listdir(tmp_path) if n.startswith(".")]
    assert hidden == []


@pytest.mark.parametrize("name", ["ds.csv", "ds", "ds.npz.bak", "ds.NPY"])
def test_dataset_build_refuses_names_it_cannot_write(name, tmp_path, capsys):
    code = main(["dataset", "build", str(FIXTURES / "cmu_02_01_short.bvh"), "-o",
                 str(tmp_path / name), "--quiet"])
    assert code == 2 and ".npz" in capsys.readouterr().err
    assert os.listdir(tmp_path) == []


def test_dataset_build_to_npz_lands_exactly(tmp_path):
    build_dataset([FIXTURES / "cmu_02_01_short.bvh"], tmp_path / "ds.npz", progress=False)
    assert os.listdir(tmp_path) == ["ds.npz"]


@pytest.mark.parametrize("args, match", [
    (["-o", "{d}/dict.csv"], "must end in .npz"),
    (["-o", "{train}"], "training file"),
    (["-o", "{d}/d.npz", "--checkpoint", "{train}"], "training file"),
    (["-o", "{d}/d.npz", "--checkpoint", "{d}/d.npz"], "same file"),
    (["-o", "{train}/d.npz"], "is a file"),
    (["-o", "{d}/d.npz", "--atoms", "0"], "n_components"),
    (["-o", "{d}/d.npz", "--batch-size", "-3"], "batch_size"),
    (["-o", "{d}/d.npz", "--alpha", "nan"], "alpha"),
    (["-o", "{d}/d.npz", "--passes", "0"], "n_passes"),
    (["-o", "{d}/d.npz", "--alpha-recover", "-1"], "alpha_recover"),
    (["-o", "{d}/d.npz", "--jobs", "0"], "n_jobs"),
    (["-o", "{d}/d.npz", "--seed", "-1"], "random_state"),
])
def test_fit_refuses_bad_outputs_and_options(args, match, tmp_path, capsys):
    train = tmp_path / "train.npz"
    train.write_bytes((FIXTURES / "cmu_poses.npz").read_bytes())
    argv = ["fit", str(train)] + [a.format(d=tmp_path, train=train) for a in args] + ["-q"]
    with unchanged(train):
        assert main(argv) == 2
    assert match in capsys.readouterr().err
    assert os.listdir(tmp_path) == ["train.npz"]


# --------------------------------------------------------------------------
# interrupted writes


_WRITER = textwrap.dedent("""
    import sys, time
    from sparseedm._atomic import atomic_path
    with atomic_path(sys.argv[1]) as tmp:
        open(tmp, "w").write("partial")
        print(tmp, flush=True)
        time.sleep(60)
""")


def _default_signals():
    # a writer started from a background or nohup'd shell inherits SIGINT/SIGHUP
    # ignored, and atomic_path rightly leaves ignored signals ignored: give the
    # child the dispositions of an interactive run
    for s in (signal.SIGINT, signal.SIGHUP, signal.SIGTERM):
        signal.signal(s, signal.SIG_DFL)


def _interrupted_writer(script, target, sig):
    """Run a writer `script` on `target`, send `sig` once it prints its temporary
    path (checked to hold TEMP_MARK), wait for it to end; that path."""
    with subprocess.Popen([sys.executable, "-c", script, str(target)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                          preexec_fn=_default_signals) as proc:
        tmp = Path(proc.stdout.readline().strip())
        assert os.path.lexists(tmp) and TEMP_MARK in tmp.name
        proc.send_signal(sig)
        proc.communicate(timeout=30)
    assert proc.returncode != 0
    return tmp


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP])
def test_signals_remove_the_temporary_file(sig, tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("previous")
    assert _interrupted_writer(_WRITER, target, sig).suffix == ".csv"
    assert os.listdir(tmp_path) == ["out.csv"] and target.read_text() == "previous"


def test_an_ignored_signal_stays_ignored(tmp_path):
    """Under nohup (SIGHUP ignored) a hang-up must not end the write."""
    def nohup():
        _default_signals()
        signal.signal(signal.SIGHUP, signal.SIG_IGN)

    target = tmp_path / "out.csv"
    with subprocess.Popen([sys.executable, "-c", _WRITER, str(target)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                          preexec_fn=nohup) as proc:
        tmp = Path(proc.stdout.readline().strip())
        proc.send_signal(signal.SIGHUP)
        with pytest.raises(subprocess.TimeoutExpired):
            proc.wait(timeout=1)
        assert tmp.is_file()
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=30)
    assert os.listdir(tmp_path) == []


def _killed_writer(script, target):
    """Run a writer `script` on `target` and SIGKILL it once it prints its
    temporary path; that path and the writer's pid."""
    with subprocess.Popen([sys.executable, "-c", script, str(target)],
                          stdout=subprocess.PIPE, text=True) as proc:
        tmp = Path(proc.stdout.readline().strip())
        proc.kill()
        proc.communicate(timeout=30)
    return tmp, proc.pid


def test_leftovers_of_a_killed_writer_are_removed_on_the_next_write(tmp_path):
    target = tmp_path / "out.csv"
    tmp, pid = _killed_writer(_WRITER, target)
    assert tmp.is_file()                                  # SIGKILL cannot be caught
    other = tmp_path / f".other.csv{TEMP_MARK}{pid}-x.csv"
    other.write_text("someone else's")
    live = tmp_path / f".out.csv{TEMP_MARK}{os.getpid()}-live.csv"
    live.write_text("a write in progress")
    with atomic_path(target) as t:
        Path(t).write_text("new")
    assert sorted(os.listdir(tmp_path)) == sorted(["out.csv", other.name, live.name])
    assert remove_leftovers(tmp_path / "other.csv") == [other]


_NESTED_WRITER = textwrap.dedent("""
    import sys, time
    from sparseedm._atomic import atomic_path
    with atomic_path(sys.argv[1]) as tmp:  # recover_file's output ...
        with atomic_path(tmp) as inner:    # ... handed to a writer that is atomic itself
            open(inner, "w").write("partial")
            print(inner, flush=True)
            time.sleep(60)
""")


def test_a_writer_handed_a_temporary_writes_into_it_and_a_kill_leaves_one_file(tmp_path):
    """One temporary per output: SIGKILL leaves one file, which the next write
    to the output removes (a temporary inside a temporary never was)."""
    target = tmp_path / "out.csv"
    inner, _ = _killed_writer(_NESTED_WRITER, target)
    assert inner.name.count(TEMP_MARK) == 1 and os.listdir(tmp_path) == [inner.name]
    with atomic_path(target) as t:
        Path(t).write_text("new")
    assert os.listdir(tmp_path) == ["out.csv"]


def test_a_temporary_left_inside_a_temporary_is_removed(tmp_path):
    dead = _dead_pid()
    nested = tmp_path / f"..o.csv{TEMP_MARK}{dead}-ab.csv{TEMP_MARK}{dead}-cd.csv"
    hidden_output_tmp = tmp_path / f"..o.csv{TEMP_MARK}{dead}-ef.csv"  # .o.csv's, not o.csv's
    for p in (nested, hidden_output_tmp):
        p.write_text("x")
    assert remove_leftovers(tmp_path / "o.csv") == [nested]
    assert os.listdir(tmp_path) == [hidden_output_tmp.name]


def _dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_recover_file_makes_one_temporary_per_output(tmp_path, csv_input, small_dictionary,
                                                     monkeypatch):
    import tempfile

    made = []
    real = tempfile.mkstemp

    def mkstemp(*args, **kw):
        fd, name = real(*args, **kw)
        made.append(Path(name).name)
        return fd, name

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    for ext in ("csv", "npz", "json"):
        made.clear()
        recover_file(csv_input, tmp_path / f"o.{ext}", dictionary=small_dictionary)
        assert made and all(name.count(TEMP_MARK) == 1 for name in made), made
        assert len([m for m in made if m.startswith(f".o.{ext}")]) == 1, made


_SIGNAL_AT_CREATION = textwrap.dedent("""
    import os, signal, sys, tempfile
    from sparseedm._atomic import atomic_path
    real = tempfile.mkstemp

    def mkstemp(*args, **kw):  # SIGTERM the moment the temporary exists
        made = real(*args, **kw)
        os.kill(os.getpid(), signal.SIGTERM)
        return made

    tempfile.mkstemp = mkstemp
    with atomic_path(sys.argv[1]) as tmp:
        open(tmp, "w").write("partial")
    print("not killed", flush=True)
""")


def test_sigterm_as_the_temporary_appears_removes_it(tmp_path):
    """The handlers are in place (and the signal waits) before the file exists."""
    target = tmp_path / "o.npy"
    target.write_text("previous")
    proc = subprocess.run([sys.executable, "-c", _SIGNAL_AT_CREATION, str(target)],
                          capture_output=True, text=True, timeout=60,
                          preexec_fn=_default_signals)
    assert proc.returncode == -signal.SIGTERM and "not killed" not in proc.stdout
    assert os.listdir(tmp_path) == ["o.npy"] and target.read_text() == "previous"


_FOLDER_WRITER = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    from sparseedm.formats._base import write_json_folder

    def docs():  # an OpenPose folder output, stopped half-written
        yield "a.json", {}
        target = Path(sys.argv[1])
        print(*(p for p in target.parent.iterdir() if p.name != target.name), flush=True)
        time.sleep(60)
        yield "b.json", {}

    write_json_folder(sys.argv[1], docs())
""")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGKILL])
def test_an_interrupted_folder_output_leaves_nothing_behind(sig, tmp_path):
    from sparseedm.formats._base import write_json_folder

    target = tmp_path / "out"
    write_json_folder(target, [("old.json", {"previous": 1})])
    tmp = _interrupted_writer(_FOLDER_WRITER, target, sig)
    assert json.loads((target / "old.json").read_text()) == {"previous": 1}  # kept
    if sig == signal.SIGKILL:                     # cannot be caught: the next write
        assert tmp.is_dir()                       # to the same output removes it
        write_json_folder(target, [("new.json", {})])
        assert sorted(os.listdir(target)) == [".sparseedm-output", "new.json"]
    assert os.listdir(tmp_path) == ["out"]


def test_signal_handlers_are_restored(tmp_path):
    before = signal.getsignal(signal.SIGTERM)
    with atomic_path(tmp_path / "a.txt") as t:
        Path(t).write_text("x")
        assert signal.getsignal(signal.SIGTERM) is not before
    assert signal.getsignal(signal.SIGTERM) is before


# --------------------------------------------------------------------------
# arguments: one place, a ParameterError naming the argument


def _poses():
    p = _rows()[:2]
    return p


BAD_RECOVER_ARGS = [
    ("alpha", "0.01"), ("alpha", 1 + 0j), ("alpha", True), ("alpha", -1.0), ("alpha", 0),
    ("alpha", float("nan")), ("alpha", float("inf")), ("alpha", [0.1]), ("alpha", np.array(0.1)),
    ("n_jobs", 0), ("n_jobs", 1.5), ("n_jobs", "2"), ("n_jobs", True),
    ("chunk_size", 0), ("chunk_size", -1), ("chunk_size", 2.0), ("chunk_size", None),
    ("chunk_size", "10"), ("dictionary", 123), ("dictionary", 1.5), ("dictionary", ["a"]),
    ("dictionary", ""), ("backend", "bogus"), ("backend", 1), ("representation", "mean"),
    ("representation", 0),  # representation None: a model's own, else "average"
    ("solver", "lars"), ("solver", None),
    ("solver", 3), ("positive", "yes"), ("positive", 1), ("progress", "no"),
    ("progress", None), ("scheduler", 8786),
]


@pytest.mark.parametrize("name, value", BAD_RECOVER_ARGS, ids=repr)
def test_recover_rejects_bad_arguments(name, value, small_dictionary):
    kwargs = {"dictionary": small_dictionary, name: value}
    with pytest.raises(ParameterError, match=f"recover: {name} must be"):
        recover(_poses(), **kwargs)


BAD_POSES = [
    ("ragged", lambda p: [p[0].tolist(), p[0, :13].tolist()]),
    ("ragged_coords", lambda p: [[[1, 2], [3]] * 7]),
    ("strings", lambda p: p.astype(str)),
    ("string_list", lambda p: [["1", "2"]] * 14),
    ("complex", lambda p: p.astype(complex)),
    ("booleans", lambda p: np.ones((1, 14, 2), bool)),
    ("objects", lambda p: np.array([[object()] * 2] * 14)),
    ("none", lambda p: None),
    ("dict", lambda p: {"poses": p}),
    ("datetime", lambda p: np.zeros((1, 14, 2), "M8[s]")),
    ("huge_python_int", lambda p: [[10 ** 400, 1]] * 14),
]


@pytest.mark.parametrize("name", [c[0] for c in BAD_POSES])
def test_recover_rejects_poses_that_are_not_real_numbers(name, small_dictionary):
    make = dict(BAD_POSES)[name]
    with pytest.raises(SparseEDMError, match="poses"):
        recover(make(_poses()), dictionary=small_dictionary)


@pytest.mark.parametrize("missing", [
    np.full((2, 14), "yes"), np.full((2, 14), 2), np.full((2, 14), 0.5),
    np.full((2, 14), np.nan), [[True] * 14, [False] * 13], np.ones((2, 14), complex),
])
def test_recover_rejects_bad_missing_masks(missing, small_dictionary):
    with pytest.raises(SparseEDMError, match="missing"):
        recover(_poses(), missing, dictionary=small_dictionary)


BAD_FILE_ARGS = [
    ("input", 5), ("input", None), ("output", 3.0), ("output", ""), ("dictionary", 123),
    ("alpha", "0.01"), ("alpha", 0), ("alpha", True), ("representation", "x"),
    ("n_jobs", 0), ("chunk_size", 0), ("chunk_size", -1), ("chunk_size", 1.5),
    ("errors_path", 7), ("progress", 1), ("save_edm", "yes"),
    ("confidence_threshold", "0.5"), ("confidence_threshold", float("nan")),
    ("filled_score", "0"), ("joint_map", 3),  # confidence_threshold None: the format's
    ("backend", "bogus"), ("scheduler", 1),
]


@pytest.mark.parametrize("name, value", BAD_FILE_ARGS, ids=repr)
def test_recover_file_rejects_bad_arguments(name, value, tmp_path, csv_input,
                                            small_dictionary):
    kwargs = {"input": csv_input, "output": tmp_path / "o.csv",
              "dictionary": small_dictionary, name: value}
    with unchanged(csv_input), pytest.raises(ParameterError, match=f"{name} must be"):
        recover_file(**kwargs)
    assert sorted(os.listdir(tmp_path)) == ["in.csv"]


@pytest.mark.parametrize("call", [
    lambda: read_keypoints(5),
    lambda: read_keypoints(CORPUS / "csv" / "ok_bom.csv", confidence_threshold="0.5"),
    lambda: read_keypoints(CORPUS / "csv" / "ok_bom.csv", confidence_threshold=np.nan),
    lambda: read_keypoints(CORPUS / "csv" / "ok_bom.csv", format="xml"),
    lambda: write_keypoints(None, np.zeros((1, 14, 2))),
    lambda: write_keypoints("/tmp/x.csv", np.full((1, 14, 2), "a")),
    lambda: write_keypoints("/tmp/x.csv", np.zeros((1, 14, 2), complex)),
    lambda: load_dictionary(123),
    lambda: load_dictionary(["default"]),
    lambda: load_dictionary(n_joints=0),
    lambda: load_dictionary(n_joints="14"),
    lambda: OcclusionRecoverer(alpha="0.1").fit(),
    lambda: OcclusionRecoverer(n_jobs=0).fit(),
    lambda: OcclusionRecoverer(dictionary=3).fit(),
    lambda: OcclusionRecoverer(solver="bogus").fit(),
    lambda: Dictionary(np.eye(91)[:2], alpha_recover="0.1"),
    lambda: Dictionary(np.eye(91)[:2], positive_code="no"),
    lambda: Dictionary(np.eye(91)[:2], provenance="cmu"),
    lambda: Dictionary(np.eye(91)[:2], alpha_scaling="sqrt"),
    lambda: Dictionary(np.eye(91)[:2], alpha_train=True),
    lambda: fit_dictionary_file("t.npz", "o.npz", n_components=0),
    lambda: fit_dictionary_file("t.npz", "o.npz", alpha="1"),
    lambda: fit_dictionary_file("t.npz", "o.npz", batch_size=0),
    lambda: fit_dictionary_file("t.npz", "o.npz", n_passes=-1),
    lambda: fit_dictionary_file(None, "o.npz"),
    lambda: build_dataset([FIXTURES / "cmu_02_01_short.bvh"], cameras_per_pose=0),
    lambda: build_dataset([FIXTURES / "cmu_02_01_short.bvh"], cameras_per_pose="2"),
    lambda: build_dataset([FIXTURES / "cmu_02_01_short.bvh"], frame_step=0),
    lambda: build_dataset([FIXTURES / "cmu_02_01_short.bvh"], output=5),
    lambda: build_dataset([FIXTURES / "cmu_02_01_short.bvh"], camera_options=[1]),
    lambda: evaluate("default", np.zeros((2, 14, 2)), n_jobs=0),
    lambda: evaluate("default", np.zeros((2, 14, 2)), max_poses=0),
    lambda: evaluate("default", np.zeros((2, 14, 2)), max_train=-5),
    lambda: evaluate("default", np.zeros((2, 14, 2)), alpha="0.1"),
    lambda: evaluate(7, np.zeros((2, 14, 2))),
    lambda: evaluate("default", np.zeros((2, 14, 2)), methods=("magic",)),
    lambda: evaluate("default", np.zeros((2, 14, 2)), counts=(4,)),
    lambda: sweep_atoms(np.zeros((5, 14, 2)), np.zeros((5, 14, 2)), atoms=(0,)),
    lambda: sweep_atoms(np.zeros((5, 14, 2)), np.zeros((5, 14, 2)), atoms=("10",)),
    lambda: sweep_atoms(np.zeros((5, 14, 2)).astype(str), np.zeros((5, 14, 2))),
    lambda: load_mocap(123),
    lambda: load_mocap(FIXTURES / "cmu_02_01_short.bvh", scale=0),
    lambda: load_mocap(FIXTURES / "cmu_02_01_short.bvh", scale="1"),
    lambda: load_mocap("walk.c3d"),
])
def test_public_functions_reject_bad_arguments(call):
    with pytest.raises(SparseEDMError):
        call()


@pytest.mark.parametrize("option, value", [
    ("--alpha", "nan"), ("--alpha", "-1"), ("--alpha", "inf"), ("--alpha", "0"),
    ("--jobs", "0"), ("--chunk-size", "0"), ("--chunk-size", "-1"),
    ("--confidence-threshold", "nan"), ("--format", "xml"), ("--dictionary", "nosuch"),
    ("--dictionary", "/nonexistent/d.npz"),
])
def test_cli_rejects_bad_options(option, value, tmp_path, csv_input, capsys):
    args = ["recover", str(csv_input), "-o", str(tmp_path / "o.csv"), option, value, "-q"]
    with unchanged(csv_input):
        code = main(args) if option != "--format" else _argparse_exit(args)
    assert code == 2 and "Traceback" not in capsys.readouterr().err
    assert sorted(os.listdir(tmp_path)) == ["in.csv"]


def _argparse_exit(args):
    with pytest.raises(SystemExit) as info:
        main(args)
    return info.value.code


# --------------------------------------------------------------------------
# property-based: generated malformed files, every reader


def _valid_bytes(kind):
    return {
        "npy": (CORPUS / "npy" / "ok_float32.npy").read_bytes(),
        "npz": (CORPUS / "npz" / "ok_plain.npz").read_bytes(),
        "npzc": (CORPUS / "npz" / "ok_compressed.npz").read_bytes(),
        "dictionary": (CORPUS / "dictionary" / "ok_plain.npz").read_bytes(),
        "csv": (CORPUS / "csv" / "ok_bom.csv").read_bytes(),
        "coco": (CORPUS / "coco" / "ok_results_list.json").read_bytes(),
        "bvh": (FIXTURES / "cmu_02_01_short.bvh").read_bytes()[:6000]
        + (FIXTURES / "cmu_02_01_short.bvh").read_bytes()[-2000:],
        "asf": (FIXTURES / "cmu_02.asf").read_bytes(),
        "amc": (FIXTURES / "cmu_02_01_short.amc").read_bytes()[:4000],
    }[kind]


@st.composite
def mutated(draw, kind):
    """A valid file with a few bytes flipped, cut, or inserted."""
    data = bytearray(_valid_bytes(kind))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "truncate", "insert", "delete"]))
        pos = draw(st.integers(0, max(len(data) - 1, 0)))
        if op == "flip" and data:
            data[pos] ^= draw(st.integers(1, 255))
        elif op == "truncate":
            del data[pos:]
        elif op == "insert":
            data[pos:pos] = draw(st.binary(min_size=1, max_size=16))
        elif data:
            del data[pos:pos + draw(st.integers(1, 64))]
    return bytes(data)


_SUFFIX = {"npy": ".npy", "npz": ".npz", "npzc": ".npz", "dictionary": ".npz",
           "csv": ".csv", "coco": ".json", "bvh": ".bvh", "asf": ".asf", "amc": ".amc"}
_READERS = {
    "dictionary": load_dictionary, "bvh": load_mocap,
    "asf": lambda p: load_asf_amc(p, FIXTURES / "cmu_02_01_short.amc"),
    "amc": lambda p: load_asf_amc(FIXTURES / "cmu_02.asf", p),
}


def _check_generated(tmp_path, kind, data):
    path = tmp_path / f"gen{_SUFFIX[kind]}"
    path.write_bytes(data)
    with unchanged(path):
        _outcome(_READERS.get(kind, read_keypoints), path)


@pytest.mark.parametrize("kind", ["npy", "npz", "npzc", "dictionary", "csv", "coco", "bvh",
                                  "asf", "amc"])
def test_mutated_files_never_escape(kind, tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp(kind)

    @SETTINGS
    @given(mutated(kind))
    def run(data):
        _check_generated(tmp_path, kind, data)

    run()


def _containers(children):
    keys = st.sampled_from(["keypoints", "annotations", "image_id", "sparseedm", "neck",
                            "head_top", "score", "x"])
    return st.lists(children, max_size=60) | st.dictionaries(keys, children, max_size=5)


_json = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True)
    | st.text(max_size=5),
    _containers, max_leaves=120,
)


@SETTINGS
@given(_json)
def test_generated_json_documents_never_escape(tmp_path_factory, doc):
    tmp_path = tmp_path_factory.mktemp("json")
    _check_generated(tmp_path, "coco", json.dumps(doc).encode())


@SETTINGS
@given(st.lists(st.lists(st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(alphabet="0123456789.eE+-naif,\"x é", max_size=8)), min_size=0, max_size=32),
    max_size=5))
def test_generated_csv_rows_never_escape(tmp_path_factory, rows):
    tmp_path = tmp_path_factory.mktemp("csv")
    header = (CORPUS / "csv" / "ok_bom.csv").read_text(encoding="utf-8-sig").splitlines()[0]
    text = "\n".join([header] + [",".join(r) for r in rows]) + "\n"
    _check_generated(tmp_path, "csv", text.encode())


@SETTINGS
@given(st.lists(st.integers(-(2 ** 63), 2 ** 63), min_size=0, max_size=4),
       st.sampled_from(["<f8", "<f4", "<i8", "|b1", "<c16", "<U3", "|S2", "|O", "<M8[s]"]),
       st.binary(max_size=64))
def test_generated_npy_headers_never_escape(tmp_path_factory, shape, descr, payload):
    tmp_path = tmp_path_factory.mktemp("npy")
    header = repr({"descr": descr, "fortran_order": False, "shape": tuple(shape)}).encode()
    header += b" " * ((64 - (len(header) + 11) % 64) % 64) + b"\n"
    data = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + payload
    _check_generated(tmp_path, "npy", data)
