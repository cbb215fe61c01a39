"""3D skeleton figures: truth against lifted (matplotlib, the optional ``plot`` extra)."""

from __future__ import annotations

import numpy as np

from ..plotting import SIDE_COLORS, bone_side, new_figure, save_figure, side_legend
from ..skeleton import SKELETON_14

__all__ = ["plot_poses3d", "plot_lifted", "VIEWS"]


def plot_poses3d(truth, lifted, path, titles=None, missing=None):
    """One 3D panel per pose: truth dashed grey, lifted blue, occluded joints red x.

    Poses are (k, N, 3) in camera axes (x right, y down, z away); drawn with
    the image's up at the top and depth into the page.

    Parameters
    ----------
    truth : array_like (k, N, 3)
        The true poses; they also set each panel's extent.
    lifted : array_like (k, N, 3)
        The lifted poses; a pose with a non-finite coordinate is not drawn.
    path : str or path-like
        The figure file, PNG, PDF or SVG by its extension (written atomically).
    titles : list of str, optional
        One title per panel.
    missing : array_like of bool (k, N), optional
        The occluded joints, marked with a red x on the lifted pose.

    Returns
    -------
    Path
        The file written.
    """
    truth = np.asarray(truth, float)
    lifted = np.asarray(lifted, float)
    k = len(truth)
    fig = new_figure(3.6 * k, 4.4)
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
    return save_figure(fig, path)


#: the two viewpoints of plot_lifted: (title, horizontal axis, its label); up is vertical
VIEWS = (("front, as the camera sees it", 0, "x, right (m)"),
         ("side, camera on the left", 2, "depth, away from the camera (m)"))


def plot_lifted(poses3d, path, titles=None, missing=None):
    """Lifted poses, each from the front and from the side, left/right coloured.

    Two orthographic views per pose (one column per pose): the camera's
    (x right, up) and a side view (depth away from the camera, up), on
    equal axes in metres.

    Parameters
    ----------
    poses3d : array_like (k, N, 3)
        Metres in camera axes (x right, y down, z away), as :func:`sparseedm.lift`
        returns them; drawn with up at the top.
    path : str or path-like
        The PNG to write (atomically).
    titles : sequence of str, optional
        One per pose (e.g. its id).
    missing : array_like of bool (k, N), optional
        Joints occluded in the 2D input, marked x.

    Returns
    -------
    Path
    """
    from matplotlib.lines import Line2D

    P = np.asarray(poses3d, float)
    k = max(len(P), 1)
    fig = new_figure(2.4 * k + 0.6, 6.2)
    lim = np.nanmax(np.abs(P)) * 1.1 if np.isfinite(P).any() else 1.0
    for i in range(len(P)):
        up = -P[i, :, 1]
        m = np.zeros(len(up), bool) if missing is None else np.asarray(missing[i], bool)
        for v, (view, axis, label) in enumerate(VIEWS):
            ax = fig.add_subplot(2, k, v * k + i + 1)
            h = P[i, :, axis]
            for a, b in SKELETON_14.bones():
                ax.plot(h[[a, b]], up[[a, b]], color=SIDE_COLORS[bone_side((a, b))], lw=2)
            ax.plot(h, up, "o", color="k", ms=2.5)
            ax.plot(h[m], up[m], "x", color="darkorange", ms=8, mew=2)
            ax.set_xlim(-lim, lim)
            ax.set_ylim(-lim, lim)
            ax.set_aspect("equal")
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=7)
            ax.set_xlabel(label, fontsize=8)
            if i == 0:
                ax.set_ylabel("up (m)", fontsize=8)
            name = titles[i] if titles is not None else f"pose {i}"
            ax.set_title(f"{name}\n{view}", fontsize=8)
    fig.subplots_adjust(bottom=0.14, hspace=0.45, wspace=0.3)
    side_legend(fig, [(Line2D([], [], color="darkorange", marker="x", ls="", mew=2),
                       "joint occluded in the 2D input")])
    return save_figure(fig, path)
