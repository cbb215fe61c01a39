"""A writer never writes what its own reader refuses: TRC and BVH.

Whatever `write_trc` / `write_cmu_bvh` accept, `read_trc` / `load_bvh` read back
equal (to the precision written); anything else is refused with a message
before the file is made. Property tests draw names, frames and rates.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from sparseedm.exceptions import FileFormatError, PoseError, SparseEDMError
from sparseedm.lifting.trc import read_trc, write_trc
from sparseedm.mocap.asf_amc import CMU_BVH_NAMES, parse_amc, parse_asf, write_cmu_bvh
from sparseedm.mocap.bvh import parse_bvh

_SETTINGS = settings(max_examples=60, deadline=None,
                     suppress_health_check=[HealthCheck.function_scoped_fixture])


def _poses(n, rng):
    P = rng.normal(size=(n, 14, 3))
    if n:
        P[rng.random(n) < 0.2] = np.nan  # refused poses: empty fields
    return P


# ---------------------------------------------------------------- TRC refusals


@pytest.mark.parametrize("kw, words", [
    (dict(frames=[5, 2, 2]), "strictly increasing"),
    (dict(frames=[1, 1, 2]), "strictly increasing"),
    (dict(frames=[0.0, 1.5, 2.0]), "whole numbers"),
    (dict(rate=1e-308), "not finite"),
    (dict(rate=0), "> 0"),
    (dict(rate=float("nan")), "> 0"),
    (dict(joint_names=["a\tb"] + [f"j{i}" for i in range(13)]), "printable"),
    (dict(joint_names=["a\nb"] + [f"j{i}" for i in range(13)]), "printable"),
    (dict(joint_names=[""] + [f"j{i}" for i in range(13)]), "blank"),
    (dict(joint_names=["a"] * 14), "same name"),
    (dict(joint_names=["a"]), "marker names for 14 joints"),
])
def test_write_trc_refuses_what_read_trc_would_not_read_back(tmp_path, kw, words):
    with pytest.raises(FileFormatError, match=words):
        write_trc(tmp_path / "p.trc", _poses(3, np.random.default_rng(0)), **kw)
    assert list(tmp_path.iterdir()) == []  # nothing written, no temporary left


def test_write_trc_names_the_argument_of_a_wrong_shape(tmp_path):
    with pytest.raises(PoseError, match=r"poses3d must have shape \(n, N, 3\), got \(3, 14, 2\)"):
        write_trc(tmp_path / "p.trc", np.zeros((3, 14, 2)))
    with pytest.raises(PoseError, match="infinite"):
        write_trc(tmp_path / "p.trc", np.full((1, 14, 3), np.inf))


@pytest.mark.parametrize("rate", [1e300, 2e6, 1e7, 29.97002997])
def test_trc_times_stay_distinct_and_exact_at_any_rate(tmp_path, rate):
    """Times that 6 decimals would make equal (or 0) are written with every digit."""
    back = read_trc(write_trc(tmp_path / "p.trc", np.zeros((4, 14, 3)), rate=rate))
    _same_times(back["times"], np.arange(4) / rate)
    assert back["rate"] == rate


#: half the 6th decimal, and the binary rounding of a value exactly half-way (0.2578125)
_HALF_LAST_DECIMAL = 5e-7 * (1 + 1e-9)


def _same_times(read, written):
    """Times read back: to the 6 decimals written (or exactly), still increasing."""
    np.testing.assert_allclose(read, written, atol=_HALF_LAST_DECIMAL, rtol=0)
    assert (np.diff(read) > 0).all()


def test_a_tab_in_the_trc_file_name_is_written_as_an_underscore(tmp_path):
    path = write_trc(tmp_path / "walk\tfast\n.trc", np.zeros((2, 14, 3)))
    first = path.read_text(encoding="utf-8").split("\n")[0]
    assert first.split("\t") == ["PathFileType", "4", "(X/Y/Z)", "walk_fast_.trc"]
    assert read_trc(path)["poses"].shape == (2, 14, 3)


_ANY_NAME = st.text(st.characters(codec="utf-8"), min_size=1, max_size=8)
_PRINTABLE = st.text(st.characters(codec="utf-8").filter(str.isprintable), min_size=1,
                     max_size=8)
_NAMES = st.one_of(st.lists(_PRINTABLE, min_size=14, max_size=14, unique=True),
                   st.lists(_ANY_NAME, min_size=14, max_size=14))
_FILE = st.text(st.characters(codec="utf-8", exclude_characters="/\x00"), min_size=1,
                max_size=12).filter(lambda s: s not in (".", ".."))
_FRAME = st.integers(-2**40, 2**40)
_FRAMES = st.one_of(st.lists(_FRAME, unique=True, max_size=6).map(sorted),
                    st.lists(_FRAME, max_size=6))


@_SETTINGS
@given(names=_NAMES, file=_FILE, frames=_FRAMES, rate=st.floats(1e-300, 1e300),
       seed=st.integers(0, 2**16))
def test_trc_round_trip_property(tmp_path, names, file, frames, rate, seed):
    """Whatever write_trc accepts, read_trc reads back: poses to the 6 decimals
    written, the frames, the names, the rate and times exactly."""
    P = _poses(len(frames), np.random.default_rng(seed))
    try:
        path = write_trc(tmp_path / (file + ".trc"), P, rate=rate, joint_names=names,
                         frames=frames)
    except FileFormatError:  # refused before writing: nothing there
        assert not any(tmp_path.iterdir())
        return
    back = read_trc(path)
    assert back["markers"] == names and back["rate"] == rate
    np.testing.assert_array_equal(back["frames"], np.asarray(frames, dtype=np.int64) + 1)
    _same_times(back["times"], np.asarray(frames) / rate)
    np.testing.assert_allclose(back["poses"], P, atol=_HALF_LAST_DECIMAL, rtol=0)
    np.testing.assert_array_equal(np.isnan(back["poses"]), np.isnan(P))
    path.unlink()


# ---------------------------------------------------------------- BVH


@pytest.fixture
def cmu_motion(fixtures_dir):
    skeleton = parse_asf(fixtures_dir / "cmu_02.asf")
    motion, degrees = parse_amc(fixtures_dir / "cmu_02_01_short.amc", skeleton)
    return skeleton, motion, degrees


@pytest.mark.parametrize("case, words", [
    ("frame_time=0", "finite number of seconds > 0"),
    ("frame_time=nan", "finite number of seconds > 0"),
    ("no frames", "at least one motion frame"),
    ("nan channel", "frame 2 of the motion has a root channel value"),
    ("tab in a joint name", "joint name 'left.tthumb' cannot be written"),
])
def test_write_cmu_bvh_refuses_what_load_bvh_refuses(tmp_path, cmu_motion, case, words):
    skeleton, motion, degrees = cmu_motion
    motion = {k: v.copy() for k, v in motion.items()}
    frame_time = 1 / 120
    if case.startswith("frame_time"):
        frame_time = float(case.split("=")[1])
    elif case == "no frames":
        motion = {k: v[:0] for k, v in motion.items()}
    elif case.startswith("tab"):
        skeleton, motion = _renamed(skeleton, motion, "lthumb", "left\tthumb")
    else:
        motion["root"][2, 3] = np.nan
    with pytest.raises(SparseEDMError, match=words):
        write_cmu_bvh(skeleton, motion, tmp_path / "m.bvh", degrees=degrees,
                      frame_time=frame_time)
    assert list(tmp_path.iterdir()) == []


def _renamed(skeleton, motion, old, new):
    """`skeleton` and `motion` with the bone `old` called `new`."""
    import dataclasses

    def name(b):
        return new if b == old else b

    skeleton = dataclasses.replace(
        skeleton, bones={name(k): v for k, v in skeleton.bones.items()},
        parents={name(k): name(v) for k, v in skeleton.parents.items()},
        order=[name(b) for b in skeleton.order])
    return skeleton, {name(k): v for k, v in motion.items()}


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(frame_time=st.floats(1e-300, 1e6), n=st.integers(1, 5), seed=st.integers(0, 2**16),
       name=st.one_of(_PRINTABLE, _ANY_NAME))
def test_bvh_round_trip_property(tmp_path, cmu_motion, frame_time, n, seed, name):
    """Whatever write_cmu_bvh accepts, parse_bvh reads back: the frames, the frame
    time (to the 8 decimals written, or exactly), the root translation and a
    joint's name (anything else refused, nothing written)."""
    skeleton, motion, degrees = cmu_motion
    assume(name not in skeleton.bones and name not in CMU_BVH_NAMES)  # a new bone name
    rng = np.random.default_rng(seed)
    rows = rng.integers(0, len(motion["root"]), n)
    motion = {k: v[rows] for k, v in motion.items()}
    motion["root"][:, :3] += rng.normal(scale=100, size=(n, 3))
    skeleton, motion = _renamed(skeleton, motion, "lthumb", name)
    try:
        path = write_cmu_bvh(skeleton, motion, tmp_path / "m.bvh", degrees=degrees,
                             frame_time=frame_time) or tmp_path / "m.bvh"
    except FileFormatError:
        assert not any(tmp_path.iterdir())
        return
    back = parse_bvh(path)
    path.unlink()
    assert name in back.joint_names
    assert back.motion.shape[0] == n and back.frame_time > 0
    assert math.isclose(back.frame_time, frame_time, abs_tol=5e-9, rel_tol=1e-15)
    trans = [k for k, ch in enumerate(skeleton.root_order) if ch[0] == "T"]
    np.testing.assert_allclose(back.motion[:, :3], motion["root"][:, trans], atol=5e-7)


def test_trc_times_either_side_of_zero_stay_distinct(tmp_path):
    """-5e-7 s and 0 s both print as zero at 6 decimals ("-0.000000", "0.000000")."""
    back = read_trc(write_trc(tmp_path / "p.trc", np.zeros((2, 14, 3)), rate=2e6,
                              frames=[-1, 0]))
    _same_times(back["times"], np.array([-1, 0]) / 2e6)
