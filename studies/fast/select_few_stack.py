"""The stacked mean's weight on files too few complete poses for the check: chosen on probes.

Below :data:`~sparseedm.exemplars.FEW_MIN_POSES` complete poses the default
path runs no held-back check, so nothing gives the Gaussian's answer a weight
in the stacked mean (:func:`sparseedm.exemplars.linear_stack`).
:func:`sparseedm.exemplars.probe_stack` chooses it on probes of the occluded
rows instead (the donor step's: one more observed joint hidden). Compared end
to end through ``recover()``'s defaults: ``previous`` (``probe_stack`` off:
nothing stacked) against ``probe`` (what ships), II (IterativeImputer on the
same file) beside them.

Files: the validation photo files of ``benchmarks/real_people.py`` built as
``select_photo_atoms.photo_files`` builds them with C complete + M occluded
poses of the split (``--photo-sizes C+M``; the COCO val file whole: 28 + 27), ``mix`` (1-3 random hidden joints) or ``transplanted``
(real masks); mocap dataset files ``path[:dictionary]`` (C complete + M Mix
poses, ``--mocap-sizes``). Score: per occluded pose the mean error of its
hidden joints, % of body size; paired difference [mean, standard error].

    python studies/fast/select_few_stack.py --seeds 0,1,2 --out selection_few_stack.json
    python studies/fast/select_few_stack.py --seeds 0,1,2 --sources "" --mocap \\
        cmu_other_subjects.npz:cmu-k2000,daz_indian.npz --out selection_few_stack_mocap.json
    python studies/fast/select_few_stack.py --table selection_few_stack*.json
"""

from __future__ import annotations

import argparse
import contextlib
import json
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from sparseedm._atomic import json_text  # noqa: E402


@contextlib.contextmanager
def previous():
    """recover()'s and recover_file()'s default path without probe_stack."""
    import sparseedm.batch
    import sparseedm.recovery

    kept = sparseedm.recovery.probe_stack, sparseedm.batch.probe_stack

    def off(res, poses, missing, answer, blend, *a, **k):
        return res, blend

    sparseedm.recovery.probe_stack = sparseedm.batch.probe_stack = off
    try:
        yield
    finally:
        sparseedm.recovery.probe_stack, sparseedm.batch.probe_stack = kept


def files(sources, conditions, photo_sizes, mocap, mocap_sizes, seed):
    """(name, truth, missing, photo, recover() options) of the files asked for."""
    from studies.fast.select_default_exemplars import mocap_file
    from studies.fast.select_photo_atoms import photo_files

    for source in filter(None, sources.split(",")):
        # the COCO val file whole (its 55 poses: 28 + 27), the others at each size
        for c, m in [(1000, 1000)] if source == "coco" else photo_sizes:
            for name, truth, missing in photo_files(source, "val", "split", sizes=(c, m),
                                                    seed=seed):
                if any(f" {k} " in name for k in conditions):
                    yield (f"{name} {(~missing.any(1)).sum()}+{missing.any(1).sum()} "
                           f"seed {seed}", truth, missing, True, {})
    for item in filter(None, mocap.split(",")):
        path, _, dictionary = item.partition(":")
        for c, m in mocap_sizes:
            truth, missing = mocap_file(path, c, m, seed)
            yield (f"{Path(path).stem} {c}+{m} {dictionary or 'default'} seed {seed}",
                   np.asarray(truth, float), missing, False,
                   {"dictionary": dictionary} if dictionary else {})


def measure(truth, missing, photo, kw):
    """One file: per-pose errors of previous, probe and II (photos), the weight."""
    import sparseedm
    from studies.fast.select_photo_atoms import iterative
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    got = {}
    with previous():
        got["previous"] = sparseedm.recover(given, missing, n_jobs=1, **kw).poses[occ]
    t0 = time.perf_counter()
    res = sparseedm.recover(given, missing, n_jobs=1, **kw)
    seconds = round(time.perf_counter() - t0, 2)
    got["probe"] = res.poses[occ]
    if photo:
        got["iterative"] = iterative(given, missing)[occ]
    settings = res.adaptation.settings if res.adaptation is not None else {}
    weight = float(settings.get("linear_weight", np.nan))
    return seconds, weight, settings.get("linear_probes"), {
        k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


def table(docs):
    """Markdown: per file (seeds pooled), previous's, probe's and II's error."""
    rows = {}
    for doc in docs:
        for name, r in doc["files"].items():
            rows.setdefault(re.sub(r" seed \d+$", "", name), []).append(r)
    lines = ["| file | seeds | weights | previous | probe | probe - previous | II "
             "| previous / II | probe / II |", "|---|---:|---|---:|---:|---:|---:|---:|---:|"]
    for name, rs in rows.items():
        d = np.array([r["candidates"]["probe"]["minus_previous"] for r in rs])
        prev = np.mean([r["candidates"]["previous"]["mean"] for r in rs])
        new = np.mean([r["candidates"]["probe"]["mean"] for r in rs])
        ii = [r["candidates"]["iterative"]["mean"] for r in rs if "iterative" in r["candidates"]]
        w = " ".join(f"{r['weight']:g}" for r in rs)
        cells = (f"{np.mean(ii):.2f} | {prev / np.mean(ii):.3f} | {new / np.mean(ii):.3f}"
                 if ii else "- | - | -")
        lines.append(f"| {name} | {len(rs)} | {w} | {prev:.2f} | {new:.2f} | "
                     f"{d[:, 0].mean():+.2f} ± {np.sqrt((d[:, 1] ** 2).sum()) / len(d):.2f} | "
                     f"{cells} |")
    return "\n".join(lines)


def _sizes(text):
    return [tuple(int(x) for x in s.split("+")) for s in filter(None, text.split(","))]


def main(argv=None):
    from studies.fast.select_photo_blend import paired

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--sources", default="coco,mpii,bonn")
    ap.add_argument("--conditions", default="mix,transplanted")
    ap.add_argument("--photo-sizes", default="28+200,40+200")
    ap.add_argument("--mocap", default="", help="dataset files path[:dictionary], comma-separated")
    ap.add_argument("--mocap-sizes", default="30+200,40+200")
    ap.add_argument("--table", nargs="+", type=Path, help="print the pooled table, stop")
    ap.add_argument("--out", type=Path, default=Path("few_stack.json"))
    a = ap.parse_args(argv)
    if a.table:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        print(table([load_results(p) for p in a.table]))
        return
    warnings.simplefilter("ignore")
    doc = json.loads(a.out.read_text()) if a.out.exists() else {
        "score": "per occluded pose: % body size of its hidden joints; minus_previous: "
                 "[mean, standard error] paired against the path without probe_stack",
        "files": {}}
    for seed in (int(s) for s in a.seeds.split(",")):
        for name, truth, missing, photo, kw in files(
                a.sources, a.conditions.split(","), _sizes(a.photo_sizes), a.mocap,
                _sizes(a.mocap_sizes), seed):
            if name in doc["files"]:
                continue
            seconds, weight, count, errors = measure(truth, missing, photo, kw)
            doc["files"][name] = {
                "seconds": seconds, "weight": weight, "probes": count,
                "n": int(len(errors["probe"])),
                "candidates": {k: {"mean": round(float(np.nanmean(e)), 4),
                                   "minus_previous": paired(e, errors["previous"])}
                               for k, e in errors.items()}}
            print(name, seconds, weight, count, {k: v["mean"] for k, v in
                                                 doc["files"][name]["candidates"].items()},
                  doc["files"][name]["candidates"]["probe"]["minus_previous"], flush=True)
            a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
