"""The default path's exemplar rule: its size threshold and its check's margin, on validation.

``recover()``'s default path takes a file's own complete poses as its only
atoms (the exemplars) instead of adapting when :mod:`sparseedm.exemplars`
says so: from ``EXEMPLAR_MIN_POSES`` complete poses always; in between, when
a check on held-back complete poses' hidden joints prefers them to the base
dictionary with those poses as extra atoms (by ``EXEMPLAR_MARGIN``). This
script measures, per validation file, what every branch of the rule needs:

* ``adapt``: ``recover(..., exemplars=False)``, the default path without the
  rule (guarded adaptation + self-training, or the base with file atoms);
* ``atoms``: the exemplars' recovery (``recover(..., preset="fast")``, the
  same dictionary the rule takes);
* the check's scores: ``pre``, the shipped check (exemplars vs base with file
  atoms on held-back complete poses, before any learning; ``--pre-only``
  adds it with held-back single rows and with the guard's contiguous blocks),
  and
  ``post``, a check after adapting that was measured and dropped (exemplars
  vs what ``adapt`` used, on the adaptation's own held-back poses, which its
  guard had chosen the adapted dictionary on);

then replays the rule for each threshold and margin asked for, rows or
blocks held back, with and without the check after adapting (which branch,
the test error of the occluded poses it would return, its seconds).
``benchmarks/real_people.py`` and ``benchmarks/default_path.py`` run the
shipped rule itself.
Errors per occluded pose: its hidden joints' error (% of body size) and its
EDM's Err_ave (%); paired differences with standard errors. Files (validation
only): held-out CMU clips (``select_fast.validation_file``), Daz-retargeted CMU
clips (``--mocap``, dataset .npz files), real people of
``studies/real_prior/harness.py`` (``mpii-large``: MPII train+val, ``bonn``:
Bonn val) under 2 random hidden joints and real masks.

    sparseedm dataset build ../shared/data/cmu-bvh-daz/indian -o daz_indian.npz
    python studies/fast/select_exemplar_rule.py --mocap daz_indian.npz
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_exemplar_rule.py` finds benchmarks/
from sparseedm._atomic import json_text  # noqa: E402

from studies.fast.select_default_exemplars import files, paired, per_pose  # noqa: E402


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def post_check(base, complete, chosen, result):
    """The check after adapting, measured and dropped: the exemplars made of the
    complete poses outside the adaptation's own held-back slice against what the
    default path chose, on that slice's hidden joints (the guard's masks)."""
    from sparseedm.adaptation import (DEFAULT_VALIDATION_FRACTION, GUARD_POSES_PER_PATTERN,
                                      guard_masks, holdout_blocks)
    from sparseedm.exemplars import hidden_joint_error
    from sparseedm.file_atoms import file_dictionary

    pool = result.pool
    rows = pool[holdout_blocks(len(pool), DEFAULT_VALIDATION_FRACTION, 0)]
    seen = {p.tobytes() for p in rows}
    held = np.array([p.tobytes() in seen for p in complete])
    truth = complete[held]
    mask = guard_masks(len(truth), 14, max(1, len(truth) // GUARD_POSES_PER_PATTERN), 0)
    atoms = file_dictionary(base, complete[~held]).dictionary
    return (hidden_joint_error(atoms, truth, mask, n_jobs=None),
            hidden_joint_error(chosen, truth, mask, n_jobs=None))


def measure(truth, missing):
    """The rule's parts on one file: both paths' errors and seconds, the check's scores."""
    import sparseedm
    from sparseedm.exemplars import choose_exemplars

    base = sparseedm.load_dictionary()
    given = np.where(missing[..., None], np.nan, truth)
    row, scores = {"poses": len(truth), "complete": int((~missing.any(axis=1)).sum())}, {}
    runs = {"adapt": dict(exemplars=False), "atoms": dict(preset="fast")}
    for name, kw in runs.items():
        res, secs = timed(lambda: sparseedm.recover(given, missing, dictionary=base,
                                                    n_jobs=2, **kw))
        scores[name] = per_pose(res.poses, truth, missing)
        ad = res.adaptation
        row[name] = {"pct_body": round(float(scores[name][0].mean()), 3),
                     "err_ave": round(float(np.nanmean(scores[name][1])), 3),
                     "seconds": round(secs, 2), "path": ad.path if ad else "base",
                     "reason": ad.reason if ad else ""}
        if name == "adapt":
            kept = res
    check, secs = timed(lambda: choose_exemplars(base, given, missing, n_jobs=None,
                                                 margin=-1.0, min_poses=10 ** 9))
    row["pre"] = {"atoms": check.err_atoms, "base_file_atoms": check.err_base,
                  "seconds": round(secs, 2)}
    if np.isfinite(check.err_atoms):
        complete = truth[~missing.any(axis=1) & np.isfinite(truth).all(axis=(1, 2))]
        if kept.adapted:
            (e_atoms, e_default), secs = timed(lambda: post_check(
                base, complete, kept.dictionary, kept.adaptation))
        else:  # not adapted: the check before adapting compared the same two
            (e_atoms, e_default), secs = (check.err_atoms, check.err_base), 0.0
        row["post"] = {"atoms": e_atoms, "default": e_default, "adapted": bool(kept.adapted),
                       "seconds": round(secs, 2)}
    for a, b in (("atoms", "adapt"),):
        row[f"{a}_minus_{b}"] = {"pct_body": paired(scores[a][0], scores[b][0]),
                                 "err_ave": paired(scores[a][1], scores[b][1])}
    return row


def held_rows(n, how, seed=0):
    """The check's held-back rows among n complete poses: ``blocks`` (whole
    contiguous blocks, as the adaptation's guard holds back) or ``rows`` (a
    seeded sample of rows); 20 %, at most 300."""
    from sparseedm.adaptation import DEFAULT_VALIDATION_FRACTION, MAX_VALIDATION, holdout_blocks

    if how == "blocks":
        return holdout_blocks(n, DEFAULT_VALIDATION_FRACTION, seed)
    want = min(int(round(DEFAULT_VALIDATION_FRACTION * n)), MAX_VALIDATION)
    held = np.zeros(n, bool)
    held[np.random.default_rng([seed, 43]).choice(n, want, replace=False)] = True
    return held


def pre_checks(truth, missing, hows=("blocks", "rows")):
    """The check before adapting with each way of holding poses back: the
    exemplars' and the base-with-file-atoms' held-back hidden-joint errors."""
    import sparseedm
    from sparseedm.adaptation import GUARD_POSES_PER_PATTERN, guard_masks
    from sparseedm.exemplars import hidden_joint_error
    from sparseedm.file_atoms import file_dictionary, with_file_atoms

    base = sparseedm.load_dictionary()
    complete = truth[~missing.any(axis=1)]
    out = {}
    for how in hows:
        t0 = time.perf_counter()
        held = held_rows(len(complete), how)
        n_held = int(held.sum())
        mask = guard_masks(n_held, 14, max(1, n_held // GUARD_POSES_PER_PATTERN), 0)
        rest = complete[~held]
        out[how] = {"atoms": hidden_joint_error(file_dictionary(base, rest).dictionary,
                                                complete[held], mask, n_jobs=None),
                    "base_file_atoms": hidden_joint_error(
                        with_file_atoms(base, rest).dictionary, complete[held], mask,
                        n_jobs=None)}
        out[how]["seconds"] = round(time.perf_counter() - t0, 2)
    return out


def replay(row, threshold, margin, post=False, how="rows"):
    """(branch, % body, seconds) the rule would give at `threshold` and `margin`,
    its check holding back `how` (``rows`` or ``blocks``); with `post`, the dropped
    check after adapting too."""
    n = row["complete"]
    pre = row.get("pre_by_holdout", {}).get(how, row["pre"])
    atoms = ("atoms", row["atoms"]["pct_body"], row["atoms"]["seconds"])
    if n < 250 or not np.isfinite(pre["atoms"]):
        return "too few", row["adapt"]["pct_body"], row["adapt"]["seconds"]
    if n >= threshold:
        return atoms
    extra = pre["seconds"]
    if pre["atoms"] <= (1 + margin) * pre["base_file_atoms"]:
        return "atoms (checked)", atoms[1], atoms[2] + extra
    if not post:
        return "adapt", row["adapt"]["pct_body"], row["adapt"]["seconds"] + extra
    after = row["post"]
    extra += after["seconds"]
    if after["atoms"] < after["default"]:
        return "atoms (after adapting)", atoms[1], row["adapt"]["seconds"] + extra
    return "adapt", row["adapt"]["pct_body"], row["adapt"]["seconds"] + extra


def replays(doc, thresholds, margins):
    """Per threshold, margin, held-back rows and with or without the check after
    adapting: the rule's mean change against ``adapt`` (% body), its worst file,
    the files it made worse by more than 0.05, its mean time ratio, and its branch
    per file."""
    out = {}
    for t in thresholds:
        for m in margins:
            for how, post in (("rows", False), ("blocks", False), ("blocks", True)):
                diffs, secs, branches = [], [], {}
                for name, r in doc["files"].items():
                    if "adapt" not in r:  # the check measured alone
                        continue
                    branch, err, s = replay(r, t, m, post, how)
                    diffs.append(err - r["adapt"]["pct_body"])
                    secs.append(s / r["adapt"]["seconds"])
                    branches[name] = branch
                out[f"T={t} margin={m} held={how} post={post}"] = {
                    "mean_change_pct_body": round(float(np.mean(diffs)), 4),
                    "worst_change_pct_body": round(float(max(diffs)), 4),
                    "files_worse": int(sum(d > 0.05 for d in diffs)),
                    "mean_time_ratio": round(float(np.mean(secs)), 3), "branches": branches}
    return out


def table(doc, threshold, margin):
    """Markdown: per file, both paths' errors and seconds, the check's ratio and
    what the rule (rows held back) does."""
    lines = ["| file | complete | adapt: % body / s (path) | exemplars: % body / s | "
             "exemplars − adapt, % body | check: exemplars / base+atoms | rule |",
             "|---|---:|---|---|---|---:|---|"]
    for name, r in doc["files"].items():
        if "adapt" not in r:
            continue
        pre = r.get("pre_by_holdout", {}).get("rows")  # the shipped check's holdout
        ratio = pre["atoms"] / pre["base_file_atoms"] if pre else None
        branch = replay(r, threshold, margin)[0]
        d, se = r["atoms_minus_adapt"]["pct_body"]
        lines.append(f"| {name} | {r['complete']:,} | {r['adapt']['pct_body']:.2f} / "
                     f"{r['adapt']['seconds']:.0f} ({r['adapt']['path']}) | "
                     f"{r['atoms']['pct_body']:.2f} / {r['atoms']['seconds']:.0f} | "
                     f"{d:+.2f} ± {se:.2f} | {'—' if ratio is None else f'{ratio:.3f}'} | "
                     f"{branch} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cmu", default="1000,2000,3000,4000", help="CMU file sizes (poses)")
    ap.add_argument("--seeds", default="0,1", help="seeds of the CMU files")
    ap.add_argument("--mocap", default="", help="dataset .npz paths, comma-separated")
    ap.add_argument("--mocap-sizes", default="500+500,1000+1000,1500+1500",
                    help="C+M (complete + Mix poses) of the mocap files, comma-separated")
    ap.add_argument("--photos", default="bonn,mpii-large", help="harness.py files")
    ap.add_argument("--protocols", default="2,real", help="harness.py protocols")
    ap.add_argument("--thresholds", default="1000,1500,2000,2500")
    ap.add_argument("--margins", default="-0.1,-0.05,0,0.05,0.1,0.2")
    ap.add_argument("--pre-only", action="store_true",
                    help="only the check before adapting, blocks and rows held back, "
                    "added to the files of --replay's JSON")
    ap.add_argument("--table", default=None, metavar="T,MARGIN",
                    help="with --replay: print the Markdown table of the rule at T, MARGIN")
    ap.add_argument("--replay", nargs="+", type=Path, metavar="JSON",
                    help="only replay the rule on these result files (merged), no runs")
    ap.add_argument("--out", type=Path,
                    default=Path(__file__).with_name("selection_exemplar_rule.json"))
    a = ap.parse_args(argv)
    thresholds = [int(t) for t in a.thresholds.split(",")]
    margins = [float(m) for m in a.margins.split(",")]
    if a.replay:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        doc = {"files": {}}
        for path in a.replay:  # merged per file: a later file's fields win
            for name, row in load_results(path)["files"].items():
                doc["files"].setdefault(name, {}).update(
                    {k: v for k, v in row.items() if not k.startswith("rule")})
        if a.pre_only:
            warnings.simplefilter("ignore")
            for name, load in files(a):
                truth, missing = load()
                doc["files"].setdefault(name, {})["pre_by_holdout"] = pre_checks(
                    np.asarray(truth, float), missing)
                print(name, doc["files"][name]["pre_by_holdout"], flush=True)
                a.out.write_text(json_text(doc, indent=1) + "\n")
        for row in doc["files"].values():  # the shipped check: single rows held back
            if "rows" in row.get("pre_by_holdout", {}):
                row["pre"] = row["pre_by_holdout"]["rows"]
        doc["runs"] = ("recover(..., n_jobs=2): adapt = exemplars=False, atoms = "
                       "preset='fast'; pre = the check (rows held back), pre_by_holdout: "
                       "rows and blocks; post: the dropped check after adapting")
        doc["replay"] = replays(doc, thresholds, margins)
        a.out.write_text(json_text(doc, indent=1) + "\n")
        if a.table:
            t, m = a.table.split(",")
            print(table(doc, int(t), float(m)))
        return
    import sparseedm

    warnings.simplefilter("ignore")
    probe = np.random.default_rng(0).normal(size=(300, 14, 2))
    sparseedm.recover(probe, np.eye(14, dtype=bool)[np.arange(300) % 14], adapt=False)
    doc = {"runs": "recover(..., n_jobs=2): adapt = exemplars=False, atoms = preset='fast'",
           "score": "per occluded pose: % body size of its hidden joints, Err_ave % of its "
                    "EDM; x_minus_y: [mean, standard error]; pre/post: held-back hidden-joint "
                    "error, % of pose size (RMS radius)", "files": {}}
    for name, load in files(a):
        truth, missing = load()
        doc["files"][name] = measure(np.asarray(truth, float), missing)
        print(name, json.dumps(doc["files"][name]), flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")
    doc["replay"] = replays(doc, thresholds, margins)
    a.out.write_text(json_text(doc, indent=1) + "\n")
    print(json.dumps(doc["replay"], indent=1))


if __name__ == "__main__":
    main()
