"""Where time is the better evidence: held still runs and the fused prior against time and the peers.

Bonn PoseTrack's ``val`` clips, one clip per call, the masks of
:func:`sparseedm.evaluation_real.evaluate_tracks` (contiguous gaps of 3, 10
and 30 frames; another track's invisibility runs transplanted, binned by run
length), scored by :func:`studies.real_video.probe_short_gaps.measure`: mean
error of the hidden joints (% of the clip's body size) per bin and the excess
jump at the gaps' edges (pixels). Arms:

* ``akima``, ``kalman``: the time-only peers of :mod:`sparseedm.temporal.fillers`;
* ``time``: the temporal model without its prior (time alone: relative
  smoothing, denoising, joined edges);
* ``defaults``: the temporal model as shipped (still runs held on the line
  between their observed neighbours, ``TemporalSettings.hold_still``);
* ``still smoothed``: the defaults with ``hold_still=False`` (a still run
  follows the prior-free smoothed curve, as before ``hold_still``);
* ``fusion x``: the fused prior with ``fusion_share`` x (the prior weighs from
  the first hidden frame, its floor set per track from the probes' measured
  error, :func:`sparseedm.temporal.model.prior_scale`).

``noise_floor`` is the error a method that knew each clip's smooth motion
exactly would still make: the annotations' own white noise
(:func:`sparseedm.temporal.model.observation_noise` of the complete clip,
times sqrt(pi/2) for the mean length of a 2D Gaussian), % of the body size.
``ratios`` divide each arm's figure by the best peer's (Akima or Kalman) in
the same run. ``--mocap N`` also runs the temporal model's arms on the first N
validation sequences of each motion-capture source of
:mod:`benchmarks.video_protocols` (one protocol condition per sequence, one
call each, :func:`studies.temporal.probe_one_clip_guard.mocap_cases`), mean
error of the hidden joints in % of body height::

    nice python studies/real_video/select_fusion.py --mocap 8 \
        --out studies/real_video/selection_fusion.json

Validation only (``--part test`` for the README's held-out figures, after the
choice); nothing of Bonn is written but scores.
"""

from __future__ import annotations

import argparse
import platform
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import video_protocols  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.metrics import joint_error  # noqa: E402
from sparseedm.temporal.fillers import fill_akima, fill_kalman  # noqa: E402
from sparseedm.temporal.model import DEFAULT_SETTINGS, observation_noise  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from studies.real_video import probe_short_gaps  # noqa: E402
from studies.temporal.probe_one_clip_guard import mocap_cases  # noqa: E402

SHARES = (0.25, 0.5, 1.0)
PEERS = ("akima", "kalman")
#: settings whose prior never weighs: the ramp starts beyond any clip
TIME_ALONE = replace(DEFAULT_SETTINGS, ramp_start=1e9, ramp_full=2e9, probe=False)


def model_settings(shares=SHARES):
    """{name: TemporalSettings} of the temporal model's arms."""
    out = {"time": TIME_ALONE, "defaults": DEFAULT_SETTINGS,
           "still smoothed": replace(DEFAULT_SETTINGS, hold_still=False)}
    for share in shares:
        out[f"fusion {share:g}"] = replace(DEFAULT_SETTINGS, fusion=True, fusion_share=share)
    return out


def arms(shares=SHARES, dictionary=None):
    """{name: fill(given, mask, frames)}: the peers and the temporal model's arms."""
    dictionary = load_dictionary(dictionary)

    def model(settings):
        return lambda g, m, f: recover_temporal(g, m, frames=f, dictionary=dictionary,
                                                settings=settings).poses

    out = {"akima": fill_akima, "kalman": fill_kalman}
    out.update({name: model(s) for name, s in model_settings(shares).items()})
    return out


def mocap(max_sequences, shares=SHARES):
    """{source: {protocol: {arm: mean error (% body height)}, 'cases': n}} on the
    motion-capture validation sequences (the time-only arm left out; the fused
    prior at the first share only: clean input is never fused)."""
    out = {}
    settings = {k: v for k, v in model_settings(shares[:1]).items() if k != "time"}
    for source in ("cmu", "bandai"):
        dictionary = load_dictionary(video_protocols.DICTIONARY[source])
        errors = {}
        for _, seq, protocol, _, mask, given in mocap_cases(source, max_sequences):
            for name, st in settings.items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = recover_temporal(given, mask, frames=seq.frames,
                                           dictionary=dictionary, settings=st)
                err = np.nanmean(joint_error(res.poses, seq.poses2d, mask)) / seq.height * 100
                errors.setdefault(protocol, {}).setdefault(name, []).append(float(err))
        out[source] = {p: dict({n: round(float(np.mean(e)), 4) for n, e in arms_.items()},
                               cases=len(next(iter(arms_.values()))))
                       for p, arms_ in errors.items()}
    return out


def noise_floor(part, seed=0):
    """{bin: mean white-noise length (% body size)} over the cases' hidden joint-frames."""
    sums = {}
    for truth, frames, size, label, mask, bins in probe_short_gaps.cases(seed, part):
        sd = observation_noise(truth, np.zeros(mask.shape, bool))
        for b in np.unique(bins):
            total = sums.setdefault(str(b), [0.0, 0])
            total[0] += sd * np.sqrt(np.pi / 2) / size * 100 * int((bins == b).sum())
            total[1] += int((bins == b).sum())
    return {b: round(s / n, 4) for b, (s, n) in sorted(sums.items())}


def ratios(table):
    """Each arm's figures over the best peer's, per bin (and the excess jump)."""
    keys = [k for k in table["akima"] if k not in ("jump", "seconds")]
    best = {k: min(table[p][k] for p in PEERS) for k in keys}
    return {name: {k: round(row[k] / best[k], 3) if np.isfinite(best[k]) else None
                   for k in keys}
            for name, row in table.items() if name not in PEERS}


def emit(doc, out=None):
    """Print `doc` as JSON (non-finite floats as null) and write it to `out`."""
    text = json_text(doc, indent=1)
    print(text)
    if out:
        Path(out).write_text(text + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="val", choices=("val", "train", "test"))
    ap.add_argument("--shares", type=float, nargs="+", default=list(SHARES))
    ap.add_argument("--mocap", type=int, default=0,
                    help="validation sequences per motion-capture source (0: none)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    table = probe_short_gaps.measure(arms(args.shares), part=args.part)
    doc = dict(split=args.part, machine=f"{platform.machine()}, {platform.python_version()}",
               results=table, ratios=ratios(table), noise_floor=noise_floor(args.part))
    if args.mocap:
        doc["mocap_validation"] = mocap(args.mocap, args.shares)
    emit(doc, args.out)


if __name__ == "__main__":
    main()
