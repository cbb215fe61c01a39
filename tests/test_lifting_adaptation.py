"""Adapting a coupled dictionary lifter on 3D-free 2D poses (tests/fixtures only)."""

import numpy as np
import pytest

from sparseedm.exceptions import PoseError
from sparseedm.lifting import LifterError, lift, load_lifter, training_pairs
from sparseedm.lifting.adaptation import adapt_lifter
from sparseedm.lifting.metrics import err_ave_3d
from tests.test_lifting import _arrays, data, dict_lifter, mlp_lifter, split  # noqa: F401


@pytest.mark.parametrize("method", ["2d-half", "reweight"])
def test_adapted_lifter_keeps_3d_half_lifts_and_round_trips(tmp_path, data, split, dict_lifter,
                                                           method):
    tr, val = split
    base = dict_lifter
    new = adapt_lifter(base, data["poses2d"][val][::2], method=method, passes=1, memory=1.0)
    assert new is not base and base.components_ is not new.components_
    C0, C1 = base.components_, new.components_
    m = C0.shape[1] // 2
    if method == "2d-half":
        assert np.array_equal(C1[:, m:], C0[:, m:])          # the 3D half is untouched
        assert not np.allclose(C1[:, :m], C0[:, :m])          # the 2D half learned
        assert np.allclose(np.linalg.norm(C1[:, :m], axis=1),  # 2D : 3D balance kept
                           np.linalg.norm(C0[:, :m], axis=1))
    else:
        g = np.linalg.norm(C1, axis=1) / np.linalg.norm(C0, axis=1)
        assert np.allclose(C1, C0 * g[:, None]) and g.std() > 0  # whole atoms scaled
    assert new.provenance_["adaptation"]["method"] == method
    # it still lifts plausibly: the other half of the held-out clips, not the adaptation poses
    _, _, metric, _ = training_pairs(*_arrays(data, val[1::2]))
    e0 = err_ave_3d(lift(data["poses2d"][val[1::2]], lifter=base).vectors3d, metric).mean()
    e1 = err_ave_3d(lift(data["poses2d"][val[1::2]], lifter=new).vectors3d, metric).mean()
    assert np.isfinite(e1) and e1 < 2 * e0
    path = new.save(tmp_path / "adapted.npz")
    back = load_lifter(path)
    assert np.array_equal(back.components_, new.components_)
    assert back.provenance_["adaptation"]["poses"] == new.provenance_["adaptation"]["poses"]


def test_adapt_lifter_refuses_bad_input(data, dict_lifter, mlp_lifter):
    with pytest.raises(LifterError, match="dictionary"):
        adapt_lifter(mlp_lifter, data["poses2d"][:50])
    with pytest.raises(PoseError, match="14, 2"):
        adapt_lifter(dict_lifter, data["poses2d"][:50, :10])
    with pytest.raises(PoseError, match="no usable"):
        adapt_lifter(dict_lifter, np.full((5, 14, 2), np.nan))
    with pytest.raises(LifterError, match="method"):
        adapt_lifter(dict_lifter, data["poses2d"][:50], method="3d")


def test_lift_adapt_argument_uses_the_adapted_lifter(data, split, dict_lifter):
    val = split[1]
    adapt_on, test = data["poses2d"][val][::2], data["poses2d"][val][1::2][:20]
    via_lift = lift(test, lifter=dict_lifter, adapt=adapt_on)
    direct = lift(test, lifter=adapt_lifter(dict_lifter, adapt_on))
    plain = lift(test, lifter=dict_lifter)
    assert np.allclose(via_lift.vectors3d, direct.vectors3d)
    assert not np.allclose(via_lift.vectors3d, plain.vectors3d)   # it changed something
