"""The annotations' noise floor at 3-frame gaps; what a per-clip choice of the smoothing can gain.

Bonn PoseTrack's ``val`` clips and masks as :mod:`studies.real_video.probe_short_gaps`
draws them, several mask seeds (``--seeds``), the 3-frame gaps only (at these
gaps the defaults are time alone: the per-frame prior's ramp starts 6 frames
from an observation). Errors are the mean distance of the hidden joints (% of
the clip's median body size); RMS beside them.

The floor, per clip, from the complete clip itself:

* ``sigma``: the white noise of the annotations per coordinate
  (:func:`sparseedm.temporal.model.observation_noise`: the lag-one covariance
  of third differences, which smooth motion does not produce), % of the body;
  no filler predicts a hidden frame's own noise, so the mean error is at least
  ``sigma * sqrt(pi / 2)`` (the mean length of a 2D Gaussian: the fill exact
  on the smooth motion) and the RMS error at least ``sqrt(2) * sigma``;
* ``smooth truth``: each complete clip smoothed as the noisy path smooths
  keypoints (:func:`studies.real_video.select_join.smooth_truth`), used as the
  fill: a smoother that sees the truth on both sides of the gap and inside it.

What a smoother that sees only the observed frames can reach: time alone at
each of :data:`studies.real_video.select_join.STIFFNESS` (``noisy_acceleration``)
and with the best one chosen per clip by the clip's own hidden truth, and per
hidden run (joint and gap) by its own truth (``oracle``: no choice made from
the observations can do better within this family); and the choice a caller
can make: per clip, the stiffness whose fill is nearest the clip's own
observed joints hidden as further 3-frame gaps (``held-out choice``, a seeded
:func:`sparseedm.temporal.protocols.gap_mask` on the joint-frames the case
observes). Peers: the Kalman smoother (the best time-only peer at these gaps)
and Akima; the goal's line is 0.8 times the Kalman smoother's error::

    nice python studies/real_video/probe_noise_floor.py --seeds 0 1 2 3 \\
        --out studies/real_video/probe_noise_floor.json

Validation only; nothing of Bonn is written but scores.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from sparseedm.temporal.fillers import fill_akima, fill_kalman  # noqa: E402
from sparseedm.temporal.model import DEFAULT_SETTINGS, free_runs, observation_noise  # noqa: E402
from sparseedm.temporal.protocols import gap_mask  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from studies.real_video import probe_short_gaps  # noqa: E402
from studies.real_video.select_fusion import TIME_ALONE, emit  # noqa: E402
from studies.real_video.select_join import STIFFNESS, smooth_truth  # noqa: E402


def time_alone(given, mask, frames, acceleration):
    """The temporal model without the per-frame prior at one noisy-path stiffness."""
    settings = replace(TIME_ALONE, noisy_acceleration=float(acceleration))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return recover_temporal(given, mask, frames=frames, settings=settings,
                                adapt=False).poses


def held_out_mask(truth, mask, seed):
    """Further 3-frame gaps on the joint-frames `mask` observes (seeded)."""
    extra = gap_mask(len(truth), 3, random_state=np.random.default_rng([seed, 77]))
    extra &= ~mask
    # a row keeps at least 4 observed joints
    heavy = (mask | extra).sum(axis=1) > 10
    extra[heavy] = False
    return extra


def errors(out, truth, mask, size):
    return np.linalg.norm(out - truth, axis=-1)[mask] / size * 100


def case_rows(truth, frames, size, mask, seed):
    """{arm: errors (hidden joint-frames,)} of one gap-3 case, and its sigma."""
    given = np.where(mask[..., None], np.nan, truth)
    fills = {a: time_alone(given, mask, frames, a) for a in STIFFNESS}
    out = {f"noisy_acceleration {a:g}": errors(f, truth, mask, size) for a, f in fills.items()}
    default = f"noisy_acceleration {DEFAULT_SETTINGS.noisy_acceleration:g}"
    out["defaults (time alone here)"] = out[default]
    out["akima"] = errors(fill_akima(given, mask, frames), truth, mask, size)
    out["kalman"] = errors(fill_kalman(given, mask, frames), truth, mask, size)
    out["smooth truth"] = errors(smooth_truth(truth), truth, mask, size)
    out["oracle per clip"] = min((out[f"noisy_acceleration {a:g}"] for a in STIFFNESS),
                                 key=np.mean)
    out["oracle per run"] = per_run_oracle(fills, truth, mask, size)
    extra = held_out_mask(truth, mask, seed)
    if extra.any():
        probe_given = np.where((mask | extra)[..., None], np.nan, truth)
        score = {a: errors(time_alone(probe_given, mask | extra, frames, a), truth, extra,
                           size).mean() for a in STIFFNESS}
        out["held-out choice"] = out[f"noisy_acceleration {min(score, key=score.get):g}"]
    else:
        out["held-out choice"] = out[default]
    sigma = observation_noise(truth, np.zeros(mask.shape, bool)) / size * 100
    return out, sigma


def per_run_oracle(fills, truth, mask, size):
    """Each hidden run's errors under its own best stiffness."""
    best = np.full(mask.shape, np.nan)
    for j, a, b in free_runs(mask):
        runs = [np.linalg.norm(f[a:b, j] - truth[a:b, j], axis=-1) for f in fills.values()]
        best[a:b, j] = min(runs, key=np.mean)
    return best[mask] / size * 100


def measure(seeds, part="val"):
    """Mean and RMS error per arm over the gap-3 cases of every seed; the floor."""
    errs, sigmas, per_seed = {}, [], {}
    for seed in seeds:
        for truth, frames, size, label, mask, _ in probe_short_gaps.cases(seed, part):
            if label != "gap 3":
                continue
            out, sigma = case_rows(truth, frames, size, mask, seed)
            sigmas.append(np.full(int(mask.sum()), sigma))
            for arm, e in out.items():
                errs.setdefault(arm, []).append(e)
                per_seed.setdefault(arm, {}).setdefault(seed, []).append(e)
    sigma = np.concatenate(sigmas)
    table = {arm: {"mean": round(float(np.mean(np.concatenate(e))), 4),
                   "rms": round(float(np.sqrt(np.mean(np.concatenate(e) ** 2))), 4),
                   "per seed": [round(float(np.mean(np.concatenate(per_seed[arm][s]))), 4)
                                for s in seeds]}
             for arm, e in errs.items()}
    kalman = table["kalman"]["mean"]
    table["floor"] = {
        "sigma (per coordinate, % of body; joint-frame weighted)": round(float(sigma.mean()), 4),
        "noise floor, mean error: sigma * sqrt(pi/2)": round(
            float(np.mean(sigma) * np.sqrt(np.pi / 2)), 4),
        "noise floor, rms error: sqrt(2) * sigma": round(
            float(np.sqrt(2 * np.mean(sigma ** 2))), 4),
        "goal: 0.8 x kalman": round(0.8 * kalman, 4),
        "joint-frames": int(len(sigma))}
    return table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="val", choices=("val", "train"))
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    emit(dict(split=args.part, seeds=args.seeds, results=measure(args.seeds, args.part)),
         args.out)


if __name__ == "__main__":
    main()
