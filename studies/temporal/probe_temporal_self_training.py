"""Self-training in the video path, on the video protocols' validation split.

    python studies/temporal/probe_temporal_self_training.py clips --out /tmp/st-clips.json
    python studies/temporal/probe_temporal_self_training.py files --out /tmp/st-files.json
    python studies/temporal/probe_temporal_self_training.py clips --rounds 5 --out /tmp/st5.json
    python studies/temporal/probe_temporal_self_training.py files --rounds "" --caps 1000:all,1000:2000 --out /tmp/st-caps.json

``recover_temporal`` adapts on what the poses offer (complete frames and
frames time fills from close by) and then, by default, self-trains
(:data:`sparseedm.adaptation.SELF_TRAINING_ROUNDS` rounds, chosen for the
per-frame path) on the per-frame recovery of the rest. On a 10,000-frame file
of another lab's clips that is 20 of its 28 seconds. Here the temporal
model with the default rounds is set against ``self_training=0`` and 1
(``--rounds``: other counts; ``--caps``: the default rounds with fewer
incomplete and complete poses per round, files only):

* ``clips``: one clip per call with defaults, beside the gap fillers
  (:func:`probe_relative.run`: the same seeded sequences, masks and scored
  joint-frames as ``benchmarks/video_protocols.py --splits validation``);
* ``files``: every validation sequence of a source in one file (tracks),
  the protocol's masks dealt round the sequences; error over the hidden
  joint-frames (% of body height) and seconds.

Validation only; nothing from Bandai-Namco is written but the scores.
Results: dictionaries/README.md, "Self-training in the video path".
"""
import contextlib
import functools
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from studies.temporal.probe_relative import parser, run  # noqa: E402
from benchmarks.video_protocols import DICTIONARY, sequences  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm import adaptation  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.temporal.evaluation import protocol_masks  # noqa: E402
from sparseedm.temporal.recover import recover_temporal, recover_track  # noqa: E402

#: rounds measured: None is the default; --rounds replaces the others
ROUNDS = (None, 0, 1)


def _name(rounds):
    return "temporal" if rounds is None else f"temporal, self_training={rounds}"


def methods(dictionary, rounds=ROUNDS):
    """The gap fillers and the temporal model at each of `rounds`."""
    return ["linear", "cubic", "akima", "pca"] + [
        (_name(r), functools.partial(recover_track, dictionary=dictionary, self_training=r))
        for r in rounds]


def whole_file(seqs, protocol):
    """Every sequence as one track of one file: poses, mask, tracks, frames, heights."""
    parts = []
    for i, s in enumerate(seqs):
        masks = protocol_masks(s, protocol)
        key = sorted(masks)[i % len(masks)]
        parts.append((s.poses2d, masks[key], np.full(len(s), i), s.frames,
                      np.full(len(s), s.height)))
    return [np.concatenate(x) for x in zip(*parts)]


def _caps(text):
    """``filled:complete`` pairs, comma-separated (``all``: no bound)."""
    return [tuple(None if v == "all" else int(v) for v in pair.split(":"))
            for pair in text.split(",")]


def _variants(rounds, caps):
    """(rounds, (filled, complete) bounds of a round or None for the defaults)."""
    return [(r, None) for r in rounds] + [(None, c) for c in caps or ()]


@contextlib.contextmanager
def _round_caps(cap):
    """A round's (filled, complete) bounds set for one call (recover_temporal
    takes no such argument), restored whatever happens."""
    saved = adaptation.SELF_TRAINING_MAX_POSES, adaptation.SELF_TRAINING_MAX_COMPLETE
    adaptation.SELF_TRAINING_MAX_POSES, adaptation.SELF_TRAINING_MAX_COMPLETE = cap
    try:
        yield
    finally:
        adaptation.SELF_TRAINING_MAX_POSES, adaptation.SELF_TRAINING_MAX_COMPLETE = saved


def files(args, out, rounds=ROUNDS, caps=None):
    """Whole-file runs of each source and protocol at each of `rounds`, and with
    the defaults under each of `caps` (a round's filled and complete poses)."""
    default = (adaptation.SELF_TRAINING_MAX_POSES, adaptation.SELF_TRAINING_MAX_COMPLETE)
    for source in args.sources:
        seqs = sequences(source, "validation", 200, args.seed)
        dictionary = load_dictionary(DICTIONARY[source])
        for protocol in ("gaps", "self-occlusion"):
            P, M, T, F, H = whole_file(seqs, protocol)
            for r, cap in _variants(rounds, caps):
                t0 = time.perf_counter()
                with _round_caps(cap or default):
                    res = recover_temporal(np.where(M[..., None], np.nan, P), M, tracks=T,
                                           frames=F, dictionary=dictionary, self_training=r)
                err = np.linalg.norm(res.poses - P, axis=-1) / H[:, None] * 100
                a = res.adaptation
                row = dict(source=source, protocol=protocol, method=_name(r),
                           caps=list(cap or default),
                           frames=len(P), sequences=len(seqs),
                           error=round(float(np.nanmean(err[M])), 4),
                           seconds=round(time.perf_counter() - t0, 1),
                           adaptation_seconds=round(a.seconds, 1),
                           adopted=bool(a.adapted), guard=[a.err_base, a.err_adapted])
                print(json.dumps(row), flush=True)
                out["files"].append(row)
                Path(args.out).write_text(json_text(out, indent=1) + "\n")


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("mode", choices=("clips", "files"))
    ap.add_argument("--rounds", type=lambda s: [int(r) for r in s.split(",") if r],
                    help="rounds to set against the default (default: 0,1)")
    ap.add_argument("--caps", type=_caps,
                    help="files: the defaults with a round's filled:complete poses "
                         "bounded, e.g. 1000:all,1000:2000")
    args = ap.parse_args(argv)
    rounds = ROUNDS if args.rounds is None else (None, *args.rounds)
    warnings.simplefilter("ignore")
    out = {"split": "validation", "mode": args.mode, "runs": [], "files": []}
    if args.mode == "clips":
        out["max_sequences"] = args.max_sequences
        run(args, functools.partial(methods, rounds=rounds), out)
    else:
        files(args, out, rounds, args.caps)


if __name__ == "__main__":
    main()
