"""Video: occluded joints recovered across time, per track.

Poses that share a track are one person over time, ordered by frame. The
modules of this subpackage (one idea each) build the temporal recovery on top
of the per-frame sparse coding, the video evaluation protocols (contiguous
gaps, self-occlusion) and the gap fillers users already apply (splines, PCA
gap filling) to compare against.
"""
