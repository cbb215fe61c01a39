"""Shared test fixtures: paths to the committed fixtures and to ../shared/data."""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures"
SHARED_DATA = ROOT.parent / "shared" / "data"


@pytest.fixture
def fixtures_dir():
    return FIXTURES


@pytest.fixture
def shared_data():
    """Path to ../shared/data; skips the test when it is not there."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"needs the real motion capture in {SHARED_DATA} (not present)")
    return SHARED_DATA


@pytest.fixture
def mocap_dir(tmp_path, fixtures_dir):
    """A folder with a CMU subject (02.asf + 02_01.amc) and a BVH in a sub-folder."""
    import shutil

    subj = tmp_path / "mocap" / "02"
    subj.mkdir(parents=True)
    shutil.copy(fixtures_dir / "cmu_02.asf", subj / "02.asf")
    shutil.copy(fixtures_dir / "cmu_02_01_short.amc", subj / "02_01.amc")
    other = tmp_path / "mocap" / "bvh"
    other.mkdir()
    shutil.copy(fixtures_dir / "cmu_02_01_short.bvh", other / "walk_take.bvh")
    return tmp_path / "mocap"


# --------------------------------------------------------------------------
# Recovery: real poses and a small dictionary learned from them (no ../shared)

CMU_POSES = FIXTURES / "cmu_poses.npz"


@pytest.fixture(scope="session")
def cmu_poses():
    """The 334 real CMU 2D poses of tests/fixtures/cmu_poses.npz, (n, 14, 2)."""
    import numpy as np

    with np.load(CMU_POSES, allow_pickle=False) as data:
        return data["poses2d"].astype(float)


@pytest.fixture(scope="session")
def small_dictionary(cmu_poses):
    """k=200 atoms learned in 2 passes over the fixture poses (a few seconds).

    Stands in for the shipped dictionary, which tests must not depend on.
    """
    from sparseedm.dictionary import Dictionary
    from sparseedm.learning import OnlineDictionaryLearning, complete_pose_vectors

    X, _ = complete_pose_vectors(cmu_poses)
    odl = OnlineDictionaryLearning(200, alpha=0.05, batch_size=64, n_passes=2,
                                   random_state=0).fit(X)
    return Dictionary(odl.components_, alpha_recover=0.002,
                      provenance={"files": ["tests/fixtures/cmu_poses.npz"],
                                  "n_poses": len(X)})


@pytest.fixture(scope="session")
def small_dictionary_path(small_dictionary, tmp_path_factory):
    """`small_dictionary` saved with Dictionary.save (for --dictionary PATH)."""
    return small_dictionary.save(tmp_path_factory.mktemp("dictionary") / "small.npz")


@pytest.fixture(scope="session")
def track():
    """A smooth 2D track: clip 02_05's 3D keyframes (1/3 s apart) joined by a
    cubic spline, 10 frames per interval, seen by one fixed camera."""
    import numpy as np
    from scipy.interpolate import CubicSpline

    from sparseedm.cameras import project, sample_cameras

    with np.load(FIXTURES / "cmu_poses.npz", allow_pickle=False) as data:
        keep = data["clips"] == "02_05"
        keys = data["poses3d"][keep][:25]
    t = np.arange(len(keys)) * 10.0
    frames = np.arange(int(t[-1]) + 1)
    poses3d = CubicSpline(t, keys, axis=0)(frames)
    cam = sample_cameras(1, targets=keys.reshape(-1, 3).mean(0), distance=5.0,
                         random_state=0)
    cams = type(cam)(R=np.repeat(cam.R, len(frames), 0), t=np.repeat(cam.t, len(frames), 0),
                     f=np.repeat(cam.f, len(frames)), c=np.repeat(cam.c, len(frames), 0))
    return project(poses3d, cams)


@pytest.fixture
def without_donor_step(monkeypatch):
    """recover() and recover_file() without the bank step and the donor step after
    the default path's answer (:func:`sparseedm.cold_bank.bank_step`,
    :func:`sparseedm.donors.donor_step`), for tests that rebuild that answer from
    its parts."""
    import sparseedm.batch
    import sparseedm.exemplars
    import sparseedm.recovery

    monkeypatch.setattr(sparseedm.exemplars, "donor_step", lambda res, *a, **k: res)
    for module in (sparseedm.recovery, sparseedm.batch):
        monkeypatch.setattr(module, "bank_step", lambda res, p, m, answer: (res, answer))


@pytest.fixture
def strict_json():
    """``loads(text)``: JSON as strict readers (JavaScript's ``JSON.parse``) take it,
    bare NaN / Infinity refused with a ValueError naming the constant."""
    import json

    def refuse(constant):
        raise ValueError(f"not strict JSON: a bare {constant}")

    return lambda text: json.loads(text, parse_constant=refuse)
