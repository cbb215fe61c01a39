"""Writer/reader round trips of the detector and tracker formats, with hypothesis.

Each format: what :func:`sparseedm.keypoints.write_keypoints` writes (poses with
NaN for missing joints, scores, filled flags, 90 % radii, tracks and frames where
the format can hold them), :func:`sparseedm.keypoints.read_keypoints` reads back
equal, or the writer refuses with a SparseEDMError; never a file its reader
refuses or reads differently. Files are read with ``confidence_threshold=0``:
the threshold is a reading policy, not part of the file.
"""

import json
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from sparseedm._atomic import save_npz
from sparseedm.batch import recover_file
from sparseedm.exceptions import SparseEDMError
from sparseedm.formats._base import filled_likelihood
from sparseedm.keypoints import read_keypoints, status_sidecar, write_keypoints
from sparseedm.skeleton import JOINT_NAMES

N = 14
HEAD_TOP, NECK = JOINT_NAMES.index("head_top"), JOINT_NAMES.index("neck")
SETTINGS = settings(max_examples=30, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])
#: finite coordinates of any magnitude (subnormal to 1.8e308), either sign, and 0
coordinate = st.one_of(st.just(0.0), st.floats(-1e4, 1e4),
                       st.floats(allow_nan=False, allow_infinity=False))
#: a detector's score of an observed joint (read with threshold 0: > 0 is present)
score = st.floats(0.0, 1.0, exclude_min=True)
radius = st.floats(0.0, 1e9)
#: body part and scorer names a user's project could have
name = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
               min_size=1, max_size=12)


@st.composite
def cases(draw, track=st.integers(0, 2**31 - 1), tracks=True):
    """Poses, missing / filled masks, scores, radii, tracks and frames."""
    n = draw(st.integers(1, 5))
    poses = draw(hnp.arrays(float, (n, N, 2), elements=coordinate))
    missing = draw(hnp.arrays(bool, (n, N)))
    filled = draw(hnp.arrays(bool, (n, N))) & ~missing
    confidence = draw(hnp.arrays(float, (n, N), elements=score))
    radii = np.where(filled, draw(hnp.arrays(float, (n, N), elements=radius)), 0.0)
    refused = draw(hnp.arrays(bool, n))  # a refused pose: no radii at all
    radii[refused] = np.nan
    case = dict(poses=np.where(missing[..., None], np.nan, poses), missing=missing,
                filled=filled, confidence=confidence, uncertainty=radii)
    # frame numbers: whole numbers up to 2**53 either sign (past it, or a fraction: refused)
    frame = st.integers(-2**53 - 1, 2**53 + 1) | st.integers(-2, 20)
    if draw(st.booleans()):
        frame = st.sampled_from([0.0, 3.0, 2.5, -1.0, 1e300])
    case["frames"] = np.asarray(draw(st.lists(frame, min_size=n, max_size=n)))
    if tracks:
        case["tracks"] = np.asarray(draw(st.lists(track, min_size=n, max_size=n)))
    return case


def _write(path, case, fmt, **extra):
    """The written path, or None when the writer refuses (naming the problem)."""
    try:
        return write_keypoints(path, case["poses"], format=fmt, confidence=case["confidence"],
                               filled=case["filled"], uncertainty=case["uncertainty"],
                               tracks=case.get("tracks"), frames=case.get("frames"), **extra)
    except SparseEDMError as exc:
        assert str(exc) and not path.exists()
        return None


def _order(case, by_frame):
    """Row order of the file: by frame (stable) for formats grouping rows by frame."""
    n = len(case["poses"])
    return np.argsort(case["frames"], kind="stable") if by_frame else np.arange(n)


def _assert_read_back(kps, case, order, *, scores=True, radii=True, frames=True,
                      tracks=True, derived=()):
    missing = case["missing"][order]
    np.testing.assert_array_equal(kps.missing, missing)
    np.testing.assert_array_equal(kps.poses, case["poses"][order])
    filled = case["filled"][order]
    np.testing.assert_array_equal(False if kps.filled is None else kps.filled, filled)
    if scores:
        seen = ~missing & ~filled
        seen[:, list(derived)] = False  # no keypoint of the format's own: no score
        np.testing.assert_array_equal(kps.confidence[seen], case["confidence"][order][seen])
    if radii:
        np.testing.assert_array_equal(kps.uncertainty, case["uncertainty"][order])
    if frames:
        np.testing.assert_array_equal(kps.frames, case["frames"][order])
    if tracks and "tracks" in case:
        np.testing.assert_array_equal(kps.tracks.astype(str),
                                      case["tracks"][order].astype(str))


# OpenPose: a folder of per-frame files; the frame is in each file's name (a
# whole number from 0 to 2**53; in the "sparseedm" object of a single file), the track in ``person_id`` (an integer >= 0, -1 is "no
# id": other tracks are refused), the neck / head top, filled joints and radii in
# the "sparseedm" object.
@SETTINGS
@given(case=cases(track=st.one_of(st.integers(0, 2**63 - 1), st.integers(-3, -1),
                                  st.text(max_size=2))),
       name=st.sampled_from(["frames", "out.json"]))
def test_openpose_round_trip(tmp_path_factory, case, name):
    """A folder, or one frame's file (several frames there: refused)."""
    path = _write(tmp_path_factory.mktemp("op") / name, case, "openpose")
    if path is not None:
        kps = read_keypoints(path, format="openpose", confidence_threshold=0)
        _assert_read_back(kps, case, _order(case, True), derived=[HEAD_TOP])


# MMPose: one JSON (``instance_info``: ``frame_id`` per frame, ``track_id`` per
# instance, any int or text) or, for a path without .json, a folder of per-image
# files named by the frame number (from 0: a negative one is refused there).
@SETTINGS
@given(case=cases(track=st.one_of(st.integers(-2**53, 2**53), st.text(min_size=1))),
       folder=st.booleans())
def test_mmpose_round_trip(tmp_path_factory, case, folder):
    path = tmp_path_factory.mktemp("mm") / ("frames" if folder else "out.json")
    path = _write(path, case, "mmpose")
    if path is not None:
        kps = read_keypoints(path, format="mmpose", confidence_threshold=0)
        _assert_read_back(kps, case, _order(case, True), derived=[NECK, HEAD_TOP])


# AlphaPose results JSON: one result per pose, in row order; the frame in
# ``image_id`` (``<frame>.jpg``, a whole number from 0: a negative one is
# refused) and in the "sparseedm" object (null without frames: no frame then),
# the track in ``idx`` (an int or text).
@SETTINGS
@given(case=cases(track=st.one_of(st.integers(-2**53, 2**53), st.text(min_size=1))),
       timed=st.booleans(), tracked=st.booleans(), ids=st.booleans())
def test_alphapose_round_trip(tmp_path_factory, case, timed, tracked, ids):
    n = len(case["poses"])
    if not timed:  # photos: no frames, tracks only when given
        case.pop("frames")
        if not tracked:
            case.pop("tracks")
    extra = {"ids": [f"img_{r}.png" for r in range(n)]} if ids else {}
    path = _write(tmp_path_factory.mktemp("ap") / "out.json", case, "alphapose", **extra)
    if path is not None:
        kps = read_keypoints(path, confidence_threshold=0)  # told from its content
        assert kps.meta["format"] == "alphapose"
        _assert_read_back(kps, case, np.arange(n), frames=timed, derived=[NECK, HEAD_TOP])
        if not timed:
            assert kps.frames is None and (kps.tracks is None) is not tracked
        if ids and not timed:
            assert kps.ids.tolist() == extra["ids"]


# COCO / PoseTrack keypoints JSON: annotations with ``image_id`` from the ids,
# ``track_id`` from the tracks and, with frames (tracks or not), PoseTrack's
# ``images`` holding each image's ``frame_id`` (any whole number up to 2**53;
# an image given two frames is refused). Scores are COCO's ``v``: a fresh file's
# observed keypoints are v = 2, so scores are not compared.
@SETTINGS
@given(case=cases(track=st.integers(-2**53, 2**53) | st.text(min_size=1)),
       ids=st.booleans(), tracks=st.booleans(), frames=st.booleans())
def test_coco_round_trip(tmp_path_factory, case, ids, tracks, frames):
    n = len(case["poses"])
    if not tracks:
        case.pop("tracks")
    if not frames:
        case.pop("frames")
    extra = {"ids": [f"img{r}" for r in range(n)]} if ids else {}
    path = _write(tmp_path_factory.mktemp("coco") / "out.json", case, "coco", **extra)
    if path is not None:
        kps = read_keypoints(path, format="coco", confidence_threshold=0)
        _assert_read_back(kps, case, np.arange(n), scores=False, frames=frames)
        if not frames and not tracks:  # (tracked, a COCO file's frames are its image ids)
            assert kps.frames is None
        if ids:
            assert kps.ids.tolist() == extra["ids"]


def test_coco_frames_without_tracks_read_back_as_frames(tmp_path):
    poses = np.arange(3 * N * 2, dtype=float).reshape(3, N, 2)
    path = write_keypoints(tmp_path / "f.json", poses, format="coco", frames=[7, 8, 9])
    doc = json.loads(path.read_text())
    assert [img["frame_id"] for img in doc["images"]] == [7, 8, 9]
    assert not any("track_id" in ann for ann in doc["annotations"])
    kps = read_keypoints(path)
    assert kps.tracks is None and kps.frames.tolist() == [7, 8, 9]


def test_plain_coco_image_ids_are_no_frames(tmp_path):
    """Without ``frame_id`` images, integer image ids stay ids, not frames."""
    path = write_keypoints(tmp_path / "p.json", np.ones((2, N, 2)), format="coco",
                           ids=["3", "4"])
    assert read_keypoints(path).frames is None


def _sidecar(path, case, keyed=False):
    """The status sidecar ``sparseedm recover`` writes beside a DeepLabCut table
    (`keyed`: with the poses' tracks and frames, which its rows are matched by)."""
    keys = {"tracks": case["tracks"], "frames": case["frames"].astype(np.int64)} \
        if keyed else {}
    save_npz(status_sidecar(path), {"filled": case["filled"],
                                    "uncertainty": case["uncertainty"], **keys})


# DeepLabCut, written fresh: body parts the joint names; one individual per track
# (multi-animal) unless the only track is 0; rows the frames (sorted, the index
# their numbers: an individual absent from a frame reads back as a pose with
# every joint missing), or without frames the poses in order (the index their
# ids); the filled flags and radii live in the status sidecar.
@SETTINGS
@given(case=cases(track=st.integers(0, 2) | st.text(max_size=2)),
       ext=st.sampled_from(["csv", "h5"]), data=st.data())
def test_deeplabcut_fresh_round_trip(tmp_path_factory, case, ext, data):
    if ext == "h5":
        pytest.importorskip("tables")
    n = len(case["poses"])
    timed = data.draw(st.booleans())
    ids = None
    if not timed:  # the index holds the ids
        del case["tracks"], case["frames"]
        ids = data.draw(st.none() | st.lists(name, min_size=n, max_size=n, unique=True))
    path = _write(tmp_path_factory.mktemp("dlc") / f"out.{ext}", case, "dlc", ids=ids)
    if path is None:
        return
    _sidecar(path, case, keyed=timed)
    kps = read_keypoints(path, format="dlc", confidence_threshold=0)
    if not timed:
        _assert_read_back(kps, case, np.arange(n), frames=False)
        if ids is None:  # the index: row numbers
            assert kps.frames.tolist() == list(range(n))
        assert kps.ids.tolist() == (ids or [str(r) for r in range(n)])
        return
    row = {(t, f): k for k, (t, f) in enumerate(zip(kps.tracks.astype(str).tolist(),
                                                     kps.frames.tolist()))}
    assert len(row) == len(kps)  # one pose per track and frame
    hit = np.asarray([row[(str(t), int(f))] for t, f in zip(case["tracks"].tolist(),
                                                             case["frames"].tolist())])
    _assert_read_back(_rows_of(kps, hit), case, np.arange(n))
    holes = np.setdiff1d(np.arange(len(kps)), hit)  # a track absent from a frame
    assert kps.missing[holes].all() and np.isnan(kps.uncertainty[holes]).all()


def _rows_of(kps, rows):
    """The read keypoints' arrays at `rows`."""
    return SimpleNamespace(**{a: None if getattr(kps, a) is None else getattr(kps, a)[rows]
                              for a in ("poses", "missing", "filled", "confidence",
                                        "uncertainty", "frames", "tracks")})


@st.composite
def dlc_tables(draw):
    """A user's DeepLabCut table: scorer, individuals (multi-animal) and body parts
    of the user's names (mapped to the joints), x / y / likelihood per part, NaN
    (an empty CSV cell) for an undetected part; rows frame-major per individual."""
    # pandas writes a line break of a name unquoted: no reader can read it back
    user = name.filter(lambda t: "\r" not in t and "\n" not in t)
    parts = draw(st.lists(user, min_size=N, max_size=N, unique=True))
    scorer = draw(user)
    individuals = draw(st.none() | st.lists(user, min_size=1, max_size=3, unique=True))
    case = draw(cases(tracks=False))
    k = len(individuals or [0])
    n = len(case["poses"]) // k * k
    if n == 0:
        individuals, k, n = None, 1, len(case["poses"])
    case = {key: v[:n] for key, v in case.items()}
    case["frames"] = np.repeat(np.arange(n // k), k)
    if individuals is not None:
        case["tracks"] = np.tile(np.asarray(individuals), n // k)
    return parts, scorer, individuals, case


def _dlc_table(path, parts, scorer, individuals, case):
    """The table as DeepLabCut writes it (.csv, or .h5 with pandas)."""
    pd = pytest.importorskip("pandas")
    inds = individuals or [None]
    columns = [(scorer,) + ((i,) if individuals else ()) + (p, c)
               for i in inds for p in parts for c in ("x", "y", "likelihood")]
    present = ~(case["missing"] | case["filled"])
    values = np.where(present[..., None], np.concatenate(
        [case["poses"], case["confidence"][..., None]], axis=-1), np.nan)
    table = values.reshape(len(values) // len(inds), -1)
    levels = ["scorer"] + (["individuals"] if individuals else []) + ["bodyparts", "coords"]
    df = pd.DataFrame(table, columns=pd.MultiIndex.from_tuples(columns, names=levels))
    if path.suffix == ".h5":
        pytest.importorskip("tables")
        df.to_hdf(path, key="df_with_missing", format="table", mode="w")
    else:
        df.to_csv(path)


@SETTINGS
@given(table=dlc_tables(), ext=st.sampled_from([".csv", ".h5"]))
def test_deeplabcut_user_table_round_trip(tmp_path_factory, table, ext):
    """A table with the user's names: read, joints filled, written back, read again."""
    parts, scorer, individuals, case = table
    folder = tmp_path_factory.mktemp("dlcu")
    src, out, jmap = folder / f"in{ext}", folder / f"out{ext}", folder / "map.json"
    _dlc_table(src, parts, scorer, individuals, case)
    jmap.write_text(json.dumps({"joints": dict(zip(JOINT_NAMES, parts))}))
    try:
        kps = read_keypoints(src, format="dlc", joint_map=jmap, confidence_threshold=0)
    except SparseEDMError as exc:
        pytest.fail(f"a DeepLabCut table with names {parts!r} / {scorer!r}: {exc}")
    read_missing = case["missing"] | case["filled"]
    np.testing.assert_array_equal(kps.missing, read_missing)
    kps.poses, kps.missing = case["poses"], case["missing"]  # the filled joints
    path = _write(out, case, "dlc", meta=kps.meta)
    if path is not None:
        _sidecar(path, case)
        back = read_keypoints(path, format="dlc", joint_map=jmap, confidence_threshold=0)
        _assert_read_back(back, case, np.arange(len(kps)), scores=False,
                          tracks=individuals is not None)
        seen = ~read_missing
        np.testing.assert_array_equal(back.confidence[seen], case["confidence"][seen])


# .npy: poses (and a score column) only; the filled flags and radii in the status
# sidecar ``sparseedm recover`` writes; no ids, tracks or frames.
@SETTINGS
@given(case=cases(tracks=False))
def test_npy_with_its_status_sidecar_round_trip(tmp_path_factory, case):
    case.pop("frames")
    path = _write(tmp_path_factory.mktemp("npy") / "out.npy", case, "npy")
    if path is not None:
        _sidecar(path, case)
        kps = read_keypoints(path, format="npy", confidence_threshold=0)
        _assert_read_back(kps, case, np.arange(len(case["poses"])), frames=False)


# ------------------------------------------------------------- regressions


@pytest.mark.parametrize("name,fmt", [("out.json", "coco"), ("out.json", "mmpose"),
                                      ("frames", "openpose")])
def test_a_missing_neck_is_not_derived_again(tmp_path, name, fmt):
    poses = np.arange(N * 2, dtype=float).reshape(1, N, 2)
    poses[0, NECK] = np.nan  # the shoulders are there
    kps = read_keypoints(write_keypoints(tmp_path / name, poses, format=fmt), format=fmt)
    assert kps.missing[0, NECK]


def test_openpose_refuses_a_track_it_cannot_hold(tmp_path):
    with pytest.raises(SparseEDMError, match="track -1 cannot be an OpenPose"):
        write_keypoints(tmp_path / "f", np.ones((1, N, 2)), format="openpose", tracks=[-1])
    assert not (tmp_path / "f").exists()


def test_deeplabcut_body_part_names_keep_their_spaces(tmp_path):
    path = tmp_path / "t.csv"
    parts = [f" {n}" for n in JOINT_NAMES]
    path.write_text("scorer" + ",s,s,s" * N + "\nbodyparts" + "".join(
        f",{p},{p},{p}" for p in parts) + "\ncoords" + ",x,y,likelihood" * N
        + "\n0" + ",1.0,2.0,0.9" * N + "\n")
    (tmp_path / "map.json").write_text(json.dumps({"joints": dict(zip(JOINT_NAMES, parts))}))
    assert not read_keypoints(path, joint_map=tmp_path / "map.json").missing.any()


@pytest.mark.parametrize("ext", ["csv", "h5"])
def test_deeplabcut_ids_read_back_as_written(tmp_path, ext):
    if ext == "h5":
        pytest.importorskip("tables")
    ids = [" a", "7", "007", "²"]
    path = write_keypoints(tmp_path / f"t.{ext}", np.ones((4, N, 2)), ids=ids, format="dlc")
    assert read_keypoints(path, format="dlc").ids.tolist() == ids


def test_posetrack_frames_read_back(tmp_path):
    path = write_keypoints(tmp_path / "t.json", np.ones((2, N, 2)), tracks=[0, 0],
                           frames=[10, 20])
    assert read_keypoints(path).frames.tolist() == [10, 20]
    with pytest.raises(SparseEDMError, match="frame number 2.5"):
        write_keypoints(tmp_path / "u.json", np.ones((1, N, 2)), tracks=[0], frames=[2.5])


@pytest.mark.parametrize("frame,fmt,name", [(0.5, "mmpose", "m.json"), (-1, "openpose", "f"),
                                            (-1, "mmpose", "f"), (-1, "alphapose", "a.json"),
                                            (2.5, "alphapose", "a.json")])
def test_a_frame_its_files_cannot_hold_is_refused(tmp_path, frame, fmt, name):
    with pytest.raises(SparseEDMError, match=f"frame number {frame}"):
        write_keypoints(tmp_path / name, np.ones((1, N, 2)), format=fmt, frames=[frame])
    assert not (tmp_path / name).exists()


# The CLI's own path: a file read, some missing joints filled, written back with
# the read's meta (the documents as read, the filled keypoints set, per-pose status
# and radii in the "sparseedm" objects), read again.
@SETTINGS
@given(case=cases(), where=st.sampled_from([("frames", "openpose"), ("out.json", "mmpose"),
                                            ("frames", "mmpose"), ("out.json", "coco"),
                                            ("out.json", "alphapose")]),
       data=st.data())
def test_written_back_after_a_read_round_trip(tmp_path_factory, case, where, data):
    name, fmt = where
    folder = tmp_path_factory.mktemp("back")
    first = case | {"filled": np.zeros_like(case["filled"]),
                    "uncertainty": None, "poses": case["poses"].copy()}
    first["poses"][first["filled"] | case["filled"]] = np.nan  # missing before the fill
    src = _write(folder / name, first, fmt)
    if src is None:
        return
    kps = read_keypoints(src, format=fmt, confidence_threshold=0)
    order = _order(case, fmt not in ("coco", "alphapose"))  # rows kept in order
    kps.poses, kps.missing = case["poses"][order], case["missing"][order]  # the fill
    status = data.draw(st.lists(st.sampled_from(["recovered", "refused"]),
                                min_size=len(kps), max_size=len(kps)))
    out = write_keypoints(folder / f"2{name}", kps, format=fmt,
                          filled=case["filled"][order], uncertainty=case["uncertainty"][order],
                          row_fields={"status": status} if fmt != "coco" else None)
    back = read_keypoints(out, format=fmt, confidence_threshold=0)
    again = case | {k: v[order] for k, v in case.items() if k != "frames"}
    again["frames"] = kps.frames
    _assert_read_back(back, again, np.arange(len(kps)), scores=fmt != "coco",
                      frames=kps.frames is not None, tracks=kps.tracks is not None,
                      derived=[NECK, HEAD_TOP])


def test_filled_likelihood_of_a_pose_without_joints_warns_nothing():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # PYTHONWARNINGS=error: no internal error
        like = filled_likelihood(np.full((1, N, 2), np.nan), np.zeros((1, N)), 0.1)
    assert (like == 0.1).all()


def test_openpose_single_file_keeps_its_frame(tmp_path):
    path = write_keypoints(tmp_path / "x.json", np.ones((1, N, 2)), format="openpose",
                           frames=[7])
    assert read_keypoints(path, format="openpose").frames.tolist() == [7]
    with pytest.raises(SparseEDMError, match="the name says frame 12"):
        write_keypoints(tmp_path / "v_000000000012.json", np.ones((1, N, 2)),
                        format="openpose", frames=[7])


def test_a_neck_between_huge_shoulders_is_their_midpoint(tmp_path):
    poses = np.full((1, N, 2), 1.7e308)
    poses[0, NECK] = np.nan
    path = write_keypoints(tmp_path / "t.json", poses, missing=np.eye(N, dtype=bool)[[NECK]])
    doc = json.loads(path.read_text())
    del doc[0]["sparseedm"]["neck"]  # derived from the shoulders again
    path.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_keypoints(path).poses[0, NECK].tolist() == [1.7e308, 1.7e308]



def test_deeplabcut_output_keeps_two_tracks_and_their_frames(tmp_path, cmu_poses,
                                                             small_dictionary):
    """recover_file from an .npz with 2 tracks x 5 frames into a new DeepLabCut .csv."""
    poses = cmu_poses[:10].copy()
    tracks, frames = np.tile([3, 8], 5), np.repeat([10, 11, 12, 14, 20], 2)
    missing = np.zeros((10, N), dtype=bool)
    missing[[1, 6], JOINT_NAMES.index("left_wrist")] = True
    src, out = tmp_path / "in.npz", tmp_path / "out.csv"
    save_npz(src, {"poses": poses, "missing": missing, "tracks": tracks, "frames": frames})
    recover_file(src, out, dictionary=small_dictionary, output_format="dlc")
    assert "individuals" in out.read_text().splitlines()[1]
    back = read_keypoints(out, format="dlc")
    assert len(back) == 10 and back.tracks.tolist() == [str(t) for t in tracks]
    assert back.frames.tolist() == frames.tolist()
    seen = ~missing
    np.testing.assert_allclose(back.poses[seen], poses[seen])
    np.testing.assert_array_equal(back.filled, missing)


@pytest.mark.parametrize("tracks,frames,why", [
    ([0, 0], [4, 4], "pose 1: frame 4 is already pose 0's"),
    (["a", "b"], [0, 1.5], "pose 1: frame number 1.5"),
    ([0, 1], None, "tracks need frame numbers")])
def test_deeplabcut_fresh_refuses_what_it_cannot_hold(tmp_path, tracks, frames, why):
    with pytest.raises(SparseEDMError, match=why):
        write_keypoints(tmp_path / "t.csv", np.ones((2, N, 2)), format="dlc",
                        tracks=tracks, frames=frames)
    assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("name,fmt,tracks,frames,match", [
    ("frames", "openpose", None, [-1, 0, 1], "frame number -1 is negative"),
    ("out.json", "coco", None, [2**60, 0, 1], "frame number '1152921504606846976' is too large"),
    ("out.csv", "dlc", None, [2**60, 0, 1], "too large"),
    ("frames", "openpose", ["a", "a", "b"], [0, 1, 0], "track 'a' cannot be an OpenPose"),
    ("out.csv", "dlc", None, [4, 4, 5], "pose 1: frame 4 is already pose 0's"),
    ("out.csv", "dlc", ["a", "b", "a"], [7, 7, 7], "pose 2: frame 7 of track 'a' is already"),
    ("out.csv", "dlc", ["a\nb", "c", "c"], [0, 0, 1], "track 'a.+b' holds a line break"),
])
def test_a_run_refuses_what_its_output_cannot_hold_before_recovering(
        tmp_path, monkeypatch, name, fmt, tracks, frames, match):
    import sparseedm.batch

    def no_recovery(*args, **kwargs):
        raise AssertionError("recovered before refusing")

    poses = np.arange(3 * N * 2, dtype=float).reshape(3, N, 2) % 97
    missing = np.zeros((3, N), dtype=bool)
    missing[:, 3] = True
    src = write_keypoints(tmp_path / "in.csv", poses, missing=missing, tracks=tracks,
                          frames=np.array(frames, dtype=object))
    monkeypatch.setattr(sparseedm.batch, "recover", no_recovery)
    out = tmp_path / "out" / name
    out.parent.mkdir()
    with pytest.raises(SparseEDMError, match=match):
        recover_file(src, out, output_format=fmt, progress=False)
    assert list(out.parent.iterdir()) == []  # nothing written, no errors file


def _with_nan(doc):
    """`doc` with a NaN field beside each person (or at its top): a field the readers
    do not use, as Python's json writes and reads it."""
    if isinstance(doc, dict):
        return doc | {"detector_note": float("nan")}
    return [_with_nan(x) if isinstance(x, dict) else x for x in doc]


def _notes(doc):
    """The values of every ``detector_note`` in a JSON document."""
    if isinstance(doc, dict):
        own = [doc["detector_note"]] if "detector_note" in doc else []
        return own + [v for x in doc.values() for v in _notes(x)]
    return [v for x in doc for v in _notes(x)] if isinstance(doc, list) else []


@pytest.mark.parametrize("name,fmt", [("out.json", "coco"), ("out.json", "mmpose"),
                                      ("frames", "mmpose"), ("out.json", "alphapose"),
                                      ("frames", "openpose")])
def test_a_read_documents_nan_is_written_back_as_null(tmp_path, strict_json, name, fmt):
    """The documents a reader keeps are written back as strict JSON (JavaScript's
    JSON.parse reads them): a NaN they held is null, and the file reads back the same."""
    poses = np.arange(2 * N * 2, dtype=float).reshape(2, N, 2) % 37 + 1
    poses[1, 3] = np.nan
    src = write_keypoints(tmp_path / name, poses, format=fmt, frames=np.array([0, 1]))
    files = sorted(p for p in src.iterdir() if p.suffix == ".json") if src.is_dir() else [src]
    for f in files:
        f.write_text(json.dumps(_with_nan(json.loads(f.read_text()))))
    kps = read_keypoints(src, format=fmt)
    out = write_keypoints(tmp_path / f"2{name}", kps, format=fmt)
    written = sorted(p for p in out.iterdir() if p.suffix == ".json") if out.is_dir() else [out]
    assert len(written) == len(files)
    for f in written:
        notes = _notes(strict_json(f.read_text()))
        assert notes and all(v is None for v in notes), f
    back = read_keypoints(out, format=fmt)
    assert np.array_equal(back.missing, kps.missing)
    assert np.allclose(back.poses, kps.poses, equal_nan=True)
