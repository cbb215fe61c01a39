"""sparseedm: recover occluded human-pose joints from Euclidean distance matrices.

See README.md for the tour; the modules, one per idea:

- :mod:`sparseedm.skeleton`   the 14-joint layout
- :mod:`sparseedm.edm`        poses <-> EDMs <-> 91-dim upper-triangle vectors
- :mod:`sparseedm.normalize`  [-1, 1] normalisation, 'zero'/'average' representations
- :mod:`sparseedm.metrics`    the paper's occlusion protocol and Err_ave
"""

__version__ = "0.1.0"
