"""The default path's file atoms on photos: mirror images, the base's atoms beside them, alpha.

``recover()``'s default path codes a file's occluded poses over its own
complete poses as the only atoms when :mod:`sparseedm.exemplars` says so
(from ``EXEMPLAR_MIN_POSES`` complete poses, or when its check on held-back
complete poses prefers them to the base dictionary with them as extra atoms).
This script measures, per validation file, what other atom sets would have
done, on the occluded poses (the test) and on the check's held-back poses
(the evidence a rule may use):

* ``atoms``: the file's complete poses (``file_dictionary``), as shipped;
* ``atoms+mirror``: the same poses and their mirror images (x reflected,
  left and right joints swapped: the same distances under swapped labels);
* ``base+atoms`` / ``base+atoms+mirror``: the shipped dictionary with them
  as extra atoms (``with_file_atoms``; the mirrored one capped at 3,000);
* ``avg(x, y)``: the mean of two candidates' filled joints;
* ``atoms+mirror a=...``: other recovery alphas of ``atoms+mirror``.

Then replays rules that choose among candidates with the check (single
held-back rows as :func:`sparseedm.exemplars.choose_exemplars` holds them back;
``check``: the guard's Mix masks; ``check_file``, added by ``--file-masks``:
the file's own missing patterns, as the package now masks them).

Files (validation only): the photo files of ``benchmarks/real_people.py``
(``--sources``; the split's occluded poses, the file's complete poses from the
source's train split with ``--complete-from train``; ``mix`` and
``transplanted`` masks), with scikit-learn's IterativeImputer on the same file
and ``recover()``'s defaults; and the validation files of
``select_exemplar_rule.py`` (``--rule-files``: held-out CMU clips, Daz
datasets, ``studies/real_prior/harness.py`` photos), where the shipped
rule's choice is replayed (where it adapts, ``recover(..., exemplars=False)`` runs).
Score: the mean over hidden joints of their error, % of body size.

    python studies/fast/select_photo_atoms.py --sources mpii,coco,bonn --out run.json
    python studies/fast/select_photo_atoms.py --replay run.json --file-masks \\
        --sources mpii,coco,bonn --out run.json
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
sys.path.insert(0, str(ROOT))  # `python studies/fast/select_photo_atoms.py` finds benchmarks/
from sparseedm._atomic import json_text  # noqa: E402

ALPHAS = (0.00025, 0.001)
#: the rule adopted (sparseedm.exemplars): the mean of three codes, checked with the
#: file's own missing patterns as the held-back masks
MEAN_RULE = "best of atoms, avg(atoms, atoms+mirror, base+atoms); margin 0.05"
CHOSEN = MEAN_RULE + "; check_file"
#: the candidates whose answers are averaged (each tuple one averaged candidate)
MEANS = (("atoms+mirror", "base+atoms"), ("atoms+mirror", "base+atoms+mirror"),
         ("atoms", "base+atoms"), ("atoms", "atoms+mirror", "base+atoms"))


def mirrored(poses):
    """`poses` and their mirror images (x reflected, left and right joints swapped)."""
    from sparseedm.skeleton import SKELETON_14

    flip = poses[:, SKELETON_14.flip_permutation()] * np.array([-1.0, 1.0])
    return np.concatenate([poses, flip])


def dictionaries(base, complete, more=False):
    """{candidate: (dictionary, alpha)} built from the complete poses `complete`;
    `more`: also the base with the mirrored atoms and other alphas."""
    from sparseedm.file_atoms import FAST_ALPHA, MAX_FAST_ATOMS, file_dictionary, with_file_atoms

    both = mirrored(complete)
    out = {"atoms": (file_dictionary(base, complete).dictionary, FAST_ALPHA),
           "atoms+mirror": (file_dictionary(base, both).dictionary, FAST_ALPHA),
           "base+atoms": (with_file_atoms(base, complete).dictionary, None)}
    if more:
        out["base+atoms+mirror"] = (with_file_atoms(base, both, max_atoms=MAX_FAST_ATOMS)
                                    .dictionary, None)
        for a in ALPHAS:
            out[f"atoms+mirror a={a}"] = (out["atoms+mirror"][0], a)
    return out


def fills(base, complete, given, missing, more=False):
    """{candidate: filled poses} of the rows `given` under `missing`."""
    import sparseedm
    from sparseedm.solvers import FastSolver

    out = {}
    for name, (d, alpha) in dictionaries(base, complete, more).items():
        own = d.n_components < base.n_components  # file atoms only: working sets
        solver = FastSolver(working_set=True, numpy_max=0) if own else "fast"
        out[name] = sparseedm.recover(given, missing, dictionary=d, alpha=alpha, adapt=False,
                                      solver=solver, n_jobs=2).poses
    for names in MEANS:
        if all(n in out for n in names):
            out[f"avg({', '.join(names)})"] = np.mean([out[n] for n in names], axis=0)
    return out


def check(base, complete, seed=0, more=False, pool=None):
    """The check's evidence for every candidate: hidden-joint error (% of pose size,
    as :func:`sparseedm.exemplars.hidden_joint_error`) on held-back complete poses
    (single rows, 20 %, at most 300) coded over the other complete poses; hidden by
    the guard's Mix masks, or with `pool` (the file's missing patterns) by patterns
    drawn from it."""
    from sparseedm.adaptation import GUARD_POSES_PER_PATTERN, guard_masks
    from sparseedm.exemplars import HELD_FRACTION, MAX_HELD
    from sparseedm.normalize import rms_radius
    from sparseedm.real_protocol import transplant_masks

    n = len(complete)
    held = np.zeros(n, bool)
    want = min(int(round(HELD_FRACTION * n)), MAX_HELD)
    held[np.random.default_rng([seed, 43]).choice(n, want, replace=False)] = True
    truth = complete[held]
    if pool is None:
        mask = guard_masks(len(truth), 14, max(1, len(truth) // GUARD_POSES_PER_PATTERN), seed)
    else:
        mask = transplant_masks(len(truth), pool, random_state=np.random.default_rng(
            [seed, 44]))[0]
    got = fills(base, complete[~held], np.where(mask[..., None], np.nan, truth), mask, more)
    _, size = rms_radius(truth, np.zeros(mask.shape, bool))
    out = {}
    for name, filled in got.items():
        err = np.linalg.norm(filled - truth, axis=-1) / size[:, None] * 100
        out[name] = round(float(np.nanmean(np.nanmean(np.where(mask, err, np.nan), axis=1))),
                          4)
    return out


def hidden(filled, truth, missing):
    """Per hidden joint: its error, % of body size."""
    from sparseedm.real_protocol import body_size, hidden_errors

    return hidden_errors(filled, truth, missing, body_size(truth)).error


def measure(base, truth, missing, extra=(), more=False):
    """One file: each candidate's test error (mean over hidden joints, % body) and the
    check's held-back errors; `extra` {name: fill(given, missing)} run on the whole file."""
    occ = missing.any(axis=1)
    complete = truth[~occ]
    given = np.where(missing[..., None], np.nan, truth)
    row = {"complete": int(len(complete)), "occluded": int(occ.sum()), "test": {},
           "seconds": {}}
    t0 = time.perf_counter()
    got = fills(base, complete, given[occ], missing[occ], more)
    row["seconds"]["candidates"] = round(time.perf_counter() - t0, 1)
    for name, fill in extra:
        t0 = time.perf_counter()
        got[name] = fill(given, missing)[occ]
        row["seconds"][name] = round(time.perf_counter() - t0, 1)
    for name, filled in got.items():
        e = hidden(filled, truth[occ], missing[occ])
        row["test"][name] = round(float(np.nanmean(e)), 4)
    t0 = time.perf_counter()
    row["check"] = check(base, complete, more=more) if len(complete) >= 250 else {}
    row["seconds"]["check"] = round(time.perf_counter() - t0, 1)
    if replay(row, "shipped", None)[0] in ("adapt", "too few"):  # the shipped default path
        t0 = time.perf_counter()
        filled = adapt(given, missing)[occ]
        row["seconds"]["adapt"] = round(time.perf_counter() - t0, 1)
        row["test"]["adapt"] = round(float(np.nanmean(hidden(filled, truth[occ], missing[occ]))),
                                     4)
    return row


def adapt(given, missing):
    """The default path without the exemplar rule (what the shipped rule does when
    its check declines the exemplars, or below 250 complete poses)."""
    import sparseedm

    return sparseedm.recover(given, missing, exemplars=False, n_jobs=2).poses


def iterative(given, missing):
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer

    X = np.where(missing[..., None], np.nan, given).reshape(len(given), -1)
    return IterativeImputer(max_iter=10, tol=0, random_state=0).fit_transform(X).reshape(
        given.shape)


def photo_files(sources, part, complete_from, sizes=(1000, 1000), seed=0):
    """(name, truth, missing) of benchmarks/real_people.py's photo files: the split's
    occluded poses under mix and transplanted masks, C complete poses first (as
    :func:`sparseedm.evaluation_real.evaluate_photos` draws them)."""
    from benchmarks import real2d
    from sparseedm.metrics import occlusion_masks
    from sparseedm.real_protocol import transplant_masks

    for source in filter(None, sources.split(",")):
        rs = real2d.load(source)
        parts = real2d.split(rs)
        s = rs.take(parts == part)
        poses = s.poses[s.complete]
        t = rs.take(parts == complete_from) if complete_from != "split" else None
        rng = np.random.default_rng([seed, 3])
        if t is None:
            c, m = sizes
            if c + m > len(poses):
                c = int(round(len(poses) * c / (c + m)))
                m = len(poses) - c
            order = rng.permutation(len(poses))
            kept, occ = poses[order[:c]], order[c:c + m]
        else:
            other = t.poses[t.complete]
            kept = other[rng.permutation(len(other))[:min(sizes[0], len(other))]]
            occ = rng.permutation(len(poses))[:min(sizes[1], len(poses))]
        m = len(occ)
        masks = {"mix": occlusion_masks(m, 14, ("mix",), seed)["mix"],
                 "transplanted": transplant_masks(m, ~s.visible, random_state=np.random.
                                                  default_rng([seed, 7]))[0]}
        for cond, mask in masks.items():
            truth = np.concatenate([kept, poses[occ]])
            missing = np.concatenate([np.zeros((len(kept), 14), bool), mask])
            yield f"{source} {cond} ({len(kept)} complete from {complete_from})", truth, missing


def file_mask_checks(doc, a):
    """Each file of `doc` (re-made as asked in `a`) gets ``check_file``: the check
    with the file's own missing patterns as masks; `doc` written to ``a.out``."""
    import sparseedm

    warnings.simplefilter("ignore")
    base = sparseedm.load_dictionary()
    made = list(photo_files(a.sources, "val", a.complete_from))
    made += list(rule_files(a)) if a.rule_files else []
    for name, truth, missing in made:
        row = doc["files"].get(name)
        occ = missing.any(axis=1)
        if row is None or row["complete"] < 250:
            continue
        row["check_file"] = check(base, truth[~occ], more=a.more, pool=missing[occ])
        print(name, row["check_file"], flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")


def rule_files(a):
    """(name, truth, missing) of select_exemplar_rule.py's validation files."""
    from studies.fast.select_default_exemplars import files

    for name, load in files(a):
        truth, missing = load()
        yield name, np.asarray(truth, float), missing


def rules():
    """{rule: (own candidates, the check's rival, margin)}: from 2,000 complete poses
    the first own candidate; below, the check takes the own candidate of lowest
    held-back error unless the rival's is lower than it by more than the margin,
    then the file adapts. "shipped" is the rule before this study."""
    out = {"shipped": (("atoms",), "base+atoms", 0.05)}
    for atoms in ("atoms+mirror", "atoms+mirror a=0.00025", "atoms+mirror a=0.001"):
        out[f"{atoms} vs base+atoms"] = ((atoms,), "base+atoms", 0.05)
    out["atoms+mirror vs base+atoms+mirror"] = (("atoms+mirror",), "base+atoms+mirror", 0.05)
    for names in MEANS:
        rival = names[-1]
        for margin in (0.0, 0.05):
            out[f"best of atoms, avg({', '.join(names)}); margin {margin}"] = (
                ("atoms", f"avg({', '.join(names)})"), rival, margin)
    for key in ("check_file", "both checks"):
        out[f"{MEAN_RULE}; {key}"] = (*out[MEAN_RULE], key)
    return out


def replay(row, rule, adapt):
    """(what the rule does on the file, its test error); `adapt`: the error of the
    default path without the rule (None: unknown)."""
    own, rival, margin, *key = rules()[rule]
    key = key[0] if key else "check"
    n = row["complete"]
    if any(c not in row["test"] for c in (*own, rival)) or (
            n >= 250 and key != "check" and "check_file" not in row):
        return "not measured", None
    if n < 250:
        return "too few", adapt
    if n >= 2000:
        return own[0], row["test"][own[0]]
    if key == "both checks":  # the two checks' errors added
        chk = {c: row["check"][c] + row["check_file"][c] for c in row["check"]}
    else:
        chk = row[key]
    best = min(own, key=lambda c: chk[c])  # ties: the first, the cheaper
    if chk[best] <= (1 + margin) * chk[rival]:
        return best, row["test"][best]
    return "adapt", adapt


def summary(doc):
    """Markdown: per file, the candidates' test errors, and each rule's choice."""
    names = list(doc["files"])
    cands = list(next(iter(doc["files"].values()))["test"])
    lines = ["| file | complete | " + " | ".join(cands) + " |",
             "|---|---:|" + "---:|" * len(cands)]
    for name in names:
        r = doc["files"][name]
        lines.append(f"| {name} | {r['complete']:,} | " + " | ".join(
            f"{r['test'].get(c, float('nan')):.2f}"
            + (f" ({r['check'][c]:.2f})" if c in r.get("check", {}) else "")
            for c in cands) + " |")
    lines += ["", "| rule | " + " | ".join(names) + " | mean change |",
              "|---|" + "---|" * (len(names) + 1)]
    for rule in rules():
        cells, diffs = [], []
        for name in names:
            r = doc["files"][name]
            adapt = r["test"].get("adapt")  # where the shipped rule adapts
            branch, err = replay(r, rule, adapt)
            _, base = replay(r, "shipped", adapt)
            cells.append(f"{err:.2f} {branch}" if err is not None else branch)
            if branch == "not measured":
                continue
            if err is not None and base is not None:
                diffs.append(err - base)
        if diffs:  # a rule whose candidates were measured
            change = f"{np.mean(diffs):+.3f} (worst {max(diffs):+.3f})"
            lines.append(f"| {rule} | " + " | ".join(cells) + f" | {change} |")
    return "\n".join(lines)


def compare(doc, rule):
    """Markdown: per file, what the shipped rule and `rule` do and their test errors
    (and IterativeImputer's on the photo files)."""
    lines = ["| file | complete | shipped rule | this rule | change | IterativeImputer | "
             "check: atoms / base+atoms / mean |", "|---|---:|---|---|---:|---:|---|"]
    for name, r in doc["files"].items():
        adapt = r["test"].get("adapt")
        (b0, e0), (b1, e1) = replay(r, "shipped", adapt), replay(r, rule, adapt)
        if e0 is None or e1 is None:
            continue
        own, _, _, *key = rules()[rule]
        c, own = r.get(key[0] if key and key[0] != "both checks" else "check") or {}, own[-1]
        chk = (f"{c['atoms']:.2f} / {c['base+atoms']:.2f} / {c[own]:.2f}" if c else "")
        it = r["test"].get("iterative")
        lines.append(f"| {name} | {r['complete']:,} | {e0:.2f} ({b0}) | {e1:.2f} ({b1}) | "
                     f"{e1 - e0:+.2f} | {'' if it is None else f'{it:.2f}'} | {chk} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sources", default="mpii,coco,bonn",
                    help="photo sources of benchmarks/real_people.py ('' for none)")
    ap.add_argument("--complete-from", default="train", choices=("train", "split"),
                    help="the photo files' complete poses: the train split or the val split")
    ap.add_argument("--rule-files", action="store_true",
                    help="also select_exemplar_rule.py's validation files")
    ap.add_argument("--cmu", default="2000,3000,4000", help="with --rule-files: CMU sizes")
    ap.add_argument("--seeds", default="0,1", help="with --rule-files: CMU seeds")
    ap.add_argument("--mocap", default="", help="with --rule-files: dataset .npz paths")
    ap.add_argument("--mocap-sizes", default="500+500,1000+1000,1500+1500,2500+2500")
    ap.add_argument("--photos", default="bonn,mpii-large",
                    help="with --rule-files: studies/real_prior/harness.py files")
    ap.add_argument("--protocols", default="2,real")
    ap.add_argument("--more", action="store_true",
                    help="also the base with the mirrored atoms, and atoms+mirror at the "
                    f"recovery alphas {ALPHAS}")
    ap.add_argument("--file-masks", action="store_true",
                    help="with --replay: add to each file the check with its own missing "
                    "patterns as the held-back masks (check_file), written to --out")
    ap.add_argument("--replay", nargs="+", type=Path, metavar="JSON",
                    help="only print the tables of these result files (merged), no runs")
    ap.add_argument("--table", default=CHOSEN, metavar="RULE",
                    help="the rule compared with the shipped one file by file "
                    f"(default {CHOSEN!r})")
    ap.add_argument("--out", type=Path,
                    default=Path(__file__).with_name("selection_photo_atoms.json"))
    a = ap.parse_args(argv)
    if a.replay:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        doc = {"files": {}}
        for path in a.replay:
            doc["files"].update(load_results(path)["files"])
        if a.file_masks:
            file_mask_checks(doc, a)
        print(summary(doc), compare(doc, a.table), sep="\n\n")
        return
    import sparseedm

    warnings.simplefilter("ignore")
    base = sparseedm.load_dictionary()
    doc = {"score": "test: mean over the occluded poses' hidden joints of their error, % of "
                    "body size; check: held-back complete poses' hidden-joint error, % of "
                    "pose size (RMS radius)", "files": {}}
    todo = list(photo_files(a.sources, "val", a.complete_from))
    extra = (("iterative", iterative),)
    todo = [(n, t, m, extra) for n, t, m in todo]  # IterativeImputer on the photo files
    if a.rule_files:
        todo += [(n, t, m, ()) for n, t, m in rule_files(a)]
    for name, truth, missing, extra in todo:
        doc["files"][name] = measure(base, truth, missing, extra, a.more)
        print(name, json.dumps(doc["files"][name]), flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")
    print(summary(doc), compare(doc, a.table), sep="\n\n")


if __name__ == "__main__":
    main()
