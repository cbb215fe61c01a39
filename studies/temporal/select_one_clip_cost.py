"""What one clip's adaptation and self-training buy, per clip size, and what they cost.

Every validation clip is given alone to :func:`sparseedm.temporal.recover.recover_temporal`
(the way most users meet the video path), once per variant, and the error of
its hidden joints (% of body size) and the call's seconds are recorded with
the clip's length:

* mocap: the validation sequences of ``bandai`` (another lab: the shipped
  dictionary never saw it) and ``cmu`` (subjects the ``cmu-k2000`` dictionary
  never saw) of :mod:`benchmarks.video_protocols`, Protocol A (one gap length
  per sequence, in turn) and Protocol B (self-occlusion);
* real people: Bonn PoseTrack's ``val`` clips (:mod:`benchmarks.real2d`, a
  track's run of at least 30 complete frames) with contiguous gaps of 3, 10
  and 30 frames and with another track's invisibility runs transplanted, the
  masks seeded as :func:`sparseedm.evaluation_real.evaluate_tracks` seeds them.

Variants (``--variants``, names of :data:`VARIANTS`): the shipped rule, the
old rule (adaptation and three self-training rounds on every clip), no
self-training, no adaptation. The summary bins the clips by length and gives
each variant's mean error and seconds per bin, so the size rule of
``sparseedm.temporal.recover`` can be read off::

    nice python studies/temporal/select_one_clip_cost.py \\
        --out studies/temporal/selection_one_clip_cost.json

Validation splits only; nothing of Bandai-Namco or Bonn is written but scores.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from benchmarks import real2d, video_protocols  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.evaluation_real import clip_cases  # noqa: E402
from sparseedm.real_protocol import body_size  # noqa: E402
from sparseedm.temporal import recover as temporal_recover  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from studies.temporal.probe_one_clip_guard import mocap_cases  # noqa: E402
from studies.temporal.probe_temporal_self_training import whole_file  # noqa: E402

#: recover_temporal's keyword arguments per variant
VARIANTS = {
    "default": {},
    "adapt every clip (3 rounds)": dict(adapt="always"),
    "self_training=0": dict(self_training=0),
    "adapt=False": dict(adapt=False),
}
#: the constants of sparseedm.temporal.recover this study chose
RULE = ("ADAPT_MIN_FRAMES", "SELF_TRAINING_MIN_FRAMES", "OFFER_MAX")
SIZE_BINS = ((0, 60), (60, 100), (100, 150), (150, 200), (200, 100_000))


_WARM = []


def _run(given, mask, frames, dictionary, variants):
    """{variant: (filled poses, seconds, adopted)} of one clip (the first clip of
    the run is recovered once untimed: the compiled kernels load then)."""
    if not _WARM:
        _WARM.append(_call(given, mask, frames, dictionary, {}))
    out = {}
    for name in variants:
        kw = dict(VARIANTS[name])
        if kw.get("adapt") == "always":  # the rule before the size rule: adapt as asked
            kw["adapt"] = "auto"
            kw["min_frames"] = 0
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = _call(given, mask, frames, dictionary, kw)
        a = res.adaptation
        out[name] = (res.poses, time.perf_counter() - t0, bool(a is not None and a.adapted))
    return out


def _call(given, mask, frames, dictionary, kw):
    min_frames = kw.pop("min_frames", None)
    if min_frames is None:
        return recover_temporal(given, mask, frames=frames, dictionary=dictionary, **kw)
    from sparseedm.temporal import recover as module
    saved = module.ADAPT_MIN_FRAMES, module.SELF_TRAINING_MIN_FRAMES
    module.ADAPT_MIN_FRAMES = module.SELF_TRAINING_MIN_FRAMES = min_frames
    try:
        return recover_temporal(given, mask, frames=frames, dictionary=dictionary, **kw)
    finally:
        module.ADAPT_MIN_FRAMES, module.SELF_TRAINING_MIN_FRAMES = saved


def _row(source, clip, protocol, condition, truth, mask, size, answers):
    row = dict(source=source, clip=clip, frames=len(truth), protocol=protocol,
               condition=condition)
    for name, (filled, seconds, adopted) in answers.items():
        err = np.linalg.norm(filled - truth, axis=-1)[mask] / np.broadcast_to(
            size, mask.shape)[mask] * 100
        row[name] = dict(error=round(float(np.nanmean(err)), 4),
                         seconds=round(seconds, 3), adopted=adopted)
    return row


def mocap_rows(source, max_sequences, variants):
    """One row per (validation sequence, protocol) of a mocap source."""
    dictionary = load_dictionary(video_protocols.DICTIONARY[source])
    for i, s, protocol, key, mask, given in mocap_cases(source, max_sequences):
        answers = _run(given, mask, s.frames, dictionary, variants)
        yield _row(source, i, protocol, key, s.poses2d, mask, s.height, answers)


def bonn_rows(variants, seed=0):
    """One row per (Bonn val clip, condition), masks as evaluate_tracks draws them."""
    d = real2d.load("bonn")
    s = d.take(real2d.split(d) == "val")
    tracks = np.char.add(np.char.add(s.group.astype(str), "#"), s.tracks.astype(str))
    hidden = ~np.isfinite(s.poses).all(axis=-1) | ~s.visible
    dictionary = load_dictionary()
    for clip_id, rows, masks in clip_cases(s.poses, tracks, s.frames, hidden,
                                           gap_lengths=(3, 10, 30), random_state=seed):
        truth, frames = s.poses[rows], s.frames[rows]
        size = np.full((len(rows), 1), np.nanmedian(body_size(truth)))
        for key, mask in masks.items():
            if mask.any():
                given = np.where(mask[..., None], np.nan, truth)
                answers = _run(given, mask, frames, dictionary, variants)
                yield _row("bonn", clip_id, "gaps" if key != "transplanted" else key, key,
                           truth, mask, size, answers)


#: the offered poses' bounds a long file is tried at (``--files``)
OFFER_CAPS = (None, 3000, 2000, 1000)


def file_rows(source, offer_caps=OFFER_CAPS, self_training=0):
    """Every validation sequence of a mocap source as one file (a track each),
    adapted on its offered poses bounded by each of `offer_caps`."""
    seqs = video_protocols.sequences(source, "validation", 200, 0)
    dictionary = load_dictionary(video_protocols.DICTIONARY[source])
    saved = temporal_recover.OFFER_MAX
    for protocol in ("gaps", "self-occlusion"):
        P, M, T, F, H = whole_file(seqs, protocol)
        for cap in offer_caps:
            temporal_recover.OFFER_MAX = cap
            t0 = time.perf_counter()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = recover_temporal(np.where(M[..., None], np.nan, P), M, tracks=T,
                                           frames=F, dictionary=dictionary,
                                           self_training=self_training)
            finally:
                temporal_recover.OFFER_MAX = saved
            err = np.linalg.norm(res.poses - P, axis=-1) / H[:, None] * 100
            a = res.adaptation
            yield dict(source=source, protocol=protocol, offer_max=cap, frames=len(P),
                       self_training=self_training, sequences=len(seqs),
                       error=round(float(np.nanmean(err[M])), 4),
                       seconds=round(time.perf_counter() - t0, 1),
                       adaptation_seconds=round(a.seconds, 1), adopted=bool(a.adapted),
                       offered=int(a.n_given))


def summary(rows, variants):
    """Per source, protocol and size bin: clips, each variant's mean error and seconds."""
    out = []
    for source in sorted({r["source"] for r in rows}):
        for protocol in sorted({r["protocol"] for r in rows if r["source"] == source}):
            for lo, hi in SIZE_BINS:
                rs = [r for r in rows if r["source"] == source and r["protocol"] == protocol
                      and lo <= r["frames"] < hi]
                if not rs:
                    continue
                entry = dict(source=source, protocol=protocol, frames=f"{lo}-{hi - 1}",
                             clips=len(rs))
                for name in variants:
                    entry[name] = dict(
                        error=round(float(np.mean([r[name]["error"] for r in rs])), 4),
                        seconds=round(float(np.mean([r[name]["seconds"] for r in rs])), 3),
                        adopted=int(sum(r[name]["adopted"] for r in rs)))
                out.append(entry)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default="../shared/data")
    ap.add_argument("--max-sequences", type=int, default=20)
    ap.add_argument("--sources", default="bonn,bandai,cmu")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--files", action="store_true",
                    help="instead: each mocap source's validation sequences as one file, "
                         "at each bound of the offered poses (OFFER_CAPS)")
    ap.add_argument("--out", default="studies/temporal/selection_one_clip_cost.json")
    args = ap.parse_args(argv)
    video_protocols.DATA = Path(args.data_dir).resolve()
    variants = args.variants.split(",")
    t0 = time.perf_counter()
    if args.files:
        rows = []
        for source in args.sources.split(","):
            for row in file_rows(source):
                print(json.dumps(row), flush=True)
                rows.append(row)
        Path(args.out).write_text(json_text(dict(
            split="validation", mode="files", seconds=round(time.perf_counter() - t0, 1),
            rows=rows), indent=1) + "\n")
        return
    rows = []
    for source in args.sources.split(","):
        it = bonn_rows(variants) if source == "bonn" else mocap_rows(
            source, args.max_sequences, variants)
        for row in it:
            print(json.dumps(row), flush=True)
            rows.append(row)
    doc = dict(split="validation", variants={v: str(VARIANTS[v]) for v in variants},
               rule={k: getattr(temporal_recover, k) for k in RULE},
               machine=f"{platform.platform()}, load average at the end "
                       f"{[round(x, 2) for x in __import__('os').getloadavg()]}",
               seconds=round(time.perf_counter() - t0, 1),
               summary=summary(rows, variants), rows=rows)
    Path(args.out).write_text(json_text(doc, indent=1) + "\n")
    print(json.dumps(doc["summary"], indent=1))


if __name__ == "__main__":
    main()
