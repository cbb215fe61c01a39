"""A file's complete poses as extra atoms (sparseedm.file_atoms) and recover()'s use of them."""

import numpy as np
import pytest

from sparseedm import recover
from sparseedm.adaptation import MIN_COMPLETE_POSES, pose_vectors
from sparseedm.file_atoms import with_file_atoms


def test_atoms_are_the_complete_poses_unit_norm(cmu_poses, small_dictionary):
    poses = cmu_poses[:40].copy()
    missing = np.zeros((40, 14), bool)
    missing[30:, 4] = True          # ten incomplete rows: not atoms
    poses[25, 3] = np.nan           # a NaN row: not an atom
    poses[10] = poses[5]            # an exact repeat: one atom
    out = with_file_atoms(small_dictionary, poses, missing)
    k = small_dictionary.n_components
    assert out.n_complete == 29
    assert out.n_atoms == 28
    assert out.dictionary.n_components == k + 28
    np.testing.assert_array_equal(out.dictionary.components[:k], small_dictionary.components)
    rows = [i for i in range(30) if i not in (10, 25)]
    X = pose_vectors(poses[rows])
    np.testing.assert_allclose(out.dictionary.components[k:],
                               X / np.linalg.norm(X, axis=1, keepdims=True))
    assert out.dictionary.provenance["file_atoms"]["atoms"] == 28


def test_cap_is_a_seeded_sample(cmu_poses, small_dictionary):
    a = with_file_atoms(small_dictionary, cmu_poses[:60], max_atoms=20, random_state=3)
    b = with_file_atoms(small_dictionary, cmu_poses[:60], max_atoms=20, random_state=3)
    c = with_file_atoms(small_dictionary, cmu_poses[:60], max_atoms=20, random_state=4)
    assert a.n_atoms == 20
    np.testing.assert_array_equal(a.dictionary.components, b.dictionary.components)
    assert not np.array_equal(a.dictionary.components, c.dictionary.components)


def test_no_complete_pose_leaves_the_dictionary(cmu_poses, small_dictionary):
    poses = cmu_poses[:5].copy()
    poses[:, 2] = np.nan
    out = with_file_atoms(small_dictionary, poses)
    assert out.n_atoms == 0 and out.dictionary is small_dictionary


def test_recover_adds_a_small_files_complete_poses(cmu_poses, small_dictionary):
    """Too few complete poses to adapt on: they become atoms, and a hidden joint
    of a pose seen complete in the file comes back (nearly) exactly."""
    n_complete = 40
    assert n_complete < MIN_COMPLETE_POSES
    truth = np.concatenate([cmu_poses[:n_complete], cmu_poses[:10]])
    missing = np.zeros((len(truth), 14), bool)
    missing[n_complete:, 9] = True  # right knee of ten poses the file also has complete
    poses = np.where(missing[..., None], np.nan, truth)
    res = recover(poses, dictionary=small_dictionary)
    cold = recover(poses, dictionary=small_dictionary, adapt=False)
    assert not res.adapted and res.adaptation.file_atoms == n_complete
    assert res.adaptation.summary()["file_atoms"] == n_complete
    assert res.dictionary.n_components == small_dictionary.n_components + n_complete
    assert cold.dictionary.n_components == small_dictionary.n_components
    err = np.linalg.norm(res.poses - truth, axis=-1)[missing]
    err_cold = np.linalg.norm(cold.poses - truth, axis=-1)[missing]
    size = np.ptp(truth[n_complete:], axis=1).max(axis=1)
    assert (err / size).max() < 0.01
    assert err.mean() < err_cold.mean()
    np.testing.assert_array_equal(res.poses[~missing], truth[~missing])


def test_recover_without_adaptation_adds_nothing(cmu_poses, small_dictionary):
    poses = cmu_poses[:30].copy()
    poses[20:, 4] = np.nan
    res = recover(poses, dictionary=small_dictionary, adapt=False)
    assert res.adaptation is None
    assert res.dictionary.n_components == small_dictionary.n_components


@pytest.mark.parametrize("filter", [True, False])
def test_filter_option(cmu_poses, small_dictionary, filter):
    out = with_file_atoms(small_dictionary, cmu_poses[:50], filter=filter)
    assert 0 < out.n_atoms <= 50
    if not filter:
        assert out.n_atoms == 50


def test_shipped_coco_prior_extends_the_default():
    """cmu-coco-k2466 is the default's atoms followed by 466 COCO exemplar atoms."""
    from sparseedm.dictionary import load_dictionary

    base, coco = load_dictionary(), load_dictionary("cmu-coco-k2466")
    assert coco.n_components == base.n_components + 466
    np.testing.assert_array_equal(coco.components[:base.n_components], base.components)
    assert coco.alpha_recover == base.alpha_recover
    assert "CC BY 4.0" in coco.provenance["coco_atoms"]["source"]
    assert coco.provenance["coco_atoms"]["mirrored"] is True


def test_shipped_two_neck_coco_prior(capsys):
    """cmu-coco-k2932: the default's atoms, then COCO's 233 complete training poses
    with COCO's neck, the same with the neck raised, and both mirrored."""
    from sparseedm.cli import main
    from sparseedm.dictionary import load_dictionary
    from sparseedm.edm import triu_indices

    base, one = load_dictionary(), load_dictionary("cmu-coco-k2466")
    two = load_dictionary("cmu-coco-k2932")
    assert two.components.shape == (base.n_components + 932, base.n_features)
    assert two.recovery_scale == "radius" and two.alpha_recover == base.alpha_recover
    np.testing.assert_array_equal(two.components[:base.n_components], base.components)
    k = base.n_components
    # COCO's own neck: the same atoms as cmu-coco-k2466's, plain and mirrored
    np.testing.assert_allclose(two.components[k:k + 233], one.components[k:k + 233])
    np.testing.assert_allclose(two.components[k + 466:k + 699], one.components[k + 233:])
    # the raised necks change the neck's distances only: the other entries of an
    # atom stay parallel to its COCO-neck twin (unit norm rescales them)
    i, j = triu_indices(14)
    other = (i != 1) & (j != 1)  # joint 1 is the neck
    plain, raised = two.components[k:k + 233], two.components[k + 233:k + 466]
    cos = (plain[:, other] * raised[:, other]).sum(1) / (
        np.linalg.norm(plain[:, other], axis=1) * np.linalg.norm(raised[:, other], axis=1))
    np.testing.assert_allclose(cos, 1.0, atol=1e-9)
    assert np.abs(plain[:, ~other] / np.linalg.norm(plain[:, other], axis=1)[:, None]
                  - raised[:, ~other] / np.linalg.norm(raised[:, other], axis=1)[:, None]
                  ).max() > 1e-3
    prov = two.provenance["coco_atoms"]
    assert "CC BY 4.0" in prov["source"] and prov["mirrored"] is True
    assert prov["necks"] == [0.0, 0.2] and prov["poses"] == 932
    assert main(["info", "cmu-coco-k2932"]) == 0
    out = capsys.readouterr().out
    assert "2932 atoms" in out and "necks" in out and "CC BY 4.0" in out


def test_bad_arguments_are_refused(cmu_poses, small_dictionary):
    from sparseedm.exceptions import ParameterError, PoseError

    with pytest.raises(ParameterError, match="max_atoms"):
        with_file_atoms(small_dictionary, cmu_poses[:5], max_atoms=0)
    with pytest.raises(PoseError):
        with_file_atoms(small_dictionary, cmu_poses[:5, :10])


@pytest.mark.parametrize("kw, name", [(dict(spacing=-1.0), "spacing"),
                                      (dict(spacing=float("nan")), "spacing"),
                                      (dict(max_atoms=-1), "max_atoms"),
                                      (dict(random_state=-1), "random_state")])
def test_file_dictionary_and_spaced_rows_refuse_bad_arguments(cmu_poses, small_dictionary,
                                                               kw, name):
    """A negative spacing merged rows 0.5 apart in spaced_rows (scipy's ball query
    reads a negative radius its own way); the others failed inside numpy."""
    from sparseedm.exceptions import ParameterError
    from sparseedm.file_atoms import file_dictionary, spaced_rows

    with pytest.raises(ParameterError, match=f"file_dictionary: {name}"):
        file_dictionary(small_dictionary, cmu_poses[:5], **kw)
    if name in ("spacing", "random_state"):
        with pytest.raises(ParameterError, match=f"spaced_rows: {name}"):
            spaced_rows(np.eye(4), **dict(dict(spacing=0.1), **kw))


def test_near_copies_make_one_atom_each(cmu_poses, small_dictionary):
    """A file of a few poses each resampled with a little noise (a still person's
    frames) gives the exemplar dictionary one atom per pose, not one per copy."""
    from sparseedm.file_atoms import file_dictionary

    rng = np.random.default_rng(0)
    distinct = cmu_poses[::40][:6]                # six poses ~100-260 px across
    copies = np.repeat(distinct, 25, axis=0)
    copies = copies + rng.normal(scale=0.2, size=copies.shape)   # a fifth of a pixel
    out = file_dictionary(small_dictionary, copies)
    assert out.n_complete == 150
    assert out.n_atoms == 6
    U = pose_vectors(distinct)
    U /= np.linalg.norm(U, axis=1, keepdims=True)
    # every pose is one atom, the mean of its copies: nearer to it than a copy is
    near = np.linalg.norm(U[:, None] - out.dictionary.components[None], axis=-1).min(axis=1)
    V = pose_vectors(copies)
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    copy = np.linalg.norm(V - np.repeat(U, 25, axis=0), axis=1).reshape(6, 25)
    assert (near < np.median(copy, axis=1)).all()
    every = file_dictionary(small_dictionary, copies, spacing=0.0)
    assert every.n_atoms == 150


def test_spaced_rows_keeps_distant_rows_and_covers_the_rest():
    from sparseedm.file_atoms import spaced_rows

    X = np.random.default_rng(1).normal(size=(300, 5))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    taken, group = spaced_rows(X, 0.5, random_state=2)
    D = np.linalg.norm(X[:, None] - X[None], axis=-1)
    sub = D[np.ix_(taken, taken)] + np.eye(len(taken))
    assert sub.min() > 0.5                               # none closer than the spacing
    assert D[np.arange(300), taken[group]].max() <= 0.5  # every row joins a taken one near
    np.testing.assert_array_equal(group[taken], np.arange(len(taken)))
    assert 1 < len(taken) < 300
    np.testing.assert_array_equal(spaced_rows(X, 1e-6)[0], np.arange(300))
