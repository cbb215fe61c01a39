"""FConv: the paper's fully convolutional EDM network (optional, needs PyTorch).

Install the extra on a CPU machine with ``pip install torch==2.13.0`` first,
then ``pip install 'sparseedm[torch]'``. Importing this package does not
import torch; training and prediction do.

- :mod:`sparseedm.fconv.network`   the architecture (two conv, two deconv) and its reading
- :mod:`sparseedm.fconv.model`     the model file (.npz of named arrays + JSON), FConvModel
- :mod:`sparseedm.fconv.training`  fit_fconv (recovery), fit_edm_lifter (2D -> 3D EDMs), FConvRecoverer
- :mod:`sparseedm.fconv.recover`   recover(..., method="fconv") lands here
- :mod:`sparseedm.fconv.lifting`   lift_edm_vectors(): 2D -> 3D EDM vectors, FConvEDMLifter

``fit_lifter``, ``lift`` and ``FConvLifter`` are the same functions under their
earlier names (not :func:`sparseedm.lifting.fit_lifter` /
:func:`sparseedm.lift`, which give a Lifter and a LiftResult).
"""

from .lifting import FConvEDMLifter, FConvLifter, lift, lift_edm_vectors
from .model import FConvModel, load_model
from .training import FConvRecoverer, fit_edm_lifter, fit_fconv, fit_lifter

__all__ = ["FConvModel", "load_model", "fit_fconv", "fit_edm_lifter", "FConvRecoverer",
           "FConvEDMLifter", "lift_edm_vectors", "fit_lifter", "FConvLifter", "lift"]
