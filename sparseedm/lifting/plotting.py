"""3D skeleton figures: truth against lifted (matplotlib, the optional ``plot`` extra)."""

from __future__ import annotations

import numpy as np

from ..plotting import _figure, _save
from ..skeleton import SKELETON_14

__all__ = ["plot_poses3d"]


def plot_poses3d(truth, lifted, path, titles=None, missing=None):
    """One 3D panel per pose: truth dashed grey, lifted blue, occluded joints red x.

    Poses are (k, N, 3) in camera axes (x right, y down, z away); drawn with
    the image's up at the top and depth into the page.
    """
    truth = np.asarray(truth, float)
    lifted = np.asarray(lifted, float)
    k = len(truth)
    fig = _figure(3.6 * k, 4.4)
    for i in range(k):
        ax = fig.add_subplot(1, k, i + 1, projection="3d")
        for pose, color, style in ((truth[i], "0.6", "--"), (lifted[i], "tab:blue", "-")):
            if not np.isfinite(pose).all():
                continue
            X, Y, Z = pose[:, 0], pose[:, 2], -pose[:, 1]  # x right, depth, up
            for a, b in SKELETON_14.bones():
                ax.plot(X[[a, b]], Y[[a, b]], Z[[a, b]], style, color=color, lw=1.5)
            if color == "tab:blue" and missing is not None and np.asarray(missing[i]).any():
                m = np.asarray(missing[i], bool)
                ax.scatter(X[m], Y[m], Z[m], marker="x", color="red", s=40)
        lim = np.nanmax(np.abs(truth[i])) * 1.1
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_zlim(-lim, lim)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_zticks([])
        ax.view_init(elev=15, azim=-70)
        if titles is not None:
            ax.set_title(titles[i], fontsize=8)
    fig.suptitle("grey dashed: truth; blue: lifted (at the size prior); red x: occluded joints",
                 fontsize=9)
    return _save(fig, path)
