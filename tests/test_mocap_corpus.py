"""A corpus of malformed motion files: each gives a clear error naming the file
and the line (never a traceback), and a folder mixing good and bad files builds
the good ones and lists the bad."""

import shutil
import warnings
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sparseedm.mocap
from sparseedm.cli import main
from sparseedm.dataset import build_dataset
from sparseedm.exceptions import FileFormatError, SparseEDMError
from sparseedm.mocap import load_mocap


def _good_bvh(fixtures_dir):
    return (fixtures_dir / "rigs" / "daz_cm.bvh").read_text()


def _motion_line(text, k=0):
    """Line number (1-based) of the k-th motion row."""
    lines = text.splitlines()
    return lines.index("MOTION") + 4 + k


def _replace_row(text, k, fn):
    lines = text.splitlines()
    i = _motion_line(text, k) - 1
    lines[i] = fn(lines[i])
    return "\n".join(lines) + "\n"


BVH_CASES = {
    # name: (mutation of the good text -> text or bytes, regex the error must match)
    "truncated_hierarchy": (lambda t: t[: t.index("JOINT rShin")], r"line \d+: no MOTION section"),
    "truncated_motion": (lambda t: "\n".join(t.splitlines()[:-2]) + "\n",
                         r"line \d+: 'Frames: 5' but only 3 frame lines"),
    "missing_channels": (lambda t: _replace_row(t, 1, lambda r: " ".join(r.split()[:-3])),
                         r"line \d+: \d+ channel values on a MOTION line, expected \d+"),
    "channels_without_count": (lambda t: t.replace("CHANNELS 3 ", "CHANNELS ", 1),
                               r"line \d+: CHANNELS needs a channel count"),
    "wrong_channel_count": (lambda t: t.replace("CHANNELS 3 ", "CHANNELS 4 ", 1),
                            r"line \d+: CHANNELS says 4 channels but lists 3"),
    "nan_value": (lambda t: _replace_row(t, 2, lambda r: "nan " + r.split(" ", 1)[1]),
                  r"line \d+: non-finite channel value"),
    "nan_offset": (lambda t: t.replace("OFFSET 9.351354", "OFFSET nan", 1),
                   r"line 12: OFFSET values must be finite"),
    "zero_frames": (lambda t: t[: t.index("Frames:")] + "Frames: 0\nFrame Time: 0.0083\n",
                    r"line \d+: 'Frames: 0': the file has no motion frames"),
    "bad_frame_time": (lambda t: t.replace("Frame Time: 0.00833333", "Frame Time: -1"),
                       r"line \d+: the frame time '-1' must be a positive"),
    "non_utf8": (lambda t: t.replace("JOINT rShin", "JOINT rSh\udcffin").encode("utf-8", "surrogateescape"),
                 r"line \d+: byte 0xff is not UTF-8 text"),
    "binary": (lambda t: b"\x00\x01\x02\xfe\xff" * 100, r"line 1: byte 0xfe is not UTF-8"),
    "empty": (lambda t: "", r"line 1: expected 'HIERARCHY'"),
}


def _write(tmp_path, name, content):
    path = tmp_path / f"{name}.bvh"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


@pytest.mark.parametrize("case", sorted(BVH_CASES))
def test_bad_bvh_corpus(tmp_path, fixtures_dir, case):
    mutate, message = BVH_CASES[case]
    path = _write(tmp_path, case, mutate(_good_bvh(fixtures_dir)))
    with pytest.raises(FileFormatError, match=message) as info:
        load_mocap(path)
    assert str(path) in str(info.value)


def test_line_numbers_are_right(tmp_path, fixtures_dir):
    text = _good_bvh(fixtures_dir)
    path = _write(tmp_path, "nan", _replace_row(text, 2, lambda r: "nan " + r.split(" ", 1)[1]))
    with pytest.raises(FileFormatError) as info:
        load_mocap(path)
    assert f"line {_motion_line(text, 2)}:" in str(info.value)
    bad = text.replace("JOINT rShin", "JOINT rSh\udcffin").encode("utf-8", "surrogateescape")
    path = _write(tmp_path, "bytes", bad)
    with pytest.raises(FileFormatError) as info:
        load_mocap(path)
    rshin = next(k for k, ln in enumerate(text.splitlines(), 1) if "JOINT rShin" in ln)
    assert f"line {rshin}:" in str(info.value)


def test_huge_file_refused_before_reading(tmp_path, fixtures_dir, monkeypatch):
    path = _write(tmp_path, "long", _good_bvh(fixtures_dir))
    monkeypatch.setattr(sparseedm.mocap, "MAX_FILE_BYTES", 1000)
    with pytest.raises(FileFormatError, match=r"long\.bvh: .* larger than the .* limit.*MAX_FILE_BYTES"):
        load_mocap(path)


def test_bad_amc_corpus(tmp_path, fixtures_dir):
    shutil.copy(fixtures_dir / "cmu_02.asf", tmp_path / "02.asf")
    amc = (fixtures_dir / "cmu_02_01_short.amc").read_text()
    cases = {
        "02_01": (amc.replace("rtibia 11.5302", "rtibia nan"), r"line 27: non-finite value"),
        "02_02": (amc.replace("rtibia 11.5302", "rtibia 11.5302 4"), r"line 27: .* 2 values"),
        "02_03": (":FULLY-SPECIFIED\n:DEGREES\n", r"no frames"),
    }
    for stem, (text, message) in cases.items():
        (tmp_path / f"{stem}.amc").write_text(text)
        with pytest.raises(FileFormatError, match=message):
            load_mocap(tmp_path / f"{stem}.amc")
    (tmp_path / "02_04.amc").write_bytes(amc.encode()[:500] + b"\xff\xfe" + amc.encode()[500:])
    with pytest.raises(FileFormatError, match=r"02_04\.amc, line \d+: byte 0xff"):
        load_mocap(tmp_path / "02_04.amc")
    asf = (fixtures_dir / "cmu_02.asf").read_text().replace("length 7.59371", "length inf")
    (tmp_path / "bad.asf").write_text(asf)
    from sparseedm.mocap import parse_asf
    with pytest.raises(FileFormatError, match=r"bad\.asf, line 29: length values must be finite"):
        parse_asf(tmp_path / "bad.asf")


def test_folder_mixing_good_and_bad_files(tmp_path, fixtures_dir, capsys):
    good = _good_bvh(fixtures_dir)
    folder = tmp_path / "mixed"
    folder.mkdir()
    for name in ("daz_cm.bvh", "mixamo_cm.bvh", "bandai_cm.bvh"):
        shutil.copy(fixtures_dir / "rigs" / name, folder / name)
    for case, (mutate, _) in BVH_CASES.items():
        _write(folder, case, mutate(good))
    with pytest.warns(UserWarning):
        data, report = build_dataset(folder, frame_step=1, progress=False, return_report=True)
    assert report["files"] == 3 and len(data["labels"]) == 15
    assert sorted(p.split("/")[-1] for p, _ in report["skipped"]) == sorted(
        f"{c}.bvh" for c in BVH_CASES)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the CLI prints each refusal as a line instead
        code = main(["dataset", "build", str(folder), "-o", str(tmp_path / "m.npz")])
    out, err = capsys.readouterr()
    assert code == 1 and "read 3 file(s), skipped 12" in out
    for case in BVH_CASES:
        assert f"skipped {folder / case}.bvh" in out
    assert "Traceback" not in out + err


GOOD_BVH = (Path(__file__).parent / "fixtures" / "rigs" / "daz_cm.bvh").read_text()


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_mutated_bvh_never_escapes_as_another_error(tmp_path_factory, data):
    """Any line deleted, duplicated or garbled: the file loads or raises a
    SparseEDMError -- never an IndexError, KeyError, numpy error ..."""
    lines = GOOD_BVH.splitlines()
    for _ in range(data.draw(st.integers(1, 3))):
        k = data.draw(st.integers(0, len(lines) - 1))
        action = data.draw(st.sampled_from(["delete", "duplicate", "garble", "truncate"]))
        if action == "delete":
            del lines[k]
        elif action == "duplicate":
            lines.insert(k, lines[k])
        elif action == "truncate":
            lines[k] = lines[k][: data.draw(st.integers(0, max(len(lines[k]) - 1, 0)))]
        else:
            lines[k] = data.draw(st.text(alphabet="{} 0123456789.-eE+nainfXYZrotsCHANLJIMO:\t",
                                         max_size=30))
        if not lines:
            break
    path = tmp_path_factory.mktemp("fuzz") / "m.bvh"
    path.write_text("\n".join(lines) + "\n")
    try:
        load_mocap(path)
    except SparseEDMError as exc:
        assert str(path) in str(exc)


@settings(max_examples=60, deadline=None)
@given(st.data(), st.sampled_from(["asf", "amc"]))
def test_mutated_asf_amc_never_escapes_as_another_error(tmp_path_factory, data, which):
    fixtures = Path(__file__).parent / "fixtures"
    texts = {"asf": (fixtures / "cmu_02.asf").read_text(),
             "amc": (fixtures / "cmu_02_01_short.amc").read_text()}
    lines = texts[which].splitlines()
    for _ in range(data.draw(st.integers(1, 3))):
        k = data.draw(st.integers(0, len(lines) - 1))
        action = data.draw(st.sampled_from(["delete", "duplicate", "garble"]))
        if action == "delete":
            del lines[k]
        elif action == "duplicate":
            lines.insert(k, lines[k])
        else:
            lines[k] = data.draw(st.text(alphabet="()# 0123456789.-naifbegndroot:xyzXYZ",
                                         max_size=30))
    texts[which] = "\n".join(lines) + "\n"
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "02.asf").write_text(texts["asf"])
    (folder / "02_01.amc").write_text(texts["amc"])
    try:
        load_mocap(folder / "02_01.amc")
    except SparseEDMError as exc:
        assert str(folder) in str(exc)


def test_unreadable_path_is_a_clear_error(tmp_path):
    (tmp_path / "folder.bvh").mkdir()
    with pytest.raises(FileFormatError, match=r"folder\.bvh is a directory"):
        load_mocap(tmp_path / "folder.bvh")
    with pytest.raises(FileNotFoundError):
        load_mocap(tmp_path / "missing.bvh")
