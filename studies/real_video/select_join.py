"""Where the excess jump at gap edges comes from; what a fill can reach there and at short gaps.

Bonn PoseTrack's ``val`` clips and masks as :mod:`studies.real_video.probe_short_gaps`
draws them (gaps of 3, 10 and 30 frames; transplanted invisibility runs), one
clip per call. Per arm: the mean error of the hidden joints (% of the clip's
body size) per bin and the excess jump at the gaps' edges (pixels, the
positive part of the step from the observed frame into the gap beyond the
truth's own step, :func:`studies.real_video.harness.excess_jumps`), split by
gap length and by edges where the annotated joint does not move at all
(``still truth``: the truth's step is exactly 0, so any step is excess).
Arms: Akima and the Kalman smoother (the time-only peers); the temporal model
as it was (``earlier``: ``noisy_jerk`` 300, the clean input's jerk penalty on
noisy keypoints too, and ``repeats=False``), with ``noisy_jerk`` 0, 30 or 100
alone, with ``repeats`` alone (a hidden joint expected to repeat its observed
neighbour as often as the track's keypoints repeat theirs:
:func:`sparseedm.temporal.model.repeated`), the defaults (both), time alone,
and the fused prior (``fusion=True``, share 0.25); each arm's excess jump minus
Akima's, with a 90 % bootstrap interval over the clips. At 3-frame gaps also the RMS error
and the RMS distance to the smooth truth (below), to split the error into the
fill's own and the annotations' noise.

Two references a real fill cannot beat, from each complete clip smoothed as
the temporal model smooths noisy keypoints (every frame data,
``noisy_acceleration`` and ``noisy_jerk``: the truth's smooth motion):

* ``smooth truth`` as the fill: the error a method that knew each clip's
  smooth motion would make (the annotations' own noise around it);
* ``smooth truth, joined``: each gap's edge frame placed at the observed
  neighbour plus the smooth motion's own step there: the excess jump of a
  fill that continues the true smooth motion exactly from the observed frame.

Time alone at five ``noisy_acceleration`` values on the 3-frame gaps, and
with each clip's best chosen by its own hidden truth (``stiffness``: the most
a per-clip choice of the smoothing could gain there).

``--mocap N`` also runs the temporal model (earlier and defaults)
on the first N CMU validation sequences of :mod:`benchmarks.video_protocols`
(one protocol condition per sequence, one call each, % of body height), as
given and with seeded white jitter of 1 % of the body height on the observed
joints (:func:`sparseedm.temporal.evaluation.detector_jitter`: the noisy
path)::

    nice python studies/real_video/select_join.py --mocap 8 \\
        --out studies/real_video/selection_join.json

Validation only (Bonn ``val``, CMU validation subjects); nothing of Bonn is
written but scores.
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
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.metrics import joint_error  # noqa: E402
from sparseedm.temporal.evaluation import detector_jitter  # noqa: E402
from sparseedm.temporal.fillers import fill_akima, fill_kalman  # noqa: E402
from sparseedm.temporal.model import (DEFAULT_SETTINGS, free_runs,  # noqa: E402
                                      observation_weight)
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from sparseedm.temporal.smoothing import smooth_trajectory  # noqa: E402
from studies.real_video import probe_short_gaps  # noqa: E402
from studies.real_video.select_fusion import TIME_ALONE, emit  # noqa: E402
from studies.temporal.probe_one_clip_guard import mocap_cases  # noqa: E402

#: the settings before this study: the clean input's jerk penalty on noisy
#: keypoints too, no repeats expected
EARLIER = replace(DEFAULT_SETTINGS, noisy_jerk=300.0, repeats=False)
BINS = ("gap 3", "gap 10", "gap 30", "transplanted 1-5", "transplanted 6-15",
        "transplanted 16-45")


def model_settings():
    """{name: TemporalSettings} of the temporal model's arms."""
    return {"earlier": EARLIER,
            "noisy_jerk 0": replace(DEFAULT_SETTINGS, repeats=False),
            "noisy_jerk 30": replace(DEFAULT_SETTINGS, noisy_jerk=30.0, repeats=False),
            "noisy_jerk 100": replace(DEFAULT_SETTINGS, noisy_jerk=100.0, repeats=False),
            "repeats": replace(EARLIER, repeats=True),
            "defaults": DEFAULT_SETTINGS,
            "time alone": TIME_ALONE,
            "fusion 0.25": replace(DEFAULT_SETTINGS, fusion=True, fusion_share=0.25)}


def smooth_truth(truth, settings=DEFAULT_SETTINGS):
    """The complete clip smoothed as the noisy path smooths keypoints (every
    frame data of :func:`observation_weight`'s weight; the truth itself when
    the clip is clean)."""
    free = np.zeros(truth.shape[:2], bool)
    w = observation_weight(truth, free, settings)
    if w is None:
        return truth.copy()
    T, out = len(truth), truth.copy()
    for j in range(truth.shape[1]):
        out[:, j] = smooth_trajectory(truth[:, j], np.ones(T, bool), truth[:, j], np.full(T, w),
                                      settings.noisy_acceleration, settings.noisy_jerk)[0]
    return out


def edges(truth, mask):
    """(joint, hidden row, observed row) of every gap edge inside the clip."""
    T = len(mask)
    for j, a, b in free_runs(mask):
        for hid, obs in ((a, a - 1), (b - 1, b)):
            if 0 <= obs < T:
                yield j, hid, obs


def edge_rows(truth, filled, mask, smooth):
    """(excess, fill's step, truth's step, oracle's excess) per gap edge (pixels)."""
    out = []
    for j, hid, obs in edges(truth, mask):
        true = np.linalg.norm(truth[hid, j] - truth[obs, j])
        step = np.linalg.norm(filled[hid, j] - truth[obs, j])
        oracle = np.linalg.norm(smooth[hid, j] - smooth[obs, j]) - true
        out.append((max(step - true, 0.0), step, true, max(oracle, 0.0)))
    return out


def measure(fills, part="val"):
    """Per arm: errors per bin, excess jumps per gap length and on still-truth
    edges, mean steps; and the two smooth-truth references."""
    err = {n: {} for n in [*fills, "smooth truth"]}
    jumps = {n: [] for n in [*fills, "smooth truth", "smooth truth, joined"]}
    rms = {n: [] for n in err}
    clip, last = -1, None
    for truth, frames, size, label, mask, bins in probe_short_gaps.cases(0, part):
        clip, last = clip + (truth is not last), truth  # a clip's masks share its truth
        given = np.where(mask[..., None], np.nan, truth)
        smooth = smooth_truth(truth)
        outs = {"smooth truth": np.where(mask[..., None], smooth, truth)}
        for name, fill in fills.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                outs[name] = fill(given, mask, frames)
        for name, out in outs.items():
            e = np.linalg.norm(out - truth, axis=-1)[mask] / size * 100
            if label == "gap 3":
                off = np.linalg.norm(out - smooth, axis=-1)[mask] / size * 100
                rms[name].append(np.stack([e ** 2, off ** 2]))
            for b in np.unique(bins):
                err[name].setdefault(str(b), []).extend(e[bins == b].tolist())
            if label != "transplanted" and name in jumps:
                jumps[name] += [(label, *r, clip) for r in edge_rows(truth, out, mask, smooth)]
        if label != "transplanted":
            jumps["smooth truth, joined"] += [(label, r[3], np.nan, r[2], r[3], clip)
                                              for r in edge_rows(truth, truth, mask, smooth)]
    table = {n: {b: round(float(np.mean(e[b])), 4) for b in BINS if b in e}
             for n, e in err.items()}
    for name, rows in jumps.items():
        table.setdefault(name, {}).update(jump_summary(rows))
    for name, parts in rms.items():  # gap 3: RMS error against the truth, the smooth truth
        sq = np.concatenate(parts, axis=1).mean(axis=1)
        table[name].update({"gap 3 rms": round(float(np.sqrt(sq[0])), 4),
                            "gap 3 rms from smooth truth": round(float(np.sqrt(sq[1])), 4)})
    for name in fills:
        if name != "akima":
            table[name]["excess_jump minus akima, 90 % interval"] = paired_interval(
                jumps[name], jumps["akima"])
    return table


def paired_interval(rows, peer, draws=5000, seed=0):
    """90 % bootstrap interval over clips (resampled whole) of the difference
    of two arms' mean excess jumps over the same edges (pixels)."""
    clips = np.array([r[-1] for r in rows])
    diff = np.array([r[1] for r in rows]) - np.array([r[1] for r in peer])
    ids = np.unique(clips)
    sums = np.array([diff[clips == c].sum() for c in ids])
    counts = np.array([(clips == c).sum() for c in ids])
    pick = np.random.default_rng(seed).integers(0, len(ids), (draws, len(ids)))
    means = sums[pick].sum(axis=1) / counts[pick].sum(axis=1)
    return [round(float(q), 4) for q in np.percentile(means, [5, 95])]


def jump_summary(rows):
    """The excess jump overall, per gap length and at still-truth edges; mean steps."""
    label = np.array([r[0] for r in rows])
    excess, step, true = (np.array([r[i] for r in rows], float) for i in (1, 2, 3))
    still = true == 0
    out = {"excess_jump": round(float(excess.mean()), 4)}
    for lab in sorted(set(label)):
        out[f"excess_jump {lab}"] = round(float(excess[label == lab].mean()), 4)
    out["excess_jump still truth"] = round(float(excess[still].mean()), 4)
    out["still truth edges"] = round(float(still.mean()), 4)
    out["excess from still-truth edges"] = round(float(excess[still].sum() / len(excess)), 4)
    if np.isfinite(step).all():
        out["mean step"] = round(float(step.mean()), 4)
    out["mean true step"] = round(float(true.mean()), 4)
    return out


#: the noisy path's acceleration penalties the per-clip oracle chooses among
STIFFNESS = (20.0, 40.0, 100.0, 250.0, 600.0)


def stiffness_oracle(part="val", label="gap 3"):
    """Time alone at each of :data:`STIFFNESS` on the `label` cases, and with
    each clip's best one chosen by its own hidden truth (an oracle: the most a
    per-clip choice of the stiffness could gain): mean error, % of body size."""
    errors = {a: [] for a in STIFFNESS}
    best = []
    for truth, frames, size, lab, mask, _ in probe_short_gaps.cases(0, part):
        if lab != label:
            continue
        given = np.where(mask[..., None], np.nan, truth)
        case = {}
        for a in STIFFNESS:
            st = replace(TIME_ALONE, noisy_acceleration=a)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = recover_temporal(given, mask, frames=frames, settings=st, adapt=False)
            case[a] = np.linalg.norm(out.poses - truth, axis=-1)[mask] / size * 100
            errors[a].extend(case[a].tolist())
        best.extend(min(case.values(), key=np.mean).tolist())
    out = {f"noisy_acceleration {a:g}": round(float(np.mean(e)), 4) for a, e in errors.items()}
    out["best per clip (oracle)"] = round(float(np.mean(best)), 4)
    return {label: out}


def arms(dictionary=None):
    """{name: fill(given, mask, frames)}: the peers and the temporal model's arms."""
    dictionary = load_dictionary(dictionary)

    def model(settings):
        return lambda g, m, f: recover_temporal(g, m, frames=f, dictionary=dictionary,
                                                settings=settings).poses

    out = {"akima": fill_akima, "kalman": fill_kalman}
    out.update({name: model(s) for name, s in model_settings().items()})
    return out


def mocap(max_sequences, jitter=0.01, source="cmu", settings=None):
    """{'as given' | 'jitter': {protocol: {arm: mean error (% body height)}}} on
    the first `max_sequences` validation sequences of `source`; `settings`:
    {arm: TemporalSettings}, default ``earlier`` and the defaults."""
    dictionary = load_dictionary(video_protocols.DICTIONARY[source])
    if settings is None:
        settings = {"earlier": EARLIER, "defaults": DEFAULT_SETTINGS}
    errors = {}
    for i, seq, protocol, _, mask, given in mocap_cases(source, max_sequences):
        noisy = given + detector_jitter(seq, jitter, random_state=i)
        for kind, poses in (("as given", given), ("jitter", noisy)):
            for name, st in settings.items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = recover_temporal(poses, mask, frames=seq.frames,
                                           dictionary=dictionary, settings=st)
                e = np.nanmean(joint_error(res.poses, seq.poses2d, mask)) / seq.height * 100
                errors.setdefault(kind, {}).setdefault(protocol, {}).setdefault(
                    name, []).append(float(e))
    return {kind: {p: dict({n: round(float(np.mean(e)), 4) for n, e in arms_.items()},
                           cases=len(next(iter(arms_.values()))))
                   for p, arms_ in by.items()} for kind, by in errors.items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="val", choices=("val", "train", "test"))
    ap.add_argument("--mocap", type=int, default=0,
                    help="CMU validation sequences (0: none)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    doc = dict(split=args.part, machine=f"{platform.machine()}, {platform.python_version()}",
               results=measure(arms(), args.part), stiffness=stiffness_oracle(args.part))
    if args.mocap:
        doc["mocap_validation"] = mocap(args.mocap)
    emit(doc, args.out)


if __name__ == "__main__":
    main()
