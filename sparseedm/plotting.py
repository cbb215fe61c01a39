"""Figures for the evaluation report (matplotlib is optional: ``pip install sparseedm[plot]``).

matplotlib is imported lazily and only through its object API with the Agg
canvas (no pyplot, no global backend switch), so importing this module never
needs it and figures can be made in any process.
"""

from __future__ import annotations

from difflib import get_close_matches
from numbers import Integral
from pathlib import Path

import numpy as np

from . import _progress
from ._atomic import atomic_path
from ._validation import Interval, validate_params
from .exceptions import SparseEDMError
from .skeleton import JOINT_NAMES, SKELETON_14

__all__ = ["have_matplotlib", "plot_poses", "plot_sweep", "plot_error_by_count",
           "report_figures", "plot_recovery", "select_values", "figure_format",
           "INSTALL_HINT", "FIGURE_FORMATS"]

INSTALL_HINT = "figures need matplotlib: pip install sparseedm[plot]"
#: the figure files written, by extension (anything else is written as PNG)
FIGURE_FORMATS = ("png", "pdf", "svg")


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


def figure_format(path):
    """The file format a figure at `path` is written in: its extension's among
    :data:`FIGURE_FORMATS`, else PNG.

    >>> figure_format("a.SVG"), figure_format("a.pdf"), figure_format("fig")
    ('svg', 'pdf', 'png')
    """
    ext = Path(path).suffix.lower().lstrip(".")
    return ext if ext in FIGURE_FORMATS else "png"


def save_figure(fig, path):
    """Write `fig` to `path` atomically, as PNG, PDF or SVG by its extension."""
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=figure_format(path), bbox_inches="tight")
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


# --------------------------------------------------------------------------
# a recovery, seen: trajectories over time and a few poses


def select_values(spec, values, what="frame"):
    """Which of `values` (integers: frame numbers, or row numbers) `spec` chooses.

    Parameters
    ----------
    spec : str or sequence of int or None
        ``"10:40"`` (40 excluded, as a Python slice; an end may be left out:
        ``"10:"``, ``":40"``), single numbers, or several of these joined by
        commas (``"3,10:20,55"``); or a sequence of ints. None chooses all.
    values : array_like of int (n,)
    what : str
        What the values are, for the error message.

    Returns
    -------
    ndarray of bool (n,)

    Raises
    ------
    SparseEDMError
        A number that is not among `values`, a range that holds none of them,
        or a `spec` that is not numbers and ranges; the message names it.

    Examples
    --------
    >>> select_values("1,4:6", [0, 1, 2, 4, 5, 6]).tolist()
    [False, True, False, True, True, False]
    >>> select_values("3", [0, 1, 2])
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.SparseEDMError: frame 3 is not in the file (its frames: 0 to 2)
    """
    values = np.asarray(values, dtype=np.int64)
    if spec is None:
        return np.ones(len(values), bool)
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    chosen = np.zeros(len(values), bool)
    span = (f"{values.min()} to {values.max()}" if len(values) else "none")
    for item in items:
        lo, hi = _bounds(item, what)
        hit = (values >= lo) & (values < hi)
        if not hit.any():
            name = f"{what} {lo}" if hi == lo + 1 else f"{what}s {str(item).strip()}"
            raise SparseEDMError(f"{name} {'is' if hi == lo + 1 else 'are'} not in the file "
                                 f"(its {what}s: {span})")
        chosen |= hit
    return chosen


def _bounds(item, what):
    """``[lo, hi)`` of one item of a selection: ``"a:b"``, ``"a"`` or an int."""
    text = str(item).strip()
    try:
        if ":" not in text:
            return int(text), int(text) + 1
        lo, hi = text.split(":")
        return (int(lo) if lo.strip() else -2**62), (int(hi) if hi.strip() else 2**62)
    except ValueError:
        raise SparseEDMError(f"{what}s: {text!r} is not a number or a range LO:HI "
                             "(e.g. 10:40, HI excluded)") from None


def _joint_indices(joints, filled):
    """Joint indices from names (None: the joints filled somewhere in `filled`)."""
    names = list(JOINT_NAMES)
    if joints is None:
        picked = np.flatnonzero(filled.any(axis=0))
        return picked if len(picked) else np.arange(len(names))
    out = []
    for name in ([joints] if isinstance(joints, str) else joints):
        if name not in names:
            near = get_close_matches(str(name), names, n=1)
            raise SparseEDMError(f"unknown joint {name!r}" + (
                f" (did you mean {near[0]!r}?)" if near else "") + f"; the joints: "
                + ", ".join(names))
        out.append(names.index(name))
    return np.asarray(out, dtype=int)


def _pick_rows(rows, filled, k):
    """Up to `k` of `rows` for the pose panels, in their order: those with filled
    joints first (spread over them when more), then others spread over the rest.

    >>> _pick_rows(np.arange(6), np.array([[0], [1], [0], [1], [0], [1]], bool), 4).tolist()
    [0, 1, 3, 5]
    """
    if len(rows) <= k:
        return rows
    some = filled[rows].any(axis=1)
    pos = _spread(np.flatnonzero(some), k)
    rest = _spread(np.flatnonzero(~some), k - len(pos))
    return rows[np.sort(np.concatenate([pos, rest]))]


def _spread(positions, k):
    """`k` of `positions` evenly spread (all of them when fewer)."""
    if len(positions) <= k:
        return positions
    return positions[np.linspace(0, len(positions) - 1, k).round().astype(int)]


#: what the recovery figure draws, by role: (colour, marker, line style)
_OBSERVED, _RECOVERED, _FILLED = ("k", ".", ""), ("tab:blue", "", "-"), ("darkorange", "X", "")


def plot_recovery(observed, recovered, filled=None, *, frames=None, tracks=None, ids=None,
                  show_tracks=None, show_frames=None, show_joints=None, show_rows=None,
                  n_poses=4, path=None):
    """What a recovery did, to check by eye: trajectories over time and a few poses.

    With `frames`, for each shown track and joint, the joint's x and y against
    the frame number: the observed values (black dots), the recovered
    trajectory (blue line) and the filled frames (orange crosses on a shaded
    band); below them, a few poses of the first shown track as skeletons
    (bones coloured by side, observed joints black dots, filled joints orange
    crosses). Without `frames`, the poses only, of the shown rows.

    Parameters
    ----------
    observed : array_like (n, 14, 2)
        The input poses, NaN where a joint was missing (as read).
    recovered : array_like (n, 14, 2)
        The same rows after recovery (row i of the output is row i of the input).
    filled : array_like of bool (n, 14), optional
        The joints the recovery filled (a recovered file's flags); default the
        joints missing in `observed` and present in `recovered`.
    frames, tracks : array_like (n,), optional
        Frame number and person of each row (a video); `tracks` None: one person.
    ids : array_like (n,), optional
        Row ids, shown in the pose panels' titles.
    show_tracks : sequence, optional
        Tracks to draw (their values, compared as text); default the track with
        the most filled joints.
    show_frames, show_rows : str or sequence of int, optional
        Frames (with `frames`) or rows (without) to draw, as
        :func:`select_values` reads them (``"10:40"``, ``"3,7"``); default all
        frames, and for the poses the rows with the most filled joints.
    show_joints : sequence of str, optional
        Joint names for the trajectories; default the joints filled in the
        shown rows.
    n_poses : int, default 4
        Pose panels at most (spread over the shown rows, those with filled
        joints first).
    path : str or path-like, optional
        Also write the figure there, atomically: PNG, PDF or SVG by the extension.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    SparseEDMError
        Arrays that do not match, or an unknown track, frame, row or joint
        (the message names it).

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.plotting import plot_recovery
    >>> rng = np.random.default_rng(0)
    >>> walk = np.cumsum(rng.normal(0, 1, (30, 14, 2)), axis=0) + 100
    >>> seen = walk.copy()
    >>> seen[10:15, 4] = np.nan                   # right wrist hidden for 5 frames
    >>> fig = plot_recovery(seen, walk, frames=np.arange(30), n_poses=2)
    >>> [ax.get_title() for ax in fig.axes[:2]]
    ['right_wrist: x', 'right_wrist: y']
    >>> len(fig.axes)                             # x and y, then 2 poses
    4
    """
    validate_params("plot_recovery", dict(n_poses=n_poses),
                    {"n_poses": [Interval(Integral, 0, None)]})
    obs, rec, fill = _recovery_arrays(observed, recovered, filled)
    n = len(obs)
    ids = np.char.add("row ", np.arange(n).astype(str)) if ids is None else \
        np.asarray(ids).astype(str)
    if frames is None:
        if show_frames is not None or show_tracks is not None:
            raise SparseEDMError("the file has no frames (no frame column or array): "
                                 "choose rows, not frames or tracks")
        rows = np.flatnonzero(select_values(show_rows, np.arange(n), "row"))
        panels, joints = [], []
    else:
        if show_rows is not None:
            raise SparseEDMError("the file has frames: choose frames and tracks, not rows")
        panels = _track_rows(frames, tracks, fill, show_tracks, show_frames)
        rows = panels[0][1]
        joints = _joint_indices(show_joints, fill[np.concatenate([r for _, r in panels])])
    shown = _pick_rows(rows, fill, int(n_poses))
    _progress.say(f"drawing {2 * len(panels) * len(joints)} trajectory panels and "
                  f"{len(shown)} poses")
    height = 1.7 * len(panels) * len(joints) + (3.6 if len(shown) else 0) + 0.8
    fig = new_figure(max(8.4, 2.4 * len(shown)), height)
    half = max(len(shown), 1)
    grid = fig.add_gridspec(len(panels) * len(joints) + 1, 2 * half,
                            height_ratios=[1.0] * (len(panels) * len(joints)) + [2.1])
    for t, (track, trows) in enumerate(panels):
        fr = np.asarray(frames)[trows]
        for k, j in enumerate(joints):
            for c in range(2):
                ax = fig.add_subplot(grid[t * len(joints) + k, c * half:(c + 1) * half])
                _trajectory(ax, fr, obs[trows, j, c], rec[trows, j, c], fill[trows, j])
                who = "" if len(panels) == 1 and tracks is None else f" (track {track})"
                ax.set_title(f"{JOINT_NAMES[j]}: {'xy'[c]}{who}", fontsize=8)
    for i, r in enumerate(shown):
        ax = fig.add_subplot(grid[-1, 2 * i:2 * i + 2])
        when = "" if frames is None else f", frame {np.asarray(frames)[r]}"
        _pose_panel(ax, rec[r], ~np.isnan(obs[r]).any(axis=-1), fill[r], f"{ids[r]}{when}")
    fig.subplots_adjust(hspace=0.75 if panels else 0.2, wspace=0.35, bottom=0.7 / height,
                        top=1 - 0.3 / height)
    _recovery_legend(fig, with_time=bool(panels))
    if path is not None:
        save_figure(fig, path)
    return fig


def _recovery_arrays(observed, recovered, filled):
    """The observed and recovered poses (n, 14, 2) and the filled mask, checked."""
    obs = np.asarray(observed, dtype=float)
    rec = np.asarray(recovered, dtype=float)
    if obs.ndim != 3 or obs.shape[1:] != (len(JOINT_NAMES), 2) or rec.shape != obs.shape:
        raise SparseEDMError(f"observed and recovered poses must both be (n, 14, 2), got "
                             f"{obs.shape} and {rec.shape} (is the recovered file this "
                             "input's?)")
    present = np.isfinite(rec).all(axis=-1)
    if filled is None:
        fill = np.isnan(obs).any(axis=-1) & present
    else:
        fill = np.asarray(filled, dtype=bool)
        if fill.shape != obs.shape[:2]:
            raise SparseEDMError(f"filled must be {obs.shape[:2]}, got {fill.shape}")
        fill = fill & present
    return obs, rec, fill


def _track_rows(frames, tracks, filled, show_tracks, show_frames):
    """[(track, its shown rows in frame order)] of the shown tracks and frames."""
    frames = np.asarray(frames)
    labels = np.zeros(len(frames), int).astype(str) if tracks is None else \
        np.asarray(tracks).astype(str)
    known = list(dict.fromkeys(labels[np.argsort(frames, kind="stable")]))
    if show_tracks is None:
        counts = {t: int(filled[labels == t].sum()) for t in known}
        chosen = [max(known, key=lambda t: counts[t])] if known else []
    else:
        chosen = [str(t) for t in show_tracks]
        more = " ..." if len(known) > 20 else ""
        for t in chosen:
            if t not in known:
                raise SparseEDMError(f"track {t!r} is not in the file (its tracks: "
                                     f"{', '.join(known[:20])}{more})")
    if not chosen:
        raise SparseEDMError("the file has no poses to draw")
    out = []
    for t in chosen:
        rows = np.flatnonzero(labels == t)
        rows = rows[np.argsort(frames[rows], kind="stable")]
        keep = select_values(show_frames, frames[rows], "frame") if show_frames is not None \
            else np.ones(len(rows), bool)
        if not keep.any():
            raise SparseEDMError(f"track {t!r} has no pose in frames {show_frames}")
        out.append((t, rows[keep]))
    return out


def _trajectory(ax, fr, obs, rec, fill):
    """One coordinate over time: recovered line, observed dots, filled crosses on bands."""
    for a, b in _runs(fill):
        ax.axvspan(fr[a] - 0.5, fr[b] + 0.5, color=_FILLED[0], alpha=0.15, lw=0)
    ax.plot(fr, rec, _RECOVERED[2], color=_RECOVERED[0], lw=1.2)
    ax.plot(fr, obs, _OBSERVED[1], color=_OBSERVED[0], ms=3)
    ax.plot(fr[fill], rec[fill], _FILLED[1], color=_FILLED[0], ms=5, ls="")
    ax.tick_params(labelsize=7)
    ax.set_xlabel("frame", fontsize=7)
    ax.grid(alpha=0.3)


def _runs(mask):
    """(first, last) index of each run of True in `mask`.

    >>> _runs(np.array([0, 1, 1, 0, 1], bool))
    [(1, 2), (4, 4)]
    """
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    edges = np.flatnonzero(m[1:] != m[:-1])
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]


def _pose_panel(ax, pose, observed, filled, title):
    """One recovered pose: bones by side, observed joints dots, filled joints crosses."""
    _draw_bones(ax, pose)
    ax.plot(pose[observed, 0], pose[observed, 1], _OBSERVED[1], color=_OBSERVED[0], ms=6)
    ax.plot(pose[filled, 0], pose[filled, 1], _FILLED[1], color=_FILLED[0], ms=10, ls="",
            mec="k", mew=0.6)
    ax.set_aspect("equal")
    ax.margins(0.15)
    ax.invert_yaxis()  # image axes: y down
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=8)


def _recovery_legend(fig, with_time):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    extra = [(Line2D([], [], color=_OBSERVED[0], marker=_OBSERVED[1], ls=""), "observed"),
             (Line2D([], [], color=_FILLED[0], marker=_FILLED[1], ls="", mec="k", mew=0.6),
              "filled by the recovery")]
    if with_time:
        extra += [(Line2D([], [], color=_RECOVERED[0], lw=1.2), "recovered trajectory"),
                  (Patch(color=_FILLED[0], alpha=0.15), "filled frames")]
    side_legend(fig, extra, ncol=3)
