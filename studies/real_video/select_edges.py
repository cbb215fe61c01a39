"""Gap edges on real people over several mask seeds: the excess jump, and a damped first step at clip ends.

Bonn PoseTrack's ``val`` clips and masks as :mod:`studies.real_video.probe_short_gaps`
draws them (:func:`sparseedm.evaluation_real.clip_cases`: gaps of 3, 10 and 30
frames; another track's invisibility runs transplanted), one clip per call,
for every mask seed of ``--seeds`` (one seed's masks are noisy). Per arm and
seed: the mean error of the hidden joints seen somewhere in their clip (% of
the clip's body size) per bin, and the mean excess jump at the gap edges as
:func:`sparseedm.evaluation_real.evaluate_tracks` scores it (the positive part
of :func:`sparseedm.temporal.evaluation.edge_jumps`, % of the body size), per
protocol, overall and split by the edges of runs that reach the clip's first
or last frame (``end``: one observed side) and the others (``inner``); then
each temporal arm's change against ``earlier``, in %, mean +- standard error
over the seeds (paired: the same masks).

Arms: linear, Akima and the Kalman smoother (the time-only peers), the
temporal model before this study (``earlier``: no damped first step,
``end_step`` 1, and the earlier linking unit, which a track without a
complete frame read from the few joints two rows share: reproduced here by
patching :func:`sparseedm.temporal.linking.body_extent`), the same with the
new linking unit only (``pair unit``) and the defaults (both)::

    nice python studies/real_video/select_edges.py --seeds 0 1 2 3 4 5 6 7 --mocap 8 \\
        --out studies/real_video/selection_edges.json

``--variants name=field:value;...`` measures other settings of
:class:`~sparseedm.temporal.model.TemporalSettings` against the defaults
instead (the earlier arms left out)::

    nice python studies/real_video/select_edges.py --seeds 0 1 2 3 \
        --variants "noisy_acceleration 50=noisy_acceleration:50" \
        "edge_decay 8=edge_decay:8" "end_decay 2=end_decay:2" "end_step 0.7=end_step:0.7" \
        --out studies/real_video/selection_edges_variants.json

``--mocap N`` runs ``earlier``'s settings and the defaults (with
``--variants``: the defaults and the variants) on the first N validation
sequences of CMU and Bandai-Namco (one protocol condition per
sequence, one call each, % of body height), as given and with seeded white
jitter of 1 % of the body height on the observed joints (the noisy path,
where the rule acts). Validation only; nothing of Bonn is written but scores.
"""

from __future__ import annotations

import argparse
import contextlib
import platform
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.temporal import linking  # noqa: E402
from sparseedm.temporal.evaluation import edge_jumps  # noqa: E402
from sparseedm.temporal.fillers import fill_akima, fill_kalman, fill_linear  # noqa: E402
from sparseedm.temporal.model import DEFAULT_SETTINGS, free_runs  # noqa: E402
from sparseedm.temporal.protocols import run_bin, run_lengths  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from studies.real_video import probe_short_gaps, select_join  # noqa: E402
from studies.real_video.select_fusion import emit  # noqa: E402

#: the damped first step off
UNDAMPED = replace(DEFAULT_SETTINGS, end_step=1.0)
PEERS = {"linear": fill_linear, "akima": fill_akima, "kalman": fill_kalman}
#: temporal arms: (settings, the earlier linking unit)
MODEL_ARMS = {"earlier": (UNDAMPED, True), "pair unit": (UNDAMPED, False),
              "defaults": (DEFAULT_SETTINGS, False)}


def complete_rows_extent(poses):
    """The linking unit before :func:`sparseedm.temporal.linking.pair_extent`:
    the complete rows' median extent (the diagonal of their bounding box), NaN
    without one."""
    full = poses[np.isfinite(poses).all(axis=(-2, -1))]
    if not len(full):
        return float("nan")
    return float(np.median(np.linalg.norm(np.ptp(full, axis=1), axis=-1)))


@contextlib.contextmanager
def earlier_unit(on):
    """:func:`sparseedm.temporal.linking.body_extent` as it was, while `on`."""
    kept = linking.body_extent
    if on:
        linking.body_extent = complete_rows_extent
    try:
        yield
    finally:
        linking.body_extent = kept


def fillers(dictionary, variants=()):
    """{arm: fill(given, mask, frames)}; `variants`: ((name, TemporalSettings),
    ...) replace the earlier arms (the peers and the defaults kept)."""
    def model(settings, earlier):
        def fill(given, mask, frames):
            with earlier_unit(earlier):
                return recover_temporal(given, mask, frames=frames, dictionary=dictionary,
                                        settings=settings).poses
        return fill

    arms = ({"defaults": MODEL_ARMS["defaults"], **{n: (st, False) for n, st in variants}}
            if variants else MODEL_ARMS)
    return dict(PEERS, **{n: model(*arm) for n, arm in arms.items()})


def end_edges(mask, edges):
    """(T, N, 2) bool: the scored edges of runs with one observed side."""
    out = np.zeros(edges.shape, bool)
    T = len(mask)
    for j, a, b in free_runs(mask):
        if (a == 0) != (b == T):
            out[a:b, j] = True
    return out & edges


def score_case(sums, filled, truth, frames, size, label, mask, bins):
    """Add one case's errors per bin and excess jumps to `sums`."""
    seen = mask & ~mask.all(axis=0)
    err = np.linalg.norm(filled - truth, axis=-1) / size * 100
    for b in np.unique(bins[seen]):
        sums.setdefault(str(b), []).extend(err[seen & (bins == b)].tolist())
    proto = "transplanted" if label == "transplanted" else "gaps"
    edges = np.isfinite(edge_jumps(truth, truth, mask, frames))
    ends = end_edges(mask, edges)
    with np.errstate(invalid="ignore"):
        jump = np.clip(edge_jumps(truth, filled, mask, frames) / size * 100, 0, None)
    for part, sel in (("", edges), (" end", ends), (" inner", edges & ~ends)):
        sums.setdefault(f"jump {proto}{part}", []).extend(jump[sel].tolist())


def measure_seed(fills, seed, part="val"):
    """{arm: {key: mean}} on one seed's masks."""
    sums = {n: {} for n in fills}
    for truth, frames, size, label, mask, _ in probe_short_gaps.cases(seed, part):
        given = np.where(mask[..., None], np.nan, truth)
        bins = (np.char.add("transplanted ", run_bin(run_lengths(mask)[0]))
                if label == "transplanted" else np.full(mask.shape, label))
        for name, fill in fills.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = fill(given, mask, frames)
            score_case(sums[name], out, truth, frames, size, label, mask, bins)
    return {n: {k: float(np.nanmean(v)) for k, v in s.items()} for n, s in sums.items()}


def summarise(per_seed, base="earlier"):
    """Means over seeds, and each temporal arm's paired change against `base`."""
    arms = per_seed[0].keys()
    keys = sorted(per_seed[0][base])
    out = {n: {k: round(float(np.mean([s[n][k] for s in per_seed])), 4) for k in keys}
           for n in arms}
    for n in arms:
        if n == base or n in PEERS or n == "earlier":
            continue
        change = {}
        for k in keys:
            d = np.array([(s[n][k] - s[base][k]) / s[base][k] * 100 for s in per_seed])
            se = d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else float("nan")
            change[k] = [round(float(d.mean()), 2), round(float(se), 2)]
        out[n][f"% change against {base} (mean, se over seeds)"] = change
    return out


def mocap(max_sequences, variants=()):
    """{source: {'as given' | 'jitter': {protocol: {arm: mean error}}}}
    (:func:`studies.real_video.select_join.mocap`): ``earlier`` and the
    defaults, or the defaults and `variants`."""
    arms = ({"defaults": DEFAULT_SETTINGS, **dict(variants)} if variants else
            {"earlier": UNDAMPED, "defaults": DEFAULT_SETTINGS})
    return {source: select_join.mocap(max_sequences, source=source, settings=arms)
            for source in ("cmu", "bandai")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="val", choices=("val", "train"))
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--mocap", type=int, default=0,
                    help="validation sequences per motion-capture source (0: none)")
    ap.add_argument("--variants", nargs="*", type=probe_short_gaps.variant, default=[],
                    help="name=field:value;field:value (TemporalSettings fields): these arms "
                    "beside the defaults and the peers instead of the earlier ones")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    fills = fillers(load_dictionary(), args.variants)
    per_seed = [measure_seed(fills, s, args.part) for s in args.seeds]
    doc = dict(split=args.part, seeds=args.seeds,
               machine=f"{platform.machine()}, {platform.python_version()}",
               variants={n: str(st) for n, st in args.variants},
               results=summarise(per_seed, "defaults" if args.variants else "earlier"),
               per_seed=per_seed)
    if args.mocap:
        doc["mocap_validation"] = mocap(args.mocap, args.variants)
    emit(doc, args.out)


if __name__ == "__main__":
    main()
