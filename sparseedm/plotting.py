"""Figures for the evaluation report (matplotlib is optional: ``pip install sparseedm[plot]``).

matplotlib is imported lazily and only through its object API with the Agg
canvas (no pyplot, no global backend switch), so importing this module never
needs it and figures can be made in any process.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._atomic import atomic_path
from .skeleton import SKELETON_14

__all__ = ["have_matplotlib", "plot_poses", "plot_sweep", "plot_error_by_count",
           "report_figures", "INSTALL_HINT"]

INSTALL_HINT = "figures need matplotlib: pip install sparseedm[plot]"


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def new_figure(width, height):
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(INSTALL_HINT) from exc
    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig, path):
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", bbox_inches="tight")
    return path


#: bone colours by side (the person's left and right, as in SKELETON_14)
SIDE_COLORS = {"left": "tab:blue", "right": "tab:red", "centre": "0.25"}


def bone_side(bone, skeleton=SKELETON_14):
    """``"left"``, ``"right"`` or ``"centre"``: the side of the bone's child joint.

    >>> bone_side((1, 5)), bone_side((1, 2)), bone_side((1, 0))
    ('left', 'right', 'centre')
    """
    child = bone[1]
    if child in skeleton.joints_left:
        return "left"
    return "right" if child in skeleton.joints_right else "centre"


def side_legend(fig, extra=(), ncol=None):
    """A legend for the side colours (and `extra` (handle, label) pairs) below the panels,
    off the skeletons."""
    from matplotlib.lines import Line2D

    items = [(Line2D([], [], color=c, lw=2), f"{s} side") for s, c in SIDE_COLORS.items()
             if s != "centre"] + list(extra)
    fig.legend([h for h, _ in items], [t for _, t in items], loc="lower center",
               ncol=ncol or len(items), fontsize=8, frameon=False, bbox_to_anchor=(0.5, 0.0))


def _draw_bones(ax, pose, *, sided=True, color="0.7", style="-", lw=1.8):
    """The bones of `pose` (N, 2): coloured by side (:data:`SIDE_COLORS`), or all `color`."""
    for a, b in SKELETON_14.bones():
        c = SIDE_COLORS[bone_side((a, b))] if sided else color
        ax.plot(pose[[a, b], 0], pose[[a, b], 1], style, color=c, lw=lw)


def plot_poses(gt, missing, recovered, path, titles=None):
    """Recovered poses over their ground truth, one panel per pose, left/right coloured.

    The recovered skeleton's bones are coloured by side (the person's left and
    right), the ground truth is dotted grey underneath, the observed joints
    (the input) are black dots and the recovered occluded joints orange crosses.
    The legend sits below the panels, off the skeletons. Image axes: x right,
    y down.
    """
    from matplotlib.lines import Line2D

    gt = np.asarray(gt, float)
    recovered = np.asarray(recovered, float)
    missing = np.asarray(missing, bool)
    k = len(gt)
    fig = new_figure(3.0 * k, 4.6)
    for i in range(k):
        ax = fig.add_subplot(1, k, i + 1)
        _draw_bones(ax, gt[i], sided=False, color="0.65", style=":", lw=1.5)
        if np.isfinite(recovered[i]).all():
            _draw_bones(ax, recovered[i])
            m = missing[i]
            ax.plot(recovered[i][m, 0], recovered[i][m, 1], "x", color="darkorange", ms=9,
                    mew=2.2)
        obs = gt[i][~missing[i]]
        ax.plot(obs[:, 0], obs[:, 1], "o", color="k", ms=3)
        ax.set_aspect("equal")
        ax.margins(0.15)
        ax.invert_yaxis()  # image axes: y down
        ax.set_xticks([])
        ax.set_yticks([])
        if titles is not None:
            ax.set_title(titles[i], fontsize=9)
    fig.subplots_adjust(bottom=0.16)
    side_legend(fig, [
        (Line2D([], [], color="0.65", ls=":", lw=1.5), "ground truth"),
        (Line2D([], [], color="k", marker="o", ls="", ms=3), "observed joint (input)"),
        (Line2D([], [], color="darkorange", marker="x", ls="", ms=8, mew=2),
         "recovered occluded joint")])
    return save_figure(fig, path)


def plot_sweep(sweep, path):
    """Fig. 5: Mix Err_ave and recovery time per pose vs the number of atoms."""
    pts = [r for r in sweep if np.isfinite(r["err_ave_mix"])]
    fig = new_figure(5.5, 3.8)
    ax = fig.add_subplot(1, 1, 1)
    k = [r["atoms"] for r in pts]
    ax.plot(k, [r["err_ave_mix"] for r in pts], "o-", color="tab:blue")
    ax.set_xlabel("atoms k")
    ax.set_ylabel("Mix Err_ave (%)", color="tab:blue")
    ax2 = ax.twinx()
    ax2.plot(k, [r["ms_per_pose"] for r in pts], "s--", color="tab:orange")
    ax2.set_ylabel("recovery time (ms / pose)", color="tab:orange")
    ax.set_title("Error and time vs number of atoms")
    return save_figure(fig, path)


def plot_error_by_count(rows, path, representation="average"):
    """Bar chart: mean Err_ave per occlusion count, one bar per method."""
    rows = [r for r in rows if r["representation"] == representation]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    counts = list(dict.fromkeys(str(r["count"]) for r in rows))
    fig = new_figure(1.6 + 1.3 * len(counts), 3.8)
    ax = fig.add_subplot(1, 1, 1)
    width = 0.8 / max(len(methods), 1)
    x = np.arange(len(counts))
    for i, m in enumerate(methods):
        vals = [next((r["err_ave_mean"] for r in rows
                      if r["method"] == m and str(r["count"]) == c), np.nan) for c in counts]
        ax.bar(x + (i - (len(methods) - 1) / 2) * width, vals, width, label=m)
    ax.set_xticks(x)
    ax.set_xticklabels(counts)
    ax.set_xlabel("occluded joints")
    ax.set_ylabel("Err_ave (%)")
    ax.set_title(f"Err_ave by occlusion count ({representation})")
    ax.legend(fontsize=7)
    return save_figure(fig, path)


def report_figures(report, directory):
    """The report's PNGs in `directory`; returns their paths."""
    directory = Path(directory)
    out = []
    ex = report.examples
    if ex:
        titles = [f"{int(m.sum())} occluded, Err_ave {e:.1f}%"
                  for m, e in zip(ex["missing"], ex["err_ave"])]
        out.append(plot_poses(ex["gt"], ex["missing"], ex["recovered"],
                              directory / "poses.png", titles))
    rep = "average" if any(r["representation"] == "average" for r in report.rows) else (
        report.rows[0]["representation"] if report.rows else None)
    if rep is not None:
        out.append(plot_error_by_count(report.rows, directory / "error_by_count.png", rep))
    if report.sweep and any(np.isfinite(r["err_ave_mix"]) for r in report.sweep):
        out.append(plot_sweep(report.sweep, directory / "sweep_atoms.png"))
    return out
