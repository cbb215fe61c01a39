"""FConv: the paper's fully convolutional EDM network (optional, needs PyTorch).

Install the extra on a CPU machine with ``pip install torch==2.13.0`` first,
then ``pip install 'sparseedm[torch]'``. Importing this package does not
import torch; training and prediction do.

- :mod:`sparseedm.fconv.network`   the architecture (two conv, two deconv) and its reading
- :mod:`sparseedm.fconv.model`     the model file (.npz of named arrays + JSON), FConvModel
- :mod:`sparseedm.fconv.training`  fit_fconv (recovery), fit_edm_lifter (2D -> 3D EDMs), FConvRecoverer
- :mod:`sparseedm.fconv.recover`   recover(..., method="fconv") lands here
- :mod:`sparseedm.fconv.lifting`   lift_edm_vectors(): 2D -> 3D EDM vectors, FConvEDMLifter

The older names ``fit_lifter``, ``lift`` and ``FConvLifter`` (of
:func:`fit_edm_lifter`, :func:`lift_edm_vectors`, :class:`FConvEDMLifter`)
still work and warn with the new name (:mod:`sparseedm._deprecated`); they
are not :func:`sparseedm.lifting.fit_lifter` / :func:`sparseedm.lift`, which
give a Lifter and a LiftResult.
"""

from .._deprecated import alias_getattr
from .lifting import FConvEDMLifter, lift_edm_vectors
from .model import FConvModel, load_model
from .network import require_torch
from .recover import recover_fconv
from .training import FConvRecoverer, fit_edm_lifter, fit_fconv, split_by_clip

__all__ = ["FConvModel", "load_model", "fit_fconv", "fit_edm_lifter", "FConvRecoverer",
           "FConvEDMLifter", "lift_edm_vectors", "recover_fconv", "split_by_clip",
           "require_torch"]

__getattr__ = alias_getattr(__name__, globals())  # the older names, deprecated
