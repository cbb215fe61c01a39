"""The outlier check's limits (:mod:`sparseedm.outliers`), chosen on validation clips.

Every Bonn PoseTrack clip of a split is written as an OpenPose folder with
wrong and right low-scored points (``studies/outliers/case.py``) twice: with
60 % of the occluded joints wrong (mixed with right ones: time can tell) and
with all of them wrong (whole occluded stretches: time mostly cannot), read back
with OpenPose's cut-off (0.05) and checked (:func:`sparseedm.outliers.find_outliers`)
once; the limits are then chosen on the distances found: the fewest wrong
points kept with at most ``MAX_RIGHT_FLAGGED`` of the right low-scored points
flagged. ``--report`` runs ``recover_file`` on every clip of the split with
the check off, on (the defaults) and, for reference, off with every point
below 0.3 read as missing (MMPose's default cut: the wrong points' fill error
when all of them are caught, and every right low-scored point lost), and
writes the errors (``studies/outliers/results-<split>.json``).

    python studies/outliers/select_outliers.py               # choose on val
    python studies/outliers/select_outliers.py --report val  # before / after
    python studies/outliers/select_outliers.py --report test # the held-out case
"""

from __future__ import annotations

import argparse
import itertools
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import real2d  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.batch import recover_file  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.keypoints import read_keypoints  # noqa: E402
from sparseedm.skeleton import JOINT_NAMES  # noqa: E402
from sparseedm.outliers import OutlierSettings, decide, find_outliers  # noqa: E402
from studies.outliers.case import imitate, measure, row_order, write_openpose  # noqa: E402

HERE = Path(__file__).resolve().parent
MAX_RIGHT_FLAGGED = 0.02
REACHES = (3, 6, 12, 30)
WRONG_SHARES = (0.6, 1.0)
GRID = dict(pose_limit=(0.06, 0.08, 0.1, 0.12, 0.15),
            time_limit=(0.1, 0.12, 0.15, 0.2, 0.25),
            far_limit=(0.1, 0.12, 0.15, 0.2, 0.25, 0.3, 0.4))
#: photos (no track): the pose model alone, chosen as far_limit's strictest
#: value that flags no right point of the clips' rows taken one by one
ALONE_LIMITS = (0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.5)


def clips(part, max_clips=None, wrong_shares=WRONG_SHARES):
    """(name, Case) of every Bonn clip of `part`, once per share of wrong points."""
    s = real2d.load("bonn")
    sp = real2d.split(s)
    groups = sorted(set(s.group[sp == part]))[:max_clips]
    for share in wrong_shares:
        for k, g in enumerate(groups):
            c = s.take(s.group == g)
            yield f"{g}@{share:g}", imitate(c.poses, c.visible, c.tracks, c.frames, seed=k,
                                            wrong_share=share)


def scores(part, reach, max_clips=None):
    """Per clip: the case, its rows as read, and the check's distances."""
    dictionary = load_dictionary()
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, case in clips(part, max_clips):
            folder = write_openpose(case, Path(tmp) / name.replace("/", "_"))
            kps = read_keypoints(folder)
            order = row_order(case, kps.ids)
            check = find_outliers(kps.poses, kps.missing, kps.confidence, [dictionary],
                                  tracks=kps.tracks, frames=None if reach is None else
                                  kps.frames, settings=OutlierSettings(time_reach=reach or 0))
            out.append((name, case, order, check))
    return out


def choose(found, reach):
    """The grid's row that leaves the wrong points least error (their mean
    displacement when kept, 0 when flagged) with at most MAX_RIGHT_FLAGGED of
    the right low-scored points flagged."""
    best = None
    for values in itertools.product(*GRID.values()):
        settings = OutlierSettings(**dict(zip(GRID, values)), time_reach=reach)
        wrong = right = right_flagged = wrong_kept = 0
        kept_error = 0.0
        for _, case, order, check in found:
            flagged = decide(check.pose_error, check.time_error, check.tracked, settings)
            w = case.wrong[order] & check.suspect
            r = case.low_right[order] & check.suspect
            away = np.linalg.norm(case.given[order] - case.truth[order], axis=-1) / \
                case.size[order][:, None]
            wrong, right = wrong + w.sum(), right + r.sum()
            wrong_kept += (w & ~flagged).sum()
            kept_error += away[w & ~flagged].sum()
            right_flagged += (r & flagged).sum()
        row = dict(settings._asdict(), wrong=int(wrong), wrong_kept=int(wrong_kept),
                   kept_error=float(kept_error / max(wrong, 1)), right=int(right),
                   right_flagged=int(right_flagged))
        if right_flagged <= MAX_RIGHT_FLAGGED * right and (
                best is None or row["kept_error"] < best["kept_error"]):
            best = row
    return best


def choose_alone(found):
    """alone_limit: the rows as photos (no time), the strictest limit with at
    most MAX_RIGHT_FLAGGED of the right low-scored points flagged."""
    rows = []
    for limit in ALONE_LIMITS:
        settings = OutlierSettings(alone_limit=limit)
        counts = np.zeros(4, int)
        for _, case, order, check in found:
            flagged = decide(check.pose_error, check.time_error, check.tracked, settings)
            w, r = case.wrong[order] & check.suspect, case.low_right[order] & check.suspect
            counts += [w.sum(), (w & ~flagged).sum(), r.sum(), (r & flagged).sum()]
        rows.append(dict(alone_limit=limit, wrong=int(counts[0]), wrong_kept=int(counts[1]),
                         right=int(counts[2]), right_flagged=int(counts[3])))
    ok = [r for r in rows if r["right_flagged"] <= MAX_RIGHT_FLAGGED * r["right"]] or rows[-1:]
    return dict(min(ok, key=lambda r: r["alone_limit"]), table=rows)


RUNS = {"off": dict(outliers=False), "on": {},
        "cut0.3": dict(outliers=False, confidence_threshold=0.3)}


def report(part, max_clips=None):
    """recover_file on each clip with the check off and on: the errors."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, case in clips(part, max_clips):
            folder = write_openpose(case, Path(tmp) / name.replace("/", "_"))
            row = {"clip": name, "poses": len(case.truth)}
            for label, kw in RUNS.items():
                out = Path(tmp) / f"{label}.npz"
                t0 = time.perf_counter()
                recover_file(folder, out, **kw)
                seconds = time.perf_counter() - t0
                res = np.load(out, allow_pickle=False)
                order = row_order(case, res["ids"])
                poses = np.empty_like(case.truth)
                poses[order] = res["poses"]
                flagged = np.zeros(case.wrong.shape, bool)
                if "outliers" in res.files:
                    for r, names in zip(order, res["outliers"]):
                        for joint in str(names).split():
                            flagged[r, JOINT_NAMES.index(joint)] = True
                row[label] = dict(measure(case, poses, flagged)._asdict(), seconds=seconds)
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def pooled(rows, label, share=None):
    """Point-weighted means of the clips' errors (of one share of wrong points)."""
    rows = [r for r in rows if share is None or r["clip"].endswith(f"@{share:g}")]
    out = {}
    for kind in ("wrong", "right"):
        n = sum(r[label][f"{kind}_count"] for r in rows)
        out[f"{kind}_error"] = sum(r[label][f"{kind}_error"] * r[label][f"{kind}_count"]
                                   for r in rows if r[label][f"{kind}_count"]) / max(n, 1)
        out[f"{kind}_count"] = n
        out[f"{kind}_flagged"] = sum(r[label][f"{kind}_flagged"] for r in rows)
    out["seconds"] = sum(r[label]["seconds"] for r in rows)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--report", choices=("val", "test"))
    ap.add_argument("--max-clips", type=int)
    args = ap.parse_args()
    meta = dict(machine=platform.platform(), processor=platform.processor())
    if args.report:
        rows = report(args.report, args.max_clips)
        doc = dict(meta, split=args.report, clips=rows,
                   pooled={k: pooled(rows, k) for k in RUNS},
                   pooled_by_share={f"{share:g}": {k: pooled(rows, k, share) for k in RUNS}
                                    for share in WRONG_SHARES})
        path = HERE / f"results-{args.report}.json"
    else:
        per_reach = [choose(scores("val", reach, args.max_clips), reach) for reach in REACHES]
        chosen = min(per_reach, key=lambda r: r["kept_error"])
        photos = choose_alone(scores("val", None, args.max_clips))
        doc = dict(meta, split="val", grid=dict(GRID, time_reach=REACHES,
                                                alone_limit=ALONE_LIMITS),
                   max_right_flagged=MAX_RIGHT_FLAGGED, per_reach=per_reach, photos=photos,
                   chosen=dict(chosen, alone_limit=photos["alone_limit"]))
        path = HERE / "selection.json"
    path.write_text(json_text(doc, indent=1) + "\n")
    print(json.dumps(doc.get("chosen") or doc["pooled"], indent=1))


if __name__ == "__main__":
    main()
