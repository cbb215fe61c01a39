"""FConv: the paper's fully convolutional EDM network (optional, needs PyTorch).

Install the extra on a CPU machine with ``pip install torch==2.13.0`` first,
then ``pip install 'sparseedm[torch]'``. Importing this package does not
import torch; training and prediction do.

- :mod:`sparseedm.fconv.network`   the architecture (two conv, two deconv) and its reading
- :mod:`sparseedm.fconv.model`     the model file (.npz of named arrays + JSON), FConvModel
- :mod:`sparseedm.fconv.training`  fit_fconv (recovery), fit_lifter (2D -> 3D), FConvRecoverer
- :mod:`sparseedm.fconv.recover`   recover(..., method="fconv") lands here
- :mod:`sparseedm.fconv.lifting`   lift(): 2D -> 3D EDMs, FConvLifter, the Table 1 experiment
"""

from .lifting import FConvLifter, lift
from .model import FConvModel, load_model
from .training import FConvRecoverer, fit_fconv, fit_lifter

__all__ = ["FConvModel", "load_model", "fit_fconv", "fit_lifter", "FConvRecoverer",
           "FConvLifter", "lift"]
