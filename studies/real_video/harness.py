"""Video gap filling on real hand-annotated people: a seeded validation harness.

Clips are one Bonn PoseTrack track's runs of consecutive frames annotated in all
14 joints (at least ``MIN_FRAMES``), from the ``val`` split of
:func:`benchmarks.real2d.split` (``train`` as a second look; never ``test``).
Two ways of hiding joints on a complete clip:

* ``gaps``: :func:`sparseedm.temporal.protocols.gap_mask` at 3, 10 and 30 frames;
* ``transplant``: another track's invisible or unannotated joint-frames (a
  window of as many frames as the clip) moved onto the clip, so some joints
  are never seen in it.

Every hidden joint-frame's error is in % of the body size (head top to the
ankles' midpoint, :func:`benchmarks.real2d.body_size`), per bin of its run's
length (``never``: the joint is hidden throughout the clip; no time-only
filler answers there). The *excess jump* at a run's edge is how much further
the filled frame next to an observed one lies from it than the truth does
(pixels, 0 when closer), averaged over the edges of runs inside the clip.

Peers: linear, cubic, Akima and PCA from :mod:`sparseedm.temporal.fillers`,
and ``kalman``: a STAND-IN constant-velocity Rauch-Tung-Striebel smoother with
its noise chosen by maximum likelihood (:func:`fill_kalman_standin`), until the
project's own Kalman filler is merged. ``sparseedm`` is
:func:`sparseedm.recover` on ONE clip per call with its defaults.

    python studies/real_video/harness.py --part val -o studies/real_video/val.json
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import real2d  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.temporal.fillers import FILLERS  # noqa: E402
from sparseedm.temporal.protocols import gap_mask  # noqa: E402

MIN_FRAMES = 30
GAP_LENGTHS = (3, 10, 30)
TRANSPLANT_BINS = ((1, 5, "1-5"), (6, 20, "6-20"), (21, 60, "21-60"), (61, None, "61+"))
PEERS = ("linear", "cubic", "akima", "pca", "kalman")


# ---------------------------------------------------------------- clips and masks
def clips(data, part="val", min_frames=MIN_FRAMES):
    """[(poses (T, 14, 2), frames (T,), key)]: complete consecutive runs of a track."""
    where = real2d.split(data) == part
    out = []
    for group, track in sorted(set(zip(data.group[where], data.tracks[where]))):
        rows = np.flatnonzero(where & (data.group == group) & (data.tracks == track))
        rows = rows[np.argsort(data.frames[rows])]
        ok = data.complete[rows]
        start = 0
        for k in range(1, len(rows) + 1):
            if k == len(rows) or not ok[k] or data.frames[rows[k]] != data.frames[rows[k - 1]] + 1:
                run = rows[start:k][ok[start:k]]
                if len(run) >= min_frames and ok[start:k].all():
                    out.append((data.poses[run], data.frames[run], f"{group}#{track}"))
                start = k + (k < len(rows) and not ok[k])
    return out


def hidden_windows(data, part="val"):
    """Every track's (T', 14) invisible-or-unannotated masks over runs of frames
    where the person is present: the donors of transplanted runs."""
    where = real2d.split(data) == part
    out = []
    for group, track in sorted(set(zip(data.group[where], data.tracks[where]))):
        rows = np.flatnonzero(where & (data.group == group) & (data.tracks == track))
        rows = rows[np.argsort(data.frames[rows])]
        out.append(~data.visible[rows])
    return out


def transplant_mask(T, donors, rng, max_missing=10):
    """A (T, 14) mask from a random donor's window of T frames (or of all its
    frames, repeated); frames with too few observed joints are thinned."""
    for _ in range(100):
        donor = donors[int(rng.integers(len(donors)))]
        if len(donor) >= T and donor.any():
            start = int(rng.integers(len(donor) - T + 1))
            mask = donor[start:start + T].copy()
            if mask.any() and (~mask).any(axis=0).sum() >= 4:
                break
    else:  # pragma: no cover - a split without a donor
        return np.zeros((T, 14), bool)
    heavy = mask.sum(axis=1) > max_missing
    mask[heavy] = False
    return mask


def run_lengths(mask):
    """Each hidden joint-frame's run length (T, N), 0 where observed."""
    lengths = np.zeros(mask.shape, int)
    for j in range(mask.shape[1]):
        edges = np.diff(np.concatenate([[0], mask[:, j].astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            lengths[a:b, j] = b - a
    return lengths


def transplant_bin(lengths, mask):
    never = mask.all(axis=0)[None, :] & mask
    out = np.full(mask.shape, "", dtype="<U8")
    for low, high, label in TRANSPLANT_BINS:
        out[(lengths >= low) & ((lengths <= high) if high else True)] = label
    out[never] = "never"
    return out


# ---------------------------------------------------------------- the stand-in Kalman peer
def _rts(z, q, r):
    """Constant-velocity RTS smoother of one coordinate series z (T,) with NaN
    gaps; returns (smoothed positions, log likelihood of the observations)."""
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = q * np.array([[1 / 3, 1 / 2], [1 / 2, 1.0]])
    T = len(z)
    first = np.flatnonzero(np.isfinite(z))[0]
    x, P = np.array([z[first], 0.0]), np.diag([r, 1e4 * max(r, q)])
    xs, Ps, xp, Pp = np.zeros((T, 2)), np.zeros((T, 2, 2)), np.zeros((T, 2)), np.zeros((T, 2, 2))
    ll = 0.0
    for t in range(T):
        if t:
            x, P = F @ x, F @ P @ F.T + Q
        xp[t], Pp[t] = x, P
        if np.isfinite(z[t]):
            s = P[0, 0] + r
            k = P[:, 0] / s
            innov = z[t] - x[0]
            ll -= 0.5 * (np.log(2 * np.pi * s) + innov ** 2 / s)
            x = x + k * innov
            P = P - np.outer(k, P[0])
        xs[t], Ps[t] = x, P
    for t in range(T - 2, -1, -1):
        G = Ps[t] @ F.T @ np.linalg.inv(Pp[t + 1])
        xs[t] = xs[t] + G @ (xs[t + 1] - xp[t + 1])
        Ps[t] = Ps[t] + G @ (Ps[t + 1] - Pp[t + 1]) @ G.T
    return xs[:, 0], ll


def fill_kalman_standin(poses, missing, frames):
    """STAND-IN peer (not the project's filler): per joint and coordinate, a
    constant-velocity RTS smoother whose process and observation noise are the
    maximum-likelihood pair on a log grid; observed joints returned as given,
    never-observed joints NaN."""
    poses = np.array(poses, float)
    out = poses.copy()
    t = np.asarray(frames) - frames[0]
    for j in range(poses.shape[1]):
        if not missing[:, j].any():
            continue
        if missing[:, j].all():
            out[:, j] = np.nan
            continue
        for c in range(2):
            z = np.full(int(t[-1]) + 1, np.nan)
            z[t[~missing[:, j]]] = poses[~missing[:, j], j, c]
            best = max(((q, r) for q in 10.0 ** np.arange(-2, 3.5, 0.5)
                        for r in 10.0 ** np.arange(-1, 2.5, 1.0)),
                       key=lambda qr: _rts(z, *qr)[1])
            out[missing[:, j], j, c] = _rts(z, *best)[0][t[missing[:, j]]]
    return out


# ---------------------------------------------------------------- methods and scores
def fill_sparseedm(poses, missing, frames, **options):
    """sparseedm.recover on one clip, defaults (plus `options`, which may
    include the temporal model's ``settings``: then its recover_temporal)."""
    from sparseedm import recover
    from sparseedm.temporal.recover import recover_temporal

    given = np.where(missing[..., None], np.nan, poses)
    run = recover_temporal if "settings" in options else recover
    return run(given, missing, frames=np.asarray(frames), **options).poses


def methods(names):
    table = dict(FILLERS, kalman=fill_kalman_standin, sparseedm=fill_sparseedm)
    return {n: table[n] for n in names}


def excess_jumps(pred, truth, mask):
    """Excess jump (px, >= 0) at every edge between an observed and a hidden
    frame of one joint inside the clip."""
    out = []
    T = len(mask)
    for j in range(mask.shape[1]):
        edges = np.diff(np.concatenate([[0], mask[:, j].astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            for hid, obs in ((a, a - 1), (b - 1, b)):
                if 0 <= obs < T and np.isfinite(pred[hid, j]).all():
                    step = np.linalg.norm(pred[hid, j] - truth[obs, j])
                    true = np.linalg.norm(truth[hid, j] - truth[obs, j])
                    out.append(max(0.0, step - true))
    return out


def _cases(clip_list, donors, seed):
    """(clip index, protocol, label, mask, bin labels) for every clip."""
    for i, (poses, frames, _) in enumerate(clip_list):
        T = len(poses)
        for L in GAP_LENGTHS:
            m = gap_mask(T, L, random_state=np.random.default_rng([seed, i, L]))
            if m.any():
                yield i, "gaps", m, np.where(m, str(L), "")
        m = transplant_mask(T, donors, np.random.default_rng([seed, i, 999]))
        if m.any():
            yield i, "transplant", m, transplant_bin(run_lengths(m), m)


def evaluate(clip_list, donors, fills, seed=0):
    """{method: {protocol: {bin: [errors]}, 'jumps': {protocol: [...]}, 'seconds': [...]}}"""
    res = {n: {"gaps": {}, "transplant": {}, "jumps": {"gaps": [], "transplant": []},
               "seconds": [], "frames": []} for n in fills}
    for i, proto, mask, bins in _cases(clip_list, donors, seed):
        truth, frames, _ = clip_list[i]
        size = real2d.body_size(truth)
        for name, fill in fills.items():
            t0 = time.perf_counter()
            pred = fill(np.where(mask[..., None], np.nan, truth), mask, frames)
            res[name]["seconds"].append(time.perf_counter() - t0)
            res[name]["frames"].append(len(truth))
            err = np.linalg.norm(pred - truth, axis=-1) / size[:, None] * 100
            for b in np.unique(bins[mask]):
                e = err[mask & (bins == b)]
                res[name][proto].setdefault(b, []).extend(np.where(np.isfinite(e), e, np.nan))
            res[name]["jumps"][proto].extend(excess_jumps(pred, truth, mask))
    return res


def summarise(res):
    """Mean errors per bin (NaN-free joint-frames of each method: unfilled counted
    apart), excess jumps, seconds per clip."""
    out = {}
    for name, r in res.items():
        row = {}
        for proto in ("gaps", "transplant"):
            allv = []
            for b, e in sorted(r[proto].items()):
                e = np.asarray(e)
                row[f"{proto}:{b}"] = float(np.nanmean(e)) if np.isfinite(e).any() else None
                row[f"{proto}:{b}:unfilled"] = float(np.mean(~np.isfinite(e)))
                if b != "never":
                    allv.append(e)
            e = np.concatenate(allv) if allv else np.array([np.nan])
            row[f"{proto}:seen"] = float(np.nanmean(e))
            row[f"{proto}:jump"] = float(np.mean(r["jumps"][proto]))
        row["seconds_per_clip"] = float(np.mean(r["seconds"]))
        out[name] = row
    return out


def table(summary):
    keys = sorted({k for row in summary.values() for k in row if not k.endswith("unfilled")})
    lines = ["key".ljust(22) + "".join(n[:10].rjust(11) for n in summary)]
    for k in keys:
        vals = [summary[n].get(k) for n in summary]
        lines.append(k.ljust(22) + "".join(
            ("-" if v is None else f"{v:.3f}" if abs(v) < 1e5 else f"{v:.2e}").rjust(11)
            for v in vals))
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="val", choices=("val", "train"))
    ap.add_argument("--methods", default=",".join(PEERS + ("sparseedm",)))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-clips", type=int, default=None)
    ap.add_argument("-o", "--output")
    args = ap.parse_args(argv)
    data = real2d.load("bonn")
    clip_list = clips(data, args.part)[:args.max_clips]
    fills = methods(args.methods.split(","))
    fill_sparseedm(clip_list[0][0][:40], np.zeros((min(40, len(clip_list[0][0])), 14), bool),
                   clip_list[0][1][:40])  # warm-up: first-call costs are not per clip
    summary = summarise(evaluate(clip_list, hidden_windows(data, args.part), fills, args.seed))
    print(f"{len(clip_list)} clips of {args.part}, {min(len(c[0]) for c in clip_list)}-"
          f"{max(len(c[0]) for c in clip_list)} frames")
    print(table(summary))
    if args.output:
        Path(args.output).write_text(json_text(dict(part=args.part, seed=args.seed,
                                                    clips=len(clip_list), summary=summary),
                                               indent=1))


if __name__ == "__main__":
    main()
