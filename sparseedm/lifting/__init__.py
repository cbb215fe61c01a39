"""Lifting completed or occluded 2D poses to 3D (DMR's pipeline on the toolkit's EDMs).

- :mod:`.base`        the lifter interface, 3D normalisation, file format, registry
- :mod:`.dictionary`  the coupled [2D ; 3D] dictionary lifter (default; one lasso
                      on the observed 2D entries recovers and lifts)
- :mod:`.mlp`         DMR's FConn regressor (scikit-learn MLP, stored as weights)
- :mod:`.fconv`       DMR's fully convolutional regressor (torch extra, stored as weights)
- :mod:`.mds`         3D coordinates from a 3D EDM: MDS, SMACOF, camera alignment,
                      reflection choice
- :mod:`.metrics`     Err_ave on 3D EDMs, MPJPE, N-MPJPE, PA-MPJPE
- :mod:`.video`       a video's frames lifted together: 2D filled across time first,
                      depth reflections chosen per track, 3D trajectories smoothed
- :mod:`.lift`        :func:`lift`, the user entry point
- :mod:`.evaluation`  the paper's application table (lifting after recovery)
- :mod:`.adaptation`  :func:`adapt_lifter`: adapt a dictionary lifter on 3D-free
                      complete 2D poses (measured: docs/explanation/settings.md)
- :mod:`.io`          :func:`lift_file`: a keypoint file lifted to a 3D file (TRC, npz, CSV)
- :mod:`.trc`         OpenSim TRC files: :func:`write_trc`, :func:`read_trc`

The lifter classes (:class:`DictionaryLifter`, :class:`MLPLifter`,
:class:`FConvNetLifter`), :func:`lift_file` and :func:`evaluate_lifting` are
imported on first use (the MLP needs scikit-learn's network, the FConv lifter
torch to fit, the file and evaluation workflows the recovery's file layer).
"""

from .base import (LIFTERS, Lifter, LifterError, available_lifters, is_lifter_file,
                   lifter_class, load_lifter, training_pairs)
from .adaptation import adapt_lifter
from .lift import STATUSES, LiftResult, lift
from .mds import reconstruct
from .metrics import err_ave_3d, mpjpe, pa_mpjpe
from .plotting import plot_lifted, plot_poses3d
from .trc import read_trc, write_trc

#: names imported on first use, by module (see above)
_LATER = {
    "dictionary": ("DictionaryLifter",),
    "mlp": ("MLPLifter",),
    "fconv": ("FConvNetLifter",),
    "io": ("lift_file", "write_poses3d", "OUTPUT_FORMATS"),
    "evaluation": ("evaluate_lifting", "LiftReport"),
}
_MODULE_OF = {name: module for module, names in _LATER.items() for name in names}

__all__ = ["lift", "LiftResult", "STATUSES", "Lifter", "LifterError", "LIFTERS",
           "load_lifter", "available_lifters", "training_pairs", "is_lifter_file",
           "fit_lifter", "adapt_lifter", "reconstruct", "err_ave_3d", "mpjpe", "pa_mpjpe",
           "plot_lifted", "plot_poses3d", "read_trc", "write_trc", *_MODULE_OF]


def __getattr__(name):
    """The names of :data:`_LATER`, imported on first use."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from . import dictionary, evaluation, fconv, io, mlp

    found = {"dictionary": dictionary, "mlp": mlp, "fconv": fconv, "io": io,
             "evaluation": evaluation}[module]
    return getattr(found, name)


def __dir__():
    return sorted(set(globals()) | set(_MODULE_OF))


def fit_lifter(poses2d, poses3d, camera_R, camera_t, camera_f, *, method="dictionary",
               provenance=None, clips=None, **params):
    """Fit a lifter of `method` (a name in :data:`LIFTERS`) on complete training poses.

    `clips` (optional, one name per pose) lets ``fconv`` hold out whole clips
    for early stopping; the other methods ignore it.

    Parameters
    ----------
    poses2d : array_like, shape (n, N, 2)
        Complete 2D training poses (pixels).
    poses3d : array_like, shape (n, N, 3)
        The same poses in 3D (metres).
    camera_R, camera_t, camera_f : array_like
        Each pose's pinhole camera (``x_cam = R X + t``; focal length in pixels).
    method : str
        ``"dictionary"``, ``"mlp"`` or ``"fconv"``.
    provenance : dict, optional
        Stored in the file's meta.
    clips : sequence, optional
        Clip name of each pose.
    **params
        The method's settings.

    Returns
    -------
    Lifter
        The fitted lifter.
    """
    cls = lifter_class(method, "fit_lifter")
    return cls(**params).fit_poses(poses2d, poses3d, camera_R, camera_t, camera_f,
                                   provenance=provenance, clips=clips)
