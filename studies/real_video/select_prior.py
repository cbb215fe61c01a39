"""The prior of one short clip: where the transplanted error lies, and what lowers it.

Bonn PoseTrack's ``val`` clips (34-41 frames), each given alone to
:func:`sparseedm.temporal.recover.recover_temporal`, the masks of
:func:`sparseedm.evaluation_real.evaluate_tracks` (another track's
invisibility runs transplanted, binned by run length; ``--gaps`` adds the
contiguous gaps of 3, 10 and 30 frames). Each hidden joint's error (% of the
clip's body size) is kept with its bin, its joint group, its clip, and whether
the joint is seen anywhere in the clip (``seen``: the peers fill those only,
the benchmark's scored figure) or never (only a per-frame pose prior can
place it).

Arms: the time-only peers (Akima, the Kalman smoother), the temporal model
without a prior (``time``), and the temporal model with different priors:

* per-frame answers only (``carry`` 0, the model before the carried prior),
  from different dictionaries. A clip under 60 frames does not adapt, so its
  answers come from the base dictionary alone; these arms put the photo
  path's candidates there instead, made of the clip's complete frames and the
  frames time fills from close by (what
  :func:`~sparseedm.temporal.recover.offered_poses` returns):
  ``base`` (as shipped), ``base+file`` (those poses as extra atoms),
  ``base+file, mirrored`` (averaged with the base with the poses and their
  mirror images as extra atoms: the photo path's rule under 250 complete
  poses), ``mirror`` (the base and its mirrored dictionary averaged, as
  ``mirror=True``), ``coco`` (``cmu-coco-k2932`` instead of the base) and
  ``coco, mirror``;
* ``carry T`` (``TemporalSettings.carry`` T, other fields as
  ``field:value``): the joints seen in the clip carried from their own
  frames by their observed neighbours (:mod:`sparseedm.temporal.carried`),
  on noisy keypoints, kept where the probes prefer them; ``carry 3, mirror``
  with the mirrored dictionary averaged in for the joints never seen;
  ``carry 3, gated[ coco][ never]``: ``recover(mirror="auto")``'s per-pose
  gate (:func:`sparseedm._recovery_base.mirror_weights`) weighing in the
  mirrored member's answers (``coco``: ``cmu-coco-k2932``'s) at every hidden
  joint or (``never``) at the joints the clip never shows
  (``TemporalSettings.never_mirror`` is the latter with the mirror; give
  ``never_mirror:False`` for the model before it).

The per-frame members are given to the temporal model by replacing the
module's own choice for the duration of a call (study only). ``--mocap N``
runs the arms without ``coco`` on the first N motion-capture validation
sequences of each source, as given and (CMU) with 1 % white jitter (% of body
height; ``--mocap-only``: those alone)::

    nice python studies/real_video/select_prior.py --gaps --mocap 8 \
        --out studies/real_video/selection_prior.json

Validation only; nothing of Bonn is written but scores.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from contextlib import contextmanager, nullcontext
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import real2d  # noqa: E402
from sparseedm._recovery_base import mirror_weights  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.evaluation_real import clip_cases  # noqa: E402
from sparseedm.file_atoms import mirror_images, with_file_atoms  # noqa: E402
from sparseedm.metrics import joint_error  # noqa: E402
from sparseedm.real_protocol import JOINT_GROUPS, body_size  # noqa: E402
from sparseedm.temporal import recover as temporal_recover  # noqa: E402
from sparseedm.temporal.fillers import fill_akima, fill_kalman  # noqa: E402
from sparseedm.temporal.model import DEFAULT_SETTINGS  # noqa: E402
from sparseedm.temporal.protocols import run_bin, run_lengths  # noqa: E402
from studies.real_video.select_fusion import emit  # noqa: E402

TIME_ALONE = replace(DEFAULT_SETTINGS, ramp_start=1e9, ramp_full=2e9, probe=False)
GROUP_OF = np.empty(14, dtype=object)
for _name, _joints in JOINT_GROUPS.items():
    GROUP_OF[list(_joints)] = _name


def cases(part="val", gaps=False, seed=0):
    """(clip id, truth, frames, size, label, mask, bins) of the `part` split."""
    d = real2d.load("bonn")
    s = d.take(real2d.split(d) == part)
    tracks = np.char.add(np.char.add(s.group.astype(str), "#"), s.tracks.astype(str))
    hidden = ~np.isfinite(s.poses).all(axis=-1) | ~s.visible
    for clip_id, rows, masks in clip_cases(s.poses, tracks, s.frames, hidden,
                                           gap_lengths=(3, 10, 30), random_state=seed):
        truth, frames = s.poses[rows], s.frames[rows]
        size = float(np.nanmedian(body_size(truth)))
        for label, mask in masks.items():
            if label != "transplanted" and not gaps:
                continue
            bins = (run_bin(run_lengths(mask)[0])[mask] if label == "transplanted"
                    else np.full(int(mask.sum()), label))
            yield clip_id, truth, frames, size, label, mask, bins


# ---------------------------------------------------------------------------
# the per-frame priors


def _base_file(base, offered):
    return [with_file_atoms(base, offered).dictionary]


def _base_file_mirrored(base, offered):
    return [with_file_atoms(base, offered).dictionary,
            with_file_atoms(base, mirror_images(offered)).dictionary]


#: the per-frame answers alone (the temporal model before the carried prior)
PER_FRAME = replace(DEFAULT_SETTINGS, carry=0.0)
CANDIDATES = {
    "base": None,
    "base+file": _base_file,
    "base+file, mirrored": _base_file_mirrored,
    "mirror": lambda base, offered: [base, base.mirrored()],
}


def _gated_rows(poses, mask, need, never_only):
    """The rows whose answers the gate changes and the joints it may move:
    every asked row and hidden joint, or (`never_only`) the asked rows with a
    joint hidden in every row of the call (one clip, one track) and those joints."""
    if not never_only:
        return need, mask
    never = mask.all(axis=0)
    return need & (mask & never).any(axis=1), mask & never


@contextmanager
def gated(second, never_only):
    """recover_temporal's per-frame answers with ``second(member)``'s answers
    weighed in per pose by :func:`sparseedm._recovery_base.mirror_weights`
    (``recover(mirror="auto")``'s gate; `second` the mirrored member or another
    dictionary), on every hidden joint or (`never_only`) on the joints the call
    never shows."""
    own = temporal_recover._per_frame
    cache = {}

    def per_frame(poses, mask, need, members, settings, kwargs, never=None):
        first = own(poses, mask, need, members, settings, kwargs, never)
        rows, joints = _gated_rows(poses, mask, need, never_only)
        if not rows.any():
            return first
        others = [cache.setdefault(id(m), second(m)) for m in members]
        other = own(poses, mask, rows, others, settings, kwargs)
        k = np.flatnonzero(rows)
        w = mirror_weights([SimpleNamespace(objective=first.fields["objective"][k]),
                            SimpleNamespace(objective=other.fields["objective"][k])])
        mixed = w[0][:, None, None] * first.poses[k] + w[1][:, None, None] * other.poses[k]
        ok = joints[k] & np.isfinite(mixed).all(axis=-1)
        first.poses[k] = np.where(ok[..., None], mixed, first.poses[k])
        return first

    temporal_recover._per_frame = per_frame
    try:
        yield
    finally:
        temporal_recover._per_frame = own


@contextmanager
def members(make):
    """recover_temporal's per-frame members made by ``make(base, offered)`` (None: its own)."""
    if make is None:
        yield
        return
    own = temporal_recover._adapt

    def adapt(dictionary, poses, mask, layout, usable, *args, **kw):
        offered = temporal_recover._offered(layout, poses, mask, usable, DEFAULT_SETTINGS)
        return make(dictionary, offered), []

    temporal_recover._adapt = adapt
    try:
        yield
    finally:
        temporal_recover._adapt = own


def model_arm(dictionary, make=None, settings=PER_FRAME, gate=None):
    """fill(given, mask, frames) of the temporal model with the members `make` makes
    (`gate`: (second, never_only) of :func:`gated`)."""
    def fill(given, mask, frames):
        with members(make), (gated(*gate) if gate else nullcontext()):
            return temporal_recover.recover_temporal(given, mask, frames=frames,
                                                     dictionary=dictionary,
                                                     settings=settings).poses
    return fill


def carry_settings(name):
    """TemporalSettings of an arm ``carry TAU[ field:value ...]`` (the carried prior)."""
    words = name.split(",")[0].split()
    kw = {"carry": float(words[1])}
    for item in words[2:]:
        key, _, value = item.partition(":")
        kind = type(getattr(DEFAULT_SETTINGS, key))
        kw[key] = (value == "True") if kind is bool else kind(value)
    return replace(DEFAULT_SETTINGS, **kw)


def gate_of(name):
    """(second, never_only) of an arm ``carry T, gated[ coco][ never]`` (None: no gate)."""
    rest = name.partition(",")[2].split()
    if not rest or rest[0] != "gated":
        return None
    if "coco" in rest:
        coco = load_dictionary("cmu-coco-k2932")
        return (lambda member: coco), "never" in rest
    return (lambda member: member.mirrored()), "never" in rest


def carry_arm(name, dictionary):
    """fill of a ``carry ...`` arm on `dictionary`."""
    return model_arm(dictionary, CANDIDATES["mirror"] if name.endswith("mirror") else None,
                     settings=carry_settings(name), gate=gate_of(name))


def arms(names):
    """{name: fill} for the arm names."""
    base = load_dictionary()
    out = {"akima": fill_akima, "kalman": fill_kalman,
           "time": model_arm(base, settings=TIME_ALONE)}
    coco = None
    for name in names:
        if name.startswith("carry"):
            out[name] = carry_arm(name, base)
        elif name.startswith("coco"):
            coco = coco or load_dictionary("cmu-coco-k2932")
            rest = name.removeprefix("coco").lstrip(", ") or "base"
            out[name] = model_arm(coco, CANDIDATES[rest])
        else:
            out[name] = model_arm(base, CANDIDATES[name])
    return out


# ---------------------------------------------------------------------------
# measuring


def measure(fills, part="val", gaps=False):
    """Per-hidden-joint records: {arm: error array}, and the shared labels."""
    errors = {n: [] for n in fills}
    seconds = dict.fromkeys(fills, 0.0)
    labels = {k: [] for k in ("clip", "cond", "bin", "group", "seen")}
    for clip_id, truth, frames, size, label, mask, bins in cases(part, gaps):
        given = np.where(mask[..., None], np.nan, truth)
        _, joint = np.nonzero(mask)
        labels["clip"].append(np.full(len(joint), clip_id))
        labels["cond"].append(np.full(len(joint), label))
        labels["bin"].append(bins)
        labels["group"].append(GROUP_OF[joint])
        labels["seen"].append((~mask).any(axis=0)[joint])
        for name, fill in fills.items():
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = fill(given, mask, frames)
            seconds[name] += time.perf_counter() - t0
            errors[name].append(np.linalg.norm(out - truth, axis=-1)[mask] / size * 100)
    return ({n: np.concatenate(e) for n, e in errors.items()},
            {k: np.concatenate(v) for k, v in labels.items()}, seconds)


def _mean(e, keep):
    keep = keep & np.isfinite(e)
    return round(float(e[keep].mean()), 3) if keep.any() else None


def breakdown(errors, labels, models=("base", "carry 3")):
    """Tables of the transplanted error: overall, per bin, seen / never seen, per group,
    per clip (each of the `models` arms' share of its total error over the seen joints)."""
    trans = labels["cond"] == "transplanted"
    seen = labels["seen"]
    out = {"counts": {"hidden": int(trans.sum()), "seen": int((trans & seen).sum()),
                      "never_seen": int((trans & ~seen).sum())}}
    rows = {}
    for name, e in errors.items():
        row = {"seen": _mean(e, trans & seen), "never seen": _mean(e, trans & ~seen),
               "all": _mean(e, trans)}
        for b in ("1-5", "6-15", "16-45"):
            row[f"seen {b}"] = _mean(e, trans & seen & (labels["bin"] == b))
            row[f"never {b}"] = _mean(e, trans & ~seen & (labels["bin"] == b))
        for g in JOINT_GROUPS:
            row[f"seen {g}"] = _mean(e, trans & seen & (labels["group"] == g))
            row[f"never {g}"] = _mean(e, trans & ~seen & (labels["group"] == g))
        for cond in sorted(set(labels["cond"]) - {"transplanted"}):
            row[cond] = _mean(e, labels["cond"] == cond)
        rows[name] = row
    out["arms"] = rows
    out["clips"] = {m: _clip_shares(errors, labels, m) for m in models if m in errors}
    return out


def _clip_shares(errors, labels, model):
    """{clip: its seen hidden joints, share of the `model` arm's summed error, its mean
    and the Kalman smoother's, its never-seen joints}, largest share first."""
    trans = (labels["cond"] == "transplanted") & labels["seen"]
    e = errors[model]
    total = float(np.nansum(e[trans]))
    share = {}
    for clip in np.unique(labels["clip"][labels["cond"] == "transplanted"]):
        k = trans & (labels["clip"] == clip)
        never = (labels["cond"] == "transplanted") & ~labels["seen"] & (labels["clip"] == clip)
        share[clip] = dict(n=int(k.sum()), share=round(float(np.nansum(e[k])) / total, 3),
                           mean=_mean(e, k), kalman=_mean(errors.get("kalman", e), k),
                           never=int(never.sum()))
    return dict(sorted(share.items(), key=lambda kv: -kv[1]["share"]))


#: seconds of each source's arm over its motion-capture runs (filled by :func:`mocap`)
MOCAP_SECONDS = {}


def mocap(max_sequences, names, jitter=0.01):
    """{source: {'as given' | 'jitter': {protocol: {arm: mean error (% body height)}}}}
    on motion-capture validation sequences, as given and with seeded white jitter of
    `jitter` x the body height on the observed joints (the jitter on CMU only), the
    arms `names` (as in :func:`arms`, the source's dictionary)."""
    from benchmarks import video_protocols
    from sparseedm.temporal.evaluation import detector_jitter
    from studies.temporal.probe_one_clip_guard import mocap_cases

    out = {}
    for source in ("cmu", "bandai"):
        dictionary = load_dictionary(video_protocols.DICTIONARY[source])
        fills = {n: (carry_arm(n, dictionary) if n.startswith("carry")
                     else model_arm(dictionary, CANDIDATES[n])) for n in names}
        errors = {}
        for i, seq, protocol, _, mask, given in mocap_cases(source, max_sequences):
            kinds = {"as given": given}
            if source == "cmu":
                kinds["jitter"] = given + detector_jitter(seq, jitter, random_state=i)
            for kind, poses in kinds.items():
                for name, fill in fills.items():
                    t0 = time.perf_counter()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        filled = fill(poses, mask, seq.frames)
                    key = f"{source} {name}"
                    MOCAP_SECONDS[key] = round(MOCAP_SECONDS.get(key, 0.0)
                                               + time.perf_counter() - t0, 2)
                    err = np.nanmean(joint_error(filled, seq.poses2d, mask)) / seq.height * 100
                    errors.setdefault(kind, {}).setdefault(protocol, {}).setdefault(
                        name, []).append(float(err))
        out[source] = {k: {p: {n: round(float(np.mean(e)), 4) for n, e in a.items()}
                           for p, a in by.items()} for k, by in errors.items()}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="val", choices=("val", "train", "test"))
    ap.add_argument("--arms", nargs="+",
                    default=[*CANDIDATES, "coco", "coco, mirror", "carry 3", "carry 3, mirror"])
    ap.add_argument("--gaps", action="store_true", help="also the 3/10/30-frame gaps")
    ap.add_argument("--mocap", type=int, default=0)
    ap.add_argument("--mocap-only", action="store_true", help="skip the Bonn clips")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    doc = {}
    if not args.mocap_only:
        errors, labels, seconds = measure(arms(args.arms), args.part, args.gaps)
        doc = dict(split=args.part, breakdown=breakdown(errors, labels),
                   seconds={k: round(v, 2) for k, v in seconds.items()})
    if args.mocap:
        doc["mocap_validation"] = mocap(args.mocap, [a for a in args.arms
                                                    if not a.startswith("coco")])
        doc["mocap_seconds"] = MOCAP_SECONDS
    emit(doc, args.out)


if __name__ == "__main__":
    main()
