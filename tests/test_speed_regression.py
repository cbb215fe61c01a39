"""The speed work changes no answer: ``recover`` against answers frozen before it.

``tests/fixtures/speed_reference.npz`` (made by ``make_speed_reference.py``
with the code as it was before the speed work) holds a real batch -- 510 CMU poses,
one 100-pose and one 30-pose pattern group, small Mix groups, bad rows of
every refusal kind -- and what ``recover`` returned. Statuses, reasons and
fallback flags must match exactly; objectives, certificates and filled poses
to round-off (Clarabel's to its certificate tolerance). The dictionary is used
as given (``adapt=False``): what is compared is the solver's answers, not what
adaptation or the file's own atoms add to the dictionary.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sparseedm import recover
from sparseedm.dictionary import load_dictionary

FIXTURES = Path(__file__).resolve().parent / "fixtures"
REF = FIXTURES / "speed_reference.npz"
DICTIONARY = FIXTURES.parents[1] / "dictionaries" / "cmu-k2000.npz"


@pytest.fixture(scope="module")
def reference():
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_speed_reference",
                                                  FIXTURES / "make_speed_reference.py")
    maker = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(maker)
    with np.load(REF, allow_pickle=False) as z:
        ref = dict(z)
    # the answers were frozen under the bounding-box normalisation, before the
    # shipped files recorded recovery_scale="radius": the solver is what is compared
    dictionary = replace(load_dictionary(DICTIONARY), recovery_scale="box")
    assert maker.components_sha1(dictionary.components) == str(ref["dictionary_sha1"]), (
        "dictionaries/cmu-k2000.npz changed: regenerate the speed reference"
    )
    poses, missing, kind = maker.build_batch()  # the batch is rebuilt, and must match
    np.testing.assert_array_equal(poses, ref["poses"])
    np.testing.assert_array_equal(missing, ref["missing"])
    return ref, dictionary


def _compare(res, ref, prefix, obj_rtol, pose_atol):
    for name in ("status", "reason", "fallback"):
        np.testing.assert_array_equal(np.asarray(getattr(res, name)), ref[f"{prefix}_{name}"],
                                      err_msg=f"{prefix} {name} changed")
    obj, ref_obj = res.objective, ref[f"{prefix}_objective"]
    np.testing.assert_array_equal(np.isnan(obj), np.isnan(ref_obj))
    np.testing.assert_allclose(obj, ref_obj, rtol=obj_rtol, atol=0, equal_nan=True)
    # the certificate: every recovered pose's gap within tolerance, as before
    ok = ref[f"{prefix}_status"] == "recovered"
    assert (res.gap[ok] <= 1e-6 * res.objective[ok]).all()
    np.testing.assert_array_equal(np.isnan(res.gap), np.isnan(ref[f"{prefix}_gap"]))
    np.testing.assert_array_equal(np.isnan(res.poses), np.isnan(ref[f"{prefix}_poses"]))
    np.testing.assert_allclose(res.poses, ref[f"{prefix}_poses"], rtol=0, atol=pose_atol,
                               equal_nan=True)
    np.testing.assert_allclose(res.vectors, ref[f"{prefix}_vectors"], rtol=0,
                               atol=pose_atol / 100, equal_nan=True)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_fast_path_answers_unchanged(reference, n_jobs):
    ref, dictionary = reference
    res = recover(ref["poses"], ref["missing"], dictionary=dictionary, solver="fast", adapt=False,
                  n_jobs=n_jobs)
    _compare(res, ref, "fast", obj_rtol=1e-9, pose_atol=1e-6)
    np.testing.assert_array_equal(res.n_active, ref["fast_n_active"])


def test_fast_path_answers_unchanged_in_small_chunks(reference):
    """Chunking (and hence group cuts) must not change any answer either."""
    ref, dictionary = reference
    res = recover(ref["poses"], ref["missing"], dictionary=dictionary, solver="fast", adapt=False,
                  chunk_size=7)
    _compare(res, ref, "fast", obj_rtol=1e-9, pose_atol=1e-6)


def test_clarabel_path_answers_unchanged(reference):
    ref, dictionary = reference
    rows = ref["clarabel_rows"]
    res = recover(ref["poses"][rows], ref["missing"][rows], dictionary=dictionary, adapt=False,
                  solver="clarabel")
    # Clarabel's answers are certified to 1e-6 of the optimum: objectives agree to
    # that, codes (hence placed joints) to the lasso's conditioning
    _compare(res, ref, "clarabel", obj_rtol=2e-6, pose_atol=0.05)
