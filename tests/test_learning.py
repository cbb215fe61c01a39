"""Online dictionary learning and the dictionary file format."""

import json
import pickle
import zipfile

import numpy as np
import pytest

from sparseedm.cli import main
from sparseedm.dictionary import Dictionary, load_dictionary
from sparseedm.exceptions import (DictionaryError, FileFormatError, OutputPathError,
                                  SparseEDMError)
from sparseedm.learning import (
    OnlineDictionaryLearning,
    complete_pose_vectors,
    fit_dictionary_file,
    sparse_code,
)


@pytest.fixture(scope="module")
def vectors(request):
    from pathlib import Path

    path = Path(__file__).parent / "fixtures" / "cmu_poses.npz"
    with np.load(path, allow_pickle=False) as npz:
        poses = npz["poses2d"]
    X, ok = complete_pose_vectors(poses)
    assert ok.all()
    return X


def _fit(X, **kw):
    params = dict(n_components=40, alpha=0.05, batch_size=64, n_passes=2, random_state=3)
    params.update(kw)
    return OnlineDictionaryLearning(**params).fit(X)


def test_same_seed_identical_atoms(vectors):
    a = _fit(vectors).components_
    b = _fit(vectors).components_
    np.testing.assert_array_equal(a, b)
    c = _fit(vectors, random_state=4).components_
    assert not np.array_equal(a, c)


def test_atoms_unit_norm_and_better_than_random(vectors):
    train, held_out = vectors[:250], vectors[250:]
    odl = _fit(train, n_passes=3)
    np.testing.assert_allclose(np.linalg.norm(odl.components_, axis=1), 1, atol=1e-12)
    rng = np.random.default_rng(0)
    random_atoms = np.abs(rng.standard_normal(odl.components_.shape))
    random_atoms /= np.linalg.norm(random_atoms, axis=1, keepdims=True)

    def err(atoms):
        code = sparse_code(held_out, atoms, 0.05)
        return np.linalg.norm(held_out - code @ atoms) / np.linalg.norm(held_out)

    assert err(odl.components_) < 0.5 * err(random_atoms)


def test_partial_fit_over_chunks_matches_fit(vectors):
    X = vectors[:256]
    full = OnlineDictionaryLearning(30, alpha=0.05, batch_size=64, n_passes=1,
                                    random_state=0)
    full.fit(X)
    # the same schedule through partial_fit: one call per mini-batch
    from sparseedm.learning import iter_batches

    part = OnlineDictionaryLearning(30, alpha=0.05, batch_size=64, random_state=0)
    part._init_state(X)
    for batch in iter_batches(len(X), 64, 1, 0):
        part.partial_fit(X[batch])
    np.testing.assert_allclose(part.components_, full.components_, atol=1e-10)


def test_bad_parameters_refused_up_front(vectors):
    with pytest.raises(SparseEDMError, match="n_components"):
        OnlineDictionaryLearning(0).fit(vectors)
    with pytest.raises(SparseEDMError, match="alpha"):
        OnlineDictionaryLearning(10, alpha=0).fit(vectors)
    with pytest.raises(SparseEDMError, match="too few"):
        OnlineDictionaryLearning(1000).fit(vectors)
    with pytest.raises(SparseEDMError, match="NaN"):
        OnlineDictionaryLearning(10).fit(np.full((20, 91), np.nan))


# ---------------------------------------------------------------- file format

def _dictionary(k=12, seed=0):
    rng = np.random.default_rng(seed)
    comp = np.abs(rng.standard_normal((k, 91)))
    comp /= np.linalg.norm(comp, axis=1, keepdims=True)
    return Dictionary(comp, alpha_recover=0.01, provenance={"files": ["x.npz"], "n_poses": 5})


def test_save_load_round_trip(tmp_path):
    d = _dictionary()
    path = d.save(tmp_path / "d.npz")
    e = load_dictionary(path)
    np.testing.assert_array_equal(d.components, e.components)
    assert e.joint_names == d.joint_names and e.alpha_recover == 0.01
    assert "12 atoms" in e.describe()


def test_loader_refuses_pickle(tmp_path):
    path = tmp_path / "evil.npz"
    with zipfile.ZipFile(path, "w") as z:
        with z.open("components.npy", "w") as f:
            np.save(f, np.array([object()], dtype=object), allow_pickle=True)
        for name in ("joint_names", "meta"):
            with z.open(f"{name}.npy", "w") as f:
                np.save(f, np.array("x"))
    with pytest.raises(DictionaryError, match="pickle"):
        load_dictionary(path)
    raw = tmp_path / "raw.npz"
    raw.write_bytes(pickle.dumps({"components": 1}))
    with pytest.raises(DictionaryError):
        load_dictionary(raw)


def test_loader_refuses_truncated_wrong_shape_nan(tmp_path):
    good = _dictionary().save(tmp_path / "good.npz")
    data = good.read_bytes()
    trunc = tmp_path / "trunc.npz"
    trunc.write_bytes(data[: len(data) // 2])
    with pytest.raises(DictionaryError, match="corrupt or truncated"):
        load_dictionary(trunc)

    def write(name, comp, names=None):
        p = tmp_path / name
        meta = json.dumps(_dictionary().meta())
        np.savez(p, components=comp, joint_names=np.array(names or _dictionary().joint_names),
                 meta=np.array(meta))
        return p

    comp = _dictionary().components
    with pytest.raises(DictionaryError, match="N\\(N-1\\)/2|joint"):
        load_dictionary(write("shape.npz", comp[:, :90]))
    bad = comp.copy()
    bad[3, 5] = np.nan
    with pytest.raises(DictionaryError, match="NaN"):
        load_dictionary(write("nan.npz", bad))
    with pytest.raises(DictionaryError, match="unit norm"):
        load_dictionary(write("norm.npz", comp * 2))
    with pytest.raises(DictionaryError, match="15 joint names|joints"):
        load_dictionary(write("names.npz", comp, list(_dictionary().joint_names) + ["tail"]))
    with pytest.raises(DictionaryError, match="for 14 joints"):
        load_dictionary(good, n_joints=17)
    with pytest.raises(DictionaryError, match="no dictionary called"):
        load_dictionary("no-such-name")


# ----------------------------------------------------------- streaming + CLI

@pytest.fixture
def train_file(tmp_path, vectors):
    from pathlib import Path

    src = Path(__file__).parent / "fixtures" / "cmu_poses.npz"
    with np.load(src, allow_pickle=False) as npz:
        poses = npz["poses2d"].copy()
    poses[5, 3] = np.nan  # one incomplete pose: skipped with a warning
    path = tmp_path / "train.npz"
    np.savez(path, poses2d=poses)
    return path


def _interrupted_fit(train_file, out, kw, monkeypatch):
    """fit_dictionary_file interrupted (Ctrl-C) at its 8th batch: its checkpoint kept."""
    import sparseedm.learning as learning

    calls = {"n": 0}
    real_step = learning.OnlineDictionaryLearning._step

    def flaky(self, X):
        calls["n"] += 1
        if calls["n"] == 8:
            raise KeyboardInterrupt
        return real_step(self, X)

    with monkeypatch.context() as m:
        m.setattr(learning.OnlineDictionaryLearning, "_step", flaky)
        with pytest.warns(UserWarning), pytest.raises(KeyboardInterrupt):
            fit_dictionary_file(train_file, out, **kw)


def test_fit_file_skips_incomplete_and_resume_equals_uninterrupted(train_file, tmp_path,
                                                                    monkeypatch):
    kw = dict(n_components=30, alpha=0.05, batch_size=32, n_passes=2, random_state=1,
              progress=False, checkpoint_every=3)
    with pytest.warns(UserWarning, match="skipped 1 of 334"):
        ref = fit_dictionary_file(train_file, tmp_path / "ref.npz", **kw)

    # interrupt the second run after 7 batches, then resume it
    out = tmp_path / "resumed.npz"
    _interrupted_fit(train_file, out, kw, monkeypatch)
    assert not out.exists()
    assert out.with_suffix(".ckpt.npz").is_file()
    with pytest.warns(UserWarning):
        resumed = fit_dictionary_file(train_file, out, resume=True, **kw)
    np.testing.assert_array_equal(resumed.components, ref.components)
    assert not out.with_suffix(".ckpt.npz").exists()


def test_resume_refuses_a_checkpoint_of_other_training_poses(train_file, tmp_path,
                                                              monkeypatch):
    """Same settings, same pose count, other poses: continuing would learn half the
    dictionary from one file and say it came from the other."""
    kw = dict(n_components=30, alpha=0.05, batch_size=32, n_passes=2, random_state=1,
              progress=False, checkpoint_every=3)
    out = tmp_path / "d.npz"
    _interrupted_fit(train_file, out, kw, monkeypatch)
    checkpoint = out.with_suffix(".ckpt.npz")
    with np.load(checkpoint, allow_pickle=False) as ck:  # pickle-free, hash inside
        assert "sha256" in json.loads(str(ck["params"]))
    with np.load(train_file, allow_pickle=False) as npz:
        other = npz["poses2d"] * 1.5  # as many poses, other values
    other_file = tmp_path / "other.npz"
    np.savez(other_file, poses2d=other)
    before = checkpoint.read_bytes()
    with pytest.warns(UserWarning), pytest.raises(SparseEDMError,
                                                  match="other training poses"):
        fit_dictionary_file(other_file, out, resume=True, **kw)
    assert checkpoint.read_bytes() == before and not out.exists()


def test_fit_and_info_cli(train_file, tmp_path, capsys):
    out = tmp_path / "cli.npz"
    code = main(["fit", str(train_file), "-o", str(out), "--atoms", "25",
                 "--alpha", "0.05", "--batch-size", "64", "--seed", "2", "--quiet"])
    assert code == 0 and out.is_file()
    # the API's warning, as the CLI shows it: one line, no Python source line
    assert "sparseedm fit: warning: " in capsys.readouterr().err
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "25 atoms over 91 distances" in text and "333 poses" in text
    assert main(["fit", str(train_file), "-o", str(out), "--atoms", "0", "-q"]) == 2
    assert main(["fit", str(train_file), "-o", str(out), "--checkpoint",
                 str(tmp_path / "c.csv"), "-q"]) == 2  # .npz, as the output
    assert "a checkpoint file must end in .npz" in capsys.readouterr().err
    assert not (tmp_path / "c.csv").exists()
    assert main(["fit", str(train_file), "-o", str(out), "--alpha", "-1", "-q"]) == 2
    assert main(["info", str(train_file)]) == 2


def test_complete_pose_vectors_keeps_what_recover_accepts():
    """One usable-pose rule (normalize.usable_rows): besides NaN/inf and
    zero extent, training leaves out the poses whose extent overflows float64 or is
    subnormal, the ones recover() refuses as out_of_range (normalize() used to
    raise a PoseError on them, stopping the fit)."""
    base = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]] + [[0.5, 0.5]] * 11)
    poses = np.stack([base, base * 1.7e308, base * 1e-308, base * 0.0, base * 3.0])
    X, ok = complete_pose_vectors(poses)
    assert ok.tolist() == [True, False, False, False, True]
    assert X.shape == (2, 91) and np.isfinite(X).all()


def test_fit_reads_a_keypoint_file_and_learns_only_what_was_seen(train_file, tmp_path):
    """`sparseedm fit KEYPOINTS.csv` learns from the keypoint file's complete poses: the
    same dictionary as from a training set of those poses; a joint a previous
    recovery filled counts as unseen, so that pose is skipped too."""
    from sparseedm.keypoints import write_keypoints

    with np.load(train_file, allow_pickle=False) as npz:
        poses = npz["poses2d"].copy()
    missing = ~np.isfinite(poses).all(axis=-1)
    filled = np.zeros_like(missing)
    filled[7, 2] = True                      # filled by a recovery: not an observation
    csv_path = tmp_path / "people.csv"
    write_keypoints(csv_path, np.where(missing[..., None], 0.0, poses), missing,
                    filled=filled)
    seen = poses.copy()
    seen[7, 2] = np.nan
    np.savez(tmp_path / "seen.npz", poses2d=seen)
    kw = dict(n_components=20, alpha=0.05, batch_size=32, random_state=0, progress=False)
    with pytest.warns(UserWarning, match="skipped 2 of 334"):
        from_csv = fit_dictionary_file(csv_path, tmp_path / "a.npz", **kw)
    with pytest.warns(UserWarning, match="skipped 2 of 334"):
        from_npz = fit_dictionary_file(tmp_path / "seen.npz", tmp_path / "b.npz", **kw)
    np.testing.assert_allclose(from_csv.components, from_npz.components, atol=1e-9)
    assert main(["fit", str(csv_path), "-o", str(tmp_path / "c.npz"), "--atoms", "20",
                 "-q"]) == 0
    # --input-format npz names a training set too (it was read as keypoints only:
    # "no 'poses' array")
    odd = tmp_path / "seen.data"
    odd.write_bytes((tmp_path / "seen.npz").read_bytes())
    with pytest.warns(UserWarning, match="skipped 2 of 334"):
        told = fit_dictionary_file(odd, tmp_path / "e.npz", input_format="npz", **kw)
    np.testing.assert_array_equal(told.components, from_npz.components)
    # an .npz that is neither a training set nor keypoints names both
    np.savez(tmp_path / "other.npz", weights=np.zeros(3))
    with pytest.raises(FileFormatError, match="neither a training set.*nor a keypoint"):
        fit_dictionary_file(tmp_path / "other.npz", tmp_path / "d.npz", **kw)


def test_too_few_complete_poses_says_what_to_do(train_file, tmp_path):
    """A keypoint file with fewer complete poses than atoms: the refusal gives the atom
    count that would fit and the fine-tuning alternative; with none, it says so."""
    from sparseedm.keypoints import write_keypoints

    with np.load(train_file, allow_pickle=False) as npz:
        poses = npz["poses2d"].copy()
    missing = ~np.isfinite(poses).all(axis=-1)
    missing[12:, 3] = True                        # 12 complete poses, one incomplete among them
    csv_path = tmp_path / "few.csv"
    write_keypoints(csv_path, np.where(missing[..., None], 0.0, poses), missing)
    out = tmp_path / "d.npz"
    with pytest.warns(UserWarning, match="skipped 323 of 334"), \
            pytest.raises(SparseEDMError, match="11 complete poses are too few for 20 atoms.*"
                          "--atoms 11.*--init default"):
        fit_dictionary_file(csv_path, out, n_components=20, progress=False)
    missing[:, 3] = True
    write_keypoints(csv_path, np.where(missing[..., None], 0.0, poses), missing)
    with pytest.warns(UserWarning), pytest.raises(SparseEDMError,
                                                  match="no complete pose to learn from"):
        fit_dictionary_file(csv_path, out, n_components=20, progress=False)
    assert not out.exists()


def test_fine_tune_refuses_its_own_inputs_as_output_before_any_work(train_file, tmp_path,
                                                                     monkeypatch):
    """`fit TRAIN -o TRAIN --init default` used to fine-tune, then overwrite the training
    file with the dictionary; the base's file and a non-.npz output are refused up front."""
    import sparseedm.adaptation as adaptation

    def no_work(*args, **kwargs):
        raise AssertionError("fine-tuned before checking the output")

    monkeypatch.setattr(adaptation, "adapt_vectors", no_work)
    before = train_file.read_bytes()
    assert main(["fit", str(train_file), "-o", str(train_file), "--init", "default",
                 "-q"]) == 2
    assert train_file.read_bytes() == before
    base = tmp_path / "base.npz"
    load_dictionary("default").save(base)
    with pytest.raises(OutputPathError, match="initial dictionary"):
        adaptation.fine_tune_file(train_file, base, base)
    with pytest.raises(DictionaryError, match="must end in .npz"):
        adaptation.fine_tune_file(train_file, tmp_path / "d.csv")
    assert not (tmp_path / "d.csv").exists()


def test_fit_from_a_frame_folder_with_an_unreadable_file_exits_1(fixtures_dir, tmp_path,
                                                                 capsys):
    """As recover and lift: a frame file that cannot be read is skipped with a warning,
    the dictionary written from the rest and named in its provenance, exit 1 (was 0)."""
    import shutil

    folder = tmp_path / "frames"
    shutil.copytree(fixtures_dir / "formats" / "openpose", folder)
    (folder / "video_000000000009_keypoints.json").write_text("{bad")
    out = tmp_path / "d.npz"
    assert main(["fit", str(folder), "-o", str(out), "--atoms", "2", "-q"]) == 1
    err = capsys.readouterr().err
    assert f"1 input file(s) unreadable; see {tmp_path / 'd.errors.csv'}" in err
    assert load_dictionary(out).provenance["skipped_files"] == [
        "video_000000000009_keypoints.json"]
    lines = (tmp_path / "d.errors.csv").read_text().splitlines()
    assert lines[1].startswith(",video_000000000009_keypoints.json,unreadable_file,")
    tuned = tmp_path / "t.npz"
    assert main(["fit", str(folder), "-o", str(tuned), "--init", "default", "-q"]) == 1
    assert load_dictionary(tuned).provenance["skipped_files"] == [
        "video_000000000009_keypoints.json"]
    (folder / "video_000000000009_keypoints.json").unlink()
    assert main(["fit", str(folder), "-o", str(out), "--atoms", "2", "-q"]) == 0
    assert "skipped_files" not in load_dictionary(out).provenance
    assert not (tmp_path / "d.errors.csv").exists()  # the stale errors file removed


def test_fit_lists_refused_rows_in_an_errors_file_as_recover_does(train_file, tmp_path,
                                                                   capsys):
    """A keypoint file with an infinite coordinate, a pose at one point and one far off:
    fit (and fit --init) learns from the rest, lists those rows (row, id, status,
    reason) in an errors file written by recover's writer, and exits 1; recover
    refuses the same rows with the same statuses."""
    import csv

    with np.load(train_file, allow_pickle=False) as npz:
        poses = npz["poses2d"][:60].copy()
    missing = ~np.isfinite(poses).all(axis=-1)
    poses[3, 4, 1] = np.inf                  # invalid_coordinates
    poses[8] = 2.0                           # degenerate
    poses[11, 6] = [1e300, 0.0]              # out_of_range: one joint far off
    ids = [f"img{i}" for i in range(len(poses))]
    kps_path = tmp_path / "people.npz"  # write_keypoints would write inf as missing
    np.savez(kps_path, poses=np.where(missing[..., None], 0.0, poses), missing=missing,
             ids=np.array(ids))
    expected = [["3", "img3", "invalid_coordinates"], ["8", "img8", "degenerate"],
                ["11", "img11", "out_of_range"]]
    for extra, out in ((["--atoms", "20"], "d.npz"), (["--init", "default"], "t.npz")):
        errors = tmp_path / f"{out}.errors.csv"
        argv = ["fit", str(kps_path), "-o", str(tmp_path / out), "--errors", str(errors),
                "-q"]
        assert main(argv + extra) == 1
        assert f"3 row(s) refused; see {errors}" in capsys.readouterr().err
        with open(errors, newline="") as f:
            rows = list(csv.reader(f))
        assert rows[0] == ["row", "id", "status", "reason"]
        assert [r[:3] for r in rows[1:]] == expected and all(r[3] for r in rows[1:])
        assert load_dictionary(tmp_path / out).provenance["refused_rows"] == 3
    recovered = tmp_path / "r.npz"
    assert main(["recover", str(kps_path), "-o", str(recovered), "-q"]) == 1
    with open(tmp_path / "r.errors.csv", newline="") as f:
        assert [r[:3] for r in list(csv.reader(f))[1:]] == expected
