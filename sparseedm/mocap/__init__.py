"""Motion-capture loaders: BVH and CMU ASF/AMC -> (frames, 14, 3) joints in metres.

The 14 joints follow :data:`sparseedm.skeleton.SKELETON_14`; every loader runs
forward kinematics over all frames at once and returns positions in metres
in the file's world frame (Y-up for BVH and ASF/AMC). See
:mod:`sparseedm.mocap.rigs` for the rig families, joint maps, units and
head-top rules, :mod:`sparseedm.mocap.bvh` and :mod:`sparseedm.mocap.asf_amc`
for the formats.

:func:`load_mocap` dispatches on the file extension.
"""

from __future__ import annotations

from numbers import Real
from pathlib import Path

from .._validation import Interval, validate_params
from ..exceptions import FileFormatError
from ._text import MAX_FILE_BYTES
from .asf_amc import ASFSkeleton, find_asf, load_asf_amc, parse_amc, parse_asf, write_cmu_bvh
from .bvh import BVHData, detect_rig, load_bvh, parse_bvh, rotation_matrices
from .rigs import (FAMILIES, UNITS, Rig, UnitsError, chirality, plausibility, read_joint_map,
                   tpose_frames)

__all__ = [
    "load_mocap",
    "load_bvh",
    "load_asf_amc",
    "parse_bvh",
    "parse_asf",
    "parse_amc",
    "find_asf",
    "detect_rig",
    "write_cmu_bvh",
    "rotation_matrices",
    "MOCAP_SUFFIXES",
    "MAX_FILE_BYTES",
    "FAMILIES",
    "UNITS",
    "UnitsError",
    "plausibility",
    "read_joint_map",
    "tpose_frames",
    "chirality",
    "Rig",
    "BVHData",
    "ASFSkeleton",
]

#: file suffixes :func:`load_mocap` reads
MOCAP_SUFFIXES = (".bvh", ".amc")


def load_mocap(path, *, scale=None, units="auto", joint_map=None, return_info=False):
    """14-joint 3D poses (n_frames, 14, 3) in metres from a .bvh or .amc file.

    For ``NN_MM.amc`` the skeleton ``NN.asf`` in the same folder is used.
    `units` and `joint_map` are those of :func:`load_bvh` /
    :func:`load_asf_amc`. With ``return_info`` a dict (``rig``, ``units``,
    ``scale``, ``height``, ``frame_rate``, ``sources``, ``tpose_frames``)
    comes too.

    Parameters
    ----------
    path : str or path-like
        A ``.bvh`` or ``.amc`` file.
    scale : float, optional
        Metres per file unit; overrides `units`.
    units : {"auto", "m", "cm", "mm", "inch", "cmu"}
        The file's unit (``"auto"``: from the standing height).
    joint_map : str, path-like or dict, optional
        A joint map (:func:`sparseedm.mocap.rigs.read_joint_map`).
    return_info : bool
        Also return what the loader chose.

    Returns
    -------
    poses : ndarray, shape (n_frames, 14, 3)
        Joint positions in metres, Y up.
    info : dict
        Only with `return_info`.

    Examples
    --------
    >>> load_mocap("walk.c3d")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: walk.c3d: unsupported motion-capture file type '.c3d' (expected .bvh or .amc)
    """
    validate_params("load_mocap", dict(path=path, scale=scale, return_info=return_info),
                    {"path": ["path"], "scale": [Interval(Real, 0, None, closed="neither"), None],
                     "return_info": ["boolean"]})
    suffix = Path(path).suffix.lower()
    if suffix == ".bvh":
        return load_bvh(path, scale=scale, units=units, joint_map=joint_map,
                        return_info=return_info)
    if suffix == ".amc":
        return load_asf_amc(None, path, scale=scale, units=units, joint_map=joint_map,
                            return_info=return_info)
    raise FileFormatError(
        f"{path}: unsupported motion-capture file type {suffix!r} (expected .bvh or .amc)"
    )
