"""sparseedm: recover occluded human-pose joints from Euclidean distance matrices.

See README.md for the tour; the modules, one per idea:

- :mod:`sparseedm.skeleton`   the 14-joint layout
- :mod:`sparseedm.edm`        poses <-> EDMs <-> 91-dim upper-triangle vectors
- :mod:`sparseedm.normalize`  [-1, 1] normalisation, 'zero'/'average' representations
- :mod:`sparseedm.metrics`    the paper's occlusion protocol and Err_ave
- :mod:`sparseedm.learning`   online dictionary learning
- :mod:`sparseedm.dictionary` the dictionary file format and the shipped default
- :mod:`sparseedm.recovery`   recover(): lasso on the observed sub-dictionary, Eq. 10
- :mod:`sparseedm.adaptation` adapt(): warm-start the dictionary on the user's complete poses
- :mod:`sparseedm.lifting`    lift(): 2D poses -> 3D (coupled dictionary or MLP, then MDS)
- :mod:`sparseedm.keypoints`  read_keypoints() / write_keypoints(): the files users exchange
- :mod:`sparseedm.temporal`   video: each track's frames filled together
- :mod:`sparseedm.uncertainty` the 90 % radius of each filled joint, radius_at()
- :mod:`sparseedm.plotting`   plot_recovery(): what a recovery did (the plot extra)
"""

from ._version import __version__
from ._validation import environment_problem

if environment_problem() is None:  # the usual case
    from .dictionary import Dictionary, load_dictionary  # noqa: E402
    from .recovery import OcclusionRecoverer, RecoveryResult, recover  # noqa: E402
    from .adaptation import adapt  # noqa: E402
    from .lifting import LiftResult, adapt_lifter, lift, load_lifter  # noqa: E402
else:  # e.g. NUMBA_NUM_THREADS=0: numba cannot load; the first use (and the CLI) says why
    def __getattr__(name):
        if name not in __all__:  # a submodule: imported as usual
            raise AttributeError(f"module 'sparseedm' has no attribute {name!r}")
        from .exceptions import EnvironmentSettingError

        raise EnvironmentSettingError(environment_problem())

__all__ = ["recover", "adapt", "lift", "adapt_lifter", "RecoveryResult", "LiftResult", "OcclusionRecoverer",
           "load_dictionary", "load_lifter", "Dictionary", "__version__"]
