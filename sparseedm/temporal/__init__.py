"""Video: occluded joints recovered across time, per track.

Poses that share a track are one person over time, ordered by frame. The
modules of this subpackage (one idea each) build the temporal recovery on top
of the per-frame sparse coding, the video evaluation protocols (contiguous
gaps, self-occlusion) and the gap fillers users already apply (splines, PCA
gap filling) to compare against.

Recovery over tracks and frames (what ``sparseedm.recover(poses, frames=...)``
runs): :func:`recover_temporal`, :class:`TemporalResult`, :func:`recover_track`
(one track, the gap-filler shape), :func:`adapt_in_time`, :func:`link_tracks`
(track ids for poses without them), :func:`split_tracks`,
:func:`smooth_trajectory`, :class:`TemporalSettings`.

The video evaluation: the gap fillers (:data:`FILLERS`, :func:`fill_linear`,
:func:`fill_cubic`, :func:`fill_akima`, :func:`fill_pca`,
:func:`sparse_filler`), the protocols (:func:`gap_mask`,
:func:`self_occlusion_mask`, :func:`dropout_mask`), the sequences
(:class:`Sequence`, :func:`load_sequences`) and :func:`evaluate_video`. These
sit a layer above :func:`sparseedm.recover` (the per-frame filler runs it),
so they are imported on first use: importing the recovery never loads them.

>>> from sparseedm.temporal import fill_linear, recover_temporal
>>> import numpy as np
>>> poses = np.array([[[0.0, 0.0]], [[np.nan, np.nan]], [[2.0, 4.0]]])
>>> fill_linear(poses, np.isnan(poses[..., 0]), np.arange(3))[1]
array([[1., 2.]])
"""

from __future__ import annotations

from .linking import link_tracks, split_at_jumps
from .model import TemporalSettings
from .recover import TemporalResult, adapt_in_time, recover_temporal, recover_track
from .smoothing import smooth_trajectory
from .tracks import split_tracks, track_chunks

#: the video evaluation's names, by module, imported on first use (see above)
_LATER = {
    "fillers": ("FILLERS", "fill_linear", "fill_cubic", "fill_akima", "fill_pca",
                "sparse_filler", "check_track"),
    "protocols": ("gap_mask", "self_occlusion_mask", "dropout_mask", "run_lengths",
                  "GAP_LENGTHS", "RUN_BINS"),
    "sequences": ("Sequence", "load_sequences", "sequences_from_dataset", "body_height"),
    "evaluation": ("evaluate_video", "VideoReport", "protocol_masks", "plot_fill",
                   "PROTOCOLS", "DEFAULT_METHODS"),
}
_MODULE_OF = {name: module for module, names in _LATER.items() for name in names}

__all__ = ["recover_temporal", "TemporalResult", "recover_track", "adapt_in_time",
           "link_tracks", "split_at_jumps", "TemporalSettings", "smooth_trajectory",
           "split_tracks", "track_chunks", *_MODULE_OF]


def __getattr__(name):
    """The video evaluation's names (:data:`_LATER`), imported on first use."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from . import evaluation, fillers, protocols, sequences

    found = {"fillers": fillers, "protocols": protocols, "sequences": sequences,
             "evaluation": evaluation}[module]
    return getattr(found, name)


def __dir__():
    return sorted(set(globals()) | set(_MODULE_OF))
