"""How far the adaptation guard's figure is to be trusted on one short clip.

One clip given alone adapts on its own complete frames, guarded by the error
on held-back blocks of them (`sparseedm.adaptation.holdout_blocks`). In a
clip of 30-300 frames those blocks are a few frames long, so every held-back
pose has a training pose a frame or two away. This probe runs each
validation sequence of both sources, one call each (Protocol A with one gap
length per sequence, and Protocol B), with defaults and with ``adapt=False``,
and records whether the guard adopted, its two figures, and the error of the
hidden joints (% of body height) either way::

    python studies/temporal/probe_one_clip_guard.py --data-dir ../shared/data \\
        --out studies/temporal/selection_one_clip_guard.json

Validation only; nothing from Bandai-Namco is written but the scores.
Results: dictionaries/README.md, "The guard on one short clip".
"""
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from benchmarks import video_protocols  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.metrics import joint_error  # noqa: E402
from sparseedm.temporal.evaluation import protocol_masks  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402


def _error(res, poses, mask, height):
    return float(np.nanmean(joint_error(res.poses, poses, mask)) / height * 100)


def mocap_cases(source, max_sequences):
    """(sequence index, sequence, protocol, condition, mask, given) of the first
    `max_sequences` validation sequences of `source`: one condition per protocol,
    taken in turn by sequence; empty masks left out."""
    for i, s in enumerate(video_protocols.sequences(source, "validation", max_sequences, 0)):
        for protocol in ("gaps", "self-occlusion"):
            masks = protocol_masks(s, protocol)
            key = sorted(masks)[i % len(masks)]
            mask = masks[key]
            if mask.any():
                yield i, s, protocol, key, mask, np.where(mask[..., None], np.nan, s.poses2d)


def clip_rows(source, max_sequences):
    """One row per (validation sequence, protocol) of `source`."""
    dictionary = load_dictionary(video_protocols.DICTIONARY[source])
    for i, s, protocol, key, mask, given in mocap_cases(source, max_sequences):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            on = recover_temporal(given, mask, frames=s.frames, dictionary=dictionary)
            off = recover_temporal(given, mask, frames=s.frames, dictionary=dictionary,
                                   adapt=False)
        a = on.adaptation
        yield dict(source=source, sequence=i, frames=len(s), protocol=protocol,
                   condition=key, adopted=bool(a is not None and a.adapted),
                   guard=[getattr(a, "err_base", None), getattr(a, "err_adapted", None)],
                   error=round(_error(on, s.poses2d, mask, s.height), 4),
                   error_adapt_false=round(_error(off, s.poses2d, mask, s.height), 4))


def summary(rows):
    """Per source and protocol: cases, adopted, better / worse than adapt=False, means."""
    out = []
    for source in sorted({r["source"] for r in rows}):
        for protocol in ("gaps", "self-occlusion"):
            rs = [r for r in rows if r["source"] == source and r["protocol"] == protocol]
            on = np.array([r["error"] for r in rs])
            off = np.array([r["error_adapt_false"] for r in rs])
            out.append(dict(source=source, protocol=protocol, cases=len(rs),
                            adopted=sum(r["adopted"] for r in rs),
                            better=int((on < off - 1e-9).sum()),
                            worse=int((on > off + 1e-9).sum()),
                            mean_error=round(float(on.mean()), 3),
                            mean_error_adapt_false=round(float(off.mean()), 3)))
    return out


def main():
    video_protocols.probe_main(__doc__, clip_rows, summary, count="max-sequences", default=20,
                               out="studies/temporal/selection_one_clip_guard.json")


if __name__ == "__main__":
    main()
