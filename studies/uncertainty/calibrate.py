"""The calibration of the 90 % radius (sparseedm.uncertainty.CALIBRATION), re-fitted.

Collects, on VALIDATION data only, every hidden joint's features
(:func:`sparseedm.uncertainty.joint_features`) and its true error under the
real-people protocols with :func:`sparseedm.recover`'s defaults:

* photos (one file per call: half the complete poses stay complete, the
  other half get joints hidden): ``mix`` (1-3 random joints) and
  ``transplanted`` (real missing patterns), on MPII, COCO and Bonn frames of
  :func:`benchmarks.real2d.split` == "val"; ``mpii-1000``: MPII's file
  topped up to 1,000 complete poses with MPII training poses (never hidden),
  and ``cmu``: 4,000 poses of the CMU clips of the benchmarks' held-out
  split (``benchmarks.split_clips``; the shipped ``cmu-all-k2000`` did learn
  from them), half under Mix (validation only). Bonn, MPII-1000
  and CMU files are coded over their own complete poses as the only atoms
  (:mod:`sparseedm.exemplars`), and are also recovered with
  ``preset="fast"`` (its local ridge over those poses) and with
  ``exemplars=False`` (the default path adapting, as it does when its check
  prefers that): each way of filling
  (:func:`sparseedm.uncertainty.coding_way`) gets its own fit. The adapted
  path also runs alone on three more files, Bonn topped up to 1,500 complete
  poses with training frames and MPII to 500 and 2,000 (1,418: every MPII
  training pose that is complete), so that its rule's file-level feature
  (the guard's error) is fitted on five files;
* video (one clip per call, ``tracks`` and ``frames`` given): Bonn
  PoseTrack's validation clips with gaps of 3, 10, 30 and 90 frames
  (:func:`sparseedm.temporal.protocols.gap_mask`) and another track's
  missing runs transplanted (:func:`sparseedm.real_protocol.transplant_track_mask`);
* mocap video: CMU clips (cmu-bvh-daz, the validation third) through one
  seeded virtual camera each, gaps and clip ends as
  ``studies/temporal/select_temporal.py`` hides them.

Then fits, per way of filling (``per_frame``, ``adapted``, ``file_atoms``,
``local_ridge``, ``temporal``), a 0.9-quantile
regression of log(error / size) on the features (each source x protocol
weighted equally), a conformal factor that brings the real people's balanced
coverage to 90 % (raised until no real protocol covers less than
``MIN_COVERAGE``, ``WAY_MIN_COVERAGE`` for the ways named there; mocap
shapes the fit only), then per way the factors from the 90 % radius to the
radius at each of :data:`sparseedm.uncertainty.LEVELS` (the real people's
balanced quantiles of error over radius, 1 at 0.9; :func:`fit_levels`, and
``"pooled"`` over every way), and reports coverage,
informativeness (the mean error of the quarter with the smallest radius over
the quarter with the largest) and the error's rank correlation with the
radius (Spearman) per source and protocol (``fast-`` labels: the fast
preset, ``adapt-``: ``exemplars=False``) and per way, and a reliability
table (nominal vs observed coverage, radii scaled to other levels by
:func:`sparseedm.uncertainty.radius_at` with each joint's way, and with the
pooled factors), also for every joint (``all``) and the real people's
(``all real``).

    python studies/uncertainty/calibrate.py                 # collect + fit + report
    python studies/uncertainty/calibrate.py --fit-only      # re-fit from the cache
    python studies/uncertainty/calibrate.py --write-module  # also rewrite CALIBRATION
    python studies/uncertainty/calibrate.py --mask-seed 1 --check \
        --cache /tmp/check.npz      # new masks, the table as it is: check_val_seed1.json
    python studies/uncertainty/calibrate.py --split test --check \
        --cache /tmp/test.npz       # the held-out measurement: check_test_seed0.json
    python studies/uncertainty/calibrate.py --fit-only \
        --figure docs/explanation/uncertainty_reliability.png   # the reliability diagram

The cache (features and errors of MPII / Bonn joints) stays outside the
repository (``--cache``); the JSON written (``-o``) holds the table and the
measured coverage only.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
import zlib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from sparseedm._atomic import json_text  # noqa: E402
import sparseedm  # noqa: E402
from benchmarks import real2d  # noqa: E402
from sparseedm.metrics import occlusion_masks  # noqa: E402
from sparseedm.real_protocol import transplant_masks, transplant_track_mask  # noqa: E402
from sparseedm.temporal.protocols import gap_mask  # noqa: E402
from sparseedm.uncertainty import (CALIBRATION, CHECKED_FLAG, FEATURES, LEVELS,  # noqa: E402
                                   joint_features, radius_at, uncertainty_rule)

GAP_LENGTHS = (3, 10, 30, 90)
#: the conformal factor is raised until every real-people protocol covers this much
MIN_COVERAGE = 0.86
#: a higher floor for the ways whose low end moves most between mask seeds
#: (MPII-1000 under the fast preset and adapted, MPII under Mix on the shipped
#: dictionary; fitted on val seed 0, judged on seed 1: studies/uncertainty/README.md)
WAY_MIN_COVERAGE = {"local_ridge": 0.91, "adapted": 0.89, "per_frame": 0.91}
#: the options that say what was collected (kept with the cache)
COLLECTION = ("split", "photo_sources", "fast_sources", "adapt_sources", "cmu_poses", "seeds",
              "coco_seeds", "max_clips", "mocap", "mask_seed")
#: features collected besides the table's (candidates for a re-fit: what was averaged)
CANDIDATES = ("averaged", "rel_spread", "log_complete", "checked", "log_held_error", "guarded",
              "log_guard_error")
KEYS = sorted({f for names in FEATURES.values() for f in names} | {"size", "noise"}
              | set(CANDIDATES))


def _record(res, truth, keep, label, tracks=None, frames=None):
    """The hidden joints of rows `keep` of one result: features, error, label."""
    feats = joint_features(res, tracks, frames)
    hidden = res.missing.copy()
    hidden[~keep] = False
    ok = hidden & (feats["way"] != "")
    err = np.linalg.norm(res.poses - truth, axis=-1)
    out = {k: feats[k][ok] for k in KEYS}
    out["way"] = feats["way"][ok]
    out["error"] = err[ok]
    out["label"] = np.full(int(ok.sum()), label)
    out["refused"] = np.array([int((hidden & (feats["way"] == "")).sum())])
    return out


def coding_path(res):
    """How the poses of `res` were coded (printed): the adaptation's path
    (``"file atoms"``, ``"adapted"``, ``"base + file atoms"``, ``"base"``),
    ``", fast"`` added under ``preset="fast"``; ``"none"`` without adaptation."""
    adaptation = getattr(res, "adaptation", None)
    if adaptation is None:
        return "none"
    fast = adaptation.settings.get("preset") == "fast"
    return adaptation.path + (", fast" if fast else "")


#: how a photo file is recovered besides the defaults: the fast preset, and the
#: default path with its adaptation forced (``exemplars=False``)
VARIANTS = {"default": {}, "fast": {"preset": "fast"}, "adapt": {"exemplars": False}}


def _label(source, cond, variant):
    return f"{source}|{'' if variant == 'default' else variant + '-'}photos-{cond}"


def photos(source, seeds, part="val", variants=("default",)):
    """Photo-protocol records of one real2d source's poses of split `part`
    (``mpii-1000``: MPII's, its file topped up to 1,000 complete poses with
    MPII training poses, which are never hidden), one call per variant
    (:data:`VARIANTS`)."""
    name, _, top = source.partition("-")
    rs = real2d.load(name)
    split = real2d.split(rs)
    val = split == part
    usable = rs.complete & (real2d.body_size(rs.poses) > 0)
    rows = np.flatnonzero(usable & val)
    extra = rs.poses[np.flatnonzero(usable & (split == "train"))] if top else rs.poses[:0]
    pool = ~rs.visible[val & ~rs.complete]
    out = []
    for seed in seeds:
        rng = np.random.default_rng([seed, 3])
        order = rng.permutation(rows)
        c = len(order) - len(order) // 2
        kept, occ = rs.poses[order[:c]], rs.poses[order[c:]]
        if top:
            want = max(int(top) - c, 0)
            kept = np.concatenate([kept, extra[rng.permutation(len(extra))[:want]]])
            c = len(kept)
        masks = {"mix": occlusion_masks(len(occ), 14, ("mix",), seed)["mix"],
                 "transplanted": transplant_masks(len(occ), pool, random_state=rng)[0]}
        for cond, mask in masks.items():
            given = np.concatenate([kept, np.where(mask[..., None], np.nan, occ)])
            keep = np.arange(len(given)) >= c
            for variant in variants:
                res = sparseedm.recover(given, **VARIANTS[variant])
                out.append(_record(res, np.concatenate([kept, occ]), keep,
                                   _label(source, cond, variant)))
                print(f"  {source} seed {seed} {cond} {variant}: {int(mask.sum())} joints, "
                      f"{c} complete, {coding_path(res)}", flush=True)
    return out


def cmu_photos(n_poses, seeds, variants=("default",)):
    """A file of `n_poses` poses of the benchmarks' held-out CMU clips (which
    ``cmu-all-k2000`` learned from; ``studies/fast/select_fast.validation_file``: half
    under Mix masks, half complete), one call per seed and variant."""
    from studies.fast.select_fast import validation_file

    out = []
    for seed in seeds:
        truth, mask = validation_file(n_poses, seed)
        given = np.where(mask[..., None], np.nan, truth)
        for variant in variants:
            res = sparseedm.recover(given, **VARIANTS[variant])
            out.append(_record(res, truth, mask.any(axis=1), _label("cmu", "mix", variant)))
            print(f"  cmu {n_poses} seed {seed} {variant}: {int(mask.sum())} joints, "
                  f"{coding_path(res)}", flush=True)
    return out


def _bonn_clips(max_clips, part="val"):
    from studies.real_video.harness import clips, hidden_windows

    data = real2d.load("bonn")
    found = clips(data, part)
    if max_clips and len(found) > max_clips:
        pick = np.random.default_rng(5).choice(len(found), max_clips, replace=False)
        found = [found[i] for i in sorted(pick)]
    return found, [d for d in hidden_windows(data, part) if d.any()]


def _video_call(truth, fr, mask, label, out):
    """One clip given alone to recover (tracks and frames), its hidden joints recorded."""
    if not mask.any():
        return
    given = np.where(mask[..., None], np.nan, truth)
    tracks = np.zeros(len(fr), int)
    res = sparseedm.recover(given, tracks=tracks, frames=fr)
    out.append(_record(res, truth, np.ones(len(fr), bool), label, tracks, fr))


def video(max_clips, seed=0, part="val"):
    """Bonn PoseTrack clips of split `part`, one per call."""
    found, donors = _bonn_clips(max_clips, part)
    out = []
    for truth, fr, key in found:
        def rng(extra, key=key):
            return np.random.default_rng([seed, zlib.crc32(key.encode()), extra])
        for L in GAP_LENGTHS:
            _video_call(truth, fr, gap_mask(len(fr), L, random_state=rng(L)),
                        f"bonn|video-gap{L}", out)
        _video_call(truth, fr, transplant_track_mask(len(fr), donors, random_state=rng(0))[0],
                    "bonn|video-transplanted", out)
        print(f"  bonn clip {key}: {len(fr)} frames", flush=True)
    return out


def mocap(data_dir, max_sequences, seed=0, part="val"):
    """CMU clips through a virtual camera each (the validation or test third)."""
    from studies.temporal.select_temporal import end_mask, sequences

    from studies.temporal.select_temporal import gap_mask as mocap_gaps
    out = []
    seqs = sequences(Path(data_dir) / "cmu-bvh-daz", 1 if part == "val" else 2, 300,
                     max_sequences)
    rng = np.random.default_rng(seed)
    for truth in seqs:
        fr = np.arange(len(truth))
        for g in GAP_LENGTHS:
            if len(truth) > 2 * g + 4:
                _video_call(truth, fr, mocap_gaps(len(truth), g, rng), f"cmu|video-gap{g}", out)
        _video_call(truth, fr, end_mask(len(truth), rng), "cmu|video-ends", out)
        print(f"  cmu clip: {len(truth)} frames", flush=True)
    return out


def collect(args):
    parts = []
    t0 = time.perf_counter()
    also = {v: set(filter(None, getattr(args, f"{v}_sources").split(",")))
            for v in ("fast", "adapt")}
    default = list(filter(None, args.photo_sources.split(",")))
    for source in default + sorted(set().union(*also.values()) - set(default)):
        count = args.coco_seeds if source == "coco" else args.seeds
        seeds = range(args.mask_seed * 100, args.mask_seed * 100 + count)
        variants = ("default",) * (source in default) + tuple(
            v for v in also if source in also[v])
        if source == "cmu":  # held-out clips of the CMU training set: validation only
            if args.split == "val":
                parts += cmu_photos(args.cmu_poses, seeds, variants)
        else:
            parts += photos(source, seeds, args.split, variants)
    parts += video(args.max_clips, args.mask_seed, args.split)
    if args.mocap:
        parts += mocap(args.data_dir, args.mocap, args.mask_seed, args.split)
    joined = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    joined["refused"] = np.array([int(joined["refused"].sum())])
    print(f"collected {len(joined['error'])} joints in {time.perf_counter() - t0:.0f} s")
    return joined


def _balanced_weights(labels):
    w = np.ones(len(labels))
    for lab in np.unique(labels):
        at = labels == lab
        w[at] = 1.0 / at.sum()
    return w * len(labels) / w.sum()


def _weighted_quantile(values, weights, q):
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cum, q * cum[-1])])


def fit(data, quantile=0.9, ways=None):
    """{way: {"coef", "conformal"}} fitted on `data` (the collected joints); only
    `ways` (None: every way), the others' entries as the module has them."""
    from sklearn.linear_model import QuantileRegressor

    table = {}
    for way, names in FEATURES.items():
        at = data["way"] == way
        if not at.any() or (ways is not None and way not in ways):
            table[way] = CALIBRATION[way]
            continue
        unchecked = CALIBRATION[way].get("unchecked")
        if unchecked is not None:  # fitted on the checked files; the others keep theirs
            at &= data[CHECKED_FLAG[way]] == 1
        X = np.stack([data[f][at] for f in names], axis=-1)
        y = np.log(np.maximum(data["error"][at], 1e-3 * data["size"][at]) / data["size"][at])
        w = _balanced_weights(data["label"][at])
        qr = QuantileRegressor(quantile=quantile, alpha=0.0, fit_intercept=False,
                               solver="highs").fit(X, y, sample_weight=w)
        entry = {"coef": tuple(round(float(c), 4) for c in qr.coef_), "conformal": 1.0}
        # the conformal factor: the real people's balanced coverage of the final
        # radius (with its floor) at 90 % (mocap shapes the fit, not the factor)
        ratio = data["error"][at] / _radius(data, at, {way: entry}, way)
        labels = data["label"][at].astype(str)
        real = ~np.char.startswith(labels, "cmu|")
        if real.any():
            ratio, labels = ratio[real], labels[real]
            w = _balanced_weights(labels)
        # no real protocol below the way's floor: the factor its joints need, if larger
        least = WAY_MIN_COVERAGE.get(way, MIN_COVERAGE)
        floor = max(np.quantile(ratio[labels == lab], least) for lab in np.unique(labels))
        entry["conformal"] = round(float(max(_weighted_quantile(ratio, w, quantile), floor)), 4)
        if unchecked is not None:
            entry["unchecked"] = unchecked
        table[way] = entry
    return table


def _real_weights(labels):
    """(True for the real people's joints, balanced weights over their labels); every
    joint when none is real (mocap only)."""
    labels = labels.astype(str)
    real = ~np.char.startswith(labels, "cmu|")
    if not real.any():
        real = np.ones(len(labels), bool)
    w = np.zeros(len(labels))
    w[real] = _balanced_weights(labels[real])
    return real, w


def _level_factors(ratio, labels):
    """The factors of :data:`sparseedm.uncertainty.LEVELS` from the errors over their
    90 % radii (`ratio`): the real people's balanced quantiles, 1 at 0.9, monotone."""
    real, w = _real_weights(labels)
    q = np.array([_weighted_quantile(ratio[real], w[real], p) for p in LEVELS])
    q = np.where(np.array(LEVELS) < 0.9, np.minimum(q, 1.0), np.maximum(q, 1.0))
    q[np.array(LEVELS) == 0.9] = 1.0
    return tuple(round(float(v), 4) for v in np.maximum.accumulate(q))


def fit_levels(data, table):
    """`table` with each way's ``"levels"`` factors and the ``"pooled"`` ones (every
    way's real people's joints, each source, protocol and way weighted alike), from
    the errors over the radii `table` gives (:func:`sparseedm.uncertainty.radius_at`)."""
    ratio = data["error"] / _radius(data, np.ones(len(data["error"]), bool), table)
    table = {way: dict(entry) for way, entry in table.items()}
    for way, entry in table.items():
        at = data["way"] == way
        if at.any():
            entry["levels"] = _level_factors(ratio[at], data["label"][at])
    cells = np.char.add(data["label"].astype(str), np.char.add("/", data["way"].astype(str)))
    table["pooled"] = {"levels": _level_factors(ratio, cells)}
    return table


def _radius(data, at, table, way=None):
    feats = {k: data[k][at][None] for k in KEYS}
    feats["way"] = data["way"][at][None]
    full = dict(CALIBRATION)
    full.update(table)
    return uncertainty_rule(feats, full)[0]


def report(data, table):
    """{label: coverage, informativeness, the error's rank correlation with the
    radius (Spearman), ...} and the reliability table."""
    from scipy.stats import spearmanr

    radius = _radius(data, np.ones(len(data["error"]), bool), table)
    err = data["error"]
    rows = {}
    labels = data["label"]
    pooled = np.array([re.sub(r"gap\d+$", "gaps", str(x)) for x in labels])
    groups = [(lab, labels == lab) for lab in np.unique(labels)]
    groups += [(lab, pooled == lab) for lab in np.unique(pooled) if lab not in labels]
    groups += [(w, data["way"] == w) for w in np.unique(data["way"])]
    groups += [("all", np.ones(len(labels), bool)),
               ("all real", ~np.char.startswith(labels.astype(str), "cmu|"))]
    for lab, at in groups:
        r, e = radius[at], err[at]
        order = np.argsort(r, kind="stable")
        q = max(len(r) // 4, 1)
        small, large = e[order[:q]].mean(), e[order[-q:]].mean()
        rows[str(lab)] = {
            "joints": int(at.sum()),
            "coverage": round(float((e <= r).mean()), 4),
            "informativeness": round(float(small / large), 3),
            "spearman": round(float(spearmanr(r, e)[0]), 3) if len(r) > 2 else None,
            "mean_radius_of_size": round(float(np.mean(r / data["size"][at])), 4),
            "mean_error_of_size": round(float(np.mean(e / data["size"][at])), 4),
            "by_way": {w: round(float((e[data["way"][at] == w] <= r[data["way"][at] == w])
                                      .mean()), 4)
                       for w in np.unique(data["way"][at])},
            "reliability": {str(p): round(float((e <= radius_at(
                r, p, data["way"][at], table)).mean()), 4) for p in LEVELS},
            "reliability_pooled": {str(p): round(float((e <= radius_at(
                r, p, None, table)).mean()), 4) for p in LEVELS},
        }
    return rows


def figure(rows, path):
    """The reliability diagram: observed coverage against the nominal level, per
    source and protocol (radii scaled by :func:`sparseedm.uncertainty.radius_at`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = [lab for lab in rows if "|" in lab and not re.search(r"gap\d+$", lab)]
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot([0.2, 1.0], [0.2, 1.0], color="0.6", lw=1, ls="--", label="calibrated")
    colours = plt.get_cmap("tab20").colors
    for i, lab in enumerate(shown):
        levels = sorted(float(p) for p in rows[lab]["reliability"])
        seen = [rows[lab]["reliability"][str(p)] for p in levels]
        ax.plot(levels, seen, marker="o", ms=3, lw=1.2, color=colours[i % len(colours)],
                ls=":" if lab.startswith("cmu|") else "-", label=lab.replace("|", ": "))
    ax.set_xlabel("nominal coverage (the 90 % radius times its way's measured factor)")
    ax.set_ylabel("observed coverage of the hidden joints")
    ax.set_title("Reliability of RecoveryResult.uncertainty (validation)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ax.set_xlim(0.2, 1.0)
    ax.set_ylim(0.2, 1.0)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def write_module(table, path=ROOT / "sparseedm" / "uncertainty.py"):
    """Rewrite the CALIBRATION block of sparseedm/uncertainty.py with `table`."""
    text = path.read_text()
    lines = ["CALIBRATION = {"]
    def numbers(values):
        return ", ".join(repr(float(c)) for c in values)

    for way, entry in table.items():
        if way == "pooled":
            lines.append(f'    "pooled": {{"levels": ({numbers(entry["levels"])})}},')
            continue
        lines.append(f'    "{way}": {{"conformal": {float(entry["conformal"])!r},')
        lines.append(f'{" " * 8}"coef": ({numbers(entry["coef"])}),')
        if "unchecked" not in entry:
            lines.append(f'{" " * 8}"levels": ({numbers(entry["levels"])})}},')
            continue
        lines.append(f'{" " * 8}"levels": ({numbers(entry["levels"])}),')
        rest = entry["unchecked"]
        lines.append(f'{" " * 8}"unchecked": {{"conformal": {float(rest["conformal"])!r},')
        lines.append(f'{" " * 22}"coef": ({numbers(rest["coef"])})}}}},')
    lines.append("}")
    new, count = re.subn(r"CALIBRATION = \{\n.*?\n\}", "\n".join(lines), text, flags=re.S)
    if count != 1:
        raise SystemExit("CALIBRATION block not found")
    path.write_text(new)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cache", default="/tmp/sparseedm-uncertainty-val.npz",
                    help="the collected joints (outside the repository)")
    ap.add_argument("--fit-only", action="store_true", help="re-fit from the cache")
    ap.add_argument("--photo-sources", default="mpii,coco,bonn,mpii-1000,cmu",
                    help="photo files: real2d sources (mpii-1000: MPII topped up to 1,000 "
                    "complete poses from its training split) and cmu (held-out CMU clips)")
    ap.add_argument("--fast-sources", default="bonn,mpii-1000,cmu",
                    help="the photo sources also recovered with preset='fast' (a source "
                    "not in --photo-sources: that way only)")
    ap.add_argument("--adapt-sources", default="bonn,mpii-1000,cmu,bonn-1500,mpii-500,mpii-2000",
                    help="the photo sources also recovered with exemplars=False (the "
                    "default path adapting, as it does when its check prefers that; a "
                    "source not in --photo-sources: that way only)")
    ap.add_argument("--cmu-poses", type=int, default=4000,
                    help="poses of the cmu photo file (half complete)")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--coco-seeds", type=int, default=4)
    ap.add_argument("--max-clips", type=int, default=0, help="0: every clip")
    ap.add_argument("--mocap", type=int, default=6, help="CMU sequences (0: none)")
    ap.add_argument("--data-dir", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--mask-seed", type=int, default=0,
                    help="seeds the hidden joints (another seed: a check on new masks)")
    ap.add_argument("--split", choices=("val", "test"), default="val",
                    help="test: the held-out measurement, with --check only")
    ap.add_argument("--check", action="store_true",
                    help="report the module's table on the collected joints, no fit")
    ap.add_argument("--write-module", action="store_true")
    ap.add_argument("--ways", help="re-fit only these ways of filling (comma-separated; "
                    "the others keep the module's entries); default every way")
    ap.add_argument("--figure", help="the reliability diagram (.png) to write")
    ap.add_argument("-o", "--output", help="the JSON written; default calibration.json "
                    "beside this script, check_<split>_seed<S>.json with --check")
    args = ap.parse_args(argv)
    if args.split == "test" and not args.check:
        ap.error("--split test measures the table as it is: add --check (fit on val only)")
    if args.fit_only:
        with np.load(args.cache, allow_pickle=False) as f:
            data = {k: f[k] for k in f.files}
    else:
        data = collect(args)
        data["settings"] = np.array(json.dumps(
            {k: getattr(args, k) for k in COLLECTION}))
        np.savez(args.cache, **data)
    settings = data.pop("settings", None)
    settings = {} if settings is None else json.loads(str(settings))
    before = report(data, CALIBRATION)
    ways = None if not args.ways else args.ways.split(",")
    table = CALIBRATION if args.check else fit_levels(data, fit(data, ways=ways))
    after = report(data, table)
    for lab, row in after.items():
        print(f"{lab:36s} n={row['joints']:6d} coverage {row['coverage']:.3f} "
              f"(was {before[lab]['coverage']:.3f}) informativeness "
              f"{row['informativeness']:.2f} rank corr {row['spearman']} "
              f"radius/size {row['mean_radius_of_size']:.3f}")
    print(json.dumps(table))
    out = {"split": settings.get("split", "val"), "calibration": table, "sources": after,
           "refused_hidden_joints": int(data["refused"][0]),
           "fitted": not args.check, "collection": settings,
           "ways_fitted": None if args.check else (ways or list(FEATURES))}
    name = f"check_{args.split}_seed{args.mask_seed}.json" if args.check else \
        "calibration.json"
    output = args.output or Path(__file__).with_name(name)
    Path(output).write_text(json_text(out, indent=1) + "\n")
    if args.write_module:
        write_module(table)
    if args.figure:
        figure(after, args.figure)


if __name__ == "__main__":
    main()
