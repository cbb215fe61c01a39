"""Short gaps and gap edges on real people: the temporal model's settings tried one at a time.

Bonn PoseTrack's ``val`` clips (:mod:`benchmarks.real2d`; a track's run of at
least 30 complete frames), each given alone to
:func:`sparseedm.temporal.recover.recover_temporal`, with the masks
:func:`sparseedm.evaluation_real.evaluate_tracks` draws (contiguous gaps of 3,
10 and 30 frames; another track's invisibility runs transplanted, binned by
run length). Per variant of :class:`~sparseedm.temporal.model.TemporalSettings`
(``name=field:value;field:value``): the mean error of the hidden joints (% of
the clip's body size) per bin, and two gap-edge figures over the gaps:
``jump`` (:func:`sparseedm.temporal.evaluation.edge_jumps`, signed, pixels) and
``excess_jump`` (the positive part of the step from the observed frame into
the gap beyond the truth's own, pixels, as ``studies/real_video/harness.py``
measures it). Akima and the Kalman smoother are the peers, in the same run::

    nice python studies/real_video/probe_short_gaps.py "edge_decay=edge_decay:8" \\
        --out studies/real_video/probe_short_gaps.json

Validation only; nothing of Bonn is written but scores.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import real2d  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.evaluation_real import clip_cases  # noqa: E402
from sparseedm.real_protocol import body_size  # noqa: E402
from sparseedm.temporal.evaluation import edge_jumps  # noqa: E402
from sparseedm.temporal.fillers import fill_akima, fill_kalman  # noqa: E402
from sparseedm.temporal.model import DEFAULT_SETTINGS  # noqa: E402
from sparseedm.temporal.protocols import run_bin, run_lengths  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from studies.real_video.harness import excess_jumps  # noqa: E402


def variant(text):
    """``name=field:value;field:value`` -> (name, TemporalSettings)."""
    name, _, fields = text.partition("=")
    kw = {}
    for item in filter(None, fields.split(";")):
        key, _, value = item.partition(":")
        kind = type(getattr(DEFAULT_SETTINGS, key))
        kw[key] = (value == "True") if kind is bool else kind(value)
    return name, replace(DEFAULT_SETTINGS, **kw)


def cases(seed=0, part="val"):
    """(truth, frames, body size, label, mask, bin labels) of every clip and mask of
    the `part` split."""
    d = real2d.load("bonn")
    s = d.take(real2d.split(d) == part)
    tracks = np.char.add(np.char.add(s.group.astype(str), "#"), s.tracks.astype(str))
    hidden = ~np.isfinite(s.poses).all(axis=-1) | ~s.visible
    for _, rows, masks in clip_cases(s.poses, tracks, s.frames, hidden, gap_lengths=(3, 10, 30),
                                     random_state=seed):
        truth, frames = s.poses[rows], s.frames[rows]
        size = float(np.nanmedian(body_size(truth)))
        for label, mask in masks.items():
            if mask.any():
                bins = (np.char.add("transplanted ", run_bin(run_lengths(mask)[0])[mask])
                        if label == "transplanted" else np.full(int(mask.sum()), label))
                yield truth, frames, size, label, mask, bins


def measure(fills, seed=0, part="val"):
    """{method: {bin: mean error, 'jump', 'excess_jump', 'seconds'}} on the `part` split."""
    errors = {n: {} for n in fills}
    jumps = {n: [] for n in fills}
    excess = {n: [] for n in fills}
    seconds = dict.fromkeys(fills, 0.0)
    for truth, frames, size, label, mask, bins in cases(seed, part):
        given = np.where(mask[..., None], np.nan, truth)
        for name, fill in fills.items():
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = fill(given, mask, frames)
            seconds[name] += time.perf_counter() - t0
            err = np.linalg.norm(out - truth, axis=-1)[mask] / size * 100
            for b in np.unique(bins):
                errors[name].setdefault(str(b), []).extend(err[bins == b].tolist())
            if label != "transplanted":
                j = edge_jumps(truth, out, mask, frames)
                jumps[name].extend(j[np.isfinite(j)].tolist())
                excess[name].extend(excess_jumps(out, truth, mask))
    return {n: dict({b: round(float(np.nanmean(e)), 4) for b, e in sorted(errors[n].items())},
                    jump=round(float(np.mean(jumps[n])), 4),
                    excess_jump=round(float(np.mean(excess[n])), 4),
                    seconds=round(seconds[n], 1)) for n in fills}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("variants", nargs="*", type=variant,
                    help="name=field:value;field:value (TemporalSettings fields)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    dictionary = load_dictionary()
    fills = {"akima": fill_akima, "kalman": fill_kalman}
    for name, settings in [("defaults", DEFAULT_SETTINGS)] + list(args.variants):
        fills[name] = (lambda st: lambda g, m, f: recover_temporal(
            g, m, frames=f, dictionary=dictionary, settings=st).poses)(settings)
    table = measure(fills)
    print(json.dumps(table, indent=1))
    if args.out:
        doc = dict(split="val", variants={n: str(s) for n, s in args.variants},
                   results=table)
        Path(args.out).write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
