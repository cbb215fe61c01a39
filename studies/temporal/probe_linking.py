"""Two people in one video, no track ids: linking them, and what time then gives.

Pairs of validation sequences of each source become one video of two people,
each hidden by Protocol B (self-occlusion and short dropouts), the rows of
each frame in a seeded order, no tracks: "beside", the second shifted
sideways by 0.4-1 body height; "across", the second walking across the
first over the clip, entering at a third of it, mostly hidden while they
overlap, with 10 % of the detections missing. Records, per pair and ``link_tracks`` distance:

* identity switches: consecutive detections of one person given different
  linked tracks, and the share of rows whose linked track is mostly their
  person's;
* the error of the hidden joints (% of body height), with defaults, given
  the true tracks, given none (linked), and each frame alone (what a file
  without tracks got before linking)::

    python studies/temporal/probe_linking.py --data-dir ../shared/data \\
        --out studies/temporal/selection_linking.json

Validation only; nothing from Bandai-Namco is written but the scores.
Results: dictionaries/README.md, "Two people without track ids".
"""
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root
from benchmarks import video_protocols  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.metrics import joint_error  # noqa: E402
from sparseedm.recovery import recover  # noqa: E402
from sparseedm.temporal.evaluation import protocol_masks  # noqa: E402
from sparseedm.temporal.linking import link_tracks  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402

DISTANCES = (0.25, 0.5, 1.0)


def scene(a, b, layout, seed):
    """Rows of two people (poses, missing, frames, truth, identity, heights),
    each frame's rows in a seeded order; see :func:`_harder` for "across"."""
    T = min(len(a), len(b))
    h = a.height
    if layout == "beside":
        shift = np.full(T, (0.4 + 0.6 * np.random.default_rng(seed).random()) * h)
    else:  # across: from one body height left of the first to one right of it
        shift = np.linspace(-h, h, T)
    pb = b.poses2d[:T] - b.poses2d[:T].mean(axis=(0, 1)) + a.poses2d[:T].mean(axis=(0, 1))
    pb = pb + np.stack([shift, np.zeros(T)], axis=1)[:, None, :]
    truth = np.concatenate([a.poses2d[:T], pb])
    ma = protocol_masks(a, "self-occlusion")["self-occlusion"][:T]
    mb = protocol_masks(b, "self-occlusion")["self-occlusion"][:T]
    missing = np.concatenate([ma, mb])
    frames = np.concatenate([np.arange(T), np.arange(T)])
    person = np.repeat([0, 1], T)
    keep = np.ones(2 * T, dtype=bool)
    if layout == "across":
        missing, keep = _harder(truth, missing, T, h, seed)
    order = np.lexsort((np.random.default_rng(seed).random(2 * T), frames))
    order = order[keep[order]]
    given = np.where(missing[..., None], np.nan, truth)
    return (given[order], missing[order], frames[order], truth[order], person[order],
            np.array([a.height, b.height])[person[order]])


def _harder(truth, missing, T, h, seed):
    """"across" as a detector sees it: while the two overlap (centres within
    half a body height) the one behind (the second) keeps only 4 random
    joints; the second enters at a third of the clip; 10 % of the detections
    are dropped in runs of 1-5 frames."""
    rng = np.random.default_rng([seed, 7])
    missing = missing.copy()
    centre = np.nanmean(truth, axis=1)
    close = np.flatnonzero(np.linalg.norm(centre[:T] - centre[T:], axis=1) < 0.5 * h)
    for t in close:
        hide = np.ones(truth.shape[1], dtype=bool)
        hide[rng.choice(truth.shape[1], 4, replace=False)] = False
        missing[T + t] |= hide
    keep = np.ones(2 * T, dtype=bool)
    keep[T:T + T // 3] = False
    while (~keep).sum() < T // 3 + 0.1 * 2 * T:
        start, length = rng.integers(0, 2 * T), rng.integers(1, 6)
        keep[start:min(start + length, 2 * T)] = False
    return missing, keep


def link_scores(linked, person, frames):
    """Identity switches and the share of rows in a track mostly of their person."""
    switches = 0
    for p in (0, 1):
        rows = np.flatnonzero(person == p)
        rows = rows[np.argsort(frames[rows])]
        switches += int((np.diff(linked[rows]) != 0).sum())
    pure = 0
    for t in np.unique(linked):
        pure += np.bincount(person[linked == t], minlength=2).max()
    return switches, pure / len(person)


def error(filled, truth, missing, heights):
    e = joint_error(filled, truth, missing) / heights[:, None] * 100
    return float(np.nanmean(e[missing]))


def pair_rows(source, max_pairs):
    seqs = video_protocols.sequences(source, "validation", 2 * max_pairs, 0)
    dictionary = load_dictionary(video_protocols.DICTIONARY[source])
    for i in range(0, len(seqs) - 1, 2):
        for layout in ("beside", "across"):
            given, missing, frames, truth, person, heights = scene(seqs[i], seqs[i + 1],
                                                                   layout, i)
            row = dict(source=source, pair=i // 2, layout=layout, frames=len(given) // 2)
            for d in DISTANCES:
                linked = link_tracks(given, missing, frames=frames, max_distance=d)
                row[f"switches_{d}"], row[f"pure_{d}"] = link_scores(linked, person, frames)
                row[f"tracks_{d}"] = int(len(np.unique(linked)))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                true = recover_temporal(given, missing, tracks=person, frames=frames,
                                        dictionary=dictionary)
                none = recover_temporal(given, missing, frames=frames, dictionary=dictionary)
                alone = recover(given, missing, dictionary=dictionary)
            row.update(error_true_tracks=error(true.poses, truth, missing, heights),
                       error_linked=error(none.poses, truth, missing, heights),
                       error_per_frame=error(alone.poses, truth, missing, heights))
            yield row


def summary(rows):
    out = []
    for source in sorted({r["source"] for r in rows}):
        for layout in ("beside", "across"):
            rs = [r for r in rows if r["source"] == source and r["layout"] == layout]
            line = dict(source=source, layout=layout, pairs=len(rs))
            for d in DISTANCES:
                line[f"switches_{d}"] = sum(r[f"switches_{d}"] for r in rs)
                line[f"pure_{d}"] = round(float(np.mean([r[f"pure_{d}"] for r in rs])), 4)
            for k in ("error_true_tracks", "error_linked", "error_per_frame"):
                line[k] = round(float(np.mean([r[k] for r in rs])), 3)
            out.append(line)
    return out


def main():
    video_protocols.probe_main(__doc__, pair_rows, summary, count="max-pairs", default=8,
                               out="studies/temporal/selection_linking.json")


if __name__ == "__main__":
    main()
