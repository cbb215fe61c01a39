"""The fused prior (``TemporalSettings.fusion``) on real people, against time alone and the peers.

Bonn PoseTrack's ``val`` clips, one clip per call, the masks of
:func:`sparseedm.evaluation_real.evaluate_tracks` (contiguous gaps of 3, 10
and 30 frames; another track's invisibility runs transplanted, binned by run
length), scored by :func:`studies.real_video.probe_short_gaps.measure`: mean
error of the hidden joints (% of the clip's body size) per bin and the excess
jump at the gaps' edges (pixels). Arms:

* ``akima``, ``kalman``: the time-only peers of :mod:`sparseedm.temporal.fillers`;
* ``time``: the temporal model without its prior (time alone: relative
  smoothing, denoising, joined edges);
* ``defaults``: the temporal model as shipped;
* ``fusion x``: the fused prior with ``fusion_share`` x (the prior weighs from
  the first hidden frame, its floor set per track from the probes' measured
  error, :func:`sparseedm.temporal.model.prior_scale`).

``noise_floor`` is the error a method that knew each clip's smooth motion
exactly would still make: the annotations' own white noise
(:func:`sparseedm.temporal.model.observation_noise` of the complete clip,
times sqrt(pi/2) for the mean length of a 2D Gaussian), % of the body size.
``ratios`` divide each arm's figure by the best peer's (Akima or Kalman) in
the same run::

    nice python studies/real_video/select_fusion.py --out studies/real_video/selection_fusion.json

Validation only (``--part test`` for the README's held-out figures, after the
choice); nothing of Bonn is written but scores.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.temporal.fillers import fill_akima, fill_kalman  # noqa: E402
from sparseedm.temporal.model import DEFAULT_SETTINGS, observation_noise  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from studies.real_video import probe_short_gaps  # noqa: E402

SHARES = (0.25, 0.5, 1.0)
PEERS = ("akima", "kalman")
#: settings whose prior never weighs: the ramp starts beyond any clip
TIME_ALONE = replace(DEFAULT_SETTINGS, ramp_start=1e9, ramp_full=2e9, probe=False)


def arms(shares=SHARES):
    """{name: fill(given, mask, frames)}: the peers and the temporal model's arms."""
    dictionary = load_dictionary()

    def model(settings):
        return lambda g, m, f: recover_temporal(g, m, frames=f, dictionary=dictionary,
                                                settings=settings).poses

    out = {"akima": fill_akima, "kalman": fill_kalman, "time": model(TIME_ALONE),
           "defaults": model(DEFAULT_SETTINGS)}
    for share in shares:
        out[f"fusion {share:g}"] = model(replace(DEFAULT_SETTINGS, fusion=True,
                                                 fusion_share=share))
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
    return {name: {k: round(row[k] / best[k], 3) for k in keys}
            for name, row in table.items() if name not in PEERS}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="val", choices=("val", "train", "test"))
    ap.add_argument("--shares", type=float, nargs="+", default=list(SHARES))
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    table = probe_short_gaps.measure(arms(args.shares), part=args.part)
    doc = dict(split=args.part, machine=f"{platform.machine()}, {platform.python_version()}",
               results=table, ratios=ratios(table), noise_floor=noise_floor(args.part))
    print(json.dumps(doc, indent=1))
    if args.out:
        Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
